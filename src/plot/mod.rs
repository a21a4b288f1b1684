//! `lobe plot`: pictures of a BRDF, written as PNG or SVG by the output's extension.
//!
//! Each kind is one library function that evaluates every point it draws through an
//! [`Evaluator`](crate::eval::Evaluator) (one `eval_pairs` call per model), draws the picture,
//! and returns the plotted data so that tests and other programs can check what the picture
//! shows:
//!
//! - [`polar`]: f (or f·cosθi) in the plane of incidence for several θi, delta lobes marked;
//! - [`hemisphere`]: a heat map of f over the hemisphere of ωo for one ωi (or the reverse), in an
//!   equal-area or Nusselt projection;
//! - [`slice`](mod@slice): the θh × θd image of Rusinkiewicz's half/difference coordinates at one φd;
//! - [`surface3d`]: the lobe r(ωo) = f·ωo as a 3D wireframe for one ωi;
//! - [`albedo`]: directional albedo E(μ) curves with E = 1 drawn;
//! - [`difference`]: two models overlaid in the plane of incidence and their relative difference
//!   over the hemisphere (`lobe compare`, `lobe fit`);
//! - [`pareto`]: `lobe tradeoff`'s error-vs-cost panels with their Pareto fronts.
//!
//! Text is drawn with DejaVu Sans, embedded in the binary and registered with plotters' ab_glyph
//! backend at the first plot: no system fonts are read.
//!
//! The plotted scalar is one channel of the RGB value ([`Channel`]); luminance by default.

pub mod albedo;
pub mod difference;
pub mod hemisphere;
pub mod pareto;
pub mod polar;
pub mod slice;
pub mod surface3d;

use crate::input::BadInput;
use crate::model::ParamSet;
use anyhow::{anyhow, bail, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

/// The font family name every text style uses.
pub const FONT: &str = "sans-serif";

/// Registers the embedded DejaVu Sans once; plotters' ab_glyph backend knows no other fonts.
pub fn register_fonts() -> Result<()> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
            .and_then(|_| {
                plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold())
            })
            .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
    })
    .clone()
    .map_err(|e| anyhow!(e))
}

/// The picture kinds of `lobe plot --kind`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// f in the plane of incidence, one curve per model and θi ([`polar`]).
    Polar,
    /// A heat map of f over the hemisphere of ωo for one ωi ([`hemisphere`]).
    Hemisphere,
    /// The θh × θd image at one φd ([`slice`](mod@slice)).
    Slice,
    /// The lobe as a 3D wireframe for one ωi ([`surface3d`]); named `3d`.
    Surface3d,
    /// Directional albedo curves E(μ) ([`albedo`]).
    Albedo,
}

impl Kind {
    /// Every kind, in the order the error for an unknown name lists them.
    pub const ALL: [Kind; 5] = [
        Kind::Polar,
        Kind::Hemisphere,
        Kind::Slice,
        Kind::Surface3d,
        Kind::Albedo,
    ];

    /// The kind's name on the command line: `polar`, `hemisphere`, `slice`, `3d` or `albedo`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Polar => "polar",
            Kind::Hemisphere => "hemisphere",
            Kind::Slice => "slice",
            Kind::Surface3d => "3d",
            Kind::Albedo => "albedo",
        }
    }

    /// The kind called `name`; an unknown name is an error that lists the kinds.
    pub fn from_name(name: &str) -> Result<Kind> {
        Kind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .ok_or_else(|| {
                anyhow!(
                    "unknown plot kind '{name}'; the kinds are: {}",
                    Kind::ALL.map(Kind::name).join(", ")
                )
            })
    }
}

/// The output file format, chosen by the extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A raster image, `size` in pixels.
    Png,
    /// A vector image, `size` in user units.
    Svg,
}

impl Format {
    /// The format of `path` by its extension (`.png` or `.svg`, in any case); any other extension
    /// is an error.
    pub fn of(path: &Path) -> Result<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => bail!(
                "{}: the plot's format follows the output's extension, which must be .png or .svg",
                path.display()
            ),
        }
    }
}

/// Which scalar of the RGB value a plot shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// Y = 0.2126 R + 0.7152 G + 0.0722 B (linear Rec. 709 primaries, as the RGB values are).
    Luminance,
    /// The red channel.
    R,
    /// The green channel.
    G,
    /// The blue channel.
    B,
    /// max(R, G, B): the channel that gains energy first.
    Max,
}

impl Channel {
    /// The channel's name on the command line: `luminance`, `r`, `g`, `b` or `max`.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Luminance => "luminance",
            Channel::R => "r",
            Channel::G => "g",
            Channel::B => "b",
            Channel::Max => "max",
        }
    }

    /// The channel called `name`; an unknown name is an error that lists the channels.
    pub fn from_name(name: &str) -> Result<Channel> {
        [
            Channel::Luminance,
            Channel::R,
            Channel::G,
            Channel::B,
            Channel::Max,
        ]
        .into_iter()
        .find(|c| c.name() == name)
        .ok_or_else(|| {
            anyhow!("unknown channel '{name}'; the channels are: luminance, r, g, b, max")
        })
    }

    /// This channel's scalar of the linear RGB value `c`.
    pub fn of(self, c: [f64; 3]) -> f64 {
        match self {
            Channel::Luminance => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2],
            Channel::R => c[0],
            Channel::G => c[1],
            Channel::B => c[2],
            Channel::Max => c[0].max(c[1]).max(c[2]),
        }
    }

    /// How the axis and colour-bar labels name the plotted value.
    pub fn label(self) -> &'static str {
        match self {
            Channel::Luminance => "luminance Y",
            Channel::R => "red channel",
            Channel::G => "green channel",
            Channel::B => "blue channel",
            Channel::Max => "max of R, G, B",
        }
    }
}

