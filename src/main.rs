//! The `lobe` command line: parses, calls the library, prints.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use glam::DVec3;
use lobe::grid::{direction, Grid};
use lobe::model::{Model, ParamKind};
use lobe::table::{write_table, TableMeta};
use lobe::{material, resolve_params, BackendKind, Evaluator, ParamSet, Session, SessionOptions};
use std::io::Write;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "lobe",
    version,
    about = "Evaluate BRDFs with Vulkan compute shaders, checked against an f64 CPU reference",
    long_about = "Evaluate BRDFs with Vulkan compute shaders (GLSL, f32), checked against a CPU reference in f64.\n\
Conventions: normal +z, tangent +x; theta from the normal, phi from +x counter-clockwise; wi points to the light,\n\
wo to the viewer; f is in 1/sr, linear RGB, without the cosine. The command line takes angles in degrees."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Evaluate f at direction pairs; prints CSV (or JSON).
    Eval(EvalArgs),
    /// Write a lobe table (EXR mosaic, plus .npy and .json beside it).
    Table(TableArgs),
    /// List every model with its parameters, ranges, defaults and a description.
    Models(ModelsArgs),
    /// The main job on the built-in materials (tin, gold, glazed ceramic, granite) with every
    /// model: lobe tables, albedo JSON, an albedo LUT, plots, the preview sheet and GPU-vs-CPU
    /// parity, shown on DIR/index.html.
    Demo(DemoArgs),
    /// Evaluations per second of every model on this device, GPU and CPU reference.
    Bench(BenchArgs),
    /// Cost and error of each speed-for-accuracy variant of a model, measured on this device.
    Tradeoff(TradeoffArgs),
    /// A labelled contact sheet (rows materials, columns models) of shaded spheres or the lab's
    /// icosahedron under the lab's four lights: PNG (sRGB) and EXR (linear radiance).
    Preview(PreviewArgs),
    /// Sweep every model over the edges of its domain (extreme parameters, grazing, mirror and
    /// opposite directions) on both backends; count NaN, Inf and negative values and report the
    /// largest GPU-vs-CPU error. Exits non-zero if any NaN, Inf or negative value appears.
    Stability(StabilityArgs),
    /// Produce everything a scene file asks for: lobe tables, albedos and previews. Only the
    /// pipelines the scene needs are built; each is listed with its build time.
    Run(RunArgs),
    /// Directional albedo E(mu) (delta lobes added exactly and also shown apart) and the
    /// hemispherical albedo, with error estimates.
    Albedo(AlbedoArgs),
    /// Energy report: every model at its presets and over a sweep of its main parameter, in its
    /// white configuration (colours at 1, specular lobes alone under the white furnace): the
    /// largest E(mu) and where, gain (E > 1) and loss (1 - E_avg).
    Energy(EnergyArgs),
    /// Pictures of a model: in-plane polar plot, hemisphere heat map, theta_h x theta_d slice,
    /// 3D lobe or albedo curves, as PNG or SVG by the output's extension (fonts built in).
    Plot(PlotArgs),
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum PlotKind {
    /// f (or f*cos(theta_i) with --cos) in the plane of incidence, one curve per --theta-i-deg.
    Polar,
    /// Heat map of f over every wo for one wi (over every wi with --reverse), one panel per
    /// --theta-i-deg.
    Hemisphere,
    /// The theta_h x theta_d image (Rusinkiewicz 1998) at --phi-d-deg, log colour.
    Slice,
    /// The lobe r(wo) = f * wo as a 3D wireframe, one panel per --theta-i-deg.
    #[value(name = "3d")]
    ThreeD,
    /// Directional albedo E(mu) curves with E = 1 drawn.
    Albedo,
}

#[derive(Args)]
struct PlotArgs {
    /// What to draw.
    #[arg(long, value_enum, default_value_t = PlotKind::Polar)]
    kind: PlotKind,
    /// Output file; .png or .svg chooses the format.
    #[arg(short = 'o', long = "output", value_name = "PATH.png|PATH.svg")]
    output: PathBuf,
    /// BRDF model (see `lobe models`); repeatable or comma-separated to overlay several
    /// (default cook_torrance). Every model is drawn with every --material.
    #[arg(long = "model", value_delimiter = ',')]
    models: Vec<String>,
    /// Material preset (tin, gold, glazed_ceramic, granite); repeatable or comma-separated.
    #[arg(long = "material", value_delimiter = ',')]
    materials: Vec<String>,
    /// Set a parameter of every model drawn, KEY=VALUE; repeatable; applied after --material.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Replace every Fresnel factor of a specular lobe by 1 (shows the lobe's own energy).
    #[arg(long)]
    white_furnace: bool,
    /// Where to evaluate.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
    /// Incidence angles theta_i in degrees, comma-separated, each in [0, 90) (polar, hemisphere,
    /// 3d; with --reverse the fixed theta_o). Default 0,30,60,80 (3d: 45).
    #[arg(long = "theta-i-deg", value_delimiter = ',')]
    theta_i_deg: Vec<f64>,
    /// Azimuth of the fixed direction in degrees (hemisphere, 3d; albedo: phi_o).
    #[arg(long = "phi-i-deg", default_value_t = 0.0, allow_hyphen_values = true)]
    phi_i_deg: f64,
    /// Plot f*cos(theta_i) instead of f.
    #[arg(long)]
    cos: bool,
    /// Logarithmic radius (polar, 3d; default linear) or colour (hemisphere; the default there).
    /// The slice is always logarithmic.
    #[arg(long, conflicts_with = "linear")]
    log: bool,
    /// Linear colour scale for the hemisphere map.
    #[arg(long)]
    linear: bool,
    /// Decades a logarithmic scale spans below its maximum.
    #[arg(long, default_value_t = 4.0)]
    decades: f64,
    /// Plotted channel: luminance, r, g, b or max.
    #[arg(long, default_value = "luminance")]
    channel: String,
    /// Hemisphere: map f over wi for the fixed wo instead.
    #[arg(long)]
    reverse: bool,
    /// Hemisphere projection: equal-area (Lambert azimuthal) or nusselt (sin theta).
    #[arg(long, default_value = "equal-area")]
    projection: String,
    /// Resolution: hemisphere cells across (128), slice cells per axis (90), 3d rings (60),
    /// albedo view directions (48), polar view angles per curve (1440).
    #[arg(long)]
    res: Option<usize>,
    /// Slice: phi_d in degrees.
    #[arg(long = "phi-d-deg", default_value_t = 90.0, allow_hyphen_values = true)]
    phi_d_deg: f64,
    /// Albedo: integration method (peak, gauss, midpoint, qmc, reference).
    #[arg(long, default_value = "peak")]
    method: String,
    /// Albedo: quadrature nodes per view direction (default: the method's).
    #[arg(long)]
    samples: Option<usize>,
    /// Image size WIDTHxHEIGHT in pixels (default 1200x800; hemisphere: height to fit its
    /// panels).
    #[arg(long)]
    size: Option<String>,
}

