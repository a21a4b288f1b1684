//! `lobe plot`: pictures of one or more models (polar, hemisphere, slice, 3d, albedo curves).

use super::{
    open_albedo_session, open_session, parse_size, resolve_all, session_error, split_specs,
    with_flag, BackendArgs, MethodArg,
};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use lobe::plot::{self, hemisphere::Projection, Channel, PlotSettings, Request, Subject};
use std::path::PathBuf;

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

/// The plotted channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ChannelArg {
    /// Y = 0.2126 R + 0.7152 G + 0.0722 B.
    Luminance,
    R,
    G,
    B,
    /// max(R, G, B): the channel that gains energy first.
    Max,
}

impl From<ChannelArg> for Channel {
    fn from(c: ChannelArg) -> Channel {
        match c {
            ChannelArg::Luminance => Channel::Luminance,
            ChannelArg::R => Channel::R,
            ChannelArg::G => Channel::G,
            ChannelArg::B => Channel::B,
            ChannelArg::Max => Channel::Max,
        }
    }
}

/// How the hemisphere map flattens the hemisphere onto a disc.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ProjectionArg {
    /// Lambert azimuthal equal-area: equal solid angles take equal areas.
    EqualArea,
    /// Nusselt's sin(theta): area is projected solid angle.
    Nusselt,
}

impl From<ProjectionArg> for Projection {
    fn from(p: ProjectionArg) -> Projection {
        match p {
            ProjectionArg::EqualArea => Projection::EqualArea,
            ProjectionArg::Nusselt => Projection::Nusselt,
        }
    }
}

/// The picture format, when --format names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum FormatArg {
    Png,
    Svg,
    /// One vector page, the text in the embedded DejaVu Sans (subset into the file).
    Pdf,
}

/// Sizes of text and lines against the page.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum StyleArg {
    /// For the screen: the canvas as --size gives it, 12-17 px text.
    Screen,
    /// A single-column figure: 3.5 in wide, PNG at 300 dpi (1050 px across; --size gives
    /// the written pixels), 8-9.5 pt text (7.5-11 pt in 3d and slice plots), lines of 0.4-0.9 pt, no title block (the title and
    /// parameters stay in the .json beside it); PDF and SVG pages of the printed size.
    Paper,
}

impl From<StyleArg> for plot::Style {
    fn from(s: StyleArg) -> plot::Style {
        match s {
            StyleArg::Screen => plot::Style::Screen,
            StyleArg::Paper => plot::Style::Paper,
        }
    }
}

#[derive(Args)]
pub struct PlotArgs {
    /// What to draw.
    #[arg(long, value_enum, default_value_t = PlotKind::Polar)]
    kind: PlotKind,
    /// Output file; .png, .svg or .pdf chooses the format.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH.png|PATH.svg|PATH.pdf"
    )]
    output: PathBuf,
    /// The picture format; -o gets its extension when it has none, and must have this one when
    /// it has one (default: by the extension of -o).
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
    /// Sizes of text and lines: screen, or paper (a single-column figure).
    #[arg(long, value_enum, default_value_t = StyleArg::Screen)]
    style: StyleArg,
    /// BRDF model (see `lobe models`); repeatable or comma-separated to overlay several
    /// (default cook_torrance). Every model is drawn with every --material. A model may carry
    /// its own parameters: --model 'phong{shininess=50},phong{shininess=500}'.
    #[arg(long = "model")]
    models: Vec<String>,
    /// Material preset (tin, gold, glazed_ceramic, granite); repeatable or comma-separated.
    #[arg(long = "material", value_delimiter = ',')]
    materials: Vec<String>,
    /// Set a parameter, KEY=VALUE: for every model drawn that has KEY (an error only if none
    /// has it); MODEL.KEY=VALUE for one model (phong.shininess=50). Repeatable; applied after
    /// --material, before a model's own {KEY=VALUE}.
    #[arg(long = "set", value_name = "[MODEL.]KEY=VALUE")]
    sets: Vec<String>,
    /// Replace every Fresnel factor of a specular lobe by 1 (shows the lobe's own energy).
    #[arg(long)]
    white_furnace: bool,
    #[command(flatten)]
    backend: BackendArgs,
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
    /// Logarithmic radius (polar, 3d) or colour (hemisphere; the default there). A polar plot
    /// chooses a log radius by itself when its curves' peaks span more than two decades.
    /// The slice is always logarithmic.
    #[arg(long, conflicts_with_all = ["linear", "normalise"])]
    log: bool,
    /// Linear radius (polar) or colour scale (hemisphere).
    #[arg(long, conflicts_with = "normalise")]
    linear: bool,
    /// Polar: divide each curve by its own peak (named in the legend), to compare shapes.
    #[arg(long)]
    normalise: bool,
    /// Decades a logarithmic scale spans below its maximum.
    #[arg(long, default_value_t = 4.0)]
    decades: f64,
    /// Plotted channel.
    #[arg(long, value_enum, default_value_t = ChannelArg::Luminance)]
    channel: ChannelArg,
    /// Hemisphere: map f over wi for the fixed wo instead.
    #[arg(long)]
    reverse: bool,
    /// Hemisphere projection.
    #[arg(long, value_enum, default_value_t = ProjectionArg::EqualArea)]
    projection: ProjectionArg,
    /// Resolution: hemisphere cells across (128), slice cells per axis (90), 3d rings (60),
    /// albedo view directions (48), polar view angles per curve (1440).
    #[arg(long)]
    res: Option<usize>,
    /// Slice: phi_d in degrees.
    #[arg(long = "phi-d-deg", default_value_t = 90.0, allow_hyphen_values = true)]
    phi_d_deg: f64,
    /// Albedo: integration method (see `lobe albedo --help`).
    #[arg(long, value_enum, default_value_t = MethodArg::Peak)]
    method: MethodArg,
    /// Albedo: quadrature nodes per view direction (default: the method's).
    #[arg(long)]
    samples: Option<usize>,
    /// Image size WIDTHxHEIGHT in pixels (default 1200x800; polar 1200x680, as a half disc is
    /// twice as wide as tall; hemisphere: height to fit its panels). With --style paper the
    /// written pixels at 300 dpi (default 1050 wide, the same shapes).
    #[arg(long)]
    size: Option<String>,
}

