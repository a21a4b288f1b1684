//! `lobe plot`: pictures of a BRDF, written as PNG, SVG or PDF by the output's extension.
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
//! - [`albedo_curve`]: directional albedo E(μ) curves with E = 1 drawn;
//! - [`difference`]: two models overlaid in the plane of incidence and their relative difference
//!   over the hemisphere (`lobe compare`, `lobe fit`);
//! - [`pareto`]: `lobe tradeoff`'s error-vs-cost panels with their Pareto fronts;
//! - [`chi2`](mod@chi2): the sampling test's observed and expected histograms and residuals
//!   (`lobe chi2 -o`).
//!
//! Text is drawn with DejaVu Sans, embedded in the binary and registered with plotters' ab_glyph
//! backend at the first plot: no system fonts are read.
//!
//! The plotted scalar is one channel of the RGB value ([`Channel`]); luminance by default.

pub mod albedo_curve;
mod canvas;
pub mod chi2;
pub mod csv;
pub mod difference;
pub mod hemisphere;
pub mod pareto;
pub mod polar;
pub mod slice;
mod subject;
pub mod surface3d;

// The canvas's items are part of this module's interface (kinds and callers use them by
// `plot::` paths).
pub use canvas::*;
pub use subject::{
    describe_subjects, params_json, params_json_path, series_names, write_params_json, Subject,
};

use crate::backend::Query;
use crate::input::BadInput;
use crate::model::ParamSet;
use anyhow::{anyhow, bail, Result};
use std::path::Path;

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
    /// Directional albedo curves E(μ) ([`albedo_curve`]).
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
    /// A vector document of one page, the text in the embedded font.
    Pdf,
}

impl Format {
    /// The format of `path` by its extension (`.png`, `.svg` or `.pdf`, in any case); any other
    /// extension is an error.
    pub fn of(path: &Path) -> Result<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            Some("pdf") => Ok(Format::Pdf),
            _ => bail!(
                "{}: the plot's format follows the output's extension, which must be .png, .svg or .pdf",
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

/// Settings every kind shares.
#[derive(Clone, Debug)]
pub struct PlotSettings {
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
    /// The canvas the picture is laid out on, in pixels (SVG: user units); the written picture
    /// is this canvas scaled by the style ([`Style::page`]).
    pub size: (u32, u32),
    /// Screen or paper sizes: how the canvas is scaled onto the written picture.
    pub style: Style,
}

impl PlotSettings {
    /// What a plot evaluates of `params`: the parameter set with the white-furnace switch.
    pub fn query<'a>(&self, params: &'a ParamSet) -> Query<'a> {
        Query::one(params).with_white_furnace(self.white_furnace)
    }
}

/// How big a picture's text and lines are against its page.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Style {
    /// For the screen: the canvas written as it is, text of 12–17 px, at 96 pixels per inch.
    #[default]
    Screen,
    /// A single-column figure of a paper: 3.5 in wide, a PNG at 300 dpi (1050 px), text of 8–9.5
    /// pt (7.5–11 pt in 3d and slice plots), lines half as heavy, no title block (the title
    /// stays in the JSON beside the picture), a PDF or SVG page of the printed size.
    Paper,
}

/// A paper figure's width: one column of a two-column journal page (IEEE, ACM: 3.5 in).
pub const PAPER_WIDTH_IN: f64 = 3.5;

/// A paper figure's resolution: what journals ask of line art with shading.
pub const PAPER_DPI: f64 = 300.0;

/// The canvas a paper figure is laid out on, in pixels: 1050 / 300 = 3.5 written pixels per
/// canvas pixel zooms plotters' smallest common text, 12 px (an em of 12/1.24 px), to 8.1 pt at
/// 300 dpi, and its 13–14 px text to 8.8–9.5 pt (the 3d plot's 11-px axis numbers: 7.5 pt; the
/// 15–16 px panel captions of slices and 3d plots: 10–11 pt); a whole zoom keeps written sizes that are
/// multiples of 7 px exact.
pub const PAPER_CANVAS_WIDTH: u32 = 300;