/// One model with its parameters, as a plot overlays or tiles it.
#[derive(Clone, Debug)]
pub struct Subject {
    /// `gold cook_torrance`, or the model's name without a material.
    pub label: String,
    /// The model and its checked parameter values.
    pub params: ParamSet,
}

impl Subject {
    /// A subject labelled `material model`, or the model's name alone when `material` is `None`.
    pub fn new(params: ParamSet, material: Option<&str>) -> Subject {
        let label = match material {
            Some(m) => format!("{m} {}", params.model().name()),
            None => params.model().name().to_string(),
        };
        Subject { label, params }
    }

    /// `gold cook_torrance: diffuse=… specular=…`, the parameters its components use.
    pub fn describe(&self) -> String {
        describe_subjects(std::slice::from_ref(self)).remove(0)
    }
}

/// A parameter value for a title: numbers shortened, an RGB triple of one grey as one number.
fn value_text(v: crate::model::Value) -> String {
    use crate::model::Value;
    match v {
        Value::One(x) => fmt_value(x),
        Value::Three([r, g, b]) if r == g && g == b => fmt_value(r),
        Value::Three(c) => c.map(fmt_value).join(","),
        Value::Choice(name) => name.to_string(),
    }
}

/// The header lines that say what the series are: the parameters every series shares, once,
/// then each series with only what differs, and only parameters that the series' components
/// use ([`ParamSet::is_active`]). The full sets go to the JSON beside the picture
/// ([`write_params_json`]).
pub fn describe_subjects(subjects: &[Subject]) -> Vec<String> {
    let active: Vec<Vec<(&str, String)>> = subjects
        .iter()
        .map(|s| {
            s.params
                .active_entries()
                .into_iter()
                .map(|(k, v)| (k, value_text(v)))
                .collect()
        })
        .collect();
    if subjects.len() == 1 {
        let text: Vec<String> = active[0].iter().map(|(k, v)| format!("{k}={v}")).collect();
        return vec![format!("{}: {}", subjects[0].label, text.join(" "))];
    }
    // Shared: the same value in every series.
    let shared: Vec<&(&str, String)> = active[0]
        .iter()
        .filter(|e| active.iter().all(|a| a.contains(e)))
        .collect();
    let mut lines = Vec::new();
    if !shared.is_empty() {
        let text: Vec<String> = shared.iter().map(|(k, v)| format!("{k}={v}")).collect();
        lines.push(format!("all: {}", text.join(" ")));
    }
    let own: Vec<String> = subjects
        .iter()
        .zip(&active)
        .map(|(s, a)| {
            let text: Vec<String> = a
                .iter()
                .filter(|e| !shared.contains(e))
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            if text.is_empty() {
                s.label.clone()
            } else {
                format!("{}: {}", s.label, text.join(" "))
            }
        })
        .collect();
    lines.push(own.join(" · "));
    lines
}

/// The series for a title: `gold: phong, blinn_phong` when every label starts with the same
/// material, `gold cook_torrance vs tin cook_torrance` otherwise; more than four series are
/// counted (the legend names them).
pub fn series_names(subjects: &[Subject]) -> String {
    let labels: Vec<&str> = subjects.iter().map(|s| s.label.as_str()).collect();
    let first = labels.first().copied().unwrap_or_default();
    let prefix = first.split_once(' ').map(|(m, _)| m);
    let common_material = prefix.filter(|m| {
        labels.len() > 1
            && labels
                .iter()
                .all(|l| l.split_once(' ').map(|(p, _)| p) == Some(*m))
    });
    match common_material {
        Some(m) if labels.len() > 4 => format!("{m}, {} models", labels.len()),
        Some(m) => {
            let rest: Vec<&str> = labels.iter().map(|l| &l[m.len() + 1..]).collect();
            format!("{m}: {}", rest.join(" vs "))
        }
        None if labels.len() > 4 => format!("{} series", labels.len()),
        None => labels.join(" vs "),
    }
}

/// Where the parameters of a picture go: `path` with the extension `.json`.
pub fn params_json_path(path: &Path) -> std::path::PathBuf {
    path.with_extension("json")
}

/// Writes every series' full parameter set (and the picture's title) as JSON to
/// [`params_json_path`] of `path`: `{"title": …, "series": [{"label", "model", "params"}]}`.
pub fn write_params_json(path: &Path, subjects: &[Subject], plotted: &Plotted) -> Result<()> {
    let json = params_json(subjects, plotted.title());
    let dest = params_json_path(path);
    let text = serde_json::to_string_pretty(&json)? + "\n";
    crate::output::write_atomic(&dest, |w| {
        std::io::Write::write_all(w, text.as_bytes())
            .with_context(|| format!("writing {}", dest.display()))
    })
}

/// What [`write_params_json`] writes: `{"title": …, "series": [{"label", "model", "params"}]}`.
pub fn params_json(subjects: &[Subject], title: &str) -> serde_json::Value {
    let series: Vec<serde_json::Value> = subjects
        .iter()
        .map(|s| {
            serde_json::json!({
                "label": s.label,
                "model": s.params.model().name(),
                "params": s.params.to_json(),
            })
        })
        .collect();
    serde_json::json!({ "title": title, "series": series })
}

/// Settings every kind shares.
#[derive(Clone, Debug)]
pub struct Common {
    /// Evaluate with every Fresnel factor of a specular lobe set to 1 (docs/design.md §3.5).
    pub white_furnace: bool,
    /// Plot f·cosθi instead of f.
    pub cos: bool,
    /// Logarithmic radius (polar, 3d) or colour (hemisphere; the slice is always logarithmic).
    pub log: bool,
    /// Decades a logarithmic scale spans below its maximum.
    pub decades: f64,
    /// The scalar of the RGB value that is plotted.
    pub channel: Channel,
    /// Image size in pixels (SVG: user units).
    pub size: (u32, u32),
}

