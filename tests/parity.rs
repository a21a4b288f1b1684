//! GPU (f32, Vulkan) vs CPU reference (f64) parity for every model, at every material preset and
//! at 200 random valid parameter sets each, over a dense set of direction pairs that includes
//! near-grazing (θ up to 89.9°) and near-mirror configurations.
//!
//! Both sides see the same inputs: the GPU receives f32 directions and parameters, and the CPU
//! evaluates at exactly those values widened to f64. What remains is the error of evaluating
//! the formula in f32 with GLSL's built-ins, which the tolerance model of lobe::tolerance (docs/design.md §10) bounds.

mod common;

use glam::DVec3;
use lobe::gpu::{Gpu, GpuPair};
use lobe::grid::direction;
use lobe::model::microfacet::MicrofacetConfig;
use lobe::model::{Brdf, Model, ParamKind, ParamSet, Reference, Value};
use lobe::tolerance::{self, ATOL, EPS32};
use lobe::{material, resolve_params};
use std::f64::consts::{FRAC_PI_2, PI};

/// Random parameter sets per model.
const RANDOM_SETS: usize = 200;
/// Random direction pairs per parameter set, on top of the structured ones.
const RANDOM_PAIRS: usize = 160;
/// Random parameter sets per microfacet component combination (96 combinations, half of them
/// with the Kulla–Conty lobe, which reads its table from the model data binding).
const MICROFACET_SETS: usize = 24;

// The tolerance model, with the reason for each term, is lobe::tolerance (docs/design.md §10):
// the same one `lobe stability` and the demo report against.
fn random_params(model: Model, rng: &mut common::Rng) -> ParamSet {
    let mut p = ParamSet::defaults(model);
    for spec in model.params() {
        let v = match (spec.kind, spec.key) {
            // Component choices are part of the model (its pipeline): keep them.
            (ParamKind::Choice(_), _) => continue,
            // Parameters whose absence means something: set them half of the time.
            (_, "alpha_x" | "alpha_y" | "f0") if rng.uniform() < 0.5 => continue,
            (_, "alpha" | "alpha_x" | "alpha_y") => Value::One(rng.log_range(0.01, 1.0)),
            (ParamKind::Rgb, _) => {
                Value::Three([0; 3].map(|_| rng.range(spec.min, spec.max.min(8.0))))
            }
            // Exponents span decades: sample log-uniformly up to the lab report's largest, 8192,
            // and include 0 now and then.
            (_, "shininess" | "nu" | "nv") => Value::One(if rng.uniform() < 0.05 {
                0.0
            } else {
                rng.log_range(0.1, 8192.0)
            }),
            (_, "roughness") => Value::One(rng.log_range(0.01, 1.0)),
            _ => Value::One(rng.range(spec.min, spec.max)),
        };
        p.set(spec.key, v)
            .unwrap_or_else(|e| panic!("random {}: {e}", model.name()));
    }
    p
}

/// Rounds a direction to f32 as the GPU receives it, and returns it widened back.
fn as_f32(v: DVec3) -> DVec3 {
    DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64)
}

fn direction_pairs(rng: &mut common::Rng) -> Vec<(DVec3, DVec3)> {
    let deg = |d: f64| d.to_radians();
    let mut pairs = Vec::new();
    // Structured: normal incidence, grazing, and the mirror configuration at several elevations.
    for ti in [0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9] {
        for (to, dphi) in [
            (ti, 180.0),
            (ti, 0.0),
            (ti, 90.0),
            (89.9, 180.0),
            (0.0, 0.0),
            (45.0, 135.0),
        ] {
            pairs.push((
                direction(deg(ti), deg(20.0)),
                direction(deg(to), deg(20.0 + dphi)),
            ));
        }
    }
    for _ in 0..RANDOM_PAIRS {
        let kind = rng.uniform();
        let ti = if kind < 0.3 {
            rng.range(deg(80.0), deg(89.9))
        } else {
            rng.range(0.0, deg(89.9))
        };
        let pi = rng.range(0.0, 2.0 * PI);
        let wi = direction(ti, pi);
        let wo = if kind < 0.6 {
            // Near the mirror direction: within 2° of it, where the specular lobes peak.
            let to = (ti + rng.range(-deg(2.0), deg(2.0))).clamp(0.0, deg(89.9));
            direction(to, pi + PI + rng.range(-deg(2.0), deg(2.0)))
        } else {
            direction(rng.range(0.0, deg(89.9)), rng.range(0.0, 2.0 * PI))
        };
        pairs.push((wi, wo));
    }
    pairs.push((DVec3::Z, DVec3::Z));
    pairs
        .into_iter()
        .map(|(a, b)| (as_f32(a), as_f32(b)))
        .collect()
}