#[derive(Args)]
struct AlbedoArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Write every albedo a scene file asks for instead (JSON, the default method; see
    /// `lobe run --help`); only --backend and --device apply then.
    #[arg(long, value_name = "SCENE.toml", conflicts_with_all = ["sets", "material", "lut"])]
    scene: Option<PathBuf>,
    /// With --scene: the folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR", requires = "scene")]
    output_dir: Option<PathBuf>,
    /// View directions as mu = cos(theta_o), comma-separated, each in (0, 1] (default 0.1,0.5,1).
    #[arg(long, value_delimiter = ',', conflicts_with = "theta_deg")]
    mu: Vec<f64>,
    /// View directions as theta_o in degrees, comma-separated, each in [0, 90).
    #[arg(long = "theta-deg", value_delimiter = ',')]
    theta_deg: Vec<f64>,
    /// View azimuth phi_o in degrees (matters for anisotropic models; E_avg is taken at it).
    #[arg(long = "phi-deg", default_value_t = 0.0, allow_hyphen_values = true)]
    phi_deg: f64,
    /// Integrator: peak (graded Gauss-Legendre aligned with the mirror direction; default),
    /// gauss (Gauss-Legendre in mu x uniform phi), midpoint (theta, phi cells), qmc
    /// (cosine-weighted low-discrepancy points), importance (randomised low-discrepancy points
    /// from a cosine + mirror-lobe mixture tuned to the model; error = 3.5 standard errors of 8
    /// replicates), reference (adaptive f64 Gauss-Kronrod, CPU only).
    #[arg(long, default_value = "peak")]
    method: String,
    /// Quadrature nodes per view direction (default depends on the method; ignored by reference).
    #[arg(long)]
    samples: Option<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
    /// Write an albedo look-up table E(mu, p) and E_avg(p) to PATH.exr (layers E, E_avg), with
    /// PATH.npy (Np x Nmu x 3), PATH_avg.npy (Np x 3) and PATH.json (axes, centring, mapping)
    /// beside it. mu cells are centred: mu_j = (j + 0.5)/Nmu.
    #[arg(long, value_name = "PATH.exr", conflicts_with_all = ["mu", "theta_deg"])]
    lut: Option<PathBuf>,
    /// LUT parameter axis: KEY, or several keys set to the same value (nu,nv). Default per model:
    /// albedo, shininess, smoothness, sigma, roughness, ior, nu,nv, alpha.
    #[arg(
        long = "lut-param",
        value_name = "KEY",
        value_delimiter = ',',
        requires = "lut"
    )]
    lut_param: Vec<String>,
    /// LUT parameter range LO,HI (default per model, e.g. shininess 1,8192; roughness 0.01,1).
    #[arg(long = "lut-range", value_name = "LO,HI", requires = "lut")]
    lut_range: Option<String>,
    /// LUT size NMU,NP (default 32,32).
    #[arg(long = "lut-res", value_name = "NMU,NP", requires = "lut")]
    lut_res: Option<String>,
    /// LUT parameter mapping of cell t_k = (k + 0.5)/NP: linear (lo + (hi-lo) t), log
    /// (lo (hi/lo)^t) or square (lo + (hi-lo) t^2). Default per model (log for exponents, square
    /// for roughness, else linear).
    #[arg(long = "lut-map", requires = "lut")]
    lut_map: Option<String>,
}

#[derive(Args)]
struct EnergyArgs {
    /// Models, comma-separated (default: every model).
    #[arg(long, value_delimiter = ',')]
    models: Vec<String>,
    /// Values of each model's main parameter to sweep (its LUT axis: shininess 1..8192 log,
    /// roughness 0.01..1 square, ...), cell-centred; 0 for presets only.
    #[arg(long, default_value_t = 8)]
    sweep: usize,
    /// Integrator (see `lobe albedo --method`).
    #[arg(long, default_value = "peak")]
    method: String,
    /// Quadrature nodes per view direction (default: the method's).
    #[arg(long)]
    samples: Option<usize>,
    /// Where to evaluate.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
}

#[derive(Args)]
struct StabilityArgs {
    /// Models to sweep, comma-separated (default: the seed models and every microfacet component
    /// choice). `microfacet` means all its component choices.
    #[arg(long, value_delimiter = ',')]
    models: Vec<String>,
    /// Sweep the CPU reference alone (no Vulkan device needed; no GPU-vs-CPU errors).
    #[arg(long)]
    cpu_only: bool,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
    /// Print a row for every parameter edge, not only those where something is off.
    #[arg(long)]
    all: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = StabilityFormat::Table)]
    format: StabilityFormat,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum StabilityFormat {
    Table,
    Json,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum Backend {
    /// Vulkan compute shaders in f32 (a real GPU if there is one, else lavapipe).
    Gpu,
    /// The CPU reference in f64.
    Cpu,
}

#[derive(Args)]
struct ModelArgs {
    /// BRDF model (see `lobe models`).
    #[arg(long, default_value = "cook_torrance")]
    model: String,
    /// Set a parameter, KEY=VALUE; rgb values as r,g,b or one number. Repeatable; applied after --material.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Start from a material preset: tin, gold, glazed_ceramic, granite.
    #[arg(long)]
    material: Option<String>,
    /// Replace every Fresnel factor of a specular lobe by 1 (shows the lobe's own energy).
    #[arg(long)]
    white_furnace: bool,
    /// Where to evaluate.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Use the first Vulkan device whose name contains this text (default: a real GPU, else lavapipe).
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum Format {
    Csv,
    Json,
}

#[derive(Args)]
struct EvalArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Light direction THETA,PHI in degrees.
    #[arg(
        long,
        value_name = "THETA,PHI",
        requires = "wo",
        conflicts_with = "pairs",
        allow_hyphen_values = true
    )]
    wi: Option<String>,
    /// View direction THETA,PHI in degrees.
    #[arg(
        long,
        value_name = "THETA,PHI",
        requires = "wi",
        allow_hyphen_values = true
    )]
    wo: Option<String>,
    /// CSV file of pairs with the header theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg.
    #[arg(long, value_name = "FILE.csv")]
    pairs: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    format: Format,
}

#[derive(Args)]
struct TableArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Grid: full (theta_i, phi_i, theta_o, phi_o), isotropic (theta_i, theta_o, delta_phi in
    /// [0, 180 deg]), or halfdiff (Rusinkiewicz's half/difference angles: theta_h, theta_d, phi_d
    /// in [0, 180 deg] for isotropic models, or theta_h, phi_h, theta_d, phi_d for any).
    #[arg(long, default_value = "full")]
    grid: String,
    /// Resolution: NTHETA_I,NPHI_I,NTHETA_O,NPHI_O (full), NTHETA_I,NTHETA_O,NDPHI (isotropic),
    /// NTHETA_H,NTHETA_D,NPHI_D or NTHETA_H,NPHI_H,NTHETA_D,NPHI_D (halfdiff).
    #[arg(long, required_unless_present = "scene")]
    res: Option<String>,
    /// Output EXR path; the .npy and .json are written beside it.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH.exr",
        required_unless_present = "scene"
    )]
    output: Option<PathBuf>,
    /// Write every table a scene file asks for instead (see `lobe run --help`); --model, --set,
    /// --material, --white-furnace, --grid, --res and -o do not apply then.
    #[arg(long, value_name = "SCENE.toml", conflicts_with_all = ["res", "output", "sets", "material"])]
    scene: Option<PathBuf>,
    /// With --scene: the folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR")]
    output_dir: Option<PathBuf>,
}

#[derive(Args)]
struct RunArgs {
    /// The scene: materials, lights, camera and the tables, albedos and previews to produce
    /// (see data/scenes/lab.toml).
    #[arg(value_name = "SCENE.toml")]
    scene: PathBuf,
    /// The folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR", default_value = ".")]
    output_dir: PathBuf,
    /// Where to evaluate.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
}

