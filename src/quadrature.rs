//! One-dimensional rules (the numerics beneath the albedo integrators and the models' own
//! tables): Gauss–Legendre, Gauss–Kronrod 7/15 panels and the globally adaptive
//! integrator built on them, and geometrically graded breakpoints.

use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// One quadrature node: E ≈ Σ weight · f(wi, wo). The weight holds c_i.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// ωi, the unit direction to the light, in the local frame.
    pub wi: DVec3,
    /// The node's weight in sr, the cosine c_i included.
    pub weight: f64,
}

/// Refinement stops at this many panels even if the tolerance is not met; the reported error
/// then says so.
const MAX_PANELS: usize = 4000;

/// Gauss–Legendre nodes and weights on [-1, 1]: Newton's iteration on P_n from Tricomi's initial
/// guess cos(π(k + 3/4)/(n + 1/2)), with P_n from the three-term recurrence (Abramowitz & Stegun
/// 25.4.29 for the weights w = 2/((1 − x²) P_n'(x)²)).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let mut x = (PI * (k as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for j in 2..=n {
                let j = j as f64;
                let p2 = ((2.0 * j - 1.0) * x * p1 - (j - 1.0) * p0) / j;
                p0 = p1;
                p1 = p2;
            }
            let (pn, pm) = if n == 0 { (1.0, 0.0) } else { (p1, p0) };
            let pn = if n == 1 { x } else { pn };
            let pm = if n == 1 { 1.0 } else { pm };
            dp = n as f64 * (x * pn - pm) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// Gauss–Legendre with `n` nodes on [a, b], as (x, w).
pub(crate) fn gauss_on(
    rule: &[(f64, f64)],
    a: f64,
    b: f64,
) -> impl Iterator<Item = (f64, f64)> + '_ {
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    rule.iter().map(move |&(x, w)| (m + h * x, h * w))
}

/// Kronrod 15-point nodes (positive half, descending) and weights, with the embedded Gauss
/// 7-point weights at the odd-indexed nodes; QUADPACK's qk15 (Piessens et al. 1983).
#[allow(clippy::excessive_precision)] // QUADPACK's published digits, kept as printed
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.0,
];
#[allow(clippy::excessive_precision)] // QUADPACK's published digits, kept as printed
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
#[allow(clippy::excessive_precision)] // QUADPACK's published digits, kept as printed
const WG: [f64; 4] = [
    0.129484966168869693270611432679082,
    0.279705391489276667901467771423780,
    0.381830050505118944950369775488975,
    0.417959183673469387755102040816327,
];

/// An integral with its error estimate (per channel) and the integrand evaluations it took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// The integral, per channel.
    pub value: DVec3,
    /// Estimated absolute error of `value`, per channel.
    pub error: DVec3,
    /// Integrand evaluations spent.
    pub evals: u64,
}

/// The 15 Kronrod abscissae on [a, b], in the order [`gk15_combine`] expects: pairs m ∓ h·x_j
/// for j = 0..7, then the midpoint.
pub(crate) fn gk15_nodes(a: f64, b: f64) -> [f64; 15] {
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut x = [m; 15];
    for j in 0..7 {
        x[2 * j] = m - h * XGK[j];
        x[2 * j + 1] = m + h * XGK[j];
    }
    x
}

/// One Gauss–Kronrod 7/15 panel from the integrand at [`gk15_nodes`]: the Kronrod sum, and as
/// error |K15 − G7| plus the integrand's own errors carried through the Kronrod weights.
pub(crate) fn gk15_combine(a: f64, b: f64, vals: &[Estimate]) -> Estimate {
    let h = 0.5 * (b - a);
    let mut k = DVec3::ZERO;
    let mut g = DVec3::ZERO;
    let mut carried = DVec3::ZERO;
    let mut evals = 0;
    for (i, e) in vals.iter().enumerate() {
        let j = i / 2;
        k += WGK[j] * e.value;
        carried += WGK[j] * e.error;
        evals += e.evals;
        if j % 2 == 1 {
            g += WG[j / 2] * e.value;
        }
    }
    Estimate {
        value: h * k,
        error: (h * (k - g)).abs() + h.abs() * carried,
        evals,
    }
}

