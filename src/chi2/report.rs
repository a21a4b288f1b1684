//! The sampling test's verdict: each direction's result from its counts and integrals (the
//! chi-square statistic, the share of draws outside the hemisphere, the draw checks), and the
//! report over all directions (docs/design.md §14).

use super::stats::{self, chi2_p_value, gamma_p, gamma_q, statistic, Statistic};
use super::tally::{DrawChecks, Tally};
use super::{Cells, Integrals, Options};
use glam::DVec3;
use serde::Serialize;

/// The cell where observed and expected counts differ most.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WorstCell {
    /// Index into the histograms.
    pub cell: usize,
    /// Its range of φ, degrees.
    pub phi_deg: [f64; 2],
    /// Its range of cosθ.
    pub cos_theta: [f64; 2],
    /// Draws counted in it.
    pub observed: u64,
    /// Draws expected in it.
    pub expected: f64,
    /// (observed − expected) / sqrt(expected); infinite where none are expected.
    pub sigma: f64,
}

/// The test at one outgoing direction.
#[derive(Clone, Debug, Serialize)]
pub struct DirectionResult {
    /// θo, degrees.
    pub theta_o_deg: f64,
    /// φo, degrees.
    pub phi_o_deg: f64,
    /// ωo.
    pub wo: [f64; 3],
    /// The cells.
    pub cells: Cells,
    /// Draws counted per cell.
    pub observed: Vec<u64>,
    /// Draws expected per cell: N ∫_cell pdf dω.
    pub expected: Vec<f64>,
    /// Each expected count's error estimate, in draws.
    pub expected_error: Vec<f64>,
    /// ∫ pdf over the upper hemisphere (the cells' sum).
    pub integral: f64,
    /// The error estimate of `integral`.
    pub integral_error: f64,
    /// The largest count error estimate against the count's noise over cells,
    /// N · error / sqrt(max(expected, 1)): ≪ 1 for a valid test.
    pub expected_accuracy: f64,
    /// pdf evaluations spent on the expected counts.
    pub pdf_evaluations: u64,
    /// Cells whose integral stopped at the rectangle budget short of its tolerance.
    pub unconverged_cells: usize,
    /// Cells integrated again from finer rectangles because they held far more draws than
    /// expected (more than [`REFINE_SIGMA`](super::REFINE_SIGMA) σ).
    pub refined_cells: usize,
    /// Draws below the horizon (cosθi ≤ 0) or with pdf 0.
    pub leaked: u64,
    /// Draws from delta lobes.
    pub delta: u64,
    /// leaked / N.
    pub leak_share: f64,
    /// delta / N.
    pub delta_share: f64,
    /// 1 − ∫ pdf over the hemisphere: the share of draws expected to leave it (leaks and delta
    /// draws together).
    pub missing_mass: f64,
    /// Two-sided p-value of the draws outside the cells (leaked, delta and invalid ones) against
    /// N · missing_mass: a normal test with binomial variance, plus the integral's error.
    pub outside_p_value: f64,
    /// The chi-square statistic with its pooling.
    pub statistic: Statistic,
    /// The chi-square p-value (NaN with no degree of freedom).
    pub p_value: f64,
    /// Where observed and expected differ most.
    pub worst_cell: Option<WorstCell>,
    /// Draw-by-draw consistency.
    pub draws: DrawChecks,
    /// Whether the histograms agree: no draw where none is expected, finite expected counts,
    /// p-value at least the corrected significance.
    pub histogram_passed: bool,
    /// Whether the draws outside the hemisphere agree with 1 − ∫ pdf at the corrected significance.
    pub outside_passed: bool,
    /// All three: histogram, outside share and [`DrawChecks::consistent`].
    pub passed: bool,
    /// Why it failed, in sentences; empty when it passed.
    pub failures: Vec<String>,
    /// Seconds spent drawing and counting.
    pub sampling_seconds: f64,
    /// Seconds spent integrating the expected counts.
    pub integration_seconds: f64,
}