impl Default for Common {
    fn default() -> Common {
        Common {
            white_furnace: false,
            cos: false,
            log: false,
            decades: 4.0,
            channel: Channel::Luminance,
            size: (1200, 800),
        }
    }
}

impl Common {
    /// `f` or `f·cosθi`, with the channel, for labels.
    pub fn quantity(&self) -> String {
        let q = if self.cos { "f·cosθi" } else { "f" };
        format!("{q} ({}, 1/sr)", self.channel.label())
    }

    /// Words for the title: the switches that change what is drawn.
    pub fn switches(&self) -> String {
        let mut s = Vec::new();
        if self.white_furnace {
            s.push("white furnace (Fresnel of specular lobes = 1)");
        }
        if self.log {
            s.push("log scale");
        }
        s.join(", ")
    }

    /// Checks `decades` (in (0, 30]) and `size` (width in [200, 8000], height in [150, 8000]).
    pub fn check(&self) -> Result<()> {
        if !(self.decades > 0.0 && self.decades <= 30.0) {
            return Err(bad(
                "decades",
                format!(
                    "{} decades: a logarithmic scale spans more than 0 and at most 30 decades",
                    self.decades
                ),
            ));
        }
        let (w, h) = self.size;
        if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
            return Err(bad(
                "size",
                format!("image size {w}x{h}: width must lie in [200, 8000] and height in [150, 8000] pixels"),
            ));
        }
        Ok(())
    }
}

/// A value-to-[0, 1] map, linear or logarithmic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// The value at position 0; positive when the scale is logarithmic.
    pub lo: f64,
    /// The value at position 1 (larger values saturate).
    pub hi: f64,
    /// Logarithmic between `lo` and `hi` instead of linear.
    pub log: bool,
}

impl Scale {
    /// From the largest plotted value: [0, max] or [max·10^-decades, max]. A zero maximum (a
    /// black lobe) still gets a usable range.
    pub fn from_max(max: f64, log: bool, decades: f64) -> Scale {
        let hi = if max.is_finite() && max > 0.0 {
            max
        } else {
            1.0
        };
        if log {
            Scale {
                lo: hi * 10f64.powf(-decades),
                hi,
                log,
            }
        } else {
            Scale { lo: 0.0, hi, log }
        }
    }

    /// A scale fitted to a heat map's values: the top at the `quantile` of the positive finite
    /// values (1 = the maximum; below 1 the colour saturates above it, so that a few extreme
    /// cells, such as the 1/(c_i c_o) blow-up at grazing θd, do not flatten the rest), and for a
    /// logarithmic scale the bottom at the smallest positive value when that is within `decades`.
    pub fn fit(values: &[f64], log: bool, decades: f64, quantile: f64) -> Scale {
        let mut v: Vec<f64> = values
            .iter()
            .copied()
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect();
        if v.is_empty() {
            return Scale::from_max(0.0, log, decades);
        }
        v.sort_by(f64::total_cmp);
        let k = ((v.len() - 1) as f64 * quantile.clamp(0.0, 1.0)).round() as usize;
        let mut s = Scale::from_max(v[k], log, decades);
        if log && v[0] > s.lo && v[0] < s.hi {
            s.lo = v[0];
        }
        s
    }

    /// Position in [0, 1]; values below the range map to 0 (NaN stays NaN).
    pub fn unit(&self, v: f64) -> f64 {
        let t = if self.log {
            if v <= 0.0 {
                0.0
            } else {
                (v / self.lo).log10() / (self.hi / self.lo).log10()
            }
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        t.clamp(0.0, 1.0)
    }

    /// The value at position t in [0, 1].
    pub fn value(&self, t: f64) -> f64 {
        if self.log {
            self.lo * (self.hi / self.lo).powf(t)
        } else {
            self.lo + t * (self.hi - self.lo)
        }
    }

    /// Tick values inside the range: powers of ten (log) or round steps (linear).
    pub fn ticks(&self) -> Vec<f64> {
        if self.log {
            let a = self.lo.log10().ceil() as i32;
            let b = self.hi.log10().floor() as i32;
            let step = ((b - a) / 6).max(1);
            (a..=b)
                .step_by(step as usize)
                .map(|e| 10f64.powi(e))
                .collect()
        } else {
            let step = nice_step(self.hi - self.lo, 5);
            let mut v = Vec::new();
            let mut x = (self.lo / step).ceil() * step;
            while x <= self.hi * (1.0 + 1e-9) {
                v.push(x);
                x += step;
            }
            v
        }
    }
}

/// A round step (1, 2 or 5 times a power of ten) giving about `n` intervals over `span`.
pub fn nice_step(span: f64, n: usize) -> f64 {
    let raw = span / n as f64;
    let p = 10f64.powf(raw.log10().floor());
    let m = raw / p;
    let k = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    k * p
}

/// A short number for a tick label: `0.25`, `12`, `3e-4`.
pub fn fmt_value(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".to_string()
    } else if (0.01..1e4).contains(&a) {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        let s = format!("{v:.1e}");
        s.replace(".0e", "e")
    }
}