#[derive(Args)]
struct BenchArgs {
    /// Models to measure (default: all), comma-separated.
    #[arg(long, value_delimiter = ',')]
    models: Vec<String>,
    /// Isotropic grid NTHETA_I,NTHETA_O,NDPHI of each timed table.
    #[arg(long, default_value = "128,128,256")]
    res: String,
    /// Timed runs per measurement (the median is reported), after one warm-up run.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Time lobe tables only, not albedo integration.
    #[arg(long)]
    no_albedo: bool,
    /// Backends to measure.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Backend::Gpu, Backend::Cpu])]
    backend: Vec<Backend>,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
}

#[derive(Args)]
struct TradeoffArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Sections to measure, comma-separated: evaluation, integration, table-resolution.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "evaluation,integration,table-resolution"
    )]
    sections: Vec<String>,
    /// A smaller version of every section (the defaults of the flags below shrink): a first look.
    #[arg(long)]
    quick: bool,
    /// Evaluation: isotropic grid NTHETA_I,NTHETA_O,NDPHI on which errors are measured (full grid
    /// with the same angular density for an anisotropic parameter set) [default: 32,32,64;
    /// --quick 16,16,32].
    #[arg(long)]
    error_res: Option<String>,
    /// Evaluation: isotropic grid NTHETA_I,NTHETA_O,NDPHI on which costs are timed [default:
    /// 96,96,192; --quick 48,48,96].
    #[arg(long)]
    timing_res: Option<String>,
    /// Timed runs per variant, after one untimed run; the median is reported [default: 5;
    /// --quick 2].
    #[arg(long)]
    repeats: Option<usize>,
    /// Integration and tables: view directions as mu = cos(theta_o), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "0.1,0.5,1")]
    mu: Vec<f64>,
    /// Integration: quadrature nodes per albedo, comma-separated [default:
    /// 256,1024,4096,16384,65536; --quick 256,1024,4096].
    #[arg(long, value_delimiter = ',')]
    samples: Vec<usize>,
    /// Tables: resolutions N (N x N x 2N cells in theta_i, theta_o, dphi), comma-separated
    /// [default: 8,16,32,64,128; --quick 8,16,32].
    #[arg(long, value_delimiter = ',')]
    table_res: Vec<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
    /// Write the log-log Pareto plot here (.png or .svg) [default: tradeoff-MODEL.png, or
    /// tradeoff-MATERIAL-MODEL.png with --material, in the current folder].
    #[arg(long, value_name = "PATH", conflicts_with = "no_plot")]
    plot: Option<PathBuf>,
    /// Write no plot.
    #[arg(long)]
    no_plot: bool,
    /// Plot size WIDTHxHEIGHT in pixels (SVG: user units).
    #[arg(long, default_value = "1800x720")]
    size: String,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum TableFormat {
    Table,
    Csv,
    Json,
}

#[derive(Args)]
struct DemoArgs {
    /// Output folder; its files are replaced only when the whole demo has succeeded, with
    /// index.html last.
    #[arg(short = 'o', long = "output", default_value = "lobe-demo")]
    output: PathBuf,
    /// Where to evaluate (with cpu there is no GPU-vs-CPU parity to show).
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
    /// Smaller grids, fewer samples and smaller images: a first look in a few seconds.
    #[arg(long)]
    quick: bool,
}

#[derive(Args)]
struct ModelsArgs {
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval(a) => cmd_eval(a),
        Command::Table(a) => cmd_table(a),
        Command::Models(a) => cmd_models(a),
        Command::Demo(a) => cmd_demo(a),
        Command::Bench(a) => cmd_bench(a),
        Command::Tradeoff(a) => cmd_tradeoff(a),
        Command::Preview(a) => cmd_preview(a),
        Command::Stability(a) => cmd_stability(a),
        Command::Run(a) => cmd_run(a),
        Command::Albedo(a) => cmd_albedo(a),
        Command::Energy(a) => cmd_energy(a),
        Command::Plot(a) => cmd_plot(a),
    };
    if let Err(e) = result {
        eprintln!("lobe: error: {e:#}");
        std::process::exit(1);
    }
}

fn params_of(a: &ModelArgs) -> Result<ParamSet> {
    Ok(resolve_params(&a.model, a.material.as_deref(), &a.sets)?)
}

/// The process-wide cancellation token: Ctrl-C (SIGINT, SIGTERM) sets it; a second Ctrl-C
/// while a job is still unwinding exits at once with status 130.
fn cancel_token() -> &'static lobe::CancelToken {
    static TOKEN: std::sync::OnceLock<lobe::CancelToken> = std::sync::OnceLock::new();
    TOKEN.get_or_init(lobe::CancelToken::new)
}

/// Installs the Ctrl-C handler that sets [`cancel_token`] (a second call is harmless).
fn install_ctrl_c() -> Result<()> {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    let mut result = Ok(());
    INSTALLED.call_once(|| {
        result = ctrlc::set_handler(|| {
            let token = cancel_token();
            if token.is_cancelled() {
                std::process::exit(130);
            }
            token.cancel();
        })
        .map_err(|e| anyhow::anyhow!("installing the Ctrl-C handler: {e}"));
    });
    result
}

/// Opens the session the backend arguments ask for. The environment switches of the command
/// line become session options here: `LOBE_VALIDATION=1` (the Khronos validation layer),
/// `LOBE_INJECT_DEVICE_LOST=1` (every dispatch fails as a lost device would), `LOBE_LOG=1`
/// (each pipeline built, on stderr).
fn open_session(backend: Backend, device: Option<String>) -> Result<Session> {
    let env_on = |name: &str| std::env::var(name).is_ok_and(|v| v == "1");
    let log: Option<lobe::gpu::LogSink> = std::env::var("LOBE_LOG")
        .is_ok_and(|v| v != "0")
        .then(|| std::sync::Arc::new(|line: &str| eprintln!("lobe: {line}")) as _);
    let opts = SessionOptions {
        backend: match backend {
            Backend::Gpu => BackendKind::Gpu,
            Backend::Cpu => BackendKind::Cpu,
        },
        device,
        validation: env_on("LOBE_VALIDATION"),
        inject_device_lost: env_on("LOBE_INJECT_DEVICE_LOST"),
        log,
        cancel: cancel_token().clone(),
    };
    Ok(Session::open(opts)?)
}

/// Runs `f` with the evaluator the arguments ask for; the session lives for the call.
fn with_evaluator<T>(a: &ModelArgs, f: impl FnOnce(&Evaluator) -> Result<T>) -> Result<T> {
    let session = open_session(a.backend, a.device.clone())?;
    f(&session.evaluator())
}

/// Parses `THETA,PHI` in degrees.
fn parse_angles(flag: &str, text: &str) -> Result<[f64; 2]> {
    let nums: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            anyhow::anyhow!("{flag} '{text}': expected THETA,PHI in degrees, e.g. {flag} 30,0")
        })?;
    let [theta, phi] = nums[..] else {
        bail!("{flag} '{text}': expected two numbers THETA,PHI in degrees")
    };
    check_angles(flag, theta, phi)?;
    Ok([theta, phi])
}

fn check_angles(what: &str, theta: f64, phi: f64) -> Result<()> {
    if !(0.0..=180.0).contains(&theta) {
        bail!("{what}: theta = {theta} deg is out of range; valid range is [0, 180] (f = 0 beyond 90)");
    }
    if !phi.is_finite() {
        bail!("{what}: phi = {phi} deg must be a finite number");
    }
    Ok(())
}

