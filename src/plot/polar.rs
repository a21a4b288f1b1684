//! In-plane polar plot: f (or f·cosθi) in the plane of incidence, one curve per model and θi.
//!
//! Geometry: the plane of incidence is the x–z plane. The light sits at φi = 180° (drawn on the
//! left), ωi = (−sinθi, 0, cosθi); the view sweeps a signed angle s ∈ (−90°, 90°),
//! ωo = (sin s, 0, cos s), so positive s is φo = 0 (the mirror side, drawn on the right) and
//! the mirror direction of ωi is s = +θi. A curve is the point at radius ρ(value) along ωo.

use super::{
    bad, check_curves, fmt_value, header_in, legend, legend_width, palette, pixel_map, rad, render,
    subject_styles, text_style, Dash, Drawn, LegendEntry, Marker, Overlay, PlotSettings, Scale,
    SeriesStyle, Subject,
};
use crate::eval::Evaluator;
use crate::model::Reference;
use anyhow::Result;
use glam::DVec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

mod curves;
mod frame;
mod paper;

use curves::{at, draw_curves};

/// View angles per curve: cell-centred over (−90°, 90°), 0.125° apart, fine enough that a
/// Phong lobe of exponent 8192 (half-width ≈ 1/√n rad ≈ 0.6°) is drawn with ~10 points.
pub const DEFAULT_SAMPLES: usize = 1440;

/// Options of the polar plot: which incidence angles, and how many view angles per curve.
#[derive(Clone, Debug)]
pub struct PolarOptions {
    /// Incidence angles θi in degrees, each in [0, 90).
    pub theta_i_deg: Vec<f64>,
    /// View angles per curve.
    pub samples: usize,
    /// How values map to the radius; [`PlotSettings::log`] forces [`Radius::Log`].
    pub radius: Radius,
}

impl Default for PolarOptions {
    fn default() -> PolarOptions {
        PolarOptions {
            theta_i_deg: vec![0.0, 30.0, 60.0, 80.0],
            samples: DEFAULT_SAMPLES,
            radius: Radius::Auto,
        }
    }
}

/// How a polar plot maps values to its radius.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Radius {
    /// Logarithmic when the curves' peaks span more than [`AUTO_LOG_DECADES`], else linear.
    Auto,
    /// Linear from 0 to the largest value.
    Linear,
    /// Logarithmic over [`PlotSettings::decades`] below the largest value.
    Log,
    /// Each curve divided by its own peak, linear from 0 to 1: shapes compared, sizes not.
    Normalised,
}

/// Peaks spanning more decades than this put a polar plot on a log radius ([`Radius::Auto`]):
/// on a linear radius a curve 100 times below the largest peaks at 1 % of the radius, a few
/// pixels at any usable size.
pub const AUTO_LOG_DECADES: f64 = 2.0;

/// One plotted curve.
#[derive(Clone, Debug)]
pub struct PolarSeries {
    /// Index into the subjects.
    pub subject: usize,
    /// The incidence angle θi of this curve, in degrees.
    pub theta_i_deg: f64,
    /// Signed view angle s in degrees (positive: the mirror side).
    pub theta_o_deg: Vec<f64>,
    /// The plotted value (the channel of f or f·cosθi) at each angle, in 1/sr.
    pub value: Vec<f64>,
    /// f (or f·cosθi) in RGB at each angle.
    pub rgb: Vec<[f64; 3]>,
}

impl PolarSeries {
    /// The signed angle where the plotted value is largest (the first, if several tie).
    pub fn peak_deg(&self) -> f64 {
        let mut best = 0;
        for (k, v) in self.value.iter().enumerate() {
            if *v > self.value[best] {
                best = k;
            }
        }
        self.theta_o_deg[best]
    }
}

/// A delta lobe drawn as an arrow at the mirror direction.
#[derive(Clone, Debug)]
pub struct DeltaMark {
    /// Index into the subjects of the delta lobe's model.
    pub subject: usize,
    /// The incidence angle θi, in degrees.
    pub theta_i_deg: f64,
    /// Signed angle of the mirror direction (= θi).
    pub mirror_deg: f64,
    /// The spike's albedo (RGB), Reference::delta_albedo at c_o = cosθi.
    pub albedo: [f64; 3],
}