/// Matplotlib's viridis at t = 0, 1/8, …, 1 (sRGB 8-bit), interpolated linearly: perceptually
/// ordered and readable in grey and by colour-blind readers.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 145, 140),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// The colour map at t in [0, 1].
pub fn colour_map(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let k = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let u = x - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    let mix = |p: u8, q: u8| (p as f64 + u * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Line colours for overlaid series: the Okabe–Ito palette (distinguishable by colour-blind
/// readers) without its yellow, which is too light on white.
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// The k-th line colour of [`PALETTE`], starting again after seven.
pub fn palette(k: usize) -> RGBColor {
    PALETTE[k % PALETTE.len()]
}

/// A symbol repeated along a curve, so that series whose colours repeat stay apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// No symbol: the line alone.
    None,
    /// A filled disc.
    Circle,
    /// A filled square.
    Square,
    /// A filled triangle, point up.
    Triangle,
    /// A filled diamond.
    Diamond,
}

/// How one series is drawn: its colour and the marker along it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeriesStyle {
    /// The line's colour.
    pub colour: RGBColor,
    /// The symbol along the line.
    pub marker: Marker,
}

/// The k-th series style: the seven colours of [`PALETTE`] with no marker, then again with
/// circles, squares, triangles and diamonds: 35 distinct styles.
pub fn series_style(k: usize) -> SeriesStyle {
    const MARKERS: [Marker; 5] = [
        Marker::None,
        Marker::Circle,
        Marker::Square,
        Marker::Triangle,
        Marker::Diamond,
    ];
    SeriesStyle {
        colour: palette(k),
        marker: MARKERS[(k / PALETTE.len()) % MARKERS.len()],
    }
}

/// The built-in models' places in [`series_style`]. The first seven take the seven colours;
/// the others repeat a colour with a marker, each the colour of a model of another kind (a
/// glossy lobe with a diffuse one), which are seldom compared in one plot.
const MODEL_STYLES: [(&str, usize); 10] = [
    ("lambert", 0),
    ("phong", 1),
    ("blinn_phong", 2),
    ("oren_nayar", 3),
    ("cook_torrance", 4),
    ("smooth_layered", 5),
    ("coupled", 6),
    ("microfacet", 7),
    ("eon", 8),
    ("ashikhmin_shirley", 10),
];

/// The style of each subject. When every subject is a different model, each model keeps its
/// place in `MODEL_STYLES` (a model registered at run time: the places after them), so that a
/// model has the same look in every plot; otherwise (one model in several materials) the
/// subjects take the styles in order.
pub fn subject_styles(subjects: &[Subject]) -> Vec<SeriesStyle> {
    let names: Vec<&str> = subjects.iter().map(|s| s.params.model().name()).collect();
    let distinct = names
        .iter()
        .collect::<std::collections::BTreeSet<_>>()
        .len()
        == names.len();
    if !distinct {
        return (0..subjects.len()).map(series_style).collect();
    }
    let mut next = MODEL_STYLES.iter().map(|m| m.1).max().unwrap_or(0) + 1;
    names
        .iter()
        .map(|name| match MODEL_STYLES.iter().find(|m| m.0 == *name) {
            Some(&(_, k)) => series_style(k),
            None => {
                next += 1;
                series_style(next - 1)
            }
        })
        .collect()
}

/// Line patterns for a second overlaid dimension (θi when several models are drawn).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dash {
    /// An unbroken line.
    Solid,
    /// Dashes of 10 pixels with gaps of 6.
    Dashed,
    /// Dots of 2 pixels with gaps of 4.
    Dotted,
    /// Long dashes of 22 pixels with a dot between.
    Long,
}

impl Dash {
    /// The k-th pattern, starting again after four: solid, dashed, dotted, long.
    pub fn nth(k: usize) -> Dash {
        [Dash::Solid, Dash::Dashed, Dash::Dotted, Dash::Long][k % 4]
    }

    /// The SVG `stroke-dasharray` in pixels; None for a solid line.
    fn dasharray(self) -> Option<&'static str> {
        match self {
            Dash::Solid => None,
            Dash::Dashed => Some("10 6"),
            Dash::Dotted => Some("2 4"),
            Dash::Long => Some("22 5 3 5"),
        }
    }
}

/// One entry of a hand-drawn legend: a sample of a curve that the plot draws, and its label.
#[derive(Clone, Debug)]
pub struct LegendEntry {
    /// The text drawn beside the line sample.
    pub label: String,
    /// The line's colour.
    pub colour: RGBColor,
    /// The line's pattern.
    pub dash: Dash,
    /// The symbol along the line.
    pub marker: Marker,
}

/// `#rrggbb` of a colour.
fn hex(c: RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}

