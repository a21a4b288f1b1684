//! Several Nelder–Mead runs in lock-step: each start runs argmin's solver on its own thread, and
//! every cost it asks for waits until all running starts have asked for theirs; then the whole
//! round goes to the backend at once (on the GPU, one dispatch of the pairs kernel, each pair
//! carrying the index of its candidate's parameter block) and each start gets its answer.
//!
//! A start that ends (converged or out of iterations) leaves the lock-step; the others go on
//! without waiting for it.

use std::sync::{Condvar, Mutex};

/// What one round evaluates: the candidates (start, z) and the function that turns them into
/// losses, in order.
pub type RoundEval<'a> = dyn Fn(&[(usize, Vec<f64>)]) -> anyhow::Result<Vec<f64>> + Sync + 'a;

struct State {
    /// Starts still running.
    active: usize,
    /// This round's candidates so far.
    pending: Vec<(usize, Vec<f64>)>,
    /// Each start's answer of the last round, taken when read.
    answers: Vec<Option<f64>>,
    /// The first failure: every later request gets it.
    failed: Option<String>,
    /// Rounds evaluated, and candidates in them.
    rounds: u64,
    evaluations: u64,
}

/// The meeting point of the starts ([module docs](self)).
pub struct LockStep<'a> {
    state: Mutex<State>,
    ready: Condvar,
    eval: &'a RoundEval<'a>,
}

impl<'a> LockStep<'a> {
    /// A lock-step for `starts` runs, evaluating each round with `eval`.
    pub fn new(starts: usize, eval: &'a RoundEval<'a>) -> LockStep<'a> {
        LockStep {
            state: Mutex::new(State {
                active: starts,
                pending: Vec::new(),
                answers: vec![None; starts],
                failed: None,
                rounds: 0,
                evaluations: 0,
            }),
            ready: Condvar::new(),
            eval,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        // A panic in another start would poison the lock; the state stays consistent (every
        // change is made under it in one step), so go on with it.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Runs the round when every running start has asked.
    fn run_if_complete(&self, st: &mut State) {
        if st.pending.is_empty() || st.pending.len() < st.active {
            return;
        }
        let round = std::mem::take(&mut st.pending);
        match (self.eval)(&round) {
            Ok(losses) => {
                for ((start, _), loss) in round.iter().zip(losses) {
                    st.answers[*start] = Some(loss);
                }
                st.rounds += 1;
                st.evaluations += round.len() as u64;
            }
            Err(e) => {
                st.failed.get_or_insert(format!("{e:#}"));
            }
        }
        self.ready.notify_all();
    }

    /// The loss at `z` for start `start`, once its round has run.
    pub fn cost(&self, start: usize, z: Vec<f64>) -> Result<f64, String> {
        let mut st = self.lock();
        if let Some(e) = &st.failed {
            return Err(e.clone());
        }
        st.pending.push((start, z));
        self.run_if_complete(&mut st);
        loop {
            if let Some(v) = st.answers[start].take() {
                return Ok(v);
            }
            if let Some(e) = &st.failed {
                return Err(e.clone());
            }
            st = self.ready.wait(st).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Start `start` has ended: the others no longer wait for it.
    pub fn finish(&self, start: usize) {
        let mut st = self.lock();
        st.active = st.active.saturating_sub(1);
        st.pending.retain(|(s, _)| *s != start);
        self.run_if_complete(&mut st);
    }

    /// (rounds, candidates evaluated) so far.
    pub fn counts(&self) -> (u64, u64) {
        let st = self.lock();
        (st.rounds, st.evaluations)
    }

    /// The first failure, if any.
    pub fn failure(&self) -> Option<String> {
        self.lock().failed.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_round_holds_one_candidate_of_each_running_start() {
        let sizes = Mutex::new(Vec::new());
        let eval = |round: &[(usize, Vec<f64>)]| {
            sizes.lock().unwrap().push(round.len());
            Ok(round.iter().map(|(_, z)| z[0] * 2.0).collect())
        };
        let step = LockStep::new(3, &eval);
        std::thread::scope(|s| {
            for start in 0..3 {
                let step = &step;
                s.spawn(move || {
                    // Start k asks k + 1 times, then ends.
                    for i in 0..=start {
                        let v = step.cost(start, vec![(10 * start + i) as f64]).unwrap();
                        assert_eq!(v, 2.0 * (10 * start + i) as f64);
                    }
                    step.finish(start);
                });
            }
        });
        assert_eq!(*sizes.lock().unwrap(), vec![3, 2, 1]);
        assert_eq!(step.counts(), (3, 6));
    }
}
