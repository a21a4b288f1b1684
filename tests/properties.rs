//! Properties of the CPU reference that hold for every model: reciprocity, mirror symmetry,
//! finiteness and non-negativity on valid input. (The GPU's values are checked against this reference in
//! tests/parity.rs, which also checks they are finite and non-negative.)

mod common;

use glam::DVec3;
use lobe::grid::direction;
use lobe::material;
use lobe::model::{Model, ParamSet, Reference};
use std::f64::consts::{FRAC_PI_2, PI};

/// Reciprocity in f64: the formulas are symmetric in ωi and ωo up to the order of operations
/// (h = normalize(ωi + ωo) vs normalize(ωo + ωi), max(c_i, c_o)), so only rounding differs: a
/// few hundred ε of f64 even where an exponent of 8192 amplifies it.
const RECIPROCITY_RTOL: f64 = 1e-11;
/// Absolute floor in 1/sr. c_d is computed as ωi·h on one side and ωo·h on the other; equal in
/// exact arithmetic, they differ by an ε of f64, which Schlick's (1 − c_d)^5 turns into a large
/// relative difference when c_d → 1 and R0 = 0 (values ~1e-23 there). 1e-12 is far below any
/// value a renderer or a table can resolve.
const RECIPROCITY_ATOL: f64 = 1e-12;

fn parameter_sets(model: Model) -> Vec<ParamSet> {
    let mut sets: Vec<ParamSet> = material::names()
        .into_iter()
        .map(|m| material::preset(m, model).unwrap())
        .collect();
    sets.push(ParamSet::defaults(model));
    // Strong anisotropy and a huge exponent where the model has them.
    let mut extreme = ParamSet::defaults(model);
    for (k, v) in [
        ("shininess", "8192"),
        ("nu", "10000"),
        ("nv", "3"),
        ("roughness", "0.02"),
        ("smoothness", "0"),
        ("alpha_x", "0.05"),
        ("alpha_y", "0.7"),
    ] {
        let _ = extreme.set_text(&format!("{k}={v}")); // keys a model lacks are skipped
    }
    sets.push(extreme);
    sets
}

fn directions(rng: &mut common::Rng, n: usize) -> Vec<(DVec3, DVec3)> {
    (0..n)
        .map(|_| {
            let wi = direction(rng.range(0.0, FRAC_PI_2 - 1e-3), rng.range(0.0, 2.0 * PI));
            let wo = if rng.uniform() < 0.5 {
                // Near the mirror direction of wi.
                DVec3::new(
                    -wi.x + rng.range(-0.02, 0.02),
                    -wi.y + rng.range(-0.02, 0.02),
                    wi.z,
                )
                .normalize()
            } else {
                direction(rng.range(0.0, FRAC_PI_2 - 1e-3), rng.range(0.0, 2.0 * PI))
            };
            (wi, wo)
        })
        .collect()
}

#[test]
fn every_model_is_reciprocal() {
    let mut rng = common::Rng(7);
    for model in Model::ALL {
        for p in parameter_sets(model) {
            for wf in [false, true] {
                let r = Reference::new(&p, wf);
                for (wi, wo) in directions(&mut rng, 2000) {
                    if wo.z <= 0.0 {
                        continue;
                    }
                    let (a, b) = (r.eval(wi, wo), r.eval(wo, wi));
                    for ch in 0..3 {
                        let tol =
                            RECIPROCITY_RTOL * a[ch].abs().max(b[ch].abs()) + RECIPROCITY_ATOL;
                        assert!(
                            (a[ch] - b[ch]).abs() <= tol,
                            "{} {} wf={wf}: f(wi,wo)={} f(wo,wi)={} at wi={wi:?} wo={wo:?}",
                            model.name(),
                            p.to_text(),
                            a[ch],
                            b[ch]
                        );
                    }
                }
            }
        }
    }
}

/// Mirror symmetry in f64 (docs/design.md §4.6): mirroring negates components exactly, and the
/// formulas read tangential components through squares and products of two mirrored vectors,
/// so the values should agree exactly; the reciprocity tolerances above are kept as the bound
/// (a formula may still group its products differently one day).
#[test]
fn every_built_in_model_is_mirror_symmetric() {
    let mirrors: [(&str, fn(DVec3) -> DVec3); 2] = [
        ("y -> -y", |w| DVec3::new(w.x, -w.y, w.z)),
        ("x -> -x", |w| DVec3::new(-w.x, w.y, w.z)),
    ];
    let mut rng = common::Rng(11);
    for model in Model::ALL {
        assert!(model.is_mirror_symmetric(), "{}", model.name());
        for p in parameter_sets(model) {
            for wf in [false, true] {
                let r = Reference::new(&p, wf);
                for (wi, wo) in directions(&mut rng, 1000) {
                    if wo.z <= 0.0 {
                        continue;
                    }
                    let a = r.eval(wi, wo);
                    for (name, m) in mirrors {
                        let b = r.eval(m(wi), m(wo));
                        for ch in 0..3 {
                            let tol =
                                RECIPROCITY_RTOL * a[ch].abs().max(b[ch].abs()) + RECIPROCITY_ATOL;
                            assert!(
                                (a[ch] - b[ch]).abs() <= tol,
                                "{} {} wf={wf} {name}: f={} mirrored f={} at wi={wi:?} wo={wo:?}",
                                model.name(),
                                p.to_text(),
                                a[ch],
                                b[ch]
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn every_model_is_finite_and_non_negative() {
    let mut rng = common::Rng(11);
    let mut pairs = directions(&mut rng, 3000);
    // The edges: normal incidence, grazing to 1e-7 of the horizon, ωi = ωo, opposite grazing.
    let graze = FRAC_PI_2 - 1e-7;
    pairs.extend([
        (DVec3::Z, DVec3::Z),
        (direction(graze, 0.0), direction(graze, PI)),
        (direction(graze, 0.0), direction(graze, 0.0)),
        (direction(graze, 0.0), DVec3::Z),
    ]);
    for model in Model::ALL {
        for p in parameter_sets(model) {
            let r = Reference::new(&p, false);
            for (wi, wo) in &pairs {
                let f = r.eval(*wi, *wo);
                assert!(
                    f.is_finite() && f.min_element() >= 0.0,
                    "{} {}: f = {f:?} at wi={wi:?} wo={wo:?}",
                    model.name(),
                    p.to_text()
                );
            }
        }
    }
}
