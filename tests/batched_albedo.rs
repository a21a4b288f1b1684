//! A LUT's rows are integrated together (`integrate::albedo_rows`): each direction's nodes are
//! made once for all rows and the GPU sums every row in the same dispatches. That must change no
//! value: the same f32 partial sums, added in the same order, as row by row.

mod common;

use lobe::gpu::Gpu;
use lobe::integrate::{albedo_rows, directional, hemispherical, Method, Settings};
use lobe::model::ParamSet;
use lobe::Evaluator;

/// Rows of a GGX LUT under the white furnace, and the directions of a small LUT.
fn rows() -> Vec<ParamSet> {
    [0.05, 0.3, 0.9]
        .iter()
        .map(|a| lobe::resolve_params("microfacet", None, &[format!("alpha={a}")]).unwrap())
        .collect()
}

const POINTS: [(f64, f64); 3] = [(0.1, 0.0), (0.5, 0.0), (1.0, 0.0)];

fn settings() -> Settings {
    Settings {
        method: Method::Peak,
        samples: 4096,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: true,
    }
}

#[test]
fn gpu_rows_together_equal_rows_one_by_one() {
    let Some(dev) = common::gpu_device("gpu_rows_together_equal_rows_one_by_one") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let eval = Evaluator::gpu(&gpu);
    let s = settings();
    let together = albedo_rows(&eval, &rows(), &s, &POINTS, Some(0.0)).unwrap();
    for (p, (dir, hemi)) in rows().iter().zip(together) {
        assert_eq!(dir, directional(&eval, p, &s, &POINTS).unwrap());
        assert_eq!(hemi, Some(hemispherical(&eval, p, &s, 0.0).unwrap()));
    }
    common::assert_validation_clean(&gpu, "gpu_rows_together_equal_rows_one_by_one");
}

/// The CPU adds each sum in parallel chunks whose grouping rayon chooses: equal to f64
/// rounding of sums of ~1e4 terms of size ≤ 1.
const CPU_SUM_TOLERANCE: f64 = 1e-12;

#[test]
fn cpu_rows_together_equal_rows_one_by_one() {
    let eval = Evaluator::cpu();
    let s = settings();
    let together = albedo_rows(&eval, &rows(), &s, &POINTS, Some(0.0)).unwrap();
    for (p, (dir, hemi)) in rows().iter().zip(together) {
        for (a, b) in dir.iter().zip(directional(&eval, p, &s, &POINTS).unwrap()) {
            assert!((a.albedo - b.albedo).abs().max_element() < CPU_SUM_TOLERANCE);
        }
        let h = hemispherical(&eval, p, &s, 0.0).unwrap();
        assert!((hemi.unwrap().e_avg - h.e_avg).abs().max_element() < CPU_SUM_TOLERANCE);
    }
}