/// The most curves one picture overlays: beyond 24 the legend outgrows the image and the
/// palette repeats, so the curves cannot be told apart.
const MAX_CURVES: usize = 24;

/// The flag behind a refused plot option.
fn plot_flag(option: &str) -> Option<String> {
    let flag = match option {
        "theta_i_deg" | "theta_deg" => "--theta-i-deg",
        "phi_i_deg" | "phi_deg" => "--phi-i-deg",
        "phi_d_deg" => "--phi-d-deg",
        "res" | "n_mu" | "n_theta" | "samples" => "--res",
        "decades" => "--decades",
        "size" => "--size",
        _ => return None,
    };
    Some(flag.to_string())
}

/// The output path with the extension --format names: added when `path` has none, refused when
/// it has another.
fn output_path(path: &std::path::Path, format: Option<FormatArg>) -> Result<PathBuf> {
    let Some(format) = format else {
        return Ok(path.to_path_buf());
    };
    let ext = match format {
        FormatArg::Png => "png",
        FormatArg::Svg => "svg",
        FormatArg::Pdf => "pdf",
    };
    match path.extension().and_then(|e| e.to_str()) {
        None => Ok(path.with_extension(ext)),
        Some(e) if e.eq_ignore_ascii_case(ext) => Ok(path.to_path_buf()),
        Some(e) => bail!(
            "-o {}: the extension .{e} is not --format {ext}'s .{ext}; give -o without an \
             extension or with .{ext}",
            path.display()
        ),
    }
}

pub fn run(mut a: PlotArgs) -> Result<()> {
    a.output = output_path(&a.output, a.format)?;
    // The same range as every direction on the command line (`lobe eval`'s).
    lobe::pairs::check_angles(0.0, a.phi_i_deg).map_err(|e| anyhow::anyhow!("--phi-i-deg: {e}"))?;
    let models = if a.models.is_empty() {
        vec!["cook_torrance".to_string()]
    } else {
        split_specs(&a.models)
    };
    let materials: Vec<Option<&str>> = if a.materials.is_empty() {
        vec![None]
    } else {
        a.materials.iter().map(|m| Some(m.as_str())).collect()
    };
    let subjects = subjects(&a, &models, &materials)?;
    if let Some(n) = a.samples {
        super::check_samples("--samples", n)?;
    }
    check_curves(&a, subjects.len(), (models.len(), materials.len()))?;
    let style: plot::Style = a.style.into();
    let size = canvas_size(&a, style, models.len() * materials.len())?;
    let common = PlotSettings {
        white_furnace: a.white_furnace,
        cos: a.cos,
        log: a.log || (a.kind == PlotKind::Hemisphere && !a.linear),
        decades: a.decades,
        channel: a.channel.into(),
        size,
        style,
    };
    let request = request(&a);
    // The picture and the two files beside it, checked before any work: none may belong to a set.
    for dest in [
        a.output.clone(),
        plot::params_json_path(&a.output),
        plot::csv::data_csv_path(&a.output),
    ] {
        lobe::output::check_destination(&dest).context("-o")?;
    }
    let session = match a.kind {
        PlotKind::Albedo => open_albedo_session(&a.backend, a.method.into())?,
        _ => open_session(&a.backend)?,
    };
    let start = std::time::Instant::now();
    let plotted = with_flag(
        session
            .plot(&subjects, &common, &request, &a.output)
            .map_err(session_error),
        plot_flag,
    )?;
    plot::write_params_json(&a.output, &subjects, &plotted)?;
    plot::csv::write_data_csv(&a.output, &subjects, &plotted)?;
    let bytes = std::fs::metadata(&a.output).map(|m| m.len()).unwrap_or(0);
    println!(
        "lobe plot: wrote {} ({} bytes, parameters in {}, {} evaluations, {:.2} s): {}",
        a.output.display(),
        bytes,
        plot::params_json_path(&a.output).display(),
        plotted.evaluations(),
        start.elapsed().as_secs_f64(),
        plotted.title()
    );
    Ok(())
}