/// One Gauss–Kronrod 7/15 panel of an integrand that returns (value, its own error, evals).
pub(crate) fn gk15<F: Fn(f64) -> Estimate>(f: &F, a: f64, b: f64) -> Estimate {
    let vals: Vec<Estimate> = gk15_nodes(a, b).iter().map(|&x| f(x)).collect();
    gk15_combine(a, b, &vals)
}

/// The Lagrange basis of the 15 Kronrod nodes of [−1, 1] (in [`gk15_nodes`]' order) at −1 and
/// at 1: the degree-14 interpolant's value at an end is Σ ℓ_j f_j.
fn end_weights() -> &'static [[f64; 15]; 2] {
    static W: OnceLock<[[f64; 15]; 2]> = OnceLock::new();
    W.get_or_init(|| {
        let x = gk15_nodes(-1.0, 1.0);
        let basis_at = |t: f64| -> [f64; 15] {
            std::array::from_fn(|j| {
                (0..15)
                    .filter(|&m| m != j)
                    .map(|m| (t - x[m]) / (x[j] - x[m]))
                    .product()
            })
        };
        [basis_at(-1.0), basis_at(1.0)]
    })
}

/// QUADPACK's constant in its error scaling of a panel (qk15: resasc · min(1, (200 |K − G| /
/// resasc)^1.5), Piessens et al. 1983).
const QAG_SCALE: f64 = 200.0;

/// One panel of the adaptive integrator: Gauss–Kronrod 7/15 with an error that also sees jumps
/// the 15 nodes cannot.
///
/// - |K15 − G7|, and no less than QUADPACK's scaled form resasc · min(1, (200 |K − G| /
///   resasc)^1.5), resasc = ∫|f − mean| by the Kronrod rule: on a panel with a jump between two
///   nodes K15 and G7 can agree by chance; the scaled form then still reports the jump's size.
/// - An end check: a jump between a panel's end and its outermost node (0.85 % of the panel on
///   each side) leaves all 15 nodes on one side, K15 = G7 exactly and the error 0 (a measured
///   table read by its nearest bin has such jumps on every bin boundary). So f is evaluated at
///   both ends too and compared with the nodes' interpolant there; the difference times the
///   sliver's width bounds what a jump inside the sliver costs. For a smooth f the interpolant's
///   error at an end is tiny (degree 14), so the check adds next to nothing there.
///
/// Plus the integrand's own errors carried through the Kronrod weights. 17 evaluations.
fn gk15_checked<F: Fn(f64) -> Estimate>(f: &F, a: f64, b: f64) -> Estimate {
    let nodes = gk15_nodes(a, b);
    let vals: Vec<Estimate> = nodes.iter().map(|&x| f(x)).collect();
    let plain = gk15_combine(a, b, &vals);
    let h = 0.5 * (b - a);
    let carried: DVec3 = vals
        .iter()
        .enumerate()
        .map(|(i, e)| h.abs() * WGK[i / 2] * e.error)
        .sum();
    let k_minus_g = plain.error - carried;
    let mean = plain.value / (b - a);
    let resasc: DVec3 = vals
        .iter()
        .enumerate()
        .map(|(i, e)| h.abs() * WGK[i / 2] * (e.value - mean).abs())
        .sum();
    let scaled = DVec3::from_array(std::array::from_fn(|c| {
        if resasc[c] > 0.0 && k_minus_g[c] > 0.0 {
            resasc[c] * (QAG_SCALE * k_minus_g[c] / resasc[c]).powf(1.5).min(1.0)
        } else {
            0.0
        }
    }));
    let (fa, fb) = (f(a), f(b));
    let [at_a, at_b] = end_weights();
    let interpolant =
        |w: &[f64; 15]| -> DVec3 { vals.iter().zip(w).map(|(e, &w)| w * e.value).sum() };
    let sliver = h.abs() * (1.0 - XGK[0]);
    let ends =
        sliver * ((fa.value - interpolant(at_a)).abs() + (fb.value - interpolant(at_b)).abs());
    Estimate {
        value: plain.value,
        error: k_minus_g.max(scaled) + carried + ends,
        evals: plain.evals + fa.evals + fb.evals,
    }
}

