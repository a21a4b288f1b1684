//! Criterion benchmark of the speed-for-accuracy variants, for development: the evaluation
//! variants `lobe tradeoff` measures (f32 GPU vs f64 CPU, Schlick vs exact Fresnel, rational vs
//! exact Beckmann G1, V-cavity vs Smith; fast vs careful pow for Phong) on one table each.
//! `cargo bench --bench tradeoff`; `lobe tradeoff` measures the same, with their errors, for users.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lobe::gpu::{Device, DeviceOptions, Gpu};
use lobe::grid::Grid;
use lobe::tradeoff::{eval_variants, variant_table};
use lobe::Evaluator;

/// 0.5e6 evaluations per iteration.
const GRID: Grid = Grid::Isotropic {
    n_theta_i: 64,
    n_theta_o: 64,
    n_dphi: 128,
};

fn variants(c: &mut Criterion) {
    let dev = Device::open(&DeviceOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let gpu = Gpu::new(dev);
    let gpu = Evaluator::gpu(&gpu);
    for (model, sets) in [
        ("cook_torrance", vec![]),
        ("phong", vec!["shininess=8192".to_string()]),
    ] {
        let params = lobe::resolve_params(model, None, &sets).expect("parameters");
        let (_, variants) = eval_variants(&params, None);
        let mut group = c.benchmark_group(format!("tradeoff_{model}"));
        group.throughput(Throughput::Elements(GRID.cells().unwrap()));
        group.sample_size(10);
        for v in &variants {
            group.bench_function(v.name.as_str(), |b| {
                b.iter(|| variant_table(Some(&gpu), v, &GRID).expect("variant"))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, variants);
criterion_main!(benches);
