//! lobe's errors as the exceptions a Python user expects.

use pyo3::create_exception;
use pyo3::exceptions::{
    PyFileNotFoundError, PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError,
};
use pyo3::PyErr;

create_exception!(
    _lobe,
    GpuError,
    PyRuntimeError,
    "No usable Vulkan device, a lost device, or a Vulkan call that failed."
);

create_exception!(
    _lobe,
    InvalidValuesError,
    PyValueError,
    "The model gave NaN, infinite or negative values where the job needs valid ones."
);

/// The exception for a lobe error: `ValueError` for a refused request or parameter (the
/// message names it and its range), `GpuError` for the device, `KeyboardInterrupt` for a
/// cancelled job, `FileNotFoundError`/`OSError` for files.
pub fn to_py(e: lobe::Error) -> PyErr {
    let message = e.to_string();
    match e {
        lobe::Error::Gpu(_) => GpuError::new_err(message),
        lobe::Error::Cancelled(_) => PyKeyboardInterrupt::new_err(message),
        lobe::Error::InvalidValues(_) => InvalidValuesError::new_err(message),
        lobe::Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(message)
        }
        lobe::Error::Io { .. } => PyOSError::new_err(message),
        // The tag names the request's input as the library spells it, which is the keyword
        // argument's name here (grid, cells, free, starts, max_iters, target).
        lobe::Error::Input { input, .. } => {
            PyValueError::new_err(format!("{}: {message}", input.option))
        }
        _ => PyValueError::new_err(message),
    }
}

/// A request the binding refuses before any job runs, named by its argument.
pub fn invalid(argument: &str, what: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("{argument}: {what}"))
}

/// An `anyhow` error from one of lobe's request parsers, as a `ValueError` naming `argument`.
pub fn from_anyhow(argument: &str, e: anyhow::Error) -> PyErr {
    invalid(argument, format!("{e:#}"))
}

/// A job error from a function that returns `anyhow` (the pictures) sorted as lobe sorts its
/// own: a cancelled job, the device, a refused input with its tag, or a refusal.
pub fn from_job(e: anyhow::Error) -> lobe::Error {
    if e.downcast_ref::<lobe::interrupt::Interrupted>().is_some() {
        return lobe::Error::Cancelled(lobe::interrupt::Interrupted);
    }
    let e = match e.downcast::<lobe::gpu::GpuError>() {
        Ok(g) => return lobe::Error::Gpu(g),
        Err(e) => e,
    };
    let message = format!("{e:#}");
    match e
        .chain()
        .find_map(|c| c.downcast_ref::<lobe::input::BadInput>())
    {
        Some(input) => lobe::Error::Input {
            input: input.clone(),
            message,
        },
        None => lobe::Error::Invalid(message),
    }
}
