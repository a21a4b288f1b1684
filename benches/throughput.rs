//! Evaluation throughput per model on this machine: the GPU table kernel (f32, Vulkan) and the
//! CPU reference (f64, all cores), over the same isotropic grid, with the output discarded.
//! `cargo bench --bench throughput`. GPU and CPU runs never overlap (PLATFORM.md: running rayon
//! work and lavapipe at once slows both).

use lobe::gpu::{Device, DeviceOptions, Gpu};
use lobe::grid::Grid;
use lobe::model::{Model, ParamSet};
use lobe::Evaluator;
use std::time::Instant;

/// 1.6e7 evaluations per run: long enough to dwarf dispatch overhead on lavapipe.
const GRID: Grid = Grid::Isotropic {
    n_theta_i: 200,
    n_theta_o: 200,
    n_dphi: 400,
};
const REPEATS: usize = 5;

fn median_rate(e: &Evaluator, p: &ParamSet) -> f64 {
    let cells = GRID.cells().unwrap() as f64;
    let mut rates: Vec<f64> = (0..REPEATS)
        .map(|_| {
            let t = Instant::now();
            e.eval_table(p, false, &GRID, &mut |_, v| {
                std::hint::black_box(v);
                Ok(())
            })
            .expect("evaluation");
            cells / t.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    rates[REPEATS / 2]
}

fn main() {
    let dev = Device::open(&DeviceOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let gpu = Gpu::new(&dev);
    let evaluators = [Evaluator::Gpu(&gpu), Evaluator::Cpu];
    println!(
        "evaluations per second, median of {REPEATS} runs of {} cells",
        GRID.cells().unwrap()
    );
    println!(
        "{:<18} {:>22} {:>22} {:>8}",
        "model",
        evaluators[0].name(),
        "cpu f64",
        "ratio"
    );
    for model in Model::ALL {
        let p = ParamSet::defaults(model);
        let g = median_rate(&evaluators[0], &p);
        let c = median_rate(&evaluators[1], &p);
        println!(
            "{:<18} {:>20.1} M {:>20.1} M {:>8.2}",
            model.name(),
            g / 1e6,
            c / 1e6,
            g / c
        );
    }
}
