//! `lobe albedo`: directional and hemispherical albedo, an albedo look-up table, or every albedo
//! of a scene.

use super::run::run_scene;
use super::{
    open_albedo_session, session_error, with_flag, BackendArgs, MethodArg, ModelArgs, TableFormat,
};
use anyhow::{anyhow, bail, Result};
use clap::{Args, ValueEnum};
use lobe::integrate::{AlbedoReport, Method, Settings};
use lobe::lut::engine::{EngineKind, EngineSpec};
use lobe::lut::{self, LutSpec, Mapping};
use lobe::Query;
use lobe::{ParamSet, Session};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How cell t_k = (k + 0.5)/NP of the LUT's parameter axis maps to a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum MappingArg {
    /// lo + (hi - lo) t.
    Linear,
    /// lo (hi/lo)^t; needs lo > 0.
    Log,
    /// lo + (hi - lo) t^2: denser at lo.
    Square,
    /// (lo + (hi - lo) t)^2: engines' perceptual roughness r with alpha = r^2, LO,HI given in r
    /// (LO may be 0).
    Perceptual,
}

impl From<MappingArg> for Mapping {
    fn from(m: MappingArg) -> Mapping {
        match m {
            MappingArg::Linear => Mapping::Linear,
            MappingArg::Log => Mapping::Log,
            MappingArg::Square => Mapping::Square,
            MappingArg::Perceptual => Mapping::Perceptual,
        }
    }
}

#[derive(Args)]
pub struct AlbedoArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    backend: BackendArgs,
    /// Write every albedo a scene file asks for instead (JSON, the default method; see
    /// `lobe run --help`); only --backend and --device apply then.
    #[arg(long, value_name = "SCENE.toml", conflicts_with_all = ["sets", "material", "lut"])]
    scene: Option<PathBuf>,
    /// With --scene: the folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR", requires = "scene")]
    output_dir: Option<PathBuf>,
    /// View directions as mu = cos(theta_o), comma-separated, each in (0, 1].
    #[arg(
        long,
        value_delimiter = ',',
        conflicts_with = "theta_deg",
        default_value = super::default_mus()
    )]
    mu: Vec<f64>,
    /// View directions as theta_o in degrees, comma-separated, each in [0, 90).
    #[arg(
        long = "theta-o-deg",
        visible_alias = "theta-deg",
        value_name = "THETA_O",
        value_delimiter = ','
    )]
    theta_deg: Vec<f64>,
    /// View azimuth phi_o in degrees (matters for anisotropic models; E_avg is taken at it).
    #[arg(
        long = "phi-o-deg",
        visible_alias = "phi-deg",
        value_name = "PHI_O",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    phi_deg: f64,
    /// Integrator (`--help` describes each).
    #[arg(long, value_enum, default_value_t = MethodArg::Peak)]
    method: MethodArg,
    /// Quadrature nodes per view direction (default depends on the method). For reference: its
    /// budget of integrand evaluations (default 50000000, for the view directions together and
    /// again for the hemispherical albedo); once spent it refines no further (each integral
    /// still finishes its first pass), says where it stopped short and reports how far it got.
    #[arg(long)]
    samples: Option<usize>,
    /// The stream the Monte Carlo methods (uniform, cosine, sampled) draw from, 0 to 4294967295
    /// (default 0): the same seed draws the same directions and gives the same estimate; another
    /// seed gives an independent one. The other methods draw nothing and refuse it.
    #[arg(
        long,
        value_name = "SEED",
        allow_hyphen_values = true,
        conflicts_with = "scene"
    )]
    seed: Option<u32>,
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
    /// LUT parameter mapping of cell t_k = (k + 0.5)/NP. Default per model (log for exponents,
    /// square for roughness, else linear).
    #[arg(long = "lut-map", value_enum, requires = "lut")]
    lut_map: Option<MappingArg>,
    /// With --lut: write a table a real-time engine loads instead (docs/luts.md), also as a C/C++
    /// header PATH.h of half floats and floats. Each picks its model (--set applies on top) and
    /// axis: perceptual roughness r in [0, 1] with alpha = r^2, except eon (its r, linear).
    #[arg(long, value_enum, requires = "lut", conflicts_with_all = ["material", "white_furnace", "lut_param"])]
    engine: Option<EngineArg>,
    /// Fail, writing nothing, when the largest error estimate exceeds E (absolute). Without it an
    /// estimate above 2^-10 (the step of half floats below 1) is only warned about.
    #[arg(long, value_name = "E")]
    max_error: Option<f64>,
}

