//! Fitting an analytic model's free parameters to a target: a model, a `.brdf` file, a MERL
//! file or a lobe table (`lobe fit`).
//!
//! 1. The target becomes samples ([`target`]): direction pairs at MERL's half/difference bin
//!    centres (or a table's own cells), its values there, each bin's cosθi and solid-angle
//!    weight, missing data left out, and at most [`FitOptions::max_bins`] of them, an evenly
//!    spaced deterministic subset.
//! 2. The loss is one of [`crate::loss`]: by default the cosine-weighted log error
//!    E = sqrt(Σ_c Σ_bins w [ln(1 + cosθi·f_target) − ln(1 + cosθi·f_fit)]² / (3 Σ w)),
//!    or the relative L2 sqrt(Σ w |f_fit − f_target|² / Σ w |f_target|²).
//! 3. The free keys span an unbounded vector z mapped into their ranges by a logistic function
//!    ([`space`]); Nelder–Mead (argmin) runs from several Halton starts in lock-step
//!    ([`batch`]; the starts' threads and rounds in `starts.rs`), so each round's candidates of
//!    every start are evaluated together: one dispatch of the pairs kernel on the GPU, or the
//!    f64 reference on the CPU.
//! 4. The best start's parameters are the fit; the report adds each start's result, the
//!    per-channel loss, and the directional albedo of target and fit side by side.

pub mod batch;
pub mod space;
mod starts;
pub mod target;

use crate::backend::Query;
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::integrate::{self, PointAlbedo};
use crate::loss::{ChannelErrors, LossKind};
use crate::model::ParamSet;
use anyhow::{Context, Result};
use glam::DVec3;
use starts::{run_starts, start_reports, Rounds};
use std::time::Instant;

pub use space::Space;
pub use target::{Samples, Target};

/// The default sample size: 2^16 bins. A MERL file has ~900,000 valid bins above the horizon;
/// 65,536 of them, evenly spread, hold the lobe's shape at every angle and keep a round of four
/// starts at 262,144 evaluations.
pub const DEFAULT_MAX_BINS: usize = 1 << 16;

/// The default number of starts.
pub const DEFAULT_STARTS: usize = 4;

/// The default bound on Nelder–Mead iterations per start.
pub const DEFAULT_MAX_ITERS: u64 = 400;

/// A start stops once the standard deviation of the loss over its simplex falls below this:
/// 1e-8 is far below any difference a plot or a parameter's third digit shows (a GGX fit to a
/// MERL file stops with α within 1e-7 of the truth), and near the f32 noise of a GPU
/// evaluation of the loss, below which more iterations only chase rounding.
pub const SD_TOLERANCE: f64 = 1e-8;

/// Most starts: each is a thread and a block of parameters per round.
pub const MAX_STARTS: usize = 64;

/// View cosines μ = cosθo at which the report compares the directional albedo of target and fit.
pub const ALBEDO_MUS: [f64; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

/// What a fit needs besides the target and the model.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// The distance minimised.
    pub loss: LossKind,
    /// Most target bins used (0: all).
    pub max_bins: usize,
    /// Nelder–Mead runs, from the first Halton points of the box.
    pub starts: usize,
    /// Most iterations per start.
    pub max_iters: u64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            loss: LossKind::default(),
            max_bins: DEFAULT_MAX_BINS,
            starts: DEFAULT_STARTS,
            max_iters: DEFAULT_MAX_ITERS,
        }
    }
}

/// Where a fit stands after a round: given to the progress callback.
#[derive(Clone, Copy, Debug)]
pub struct FitProgress {
    /// Rounds evaluated (one dispatch each).
    pub rounds: u64,
    /// The largest iteration count reached by a start.
    pub iteration: u64,
    /// The smallest loss seen so far.
    pub best_loss: f64,
}

/// One start's run.
#[derive(Clone, Debug)]
pub struct StartReport {
    /// Where it started.
    pub start: ParamSet,
    /// Where it ended.
    pub params: ParamSet,
    /// The loss there.
    pub loss: f64,
    /// Nelder–Mead iterations.
    pub iterations: u64,
    /// Why it stopped, in argmin's words.
    pub stopped: String,
}

/// The directional albedo of target and fit at one view cosine.
#[derive(Clone, Copy, Debug)]
pub struct AlbedoPair {
    /// μ = cosθo.
    pub mu: f64,
    /// The target's E(μ), where the target is a model (not a table).
    pub target: Option<DVec3>,
    /// The fit's E(μ).
    pub fit: DVec3,
}

