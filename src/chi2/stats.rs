//! The statistics of the sampling test: the regularised incomplete gamma function, the
//! chi-square p-value, Šidák's correction, and the statistic over pooled cells.

use serde::Serialize;

/// Cells whose expected count is below this are pooled until the pool reaches it: the usual
/// rule for the chi-square approximation to hold (Cochran 1954), as Mitsuba 3 and pbrt-v4 apply it.
pub const MIN_EXPECTED: f64 = 5.0;

/// Series and continued fraction stop once a term changes the sum by less than this (f64's
/// machine epsilon, as Numerical Recipes 3rd ed. §6.2 does).
const EPS: f64 = f64::EPSILON;
/// Lentz's guard against a zero denominator (Numerical Recipes 3rd ed. §5.2: a number near the
/// smallest normal one, divided by EPS so that it still carries precision).
const FPMIN: f64 = f64::MIN_POSITIVE / EPS;
/// Both expansions converge in O(sqrt(a)) terms near x ≈ a (a few hundred at a = 10⁴); this bound
/// is only reached for a beyond what the test ever asks (dof > 10⁸).
const MAX_TERMS: usize = 1_000_000;

/// e^{−x} x^a / Γ(a), the factor both expansions share, in logarithms so that large a and x do
/// not overflow.
fn prefactor(a: f64, x: f64) -> f64 {
    (-x + a * x.ln() - libm::lgamma(a)).exp()
}

/// P(a, x) by its series, e^{−x} x^a / Γ(a) Σ_n x^n / (a (a+1) ⋯ (a+n)) (Numerical Recipes 3rd
/// ed. §6.2, eq. 6.2.5); converges fast for x < a + 1.
fn p_series(a: f64, x: f64) -> f64 {
    let (mut ap, mut del) = (a, 1.0 / a);
    let mut sum = del;
    for _ in 0..MAX_TERMS {
        ap += 1.0;
        del *= x / ap;
        sum += del;
        if del.abs() < sum.abs() * EPS {
            break;
        }
    }
    sum * prefactor(a, x)
}

/// Q(a, x) = 1 − P(a, x) by its continued fraction (Numerical Recipes 3rd ed. §6.2, eq. 6.2.7, the
/// even form), evaluated by the modified Lentz method (§5.2); converges fast for x > a + 1.
fn q_fraction(a: f64, x: f64) -> f64 {
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / FPMIN;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..MAX_TERMS {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < FPMIN {
            d = FPMIN;
        }
        c = b + an / c;
        if c.abs() < FPMIN {
            c = FPMIN;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() <= EPS {
            break;
        }
    }
    prefactor(a, x) * h
}

/// The regularised lower incomplete gamma function P(a, x) = γ(a, x) / Γ(a), for a > 0, x ≥ 0.
pub fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        0.0
    } else if x < a + 1.0 {
        p_series(a, x)
    } else {
        1.0 - q_fraction(a, x)
    }
}

/// The regularised upper incomplete gamma function Q(a, x) = 1 − P(a, x), computed directly where
/// it is small (no cancellation in 1 − P), for a > 0, x ≥ 0.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        1.0
    } else if x < a + 1.0 {
        1.0 - p_series(a, x)
    } else {
        q_fraction(a, x)
    }
}

/// The probability that a chi-square variable with `dof` degrees of freedom is at least `stat`:
/// Q(dof/2, stat/2). NaN for dof = 0 (no test).
pub fn chi2_p_value(stat: f64, dof: usize) -> f64 {
    if dof == 0 || stat.is_nan() {
        return f64::NAN;
    }
    gamma_q(0.5 * dof as f64, 0.5 * stat)
}

/// Šidák's significance for each of `tests` independent tests, so that all of them together
/// reject a correct sampler with probability `alpha`: 1 − (1 − α)^(1/k) (Šidák 1967), computed
/// as −expm1(ln(1 − α)/k) so that small values keep their digits.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    -((-alpha).ln_1p() / tests.max(1) as f64).exp_m1()
}

