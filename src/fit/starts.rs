//! The Nelder–Mead starts of a fit, run in lock-step: one thread per start, each start's costs
//! gathered into rounds that [`Rounds::eval`] evaluates together (module docs of [`super`], step 3).

use super::batch;
use super::{FitProgress, Objective, Space, StartReport, SD_TOLERANCE};
use crate::model::ParamSet;
use anyhow::Result;
use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Executor, State, KV};
use argmin::solver::neldermead::NelderMead;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Size of the starting simplex in z (the logistic coordinates): 1 moves a value from the middle
/// of its range by about a quarter of it.
const SIMPLEX_STEP: f64 = 1.0;

/// One start's problem for argmin: its costs go through the lock-step.
struct StartProblem<'s, 'a> {
    step: &'s batch::LockStep<'a>,
    start: usize,
    /// Cost calls so far, to tell the initial simplex from the iterations.
    calls: AtomicUsize,
    /// Calls of the initial simplex (dims + 1).
    init_calls: usize,
}

impl CostFunction for StartProblem<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, z: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        let call = self.calls.fetch_add(1, Ordering::Relaxed);
        match self.step.cost(self.start, z.clone()) {
            Ok(v) => Ok(v),
            // argmin's Nelder–Mead unwraps the costs of its initial simplex; an infinite loss
            // there ends the run at its first iteration, which then reports the failure.
            Err(_) if call < self.init_calls => Ok(f64::INFINITY),
            Err(e) => Err(anyhow::anyhow!(e)),
        }
    }
}

/// Writes each iteration of one start into a shared counter.
struct IterationCounter(Arc<AtomicU64>);

impl<I: State> Observe<I> for IterationCounter {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), argmin::core::Error> {
        self.0.store(state.get_iter(), Ordering::Relaxed);
        Ok(())
    }
}

/// The evaluation of every round of the lock-step, with what the progress callback is told.
pub(super) struct Rounds<'o, 'a> {
    objective: &'o Objective<'a>,
    space: &'o Space,
    /// The smallest loss seen so far.
    best: Mutex<f64>,
    /// Each start's iteration count, written by its observer.
    pub(super) iterations: Vec<Arc<AtomicU64>>,
    /// Rounds evaluated.
    rounds: AtomicU64,
    progress: &'o (dyn Fn(FitProgress) + Sync),
}

impl<'o, 'a> Rounds<'o, 'a> {
    /// Rounds of `objective` over candidates in `space`'s coordinates, for `starts` starts.
    pub(super) fn new(
        objective: &'o Objective<'a>,
        space: &'o Space,
        starts: usize,
        progress: &'o (dyn Fn(FitProgress) + Sync),
    ) -> Rounds<'o, 'a> {
        Rounds {
            objective,
            space,
            best: Mutex::new(f64::INFINITY),
            iterations: (0..starts).map(|_| Arc::new(AtomicU64::new(0))).collect(),
            rounds: AtomicU64::new(0),
            progress,
        }
    }

    /// The loss of each candidate z of a round (infinite where z names no valid parameter set or
    /// the loss is not finite), then the progress callback.
    pub(super) fn eval(&self, round: &[(usize, Vec<f64>)]) -> Result<Vec<f64>> {
        let sets: Vec<Option<ParamSet>> = round
            .iter()
            .map(|(_, z)| self.space.params(z).ok())
            .collect();
        let valid: Vec<ParamSet> = sets.iter().flatten().cloned().collect();
        let mut losses = self.objective.losses(&valid)?.into_iter();
        let out: Vec<f64> = sets
            .iter()
            .map(|s| match s {
                Some(_) => losses
                    .next()
                    .map(|e| e.total)
                    .filter(|l| l.is_finite())
                    .unwrap_or(f64::INFINITY),
                None => f64::INFINITY,
            })
            .collect();
        let mut b = self.best.lock().unwrap_or_else(|e| e.into_inner());
        *b = out.iter().copied().fold(*b, f64::min);
        let done = self.rounds.fetch_add(1, Ordering::Relaxed) + 1;
        (self.progress)(FitProgress {
            rounds: done,
            iteration: self
                .iterations
                .iter()
                .map(|i| i.load(Ordering::Relaxed))
                .max()
                .unwrap_or(0),
            best_loss: *b,
        });
        Ok(out)
    }
}

/// How one start ended: (best z, its loss, iterations, why it stopped), or why it failed.
pub(super) type StartOutcome = std::result::Result<(Vec<f64>, f64, u64, String), String>;

/// Runs a Nelder–Mead start from each of `starts`, each on a thread of its own and its costs
/// through `step`, start k counting its iterations in `iterations[k]`.
pub(super) fn run_starts(
    step: &batch::LockStep,
    starts: &[Vec<f64>],
    dims: usize,
    max_iters: u64,
    iterations: &[Arc<AtomicU64>],
) -> Vec<StartOutcome> {
    std::thread::scope(|scope| {
        let handles: Vec<_> = starts
            .iter()
            .enumerate()
            .map(|(k, z0)| {
                let counter = iterations[k].clone();
                scope.spawn(move || {
                    let r = run_start(step, k, z0, dims, max_iters, counter);
                    step.finish(k);
                    r
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err("a Nelder-Mead run panicked".to_string()))
            })
            .collect()
    })
}

/// Each start's report, in order; the first start that failed fails the fit.
pub(super) fn start_reports(
    space: &Space,
    starts: &[Vec<f64>],
    results: Vec<StartOutcome>,
) -> Result<Vec<StartReport>> {
    let mut reports = Vec::new();
    for (k, r) in results.into_iter().enumerate() {
        let (z, loss, iters, stopped) =
            r.map_err(|e| anyhow::anyhow!("fitting {}: {e}", space.base.model().name()))?;
        reports.push(StartReport {
            start: space.params(&starts[k])?,
            params: space.params(&z)?,
            loss,
            iterations: iters,
            stopped,
        });
    }
    Ok(reports)
}

/// One Nelder–Mead run from `z0`: (best z, its loss, iterations, why it stopped).
fn run_start(
    step: &batch::LockStep,
    start: usize,
    z0: &[f64],
    dims: usize,
    max_iters: u64,
    counter: Arc<AtomicU64>,
) -> StartOutcome {
    let mut simplex = vec![z0.to_vec()];
    for d in 0..dims {
        let mut z = z0.to_vec();
        z[d] += SIMPLEX_STEP;
        simplex.push(z);
    }
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(SD_TOLERANCE)
        .map_err(|e| e.to_string())?;
    let problem = StartProblem {
        step,
        start,
        calls: AtomicUsize::new(0),
        init_calls: dims + 1,
    };
    let result = Executor::new(problem, solver)
        .configure(|s| s.max_iters(max_iters))
        .add_observer(IterationCounter(counter), ObserverMode::Always)
        .run()
        .map_err(|e| format!("{e:#}"))?;
    let state = result.state();
    let z = state
        .get_best_param()
        .cloned()
        .unwrap_or_else(|| z0.to_vec());
    Ok((
        z,
        state.get_best_cost(),
        state.get_iter(),
        state
            .get_termination_reason()
            .map_or_else(|| "not stopped".to_string(), |r| r.text().to_string()),
    ))
}