/// What a polar plot shows.
#[derive(Clone, Debug)]
pub struct PolarData {
    /// The title drawn at the top of the picture.
    pub title: String,
    /// The curves, subject by subject and, within a subject, in the order of the θi given.
    pub series: Vec<PolarSeries>,
    /// One arrow per delta lobe and θi, for models that have one.
    pub deltas: Vec<DeltaMark>,
    /// The radial scale the curves were drawn with ([0, 1] when normalised).
    pub scale: Scale,
    /// The radius mapping used: never [`Radius::Auto`], which resolves to linear or log.
    pub radius: Radius,
    /// Each series' largest finite value (the divisor of a normalised curve), in series order.
    pub peaks: Vec<f64>,
    /// Words on the plot saying which radius is drawn and, when chosen automatically, why.
    pub radius_note: String,
}

/// ωi for θi (light at φi = 180°).
pub fn light_direction(theta_i: f64) -> DVec3 {
    DVec3::new(-theta_i.sin(), 0.0, theta_i.cos())
}

/// ωo for the signed in-plane angle s.
pub fn view_direction(s: f64) -> DVec3 {
    DVec3::new(s.sin(), 0.0, s.cos())
}

/// Evaluates the curves (one eval_pairs call per subject), without drawing.
pub fn polar_data(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &PolarOptions,
) -> Result<PolarData> {
    check_request(subjects, common, opts)?;
    let n = opts.samples;
    let s_deg: Vec<f64> = (0..n)
        .map(|k| -90.0 + (k as f64 + 0.5) * 180.0 / n as f64)
        .collect();
    let mut series = Vec::new();
    let mut deltas = Vec::new();
    for (j, subject) in subjects.iter().enumerate() {
        let pairs: Vec<(DVec3, DVec3)> = opts
            .theta_i_deg
            .iter()
            .flat_map(|&t| {
                let wi = light_direction(rad(t));
                s_deg.iter().map(move |&s| (wi, view_direction(rad(s))))
            })
            .collect();
        let f = eval.eval_pairs(common.query(&subject.params), &pairs)?;
        let reference = Reference::new(&subject.params, common.white_furnace);
        for (a, &t) in opts.theta_i_deg.iter().enumerate() {
            let c_i = rad(t).cos();
            let weight = if common.cos { c_i } else { 1.0 };
            let rgb: Vec<[f64; 3]> = f[a * n..(a + 1) * n]
                .iter()
                .map(|c| c.map(|x| x * weight))
                .collect();
            let value = rgb.iter().map(|c| common.channel.of(*c)).collect();
            series.push(PolarSeries {
                subject: j,
                theta_i_deg: t,
                theta_o_deg: s_deg.clone(),
                value,
                rgb,
            });
            if subject.params.model().has_delta() {
                deltas.push(DeltaMark {
                    subject: j,
                    theta_i_deg: t,
                    mirror_deg: t,
                    albedo: reference.delta_albedo(c_i).to_array(),
                });
            }
        }
    }
    let peaks: Vec<f64> = series
        .iter()
        .map(|s| {
            s.value
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max)
        })
        .collect();
    let (radius, radius_note) = resolve_radius(opts.radius, common, &peaks);
    let scale = match radius {
        Radius::Normalised => Scale::from_max(1.0, false, common.decades),
        _ => Scale::from_max(
            peaks.iter().copied().fold(0.0, f64::max),
            radius == Radius::Log,
            common.decades,
        ),
    };
    let angles: Vec<String> = opts
        .theta_i_deg
        .iter()
        .map(|t| format!("{}°", fmt_value(*t)))
        .collect();
    let what = if common.cos { "f·cosθi" } else { "f" };
    let title = format!(
        "{what} in the plane of incidence, θi = {}: {}",
        angles.join(", "),
        super::series_names(subjects)
    );
    Ok(PolarData {
        title,
        series,
        deltas,
        scale,
        radius,
        peaks,
        radius_note,
    })
}