/// A coordinate with two decimals: sub-pixel positions, and the same text for the same input.
fn coord(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// SVG elements drawn over plotters' picture in canvas pixels with sub-pixel precision: the
/// curves, markers and masks whose shape matters (plotters rounds every coordinate to a whole
/// pixel). PNG and SVG share them: the PNG is the SVG rasterised.
#[derive(Debug, Default)]
pub struct Ink {
    svg: String,
}

impl Ink {
    /// A polyline through `points` (canvas pixels); non-finite points break it into pieces.
    pub fn line(
        &mut self,
        points: &[(f64, f64)],
        colour: RGBColor,
        width: f64,
        dash: Dash,
        opacity: f64,
    ) {
        for run in points.split(|p| !(p.0.is_finite() && p.1.is_finite())) {
            if run.len() < 2 {
                continue;
            }
            let mut pts = String::new();
            let mut last: Option<(f64, f64)> = None;
            for (k, &p) in run.iter().enumerate() {
                // Points closer than a tenth of a pixel to the last one add nothing visible.
                if let Some(q) = last {
                    if k + 1 < run.len() && (p.0 - q.0).abs() < 0.1 && (p.1 - q.1).abs() < 0.1 {
                        continue;
                    }
                }
                if !pts.is_empty() {
                    pts.push(' ');
                }
                pts.push_str(&format!("{},{}", coord(p.0), coord(p.1)));
                last = Some(p);
            }
            let dash = dash
                .dasharray()
                .map(|d| format!(" stroke-dasharray=\"{d}\""))
                .unwrap_or_default();
            let opacity = if opacity < 1.0 {
                format!(" stroke-opacity=\"{}\"", coord(opacity))
            } else {
                String::new()
            };
            self.svg.push_str(&format!(
                "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" stroke-linejoin=\"round\" stroke-linecap=\"round\"{dash}{opacity} points=\"{pts}\"/>\n",
                hex(colour),
                coord(width)
            ));
        }
    }

    /// One marker centred on `p`, `r` pixels in radius, filled with `colour` and ringed in white.
    pub fn marker(&mut self, p: (f64, f64), marker: Marker, colour: RGBColor, r: f64) {
        let (x, y) = p;
        let style = format!(
            "fill=\"{}\" stroke=\"white\" stroke-width=\"1\"",
            hex(colour)
        );
        let shape = match marker {
            Marker::None => return,
            Marker::Circle => format!(
                "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" {style}/>",
                coord(x),
                coord(y),
                coord(r)
            ),
            Marker::Square => {
                let a = r * 0.9;
                format!(
                    "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" {style}/>",
                    coord(x - a),
                    coord(y - a),
                    coord(2.0 * a),
                    coord(2.0 * a)
                )
            }
            Marker::Triangle => {
                let a = r * 1.2;
                self.polygon(
                    &[(x, y - a), (x + a, y + 0.8 * a), (x - a, y + 0.8 * a)],
                    &style,
                );
                return;
            }
            Marker::Diamond => {
                let a = r * 1.25;
                self.polygon(&[(x, y - a), (x + a, y), (x, y + a), (x - a, y)], &style);
                return;
            }
        };
        self.svg.push_str(&shape);
        self.svg.push('\n');
    }

    fn polygon(&mut self, pts: &[(f64, f64)], style: &str) {
        let pts: Vec<String> = pts
            .iter()
            .map(|p| format!("{},{}", coord(p.0), coord(p.1)))
            .collect();
        self.svg.push_str(&format!(
            "<polygon points=\"{}\" {style}/>\n",
            pts.join(" ")
        ));
    }

    /// Markers along `points` (canvas pixels), one every `spacing` pixels of arc length,
    /// starting half a spacing in (with an offset `phase` in [0, 1) of a spacing, so that
    /// overlaid curves do not put their markers at the same places).
    pub fn markers_along(
        &mut self,
        points: &[(f64, f64)],
        marker: Marker,
        colour: RGBColor,
        spacing: f64,
        phase: f64,
    ) {
        if marker == Marker::None {
            return;
        }
        let mut next = spacing * (0.5 + phase);
        let mut s = 0.0;
        for w in points.windows(2) {
            let (a, b) = (w[0], w[1]);
            if !(a.0.is_finite() && a.1.is_finite() && b.0.is_finite() && b.1.is_finite()) {
                continue;
            }
            let len = (b.0 - a.0).hypot(b.1 - a.1);
            while next <= s + len {
                let u = (next - s) / len;
                self.marker(
                    (a.0 + u * (b.0 - a.0), a.1 + u * (b.1 - a.1)),
                    marker,
                    colour,
                    4.0,
                );
                next += spacing;
            }
            s += len;
        }
    }

    /// A label centred on `p` (canvas pixels), `size` pixels high, in `colour` with a white
    /// halo so that it reads on any background.
    pub fn label(&mut self, p: (f64, f64), text: &str, size: f64, colour: RGBColor) {
        let text = text
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;");
        self.svg.push_str(&format!(
            "<text x=\"{}\" y=\"{}\" dy=\"0.35em\" text-anchor=\"middle\" font-family=\"{FONT}\" font-size=\"{}\" fill=\"{}\" stroke=\"white\" stroke-width=\"3\" stroke-linejoin=\"round\" paint-order=\"stroke\">{text}</text>\n",
            coord(p.0),
            coord(p.1),
            coord(size),
            hex(colour)
        ));
    }

    /// A white mask over everything outside the circle of radius `r` about `c` within the
    /// rectangle (x0, y0)–(x1, y1): an anti-aliased round edge for a heat map drawn in square
    /// cells.
    pub fn mask_outside_circle(&mut self, rect: (f64, f64, f64, f64), c: (f64, f64), r: f64) {
        let (x0, y0, x1, y1) = rect;
        self.svg.push_str(&format!(
            "<path fill=\"white\" fill-rule=\"evenodd\" d=\"M{},{}H{}V{}H{}Z M{},{}a{r},{r} 0 1,0 {d},0a{r},{r} 0 1,0 -{d},0Z\"/>\n",
            coord(x0),
            coord(y0),
            coord(x1),
            coord(y1),
            coord(x0),
            coord(c.0 - r),
            coord(c.1),
            r = coord(r),
            d = coord(2.0 * r)
        ));
    }
}

/// The pieces of the contour line `value = level` of a grid of `nx` × `ny` values (row-major,
/// row k at `ys[k]`, column j at `xs[j]`), by marching squares with linear interpolation along
/// the cell edges: one segment per crossing pair in each square of four neighbouring values.
pub fn contour_segments(
    values: &[f64],
    xs: &[f64],
    ys: &[f64],
    level: f64,
) -> Vec<((f64, f64), (f64, f64))> {
    let (nx, ny) = (xs.len(), ys.len());
    let v = |j: usize, k: usize| values[k * nx + j];
    let mut out = Vec::new();
    for k in 0..ny.saturating_sub(1) {
        for j in 0..nx.saturating_sub(1) {
            // The square's corners, counter-clockwise from the bottom left.
            let corners = [(j, k), (j + 1, k), (j + 1, k + 1), (j, k + 1)];
            let mut cuts = Vec::new();
            for e in 0..4 {
                let (a, b) = (corners[e], corners[(e + 1) % 4]);
                let (va, vb) = (v(a.0, a.1), v(b.0, b.1));
                if !(va.is_finite() && vb.is_finite()) || (va < level) == (vb < level) {
                    continue;
                }
                let t = (level - va) / (vb - va);
                let at = |c: (usize, usize)| (xs[c.0], ys[c.1]);
                let (pa, pb) = (at(a), at(b));
                cuts.push((pa.0 + t * (pb.0 - pa.0), pa.1 + t * (pb.1 - pa.1)));
            }
            for pair in cuts.chunks_exact(2) {
                out.push((pair[0], pair[1]));
            }
        }
    }
    out
}

/// A float version of a 2D chart's coordinate map: chart units to canvas pixels without
/// rounding. `pa` is the chart's plotting area.
pub(crate) fn pixel_map<DB: DrawingBackend>(
    pa: &DrawingArea<
        DB,
        plotters::coord::cartesian::Cartesian2d<
            plotters::coord::types::RangedCoordf64,
            plotters::coord::types::RangedCoordf64,
        >,
    >,
) -> impl Fn((f64, f64)) -> (f64, f64) {
    let (px, py) = pa.get_pixel_range();
    let (xr, yr) = (pa.get_x_range(), pa.get_y_range());
    move |(x, y)| {
        let u = (x - xr.start) / (xr.end - xr.start);
        let v = (y - yr.start) / (yr.end - yr.start);
        (
            px.start as f64 + u * (px.end - px.start) as f64,
            py.end as f64 - v * (py.end - py.start) as f64,
        )
    }
}

/// Maps plotters' errors (whose types depend on the backend) to anyhow with what was drawn.
pub(crate) trait Drawn<T> {
    /// The result, its error turned into "drawing {what}: {error}".
    fn drawing(self, what: &str) -> Result<T>;
}

impl<T, E: std::fmt::Display> Drawn<T> for std::result::Result<T, E> {
    fn drawing(self, what: &str) -> Result<T> {
        self.map_err(|e| anyhow!("drawing {what}: {e}"))
    }
}

/// DejaVu Sans of `size` pixels in `colour`, anchored at the text's top left.
pub(crate) fn text_style(size: u32, colour: RGBColor) -> TextStyle<'static> {
    TextStyle {
        font: (FONT, size).into_font(),
        color: colour.to_backend_color(),
        pos: Pos::new(HPos::Left, VPos::Top),
    }
}