/// A fit's result.
#[derive(Clone, Debug)]
pub struct FitReport {
    /// The fitted parameter set (the free keys fitted, every other as given).
    pub params: ParamSet,
    /// The free keys.
    pub free: Vec<&'static str>,
    /// The loss minimised.
    pub loss_kind: LossKind,
    /// Its value at the fit, over all channels and per channel.
    pub loss: ChannelErrors,
    /// Every start, in order.
    pub starts: Vec<StartReport>,
    /// Iterations over all starts.
    pub iterations: u64,
    /// Rounds: one batched evaluation (one GPU dispatch) each.
    pub rounds: u64,
    /// Candidate parameter sets evaluated.
    pub evaluations: u64,
    /// Seconds from the first sample to the fit (albedo excluded).
    pub seconds: f64,
    /// The samples' counts and grid.
    pub samples: SampleCounts,
    /// Directional albedo of target and fit at [`ALBEDO_MUS`].
    pub albedo: Vec<AlbedoPair>,
    /// The backend, in words.
    pub backend: String,
}

/// How many bins a fit used, of how many.
#[derive(Clone, Debug)]
pub struct SampleCounts {
    /// Bins used.
    pub used: usize,
    /// Valid bins (data, above the horizon) before sampling.
    pub valid: usize,
    /// Bins of the target's grid.
    pub grid_bins: usize,
    /// Bins without data.
    pub missing: usize,
    /// The grid, in words.
    pub grid: String,
}

/// Evaluates candidate parameter sets at the samples' pairs and returns each one's loss.
pub struct Objective<'a> {
    eval: Evaluator<'a>,
    samples: &'a Samples,
    loss: LossKind,
    /// Candidates evaluated in one backend job at most (bounds its memory).
    batch: usize,
}

impl<'a> Objective<'a> {
    /// An objective for up to `batch` candidates at once.
    pub fn new(
        eval: Evaluator<'a>,
        samples: &'a Samples,
        loss: LossKind,
        batch: usize,
    ) -> Objective<'a> {
        Objective {
            eval,
            samples,
            loss,
            batch: batch.max(1),
        }
    }

    /// The fit's values at the samples for each parameter set (all of one model).
    pub fn values(&self, sets: &[ParamSet]) -> Result<Vec<Vec<[f64; 3]>>> {
        let mut values = Vec::with_capacity(sets.len());
        for part in sets.chunks(self.batch) {
            values.extend(
                self.eval
                    .eval_sets_unchecked(Query::sets(part), &self.samples.pairs)?,
            );
        }
        // NaN, ±Inf and negative values are refused (docs/design.md §2.1): a loss of them
        // would steer the search by garbage.
        for (p, v) in sets.iter().zip(&values) {
            let mut count = crate::finite::InvalidCount::default();
            count.add_pairs(0, v, &self.samples.pairs);
            count.refuse(p.model().name(), &format!("fit at {}", p.to_text()))?;
        }
        Ok(values)
    }

    /// The loss of each parameter set against the target.
    pub fn losses(&self, sets: &[ParamSet]) -> Result<Vec<ChannelErrors>> {
        Ok(self
            .values(sets)?
            .iter()
            .map(|v| self.loss.eval(&self.samples.bins, &self.samples.values, v))
            .collect())
    }
}

/// Fits the free keys of `space` to `target` (module docs). `progress` is called after every
/// round.
pub fn fit(
    eval: &Evaluator,
    target: &Target,
    space: &Space,
    opts: &FitOptions,
    progress: &(dyn Fn(FitProgress) + Sync),
) -> Result<FitReport> {
    check_options(opts)?;
    eval.supports(space.base.model())?;
    let t0 = Instant::now();
    let samples = target::samples(target, eval, opts.max_bins)?;
    let objective = Objective::new(*eval, &samples, opts.loss, opts.starts);
    let rounds = Rounds::new(&objective, space, opts.starts, progress);
    let round_eval = |round: &[(usize, Vec<f64>)]| rounds.eval(round);
    let step = batch::LockStep::new(opts.starts, &round_eval);
    let starts = space.starts(opts.starts);
    let results = run_starts(
        &step,
        &starts,
        space.dims(),
        opts.max_iters,
        &rounds.iterations,
    );
    if let Some(e) = step.failure() {
        // The first failure of a round (a lost device, Ctrl-C) ends the fit with its own error.
        if eval.check_cancelled().is_err() {
            eval.check_cancelled()?;
        }
        anyhow::bail!("fitting {}: {e}", space.base.model().name());
    }
    let reports = start_reports(space, &starts, results)?;
    let best_start = reports
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.loss.total_cmp(&b.1.loss))
        .map(|(k, _)| k)
        .unwrap_or(0);
    let params = reports[best_start].params.clone();
    let loss = objective.losses(std::slice::from_ref(&params))?[0];
    let (rounds, evaluations) = step.counts();
    let seconds = t0.elapsed().as_secs_f64();
    let albedo = albedo_side_by_side(eval, target, &params)?;
    Ok(FitReport {
        free: space.keys.iter().map(|k| k.key).collect(),
        loss_kind: opts.loss,
        loss,
        iterations: reports.iter().map(|s| s.iterations).sum(),
        starts: reports,
        rounds,
        evaluations,
        seconds,
        samples: SampleCounts::of(&samples),
        albedo,
        backend: eval.name(),
        params,
    })
}