/// The options and subjects of a polar plot, checked before any evaluation.
fn check_request(subjects: &[Subject], common: &PlotSettings, opts: &PolarOptions) -> Result<()> {
    check_curves(subjects, common, "polar", &opts.theta_i_deg)?;
    if !(16..=1 << 20).contains(&opts.samples) {
        return Err(bad(
            "samples",
            format!(
                "{} view angles: a polar curve takes between 16 and 1048576",
                opts.samples
            ),
        ));
    }
    Ok(())
}

/// The radius a polar plot draws with, and the words that say so: `Auto` resolves by the
/// decades between the largest and the smallest positive peak.
fn resolve_radius(asked: Radius, common: &PlotSettings, peaks: &[f64]) -> (Radius, String) {
    let log_note = format!("log radius, {} decades", fmt_value(common.decades));
    let positive: Vec<f64> = peaks.iter().copied().filter(|p| *p > 0.0).collect();
    let hi = positive.iter().copied().fold(0.0, f64::max);
    let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
    let span = if hi > 0.0 { (hi / lo).log10() } else { 0.0 };
    match asked {
        _ if common.log => (Radius::Log, log_note),
        Radius::Log => (Radius::Log, log_note),
        Radius::Linear => (Radius::Linear, "linear radius".into()),
        Radius::Normalised => (
            Radius::Normalised,
            "each curve divided by its own peak (legend)".into(),
        ),
        Radius::Auto if span > AUTO_LOG_DECADES => (
            Radius::Log,
            format!(
                "{log_note} (the peaks span {} decades)",
                fmt_value((span * 10.0).round() / 10.0)
            ),
        ),
        Radius::Auto => (Radius::Linear, "linear radius".into()),
    }
}

/// Evaluates and draws the polar plot into `path` (.png, .svg or .pdf); returns what it drew.
pub fn plot_polar(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &PolarOptions,
    path: &Path,
) -> Result<PolarData> {
    super::Format::of(path)?;
    let data = polar_data(eval, subjects, common, opts)?;
    render(path, common.page(), |root, ink| {
        draw(root, ink, &data, subjects, common, opts)
    })?;
    Ok(data)
}

/// The picture of `data` (made by [`polar_data`] from the same arguments) as the bytes of a
/// `format` file.
pub fn polar_picture(
    data: &PolarData,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &PolarOptions,
    format: super::Format,
) -> Result<Vec<u8>> {
    super::render_bytes(format, common.page(), |root, ink| {
        draw(root, ink, data, subjects, common, opts)
    })
}

/// How each curve is styled: colour by θi when one model is drawn, else the subject's style
/// (colour and marker) with the line pattern by θi.
fn style_of(
    s: &PolarSeries,
    styles: &[SeriesStyle],
    angle_index: usize,
) -> (RGBColor, Marker, Dash) {
    if styles.len() == 1 {
        (palette(angle_index), Marker::None, Dash::Solid)
    } else {
        let st = styles[s.subject];
        (st.colour, st.marker, Dash::nth(angle_index))
    }
}

/// The legend: one row per curve when there are at most [`LEGEND_ROWS`] curves, else one row
/// per subject (solid) and one per θi drawn as the first subject's curve at that θi. Every
/// sample is a curve of the plot.
fn legend_entries(
    data: &PolarData,
    subjects: &[Subject],
    styles: &[SeriesStyle],
    opts: &PolarOptions,
) -> Vec<LegendEntry> {
    let angles = &opts.theta_i_deg;
    let theta = |t: f64| format!("θi = {}°", fmt_value(t));
    let mut entries = Vec::new();
    if subjects.len() == 1 {
        for (k, &t) in angles.iter().enumerate() {
            let label = if data.radius == Radius::Normalised {
                format!("{}, peak {}/sr", theta(t), fmt_value(data.peaks[k]))
            } else {
                theta(t)
            };
            entries.push(LegendEntry {
                label,
                colour: palette(k),
                dash: Dash::Solid,
                marker: Marker::None,
            });
        }
    } else if angles.len() == 1 {
        // One θi (it is in the title): one row per subject.
        for (j, s) in subjects.iter().enumerate() {
            entries.push(LegendEntry {
                label: s.label.clone(),
                colour: styles[j].colour,
                dash: Dash::Solid,
                marker: styles[j].marker,
            });
        }
    } else if subjects.len() * angles.len() <= LEGEND_ROWS {
        for (j, s) in subjects.iter().enumerate() {
            for (k, &t) in angles.iter().enumerate() {
                entries.push(LegendEntry {
                    label: format!("{}, {}", s.label, theta(t)),
                    colour: styles[j].colour,
                    dash: Dash::nth(k),
                    marker: styles[j].marker,
                });
            }
        }
    } else {
        for (j, s) in subjects.iter().enumerate() {
            entries.push(LegendEntry {
                label: s.label.clone(),
                colour: styles[j].colour,
                dash: Dash::Solid,
                marker: styles[j].marker,
            });
        }
        for (k, &t) in angles.iter().enumerate() {
            entries.push(LegendEntry {
                label: format!("{} ({} here)", theta(t), subjects[0].label),
                colour: styles[0].colour,
                dash: Dash::nth(k),
                marker: styles[0].marker,
            });
        }
    }
    if !data.deltas.is_empty() {
        entries.push(LegendEntry {
            label: "arrow: δ spike, ρ = albedo".into(),
            colour: BLACK,
            dash: Dash::Solid,
            marker: Marker::None,
        });
    }
    entries
}