fn read_pairs(path: &PathBuf) -> Result<Vec<[f64; 4]>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    const HEADER: &str = "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg";
    match lines.next() {
        Some((_, h)) if h.replace(' ', "") == HEADER => {}
        _ => bail!(
            "{}: the first line must be the header {HEADER}",
            path.display()
        ),
    }
    let mut out = Vec::new();
    for (n, line) in lines {
        let where_ = format!("{} line {}", path.display(), n + 1);
        let nums: Vec<f64> = line
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| anyhow::anyhow!("{where_}: '{line}' is not four numbers"))?;
        let [ti, pi, to, po] = nums[..] else {
            bail!("{where_}: expected four numbers, found {}", nums.len())
        };
        check_angles(&where_, ti, pi)?;
        check_angles(&where_, to, po)?;
        out.push([ti, pi, to, po]);
    }
    Ok(out)
}

fn cmd_eval(a: EvalArgs) -> Result<()> {
    let params = params_of(&a.model)?;
    let angles: Vec<[f64; 4]> = match (&a.wi, &a.wo, &a.pairs) {
        (Some(wi), Some(wo), None) => {
            let [ti, pi] = parse_angles("--wi", wi)?;
            let [to, po] = parse_angles("--wo", wo)?;
            vec![[ti, pi, to, po]]
        }
        (None, None, Some(path)) => read_pairs(path)?,
        _ => bail!("give either --wi THETA,PHI --wo THETA,PHI or --pairs FILE.csv"),
    };
    let dirs: Vec<(DVec3, DVec3)> = angles
        .iter()
        .map(|[ti, pi, to, po]| {
            (
                direction(ti.to_radians(), pi.to_radians()),
                direction(to.to_radians(), po.to_radians()),
            )
        })
        .collect();
    let (values, backend) = with_evaluator(&a.model, |e| {
        Ok((
            e.eval_pairs(&params, a.model.white_furnace, &dirs)?,
            e.name(),
        ))
    })?;
    let mut out = std::io::stdout().lock();
    match a.format {
        Format::Csv => {
            writeln!(out, "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,r,g,b")?;
            for ([ti, pi, to, po], [r, g, b]) in angles.iter().zip(&values) {
                writeln!(out, "{ti},{pi},{to},{po},{r},{g},{b}")?;
            }
        }
        Format::Json => {
            let rows: Vec<_> = angles
                .iter()
                .zip(&values)
                .map(|([ti, pi, to, po], rgb)| {
                    serde_json::json!({"theta_i_deg": ti, "phi_i_deg": pi, "theta_o_deg": to, "phi_o_deg": po, "rgb": rgb})
                })
                .collect();
            let doc = serde_json::json!({
                "model": params.model().name(),
                "parameters": params.to_json(),
                "white_furnace": a.model.white_furnace,
                "backend": backend,
                "units": "1/sr, linear RGB, without the cosine; delta lobes excluded",
                "values": rows,
            });
            writeln!(out, "{}", serde_json::to_string_pretty(&doc)?)?;
        }
    }
    Ok(())
}

/// Cells above which a table is refused before any work starts: 2^32, the GPU kernel's cell index
/// (48 GiB of float32 RGB).
const MAX_TABLE_CELLS: u64 = u32::MAX as u64;

fn cmd_table(a: TableArgs) -> Result<()> {
    install_ctrl_c()?;
    if let Some(scene) = &a.scene {
        return run_scene(
            scene,
            a.output_dir.as_deref().unwrap_or(std::path::Path::new(".")),
            a.model.backend,
            a.model.device.clone(),
            lobe::scene::Outputs::TABLES,
        );
    }
    if a.output_dir.is_some() {
        bail!("--output-dir applies only with --scene; for one table give -o PATH.exr");
    }
    let (Some(res), Some(output)) = (&a.res, &a.output) else {
        bail!("give --res and -o PATH.exr, or --scene FILE");
    };
    let params = params_of(&a.model)?;
    let grid = Grid::parse(&a.grid, res).map_err(anyhow::Error::msg)?;
    if grid.needs_isotropy() && !params.is_isotropic() {
        let full = match grid {
            Grid::Isotropic { .. } => "--grid full",
            _ => "--grid halfdiff with four numbers NTHETA_H,NPHI_H,NTHETA_D,NPHI_D",
        };
        bail!(
            "--grid {} with --res {res} needs an isotropic parameter set, but {} with {} is anisotropic; use {full}",
            grid.name(),
            params.model().name(),
            params.to_text()
        );
    }
    let cells = grid.cells().filter(|&c| c <= MAX_TABLE_CELLS).ok_or_else(|| {
        anyhow::anyhow!("--res {}: the table would have more than {MAX_TABLE_CELLS} cells; lower the resolution", res)
    })?;
    if output.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "-o {}: the output must end in .exr (the .npy and .json are written beside it)",
            output.display()
        );
    }
    with_evaluator(&a.model, |e| {
        let meta = TableMeta {
            params: &params,
            white_furnace: a.model.white_furnace,
            grid,
            backend: e.name(),
        };
        let bar = indicatif::ProgressBar::new(cells);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{msg} [{bar:40}] {percent}% {per_sec} eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(format!("{} table", params.model().name()));
        let started = std::time::Instant::now();
        write_table(e, &meta, output, &mut |done, _| bar.set_position(done))?;
        bar.finish_and_clear();
        let (npy, json) = lobe::table::sibling_paths(output);
        eprintln!(
            "lobe: wrote {} ({} cells, {:.2} s on {}), {} and {}",
            output.display(),
            cells,
            started.elapsed().as_secs_f64(),
            e.name(),
            npy.display(),
            json.display()
        );
        Ok(())
    })
}

fn cmd_models(a: ModelsArgs) -> Result<()> {
    let mut out = std::io::stdout().lock();
    if a.json {
        let models: Vec<_> = Model::ALL
            .iter()
            .map(|m| {
                let params: Vec<_> = m
                    .params()
                    .iter()
                    .map(|p| serde_json::json!({"key": p.key, "kind": match p.kind { ParamKind::Rgb => "rgb", ParamKind::Scalar => "scalar", ParamKind::Choice(_) => "choice" },
                        "range": p.range_text(), "default": p.default_value().to_string(), "description": p.doc}))
                    .collect();
                serde_json::json!({"name": m.name(), "description": m.description(), "delta_lobe": m.has_delta(), "parameters": params})
            })
            .collect();
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(
                &serde_json::json!({"models": models, "materials": material::all_names()})
            )?
        )?;
        return Ok(());
    }
    for m in Model::ALL {
        writeln!(
            out,
            "{}{}\n  {}",
            m.name(),
            if m.has_delta() { "  [delta lobe]" } else { "" },
            m.description()
        )?;
        for p in m.params() {
            let kind = match p.kind {
                ParamKind::Rgb => "rgb",
                ParamKind::Choice(_) => "one of",
                ParamKind::Scalar => "",
            };
            writeln!(
                out,
                "    {:<12} {:<4} {:<14} default {:<8} {}",
                p.key,
                kind,
                p.range_text(),
                p.default_value().to_string(),
                p.doc
            )?;
        }
    }
    writeln!(
        out,
        "\nmaterials (--material): {} (lab materials, every model); {} (metals, microfacet only)",
        material::names().join(", "),
        material::METALS
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    Ok(())
}

fn cmd_demo(a: DemoArgs) -> Result<()> {
    install_ctrl_c()?;
    let model_args = ModelArgs {
        model: "lambert".into(),
        sets: Vec::new(),
        material: None,
        white_furnace: false,
        backend: a.backend,
        device: a.device.clone(),
    };
    let settings = if a.quick {
        lobe::demo::Settings::quick()
    } else {
        lobe::demo::Settings::full()
    };
    let report = with_evaluator(&model_args, |e| {
        eprintln!(
            "lobe demo: {} settings on {}, writing {}",
            settings.name,
            e.name(),
            a.output.display()
        );
        lobe::demo::run(e, &a.output, &settings, &mut DemoBars { bar: None })
    })?;
    println!("{}", report.summary());
    Ok(())
}

