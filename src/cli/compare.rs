//! `lobe compare A B`: two models on the same bins, the distances between them and, with -o,
//! pictures of both and of their difference.

use super::table::GridArg;
use super::{
    bar, open_session, resolve_all, session_error, with_flag, BackendArg, BackendArgs, MethodArg,
};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use lobe::compare::{self, Bins, Comparison, Options, Side, CHANNELS};
use lobe::grid::Grid;
use lobe::integrate::{Method, Settings};
use lobe::plot::difference;
use lobe::plot::{Format, Subject};
use lobe::ParamSet;
use std::io::Write;
use std::path::PathBuf;

/// What the report is printed as.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ReportFormat {
    /// Lines for people.
    Table,
    /// One JSON object.
    Json,
}

/// The picture format of -o.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum PlotFormat {
    Png,
    Svg,
    /// One vector page, the text in the embedded DejaVu Sans.
    Pdf,
}

#[derive(Args)]
#[command(
    after_help = "Examples:\n  lobe compare lambert 'lambert{albedo=0.88}'\n  lobe compare phong blinn_phong --set-a shininess=200 --set-b smoothness=0.4 -o cmp\n  lobe compare data/brdf/coated_plastic.brdf microfacet --grid isotropic --res 30,30,60\n  lobe compare gold.binary 'cook_torrance{roughness=0.3}' --format json\n\n\
A is the reference: relative L2 is |B - A| / |A|, the albedo difference is E_A - E_B.\n\
Relative differences are |B - A| / max(|A|, |B|, 1e-4) per bin and channel (the floor keeps\n\
near-black bins from reporting huge ratios); bins are weighted by their solid angle."
)]
pub struct CompareArgs {
    /// Model A (the reference): a built-in model, NAME{KEY=VALUE,...}, a .brdf file or a MERL
    /// .binary file.
    a: String,
    /// Model B, in the same forms.
    b: String,
    /// Set a parameter of A, KEY=VALUE (rgb as r,g,b or one number); repeatable, applied last.
    #[arg(long = "set-a", value_name = "KEY=VALUE")]
    set_a: Vec<String>,
    /// Set a parameter of B, KEY=VALUE; repeatable, applied last.
    #[arg(long = "set-b", value_name = "KEY=VALUE")]
    set_b: Vec<String>,
    /// Set a parameter of whichever of A and B has KEY, or MODEL.KEY=VALUE for the side that is
    /// that model (phong.shininess=50); repeatable, applied before a model's own {KEY=VALUE}.
    #[arg(long = "set", value_name = "[MODEL.]KEY=VALUE")]
    sets: Vec<String>,
    /// Replace every Fresnel factor of a specular lobe by 1 on both sides.
    #[arg(long)]
    white_furnace: bool,
    /// The bins both models are evaluated at (default: MERL's own half/difference bins when a
    /// side is a MERL file, else isotropic, or full when a side is anisotropic).
    #[arg(long, value_enum)]
    grid: Option<GridArg>,
    /// Resolution of --grid, as `lobe table --res` (default full 16,32,16,32, isotropic
    /// 45,45,90, halfdiff 90,90,180).
    #[arg(long, requires = "grid")]
    res: Option<String>,
    /// View directions mu = cos(theta_o) of the directional albedo difference, each in (0, 1].
    #[arg(long, value_delimiter = ',', default_value = super::default_mus())]
    mu: Vec<f64>,
    /// Albedo integrator (see `lobe albedo --help`).
    #[arg(long, value_enum, default_value_t = MethodArg::Peak)]
    method: MethodArg,
    /// Albedo quadrature nodes per view direction (default: the method's).
    #[arg(long)]
    samples: Option<usize>,
    /// Leave out the albedo differences (the table part alone).
    #[arg(long)]
    no_albedo: bool,
    /// Report format on standard output.
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    format: ReportFormat,
    /// Write PREFIX_polar.png (A and B in the plane of incidence) and PREFIX_difference.png
    /// ((B - A)/max(|A|, |B|, 1e-4) over the hemisphere), each with the parameters of A and B
    /// in a .json and the plotted numbers in a .csv beside it; all six or none.
    #[arg(short = 'o', long = "output", value_name = "PREFIX")]
    output: Option<PathBuf>,
    /// Picture format of -o.
    #[arg(long, value_enum, default_value_t = PlotFormat::Png, requires = "output")]
    plot_format: PlotFormat,
    /// Incidence angles theta_i in degrees of the pictures, comma-separated, each in [0, 90).
    #[arg(
        long = "theta-i-deg",
        value_delimiter = ',',
        default_value = "0,30,60",
        requires = "output"
    )]
    theta_i_deg: Vec<f64>,
    #[command(flatten)]
    backend: BackendArgs,
}

