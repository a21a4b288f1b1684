//! Ctrl-C: the handler only sets a flag; long loops call [`check`] between chunks and return the
//! error "interrupted", so that everything unwinds through the ordinary error path: temporary
//! files are dropped (and so removed), no output is renamed into place, and the process exits
//! with a message and a non-zero status instead of dying mid-write.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag shared between whoever wants work stopped (a Ctrl-C handler, a GUI's cancel button,
/// another thread) and the job's loops, which check it between chunks and return [`Interrupted`].
/// Clones share the flag.
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

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The error a loop returns once Ctrl-C was pressed.
#[derive(Debug, thiserror::Error)]
#[error("interrupted (Ctrl-C); no partial output was kept")]
pub struct Interrupted;

/// Whether Ctrl-C was pressed.
pub fn is_interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Err(Interrupted) once Ctrl-C was pressed.
pub fn check() -> Result<(), Interrupted> {
    if is_interrupted() {
        Err(Interrupted)
    } else {
        Ok(())
    }
}

/// Sets the flag as Ctrl-C would (for tests and for callers that stop work themselves).
pub fn request() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}

/// Clears the flag (for tests).
pub fn reset() {
    INTERRUPTED.store(false, Ordering::SeqCst);
}
