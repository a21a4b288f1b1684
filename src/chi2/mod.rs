//! The sampling test: does a sampler draw directions with the density its pdf claims, and are
//! its weights f cos / pdf? (docs/design.md §14)
//!
//! For each outgoing direction ωo, N directions ωi are drawn (draw i from
//! [`random::draw_numbers`], so any chunking gives the same draws) and
//! counted in cells of equal solid angle over the upper hemisphere ([`Cells`]); the expected
//! count of each cell is N ∫_cell pdf dω, integrated adaptively to well under the count's own
//! noise. A chi-square test with pooling (as Mitsuba 3 and pbrt-v4 test their BSDFs) compares the
//! two histograms; a second test compares the share of draws that leave the hemisphere with
//! 1 − ∫ pdf over it; and the weight and pdf of each direction's first
//! [`Options::checked_draws`] draws (every draw at the default count) are checked against the
//! sampler's own `eval_cos` and `pdf`. The tests over all ωo together reject a correct sampler with
//! probability `significance` (Šidák's correction).
//!
//! The draws are counted either on the CPU through the [`Sampler`] (every draw checked in f64)
//! or on a backend's device ([`Counting::Backend`]: the counting kernel draws the same numbers
//! in f32, counts each draw in its cell and reduces the draw checks there, so no draw leaves
//! the device); the expected counts are the f64 integrals of the sampler's f64 pdf
//! either way.
//!
//! The test knows no model: anything that implements [`Sampler`] can be judged.

pub mod cells;
mod model;
mod report;
pub mod stats;
mod tally;

pub use cells::{Cells, Integrals};
pub use model::test_model;
pub use report::{DirectionResult, Report, WorstCell};
pub use stats::{chi2_p_value, gamma_p, gamma_q, sidak, statistic, Statistic};
pub use tally::{DrawChecks, TINY};

use report::judge;
use tally::Tally;

use crate::backend::{Backend, DrawCounting, DrawRange, Precision, Query};
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
/// Draws per direction whose weight and pdf are checked by default ([`Options::checked_draws`]):
/// every draw of the default 2²⁴. The checks evaluate f and the pdf again at each draw's ωi,
/// which costs about as much as the draw itself; a weight or pdf that is wrong anywhere the
/// sampler goes shows in a sample of 2²⁴ draws, while the histogram, the test that needs the
/// count, keeps every draw.
pub const CHECKED_DRAWS: u64 = 1 << 24;
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
    /// How many of each direction's first draws have their weight checked against
    /// eval_cos / pdf and their pdf against pdf(ωi) (and their weight for being finite, and 0
    /// where the draw leaves); `None` for every draw. Every draw is counted, and checked for
    /// being finite, of unit length and with pdf 0 where it leaves.
    pub checked_draws: Option<u64>,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            directions: vec![[0.0, 0.0], [30.0, 0.0], [60.0, 0.0], [85.0, 0.0]],
            samples: 1 << 20,
            seed: 0,
            significance: 0.01,
            cells: None,
            checked_draws: Some(CHECKED_DRAWS),
        }
    }
}

/// ωo from (θo, φo) in degrees.
fn direction_deg(theta: f64, phi: f64) -> DVec3 {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
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
        let pairs: Vec<(DVec3, DVec3)> = wi.iter().map(|&w| (w, wo)).collect();
        backend.pdf(query, &pairs).lobe()
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
    let checked = options
        .checked_draws
        .map_or(options.samples, |n| n.min(options.samples));
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
                (group, checked),
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
                            t.draw(sampler, &cells, wo, (i, i < checked), d);
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
        tally.checks.checked_draws = checked;
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

/// One direction's draws counted on `backend`'s device, `DEVICE_BATCH` at a time, the first
/// `checked` with the weight checks; `advance` hears each batch's draws.
#[allow(clippy::too_many_arguments)] // one call site: the direction's part of run_counted
fn count_on_device(
    backend: &dyn Backend,
    query: Query<'_>,
    wo: DVec3,
    options: &Options,
    (group, checked): (u32, u64),
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
            checked: checked.saturating_sub(first).min(n),
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

#[cfg(test)]
mod tests;