/// The test over all directions.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// What was asked.
    pub options: Options,
    /// Where the draws were made and counted: "cpu (f64 reference)" or the device's backend
    /// name ([`Backend::name`](crate::backend::Backend::name)).
    pub backend: String,
    /// Where the density the expected counts integrate was evaluated: "f64" for the sampler's
    /// f64 pdf, or the backend's name and "(f32)" for a density that exists only in a device's
    /// kernels ([`run_on_device`](super::run_on_device)). The integration itself is in f64 either way.
    pub density: String,
    /// Tests made: two per direction (the histogram and the outside share).
    pub tests: usize,
    /// Šidák's significance per test.
    pub corrected_significance: f64,
    /// Whether every direction passed.
    pub passed: bool,
    /// Per direction, in the order asked.
    pub directions: Vec<DirectionResult>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl Report {
    /// The report as JSON (histograms included).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }

    /// The report of a model's sampler as `lobe chi2 --format json` prints it (and Python's
    /// `Session.chi2` returns it): [`Report::to_json`] with the model, its parameters and where
    /// it was drawn.
    pub fn to_json_for(&self, params: &crate::model::ParamSet) -> serde_json::Value {
        let mut j = self.to_json();
        j["model"] = serde_json::json!(params.model().name());
        j["parameters"] = params.to_json();
        j
    }
}

/// Two-sided p-value of `outside` draws of `samples` leaving the hemisphere where a share
/// `missing` (known to ± `uncertainty`) is expected to. The count is binomial; it is tested as
/// Poisson on whichever side (outside or inside) has the smaller expectation, whose variance
/// exceeds the binomial one by at most a factor 2 there (a test that errs towards passing), and
/// which stays exact for the small expectations (a correct sampler that never leaks has
/// missing ≈ 0). The expectation is taken as favourably as the uncertainty allows.
fn outside_p_value(outside: u64, samples: u64, missing: f64, uncertainty: f64) -> f64 {
    let n = samples as f64;
    if missing + uncertainty < 0.0 || missing - uncertainty > 1.0 {
        return 0.0;
    }
    let (k, share) = if missing <= 0.5 {
        (outside, missing)
    } else {
        (samples - outside, 1.0 - missing)
    };
    let (lo, hi) = (
        (n * (share - uncertainty)).max(0.0),
        (n * (share + uncertainty)).max(0.0),
    );
    let lambda = (k as f64).clamp(lo, hi);
    if lambda == 0.0 {
        return if k == 0 { 1.0 } else { 0.0 };
    }
    // P(X ≥ k) = P(k, λ) and P(X ≤ k) = Q(k + 1, λ) for X ~ Poisson(λ).
    let upper = if k == 0 {
        1.0
    } else {
        gamma_p(k as f64, lambda)
    };
    let lower = gamma_q(k as f64 + 1.0, lambda);
    (2.0 * upper.min(lower)).min(1.0)
}

