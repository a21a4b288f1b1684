//! Criterion benchmark of evaluation throughput per model, for development: the GPU table kernel
//! (f32, Vulkan) and the CPU reference (f64, all cores) over the same isotropic grid, output
//! discarded. `cargo bench --bench throughput`; `lobe bench` measures the same for users.
//! GPU and CPU groups run one after the other, never at once (PLATFORM.md: rayon work and
//! lavapipe slow each other down).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lobe::gpu::{Device, DeviceOptions, Gpu};
use lobe::grid::Grid;
use lobe::model::{Model, ParamSet};
use lobe::Evaluator;

/// 1.0e6 evaluations per iteration: long enough to dwarf a submit on lavapipe.
const GRID: Grid = Grid::Isotropic {
    n_theta_i: 64,
    n_theta_o: 64,
    n_dphi: 256,
};

fn eval(e: &Evaluator, p: &ParamSet) {
    e.eval_table(p, false, &GRID, &mut |_, v| {
        std::hint::black_box(v);
        Ok(())
    })
    .expect("evaluation");
}

fn throughput(c: &mut Criterion) {
    let dev = Device::open(&DeviceOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let gpu = Gpu::new(&dev);
    for (name, e) in [("gpu", Evaluator::Gpu(&gpu)), ("cpu_f64", Evaluator::Cpu)] {
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

criterion_group!(benches, throughput);
criterion_main!(benches);