/// The default resolution of each grid for a comparison: about 2e5 bins for the product grids
/// (seconds on lavapipe), MERL's size for halfdiff.
fn default_res(grid: GridArg) -> &'static str {
    match grid {
        GridArg::Full => "16,32,16,32",
        GridArg::Isotropic => "45,45,90",
        GridArg::Halfdiff => "90,90,180",
    }
}

/// The flag behind a refused compare option.
fn compare_flag(option: &str) -> Option<String> {
    Some(
        match option {
            "grid" => "--grid",
            "cells" => "--res",
            "mu" => "--mu",
            "theta_i_deg" => "--theta-i-deg",
            "samples" => "--samples",
            _ => return None,
        }
        .to_string(),
    )
}

/// `--set-a`/`--set-b` on one side's parameters; a refusal names the flag and the side.
fn apply_side(
    params: &mut ParamSet,
    flag: &str,
    side: &str,
    spec: &str,
    sets: &[String],
) -> Result<()> {
    for set in sets {
        params
            .set_text(set)
            .with_context(|| format!("{flag} {set} (model {side} = {spec})"))?;
    }
    Ok(())
}

pub fn run(a: CompareArgs) -> Result<()> {
    check_directions(&a)?;
    let specs = [a.a.clone(), a.b.clone()];
    let mut resolved = resolve_all(&specs, None, &a.sets)?;
    let (label_b, mut pb) = resolved.remove(1);
    let (label_a, mut pa) = resolved.remove(0);
    apply_side(&mut pa, "--set-a", "A", &label_a, &a.set_a)?;
    apply_side(&mut pb, "--set-b", "B", &label_b, &a.set_b)?;
    check_cpu_twins(&a, [(label_a.as_str(), &pa), (label_b.as_str(), &pb)])?;
    let bins = bins(&a, [(label_a.as_str(), &pa), (label_b.as_str(), &pb)])?;
    let format = match a.plot_format {
        PlotFormat::Png => Format::Png,
        PlotFormat::Svg => Format::Svg,
        PlotFormat::Pdf => Format::Pdf,
    };
    if let Some(prefix) = &a.output {
        check_plot_paths(prefix, format)?;
    }
    let mut side_a = Side::new(pa.clone());
    let mut side_b = Side::new(pb.clone());
    for (side, spec) in [(&mut side_a, &label_a), (&mut side_b, &label_b)] {
        if is_merl_spec(spec) {
            let (name, _) = super::split_spec(spec)?;
            side.missing = compare::missing_bins(std::path::Path::new(name))?;
        }
    }
    let method = Method::from(a.method);
    let opts = options(&a, bins, method);
    let session = open_session(&a.backend)?;
    let progress = bar(bins.cells(), "{msg} [{bar:40}] {percent}% eta {eta}");
    progress.set_message(format!("comparing on {}", bins.describe()));
    let started = std::time::Instant::now();
    let report = with_flag(
        session
            .compare(&side_a, &side_b, &opts, &mut |done, all| {
                progress.set_position(done);
                if done == all && !a.no_albedo {
                    progress.set_message("albedo of A and B");
                }
            })
            .map_err(session_error),
        compare_flag,
    );
    progress.finish_and_clear();
    let report = report?;
    let seconds = started.elapsed().as_secs_f64();
    let mut out = super::stdout();
    match a.format {
        ReportFormat::Json => {
            let mut v = report.to_json();
            v["a"] = side_json(&label_a, &pa);
            v["b"] = side_json(&label_b, &pb);
            v["backend"] = session.backend_name().into();
            v["albedo_method"] = (!a.no_albedo).then(|| method.name()).into();
            v["seconds"] = seconds.into();
            writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        }
        ReportFormat::Table => print_table(
            &mut out,
            &report,
            &label_a,
            &pa,
            &label_b,
            &pb,
            method,
            a.no_albedo,
        )?,
    }
    out.flush()?;
    if let Some(prefix) = &a.output {
        write_plots(
            &a,
            &session,
            [(label_a.as_str(), &pa), (label_b.as_str(), &pb)],
            prefix,
            format,
        )?;
    }
    eprintln!(
        "lobe: compared on {} in {seconds:.2} s",
        session.backend_name()
    );
    Ok(())
}

