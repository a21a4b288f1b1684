//! The GPU-vs-CPU tolerance model (docs/design.md §10), used by the parity tests, `lobe stability`
//! and the demo's parity table alike: a GPU value g (f32, GLSL built-ins) passes against the f64
//! reference c at the same f32-rounded inputs when, per channel,
//!
//! |g − c| ≤ ATOL + (RTOL_BASE + EXPONENT_FACTOR·ε·|x|)·|c| + spread,
//!
//! x the argument of the exponential the model evaluates there (its `exponent`), spread the
//! reference's change over a PERTURBATION neighbourhood of the directions.

use crate::model::{ParamSet, Reference};
use glam::DVec3;

/// f32 machine epsilon.
pub const EPS32: f64 = f32::EPSILON as f64;

/// Relative tolerance for a smooth formula evaluated in f32: a few dozen roundings of ε = 1.2e-7
/// each (normalize, dot products, Schlick's fifth power, divisions) plus `exp`/`pow`, whose
/// Vulkan bound is 3 + 2|x| ULP. 64 ε ≈ 7.6e-6.
pub const RTOL_BASE: f64 = 64.0 * EPS32;

/// Exponentials: the lobes are exp(x) with x = n·log(1 − s) (Phong, Blinn–Phong,
/// Ashikhmin–Shirley, s = 1 − cos taken from the geometry without cancellation) or
/// x = −tan²θh/m² (Beckmann). The Vulkan spec allows exp an error of 3 + 2|x| ULP, so the
/// tolerance grows by 2 ε per unit of |x|; this factor keeps a margin of 2 over that bound.
pub const EXPONENT_FACTOR: f64 = 4.0;

/// Input conditioning: the GPU computes dot products of f32 vectors, each off by a few ε in
/// absolute terms, so where f depends steeply on the directions (a cosine that results from
/// cancellation, such as r·ωo near 0 at grazing, raised to a small power n: x^n has an infinite
/// slope at 0) no f32 implementation can do better than f varies over that neighbourhood. The
/// tolerance adds the spread of the f64 reference over directions perturbed by this angle
/// (radians): 8 ε.
pub const PERTURBATION: f64 = 8.0 * EPS32;

/// Absolute tolerance in 1/sr: values this small are far below anything a renderer can resolve,
/// and an f32 exp underflows to 0 where the f64 value is still ~1e-40.
pub const ATOL: f64 = 1e-6;

/// The largest change of the f64 reference when ωi or ωo moves by [`PERTURBATION`] along each
/// axis: the input conditioning that no f32 implementation can beat. A non-finite neighbour says
/// nothing about conditioning and is left out (the checks count non-finite values apart).
pub fn conditioning(r: &Reference, wi: DVec3, wo: DVec3, c: DVec3) -> DVec3 {
    let mut worst = DVec3::ZERO;
    for axis in [
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        -DVec3::X,
        -DVec3::Y,
        -DVec3::Z,
    ] {
        let d = axis * PERTURBATION;
        for (a, b) in [((wi + d).normalize(), wo), (wi, (wo + d).normalize())] {
            let v = r.eval(a, b) - c;
            if v.is_finite() {
                worst = worst.max(v.abs());
            }
        }
    }
    worst
}

/// The relative part of the tolerance at (ωi, ωo): RTOL_BASE + EXPONENT_FACTOR·ε·|x|.
pub fn relative(params: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    RTOL_BASE + EXPONENT_FACTOR * EPS32 * params.exponent_at(wi, wo)
}

/// The per-channel tolerance for a GPU value at (ωi, ωo), given the reference value `c` there
/// (from `r`, built from `params`). `params` must be the f32-rounded set the GPU received.
pub fn parity_tolerance(params: &ParamSet, r: &Reference, wi: DVec3, wo: DVec3, c: DVec3) -> DVec3 {
    DVec3::splat(ATOL) + relative(params, wi, wo) * c.abs() + conditioning(r, wi, wo, c)
}
