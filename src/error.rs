//! The library's error type: one enum that callers can match, with messages that name the
//! parameter, the value and the valid range (never a command-line flag; the CLI adds those).

use crate::finite::InvalidValues;
use crate::gpu::GpuError;
use crate::input::BadInput;
use crate::interrupt::Interrupted;
use crate::model::runtime::NoReference;
use crate::model::ParamError;

/// Everything a [`crate::Session`] call can fail with.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A model name, parameter key or value that the model's parameter table refuses.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// No usable Vulkan device, a lost device, a Vulkan call that failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The cancellation token was set; no partial output was kept.
    #[error(transparent)]
    Cancelled(#[from] Interrupted),
    /// A request value the job refuses, tagged with the option it came from
    /// ([`BadInput::option`]) so that a front end can name its own spelling of it.
    #[error("{message}")]
    Input {
        /// The refused value and the option it came from.
        input: BadInput,
        /// The whole message, with the context the job added.
        message: String,
    },
    /// A request outside what the job accepts: the message names the input and its valid range.
    #[error("{0}")]
    Invalid(String),
    /// The job needs the f64 CPU reference, which this model (defined at run time) lacks.
    #[error(transparent)]
    NoReference(#[from] NoReference),
    /// The model gave NaN, ±Inf or negative values where the job needs valid ones
    /// (docs/design.md §2.1); nothing was written.
    #[error(transparent)]
    InvalidValues(#[from] InvalidValues),
    /// Reading or writing a file.
    #[error("{what}: {source}")]
    Io {
        /// What was being read or written, with its path.
        what: String,
        /// The operating system's error.
        source: std::io::Error,
    },
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Sorts an error from a job's internals into the variant that says what went wrong. The
    /// typed causes are found anywhere in the chain; `Param`, `Gpu` and `NoReference` come back
    /// as the cause itself (whose sentence names the parameter or the Vulkan step), while
    /// `Input`, `Io` and `Invalid` keep the whole chain in their message.
    pub(crate) fn from_job(e: anyhow::Error) -> Error {
        if e.downcast_ref::<Interrupted>().is_some() {
            return Error::Cancelled(Interrupted);
        }
        if let Some(v) = e.chain().find_map(|c| c.downcast_ref::<InvalidValues>()) {
            return Error::InvalidValues(v.clone());
        }
        if let Some(GpuError::InvalidValues(v)) =
            e.chain().find_map(|c| c.downcast_ref::<GpuError>())
        {
            return Error::InvalidValues(v.clone());
        }
        let e = match e.downcast::<ParamError>() {
            Ok(p) => return Error::Param(p),
            Err(e) => e,
        };
        let e = match e.downcast::<GpuError>() {
            Ok(g) => return Error::Gpu(g),
            Err(e) => e,
        };
        let e = match e.downcast::<NoReference>() {
            Ok(n) => return Error::NoReference(n),
            Err(e) => e,
        };
        if let Some(input) = e.chain().find_map(|c| c.downcast_ref::<BadInput>()) {
            return Error::Input {
                input: input.clone(),
                message: format!("{e:#}"),
            };
        }
        let io = e.chain().find_map(|c| c.downcast_ref::<std::io::Error>());
        match io {
            Some(io) => Error::Io {
                what: format!("{e:#}"),
                source: std::io::Error::new(io.kind(), io.to_string()),
            },
            None => Error::Invalid(format!("{e:#}")),
        }
    }
}

/// Converts a job's `anyhow` result into the library's error type.
pub(crate) trait IntoLobe<T> {
    fn lobe(self) -> Result<T>;
}

impl<T> IntoLobe<T> for anyhow::Result<T> {
    fn lobe(self) -> Result<T> {
        self.map_err(Error::from_job)
    }
}
