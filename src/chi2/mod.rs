//! The sampling test: does a sampler draw directions with the density its pdf claims, and are
//! its weights f cos / pdf? (docs/design.md §14)
//!
//! For each outgoing direction ωo, N directions ωi are drawn (draw i from
//! [`random::draw_numbers`], so any chunking gives the same draws) and
//! counted in cells of equal solid angle over the upper hemisphere ([`Cells`]); the expected
//! count of each cell is N ∫_cell pdf dω, integrated adaptively to well under the count's own
//! noise. A chi-square test with pooling (as Mitsuba 3 and pbrt-v4 test their BSDFs) compares the
//! two histograms; a second test compares the share of draws that leave the hemisphere with
//! 1 − ∫ pdf over it; and every draw's weight and pdf are checked against the sampler's own
//! `eval_cos` and `pdf`. The tests over all ωo together reject a correct sampler with
//! probability `significance` (Šidák's correction).
//!
//! The draws are counted either on the CPU through the [`Sampler`] (every draw checked in f64)
//! or on a backend's device ([`Counting::Backend`]: the counting kernel draws the same numbers
//! in f32, counts each draw in its cell with atomics and reduces the draw checks there, so no
//! draw leaves the device); the expected counts are the f64 integrals of the sampler's f64 pdf
//! either way.
//!
//! The test knows no model: anything that implements [`Sampler`] can be judged.

pub mod cells;
mod model;
pub mod stats;

pub use cells::{Cells, Integrals};
pub use model::test_model;
pub use stats::{chi2_p_value, gamma_p, gamma_q, sidak, statistic, Statistic};

use crate::backend::{Backend, DrawCounting, DrawCounts, DrawRange, Precision, Query};
use crate::error::{Error, IntoLobe, Result};
use crate::interrupt::CancelToken;
use crate::model::Reference;
use crate::random;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// One draw of a sampler.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drawn {
    /// The direction drawn, ωi (towards the light), a unit vector in the local frame.
    pub wi: DVec3,
    /// f(ωi, ωo) cosθi / pdf, per channel; 0 for a draw below the surface.
    pub weight: DVec3,
    /// The density of the draw over the solid angle of ωi; 0 for a draw below the surface or one
    /// the sampler gave up on. For a delta draw, whatever the sampler says (not checked).
    pub pdf: f64,
    /// Whether ωi was drawn from a delta lobe (a mirror direction): such draws are counted apart.
    pub delta: bool,
}

/// What the test asks of a sampler: a draw, the density of a direction, and the value the
/// weight must equal times the pdf. The same contract as a renderer's BSDF sampling (lobe's
/// convention: ωi towards the light, ωo towards the viewer, both in the local frame, n = +z;
/// docs/design.md §14). A model's f64 reference implements it by forwarding its own sample and
/// pdf, with `eval_cos` its f times max(cosθi, 0).
pub trait Sampler: Sync {
    /// A draw for `wo` from the uniform numbers `uc` (to choose a lobe) and `u` (the direction).
    fn sample(&self, wo: DVec3, uc: f64, u: DVec2) -> Drawn;
    /// The density over solid angle with which [`Sampler::sample`] draws `wi` (delta lobes
    /// excluded).
    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64;
    /// f(ωi, ωo) cosθi, per channel (delta lobes excluded).
    fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3;
}

