//! What the commands share: the backend flags and the session they open, the model flags, the
//! closed choices as clap value enums, Ctrl-C, and the flag named in front of a library refusal.
//! Each command lives in its own file and exposes its clap arguments and a `run`.

pub mod albedo;
pub mod bench;
pub mod chi2;
pub mod compare;
pub mod demo;
pub mod energy;
pub mod eval;
pub mod explore;
pub mod fit;
pub mod light;
pub mod models;
pub mod plot;
pub mod preview;
pub mod run;
pub mod sample;
pub mod stability;
pub mod table;
pub mod tradeoff;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use lobe::gpu::GpuError;
use lobe::integrate::{Method, DEFAULT_MUS};
use lobe::{BackendKind, CancelToken, ParamSet, Session, SessionOptions};

/// Where to evaluate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BackendArg {
    /// Vulkan compute shaders in f32 (a real GPU if there is one, else lavapipe).
    Gpu,
    /// The CPU reference in f64; needs no Vulkan.
    Cpu,
}

impl From<BackendArg> for BackendKind {
    fn from(b: BackendArg) -> BackendKind {
        match b {
            BackendArg::Gpu => BackendKind::Gpu,
            BackendArg::Cpu => BackendKind::Cpu,
        }
    }
}

/// The backend flags of every command that evaluates f.
#[derive(Args, Clone, Debug)]
pub struct BackendArgs {
    /// Where to evaluate.
    #[arg(long, value_enum, default_value_t = BackendArg::Gpu)]
    pub backend: BackendArg,
    /// Use the first Vulkan device whose name contains this text (default: a real GPU, else
    /// lavapipe).
    #[arg(long, value_name = "SUBSTRING")]
    pub device: Option<String>,
}

/// The flags that choose a parameter set.
#[derive(Args, Clone, Debug)]
pub struct ModelArgs {
    /// BRDF model (see `lobe models`), optionally with parameters: 'phong{shininess=50}'.
    #[arg(long, default_value = "cook_torrance")]
    pub model: String,
    /// Set a parameter, KEY=VALUE (or MODEL.KEY=VALUE); rgb values as r,g,b or one number.
    /// Repeatable; applied after --material. The model may also carry its own:
    /// --model 'phong{shininess=50}'.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Start from a material preset: tin, gold, glazed_ceramic, granite.
    #[arg(long)]
    pub material: Option<String>,
    /// Replace every Fresnel factor of a specular lobe by 1 (shows the lobe's own energy).
    #[arg(long)]
    pub white_furnace: bool,
}

impl ModelArgs {
    /// The parameter set these flags name.
    pub fn params(&self) -> Result<ParamSet> {
        resolve(&self.model, self.material.as_deref(), &self.sets)
    }
}

/// One model spec, `NAME` or `NAME{KEY=VALUE,...}` (rgb values as r,g,b inside the braces), a
/// `.brdf` file or a MERL file ([`lobe::resolve::resolve_spec`]), with the command line's notes
/// and options.
pub fn resolve(model: &str, material: Option<&str>, sets: &[String]) -> Result<ParamSet> {
    let mut all = resolve_all(&[model.to_string()], material, sets)?;
    Ok(all.remove(0).1)
}

pub use lobe::resolve::{split_spec, split_specs};

/// The parameter sets of several model specs, each with its label ([`lobe::resolve::resolve_specs`]),
/// with notes on stderr and refusals naming `--set`.
pub fn resolve_all(
    specs: &[String],
    material: Option<&str>,
    sets: &[String],
) -> Result<Vec<(String, ParamSet)>> {
    lobe::resolve::resolve_specs(specs, material, sets, &spec_options()?, &mut note).map_err(|e| {
        match lobe::input::option_of(&e) {
            // An assignment's refusal names it: "--set KEY=VALUE for model M: why".
            Some("set") => anyhow::anyhow!("--set {e:#}"),
            _ => e,
        }
    })
}

/// How the command line loads model files: a `.brdf` model's time limit per chunk of GPU work
/// from `LOBE_BRDF_TIMEOUT=SECONDS` (default [`lobe::brdf::DEFAULT_CHUNK_TIMEOUT`]).
pub fn spec_options() -> Result<lobe::resolve::SpecOptions> {
    let mut options = lobe::resolve::SpecOptions::default();
    if let Ok(text) = std::env::var("LOBE_BRDF_TIMEOUT") {
        match text.trim().parse::<f64>() {
            Ok(s) if s > 0.0 && s <= 86400.0 => {
                options.brdf.chunk_timeout = std::time::Duration::from_secs_f64(s)
            }
            _ => bail!("LOBE_BRDF_TIMEOUT={text}: expected seconds, more than 0 and at most 86400"),
        }
    }
    Ok(options)
}

