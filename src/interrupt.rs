//! Ctrl-C: the handler only sets a flag; long loops call [`check`] between chunks and return the
//! error "interrupted", so that everything unwinds through the ordinary error path: temporary
//! files are dropped (and so removed), no output is renamed into place, and the process exits
//! with a message and a non-zero status instead of dying mid-write.

use std::sync::atomic::{AtomicBool, Ordering};

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The error a loop returns once Ctrl-C was pressed.
#[derive(Debug, thiserror::Error)]
#[error("interrupted (Ctrl-C); no partial output was kept")]
pub struct Interrupted;

/// Installs the Ctrl-C (SIGINT, and SIGTERM on Unix) handler. A second call is harmless.
pub fn install() -> anyhow::Result<()> {
    static INSTALLED: AtomicBool = AtomicBool::new(false);
    if INSTALLED.swap(true, Ordering::SeqCst) {
        return Ok(());
    }
    ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            // A second Ctrl-C while a loop is still unwinding: give up at once.
            std::process::exit(130);
        }
    })
    .map_err(|e| anyhow::anyhow!("installing the Ctrl-C handler: {e}"))
}

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