/// The chi-square statistic of a histogram against its expected counts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Statistic {
    /// Σ (o − e)² / e over the terms (single cells, or pools of cells).
    pub value: f64,
    /// Terms minus one.
    pub dof: usize,
    /// Cells that went into pools (expected below [`MIN_EXPECTED`]).
    pub pooled_cells: usize,
    /// Cells with expected 0 (left out; they carry no degree of freedom).
    pub empty_cells: usize,
    /// The first cell (index into the histogram) with expected count 0 that holds draws: the
    /// sampler puts mass where its pdf says there is none, and the test rejects outright.
    pub draws_where_none_expected: Option<usize>,
}

/// The statistic with pooling, as Mitsuba 3's `chi2.py` and pbrt-v4's `bsdfs_test.cpp` define
/// it: cells sorted by expected count; cells below [`MIN_EXPECTED`] gathered into a pool until
/// the pool reaches it (a cell at or above it that meets an unfinished pool closes the pool);
/// each single cell or pool adds (o − e)² / e and one degree of freedom; one degree of freedom
/// less for the total being fixed. Expected counts ≤ 0 count as 0.
pub fn statistic(observed: &[u64], expected: &[f64]) -> Statistic {
    assert_eq!(observed.len(), expected.len(), "histogram and expectation");
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&i, &j| expected[i].total_cmp(&expected[j]).then(i.cmp(&j)));
    let term = |o: f64, e: f64| (o - e) * (o - e) / e;
    let mut out = Statistic {
        value: 0.0,
        dof: 0,
        pooled_cells: 0,
        empty_cells: 0,
        draws_where_none_expected: None,
    };
    let mut terms = 0usize;
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for i in order {
        let (o, e) = (observed[i] as f64, expected[i]);
        if e.is_nan() || e <= 0.0 {
            out.empty_cells += 1;
            if o > 0.0 && out.draws_where_none_expected.is_none() {
                out.draws_where_none_expected = Some(i);
            }
            continue;
        }
        if e < MIN_EXPECTED || pool_e > 0.0 {
            pool_o += o;
            pool_e += e;
            out.pooled_cells += 1;
            if pool_e >= MIN_EXPECTED {
                out.value += term(pool_o, pool_e);
                terms += 1;
                (pool_o, pool_e) = (0.0, 0.0);
            }
        } else {
            out.value += term(o, e);
            terms += 1;
        }
    }
    // A pool still open holds every cell with a positive expectation, all of them together
    // below MIN_EXPECTED: it is one (small) term.
    if pool_e > 0.0 {
        out.value += term(pool_o, pool_e);
        terms += 1;
    }
    out.dof = terms.saturating_sub(1);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The expansions sum to machine precision; closed forms computed through exp, erf and
    /// lgamma carry a few ulps each, and the prefactor's exponent (up to ~10⁴ in magnitude at the
    /// largest a tested) loses up to ~10⁴ ulps of relative accuracy.
    const CLOSED_FORM: f64 = 1e-13;

    fn close(what: &str, got: f64, want: f64, rel: f64) {
        let err = (got - want).abs();
        assert!(
            err <= rel * want.abs().max(1e-300),
            "{what}: got {got:e}, want {want:e}, error {err:e} (relative {:e}), allowed {rel:e}",
            err / want.abs()
        );
    }

    #[test]
    fn chi2_gamma_p_matches_the_exponential_and_erf() {
        for &x in &[1e-6f64, 0.01, 0.3, 1.0, 1.9, 2.0, 2.1, 5.0, 20.0, 40.0] {
            close(
                &format!("P(1, {x})"),
                gamma_p(1.0, x),
                -(-x).exp_m1(),
                CLOSED_FORM,
            );
            close(
                &format!("Q(1, {x})"),
                gamma_q(1.0, x),
                (-x).exp(),
                CLOSED_FORM,
            );
            close(
                &format!("P(1/2, {x})"),
                gamma_p(0.5, x),
                libm::erf(x.sqrt()),
                CLOSED_FORM,
            );
            close(
                &format!("Q(1/2, {x})"),
                gamma_q(0.5, x),
                libm::erfc(x.sqrt()),
                1e-12,
            );
        }
    }

    #[test]
    fn chi2_gamma_q_matches_the_poisson_sum_at_integer_a() {
        // Q(n, x) = e^{−x} Σ_{k<n} x^k / k! for integer n: the probability of fewer than n events of
        // a Poisson process of mean x; summed in f64 term by term.
        for &n in &[2u32, 5, 30, 200] {
            for &r in &[0.3, 0.8, 0.97, 1.0, 1.03, 1.3, 2.0] {
                let x = r * n as f64;
                let (mut t, mut s) = ((-x).exp(), 0.0);
                for k in 0..n {
                    s += t;
                    t *= x / (k + 1) as f64;
                }
                close(&format!("Q({n}, {x})"), gamma_q(n as f64, x), s, 1e-11);
                close(
                    &format!("P({n}, {x})"),
                    gamma_p(n as f64, x),
                    1.0 - s,
                    1e-11 * s / (1.0 - s) + 1e-14,
                );
            }
        }
    }

    #[test]
    fn chi2_p_value_at_the_wilson_hilferty_median_is_one_half() {
        // Wilson & Hilferty 1931: (X/k)^{1/3} is nearly normal with mean 1 − 2/(9k), so the median
        // of χ²_k is about k (1 − 2/(9k))³. The approximation's own error in probability is
        // ~0.002 at k = 3 and falls like 1/k; the bound allows that.
        for &k in &[3usize, 10, 30, 100, 1000, 5000, 20000] {
            let kf = k as f64;
            let median = kf * (1.0 - 2.0 / (9.0 * kf)).powi(3);
            let p = chi2_p_value(median, k);
            assert!((p - 0.5).abs() < 0.01 / kf, "k = {k}: p at the median {p}");
        }
    }

    #[test]
    fn chi2_p_value_of_two_dof_is_exponential() {
        // χ²₂ is exponential with mean 2: p = e^{−s/2}, down to far tails.
        for &s in &[0.1f64, 1.0, 10.0, 100.0, 1000.0] {
            close(
                &format!("p({s}, 2)"),
                chi2_p_value(s, 2),
                (-0.5 * s).exp(),
                CLOSED_FORM,
            );
        }
        assert!(chi2_p_value(1.0, 0).is_nan());
    }

    #[test]
    fn chi2_sidak_corrects_for_k_tests() {
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-17);
        for k in [2usize, 10, 1000] {
            let s = sidak(0.01, k);
            close(
                &format!("(1 − s)^{k}"),
                (1.0 - s).powi(k as i32),
                0.99,
                1e-13,
            );
            assert!(s < 0.01 / k as f64 * 1.01 && s > 0.01 / k as f64);
        }
    }

    #[test]
    fn chi2_statistic_pools_small_cells() {
        // Sorted: five cells of 1 form one pool (expected 5, observed 8), then 10 and 10.
        let expected = [1.0, 10.0, 1.0, 1.0, 10.0, 1.0, 1.0, 0.0];
        let observed = [2u64, 13, 2, 1, 9, 2, 1, 0];
        let s = statistic(&observed, &expected);
        let want = (8.0f64 - 5.0).powi(2) / 5.0 + 9.0 / 10.0 + 1.0 / 10.0;
        assert!((s.value - want).abs() < 1e-12, "{s:?}, want {want}");
        assert_eq!((s.dof, s.pooled_cells, s.empty_cells), (2, 5, 1));
        assert_eq!(s.draws_where_none_expected, None);
        // A cell ≥ 5 that meets an open pool closes it: pool 4 + cell 6.
        let s = statistic(&[3, 1, 8], &[2.0, 2.0, 6.0]);
        assert_eq!((s.dof, s.pooled_cells), (0, 3));
        assert!((s.value - 4.0 / 10.0).abs() < 1e-12, "{s:?}");
    }

    #[test]
    fn chi2_statistic_flags_draws_where_none_are_expected() {
        let s = statistic(&[0, 4, 6], &[0.0, 5.0, 5.0]);
        assert_eq!(s.draws_where_none_expected, None);
        let s = statistic(&[1, 4, 5], &[0.0, 5.0, 5.0]);
        assert_eq!(s.draws_where_none_expected, Some(0));
        let s = statistic(&[7, 9], &[7.0, 9.0]);
        assert_eq!((s.value, s.dof), (0.0, 1));
    }
}