/// The engine tables of --engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum EngineArg {
    /// Split-sum DFG of GGX, height-correlated Smith: R multiplies F0, G multiplies F90.
    Dfg,
    /// The same integrals as R = F90 part, G = E with F = 1 (for multiple-scattering
    /// compensation: E = mix(R, G, F0)).
    DfgMultiscatter,
    /// Kulla-Conty's E(mu, alpha) with F = 1 and E_avg(alpha) of microfacet.
    KullaConty,
    /// EON's single-scattering albedo E_hat(mu, r) and its average.
    Eon,
}

impl From<EngineArg> for EngineKind {
    fn from(e: EngineArg) -> EngineKind {
        match e {
            EngineArg::Dfg => EngineKind::Dfg,
            EngineArg::DfgMultiscatter => EngineKind::DfgMultiscatter,
            EngineArg::KullaConty => EngineKind::KullaConty,
            EngineArg::Eon => EngineKind::Eon,
        }
    }
}

pub fn run(a: AlbedoArgs) -> Result<()> {
    if let Some(scene) = &a.scene {
        return run_scene(
            scene,
            a.output_dir.as_deref().unwrap_or(Path::new(".")),
            &a.backend,
            lobe::scene::Outputs::ALBEDOS,
        );
    }
    if let Some(m) = a.max_error {
        if !(m >= 0.0) {
            bail!("--max-error {m}: expected an absolute error >= 0");
        }
    }
    let method = Method::from(a.method);
    let seed = check_seed(a.seed, method)?;
    if let (Some(kind), Some(path)) = (a.engine, &a.lut) {
        return write_engine_lut(&a, kind.into(), method, path);
    }
    let params = a.model.params()?;
    // The same range as every direction on the command line (`lobe eval`'s).
    lobe::pairs::check_angles(0.0, a.phi_deg).map_err(|e| anyhow!("--phi-o-deg: {e}"))?;
    let mus = view_mus(&a)?;
    match a.samples {
        Some(0) if method == Method::Reference => bail!(
            "--samples 0: expected the reference's budget of integrand evaluations, at least 1"
        ),
        Some(n) if method != Method::Reference => super::check_samples("--samples", n)?,
        _ => {}
    }
    let settings = Settings {
        method,
        samples: a.samples.unwrap_or(method.default_samples()),
        seed,
        white_furnace: a.model.white_furnace,
    };
    let phi = a.phi_deg.to_radians();
    if let Some(path) = &a.lut {
        let spec = lut_spec(&a, params, settings, phi)?;
        let session = open_albedo_session(&a.backend, method)?;
        return write_lut(&a, &session, &spec, path);
    }
    let session = open_albedo_session(&a.backend, method)?;
    let backend = session.backend_name();
    let points: Vec<(f64, f64)> = mus.iter().map(|&m| (m, phi)).collect();
    // A spinner: the hemispherical albedo of an anisotropic model integrates thousands of view
    // directions (seconds to tens of seconds on lavapipe).
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.set_message(format!(
        "integrating {} with {} on {backend}",
        params.model().name(),
        method.name(),
    ));
    spinner.enable_steady_tick(std::time::Duration::from_millis(120));
    let report = session.albedo_report(&params, &settings, &points, phi);
    spinner.finish_and_clear();
    let report = report?;
    check_report_error(&a, &report)?;
    if a.format != TableFormat::Table {
        // The table says it in lines of its own, JSON in its `stopped_short` fields too.
        for note in report.short_notes() {
            eprintln!("lobe: {note}");
        }
    }
    let mut out = super::stdout();
    match a.format {
        TableFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&report.to_json(
                Query::one(&params).with_white_furnace(a.model.white_furnace),
                &backend
            ))?
        )?,
        TableFormat::Csv => report.write_csv(&mut out)?,
        TableFormat::Table => report.write_table(
            &mut out,
            Query::one(&params).with_white_furnace(a.model.white_furnace),
            &backend,
            a.phi_deg,
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

/// The look-up table the flags ask for: the model's own axis unless --lut-param names another
/// (then its full valid range, linear, unless given).
fn lut_spec(a: &AlbedoArgs, params: ParamSet, settings: Settings, phi: f64) -> Result<LutSpec> {
    let mut spec = LutSpec::new(params);
    spec.white_furnace = a.model.white_furnace;
    spec.method = settings.method;
    spec.samples = settings.samples;
    spec.seed = settings.seed;
    spec.phi = phi;
    if !a.lut_param.is_empty() {
        spec.keys = a.lut_param.clone();
        let model = spec.params.model();
        let (default_keys, ..) = lut::default_axis(model);
        if a.lut_param != default_keys {
            if let Some(s) = model.params().iter().find(|s| s.key == a.lut_param[0]) {
                spec.lo = s.min;
                spec.hi = s.max;
                spec.mapping = Mapping::Linear;
            }
        }
    }
    if let Some(r) = &a.lut_range {
        (spec.lo, spec.hi) = parse_pair("--lut-range", r, "LO,HI (two numbers)")?;
    }
    if let Some(r) = &a.lut_res {
        (spec.n_mu, spec.n_p) = parse_pair("--lut-res", r, "NMU,NP (two positive integers)")?;
    }
    if let Some(m) = a.lut_map {
        spec.mapping = m.into();
    }
    spec.max_error = a.max_error;
    with_flag(spec.validate(), |o| lut_flag(&spec, o))?;
    Ok(spec)
}

/// The flag, with its value, behind a refused part of a LUT request.
fn lut_flag(spec: &LutSpec, option: &str) -> Option<String> {
    let range = format!("--lut-range {},{}", spec.lo, spec.hi);
    Some(match option {
        "keys" if spec.keys.is_empty() => "--lut".to_string(),
        "keys" => format!("--lut-param {}", spec.keys.join(",")),
        "range" => range,
        "mapping" => format!("--lut-map {} with {range}", spec.mapping.name()),
        "res" => format!("--lut-res {},{}", spec.n_mu, spec.n_p),
        "phi" => "--phi-o-deg".to_string(),
        "max-error" => format!("--max-error {}", spec.max_error.unwrap_or(f64::NAN)),
        "path" => "--lut".to_string(),
        _ => return None,
    })
}

/// `lobe albedo --lut`: computes the table, writes its files and prints what it holds.
fn write_lut(a: &AlbedoArgs, session: &Session, spec: &LutSpec, path: &Path) -> Result<()> {
    let progress = indicatif::ProgressBar::new(spec.n_p as u64);
    let summary = with_flag(
        session
            .write_albedo_lut(spec, path, &mut |done, _| progress.set_position(done))
            .map_err(session_error),
        |o| lut_flag(spec, o),
    )?;
    progress.finish_and_clear();
    warn_large(
        summary.max_error,
        &where_largest(summary.largest_error(), spec),
    );
    let mut out = super::stdout();
    match a.format {
        TableFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&summary.to_json(spec))?
        )?,
        _ => summary.write_text(spec, &mut out)?,
    }
    Ok(())
}