/// The most legend rows that list every curve on its own.
const LEGEND_ROWS: usize = 16;

/// Radius in chart units (the horizon circle is radius 1) of a plotted value of the series
/// whose peak is `peak`.
fn radius(data: &PolarData, peak: f64, v: f64) -> f64 {
    let v = if data.radius == Radius::Normalised && peak > 0.0 {
        v / peak
    } else {
        v
    };
    if v.is_finite() {
        data.scale.unit(v)
    } else {
        0.0
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &PolarData,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &PolarOptions,
) -> Result<()> {
    if common.style == super::Style::Paper {
        return paper::draw_paper(root, ink, data, subjects, common, opts);
    }
    let mut lines = super::describe_subjects(subjects);
    let mut notes = vec![
        "light on the left at φi = 180°; signed θo > 0 is the mirror side (φo = 0)".to_string(),
    ];
    if !common.switches().is_empty() {
        notes.push(common.switches());
    }
    lines.push(notes.join("; "));
    let body = header_in(common.style, root, &data.title, &lines)?;
    let styles = subject_styles(subjects);
    let entries = legend_entries(data, subjects, &styles, opts);
    let (w, _) = body.dim_in_pixel();
    // At least 150 px, but never more than a third of a narrow canvas.
    let legend_w = legend_width(&body, &entries).max(150).min(w / 3);
    let (plot_area, legend_area) = body.split_horizontally(w - legend_w);

    // Equal scale on both axes: fit the half disc (plus room for labels) in the area.
    let (pw, ph) = plot_area.dim_in_pixel();
    let margin = 8u32;
    let (pw, ph) = ((pw - 2 * margin) as f64, (ph - 2 * margin) as f64);
    let axis_caption = format!(
        "radius: {}, {}   ·   angles: signed θo in degrees",
        common.quantity(),
        data.radius_note
    );
    // Wrapped to the chart's width (a narrow paper figure needs several lines); the lines after
    // the first take room from the half disc.
    let caption_lines = super::wrap_to_width(&axis_caption, pw, 14, false);
    let fr = frame::Frame::fit(pw, ph, caption_lines.len());
    let chart = ChartBuilder::on(&plot_area)
        .margin(margin)
        .build_cartesian_2d(-fr.x_half..fr.x_half, fr.y_bottom..fr.y_top)
        .drawing("the polar chart")?;
    let pa = chart.plotting_area().clone();
    let px = pixel_map(&pa);
    frame::draw_rings_and_spokes(&pa, ink, &px, &data.scale)?;
    fr.draw_caption(&pa, caption_lines)?;
    frame::draw_incidence(&pa, ink, &px, subjects, &opts.theta_i_deg)?;
    // Curves, in canvas pixels with sub-pixel precision.
    draw_curves(ink, data, &styles, &opts.theta_i_deg, &px, 90.0);
    frame::draw_deltas(
        &pa,
        ink,
        &px,
        (data, subjects, &styles),
        common,
        &opts.theta_i_deg,
    )?;
    legend(&legend_area, ink, &entries)?;
    Ok(())
}