/// A draw's weight and pdf may differ from eval_cos / pdf and pdf(ωi) by this relative amount:
/// the same f64 formula reached along two paths agrees to ~1e-12; 1e-6 leaves room for the
/// conditioning of grazing directions and still catches every missing factor or Jacobian.
pub const DRAW_TOLERANCE: f64 = 1e-6;
/// A drawn ωi may differ from unit length by this much: a normalised vector in f64 is within a
/// few ulps of it.
pub const UNIT_TOLERANCE: f64 = 1e-9;
/// [`DRAW_TOLERANCE`] for draws made and checked in f32 on a device: the weight and
/// f cos θi / pdf, and the draw's pdf and pdf(ωi), are the same f32 formulas reached along two
/// paths (the sampled half vector against one made again from ωi + ωo, a product against a
/// quotient), each a few ulp (6e-8) off, amplified where the lobe is steep in the direction:
/// pow(cos, n) multiplies the base's relative error by n (Phong's exponent 8192: ~5e-4) and a
/// GGX lobe of α = 0.01 is ~400 times steeper in θh than in its value. 1e-2 leaves room for
/// those and still catches a missing factor or Jacobian (a factor 4 ωo·h, cosθi, a
/// component's share: errors of order 1). Measured on lavapipe over every built-in model and
/// its parameters' edges: weight 2.3e-7, pdf 0 (the samplers return their pdf function's value
/// at the drawn ωi); a GPU's looser sin, cos, exp and pow are what the margin is for.
pub const DRAW_TOLERANCE_F32: f64 = 1e-2;
/// [`UNIT_TOLERANCE`] for f32 directions: a normalised f32 vector is within a few ulp
/// (6e-8 each) of unit length, and a reflection 2 (ωo·h) h − ωo of unit f32 vectors within
/// ~1e-6; 1e-5 still catches a direction never normalised. The counting kernel's
/// `UNIT_TOLERANCE_F32` is its twin.
pub const UNIT_TOLERANCE_F32: f64 = 1e-5;
/// Draws per call of a backend's counting ([`Counting::Backend`]): the cancellation token and
/// the progress callback are heard between calls.
const DEVICE_BATCH: u64 = 1 << 24;
/// A cell whose count exceeds its expectation e by more than REFINE_SIGMA (sqrt(e) + 1) is
/// integrated again from finer rectangles ([`Cells::refine`]). Refining changes no correct
/// integral beyond its tolerance, so the test's verdict on a correct sampler stays what it was;
/// 4σ keeps the work to the few cells where the rule may have missed mass (of 5000 cells of a
/// correct sampler, about one in six runs has one beyond 4σ by chance).
pub const REFINE_SIGMA: f64 = 4.0;
/// Draws per chunk (one rayon task).
const CHUNK: u64 = 1 << 16;
/// Chunks between checks of the cancellation token and calls of the progress callback.
const BATCH: u64 = 64;

/// What to test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Options {
    /// The outgoing directions ωo, as (θo, φo) in degrees; θo in [0, 90).
    pub directions: Vec<[f64; 2]>,
    /// Draws per direction.
    pub samples: u64,
    /// The random stream: direction k's draw i uses `random::uniform(seed, i, 4k + d)`, d = 0, 1, 2
    /// for uc, u.x, u.y, so that the directions' draws are independent.
    pub seed: u32,
    /// The probability with which all tests together may reject a correct sampler.
    pub significance: f64,
    /// The cells; `None` chooses them from `samples` ([`Cells::for_samples`]).
    pub cells: Option<Cells>,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            directions: vec![[0.0, 0.0], [30.0, 0.0], [60.0, 0.0], [85.0, 0.0]],
            samples: 1 << 20,
            seed: 0,
            significance: 0.01,
            cells: None,
        }
    }
}

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

/// The draw-by-draw checks of one direction.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DrawChecks {
    /// The relative weight and pdf error allowed: [`DRAW_TOLERANCE`] for draws checked in f64,
    /// [`DRAW_TOLERANCE_F32`] for draws checked on a device in f32.
    pub tolerance: f64,
    /// The difference from unit length allowed: [`UNIT_TOLERANCE`] or [`UNIT_TOLERANCE_F32`].
    pub unit_tolerance: f64,
    /// Draws whose ωi or pdf is NaN or infinite, or whose pdf is negative.
    pub invalid: u64,
    /// Draws whose ωi is off unit length by more than `unit_tolerance` (counted in their
    /// normalised direction's cell).
    pub non_unit: u64,
    /// Draws above the horizon with pdf 0 (counted as leaving the hemisphere).
    pub zero_pdf: u64,
    /// Draws with a NaN or infinite weight.
    pub non_finite_weight: u64,
    /// Draws below the horizon or with pdf 0 whose weight is not 0.
    pub nonzero_weight_outside: u64,
    /// Draws below the horizon reported with a pdf other than 0 (the contract asks for 0).
    pub nonzero_pdf_below: u64,
    /// The largest relative difference |w − eval_cos/pdf| / max(|w|, |eval_cos/pdf|) over
    /// channels and draws counted in cells, and the draw (its index i) where it occurred.
    pub max_weight_error: f64,
    /// The draw with the largest weight error (None for draws counted on a device, which
    /// reduces the errors without their indices).
    pub worst_weight_draw: Option<u64>,
    /// The largest relative difference between a draw's pdf and pdf(ωi, ωo).
    pub max_pdf_error: f64,
    /// The draw with the largest pdf error.
    pub worst_pdf_draw: Option<u64>,
}