/// A note from loading a model file, on stderr.
fn note(text: &str) {
    eprintln!("lobe: {text}");
}

/// A model spec's name as a model name, a model file loaded ([`lobe::resolve::load_model`]).
pub fn model_file(name: &str) -> Result<&'static str> {
    Ok(lobe::resolve::load_model(name, &spec_options()?, &mut note)?.name())
}

/// The names of a `--models` list with each model file (`.brdf`, MERL) loaded ([`model_file`]) and replaced
/// by its model's name.
pub fn model_files(names: &[String]) -> Result<Vec<String>> {
    names
        .iter()
        .map(|n| model_file(n).map(str::to_string))
        .collect()
}

/// Output format of the commands that print a table for people, CSV or JSON.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TableFormat {
    Table,
    Csv,
    Json,
}

/// The albedo integrators.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Graded Gauss-Legendre in polar coordinates aligned with the mirror direction (the
    /// default).
    Peak,
    /// Gauss-Legendre in mu x uniform phi.
    Gauss,
    /// Midpoint cells in (theta, phi).
    Midpoint,
    /// Cosine-weighted low-discrepancy points.
    Qmc,
    /// Randomised low-discrepancy points from a cosine + mirror-lobe mixture tuned to the model;
    /// error = 3.5 standard errors of 8 replicates.
    Importance,
    /// Monte Carlo, draws uniform over the hemisphere; error = 4 standard errors, the variance
    /// per draw reported.
    Uniform,
    /// Monte Carlo, cosine-distributed draws; error and variance as for uniform.
    Cosine,
    /// Monte Carlo with the model's own sampler (as `lobe sample` draws); error and variance
    /// as for uniform.
    Sampled,
    /// Adaptive f64 Gauss-Kronrod; always runs on the CPU (no Vulkan needed).
    Reference,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Method {
        match m {
            MethodArg::Peak => Method::Peak,
            MethodArg::Gauss => Method::Gauss,
            MethodArg::Midpoint => Method::Midpoint,
            MethodArg::Qmc => Method::Qmc,
            MethodArg::Importance => Method::Importance,
            MethodArg::Uniform => Method::Uniform,
            MethodArg::Cosine => Method::Cosine,
            MethodArg::Sampled => Method::Sampled,
            MethodArg::Reference => Method::Reference,
        }
    }
}

/// [`DEFAULT_MUS`] as the command line writes a list, `0.1,0.5,1`: the default of the `--mu`
/// flags.
pub fn default_mus() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| DEFAULT_MUS.map(|m| m.to_string()).join(","))
}

/// The process-wide cancellation token: Ctrl-C (SIGINT), SIGTERM and SIGHUP set it.
pub fn cancel_token() -> &'static CancelToken {
    static TOKEN: std::sync::OnceLock<CancelToken> = std::sync::OnceLock::new();
    TOKEN.get_or_init(CancelToken::new)
}

/// Installs the handler of Ctrl-C, SIGTERM and SIGHUP (a second call is harmless). The first
/// signal sets [`cancel_token`] and interrupts all output ([`lobe::output::interrupt`]): jobs stop
/// at their next chunk, encoders at their next write, no commit starts, and the command unwinds,
/// removing its temporary files. A second signal while it unwinds removes every temporary file at
/// once (after a commit under way, so no set is left half renamed) and exits with status 130.
pub fn install_ctrl_c() -> Result<()> {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    let mut result = Ok(());
    INSTALLED.call_once(|| {
        result = ctrlc::set_handler(|| {
            let token = cancel_token();
            if token.is_cancelled() {
                let removed = lobe::output::remove_staged();
                eprintln!(
                    "lobe: interrupted again: stopped at once; {removed} temporary files removed, the old files kept"
                );
                std::process::exit(130);
            }
            token.cancel();
            lobe::output::interrupt();
        })
        .map_err(|e| anyhow::anyhow!("installing the Ctrl-C handler: {e}"));
    });
    result
}

/// Opens the session the backend flags ask for. The environment switches of the command line
/// become session options here: `LOBE_VALIDATION=1` (the Khronos validation layer),
/// `LOBE_INJECT_DEVICE_LOST=1` (every dispatch fails as a lost device would), `LOBE_STAGING=1`
/// (every GPU buffer staged through device-local memory, as on a discrete GPU), `LOBE_LOG=1`
/// (each pipeline built, on stderr).
pub fn open_session(b: &BackendArgs) -> Result<Session> {
    Ok(Session::open(session_options(b))?)
}

