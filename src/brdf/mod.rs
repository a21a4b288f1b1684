//! BRDF Explorer `.brdf` files ("analytic" BRDFs: parameters and a GLSL function) as models.
//!
//! [`load`] reads a file ([`parse()`]), compiles its shader into lobe's six kernels at run time
//! ([`mod@glsl`]), and registers the result as a [`RuntimeModel`] named after the file, so that every
//! job takes it like a built-in model. The parameters become the model's parameter table: a
//! `float NAME MIN MAX DEFAULT` a scalar in [MIN, MAX], a `bool NAME 0|1` a flag, a
//! `color NAME R G B` an rgb triple in [0, 1]. The file's `vec3 BRDF(vec3 L, vec3 V, vec3 N,
//! vec3 X, vec3 Y)` is called with L = ωi, V = ωo, N = +z, X = +x, Y = +y, behind lobe's
//! one-sided rule (f = 0 unless both cosines are positive).
//!
//! The shader is untrusted code inside lobe's kernels: it may define functions and constants and
//! read its parameters, and [`mod@validate`] refuses anything more in the compiled kernels (a
//! buffer, image or `shared` variable, a barrier, an atomic, large arrays) before a driver sees
//! them.
//!
//! Such a model has no f64 twin: the CPU backend and the jobs that need the reference (the
//! adaptive integrator, the stability sweep's GPU-vs-CPU parity) refuse it with a sentence. Its
//! GPU work is bounded per chunk ([`LoadOptions::chunk_timeout`]), so a shader that never
//! returns stops the job with a message instead of hanging it.

pub mod glsl;
mod lex;
mod names;
pub mod parse;
mod rename;
pub mod validate;

pub use glsl::SIGNATURE;
pub use parse::{parse, BrdfFile, Param, ParamType, MAX_FILE_BYTES};

use crate::model::runtime::RuntimeModel;
use crate::model::{Model, ParamError, ParamSpec, Value};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

/// Why a `.brdf` file could not become a model. Every message names the file, and the line
/// where there is one.
#[derive(Debug, thiserror::Error)]
pub enum BrdfError {
    /// The file could not be read.
    #[error("{file}: {source}")]
    Read {
        /// The path as given.
        file: String,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file is larger than [`MAX_FILE_BYTES`].
    #[error(
        "{file}: {bytes} bytes or more; a .brdf file may have at most {MAX_FILE_BYTES} (1 MiB)"
    )]
    TooLarge {
        /// The path as given.
        file: String,
        /// Its size (at least), bytes.
        bytes: u64,
    },
    /// The file is not a valid analytic `.brdf` file.
    #[error("{file}:{line}: {message}")]
    Parse {
        /// The path as given.
        file: String,
        /// The line (from 1).
        line: usize,
        /// What is wrong, in words.
        message: String,
    },
    /// The shader does not compile; the message holds the compiler's errors, each with its line
    /// in the file.
    #[error("{file}:{line}: the shader does not compile:\n{message}")]
    Compile {
        /// The path as given.
        file: String,
        /// The line of the first error (from 1).
        line: usize,
        /// The compiler's messages, one a line, as `FILE:LINE: message`.
        message: String,
    },
    /// The shader compiles but adds to lobe's kernels what a `.brdf` shader may not (a
    /// resource, a barrier, an atomic, too much memory: [`mod@validate`]).
    #[error("{file}:{line}: {message}")]
    Refused {
        /// The path as given.
        file: String,
        /// The line of the offending declaration or function, or the shader's first line.
        line: usize,
        /// What is not allowed, in words.
        message: String,
    },
    /// The parameter table or the name was refused.
    #[error("{file}: {source}")]
    Model {
        /// The path as given.
        file: String,
        /// Why.
        source: ParamError,
    },
}

/// The prefix of every name lobe adds to a `.brdf` shader's program; parameter names may not
/// start with it.
pub const RESERVED: &str = "lobe_";

/// How long one chunk of a `.brdf` model's GPU work may take by default. A chunk is at most a
/// few million evaluations ([`crate::gpu::CHUNK_OUTPUT_BYTES`]), a fraction of a second even on
/// lavapipe for shaders far heavier than lobe's own models; a shader that never returns is
/// stopped after this long.
pub const DEFAULT_CHUNK_TIMEOUT: Duration = Duration::from_secs(10);

/// Options of [`load`].
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// The bound on each chunk's GPU wait ([`DEFAULT_CHUNK_TIMEOUT`]).
    pub chunk_timeout: Duration,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            chunk_timeout: DEFAULT_CHUNK_TIMEOUT,
        }
    }
}

/// A loaded file: its model, and notes on what was skipped (print them for the user).
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The registered model.
    pub model: Model,
    /// One sentence per skipped section, naming file and line.
    pub notes: Vec<String>,
}

