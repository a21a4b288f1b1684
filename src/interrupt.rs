//! Cancellation: whoever wants work stopped (a Ctrl-C handler, a GUI's cancel button, another
//! thread) sets a [`CancelToken`]; long loops check it between chunks and return [`Interrupted`],
//! so that everything unwinds through the ordinary error path: temporary files are dropped (and
//! so removed), no output is renamed into place, and the caller reports a sentence instead of
//! dying mid-write. The library installs no signal handler; the command line does.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag shared between whoever wants work stopped and the job's loops. Clones share the flag;
/// a [`child`](CancelToken::child) has a flag of its own and is also set whenever its parent is.
#[derive(Clone, Debug, Default)]
pub struct CancelToken {
    flag: Arc<AtomicBool>,
    parent: Option<Box<CancelToken>>,
}

impl CancelToken {
    /// A token that is not set.
    pub fn new() -> CancelToken {
        CancelToken::default()
    }

    /// A token that stops its jobs when it is set, or when this one is: one call's own stop
    /// under a process-wide one (a server dropping a request its page no longer waits for, while
    /// Ctrl-C still stops everything).
    ///
    /// ```
    /// let all = lobe::CancelToken::new();
    /// let (one, other) = (all.child(), all.child());
    /// one.cancel();
    /// assert!(one.is_cancelled() && !other.is_cancelled() && !all.is_cancelled());
    /// all.cancel();
    /// assert!(other.is_cancelled());
    /// ```
    pub fn child(&self) -> CancelToken {
        CancelToken {
            flag: Arc::default(),
            parent: Some(Box::new(self.clone())),
        }
    }

    /// Asks every job that holds this token (or a clone, or a child) to stop at its next check.
    pub fn cancel(&self) {
        self.flag.store(true, Ordering::SeqCst);
    }

    /// Whether [`CancelToken::cancel`] was called on this token or a parent (and not
    /// [`CancelToken::reset`] since).
    pub fn is_cancelled(&self) -> bool {
        self.flag.load(Ordering::SeqCst) || self.parent.as_ref().is_some_and(|p| p.is_cancelled())
    }

    /// Clears this token's own flag (not a parent's), so that the next job runs.
    pub fn reset(&self) {
        self.flag.store(false, Ordering::SeqCst);
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
