//! Criterion benchmark of evaluation throughput per model, for development: the GPU table kernel
//! (f32, Vulkan) and the CPU reference (f64, all cores) over the same isotropic grid, output
//! discarded; and albedo integration (the GPU reduction kernel, f64 sums on the CPU) with
//! `lobe bench`'s rule and view directions; and a GGX white-furnace albedo LUT as `lobe bench
//! --tasks lut` times it (32 × 32 cells, the peak rule at 32768 nodes per direction). `cargo bench --bench throughput`; `lobe bench`
//! measures the same for users.
//! GPU and CPU groups run one after the other, never at once (PLATFORM.md: rayon work and
//! lavapipe slow each other down).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lobe::gpu::{Device, DeviceOptions, Gpu};
use lobe::grid::Grid;
use lobe::model::{Model, ParamSet};
use lobe::Evaluator;
use lobe::Query;

/// 1.0e6 evaluations per iteration: long enough to dwarf a submit on lavapipe.
const GRID: Grid = Grid::Isotropic {
    n_theta_i: 64,
    n_theta_o: 64,
    n_dphi: 256,
};

fn eval(e: &Evaluator, p: &ParamSet) {
    e.eval_table(p, &GRID, &mut |_, v| {
        std::hint::black_box(v);
        Ok(())
    })
    .expect("evaluation");
}

fn throughput(c: &mut Criterion) {
    let dev = Device::open(&DeviceOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let gpu = Gpu::new(dev);
    for (name, e) in [("gpu", Evaluator::gpu(&gpu)), ("cpu_f64", Evaluator::cpu())] {
        let mut group = c.benchmark_group(format!("table_{name}"));
        group.throughput(Throughput::Elements(GRID.cells().unwrap()));
        group.sample_size(10);
        for model in Model::ALL {
            let p = ParamSet::defaults(model);
            group.bench_function(model.name(), |b| b.iter(|| eval(&e, &p)));
        }
        group.finish();
    }
}

fn albedo_throughput(c: &mut Criterion) {
    use lobe::bench::{ALBEDO_DIRECTIONS, ALBEDO_RULE};
    use lobe::integrate::{rule_albedo, view_direction};
    let dev = Device::open(&DeviceOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let gpu = Gpu::new(dev);
    let wo: Vec<glam::DVec3> = (0..ALBEDO_DIRECTIONS)
        .map(|k| view_direction((k as f64 + 1.0) / ALBEDO_DIRECTIONS as f64, 0.0))
        .collect();
    let per_direction = ALBEDO_RULE.nodes(glam::DVec3::Z).len()
        + ALBEDO_RULE.coarse().nodes(glam::DVec3::Z).len()
        + ALBEDO_RULE.coarse().coarse().nodes(glam::DVec3::Z).len();
    for (name, e) in [("gpu", Evaluator::gpu(&gpu)), ("cpu_f64", Evaluator::cpu())] {
        let mut group = c.benchmark_group(format!("albedo_{name}"));
        group.throughput(Throughput::Elements((per_direction * wo.len()) as u64));
        group.sample_size(10);
        for model in Model::ALL {
            let p = ParamSet::defaults(model);
            group.bench_function(model.name(), |b| {
                b.iter(|| rule_albedo(&e, &p, ALBEDO_RULE, &wo).expect("albedo"))
            });
        }
        group.finish();
    }
}

fn lut_throughput(c: &mut Criterion) {
    use lobe::bench::{lut_evaluations, lut_spec};
    let dev = Device::open(&DeviceOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let gpu = Gpu::new(dev);
    let params = lobe::resolve_params("microfacet", None, &[]).expect("microfacet");
    let spec = lut_spec(Query::one(&params).with_white_furnace(true));
    let evaluations = lut_evaluations(&spec).expect("LUT spec");
    for (name, e) in [("gpu", Evaluator::gpu(&gpu)), ("cpu_f64", Evaluator::cpu())] {
        let mut group = c.benchmark_group(format!("lut_{name}"));
        group.throughput(Throughput::Elements(evaluations));
        // Seconds per LUT on lavapipe: criterion's fewest samples.
        group.sample_size(10);
        group.bench_function("microfacet_white_furnace", |b| {
            b.iter(|| lobe::lut::compute(&e, &spec, &mut |_, _| {}).expect("LUT"))
        });
        group.finish();
    }
}

criterion_group!(benches, throughput, albedo_throughput, lut_throughput);
criterion_main!(benches);