/// One indicatif bar per demo step; each finished step leaves a line with its time.
struct DemoBars {
    bar: Option<indicatif::ProgressBar>,
}

impl lobe::demo::Progress for DemoBars {
    fn begin(&mut self, step: &str, total: u64) {
        let bar = indicatif::ProgressBar::new(total.max(1));
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{prefix:>8} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_prefix(step.to_string());
        self.bar = Some(bar);
    }

    fn advance(&mut self, done: u64) {
        if let Some(b) = &self.bar {
            b.set_position(done);
        }
    }

    fn end(&mut self, step: &lobe::demo::Step) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        // A live line per finished step on a terminal; the summary on stdout repeats them all.
        if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            eprintln!("{:>8} {:>7.2} s  {}", step.name, step.seconds, step.detail);
        }
    }
}

fn cmd_bench(a: BenchArgs) -> Result<()> {
    let models: Vec<Model> = if a.models.is_empty() {
        Model::ALL.to_vec()
    } else {
        a.models
            .iter()
            .map(|m| Model::from_name(m))
            .collect::<Result<_, _>>()?
    };
    let grid = Grid::parse("isotropic", &a.res).map_err(anyhow::Error::msg)?;
    let mut rows = Vec::new();
    for backend in &a.backend {
        let args = ModelArgs {
            model: "lambert".into(),
            sets: Vec::new(),
            material: None,
            white_furnace: false,
            backend: *backend,
            device: a.device.clone(),
        };
        with_evaluator(&args, |e| {
            let bar = indicatif::ProgressBar::new(models.len() as u64);
            bar.set_style(
                indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            for m in &models {
                bar.set_message(format!("bench {} on {}", m.name(), e.name()));
                rows.push(lobe::bench::measure(
                    e,
                    &ParamSet::defaults(*m),
                    &grid,
                    a.repeats,
                )?);
                if !a.no_albedo {
                    rows.push(lobe::bench::measure_albedo(
                        e,
                        &ParamSet::defaults(*m),
                        a.repeats,
                    )?);
                }
                bar.inc(1);
            }
            bar.finish_and_clear();
            Ok(())
        })?;
    }
    let mut out = std::io::stdout().lock();
    match a.format {
        TableFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?,
        TableFormat::Csv => {
            writeln!(
                out,
                "model,task,backend,evaluations,wall_evals_per_s,kernel_evals_per_s"
            )?;
            for r in &rows {
                let k = r.kernel_per_s.map(|k| k.to_string()).unwrap_or_default();
                writeln!(
                    out,
                    "{},{},{},{},{},{k}",
                    r.model, r.task, r.backend, r.evaluations, r.wall_per_s
                )?;
            }
        }
        TableFormat::Table => {
            writeln!(
                out,
                "evaluations per second, median of {} runs: table = {} cells of an isotropic table; \
                 albedo = {} view directions x {} nodes (Gauss-Legendre, with its coarse check)",
                a.repeats,
                grid.cells().unwrap_or(0),
                lobe::bench::ALBEDO_DIRECTIONS,
                lobe::bench::ALBEDO_RULE.nodes(glam::DVec3::Z).len()
                    + lobe::bench::ALBEDO_RULE.coarse().0.nodes(glam::DVec3::Z).len()
            )?;
            writeln!(
                out,
                "{:<18} {:<7} {:<44} {:>14} {:>16}",
                "model", "task", "backend", "wall (M/s)", "kernel (M/s)"
            )?;
            for r in &rows {
                let k = r
                    .kernel_per_s
                    .map(|k| format!("{:.1}", k / 1e6))
                    .unwrap_or_else(|| "-".into());
                writeln!(
                    out,
                    "{:<18} {:<7} {:<44} {:>14.1} {:>16}",
                    r.model,
                    r.task,
                    r.backend,
                    r.wall_per_s / 1e6,
                    k
                )?;
            }
        }
    }
    Ok(())
}

fn cmd_tradeoff(a: TradeoffArgs) -> Result<()> {
    use lobe::tradeoff::{AlbedoSetup, Options, Section};
    let params = params_of(&a.model)?;
    let sections = a
        .sections
        .iter()
        .map(|s| Section::from_name(s.trim()))
        .collect::<Result<Vec<_>>>()?;
    let mut albedo = if a.quick {
        AlbedoSetup::quick()
    } else {
        AlbedoSetup::standard()
    };
    albedo.mus = a.mu.clone();
    if !a.samples.is_empty() {
        albedo.samples = a.samples.clone();
    }
    if !a.table_res.is_empty() {
        albedo.table_res = a.table_res.clone();
    }
    if let Some(r) = a.repeats {
        albedo.repeats = r;
    }
    let grid = |flag: &str, text: &Option<String>, standard: &str, quick: &str| {
        let res = text
            .as_deref()
            .unwrap_or(if a.quick { quick } else { standard });
        Grid::parse("isotropic", res).map_err(|e| anyhow::anyhow!("{flag}: {e}"))
    };
    let opts = Options {
        sections,
        error_grid: lobe::tradeoff::error_grid_for(
            &params,
            grid("--error-res", &a.error_res, "32,32,64", "16,16,32")?,
        ),
        timing_grid: grid("--timing-res", &a.timing_res, "96,96,192", "48,48,96")?,
        eval_repeats: albedo.repeats,
        albedo,
    };
    let plot_path = (!a.no_plot).then(|| {
        a.plot.clone().unwrap_or_else(|| {
            PathBuf::from(match &a.model.material {
                Some(m) => format!("tradeoff-{m}-{}.png", params.model().name()),
                None => format!("tradeoff-{}.png", params.model().name()),
            })
        })
    });
    let size = a
        .size
        .split_once('x')
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)))
        .with_context(|| format!("--size '{}': expected WIDTHxHEIGHT, e.g. 1800x720", a.size))?;
    if let Some(p) = &plot_path {
        // Refused before minutes of measuring, not after.
        lobe::plot::Format::of(p)?;
    }
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let material = a.model.material.as_deref();
    let mut progress = |step: usize, steps: usize, what: &str| {
        bar.set_length(steps as u64);
        bar.set_position(step as u64);
        bar.set_message(what.to_string());
    };
    let session = open_session(a.model.backend, a.model.device.clone())?;
    let report = lobe::tradeoff::run(
        &session.evaluator(),
        &params,
        material,
        &opts,
        &mut progress,
    )?;
    bar.finish_and_clear();
    let mut out = std::io::stdout().lock();
    match a.format {
        TableFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&report.to_json())?)?,
        TableFormat::Csv => report.write_csv(&mut out)?,
        TableFormat::Table => report.write_table(&mut out)?,
    }
    if let Some(p) = plot_path {
        lobe::plot::pareto::plot_pareto(&report, size, &p)?;
        eprintln!("lobe: wrote {}", p.display());
    }
    Ok(())
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum ShapeArg {
    /// A sphere of radius 1, three units in front of the camera.
    Sphere,
    /// The lab's regular icosahedron (circumradius 1, flat faces) in the same place.
    Icosahedron,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum LightsArg {
    /// Point lights at the lab's positions, in the camera's space (OpenGL eye space, w = 1).
    Point,
    /// Directional lights toward the lab's vectors (OpenGL w = 0).
    Directional,
}

#[derive(Args)]
struct PreviewArgs {
    /// Render every preview a scene file asks for instead (see `lobe run --help`), with its own
    /// lights, camera and settings; the other flags except --backend and --device do not apply.
    #[arg(long, value_name = "SCENE.toml")]
    scene: Option<PathBuf>,
    /// With --scene: the folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR", requires = "scene")]
    output_dir: Option<PathBuf>,
    /// Output PNG (tone-mapped, labelled); the linear radiance goes to the .exr beside it.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH.png",
        default_value = "preview.png"
    )]
    output: PathBuf,
    /// Models, one column each (repeatable or comma-separated; default: every model).
    #[arg(long = "model", value_delimiter = ',')]
    models: Vec<String>,
    /// Material presets, one row each (repeatable or comma-separated; default: tin, gold, glazed_ceramic, granite).
    #[arg(long = "material", value_delimiter = ',')]
    materials: Vec<String>,
    /// The object in every cell.
    #[arg(long, value_enum, default_value_t = ShapeArg::Sphere)]
    shape: ShapeArg,
    /// How the lab's light vectors (0,0,1), (0,1,1), (1,0,1), (-1,0,1) are read.
    #[arg(long, value_enum, default_value_t = LightsArg::Point)]
    lights: LightsArg,
    /// Cell size in pixels (square).
    #[arg(long, default_value_t = lobe::preview::DEFAULT_CELL)]
    cell: u32,
    /// Exposure of the PNG in stops (EV): radiance is multiplied by 2^EV before sRGB encoding.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f64,
    /// Radiance of a uniform white sky, one number or r,g,b (default 0: the lab has no ambient light).
    /// Approximated as its irradiance pi*A arriving along the normal: exact for Lambert only.
    #[arg(long, value_name = "A or R,G,B")]
    ambient: Option<String>,
    /// Where to render.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
}