/// Whether a model spec names a `.brdf` file rather than a model.
pub fn is_brdf_path(spec: &str) -> bool {
    Path::new(spec.trim())
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("brdf"))
}

/// Reads and parses `path`, refusing a file larger than [`MAX_FILE_BYTES`] before reading it
/// all.
pub fn read(path: &Path) -> Result<BrdfFile, BrdfError> {
    let file = path.display().to_string();
    let read_err = |source| BrdfError::Read {
        file: file.clone(),
        source,
    };
    let mut bytes = Vec::new();
    crate::input::open_regular(path)
        .and_then(|(f, _)| f.take(MAX_FILE_BYTES as u64 + 1).read_to_end(&mut bytes))
        .map_err(read_err)?;
    if bytes.len() > MAX_FILE_BYTES {
        return Err(BrdfError::TooLarge {
            file,
            bytes: bytes.len() as u64,
        });
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        BrdfError::Parse {
            file: file.clone(),
            line: 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count(),
            message: format!("not UTF-8 text (an invalid byte at offset {at}); a .brdf file is text, not a binary file"),
        }
    })?;
    parse(&file, &text)
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// The parsed file as a run-time model named `name` with its compiled kernels (not registered
/// yet: [`RuntimeModel::register`]).
pub fn build(
    file: &BrdfFile,
    name: &str,
    options: &LoadOptions,
) -> Result<RuntimeModel, BrdfError> {
    let model_err = |source| BrdfError::Model {
        file: file.file.clone(),
        source,
    };
    let specs: Vec<ParamSpec> = file
        .params
        .iter()
        .map(|p| {
            let key = leak(p.name.clone());
            let doc = leak(format!("{} line {}", file.file, p.line));
            match p.kind {
                ParamType::Float { min, max, default } => {
                    ParamSpec::scalar(key, min, max, default, doc)
                }
                ParamType::Bool { default } => ParamSpec::flag(key, default, doc),
                ParamType::Color { default } => ParamSpec::rgb(key, default[0], doc),
            }
        })
        .collect();
    let description = format!("BRDF Explorer shader from {}", file.file);
    let mut model = RuntimeModel::new(name, &description, specs, isotropic(file))
        .map_err(model_err)?
        .with_no_reference_note(&format!(
            "it is the GLSL shader of {}, which has no f64 twin",
            file.file
        ))
        .with_chunk_timeout(options.chunk_timeout);
    for p in &file.params {
        if let ParamType::Color { default } = p.kind {
            model = model
                .with_default(&p.name, Value::Three(default))
                .map_err(model_err)?;
        }
    }
    for (kernel, spirv) in glsl::compile(file)? {
        model = model.with_kernel(kernel, &spirv);
    }
    Ok(model)
}

/// Whether the file's BRDF ignores its tangent arguments X and Y: then nothing in it can tell
/// azimuths apart and the model is taken as isotropic (a shader that reads the components of L
/// and V, `L.x`, rather than their dot products would not be; lobe cannot see that).
fn isotropic(file: &BrdfFile) -> bool {
    glsl::unused_tangents(&file.shader)
}

/// The model name for `path`: its file stem with every character other than letters, digits,
/// '_' and '-' made '_' (a '.' would read as MODEL.KEY in `--set`).
pub fn stem_name(path: &Path) -> String {
    crate::model::runtime::name_from_stem(path, "brdf")
}

/// The files loaded so far, by canonical path: loading a file again gives the same model.
static LOADED: Mutex<Vec<(PathBuf, Model)>> = Mutex::new(Vec::new());

/// Reads, compiles and registers the `.brdf` file at `path` under its [`stem_name`] (or, if a
/// model has that name, the stem with `_brdf` and a number added). A file loaded before in this
/// process gives the model it gave then, without notes.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Loaded, BrdfError> {
    let canonical = std::fs::canonicalize(path).map_err(|source| BrdfError::Read {
        file: path.display().to_string(),
        source,
    })?;
    let mut loaded = LOADED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, model)) = loaded.iter().find(|(p, _)| *p == canonical) {
        return Ok(Loaded {
            model: *model,
            notes: Vec::new(),
        });
    }
    let file = read(path)?;
    let stem = stem_name(path);
    let name = (0..)
        .map(|k| match k {
            0 => stem.clone(),
            1 => format!("{stem}_brdf"),
            k => format!("{stem}_brdf{k}"),
        })
        .find(|n| Model::from_name(n).is_err())
        .unwrap_or(stem);
    let model = build(&file, &name, options)?
        .register()
        .map_err(|source| BrdfError::Model {
            file: file.file.clone(),
            source,
        })?;
    loaded.push((canonical, model));
    Ok(Loaded {
        model,
        notes: file.notes,
    })
}