/// Black DejaVu Sans of `size` pixels, anchored at (`h`, `v`) of the text.
pub(crate) fn anchored(size: u32, h: HPos, v: VPos) -> TextStyle<'static> {
    text_style(size, BLACK).pos(Pos::new(h, v))
}

/// Characters of `size`-pixel DejaVu Sans that fit in `width` pixels (its mean advance is about
/// 0.55 em for mixed text).
fn chars_in(width: u32, size: u32) -> usize {
    ((width as f64) / (0.55 * size as f64)).max(10.0) as usize
}

/// Greedy word wrap.
fn wrap(text: &str, max: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for w in text.split(' ') {
        if !cur.is_empty() && cur.chars().count() + 1 + w.chars().count() > max {
            lines.push(std::mem::take(&mut cur));
            cur.push_str("    ");
        }
        if !cur.is_empty() && !cur.ends_with("    ") {
            cur.push(' ');
        }
        cur.push_str(w);
    }
    if !cur.trim().is_empty() {
        lines.push(cur);
    }
    lines
}

/// Draws a bold title and smaller wrapped lines at the top of `root`; returns the area below.
pub(crate) fn header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    lines: &[String],
) -> Result<DrawingArea<DB, Shift>> {
    let (w, _) = root.dim_in_pixel();
    let title_size = 22;
    let small = 14;
    let mut y = 8i32;
    let title_style = TextStyle {
        font: (FONT, title_size, FontStyle::Bold).into_font(),
        color: BLACK.to_backend_color(),
        pos: Pos::new(HPos::Center, VPos::Top),
    };
    for line in wrap(title, chars_in(w - 20, title_size)) {
        root.draw(&Text::new(line, (w as i32 / 2, y), title_style.clone()))
            .drawing("the title")?;
        y += title_size as i32 + 4;
    }
    let style = anchored(small, HPos::Center, VPos::Top);
    for text in lines {
        for line in wrap(text, chars_in(w - 20, small)) {
            root.draw(&Text::new(line, (w as i32 / 2, y), style.clone()))
                .drawing("the title")?;
            y += small as i32 + 3;
        }
    }
    Ok(root.split_vertically(y + 6).1)
}

/// The width in pixels a legend of `entries` needs: the sample, the widest label and margins.
pub(crate) fn legend_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> u32 {
    let style = anchored(LEGEND_TEXT, HPos::Left, VPos::Center);
    let widest = entries
        .iter()
        .map(|e| {
            area.estimate_text_size(&e.label, &style)
                .map(|(w, _)| w)
                .unwrap_or(0)
        })
        .max()
        .unwrap_or(0);
    widest + 72
}

/// `text`, shortened with "…" until it fits in `width` pixels at `size`.
fn fit_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    width: u32,
    size: u32,
) -> String {
    let style = anchored(size, HPos::Left, VPos::Center);
    let fits = |t: &str| {
        area.estimate_text_size(t, &style)
            .map(|(w, _)| w <= width)
            .unwrap_or(true)
    };
    if fits(text) {
        return text.to_string();
    }
    let chars: Vec<char> = text.chars().collect();
    (1..chars.len())
        .rev()
        .map(|n| chars[..n].iter().collect::<String>() + "…")
        .find(|t| fits(t))
        .unwrap_or_else(|| "…".to_string())
}

/// Text size of legend labels, in pixels.
const LEGEND_TEXT: u32 = 14;