/// Refuses a number of starts outside 1..=[`MAX_STARTS`] and a bound of 0 iterations.
fn check_options(opts: &FitOptions) -> Result<()> {
    if !(1..=MAX_STARTS).contains(&opts.starts) {
        return Err(BadInput::new(
            "starts",
            format!(
                "starts = {}: expected from 1 to {MAX_STARTS} Nelder-Mead runs",
                opts.starts
            ),
        )
        .into());
    }
    if opts.max_iters == 0 {
        return Err(BadInput::new(
            "max_iters",
            "max_iters = 0: expected at least 1 Nelder-Mead iteration per start",
        )
        .into());
    }
    Ok(())
}

impl SampleCounts {
    /// The counts of `samples`.
    fn of(samples: &Samples) -> SampleCounts {
        SampleCounts {
            used: samples.pairs.len(),
            valid: samples.valid,
            grid_bins: samples.grid_bins,
            missing: samples.missing,
            grid: samples.grid.clone(),
        }
    }
}

/// The target's model, where it has one: a model target, or a MERL file as its lookup model.
pub fn target_model(target: &Target) -> Result<Option<ParamSet>> {
    match target {
        Target::Model(p) => Ok(Some(p.clone())),
        Target::Merl(path) => {
            let loaded = crate::merl::model::load(path)?;
            Ok(Some(ParamSet::defaults(loaded.model)))
        }
        Target::Table(_) => Ok(None),
    }
}

/// E(μ) of target (where it is a model) and fit at [`ALBEDO_MUS`], φo = 0.
fn albedo_side_by_side(
    eval: &Evaluator,
    target: &Target,
    fit: &ParamSet,
) -> Result<Vec<AlbedoPair>> {
    let points: Vec<(f64, f64)> = ALBEDO_MUS.iter().map(|&m| (m, 0.0)).collect();
    let settings = integrate::Settings::default();
    let e = |p: &ParamSet| -> Result<Vec<PointAlbedo>> {
        integrate::directional(eval, p, &settings, &points)
            .with_context(|| format!("directional albedo of {}", p.model().name()))
    };
    let fit_e = e(fit)?;
    let target_e = match target_model(target)? {
        // A model without the f64 twin (a .brdf file) on the CPU backend has no albedo here.
        Some(p) if eval.supports(p.model()).is_ok() => Some(e(&p)?),
        _ => None,
    };
    Ok(fit_e
        .iter()
        .enumerate()
        .map(|(k, f)| AlbedoPair {
            mu: f.mu,
            target: target_e.as_ref().map(|t| t[k].albedo),
            fit: f.albedo,
        })
        .collect())
}

impl FitReport {
    /// The report as `lobe fit --format json` prints it; `parameters` is the object
    /// `lobe albedo --format json` prints ([`ParamSet::to_json`]).
    pub fn to_json(&self, target: &Target) -> serde_json::Value {
        let rgb = |v: DVec3| serde_json::json!([v.x, v.y, v.z]);
        serde_json::json!({
            "model": self.params.model().name(),
            "parameters": self.params.to_json(),
            "free": self.free,
            "target": target.describe(),
            "loss": {
                "kind": self.loss_kind.name(),
                "total": self.loss.total,
                "channel": self.loss.channel,
            },
            "albedo": self.albedo.iter().map(|a| serde_json::json!({
                "mu": a.mu,
                "target": a.target.map(rgb),
                "fit": rgb(a.fit),
            })).collect::<Vec<_>>(),
            "iterations": self.iterations,
            "rounds": self.rounds,
            "evaluations": self.evaluations,
            "seconds": self.seconds,
            "samples": {
                "used": self.samples.used,
                "valid": self.samples.valid,
                "missing": self.samples.missing,
                "grid_bins": self.samples.grid_bins,
                "grid": self.samples.grid,
            },
            "starts": self.starts.iter().map(|s| serde_json::json!({
                "start": s.start.to_json(),
                "parameters": s.params.to_json(),
                "loss": s.loss,
                "iterations": s.iterations,
                "stopped": s.stopped,
            })).collect::<Vec<_>>(),
            "backend": self.backend,
        })
    }
}