impl DrawChecks {
    /// Whether every draw is finite, of unit length, with weight and pdf within `tolerance`
    /// of eval_cos / pdf and pdf(ωi), and weight 0 when it leaves.
    pub fn consistent(&self) -> bool {
        self.invalid == 0
            && self.non_unit == 0
            && self.non_finite_weight == 0
            && self.nonzero_weight_outside == 0
            && self.nonzero_pdf_below == 0
            && self.max_weight_error <= self.tolerance
            && self.max_pdf_error <= self.tolerance
    }
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
    /// expected (more than [`REFINE_SIGMA`] σ).
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
    /// name ([`Backend::name`]).
    pub backend: String,
    /// Where the density the expected counts integrate was evaluated: "f64" for the sampler's
    /// f64 pdf, or the backend's name and "(f32)" for a density that exists only in a device's
    /// kernels ([`run_on_device`]). The integration itself is in f64 either way.
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

/// ωo from (θo, φo) in degrees.
fn direction_deg(theta: f64, phi: f64) -> DVec3 {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Below this, values are compared as equal: a product whose factors are normal f64 numbers can
/// land among the subnormals (below 2.2e-308), which keep ever fewer significant bits, and the
/// same weight reached along two paths then differs in its leading digits (a Phong lobe of
/// exponent 1000 in a channel whose diffuse part is 0 reaches 1e-310 far from its peak).
/// 2⁵² times the smallest normal number leaves every bit of a normal result's precision.
pub const TINY: f64 = f64::MIN_POSITIVE * (1u64 << 52) as f64;

/// |a − b| / max(|a|, |b|), 0 when both are below [`TINY`].
fn relative(a: f64, b: f64) -> f64 {
    let m = a.abs().max(b.abs());
    if m < TINY {
        0.0
    } else if !m.is_finite() {
        if a == b {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        (a - b).abs() / m
    }
}

/// The counts of a range of draws.
#[derive(Clone)]
struct Tally {
    hist: Vec<u64>,
    leaked: u64,
    delta: u64,
    checks: DrawChecks,
}

impl Tally {
    /// No draws yet, to be checked in f64.
    fn new(cells: usize) -> Tally {
        Tally {
            hist: vec![0; cells],
            leaked: 0,
            delta: 0,
            checks: DrawChecks {
                tolerance: DRAW_TOLERANCE,
                unit_tolerance: UNIT_TOLERANCE,
                ..DrawChecks::default()
            },
        }
    }

    /// A backend's counts of draws made and checked in f32 on its device.
    fn from_device(d: DrawCounts) -> Tally {
        Tally {
            hist: d.cells,
            leaked: d.lost,
            delta: d.delta,
            checks: DrawChecks {
                tolerance: DRAW_TOLERANCE_F32,
                unit_tolerance: UNIT_TOLERANCE_F32,
                invalid: d.invalid,
                non_unit: d.non_unit,
                zero_pdf: d.zero_pdf,
                non_finite_weight: d.non_finite_weight,
                nonzero_weight_outside: d.nonzero_weight_outside,
                nonzero_pdf_below: d.nonzero_pdf_below,
                max_weight_error: d.max_weight_error,
                worst_weight_draw: None,
                max_pdf_error: d.max_pdf_error,
                worst_pdf_draw: None,
            },
        }
    }

    /// Keeps the larger error; on a tie the earlier draw, so the result does not depend on the
    /// order chunks are merged in.
    fn worse(a: (f64, Option<u64>), b: (f64, Option<u64>)) -> (f64, Option<u64>) {
        match a.0.total_cmp(&b.0) {
            std::cmp::Ordering::Greater => a,
            std::cmp::Ordering::Less => b,
            std::cmp::Ordering::Equal => (a.0, a.1.min(b.1).or(a.1).or(b.1)),
        }
    }

    fn merge(mut self, other: Tally) -> Tally {
        self.checks.tolerance = self.checks.tolerance.max(other.checks.tolerance);
        self.checks.unit_tolerance = self.checks.unit_tolerance.max(other.checks.unit_tolerance);
        for (a, b) in self.hist.iter_mut().zip(&other.hist) {
            *a += b;
        }
        self.leaked += other.leaked;
        self.delta += other.delta;
        let (c, o) = (&mut self.checks, &other.checks);
        c.invalid += o.invalid;
        c.non_unit += o.non_unit;
        c.zero_pdf += o.zero_pdf;
        c.non_finite_weight += o.non_finite_weight;
        c.nonzero_weight_outside += o.nonzero_weight_outside;
        c.nonzero_pdf_below += o.nonzero_pdf_below;
        (c.max_weight_error, c.worst_weight_draw) = Tally::worse(
            (c.max_weight_error, c.worst_weight_draw),
            (o.max_weight_error, o.worst_weight_draw),
        );
        (c.max_pdf_error, c.worst_pdf_draw) = Tally::worse(
            (c.max_pdf_error, c.worst_pdf_draw),
            (o.max_pdf_error, o.worst_pdf_draw),
        );
        self
    }

    fn draw<S: Sampler>(&mut self, s: &S, cells: &Cells, wo: DVec3, i: u64, d: Drawn) {
        let c = &mut self.checks;
        if d.delta {
            self.delta += 1;
            return;
        }
        if !d.wi.is_finite() || d.pdf.is_nan() || d.pdf.is_infinite() || d.pdf < 0.0 {
            c.invalid += 1;
            return;
        }
        if !d.weight.is_finite() {
            c.non_finite_weight += 1;
        }
        // pdf and eval_cos see ωi as drawn; only the cell is found from its normalised form.
        let wi = d.wi;
        let len = wi.length();
        if (len - 1.0).abs() > UNIT_TOLERANCE {
            c.non_unit += 1;
        }
        let cell = if d.pdf > 0.0 {
            cells.index(wi / len)
        } else {
            None
        };
        let Some(cell) = cell else {
            self.leaked += 1;
            if wi.z > 0.0 {
                c.zero_pdf += 1;
            } else if d.pdf != 0.0 {
                c.nonzero_pdf_below += 1;
            }
            if d.weight != DVec3::ZERO {
                c.nonzero_weight_outside += 1;
            }
            return;
        };
        self.hist[cell] += 1;
        let pdf = s.pdf(wi, wo);
        let e = relative(d.pdf, pdf);
        let e = if e.is_nan() { f64::INFINITY } else { e };
        if e > c.max_pdf_error {
            (c.max_pdf_error, c.worst_pdf_draw) = (e, Some(i));
        }
        let want = s.eval_cos(wi, wo) / d.pdf;
        let e = (0..3)
            .map(|k| relative(d.weight[k], want[k]))
            .fold(
                0.0,
                |m: f64, x| if x.is_nan() { f64::INFINITY } else { m.max(x) },
            );
        if e > c.max_weight_error {
            (c.max_weight_error, c.worst_weight_draw) = (e, Some(i));
        }
    }
}

/// Where the test's draws are made and counted.
#[derive(Clone, Copy)]
pub enum Counting<'a> {
    /// On the CPU's threads through the [`Sampler`], every draw checked in f64.
    Sampler,
    /// On a backend's device ([`Backend::draw_counts`]): the sampler of the query's first set,
    /// drawn and checked in f32 where it runs, with the same numbers as the [`Sampler`]'s
    /// draws (the same model), counted in the same cells. The backend must count on a device.
    Backend(&'a dyn Backend, Query<'a>),
}

impl Counting<'_> {
    /// Where the draws are made, as a report names it.
    fn name(&self) -> String {
        match self {
            Counting::Sampler => "cpu (f64 reference)".into(),
            Counting::Backend(b, _) => b.name(),
        }
    }

    /// The counting of `backend`: on its device where it counts there (an f32 backend), else
    /// through the sampler.
    pub fn on<'a>(backend: &'a dyn Backend, query: Query<'a>) -> Counting<'a> {
        if backend.precision() == Precision::F64 {
            Counting::Sampler
        } else {
            Counting::Backend(backend, query)
        }
    }
}

/// Runs the test for `sampler`, drawn and counted on the CPU. `progress(done, total)` is called
/// on the calling thread between batches of draws (total = samples × directions); `cancel` is
/// checked at the same points.
pub fn run<S: Sampler>(
    sampler: &S,
    options: &Options,
    cancel: Option<&CancelToken>,
    progress: impl FnMut(u64, u64),
) -> Result<Report> {
    run_counted(sampler, Counting::Sampler, options, cancel, progress)
}

/// [`run`] with the draws counted where `counting` says; the expected counts are the f64
/// integrals of `sampler`'s pdf either way.
pub fn run_counted<S: Sampler>(
    sampler: &S,
    counting: Counting<'_>,
    options: &Options,
    cancel: Option<&CancelToken>,
    progress: impl FnMut(u64, u64),
) -> Result<Report> {
    let mut density =
        |wo: DVec3, wi: &[DVec3]| Ok(wi.par_iter().map(|&w| sampler.pdf(w, wo)).collect());
    let expected = Expected {
        density: &mut density,
        name: "f64".into(),
    };
    run_with(Some(sampler), counting, expected, options, cancel, progress)
}

/// The test of the sampler of `query`'s first set where it exists only on `backend`'s device
/// (a `.brdf` file's `sampleL` and `pdfL`): drawn and counted there, the expected counts the
/// f64 integrals of the density the backend evaluates ([`Backend::pdf`], in f32 on a device).
pub fn run_on_device(
    backend: &dyn Backend,
    query: Query<'_>,
    options: &Options,
    cancel: Option<&CancelToken>,
    progress: impl FnMut(u64, u64),
) -> Result<Report> {
    if backend.precision() == Precision::F64 {
        return Err(Error::Invalid(format!(
            "the backend {} draws on no device; this sampler exists only in a device's kernels",
            backend.name()
        )));
    }
    let mut density = |wo: DVec3, wi: &[DVec3]| {
        if let Some(c) = cancel {
            c.check()?;
        }
        backend.pdf(query, wo, wi).lobe()
    };
    let expected = Expected {
        density: &mut density,
        name: format!("{} (f32)", backend.name()),
    };
    run_with(
        None::<&Reference>,
        Counting::Backend(backend, query),
        expected,
        options,
        cancel,
        progress,
    )
}

/// The density the expected counts integrate: pdf(ωi, ωo) at many ωi for one ωo, and where it
/// is evaluated, as the report names it.
struct Expected<'a> {
    density: &'a mut dyn FnMut(DVec3, &[DVec3]) -> Result<Vec<f64>>,
    name: String,
}