/// A legend in its own column: a sample of each entry's curve (colour, pattern and marker) and
/// its label.
pub(crate) fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    ink: &mut Ink,
    entries: &[LegendEntry],
) -> Result<()> {
    let size = LEGEND_TEXT;
    let row = 22;
    let (w, h) = area.dim_in_pixel();
    let (ox, oy) = area.get_base_pixel();
    let top = ((h as i32 - row * entries.len() as i32) / 2).max(10);
    for (k, e) in entries.iter().enumerate() {
        let y = top + row * k as i32 + row / 2;
        let (x0, x1, yy) = ((ox + 8) as f64, (ox + 48) as f64, (oy + y) as f64);
        ink.line(&[(x0, yy), (x1, yy)], e.colour, 2.0, e.dash, 1.0);
        ink.marker(((x0 + x1) / 2.0, yy), e.marker, e.colour, 4.0);
        let label = fit_text(area, &e.label, w.saturating_sub(60), size);
        area.draw(&Text::new(
            label,
            (56, y),
            anchored(size, HPos::Left, VPos::Center),
        ))
        .drawing("the legend")?;
    }
    Ok(())
}

/// A vertical colour bar with tick labels and a caption, filling `area`.
pub(crate) fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: &Scale,
    caption: &str,
) -> Result<()> {
    let (w, h) = area.dim_in_pixel();
    let (x0, x1) = (10i32, 34i32);
    let (y0, y1) = (30i32, h as i32 - 30);
    let steps = (y1 - y0).max(1);
    for k in 0..steps {
        let t = 1.0 - (k as f64 + 0.5) / steps as f64;
        area.draw(&Rectangle::new(
            [(x0, y0 + k), (x1, y0 + k + 1)],
            colour_map(t).filled(),
        ))
        .drawing("the colour bar")?;
    }
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))
        .drawing("the colour bar")?;
    for v in scale.ticks() {
        let t = scale.unit(v);
        let y = y1 - (t * (y1 - y0) as f64).round() as i32;
        area.draw(&PathElement::new(vec![(x1, y), (x1 + 5, y)], BLACK))
            .drawing("the colour bar")?;
        area.draw(&Text::new(
            fmt_value(v),
            (x1 + 8, y),
            anchored(13, HPos::Left, VPos::Center),
        ))
        .drawing("the colour bar")?;
    }
    let style = text_style(14, BLACK)
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Bottom));
    area.draw(&Text::new(
        caption.to_string(),
        (w as i32 - 4, (y0 + y1) / 2),
        style,
    ))
    .drawing("the colour bar")?;
    Ok(())
}

/// Draws with `draw` on an SVG canvas of `size` and writes it to `path`: as SVG, or for a
/// `.png` rasterised, anti-aliased, by resvg (one drawing for both formats). `draw` gets the
/// plotters canvas and an [`Ink`] layer that is drawn over it. The picture is written to a
/// temporary file beside `path` and renamed over it only when complete: a failed plot leaves
/// no file. The same input gives the same bytes.
pub(crate) fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Ink) -> Result<()>,
) -> Result<()> {
    let bytes = render_bytes(Format::of(path)?, size, draw)?;
    crate::output::write_atomic(path, |w| {
        std::io::Write::write_all(w, &bytes).with_context(|| format!("writing {}", path.display()))
    })
}

/// What `draw` draws on an SVG canvas of `size`, as the bytes of a file in `format` (see
/// [`render`]), for a caller that writes several pictures as one transaction.
pub(crate) fn render_bytes(
    format: Format,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Ink) -> Result<()>,
) -> Result<Vec<u8>> {
    let svg = draw_svg(size, draw)?;
    Ok(match format {
        Format::Svg => svg.into_bytes(),
        Format::Png => rasterise(&svg, size)?,
    })
}

/// The SVG text of what `draw` draws on a white canvas of `size`, its [`Ink`] on top.
pub fn draw_svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Ink) -> Result<()>,
) -> Result<String> {
    register_fonts()?;
    let mut svg = String::new();
    let mut ink = Ink::default();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).drawing("the background")?;
        draw(&root, &mut ink)?;
        root.present().drawing("the picture")?;
    }
    let end = svg
        .rfind("</svg>")
        .ok_or_else(|| anyhow!("the SVG backend wrote no closing tag"))?;
    svg.insert_str(end, &ink.svg);
    Ok(svg)
}

/// The fonts resvg draws text with: the embedded DejaVu Sans (regular and bold) as every
/// family, so that no system font is read.
fn font_db() -> std::sync::Arc<resvg::usvg::fontdb::Database> {
    static DB: OnceLock<std::sync::Arc<resvg::usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = resvg::usvg::fontdb::Database::new();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.load_font_data(dejavu::sans::bold().to_vec());
        db.set_sans_serif_family("DejaVu Sans");
        std::sync::Arc::new(db)
    })
    .clone()
}

/// The SVG `svg` (of `size` pixels) as an 8-bit sRGB PNG, anti-aliased by resvg.
pub fn rasterise(svg: &str, size: (u32, u32)) -> Result<Vec<u8>> {
    let options = resvg::usvg::Options {
        font_family: "DejaVu Sans".to_string(),
        fontdb: font_db(),
        ..Default::default()
    };
    let tree = resvg::usvg::Tree::from_str(svg, &options).context("reading the drawn SVG")?;
    let (w, h) = size;
    let mut pixmap = resvg::tiny_skia::Pixmap::new(w, h)
        .ok_or_else(|| anyhow!("cannot make a {w}x{h} image"))?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    // The background is opaque white, so the premultiplied RGBA pixels are plain RGB.
    let rgb: Vec<u8> = pixmap
        .data()
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().context("encoding the PNG")?;
        writer.write_image_data(&rgb).context("encoding the PNG")?;
    }
    Ok(out)
}