/// The session options `--backend`, `--device` and the environment (`LOBE_VALIDATION`,
/// `LOBE_INJECT_DEVICE_LOST`, `LOBE_STAGING`, `LOBE_LOG`) ask for.
pub fn session_options(b: &BackendArgs) -> SessionOptions {
    let env_on = |name: &str| std::env::var(name).is_ok_and(|v| v == "1");
    let log: Option<lobe::gpu::LogSink> = std::env::var("LOBE_LOG")
        .is_ok_and(|v| v != "0")
        .then(|| std::sync::Arc::new(|line: &str| eprintln!("lobe: {line}")) as _);
    SessionOptions {
        backend: b.backend.into(),
        device: b.device.clone(),
        validation: env_on("LOBE_VALIDATION"),
        inject_device_lost: env_on("LOBE_INJECT_DEVICE_LOST"),
        staging: env_on("LOBE_STAGING"),
        log,
        cancel: cancel_token().clone(),
    }
}

/// The session for an albedo job: the adaptive reference runs on the CPU whatever the backend,
/// so for it a CPU session is opened and no Vulkan device is needed.
pub fn open_albedo_session(b: &BackendArgs, method: Method) -> Result<Session> {
    if method == Method::Reference {
        let cpu = BackendArgs {
            backend: BackendArg::Cpu,
            device: None,
        };
        return open_session(&cpu);
    }
    open_session(b)
}

/// Puts the flag a library refusal came from in front of its message: `flag_of` maps the
/// refusal's option tag ([`lobe::input::BadInput`]) to this command's flag, with its value where
/// that helps. Other errors pass unchanged.
pub fn with_flag<T>(r: anyhow::Result<T>, flag_of: impl Fn(&str) -> Option<String>) -> Result<T> {
    r.map_err(|e| match option_tag(&e).and_then(flag_of) {
        Some(flag) => e.context(flag),
        None => e,
    })
}

/// The flag that answers a library refusal no command's own flags name: files in the way of a
/// run's outputs (`replace`) are replaced with `--replace`.
pub fn flag_hint(e: &anyhow::Error) -> Option<&'static str> {
    (option_tag(e) == Some("replace")).then_some(
        "--replace lets this run replace them (and every other member of their sets, whole)",
    )
}

/// The option a refusal in `e`'s chain came from: a job's [`lobe::input::BadInput`], or a
/// [`Session`] call's [`lobe::Error::Input`].
fn option_tag(e: &anyhow::Error) -> Option<&'static str> {
    lobe::input::option_of(e).or_else(|| {
        e.chain()
            .find_map(|c| match c.downcast_ref::<lobe::Error>() {
                Some(lobe::Error::Input { input, .. }) => Some(input.option),
                _ => None,
            })
    })
}

/// A [`Session`] call's error as the command reports it. A file error becomes the I/O error it
/// was, its message the job's whole chain (what was being read or written, then why), as the
/// job gave it; the others keep their variant, which [`option_tag`], [`gpu_hint`] and the exit
/// status read.
pub fn session_error(e: lobe::Error) -> anyhow::Error {
    match e {
        lobe::Error::Io { what, source } => std::io::Error::new(source.kind(), what).into(),
        e => e.into(),
    }
}

/// Says on stderr how many of `model`'s values were NaN, ±Inf or negative and where the first
/// was, when any were (`eval` and `table` keep them; docs/design.md §2.1).
pub fn warn_invalid(model: &str, count: &lobe::finite::InvalidCount) {
    if !count.is_clean() {
        eprintln!("lobe: warning: the model {model} gives invalid BRDF values (a BRDF is finite and not negative): {count}");
    }
}

/// Parses `WIDTHxHEIGHT` for `flag`; `example` shows the form.
pub fn parse_size(flag: &str, text: &str, example: &str) -> Result<(u32, u32)> {
    let size = text
        .split_once('x')
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match size {
        Some(s) => Ok(s),
        None => bail!("{flag} '{text}': expected WIDTHxHEIGHT, e.g. {example}"),
    }
}

/// Standard output whose write errors say so: "writing to stdout: No space left on device".
pub struct Stdout(std::io::StdoutLock<'static>);

/// Locks standard output for a command's report (see [`Stdout`]).
pub fn stdout() -> Stdout {
    Stdout(std::io::stdout().lock())
}

impl std::io::Write for Stdout {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.write(bytes).map_err(stdout_error)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush().map_err(stdout_error)
    }
}

fn stdout_error(e: std::io::Error) -> std::io::Error {
    std::io::Error::new(e.kind(), format!("writing to stdout: {e}"))
}

/// The most cells of a grid a command holds in memory or times (`bench --res`, `tradeoff
/// --error-res`, `--timing-res`, `--table-res`): 2^24, 400 MB per f64 RGB copy; the defaults are
/// far below (bench 4.2 M cells).
pub const MAX_HELD_CELLS: u64 = 1 << 24;

