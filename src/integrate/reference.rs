//! The reference directional albedo: nested adaptive Gauss–Kronrod in f64 on the CPU, the truth
//! the fixed rules are tested against.

use super::gauss::{adaptive, adaptive_until, graded, Estimate};
use super::peak::{peak_mu_breaks, peak_nodes, peak_phi_breaks, PeakFrame};
use crate::interrupt::CancelToken;
use crate::model::Reference;
use glam::DVec3;
use std::f64::consts::TAU;
use std::sync::atomic::{AtomicU64, Ordering};

/// Relative tolerance the reference integrator converges to (docs/design.md §5 asks for 1e-9; the
/// nested tolerances are set tighter so that the sum of the inner errors stays under it).
pub const REFERENCE_RTOL: f64 = 1e-10;

/// Levels of geometric grading towards the peak in α: the innermost panel spans 2^-10 of the
/// distance to the horizon (≥ 1.5e-3 rad at normal incidence), finer than the narrowest built-in
/// lobe (Phong n = 8192: width 1/√n ≈ 1.1e-2 rad).
const ALPHA_LEVELS: u32 = 10;

/// Integrand evaluations the reference may spend on one job (every view direction of a
/// `lobe albedo --method reference`, or of its hemispherical albedo, together; one direction
/// of [`reference_albedo`]). An analytic model meets [`REFERENCE_RTOL`] in 10⁵ to 10⁷ per
/// direction (GGX α = 0.3 at μo = 0.5: 4.6e5); measured data, a jump on every bin boundary,
/// would refine up to 4000 panels in each of up to 4000 inner integrals (10¹¹ evaluations,
/// hours) and is stopped here, within seconds on two cores, each direction with the error
/// its panels still carry.
pub const REFERENCE_MAX_EVALS: u64 = 50_000_000;

/// What a reference integral may spend: integrand evaluations up to a limit, until a job is
/// cancelled. Shared by the nested integrals of one view direction (on every thread).
#[derive(Debug)]
pub struct Budget<'a> {
    spent: AtomicU64,
    limit: u64,
    cancel: Option<&'a CancelToken>,
}

impl<'a> Budget<'a> {
    /// `limit` evaluations, stopping early once `cancel` is set.
    pub fn new(limit: u64, cancel: Option<&'a CancelToken>) -> Budget<'a> {
        Budget {
            spent: AtomicU64::new(0),
            limit,
            cancel,
        }
    }

    fn spend(&self, evals: u64) {
        self.spent.fetch_add(evals, Ordering::Relaxed);
    }

    /// Evaluations spent so far.
    pub fn spent(&self) -> u64 {
        self.spent.load(Ordering::Relaxed)
    }

    /// Whether the limit was reached: the integral stopped refining there, and its error
    /// estimate (the panels' Σ|K15 − G7|) says how far it got.
    pub fn exhausted(&self) -> bool {
        self.spent() >= self.limit
    }

    /// Whether the job was cancelled: its values will not be used.
    pub(super) fn cancelled(&self) -> bool {
        self.cancel.is_some_and(CancelToken::is_cancelled)
    }

    /// Whether refinement must stop: the limit reached or the job cancelled.
    pub(super) fn stop(&self) -> bool {
        self.exhausted() || self.cancelled()
    }
}

/// [`reference_albedo_within`] with [`REFERENCE_MAX_EVALS`] and no cancellation.
pub fn reference_albedo(r: &Reference, wo: DVec3, rtol: f64) -> Estimate {
    reference_albedo_within(r, wo, rtol, &Budget::new(REFERENCE_MAX_EVALS, None)).0
}

/// Directional albedo (delta lobe excluded), the reference: nested adaptive Gauss–Kronrod in
/// (μi, Δφ) from the `peak` rule's aligned, graded breakpoints: outer over μ ∈ [0, 1], inner
/// over Δφ ∈ [0, 2π], E = ∫∫ f μ dΔφ dμ. The built-in models' kinks lie on breakpoints (μ = μo,
/// Δφ = ±π/2) or are found by bisection (the V-cavity's min); tolerances as in
/// [`reference_albedo_mirror_frame`]. Refinement stops once `budget` is spent or cancelled;
/// the error then reports what the panels still carry. Also returns whether every integral of
/// the nest met its tolerance (false: it stopped short, at the budget, at
/// 4000 panels or at f64's resolution, and the error estimate is
/// what there is).
pub fn reference_albedo_within(
    r: &Reference,
    wo: DVec3,
    rtol: f64,
    budget: &Budget,
) -> (Estimate, bool) {
    if wo.z <= 0.0 {
        return (Estimate::default(), true);
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
        // A cancelled job's values are thrown away: skip even the first pass of what is left,
        // so that Ctrl-C is obeyed within one inner integral rather than one outer pass.
        if budget.cancelled() {
            return Estimate::default();
        }
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let g = |dphi: f64| {
            let (sp, cp) = (phi_o + dphi).sin_cos();
            Estimate {
                value: r.eval(DVec3::new(s * cp, s * sp, mu), wo) * mu,
                error: DVec3::ZERO,
                evals: 1,
            }
        };
        let (e, _) = adaptive_until(&g, &pb, tol_inner, false, &|| budget.stop());
        budget.spend(e.evals);
        e
    };
    // An inner integral short of its own tolerance counts only through the error it carries
    // into the outer one: whether the nest met its tolerance is the outer integral's answer.
    adaptive_until(&inner, &peak_mu_breaks(wo.z, 0), tol, true, &|| {
        budget.stop()
    })
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