/// Says on stderr that an error estimate is large ([`lut::LARGE_ERROR`]), and where.
fn warn_large(largest: f64, at: &str) {
    let limit = lut::LARGE_ERROR;
    if !(largest <= limit) {
        eprintln!(
            "warning: the largest error estimate is {largest:.3e}, at {at}, above {limit:.3e} (the step of half floats below 1); use more --samples, another --method, or --max-error to refuse such results"
        );
    }
}

/// A table's entry with the largest estimate, in words.
fn where_largest(entry: Option<lut::ErrorEntry>, spec: &LutSpec) -> String {
    entry.map_or("no entry".to_string(), |e| e.describe(&spec.keys.join(",")))
}

/// `lobe albedo --lut PATH.exr --engine KIND`: an engine table with its C/C++ header.
fn write_engine_lut(a: &AlbedoArgs, kind: EngineKind, method: Method, path: &Path) -> Result<()> {
    let default_model = "cook_torrance";
    if a.model.model != default_model && a.model.model != kind.model_name() {
        bail!(
            "--model {} with --engine {}: the table is made from {} (drop --model; --set changes its parameters)",
            a.model.model,
            kind.name(),
            kind.model_name()
        );
    }
    let mut spec = EngineSpec::new(kind, &a.model.sets)?;
    spec.lut.method = method;
    spec.lut.samples = a.samples.unwrap_or(method.default_samples());
    spec.lut.seed = check_seed(a.seed, method)?;
    spec.lut.max_error = a.max_error;
    if let Some(r) = &a.lut_range {
        (spec.lut.lo, spec.lut.hi) = parse_pair("--lut-range", r, "LO,HI (two numbers)")?;
    }
    if let Some(r) = &a.lut_res {
        (spec.lut.n_mu, spec.lut.n_p) =
            parse_pair("--lut-res", r, "NMU,NP (two positive integers)")?;
    }
    if let Some(m) = a.lut_map {
        spec.lut.mapping = m.into();
    }
    with_flag(spec.lut.validate(), |o| lut_flag(&spec.lut, o))?;
    let session = open_albedo_session(&a.backend, method)?;
    let rows = (spec.lut.n_p * if kind.channels() == 2 { 2 } else { 1 }) as u64;
    let progress = indicatif::ProgressBar::new(rows);
    let table = with_flag(
        session
            .write_engine_lut(&spec, path, &mut |done, _| progress.set_position(done))
            .map_err(session_error),
        |o| lut_flag(&spec.lut, o),
    )?;
    progress.finish_and_clear();
    warn_large(
        table.max_error,
        &where_largest(table.largest_error(), &spec.lut),
    );
    let ranges: Vec<(f64, f64)> = (0..table.channels).map(|c| table.range(c)).collect();
    let mut out = std::io::stdout().lock();
    match a.format {
        TableFormat::Json => {
            let files: Vec<String> = table
                .files
                .iter()
                .map(|p| p.display().to_string())
                .collect();
            let v = serde_json::json!({
                "files": files,
                "engine": kind.name(),
                "model": kind.model_name(),
                "parameters": spec.lut.params.to_json(),
                "range": [spec.lut.lo, spec.lut.hi],
                "mapping": spec.lut.mapping.name(),
                "res": [spec.lut.n_mu, spec.lut.n_p],
                "method": method.name(),
                "samples": spec.lut.samples,
                "seed": method.sampler().map(|_| spec.lut.seed),
                "channel_ranges": ranges,
                "max_error_estimate": table.max_error,
                "seconds": table.seconds,
            });
            writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        }
        _ => {
            let text: Vec<String> = ranges
                .iter()
                .zip(["R", "G"])
                .map(|((lo, hi), c)| format!("{c} in [{lo:.6}, {hi:.6}]"))
                .collect();
            writeln!(
                out,
                "{} table ({}) over mu ({} cells) x {} in [{}, {}] ({} cells, {}): {}, largest error estimate {:.2e}; {} {} nodes per direction; {:.2} s",
                kind.name(),
                kind.model_name(),
                spec.lut.n_mu,
                spec.lut.keys.join(","),
                spec.lut.lo,
                spec.lut.hi,
                spec.lut.n_p,
                spec.lut.mapping.name(),
                text.join(", "),
                table.max_error,
                method.name(),
                spec.lut.samples,
                table.seconds
            )?;
            for f in &table.files {
                writeln!(out, "wrote {}", f.display())?;
            }
        }
    }
    Ok(())
}