fn cmd_preview(a: PreviewArgs) -> Result<()> {
    use lobe::preview::{self, LightKind, Scene, Shape, Sheet};
    if let Some(scene) = &a.scene {
        install_ctrl_c()?;
        return run_scene(
            scene,
            a.output_dir.as_deref().unwrap_or(std::path::Path::new(".")),
            a.backend,
            a.device.clone(),
            lobe::scene::Outputs::PREVIEWS,
        );
    }
    if a.output.extension().and_then(|e| e.to_str()) != Some("png") {
        bail!(
            "-o {}: the output must end in .png (the .exr is written beside it)",
            a.output.display()
        );
    }
    if !a.exposure.is_finite() {
        bail!(
            "--exposure {}: expected a finite number of stops",
            a.exposure
        );
    }
    if !(1..=4096).contains(&a.cell) {
        bail!(
            "--cell {}: expected a cell size in [1, 4096] pixels",
            a.cell
        );
    }
    let ambient = match &a.ambient {
        None => DVec3::ZERO,
        Some(text) => {
            let nums: Vec<f64> = text
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| anyhow::anyhow!("--ambient '{text}': expected one number or r,g,b"))?;
            let v = match nums[..] {
                [g] => DVec3::splat(g),
                [r, g, b] => DVec3::new(r, g, b),
                _ => bail!("--ambient '{text}': expected one number or r,g,b"),
            };
            if !v.is_finite() || v.min_element() < 0.0 {
                bail!("--ambient '{text}': radiance must be finite and >= 0");
            }
            v
        }
    };
    let models: Vec<Model> = if a.models.is_empty() {
        Model::ALL.to_vec()
    } else {
        a.models
            .iter()
            .map(|m| Model::from_name(m))
            .collect::<Result<_, _>>()?
    };
    let materials: Vec<String> = if a.materials.is_empty() {
        material::names().into_iter().map(String::from).collect()
    } else {
        a.materials.clone()
    };
    let sheet = Sheet::new(&materials, &models)?;
    let shape = match a.shape {
        ShapeArg::Sphere => Shape::Sphere,
        ShapeArg::Icosahedron => Shape::Icosahedron,
    };
    let kind = match a.lights {
        LightsArg::Point => LightKind::Point,
        LightsArg::Directional => LightKind::Directional,
    };
    let scene = Scene::lab(a.cell, shape, kind, ambient);
    let exr_path = a.output.with_extension("exr");
    let model_args = ModelArgs {
        model: "lambert".into(),
        sets: Vec::new(),
        material: None,
        white_furnace: false,
        backend: a.backend,
        device: a.device.clone(),
    };
    with_evaluator(&model_args, |e| {
        let bar = indicatif::ProgressBar::new(models.len() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} columns")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(format!("preview on {}", e.name()));
        let started = std::time::Instant::now();
        let image = preview::render(e, &sheet, &scene, &mut |done, _| {
            bar.set_position(done as u64)
        })?;
        let render_time = started.elapsed();
        bar.finish_and_clear();
        preview::write_exr(&image, &sheet, &scene, &e.name(), &exr_path)?;
        let caption = preview::caption(&scene, a.exposure, &e.name());
        let (png_w, png_h) = preview::write_png(&image, &sheet, a.exposure, &caption, &a.output)?;
        eprintln!(
            "lobe: rendered {} x {} cells of {} px in {:.2} s on {}; wrote {} ({png_w}x{png_h}, labelled) and {} ({}x{}, linear radiance)",
            sheet.materials.len(),
            sheet.models.len(),
            a.cell,
            render_time.as_secs_f64(),
            e.name(),
            a.output.display(),
            exr_path.display(),
            image.width(),
            image.height()
        );
        Ok(())
    })
}

fn cmd_stability(a: StabilityArgs) -> Result<()> {
    use lobe::stability;
    install_ctrl_c()?;
    let models = stability::models_named(&a.models)?;
    let bar = indicatif::ProgressBar::new(models.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut progress = |label: &str| {
        bar.set_message(format!("stability {label}"));
        bar.inc(1);
    };
    let backend = if a.cpu_only {
        Backend::Cpu
    } else {
        Backend::Gpu
    };
    let session = open_session(backend, a.device.clone())?;
    let report = session.stability(models, &mut progress)?;
    bar.finish_and_clear();
    let mut out = std::io::stdout().lock();
    match a.format {
        StabilityFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?,
        StabilityFormat::Table => write!(out, "{}", stability::format_table(&report, a.all))?,
    }
    let bad = report.bad_values();
    if bad > 0 {
        bail!("{bad} NaN, infinite or negative values on valid input (see the table)");
    }
    Ok(())
}

fn cmd_energy(a: EnergyArgs) -> Result<()> {
    use lobe::energy;
    use lobe::integrate::Method;
    let method = Method::from_name(&a.method)?;
    if let Some(0) = a.samples {
        bail!("--samples 0: expected a positive number of nodes per direction");
    }
    let samples = a.samples.unwrap_or(method.default_samples());
    let models: Vec<Model> = if a.models.is_empty() {
        Model::ALL.to_vec()
    } else {
        a.models
            .iter()
            .map(|m| Model::from_name(m).with_context(|| format!("--models {m}")))
            .collect::<Result<_>>()?
    };
    let bar = indicatif::ProgressBar::new(0);
    let run = |e: &Evaluator| {
        energy::report(e, &models, a.sweep, method, samples, &mut |done, total| {
            bar.set_length(total);
            bar.set_position(done);
        })
    };
    let session = open_session(a.backend, a.device.clone())?;
    let rows = run(&session.evaluator())?;
    bar.finish_and_clear();
    let mut out = std::io::stdout().lock();
    match a.format {
        TableFormat::Table => {
            write!(out, "{}", energy::format_table(&rows))?;
            writeln!(
                out,
                "white configuration: colours at 1, specular lobes alone under the white furnace, smooth_layered diffuse = 1 - R0; gain: E > 1 + {} beyond its error estimate; loss = 1 - E_avg; method {} ({} nodes per direction)",
                energy::GAIN_MARGIN,
                method.name(),
                samples
            )?;
        }
        TableFormat::Csv => write!(out, "{}", energy::format_csv(&rows))?,
        TableFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "method": method.name(),
                "samples": samples,
                "gain_margin": energy::GAIN_MARGIN,
                "definition": "white configuration: colours at 1 (lambert, oren_nayar albedo; coupled matte), the specular lobe alone under the white furnace (phong, blinn_phong, cook_torrance, ashikhmin_shirley, microfacet), smooth_layered diffuse = 1 - R0; gain: max E(mu) > 1 + gain_margin beyond its error estimate; loss = 1 - E_avg",
                "rows": rows,
            }))?
        )?,
    }
    Ok(())
}

