//! Running a lobe job from Python: the GIL is released while the job works, Ctrl-C reaches the
//! job through the session's cancellation token, and a panic comes back as an exception.

use crate::errors::to_py;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc;
use std::time::Duration;

/// How often the waiting thread asks Python whether a signal (Ctrl-C) arrived: short enough that
/// an interrupt feels immediate, long enough that the check costs nothing next to the job.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `job` on a worker thread with the GIL released. Meanwhile this thread polls Python's
/// signal handlers; when one raises (KeyboardInterrupt), the session's token is set, the job
/// stops at its next chunk with nothing partial kept, the token is cleared for the next job,
/// and the handler's exception is raised. Every job of the session sees the token, so an
/// interrupt stops the jobs other Python threads run on the same session too.
pub fn run<T: Send>(
    py: Python<'_>,
    session: &lobe::Session,
    job: impl FnOnce() -> lobe::Result<T> + Send,
) -> PyResult<T> {
    let token = session.cancel_token().clone();
    let (outcome, interrupt) = py.detach(|| {
        std::thread::scope(|scope| {
            let (done_tx, done_rx) = mpsc::channel::<()>();
            let worker = scope.spawn(move || {
                let r = catch_unwind(AssertUnwindSafe(job));
                let _ = done_tx.send(());
                r
            });
            let mut interrupt: Option<PyErr> = None;
            while let Err(mpsc::RecvTimeoutError::Timeout) = done_rx.recv_timeout(SIGNAL_POLL) {
                if interrupt.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        token.cancel();
                        interrupt = Some(e);
                    }
                }
            }
            let outcome = worker
                .join()
                .unwrap_or_else(|payload| Err(payload))
                .map_err(panic_message);
            (outcome, interrupt)
        })
    });
    if let Some(e) = interrupt {
        token.reset();
        return Err(e);
    }
    match outcome {
        Ok(result) => result.map_err(to_py),
        Err(message) => Err(PyRuntimeError::new_err(format!(
            "lobe stopped on an internal error ({message}); nothing was written"
        ))),
    }
}

fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".to_string())
}
