//! Cancellation: whoever wants work stopped (a Ctrl-C handler, a GUI's cancel button, another
//! thread) sets a [`CancelToken`]; long loops check it between chunks and return [`Interrupted`],
//! so that everything unwinds through the ordinary error path: temporary files are dropped (and
//! so removed), no output is renamed into place, and the caller reports a sentence instead of
//! dying mid-write. The library installs no signal handler; the command line does.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag shared between whoever wants work stopped and the job's loops. Clones share the flag.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token that is not set.
    pub fn new() -> CancelToken {
        CancelToken::default()
    }

    /// Asks every job that holds this token (or a clone) to stop at its next check.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether [`CancelToken::cancel`] was called (and not [`CancelToken::reset`] since).
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// Clears the flag, so that the next job runs.
    pub fn reset(&self) {
        self.0.store(false, Ordering::SeqCst);
    }

    /// `Err(Interrupted)` once the token is set.
    pub fn check(&self) -> Result<(), Interrupted> {
        if self.is_cancelled() {
            Err(Interrupted)
        } else {
            Ok(())
        }
    }
}

/// The error a loop returns once its cancellation token is set.
#[derive(Debug, thiserror::Error)]
#[error("interrupted (Ctrl-C or a termination signal); no partial output was kept, and the old files are as they were")]
pub struct Interrupted;
