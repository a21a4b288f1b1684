//! Where the V-cavity masking term min(1, 2 c_h min(c_i, c_o)/c_d) has its kinks, so that the
//! `peak` rule can put them on panel edges.

use std::f64::consts::TAU;

/// The μi where the V-cavity's kink curve turns (cos Δφ* of [`v_cavity_kinks`] reaches ±1): there
/// the kinks appear or vanish on the μ lines, the inner integral's derivative in μ is singular
/// like a square root, and the outer rule needs a panel edge. Found by bisection on a scan of
/// q(μ) = (2m(μ + μo) − 1 − μμo)² − (1 − μ²)(1 − μo²), whose sign changes they are.
pub fn v_cavity_turns(mu_o: f64) -> Vec<f64> {
    let q = |mu: f64| {
        let m = mu.min(mu_o);
        let a = 2.0 * m * (mu + mu_o) - 1.0 - mu * mu_o;
        a * a - (1.0 - mu * mu) * (1.0 - mu_o * mu_o)
    };
    const SCAN: usize = 256;
    let mut out = Vec::new();
    for k in 0..SCAN {
        let (mut a, mut b) = (k as f64 / SCAN as f64, (k + 1) as f64 / SCAN as f64);
        let (qa, qb) = (q(a), q(b));
        if qa == 0.0 {
            out.push(a);
            continue;
        }
        if qa * qb >= 0.0 {
            continue;
        }
        for _ in 0..60 {
            let mid = 0.5 * (a + b);
            if q(mid) * qa > 0.0 {
                a = mid;
            } else {
                b = mid;
            }
        }
        out.push(0.5 * (a + b));
    }
    out
}

/// The Δφ = φi − φo ∈ (0, 2π) where the V-cavity's G = min(1, 2 c_h m / c_d), m = min(μi, μo),
/// has its kink on the line μi = `mu`, for a view at μo = `mu_o`.
///
/// With s = ωi + ωo: c_h = (μi + μo)/|s| and c_d = |s|/2, so 2 c_h m = c_d ⟺ |s|² = 4m(μi + μo),
/// and |s|² = 2 + 2(μi μo + sinθi sinθo cos Δφ):
/// cos Δφ* = (2m(μi + μo) − 1 − μi μo) / (sinθi sinθo). The other kink, μi = μo where m switches,
/// is already a μ breakpoint of the `peak` rule.
pub fn v_cavity_kinks(mu: f64, mu_o: f64) -> Vec<f64> {
    let m = mu.min(mu_o);
    let ss = ((1.0 - mu * mu) * (1.0 - mu_o * mu_o)).max(0.0).sqrt();
    if ss <= 0.0 {
        return Vec::new();
    }
    let c = (2.0 * m * (mu + mu_o) - 1.0 - mu * mu_o) / ss;
    if !(c > -1.0 && c < 1.0) {
        return Vec::new();
    }
    let d = c.acos();
    vec![d, TAU - d]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::view_direction;

    /// The V-cavity's kinks from the closed forms against a brute-force scan of where
    /// 2 c_h min(μi, μo)/c_d crosses 1, computed from the vectors.
    #[test]
    fn v_cavity_kinks_and_turns_are_where_the_masking_term_crosses_one() {
        let g = |mu: f64, mu_o: f64, dphi: f64| {
            let wi = view_direction(mu, dphi);
            let wo = view_direction(mu_o, 0.0);
            let s = wi + wo;
            2.0 * (s.z / s.length()) * mu.min(mu_o) / (0.5 * s.length()) - 1.0
        };
        const N: usize = 20_000;
        for mu_o in [0.05, 0.3, 0.5, 0.9] {
            let mut lines_with_kinks = Vec::new();
            for k in 1..200 {
                let mu = k as f64 / 200.0;
                let scan: Vec<f64> = (1..N)
                    .filter(|&j| {
                        let (a, b) = ((j - 1) as f64 * TAU / N as f64, j as f64 * TAU / N as f64);
                        g(mu, mu_o, a) * g(mu, mu_o, b) < 0.0
                    })
                    .map(|j| (j as f64 - 0.5) * TAU / N as f64)
                    .collect();
                let kinks = v_cavity_kinks(mu, mu_o);
                assert_eq!(
                    kinks.len(),
                    scan.len(),
                    "mu_o {mu_o} mu {mu}: {kinks:?} vs {scan:?}"
                );
                for (a, b) in kinks.iter().zip(&scan) {
                    assert!(
                        (a - b).abs() < TAU / N as f64,
                        "mu_o {mu_o} mu {mu}: {a} vs {b}"
                    );
                }
                lines_with_kinks.push(!kinks.is_empty());
            }
            // Each change between lines with and without kinks has a turn between them.
            let turns = v_cavity_turns(mu_o);
            for k in 1..lines_with_kinks.len() {
                if lines_with_kinks[k] != lines_with_kinks[k - 1] {
                    let (lo, hi) = (k as f64 / 200.0, (k + 1) as f64 / 200.0);
                    assert!(
                        turns.iter().any(|&t| lo <= t && t <= hi),
                        "mu_o {mu_o}: no turn in [{lo}, {hi}]: {turns:?}"
                    );
                }
            }
        }
    }
}
