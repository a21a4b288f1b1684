//! The table kernel (glsl/kernels/table.comp) is shaped for throughput: several cells per
//! invocation, a wrap from one light direction to the next inside an invocation, texel-buffer
//! direction lists on CPU drivers, vec4 stores, padded last invocations, double-buffered chunks
//! and inputs in buffers kept from one table to the next.
//! None of that may change a value: every cell must be bit-identical to evaluating its (ωi, ωo)
//! pair alone, which the pairs kernel does (one pair per evaluation, the same `brdf()` on the
//! same f32 directions).

mod common;

use lobe::gpu::{Gpu, GpuPair};
use lobe::grid::Grid;
use lobe::model::{Brdf, Model, ParamSet};
use lobe::Evaluator;

fn f32x3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The table on `grid` by the table kernel, and cell by cell by the pairs kernel, as bits.
fn both(gpu: &Gpu, params: &ParamSet, grid: &Grid) -> (Vec<u32>, Vec<u32>) {
    let mut table = Vec::new();
    Evaluator::gpu(gpu)
        .eval_table(params, grid, &mut |first, v| {
            assert_eq!(first as usize * 3, table.len(), "chunks arrive in order");
            table.extend(v.iter().map(|x| x.to_bits()));
            Ok(())
        })
        .expect("table");
    let (wi, wo) = (grid.wi_list(), grid.wo_list());
    let pairs: Vec<GpuPair> = wi
        .iter()
        .flat_map(|&i| {
            wo.iter().map(move |&o| GpuPair {
                wi: f32x3(i),
                param_index: 0,
                wo: f32x3(o),
                pad: 0,
            })
        })
        .collect();
    let block = Brdf::new(params).gpu_block();
    let single = gpu
        .eval_pairs(params.model(), &[block], &pairs, false)
        .expect("pairs");
    let single = single.iter().flatten().map(|x| x.to_bits()).collect();
    (table, single)
}

fn first_difference(a: &[u32], b: &[u32]) -> Option<usize> {
    a.iter().zip(b).position(|(x, y)| x != y)
}

/// Every model on small grids with odd list lengths (rows end inside an invocation and the
/// last invocation is padded) and with rows of 64 and 32 view cells (on a CPU driver as many
/// evaluations per invocation, rows aligned, interleaved where the model and driver are).
fn every_cell_of_every_model(gpu: &Gpu) {
    let grids = [
        Grid::parse("isotropic", "7,5,9").unwrap(),
        Grid::parse("full", "3,5,7,3").unwrap(),
        Grid::parse("isotropic", "3,2,32").unwrap(),
        Grid::parse("full", "2,3,4,8").unwrap(),
    ];
    for model in Model::ALL {
        let params = ParamSet::defaults(model);
        for grid in &grids {
            if grid.needs_isotropy() && !params.is_isotropic() {
                continue;
            }
            let (table, single) = both(gpu, &params, grid);
            assert_eq!(table.len(), single.len());
            assert_eq!(
                first_difference(&table, &single),
                None,
                "{} on {grid:?}: a table cell differs from its pair",
                model.name()
            );
        }
    }
}

#[test]
fn every_cell_equals_its_pair_evaluated_alone() {
    common::on_gpu(
        "every_cell_equals_its_pair_evaluated_alone",
        false,
        every_cell_of_every_model,
    );
}

/// The same with a GPU's kernel choices (4 cells per invocation, storage-buffer direction
/// lists), which a CPU driver would otherwise never run.
#[test]
fn with_a_gpus_kernel_choices_every_cell_equals_its_pair() {
    common::on_gpu(
        "with_a_gpus_kernel_choices_every_cell_equals_its_pair",
        true,
        every_cell_of_every_model,
    );
}

#[test]
fn a_table_of_several_chunks_equals_its_pairs() {
    let Some(dev) = common::gpu_device("a_table_of_several_chunks_equals_its_pairs") else {
        return;
    };
    // 1.1e6 cells: 13 MB of output in 1 MiB chunks, so both output buffers take turns.
    let gpu = Gpu::new(dev).with_table_chunk_bytes(1 << 20);
    let grid = Grid::parse("isotropic", "67,63,263").unwrap();
    let params = lobe::resolve_params(
        "microfacet",
        Some("gold"),
        &["distribution=beckmann".into(), "fresnel=conductor".into()],
    )
    .unwrap();
    // The runner keeps its buffers (outputs, parameter block, direction lists) from one table
    // to the next: a small table first, then the big one, which makes every buffer larger;
    // then the small table in the big one's buffers, which still hold the big table's lists and
    // values, and the big table again in them.
    let small = Grid::parse("isotropic", "7,5,9").unwrap();
    let (small_first, _) = both(&gpu, &params, &small);
    let (table, single) = both(&gpu, &params, &grid);
    assert_eq!(table.len(), single.len());
    assert_eq!(first_difference(&table, &single), None);
    let (small_table, small_single) = both(&gpu, &params, &small);
    assert_eq!(small_table.len(), small_single.len());
    assert_eq!(first_difference(&small_table, &small_single), None);
    assert_eq!(first_difference(&small_table, &small_first), None);
    let (again, _) = both(&gpu, &params, &grid);
    assert_eq!(first_difference(&again, &table), None);
    assert_eq!(again.len(), table.len());
    common::assert_validation_clean(&gpu, "a_table_of_several_chunks_equals_its_pairs");
}