/// Parses `A,B` for `flag` into two values.
fn parse_pair<T: std::str::FromStr>(flag: &str, text: &str, what: &str) -> Result<(T, T)> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if let [a, b] = parts[..] {
        if let (Ok(a), Ok(b)) = (a.parse(), b.parse()) {
            return Ok((a, b));
        }
    }
    bail!("{flag} {text}: expected {what}")
}

/// `lobe albedo --lut`: the look-up table over mu and one parameter axis.
fn albedo_lut(
    a: &AlbedoArgs,
    params: ParamSet,
    settings: lobe::integrate::Settings,
    phi: f64,
    path: &std::path::Path,
) -> Result<()> {
    use lobe::lut;
    let mut spec = lut::LutSpec::new(params, a.model.white_furnace);
    spec.method = settings.method;
    spec.samples = settings.samples;
    spec.phi = phi;
    if !a.lut_param.is_empty() {
        spec.keys = a.lut_param.clone();
        // Another axis than the model's own: its full valid range, linear, unless given.
        let model = spec.params.model();
        let (default_keys, ..) = lut::default_axis(model);
        if a.lut_param != default_keys {
            if let Some(s) = model.params().iter().find(|s| s.key == a.lut_param[0]) {
                spec.lo = s.min;
                spec.hi = s.max;
                spec.mapping = lut::Mapping::Linear;
            }
        }
    }
    if let Some(r) = &a.lut_range {
        (spec.lo, spec.hi) = parse_pair("--lut-range", r, "LO,HI (two numbers)")?;
    }
    if let Some(r) = &a.lut_res {
        (spec.n_mu, spec.n_p) = parse_pair("--lut-res", r, "NMU,NP (two positive integers)")?;
    }
    if let Some(m) = &a.lut_map {
        spec.mapping = lut::Mapping::from_name(m).context("--lut-map")?;
    }
    spec.validate()?;
    let bar = indicatif::ProgressBar::new(spec.n_p as u64);
    let summary = with_evaluator(&a.model, |e| {
        lut::write(e, &spec, path, &mut |done, _| bar.set_position(done))
    })?;
    bar.finish_and_clear();
    let mut out = std::io::stdout().lock();
    let files: Vec<String> = summary
        .files
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let range = |v: &[glam::DVec3]| {
        v.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                (lo.min(c.min_element()), hi.max(c.max_element()))
            })
    };
    let (e_lo, e_hi) = range(&summary.e);
    let (a_lo, a_hi) = range(&summary.e_avg);
    match a.format {
        TableFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "files": files,
                "model": spec.params.model().name(),
                "keys": spec.keys,
                "range": [spec.lo, spec.hi],
                "mapping": spec.mapping.name(),
                "res": [spec.n_mu, spec.n_p],
                "method": spec.method.name(),
                "samples": spec.samples,
                "e_range": [e_lo, e_hi],
                "e_avg_range": [a_lo, a_hi],
                "max_error_estimate": summary.max_error,
                "seconds": summary.seconds,
            }))?
        )?,
        _ => {
            writeln!(
                out,
                "{} LUT over mu ({} cells) x {} in [{}, {}] ({} cells, {}): E in [{e_lo:.6}, {e_hi:.6}], E_avg in [{a_lo:.6}, {a_hi:.6}], largest error estimate {:.2e}; {} {} nodes per direction; {:.2} s",
                spec.params.model().name(),
                spec.n_mu,
                spec.keys.join(","),
                spec.lo,
                spec.hi,
                spec.n_p,
                spec.mapping.name(),
                summary.max_error,
                spec.method.name(),
                spec.samples,
                summary.seconds
            )?;
            for f in files {
                writeln!(out, "wrote {f}")?;
            }
        }
    }
    Ok(())
}

fn cmd_albedo(a: AlbedoArgs) -> Result<()> {
    use lobe::integrate::{albedo_report, Method, Settings};
    if let Some(scene) = &a.scene {
        install_ctrl_c()?;
        return run_scene(
            scene,
            a.output_dir.as_deref().unwrap_or(std::path::Path::new(".")),
            a.model.backend,
            a.model.device.clone(),
            lobe::scene::Outputs::ALBEDOS,
        );
    }
    let params = params_of(&a.model)?;
    let method = Method::from_name(&a.method)?;
    if !a.phi_deg.is_finite() {
        bail!(
            "--phi-deg {}: expected a finite number of degrees",
            a.phi_deg
        );
    }
    let mus: Vec<f64> = if !a.theta_deg.is_empty() {
        a.theta_deg
            .iter()
            .map(|&t| {
                if (0.0..90.0).contains(&t) {
                    Ok(t.to_radians().cos())
                } else {
                    bail!("--theta-deg {t}: expected theta_o in [0, 90) degrees")
                }
            })
            .collect::<Result<_>>()?
    } else if !a.mu.is_empty() {
        for &m in &a.mu {
            if !(m > 0.0 && m <= 1.0) {
                bail!("--mu {m}: expected mu = cos(theta_o) in (0, 1]");
            }
        }
        a.mu.clone()
    } else {
        vec![0.1, 0.5, 1.0]
    };
    if let Some(0) = a.samples {
        bail!("--samples 0: expected a positive number of nodes per direction");
    }
    let settings = Settings {
        method,
        samples: a.samples.unwrap_or(method.default_samples()),
        white_furnace: a.model.white_furnace,
    };
    let phi = a.phi_deg.to_radians();
    if let Some(path) = &a.lut {
        return albedo_lut(&a, params, settings, phi, path);
    }
    let points: Vec<(f64, f64)> = mus.iter().map(|&m| (m, phi)).collect();
    let (report, backend) = with_evaluator(&a.model, |e| {
        // A spinner: the hemispherical albedo of an anisotropic model integrates thousands of
        // view directions (seconds to tens of seconds on lavapipe).
        let spinner = indicatif::ProgressBar::new_spinner();
        spinner.set_message(format!(
            "integrating {} with {} on {}",
            params.model().name(),
            method.name(),
            e.name()
        ));
        spinner.enable_steady_tick(std::time::Duration::from_millis(120));
        let report = albedo_report(e, &params, &settings, &points, phi);
        spinner.finish_and_clear();
        Ok((report?, e.name()))
    })?;
    let mut out = std::io::stdout().lock();
    let rgb = |v: glam::DVec3| format!("{:.9},{:.9},{:.9}", v.x, v.y, v.z);
    let h = &report.hemispherical;
    match a.format {
        TableFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&report.to_json(
                &params,
                a.model.white_furnace,
                &backend
            ))?
        )?,
        TableFormat::Csv => {
            writeln!(out, "kind,mu,theta_deg,phi_deg,albedo_r,albedo_g,albedo_b,delta_r,delta_g,delta_b,error_r,error_g,error_b,samples")?;
            for p in &report.points {
                writeln!(
                    out,
                    "directional,{},{},{},{},{},{},{}",
                    p.mu,
                    p.mu.acos().to_degrees(),
                    p.phi.to_degrees(),
                    rgb(p.albedo),
                    rgb(p.delta),
                    rgb(p.error),
                    p.samples
                )?;
            }
            writeln!(
                out,
                "hemispherical,,,,{},{},{},{}",
                rgb(h.albedo),
                rgb(h.delta),
                rgb(h.error),
                h.samples
            )?;
        }
        TableFormat::Table => {
            writeln!(out, "{} {}", params.model().name(), params.to_text())?;
            writeln!(
                out,
                "method {} ({} nodes per direction) on {}{}",
                report.method.name(),
                report.samples,
                backend,
                if a.model.white_furnace {
                    ", white furnace"
                } else {
                    ""
                }
            )?;
            writeln!(
                out,
                "{:>8} {:>8} {:>8}  {:<38} {:<38} {:>10}",
                "mu", "theta", "phi", "albedo r,g,b (incl. delta)", "delta r,g,b", "error est"
            )?;
            for p in &report.points {
                writeln!(
                    out,
                    "{:>8.4} {:>8.3} {:>8.3}  {:<38} {:<38} {:>10.2e}",
                    p.mu,
                    p.mu.acos().to_degrees(),
                    p.phi.to_degrees(),
                    rgb(p.albedo),
                    rgb(p.delta),
                    p.error.max_element()
                )?;
            }
            writeln!(
                out,
                "hemispherical albedo {} (delta {}) error est {:.2e}; E_avg at phi {} deg {}",
                rgb(h.albedo),
                rgb(h.delta),
                h.error.max_element(),
                a.phi_deg,
                rgb(h.e_avg)
            )?;
            writeln!(out, "{:.3} s", report.seconds)?;
        }
    }
    Ok(())
}

