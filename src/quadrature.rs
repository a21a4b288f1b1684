//! One-dimensional rules (the numerics beneath the albedo integrators and the models' own
//! tables): Gauss–Legendre, Gauss–Kronrod 7/15 panels and the globally adaptive
//! integrator built on them, and geometrically graded breakpoints.

use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

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

/// Globally adaptive Gauss–Kronrod over the panels between `breaks` (QUADPACK's QAG strategy,
/// refined in batches): while the summed error exceeds `tol` (absolute, in the largest
/// channel), every panel whose error is at least half the largest one is bisected. With
/// `parallel`, the panels of a batch are evaluated on rayon's threads.
pub(crate) fn adaptive<F: Fn(f64) -> Estimate + Sync>(
    f: &F,
    breaks: &[f64],
    tol: f64,
    parallel: bool,
) -> Estimate {
    adaptive_until(f, breaks, tol, parallel, &|| false)
}

/// [`adaptive`] that also stops refining, before each batch, once `stop` says so (a budget
/// spent, a job cancelled): the panels made so far give the value, and their summed error says
/// how far it is from the tolerance.
pub(crate) fn adaptive_until<F: Fn(f64) -> Estimate + Sync>(
    f: &F,
    breaks: &[f64],
    tol: f64,
    parallel: bool,
    stop: &(dyn Fn() -> bool + Sync),
) -> Estimate {
    let eval = |(a, b): (f64, f64)| (a, b, gk15(f, a, b));
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
    loop {
        let error: DVec3 = panels.iter().map(|p| p.2.error).sum();
        if error.max_element() <= tol || panels.len() >= MAX_PANELS || stop() {
            break;
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
            break;
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
    }
    Estimate {
        value: panels.iter().map(|p| p.2.value).sum(),
        error: panels.iter().map(|p| p.2.error).sum(),
        evals,
    }
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