/// The verdict at one direction from its counts and integrals.
#[allow(clippy::too_many_arguments)] // one call site; the pieces are the test's stages
pub(super) fn judge(
    cells: &Cells,
    samples: u64,
    [theta, phi]: [f64; 2],
    wo: DVec3,
    tally: Tally,
    ints: Integrals,
    corrected: f64,
    [sampling_seconds, integration_seconds]: [f64; 2],
) -> DirectionResult {
    let n = samples as f64;
    let expected: Vec<f64> = ints.probability.iter().map(|p| n * p).collect();
    let statistic = statistic(&tally.hist, &expected);
    let p_value = if statistic.draws_where_none_expected.is_some() {
        0.0
    } else {
        chi2_p_value(statistic.value, statistic.dof)
    };
    // Cells expected to hold fewer than MIN_EXPECTED draws are pooled by the statistic and
    // their σ means little; they are passed over unless none was expected and some came.
    let worst_cell = (0..cells.len())
        .filter_map(|c| {
            let (o, e) = (tally.hist[c] as f64, expected[c]);
            if e >= stats::MIN_EXPECTED {
                Some((c, (o - e) / e.sqrt()))
            } else if (e.is_nan() || e <= 0.0) && o > 0.0 {
                Some((c, f64::INFINITY))
            } else {
                None
            }
        })
        .fold(None, |best: Option<(usize, f64)>, (c, s)| match best {
            Some((_, b)) if s.abs() <= b.abs() => best,
            _ => Some((c, s)),
        })
        .map(|(c, sigma)| {
            let (phi, mu) = cells.bounds(c);
            WorstCell {
                cell: c,
                phi_deg: phi.map(f64::to_degrees),
                cos_theta: mu,
                observed: tally.hist[c],
                expected: expected[c],
                sigma,
            }
        });

    let outside = tally.leaked + tally.delta + tally.checks.invalid;
    let missing = 1.0 - ints.total;
    // The integral's uncertainty: its error estimate plus the rounding of the sum over cells.
    let uncertainty = ints.total_error + cells.len() as f64 * f64::EPSILON * ints.total.abs();
    let outside_p_value = outside_p_value(outside, samples, missing, uncertainty);
    let mut failures = Vec::new();
    if let Some(c) = statistic.draws_where_none_expected {
        let (phi, mu) = cells.bounds(c);
        failures.push(format!(
            "{} draws fell in cell {c} (φ {:.2}°–{:.2}°, cosθ {:.4}–{:.4}) where the pdf integrates to 0",
            tally.hist[c],
            phi[0].to_degrees(),
            phi[1].to_degrees(),
            mu[0],
            mu[1]
        ));
    }
    if ints.non_finite_cells > 0 || ints.negative_cells > 0 {
        failures.push(format!(
            "the pdf integrates to NaN, infinity or a negative value over {} cells",
            ints.non_finite_cells + ints.negative_cells
        ));
    }
    let histogram_passed = failures.is_empty() && p_value >= corrected;
    if !histogram_passed && failures.is_empty() {
        failures.push(format!(
            "histogram: chi-square {:.1} over {} dof, p = {:.3e} < {:.3e}",
            statistic.value, statistic.dof, p_value, corrected
        ));
    }
    let outside_passed = outside_p_value >= corrected;
    if missing + uncertainty < 0.0 {
        failures.push(format!(
            "the pdf integrates to {:.9} over the hemisphere, more than 1",
            ints.total
        ));
    } else if !outside_passed {
        failures.push(format!(
            "{outside} draws left the hemisphere (leaked {}, delta {}, invalid {}) where 1 − ∫pdf = {missing:.6e} expects {:.1}: p = {outside_p_value:.3e}",
            tally.leaked,
            tally.delta,
            tally.checks.invalid,
            n * missing
        ));
    }
    let c = &tally.checks;
    if !c.consistent() {
        failures.push(format!(
            "draws: {} invalid, {} not of unit length, {} with non-finite weight, {} leaving with a weight, {} below the horizon with a pdf; largest weight error {:.3e} (draw {:?}), pdf error {:.3e} (draw {:?}), allowed {:e}",
            c.invalid,
            c.non_unit,
            c.non_finite_weight,
            c.nonzero_weight_outside,
            c.nonzero_pdf_below,
            c.max_weight_error,
            c.worst_weight_draw,
            c.max_pdf_error,
            c.worst_pdf_draw,
            c.tolerance
        ));
    }
    let passed = histogram_passed && outside_passed && c.consistent();
    DirectionResult {
        theta_o_deg: theta,
        phi_o_deg: phi,
        wo: wo.to_array(),
        cells: *cells,
        expected_error: ints.error.iter().map(|e| n * e).collect(),
        integral: ints.total,
        integral_error: ints.total_error,
        expected_accuracy: ints.accuracy,
        pdf_evaluations: ints.evaluations,
        unconverged_cells: ints.unconverged_cells,
        refined_cells: ints.refined_cells,
        leaked: tally.leaked,
        delta: tally.delta,
        leak_share: tally.leaked as f64 / n,
        delta_share: tally.delta as f64 / n,
        missing_mass: missing,
        outside_p_value,
        statistic,
        p_value,
        worst_cell,
        histogram_passed,
        outside_passed,
        passed,
        failures,
        sampling_seconds,
        integration_seconds,
        expected,
        observed: tally.hist,
        draws: tally.checks,
    }
}