fn side_json(spec: &str, p: &ParamSet) -> serde_json::Value {
    serde_json::json!({
        "spec": spec,
        "model": p.model().name(),
        "params": p.to_text(),
    })
}

fn rgb(v: [f64; 3]) -> String {
    format!("{:>10.6} {:>10.6} {:>10.6}", v[0], v[1], v[2])
}

#[allow(clippy::too_many_arguments)]
fn print_table(
    out: &mut impl Write,
    r: &Comparison,
    label_a: &str,
    pa: &ParamSet,
    label_b: &str,
    pb: &ParamSet,
    method: Method,
    no_albedo: bool,
) -> Result<()> {
    writeln!(
        out,
        "A = {label_a} ({}: {})",
        pa.model().name(),
        pa.to_text()
    )?;
    writeln!(
        out,
        "B = {label_b} ({}: {})",
        pb.model().name(),
        pb.to_text()
    )?;
    writeln!(
        out,
        "bins: {}: {} compared, {} at or below the horizon, {} with missing data (left out)",
        r.bins, r.used, r.below_horizon, r.missing
    )?;
    writeln!(
        out,
        "relative difference |B - A| / max(|A|, |B|, {}): RMS {:.4e}, max {:.4e}",
        lobe::loss::RELATIVE_FLOOR,
        r.relative_rms,
        r.relative_max
    )?;
    if let Some(l) = r.largest {
        writeln!(
            out,
            "  largest at theta_i = {:.2} deg, theta_o = {:.2} deg, phi_o - phi_i = {:.2} deg, channel {}: A = {:.6e}, B = {:.6e} 1/sr",
            l.theta_i_deg, l.theta_o_deg, l.phi_deg, CHANNELS[l.channel], l.a, l.b
        )?;
    }
    let ch = |e: &lobe::loss::ChannelErrors| {
        format!(
            "{:.4e} (r {:.4e}, g {:.4e}, b {:.4e})",
            e.total, e.channel[0], e.channel[1], e.channel[2]
        )
    };
    writeln!(out, "cosine-weighted log error: {}", ch(&r.log_error))?;
    writeln!(out, "relative L2 |B - A| / |A|: {}", ch(&r.relative_l2))?;
    if no_albedo {
        return Ok(());
    }
    writeln!(out, "albedo ({}):", method.name())?;
    writeln!(
        out,
        "  {:<14} {:>32}   {:>32}   {:>32}",
        "", "E_A (r g b)", "E_B (r g b)", "E_A - E_B (r g b)"
    )?;
    for p in &r.directional {
        writeln!(
            out,
            "  mu = {:<9} {}   {}   {}",
            p.mu,
            rgb(p.a),
            rgb(p.b),
            rgb(p.difference)
        )?;
    }
    if let Some(h) = &r.hemispherical {
        writeln!(
            out,
            "  {:<14} {}   {}   {}",
            "hemispherical",
            rgb(h.a),
            rgb(h.b),
            rgb(h.difference)
        )?;
    }
    Ok(())
}

/// --samples, --mu and --theta-i-deg in their ranges.
fn check_directions(a: &CompareArgs) -> Result<()> {
    if let Some(n) = a.samples {
        super::check_samples("--samples", n)?;
    }
    for &mu in &a.mu {
        if !(mu > 0.0 && mu <= 1.0) {
            bail!("--mu {mu}: expected mu = cos(theta_o) in (0, 1]");
        }
    }
    for &t in &a.theta_i_deg {
        if !(0.0..90.0).contains(&t) {
            bail!("--theta-i-deg {t}: expected theta_i in [0, 90) degrees");
        }
    }
    Ok(())
}