/// The factor on line widths of a paper figure: the screen's 1 and 2 px lines, zoomed, would be
/// 0.84 and 1.7 pt; halved, 0.42 and 0.84 pt, the hairlines and data lines of printed plots.
pub const PAPER_STROKE: f64 = 0.5;

impl Style {
    /// The style's name on the command line: `screen` or `paper`.
    pub fn name(self) -> &'static str {
        match self {
            Style::Screen => "screen",
            Style::Paper => "paper",
        }
    }

    /// Written pixels per canvas pixel.
    pub fn zoom(self) -> f64 {
        match self {
            Style::Screen => 1.0,
            Style::Paper => PAPER_WIDTH_IN * PAPER_DPI / PAPER_CANVAS_WIDTH as f64,
        }
    }

    /// How a canvas of `canvas` pixels is written in this style.
    pub fn page(self, canvas: (u32, u32)) -> Page {
        match self {
            Style::Screen => Page::from(canvas),
            Style::Paper => Page {
                canvas,
                zoom: self.zoom(),
                dpi: PAPER_DPI,
                stroke: PAPER_STROKE,
            },
        }
    }

    /// The canvas whose written picture is `pixels` (width, height) in this style.
    pub fn canvas_for(self, pixels: (u32, u32)) -> (u32, u32) {
        let z = self.zoom();
        (
            (pixels.0 as f64 / z).round() as u32,
            (pixels.1 as f64 / z).round() as u32,
        )
    }
}

impl Default for PlotSettings {
    fn default() -> PlotSettings {
        PlotSettings {
            white_furnace: false,
            cos: false,
            log: false,
            decades: 4.0,
            channel: Channel::Luminance,
            size: (1200, 800),
            style: Style::Screen,
        }
    }
}

impl PlotSettings {
    /// How the canvas is written: [`Style::page`] of `size`.
    pub fn page(&self) -> Page {
        self.style.page(self.size)
    }

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
            let message = match self.style {
                Style::Screen => format!("image size {w}x{h}: width must lie in [200, 8000] and height in [150, 8000] pixels"),
                Style::Paper => {
                    let z = self.style.zoom();
                    let (pw, ph) = self.page().pixels();
                    format!(
                        "image size {pw}x{ph} (a canvas of {w}x{h} at the paper style's zoom of {z:.3}): \
                         the canvas's width must lie in [200, 8000] and its height in [150, 8000] pixels, \
                         the written size in [{:.0}, {:.0}] x [{:.0}, {:.0}]",
                        200.0 * z, 8000.0 * z, 150.0 * z, 8000.0 * z
                    )
                }
            };
            return Err(bad("size", message));
        }
        Ok(())
    }
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
    /// Directional albedo curves ([`albedo_curve::plot_albedo`]).
    Albedo(albedo_curve::AlbedoOptions),
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
    /// What [`albedo_curve::plot_albedo`] drew.
    Albedo(albedo_curve::AlbedoData),
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

/// Evaluates and draws `request` into `path` (.png, .svg or .pdf by its extension).
pub fn plot(
    eval: &crate::eval::Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
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
            Plotted::Albedo(albedo_curve::plot_albedo(eval, subjects, common, o, path)?)
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
/// The checks a plot of curves per incidence angle makes first: the common options, at least one
/// model and at least one θi, each in [0°, 90°).
pub(crate) fn check_curves(
    subjects: &[Subject],
    common: &PlotSettings,
    kind: &str,
    theta_i_deg: &[f64],
) -> Result<()> {
    common.check()?;
    if subjects.is_empty() {
        bail!("a {kind} plot needs at least one model");
    }
    if theta_i_deg.is_empty() {
        return Err(bad(
            "theta_i_deg",
            "give at least one incidence angle theta_i".into(),
        ));
    }
    for &t in theta_i_deg {
        check_deg("theta_i_deg", "theta_i", t, 0.0, 90.0)?;
    }
    Ok(())
}

pub(crate) fn bad(option: &'static str, message: String) -> anyhow::Error {
    BadInput::new(option, message).into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::style::RGBColor;

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