/// Refuses a `--samples` count outside 1 to [`lobe::integrate::MAX_SAMPLES`] before any work.
pub fn check_samples(flag: &str, samples: usize) -> Result<()> {
    let max = lobe::integrate::MAX_SAMPLES;
    if !(1..=max).contains(&samples) {
        bail!("{flag} {samples}: expected nodes per view direction from 1 to {max} (at least 16 are used)");
    }
    Ok(())
}

/// Refuses a grid of more than [`MAX_HELD_CELLS`] cells for `flag` before any work.
pub fn check_held_cells(flag: &str, grid: &lobe::grid::Grid) -> Result<()> {
    match grid.cells() {
        Some(c) if c <= MAX_HELD_CELLS => Ok(()),
        cells => bail!(
            "{flag}: a grid of shape {:?} has {} cells; this command takes at most {MAX_HELD_CELLS}",
            grid.shape(),
            cells.map_or("more than 2^64".to_string(), |c| c.to_string())
        ),
    }
}

/// The most timed runs per measurement: a median of 1000 is stable far below the machine's
/// noise.
pub const MAX_REPEATS: usize = 1000;

/// Refuses a repeat count outside 1 to [`MAX_REPEATS`] for `flag`: a median needs a run.
pub fn check_repeats(flag: &str, repeats: usize) -> Result<()> {
    if !(1..=MAX_REPEATS).contains(&repeats) {
        bail!("{flag} {repeats}: expected timed runs from 1 to {MAX_REPEATS} (the median of them is reported)");
    }
    Ok(())
}

/// A progress bar of `len` steps drawn with `template` (indicatif's syntax).
pub fn bar(len: u64, template: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Whether `e` says the device did not finish its work in time: its threads (a CPU driver's) may
/// still be running the kernel.
pub fn device_hung(e: &anyhow::Error) -> bool {
    matches!(
        gpu_error(e),
        Some(GpuError::Timeout { .. } | GpuError::ModelTimeout { .. } | GpuError::Hung)
    )
}

/// The GPU error in `e`'s chain, bare or inside a `lobe::Error`.
fn gpu_error(e: &anyhow::Error) -> Option<&GpuError> {
    e.chain().find_map(|c| {
        c.downcast_ref::<GpuError>()
            .or_else(|| match c.downcast_ref::<lobe::Error>() {
                Some(lobe::Error::Gpu(g)) => Some(g),
                _ => None,
            })
    })
}

/// The flags that help with a GPU failure, when `e` is one: the library's message says what to
/// do in words, this names the command line's spelling of it.
pub fn gpu_hint(e: &anyhow::Error) -> Option<&'static str> {
    let gpu = gpu_error(e)?;
    Some(match gpu {
        GpuError::NoLoader(_) | GpuError::NoDevice => {
            "--backend cpu runs the f64 CPU reference without Vulkan"
        }
        GpuError::NoMatchingDevice { .. } => {
            "--device SUBSTRING picks a device by name; leave it out for the best device"
        }
        GpuError::NoValidationLayer | GpuError::InvalidValues(_) => return None,
        GpuError::DeviceLost(_) => {
            "rerun, pick another device with --device SUBSTRING, or use --backend cpu"
        }
        GpuError::Timeout { .. } => "ask for less work at once, or use --backend cpu",
        GpuError::ModelTimeout { .. } => {
            "for a .brdf model, LOBE_BRDF_TIMEOUT=SECONDS sets the limit (default 10)"
        }
        GpuError::Limit(_) => {
            "ask for less work at once (fewer --samples, a smaller --res or --cell), or use --backend cpu"
        }
        _ => "--backend cpu runs the f64 CPU reference instead",
    })
}

/// The models a `--models` list names, each checked by name; every built-in model when the list
/// is empty.
pub fn models_or_all(names: &[String]) -> Result<Vec<lobe::Model>> {
    if names.is_empty() {
        return Ok(lobe::Model::ALL.to_vec());
    }
    names
        .iter()
        .map(|m| {
            model_file(m)
                .and_then(|name| Ok(lobe::Model::from_name(name)?))
                .with_context(|| format!("--models {m}"))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    /// Every computation of a command goes through a `Session` method: no command file takes the
    /// session's evaluator to call a job function one level down, nor reaches for its GPU runner.
    #[test]
    fn the_commands_compute_only_through_session_methods() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/cli");
        // Spelled in parts so that this test's own file does not match them.
        let needles = [[".", "evaluator()"].concat(), [".", "gpu()"].concat()];
        let mut found = Vec::new();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            for (n, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                if needles.iter().any(|n| code.contains(n.as_str())) {
                    found.push(format!("{}:{}: {}", path.display(), n + 1, line.trim()));
                }
            }
        }
        assert!(
            found.is_empty(),
            "calls around Session:\n{}",
            found.join("\n")
        );
    }
}