/// The worst case by two measures: closest to its tolerance, and largest relative error.
struct Worst {
    ratio: f64,
    text: String,
    rel: f64,
    rel_text: String,
}

#[test]
fn gpu_matches_cpu_reference_for_every_model() {
    let Some(dev) = common::gpu_device("parity") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let mut rng = common::Rng(0x10be_2026);
    let mut failures = Vec::new();
    let mut summary = Vec::new();
    for model in Model::ALL {
        let mut sets: Vec<(String, ParamSet)> = material::names()
            .into_iter()
            .map(|m| (format!("material {m}"), material::preset(m, model).unwrap()))
            .collect();
        sets.push(("defaults".into(), ParamSet::defaults(model)));
        for k in 0..RANDOM_SETS {
            sets.push((format!("random #{k}"), random_params(model, &mut rng)));
        }
        // A preset may choose other components (another pipeline): one comparison per model.
        let mut models: Vec<Model> = sets.iter().map(|(_, p)| p.model()).collect();
        models.sort();
        models.dedup();
        for m in models {
            let group: Vec<_> = sets
                .iter()
                .filter(|(_, p)| p.model() == m)
                .cloned()
                .collect();
            compare(&gpu, m, &group, &mut rng, &mut failures, &mut summary);
        }
    }
    report(&gpu, "parity", &summary, &failures);
}

/// Every combination of the microfacet model's components (each its own pipeline), at random
/// parameter sets.
#[test]
fn microfacet_every_component_combination() {
    let Some(dev) = common::gpu_device("microfacet parity") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let mut rng = common::Rng(0x00c0_ffee);
    let mut failures = Vec::new();
    let mut summary = Vec::new();
    for config in MicrofacetConfig::all() {
        let model = Model::Microfacet(config);
        let sets: Vec<(String, ParamSet)> = (0..MICROFACET_SETS)
            .map(|k| (format!("random #{k}"), random_params(model, &mut rng)))
            .collect();
        compare(&gpu, model, &sets, &mut rng, &mut failures, &mut summary);
    }
    report(&gpu, "microfacet parity", &summary, &failures);
}