/// The stream of a Monte Carlo method: --seed, else [`lobe::integrate::DEFAULT_SEED`]; refused
/// for a method that draws nothing, where it would change nothing.
fn check_seed(seed: Option<u32>, method: Method) -> Result<u32> {
    match seed {
        Some(s) if method.sampler().is_none() => bail!(
            "--seed {s} with --method {}: that method draws nothing; --seed applies to the Monte Carlo methods (uniform, cosine, sampled)",
            method.name()
        ),
        Some(s) => Ok(s),
        None => Ok(lobe::integrate::DEFAULT_SEED),
    }
}

/// The view directions' mu = cos(theta_o): from --theta-o-deg, else --mu.
fn view_mus(a: &AlbedoArgs) -> Result<Vec<f64>> {
    Ok(if !a.theta_deg.is_empty() {
        a.theta_deg
            .iter()
            .map(|&t| {
                if (0.0..90.0).contains(&t) {
                    Ok(lobe::grid::sin_cos_deg(t).1)
                } else {
                    bail!("--theta-o-deg {t}: expected theta_o in [0, 90) degrees")
                }
            })
            .collect::<Result<_>>()?
    } else {
        for &m in &a.mu {
            if !(m > 0.0 && m <= 1.0) {
                bail!("--mu {m}: expected mu = cos(theta_o) in (0, 1]");
            }
        }
        a.mu.clone()
    })
}

/// The largest error estimate against --max-error, with a warning when it is large.
fn check_report_error(a: &AlbedoArgs, report: &AlbedoReport) -> Result<()> {
    let largest = report
        .points
        .iter()
        .map(|p| p.error.max_element())
        .chain([
            report.hemispherical.error.max_element(),
            report.hemispherical.e_avg_error.max_element(),
        ])
        .fold(0.0, f64::max);
    with_flag(lut::check_max_error(largest, a.max_error), |_| {
        a.max_error.map(|m| format!("--max-error {m}"))
    })?;
    let at = report
        .points
        .iter()
        .find(|p| p.error.max_element() == largest)
        .map_or("the hemispherical albedo".to_string(), |p| {
            format!("mu = {}", p.mu)
        });
    warn_large(largest, &at);
    Ok(())
}