/// One subject per model and material; a label gains its material where the spec has `{`.
fn subjects(a: &PlotArgs, models: &[String], materials: &[Option<&str>]) -> Result<Vec<Subject>> {
    let mut subjects = Vec::new();
    for material in materials {
        for (label, params) in resolve_all(models, *material, &a.sets)? {
            let mut subject = Subject::new(params, *material);
            if label.contains('{') {
                subject.label = match material {
                    Some(m) => format!("{m} {label}"),
                    None => label,
                };
            }
            subjects.push(subject);
        }
    }
    Ok(subjects)
}

/// Refuses more curves than one picture overlays.
fn check_curves(a: &PlotArgs, subjects: usize, (models, materials): (usize, usize)) -> Result<()> {
    let n_angles = if a.theta_i_deg.is_empty() {
        4
    } else {
        a.theta_i_deg.len()
    };
    let curves = match a.kind {
        PlotKind::Polar => subjects * n_angles,
        PlotKind::Albedo => subjects,
        _ => 0,
    };
    if curves > MAX_CURVES {
        bail!(
            "{curves} curves in one picture ({} models x {} materials{}); a plot overlays at most \
             {MAX_CURVES}: ask for fewer --model, --material or --theta-i-deg values",
            models,
            materials,
            if a.kind == PlotKind::Polar {
                format!(" x {n_angles} angles")
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

/// The canvas: --size, or the kind's default, in canvas pixels (paper: written pixels, whose
/// canvas is smaller by the style's zoom). `pairs` is the models times the materials: a
/// hemisphere map gives each its own rows of panels.
fn canvas_size(a: &PlotArgs, style: plot::Style, pairs: usize) -> Result<(u32, u32)> {
    let width = match style {
        plot::Style::Screen => 1200,
        plot::Style::Paper => plot::PAPER_CANVAS_WIDTH,
    };
    Ok(match &a.size {
        Some(text) => style.canvas_for(parse_size("--size", text, "1200x800")?),
        None if a.kind == PlotKind::Hemisphere => {
            let cols = if a.theta_i_deg.is_empty() {
                4
            } else {
                a.theta_i_deg.len()
            };
            let maps = width.saturating_sub(plot::hemisphere::COLOUR_BAR_WIDTH);
            let per_row = plot::hemisphere::panel_columns(maps, cols);
            let rows = pairs * cols.div_ceil(per_row);
            let side = (maps / per_row as u32).clamp(20, 520);
            // 150 px for the title on a screen; a paper figure has none. 30 px per panel caption.
            let head = match style {
                plot::Style::Screen => 150,
                plot::Style::Paper => 20,
            };
            (width, (head + rows as u32 * (side + 30)).clamp(150, 8000))
        }
        None if a.kind == PlotKind::Polar => (width, width * 680 / 1200),
        None => (width, width * 2 / 3),
    })
}

/// The kind of plot with its own options, from the flags.
fn request(a: &PlotArgs) -> Request {
    let angles = |default: &[f64]| {
        if a.theta_i_deg.is_empty() {
            default.to_vec()
        } else {
            a.theta_i_deg.clone()
        }
    };
    match a.kind {
        PlotKind::Polar => Request::Polar(plot::polar::PolarOptions {
            theta_i_deg: angles(&[0.0, 30.0, 60.0, 80.0]),
            samples: a.res.unwrap_or(plot::polar::DEFAULT_SAMPLES),
            radius: if a.normalise {
                plot::polar::Radius::Normalised
            } else if a.linear {
                plot::polar::Radius::Linear
            } else {
                plot::polar::Radius::Auto
            },
        }),
        PlotKind::Hemisphere => Request::Hemisphere(plot::hemisphere::HemisphereOptions {
            theta_deg: angles(&[0.0, 30.0, 60.0, 80.0]),
            phi_deg: a.phi_i_deg,
            reverse: a.reverse,
            projection: a.projection.into(),
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
        PlotKind::Albedo => Request::Albedo(plot::albedo_curve::AlbedoOptions {
            n_mu: a.res.unwrap_or(48),
            method: a.method.into(),
            samples: a.samples,
            phi_deg: a.phi_i_deg,
        }),
    }
}