/// What to plot: the kind with its own options.
#[derive(Clone, Debug)]
pub enum Request {
    /// A polar plot ([`polar::plot_polar`]).
    Polar(polar::PolarOptions),
    /// A hemisphere heat map ([`hemisphere::plot_hemisphere`]).
    Hemisphere(hemisphere::HemisphereOptions),
    /// A θh × θd slice ([`slice::plot_slice`]).
    Slice(slice::SliceOptions),
    /// A 3D wireframe of the lobe ([`surface3d::plot_surface3d`]).
    Surface3d(surface3d::Surface3dOptions),
    /// Directional albedo curves ([`albedo::plot_albedo`]).
    Albedo(albedo::AlbedoOptions),
}

/// What a plot drew, by kind.
#[derive(Clone, Debug)]
pub enum Plotted {
    /// What [`polar::plot_polar`] drew.
    Polar(polar::PolarData),
    /// What [`hemisphere::plot_hemisphere`] drew.
    Hemisphere(hemisphere::HemisphereData),
    /// What [`slice::plot_slice`] drew.
    Slice(slice::SliceData),
    /// What [`surface3d::plot_surface3d`] drew.
    Surface3d(surface3d::Surface3dData),
    /// What [`albedo::plot_albedo`] drew.
    Albedo(albedo::AlbedoData),
}

impl Plotted {
    /// The title drawn at the top of the picture.
    pub fn title(&self) -> &str {
        match self {
            Plotted::Polar(d) => &d.title,
            Plotted::Hemisphere(d) => &d.title,
            Plotted::Slice(d) => &d.title,
            Plotted::Surface3d(d) => &d.title,
            Plotted::Albedo(d) => &d.title,
        }
    }

    /// BRDF evaluations spent (albedo: integrand evaluations).
    pub fn evaluations(&self) -> u64 {
        match self {
            Plotted::Polar(d) => d.series.iter().map(|s| s.value.len() as u64).sum(),
            Plotted::Hemisphere(d) => d.evaluations,
            Plotted::Slice(d) => d.evaluations,
            Plotted::Surface3d(d) => d.evaluations,
            Plotted::Albedo(d) => d.evaluations,
        }
    }
}

/// Evaluates and draws `request` into `path` (.png or .svg by its extension).
pub fn plot(
    eval: &crate::eval::Evaluator,
    subjects: &[Subject],
    common: &Common,
    request: &Request,
    path: &Path,
) -> Result<Plotted> {
    Ok(match request {
        Request::Polar(o) => Plotted::Polar(polar::plot_polar(eval, subjects, common, o, path)?),
        Request::Hemisphere(o) => Plotted::Hemisphere(hemisphere::plot_hemisphere(
            eval, subjects, common, o, path,
        )?),
        Request::Slice(o) => Plotted::Slice(slice::plot_slice(eval, subjects, common, o, path)?),
        Request::Surface3d(o) => {
            Plotted::Surface3d(surface3d::plot_surface3d(eval, subjects, common, o, path)?)
        }
        Request::Albedo(o) => {
            Plotted::Albedo(albedo::plot_albedo(eval, subjects, common, o, path)?)
        }
    })
}

/// Degrees to radians, for the CLI's angles.
pub(crate) fn rad(deg: f64) -> f64 {
    deg.to_radians()
}

/// Checks an angle given in degrees against [lo, hi); `option` tags the refusal, `name` is the
/// angle's name in the message.
pub(crate) fn check_deg(option: &'static str, name: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    if !(v >= lo && v < hi) {
        return Err(BadInput::new(
            option,
            format!("{name} = {v} deg is outside [{lo}, {hi}) degrees"),
        )
        .into());
    }
    Ok(())
}

/// Refuses a non-finite angle in degrees; `option` tags the refusal.
pub(crate) fn check_finite_deg(option: &'static str, name: &str, v: f64) -> Result<()> {
    if !v.is_finite() {
        return Err(BadInput::new(
            option,
            format!("{name} = {v} deg: expected a finite number of degrees"),
        )
        .into());
    }
    Ok(())
}

/// A [`BadInput`] tagged `option`, as an error.
pub(crate) fn bad(option: &'static str, message: String) -> anyhow::Error {
    BadInput::new(option, message).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_scale_maps_its_ends_and_ticks_are_inside() {
        let s = Scale::from_max(10.0, true, 3.0);
        assert!((s.unit(10.0) - 1.0).abs() < 1e-12);
        assert!((s.unit(0.01) - 0.0).abs() < 1e-12);
        assert_eq!(s.unit(0.0), 0.0);
        assert!((s.value(s.unit(0.5)) - 0.5).abs() < 1e-12);
        for t in s.ticks() {
            assert!(t >= s.lo * 0.999 && t <= s.hi * 1.001);
        }
        let l = Scale::from_max(0.25, false, 3.0);
        assert_eq!(l.ticks().first(), Some(&0.0));
    }

    #[test]
    fn a_fitted_scale_saturates_above_its_quantile_and_starts_at_the_smallest_value() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        v.push(1e9);
        v.push(f64::NAN);
        v.push(0.0);
        let s = Scale::fit(&v, true, 4.0, 0.99);
        assert_eq!((s.lo, s.hi), (1.0, 100.0));
        let m = Scale::fit(&v, false, 4.0, 1.0);
        assert_eq!((m.lo, m.hi), (0.0, 1e9));
    }

    #[test]
    fn every_built_in_model_has_a_style_place() {
        for m in crate::model::Model::ALL {
            assert!(
                MODEL_STYLES.iter().any(|s| s.0 == m.name()),
                "{} has no place in MODEL_STYLES",
                m.name()
            );
        }
    }

    #[test]
    fn formats_and_extensions() {
        assert_eq!(fmt_value(0.25), "0.25");
        assert_eq!(fmt_value(1e-4), "1e-4");
        assert!(Format::of(Path::new("a.PNG")).is_ok());
        assert!(Format::of(Path::new("a.jpg")).is_err());
        assert_eq!(colour_map(0.0), RGBColor(68, 1, 84));
        assert_eq!(colour_map(1.0), RGBColor(253, 231, 37));
    }
}