/// The test with the draws counted where `counting` says (through `sampler` on the CPU, which
/// must then be given) and the expected counts from `expected`.
fn run_with<S: Sampler>(
    sampler: Option<&S>,
    counting: Counting<'_>,
    expected: Expected<'_>,
    options: &Options,
    cancel: Option<&CancelToken>,
    mut progress: impl FnMut(u64, u64),
) -> Result<Report> {
    let Expected {
        density,
        name: density_name,
    } = expected;
    let start = Instant::now();
    if options.directions.is_empty() {
        return Err(Error::Invalid(
            "the sampling test needs at least one direction ωo".into(),
        ));
    }
    if options.samples == 0 {
        return Err(Error::Invalid("the sampling test needs samples ≥ 1".into()));
    }
    if !(options.significance > 0.0 && options.significance < 1.0) {
        return Err(Error::Invalid(format!(
            "significance {} is outside (0, 1)",
            options.significance
        )));
    }
    if let Some(&[t, p]) = options
        .directions
        .iter()
        .find(|[t, p]| !(t.is_finite() && p.is_finite() && (0.0..90.0).contains(t)))
    {
        return Err(Error::Invalid(format!(
            "direction θo = {t}°, φo = {p}°: θo must be in [0, 90) degrees and φo finite"
        )));
    }
    let cells = options
        .cells
        .unwrap_or_else(|| Cells::for_samples(options.samples));
    if cells.is_empty() {
        return Err(Error::Invalid(format!(
            "cells {} × {}: the sampling test needs at least one step in φ and in cosθ",
            cells.n_phi, cells.n_cos
        )));
    }
    let tests = 2 * options.directions.len();
    let corrected = sidak(options.significance, tests);
    let total = options
        .samples
        .saturating_mul(options.directions.len() as u64);
    let mut done = 0u64;
    let mut results = Vec::with_capacity(options.directions.len());
    for (k, &[theta, phi]) in options.directions.iter().enumerate() {
        let wo = direction_deg(theta, phi);
        let group = k as u32;
        let t0 = Instant::now();
        let chunks = options.samples.div_ceil(CHUNK);
        let mut tally = Tally::new(cells.len());
        let mut next = 0u64;
        if let Counting::Backend(backend, query) = counting {
            tally = count_on_device(
                backend,
                query,
                wo,
                options,
                group,
                cells,
                cancel,
                &mut |n| {
                    done += n;
                    progress(done, total)
                },
            )?;
            next = chunks;
        }
        while next < chunks {
            let Some(sampler) = sampler else {
                return Err(Error::Invalid(
                    "the sampling test on the CPU's threads needs the sampler's f64 twin".into(),
                ));
            };
            if let Some(c) = cancel {
                c.check()?;
            }
            let end = (next + BATCH).min(chunks);
            let part = (next..end)
                .into_par_iter()
                .fold(
                    || Tally::new(cells.len()),
                    |mut t, chunk| {
                        let last = ((chunk + 1) * CHUNK).min(options.samples);
                        for i in chunk * CHUNK..last {
                            let (uc, u) = random::draw_numbers(options.seed, i, group);
                            let d = sampler.sample(wo, uc, u);
                            t.draw(sampler, &cells, wo, i, d);
                        }
                        t
                    },
                )
                .reduce(|| Tally::new(cells.len()), Tally::merge);
            tally = tally.merge(part);
            done += (end * CHUNK).min(options.samples) - (next * CHUNK).min(options.samples);
            next = end;
            progress(done, total);
        }
        let sampling_seconds = t0.elapsed().as_secs_f64();
        if let Some(c) = cancel {
            c.check()?;
        }
        let t1 = Instant::now();
        let mut pdf = |wi: &[DVec3]| density(wo, wi);
        let mut ints = cells.integrate_density(&mut pdf, options.samples)?;
        // Cells holding far more draws than expected are integrated again, finer: a lobe can
        // pass between one rectangle's nodes unseen.
        let n = options.samples as f64;
        let suspects: Vec<usize> = (0..cells.len())
            .filter(|&c| {
                let e = (n * ints.probability[c]).max(0.0);
                tally.hist[c] as f64 > e + REFINE_SIGMA * (e.sqrt() + 1.0)
            })
            .collect();
        if !suspects.is_empty() {
            cells.refine_density(&mut pdf, options.samples, &mut ints, &suspects)?;
        }
        let integration_seconds = t1.elapsed().as_secs_f64();
        results.push(judge(
            &cells,
            options.samples,
            [theta, phi],
            wo,
            tally,
            ints,
            corrected,
            [sampling_seconds, integration_seconds],
        ));
    }
    Ok(Report {
        options: options.clone(),
        backend: counting.name(),
        density: density_name,
        tests,
        corrected_significance: corrected,
        passed: results.iter().all(|r| r.passed),
        directions: results,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// One direction's draws counted on `backend`'s device, `DEVICE_BATCH` at a time; `advance`
/// hears each batch's draws.
#[allow(clippy::too_many_arguments)] // one call site: the direction's part of run_counted
fn count_on_device(
    backend: &dyn Backend,
    query: Query<'_>,
    wo: DVec3,
    options: &Options,
    group: u32,
    cells: Cells,
    cancel: Option<&CancelToken>,
    advance: &mut dyn FnMut(u64),
) -> Result<Tally> {
    let mut tally: Option<Tally> = None;
    let mut first = 0u64;
    while first < options.samples {
        if let Some(c) = cancel {
            c.check()?;
        }
        let n = DEVICE_BATCH.min(options.samples - first);
        let counting = DrawCounting {
            range: DrawRange {
                seed: options.seed,
                group,
                first,
                count: n as usize,
            },
            n_phi: cells.n_phi,
            n_cos: cells.n_cos,
        };
        let counts = backend
            .draw_counts(query, wo, counting, cancel)
            .ok_or_else(|| {
                Error::Invalid(format!(
                    "the backend {} counts no draws on a device; run the sampling test on the CPU",
                    backend.name()
                ))
            })?
            .lobe()?;
        if counts.cells.len() != cells.len() {
            return Err(Error::Invalid(format!(
                "the backend {} counted {} cells of {}",
                backend.name(),
                counts.cells.len(),
                cells.len()
            )));
        }
        let part = Tally::from_device(counts);
        tally = Some(match tally {
            Some(t) => t.merge(part),
            None => part,
        });
        first += n;
        advance(n);
    }
    Ok(tally.unwrap_or_else(|| Tally::new(cells.len())))
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
fn judge(
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

#[cfg(test)]
mod tests;