fn report(gpu: &Gpu, test: &str, summary: &[String], failures: &[String]) {
    eprintln!(
        "{test} summary on {}:\n{}",
        gpu.device().name(),
        summary.join("\n")
    );
    common::assert_validation_clean(gpu, test);
    assert!(
        failures.is_empty(),
        "{} GPU values outside tolerance; first 20:\n{}",
        failures.len(),
        failures
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// Evaluates every (parameter set, direction pair) on the GPU in one dispatch per white-furnace
/// setting and compares each channel with the f64 reference.
fn compare(
    gpu: &Gpu,
    model: Model,
    sets: &[(String, ParamSet)],
    rng: &mut common::Rng,
    failures: &mut Vec<String>,
    summary: &mut Vec<String>,
) {
    let model_label = model.label();
    for white_furnace in [false, true] {
        if white_furnace && !model.has_specular_fresnel() {
            continue;
        }
        let mut blocks = Vec::new();
        let mut pairs = Vec::new();
        let mut refs = Vec::new();
        for (k, (_, p)) in sets.iter().enumerate() {
            let p32 = p.rounded_to_f32();
            blocks.push(Brdf::new(&p32).gpu_block());
            for (wi, wo) in direction_pairs(rng) {
                pairs.push(GpuPair {
                    wi: [wi.x as f32, wi.y as f32, wi.z as f32],
                    param_index: k as u32,
                    wo: [wo.x as f32, wo.y as f32, wo.z as f32],
                    pad: 0,
                });
                refs.push((k, wi, wo));
            }
        }
        let got = gpu
            .eval_pairs(model, &blocks, &pairs, white_furnace)
            .expect("GPU evaluation");
        let mut worst = Worst {
            ratio: 0.0,
            text: String::new(),
            rel: 0.0,
            rel_text: String::new(),
        };
        let mut n = 0usize;
        for ((k, wi, wo), g) in refs.iter().zip(&got) {
            let (label, p) = &sets[*k];
            let p32 = p.rounded_to_f32();
            let reference = Reference::new(&p32, white_furnace);
            let c = reference.eval(*wi, *wo);
            let allowed = tolerance::parity_tolerance(&p32, &reference, *wi, *wo, c);
            for ch in 0..3 {
                let (gv, cv) = (g[ch] as f64, c[ch]);
                n += 1;
                let describe = || {
                    format!(
                        "{} ({label}, white_furnace={white_furnace}) {}: wi={wi:?} (θ={:.4}°) wo={wo:?} (θ={:.4}°) \
                         channel {ch}: gpu={gv:e} cpu={cv:e} |diff|={:e} allowed={:e}",
                        model_label,
                        p.to_text(),
                        wi.z.acos().to_degrees(),
                        wo.z.acos().to_degrees(),
                        (gv - cv).abs(),
                        allowed[ch]
                    )
                };
                if !gv.is_finite() || gv < 0.0 {
                    failures.push(format!("non-finite or negative GPU value: {}", describe()));
                    continue;
                }
                let diff = (gv - cv).abs();
                let allowed = allowed[ch];
                if diff > allowed {
                    failures.push(describe());
                }
                let rel = if cv.abs() > ATOL {
                    diff / cv.abs()
                } else {
                    0.0
                };
                if diff / allowed > worst.ratio {
                    (worst.ratio, worst.text) = (diff / allowed, describe());
                }
                if rel > worst.rel {
                    (worst.rel, worst.rel_text) = (rel, describe());
                }
            }
        }
        summary.push(format!(
            "{:<18} wf={:<5} {} sets x {} values: worst relative error {:.2e} at {}\n    closest to the tolerance ({:.0}% of it): {}",
            model_label,
            white_furnace,
            sets.len(),
            n,
            worst.rel,
            worst.rel_text,
            worst.ratio * 100.0,
            worst.text
        ));
    }
}

/// Closed form: Lambert is albedo/π on both backends (the GPU to f32 rounding of 1/π·albedo).
#[test]
fn lambert_is_albedo_over_pi_on_both_backends() {
    let Some(dev) = common::gpu_device("lambert closed form") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let p = resolve_params("lambert", None, &["albedo=0.25,0.5,0.75".into()]).unwrap();
    let pairs: Vec<(DVec3, DVec3)> = (0..50)
        .map(|k| {
            (
                direction(k as f64 * 0.03, 1.0),
                direction(FRAC_PI_2 - 0.001 * k as f64 - 1e-4, 4.0),
            )
        })
        .collect();
    for e in [lobe::Evaluator::gpu(&gpu), lobe::Evaluator::cpu()] {
        let expected = [0.25 / PI, 0.5 / PI, 0.75 / PI];
        for f in e.eval_pairs(&p, &pairs).unwrap() {
            for ch in 0..3 {
                // f32: one rounding of albedo and of 1/π and one product: 4 ε.
                assert!(
                    (f[ch] - expected[ch]).abs() <= 4.0 * EPS32 * expected[ch],
                    "{}: f = {f:?}, expected {expected:?}",
                    e.name()
                );
            }
        }
    }
}

/// Ashikhmin–Shirley's exponent is 0/0 at h = n; the formulation must keep f finite there, on
/// both backends, even with strong anisotropy.
#[test]
fn ashikhmin_shirley_is_finite_at_h_equal_n() {
    let Some(dev) = common::gpu_device("ashikhmin_shirley at h = n") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let p = resolve_params(
        "ashikhmin_shirley",
        None,
        &["nu=10000".into(), "nv=1".into()],
    )
    .unwrap();
    let pairs = [
        (DVec3::Z, DVec3::Z),
        (direction(0.3, 0.0), direction(0.3, PI)),
    ];
    for e in [lobe::Evaluator::gpu(&gpu), lobe::Evaluator::cpu()] {
        for f in e.eval_pairs(&p, &pairs).unwrap() {
            assert!(
                f.iter().all(|v| v.is_finite() && *v > 0.0),
                "{}: f = {f:?} at h = n",
                e.name()
            );
        }
    }
}

/// One-sided: f = 0 whenever either direction is at or below the horizon, on both backends.
#[test]
fn zero_below_the_horizon() {
    let Some(dev) = common::gpu_device("one-sided") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let below = direction(FRAC_PI_2 + 0.2, 0.5);
    let horizon = DVec3::new(1.0, 0.0, 0.0);
    let up = direction(0.4, 2.0);
    for model in Model::ALL {
        let p = ParamSet::defaults(model);
        for e in [lobe::Evaluator::gpu(&gpu), lobe::Evaluator::cpu()] {
            let out = e
                .eval_pairs(
                    &p,
                    &[(below, up), (up, below), (horizon, up), (up, horizon)],
                )
                .unwrap();
            assert!(
                out.iter().all(|f| *f == [0.0; 3]),
                "{} on {}: {out:?}",
                model.name(),
                e.name()
            );
        }
    }
}
