//! The reference directional albedo: nested adaptive Gauss–Kronrod in f64 on the CPU, the truth
//! the fixed rules are tested against.

use super::gauss::{adaptive, graded, Estimate};
use super::peak::{peak_mu_breaks, peak_nodes, peak_phi_breaks, PeakFrame};
use crate::model::Reference;
use glam::DVec3;
use std::f64::consts::TAU;

/// Relative tolerance the reference integrator converges to (docs/design.md §5 asks for 1e-9; the
/// nested tolerances are set tighter so that the sum of the inner errors stays under it).
pub const REFERENCE_RTOL: f64 = 1e-10;

/// Levels of geometric grading towards the peak in α: the innermost panel spans 2^-10 of the
/// distance to the horizon (≥ 1.5e-3 rad at normal incidence), finer than the narrowest built-in
/// lobe (Phong n = 8192: width 1/√n ≈ 1.1e-2 rad).
const ALPHA_LEVELS: u32 = 10;

/// Directional albedo (delta lobe excluded), the reference: nested adaptive Gauss–Kronrod in
/// (μi, Δφ) from the `peak` rule's aligned, graded breakpoints: outer over μ ∈ [0, 1], inner
/// over Δφ ∈ [0, 2π], E = ∫∫ f μ dΔφ dμ. The built-in models' kinks lie on breakpoints (μ = μo,
/// Δφ = ±π/2) or are found by bisection (the V-cavity's min); tolerances as in
/// [`reference_albedo_mirror_frame`].
pub fn reference_albedo(r: &Reference, wo: DVec3, rtol: f64) -> Estimate {
    if wo.z <= 0.0 {
        return Estimate::default();
    }
    let first: DVec3 = peak_nodes(6, false, 0, wo)
        .iter()
        .map(|n| n.weight * r.eval(n.wi, wo))
        .sum();
    let tol = (rtol * first.abs().max_element()).max(f64::MIN_POSITIVE);
    let tol_inner = tol / 100.0;
    let phi_o = wo.y.atan2(wo.x);
    let pb = peak_phi_breaks(wo.z, 0);
    let inner = |mu: f64| {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let g = |dphi: f64| {
            let (sp, cp) = (phi_o + dphi).sin_cos();
            Estimate {
                value: r.eval(DVec3::new(s * cp, s * sp, mu), wo) * mu,
                error: DVec3::ZERO,
                evals: 1,
            }
        };
        adaptive(&g, &pb, tol_inner, false)
    };
    adaptive(&inner, &peak_mu_breaks(wo.z, 0), tol, true)
}

/// Directional albedo (delta lobe excluded) by nested adaptive Gauss–Kronrod in the peak frame:
/// inner over α ∈ [0, α_max(β)] from the graded breakpoints, outer over β from the graded
/// quadrants. The absolute tolerance is `rtol` × the largest channel of a first estimate (the
/// `peak` rule of order 6); the inner integrals get 1/(100·2π) of it each so that their carried
/// errors (weighted by at most 2π) stay a small part of the total.
pub fn reference_albedo_mirror_frame(r: &Reference, wo: DVec3, rtol: f64) -> Estimate {
    if wo.z <= 0.0 {
        return Estimate::default();
    }
    let frame = PeakFrame::new(wo);
    let first: DVec3 = peak_nodes(6, false, 0, wo)
        .iter()
        .map(|n| n.weight * r.eval(n.wi, wo))
        .sum();
    let scale = first.abs().max_element();
    // A black material: the estimate is exact (every node gives 0) and nothing needs refining.
    let tol = (rtol * scale).max(f64::MIN_POSITIVE);
    let tol_inner = tol / (100.0 * TAU);
    let tb = graded(ALPHA_LEVELS);
    let inner = |beta: f64| {
        let am = frame.alpha_max(beta);
        let breaks: Vec<f64> = tb.iter().map(|t| am * t).collect();
        let g = |alpha: f64| {
            let wi = frame.dir(alpha, beta);
            Estimate {
                value: r.eval(wi, wo) * (wi.z.max(0.0) * alpha.sin()),
                error: DVec3::ZERO,
                evals: 1,
            }
        };
        adaptive(&g, &breaks, tol_inner, false)
    };
    adaptive(&inner, &frame.beta_breaks(), tol, true)
}