fn cmd_run(a: RunArgs) -> Result<()> {
    install_ctrl_c()?;
    run_scene(
        &a.scene,
        &a.output_dir,
        a.backend,
        a.device,
        lobe::scene::Outputs::ALL,
    )
}

/// Loads a scene, checks every output before any work, produces `what`, and lists the pipelines
/// built with their build times.
fn run_scene(
    path: &std::path::Path,
    out_dir: &std::path::Path,
    backend: Backend,
    device: Option<String>,
    what: lobe::scene::Outputs,
) -> Result<()> {
    let scene = lobe::scene::load(path)?;
    for (kind, asked, none) in [
        ("tables", what.tables, scene.tables.is_empty()),
        ("albedos", what.albedos, scene.albedos.is_empty()),
        ("previews", what.previews, scene.previews.is_empty()),
    ] {
        if what != lobe::scene::Outputs::ALL && asked && none {
            bail!("{}: the scene asks for no {kind}", path.display());
        }
    }
    let needed: Vec<&str> = scene.models_needed(what).iter().map(|m| m.name()).collect();
    eprintln!(
        "lobe: scene '{}' ({}): {} materials, {} lights; kernels needed for: {}",
        scene.name,
        path.display(),
        scene.materials.len(),
        scene.lights.len(),
        needed.join(", ")
    );
    let mut log = |line: &str| println!("wrote {line}");
    let session = open_session(backend, device)?;
    let result = scene.run(&session.evaluator(), out_dir, what, &mut log);
    if let Some(gpu) = session.gpu() {
        let built = gpu.built_pipelines();
        println!("pipelines built: {}", built.len());
        for (label, time) in &built {
            println!("  {label}: {:.1} ms", time.as_secs_f64() * 1e3);
        }
    }
    let summary = result?;
    println!("lobe: {} files written", summary.written.len());
    Ok(())
}

fn cmd_plot(a: PlotArgs) -> Result<()> {
    use lobe::plot::{self, Channel, Common, Request, Subject};
    let models = if a.models.is_empty() {
        vec!["cook_torrance".to_string()]
    } else {
        a.models.clone()
    };
    let materials: Vec<Option<&str>> = if a.materials.is_empty() {
        vec![None]
    } else {
        a.materials.iter().map(|m| Some(m.as_str())).collect()
    };
    let mut subjects = Vec::new();
    for material in &materials {
        for model in &models {
            let params = resolve_params(model, *material, &a.sets)?;
            subjects.push(Subject::new(params, *material));
        }
    }
    let size = match &a.size {
        Some(text) => text
            .split_once('x')
            .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)))
            .with_context(|| format!("--size '{text}': expected WIDTHxHEIGHT, e.g. 1200x800"))?,
        None if a.kind == PlotKind::Hemisphere => {
            let cols = if a.theta_i_deg.is_empty() {
                4
            } else {
                a.theta_i_deg.len()
            };
            let rows = models.len() * materials.len();
            let side = (1090 / cols as u32).min(520);
            (1200, (150 + rows as u32 * (side + 30)).min(8000))
        }
        None => (1200, 800),
    };
    let common = Common {
        white_furnace: a.white_furnace,
        cos: a.cos,
        log: a.log || (a.kind == PlotKind::Hemisphere && !a.linear),
        decades: a.decades,
        channel: Channel::from_name(&a.channel)?,
        size,
    };
    let angles = |default: &[f64]| {
        if a.theta_i_deg.is_empty() {
            default.to_vec()
        } else {
            a.theta_i_deg.clone()
        }
    };
    let request = match a.kind {
        PlotKind::Polar => Request::Polar(plot::polar::PolarOptions {
            theta_i_deg: angles(&[0.0, 30.0, 60.0, 80.0]),
            samples: a.res.unwrap_or(plot::polar::DEFAULT_SAMPLES),
        }),
        PlotKind::Hemisphere => Request::Hemisphere(plot::hemisphere::HemisphereOptions {
            theta_deg: angles(&[0.0, 30.0, 60.0, 80.0]),
            phi_deg: a.phi_i_deg,
            reverse: a.reverse,
            projection: plot::hemisphere::Projection::from_name(&a.projection)?,
            res: a.res.unwrap_or(128),
        }),
        PlotKind::Slice => Request::Slice(plot::slice::SliceOptions {
            res: a.res.unwrap_or(90),
            phi_d_deg: a.phi_d_deg,
        }),
        PlotKind::ThreeD => {
            let rings = a.res.unwrap_or(60);
            Request::Surface3d(plot::surface3d::Surface3dOptions {
                theta_i_deg: angles(&[45.0]),
                phi_i_deg: a.phi_i_deg,
                n_theta: rings,
                n_phi: 2 * rings,
            })
        }
        PlotKind::Albedo => Request::Albedo(plot::albedo::AlbedoOptions {
            n_mu: a.res.unwrap_or(48),
            method: lobe::integrate::Method::from_name(&a.method)?,
            samples: a.samples,
            phi_deg: a.phi_i_deg,
        }),
    };
    let model_args = ModelArgs {
        model: models[0].clone(),
        sets: Vec::new(),
        material: None,
        white_furnace: a.white_furnace,
        backend: a.backend,
        device: a.device.clone(),
    };
    let start = std::time::Instant::now();
    let plotted = with_evaluator(&model_args, |e| {
        plot::plot(e, &subjects, &common, &request, &a.output)
    })?;
    let bytes = std::fs::metadata(&a.output).map(|m| m.len()).unwrap_or(0);
    println!(
        "lobe plot: wrote {} ({} bytes, {} evaluations, {:.2} s): {}",
        a.output.display(),
        bytes,
        plotted.evaluations(),
        start.elapsed().as_secs_f64(),
        plotted.title()
    );
    Ok(())
}