/// With --backend cpu, both sides need an f64 twin.
fn check_cpu_twins(a: &CompareArgs, sides: [(&str, &ParamSet); 2]) -> Result<()> {
    if a.backend.backend == BackendArg::Cpu {
        for (side, (spec, p)) in ["A", "B"].into_iter().zip(sides) {
            if !p.model().has_reference() {
                bail!(
                    "--backend cpu: model {side} = {spec} has no f64 CPU twin (a .brdf shader runs \
                     on the GPU only); leave out --backend cpu"
                );
            }
        }
    }
    Ok(())
}

/// Whether a side's spec names a MERL file.
fn is_merl_spec(spec: &str) -> bool {
    super::split_spec(spec).is_ok_and(|(name, _)| lobe::merl::model::is_merl_path(name))
}

/// The bins both sides are compared on: --grid and --res, MERL's bins when a side is a MERL
/// file, else the grid both sides' isotropy allows.
fn bins(a: &CompareArgs, [(label_a, pa), (label_b, pb)]: [(&str, &ParamSet); 2]) -> Result<Bins> {
    Ok(match a.grid {
        None if is_merl_spec(label_a) || is_merl_spec(label_b) => Bins::Merl,
        None => {
            let kind = if pa.is_isotropic() && pb.is_isotropic() {
                GridArg::Isotropic
            } else {
                GridArg::Full
            };
            Bins::Grid(Grid::parse(kind.name(), default_res(kind)).map_err(anyhow::Error::msg)?)
        }
        Some(kind) => {
            let res = a.res.as_deref().unwrap_or(default_res(kind));
            let grid = Grid::parse(kind.name(), res).map_err(|e| anyhow::anyhow!("--res: {e}"))?;
            super::check_held_cells("--res", &grid)?;
            Bins::Grid(grid)
        }
    })
}

/// The folder of -o exists and neither picture belongs to a set.
fn check_plot_paths(prefix: &std::path::Path, format: Format) -> Result<()> {
    let (polar, difference) = difference::plot_paths(prefix, format);
    let folder = lobe::output::folder_of(&polar);
    if !folder.as_os_str().is_empty() && !folder.is_dir() {
        bail!(
            "-o {}: the folder {} does not exist",
            prefix.display(),
            folder.display()
        );
    }
    for p in [&polar, &difference] {
        lobe::output::check_destination(p).context("-o")?;
    }
    Ok(())
}

/// The polar overlay of both sides and the picture of their difference.
fn write_plots(
    a: &CompareArgs,
    session: &lobe::Session,
    [(label_a, pa), (label_b, pb)]: [(&str, &ParamSet); 2],
    prefix: &std::path::Path,
    format: Format,
) -> Result<()> {
    let plot_opts = difference::PlotOptions {
        theta_i_deg: a.theta_i_deg.clone(),
        common: lobe::plot::PlotSettings {
            white_furnace: a.white_furnace,
            ..difference::PlotOptions::default().common
        },
        ..difference::PlotOptions::default()
    };
    let sa = Subject {
        label: format!("A: {label_a}"),
        params: pa.clone(),
    };
    let sb = Subject {
        label: format!("B: {label_b}"),
        params: pb.clone(),
    };
    let plots = with_flag(
        session
            .plot_difference(&sa, &sb, &plot_opts, prefix, format)
            .map_err(session_error),
        compare_flag,
    )?;
    eprintln!(
        "lobe: wrote {} and {}",
        plots.polar_path.display(),
        plots.difference_path.display()
    );
    Ok(())
}

/// What is compared: the bins, and unless --no-albedo the albedo at --mu and its settings.
fn options(a: &CompareArgs, bins: Bins, method: Method) -> Options {
    Options {
        bins,
        white_furnace: a.white_furnace,
        mus: if a.no_albedo {
            Vec::new()
        } else {
            a.mu.clone()
        },
        albedo: (!a.no_albedo).then(|| Settings {
            method,
            samples: a.samples.unwrap_or(method.default_samples()),
            seed: lobe::integrate::DEFAULT_SEED,
            white_furnace: a.white_furnace,
        }),
    }
}