/// Globally adaptive Gauss–Kronrod over the panels between `breaks` (QUADPACK's QAG strategy,
/// refined in batches): while the summed error exceeds `tol` (absolute, in the largest
/// channel), every panel whose error is at least half the largest one is bisected. With
/// `parallel`, the panels of a batch are evaluated on rayon's threads. Each panel's error is
/// [`gk15_checked`]'s.
pub(crate) fn adaptive<F: Fn(f64) -> Estimate + Sync>(
    f: &F,
    breaks: &[f64],
    tol: f64,
    parallel: bool,
) -> Estimate {
    adaptive_until(f, breaks, tol, parallel, &|| false).0
}

/// [`adaptive`] that also stops refining, before each batch, once `stop` says so (a budget
/// spent, a job cancelled): the panels made so far give the value, and their summed error says
/// how far it is from the tolerance. Also returns whether the tolerance was met (false when
/// `stop`, [`MAX_PANELS`] or f64's resolution ended the refinement first).
pub(crate) fn adaptive_until<F: Fn(f64) -> Estimate + Sync>(
    f: &F,
    breaks: &[f64],
    tol: f64,
    parallel: bool,
    stop: &(dyn Fn() -> bool + Sync),
) -> (Estimate, bool) {
    let eval = |(a, b): (f64, f64)| (a, b, gk15_checked(f, a, b));
    let spans: Vec<(f64, f64)> = breaks
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| (w[0], w[1]))
        .collect();
    let mut panels: Vec<(f64, f64, Estimate)> = if parallel {
        spans.into_par_iter().map(eval).collect()
    } else {
        spans.into_iter().map(eval).collect()
    };
    let mut evals: u64 = panels.iter().map(|p| p.2.evals).sum();
    let converged = loop {
        let error: DVec3 = panels.iter().map(|p| p.2.error).sum();
        if error.max_element() <= tol {
            break true;
        }
        if panels.len() >= MAX_PANELS || stop() {
            break false;
        }
        let worst = panels
            .iter()
            .map(|p| p.2.error.max_element())
            .fold(0.0, f64::max);
        // A panel too narrow to bisect in f64 keeps its error: reported, not hidden.
        let splittable = |p: &(f64, f64, Estimate)| {
            p.2.error.max_element() >= 0.5 * worst
                && 0.5 * (p.0 + p.1) > p.0
                && 0.5 * (p.0 + p.1) < p.1
        };
        let (split, keep): (Vec<_>, Vec<_>) = panels.into_iter().partition(splittable);
        if split.is_empty() {
            panels = keep;
            break false;
        }
        let halves: Vec<(f64, f64)> = split
            .iter()
            .flat_map(|&(a, b, _)| {
                let m = 0.5 * (a + b);
                [(a, m), (m, b)]
            })
            .collect();
        let new: Vec<_> = if parallel {
            halves.into_par_iter().map(eval).collect()
        } else {
            halves.into_iter().map(eval).collect()
        };
        evals += new.iter().map(|p| p.2.evals).sum::<u64>();
        panels = keep;
        panels.extend(new);
    };
    let estimate = Estimate {
        value: panels.iter().map(|p| p.2.value).sum(),
        error: panels.iter().map(|p| p.2.error).sum(),
        evals,
    };
    (estimate, converged)
}

/// Breakpoints on [0, 1] graded geometrically towards 0: 0, 2^-levels, …, 1/2, 1.
pub(crate) fn graded(levels: u32) -> Vec<f64> {
    let mut b = vec![0.0];
    b.extend((0..=levels).rev().map(|k| 0.5f64.powi(k as i32)));
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(value: f64) -> Estimate {
        Estimate {
            value: DVec3::splat(value),
            error: DVec3::ZERO,
            evals: 1,
        }
    }

    #[test]
    fn the_end_weights_interpolate_polynomials_of_degree_14() {
        // Σ ℓ_j(±1) x_j^k = (±1)^k for k ≤ 14: the interpolant is exact on polynomials.
        let x = gk15_nodes(-1.0, 1.0);
        let [at_a, at_b] = end_weights();
        for k in 0..=14 {
            for (w, t) in [(at_a, -1.0f64), (at_b, 1.0)] {
                let s: f64 = x.iter().zip(w).map(|(x, w)| w * x.powi(k)).sum();
                assert!((s - t.powi(k)).abs() < 1e-9, "k = {k}, end {t}: {s}");
            }
        }
    }

    #[test]
    fn a_smooth_integrand_converges_to_its_closed_form() {
        // ∫₀^π sin x dx = 2.
        let (e, converged) = adaptive_until(
            &|x: f64| point(x.sin()),
            &[0.0, 1.0, PI],
            1e-13,
            false,
            &|| false,
        );
        assert!(converged, "{e:?}");
        assert!((e.value.x - 2.0).abs() < 1e-13, "{e:?}");
        assert!(e.error.x <= 1e-13, "{e:?}");
    }

    #[test]
    fn a_jump_beside_a_panel_end_is_seen() {
        // ∫₀¹ [x > 0.998] dx = 0.002: the step lies beyond the last Kronrod node of [0, 1]
        // (0.99573), so all 15 nodes read 0 and K15 = G7 = 0; without the end check the panel
        // would claim error 0 at an actual error of 0.002.
        let f = |x: f64| point(if x > 0.998 { 1.0 } else { 0.0 });
        let one = gk15_checked(&f, 0.0, 1.0);
        assert_eq!(one.value.x, 0.0);
        assert!(one.error.x >= 0.002, "{one:?}");
        let e = adaptive(&f, &[0.0, 1.0], 1e-9, false);
        let err = (e.value.x - 0.002).abs();
        assert!(err <= e.error.x.max(1e-9), "error {err:e}: {e:?}");
    }

    #[test]
    fn a_jump_stopped_early_keeps_an_error_that_bounds_it() {
        // A step at an irrational point, ∫₀¹ [x > 1/√2] dx = 1 − 1/√2, stopped after 1, 2, 4,
        // ... batches: at every stop the summed error bounds the actual one.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let f = |x: f64| point(if x > s { 1.0 } else { 0.0 });
        for batches in [0usize, 1, 2, 4, 8, 16] {
            let calls = std::sync::atomic::AtomicUsize::new(0);
            let stop = || calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= batches;
            let (e, converged) = adaptive_until(&f, &[0.0, 1.0], 1e-30, false, &stop);
            assert!(!converged, "{e:?}");
            let err = (e.value.x - (1.0 - s)).abs();
            assert!(
                err <= e.error.x,
                "after {batches} batches: error {err:e}, {e:?}"
            );
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..40 {
            let rule = gauss_legendre(n);
            // ∫_{-1}^{1} x^k dx = 2/(k+1) for even k, exact up to degree 2n − 1.
            for k in (0..2 * n).step_by(2) {
                let s: f64 = rule.iter().map(|&(x, w)| w * x.powi(k as i32)).sum();
                let exact = 2.0 / (k as f64 + 1.0);
                assert!(
                    (s - exact).abs() < 1e-13 * exact.max(1.0) * (k as f64 + 1.0),
                    "n = {n}, k = {k}: {s} vs {exact}"
                );
            }
        }
    }
}
