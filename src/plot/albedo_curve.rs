//! Directional albedo curves E(μ), μ = cosθo, for several models or materials, with E = 1 drawn:
//! a curve above it gains energy (`smooth_layered` at grazing view), one below it
//! loses energy (single-scattering microfacet models at high roughness).
//!
//! E comes from [`crate::integrate::directional`] on the same backend as every other plot; delta
//! lobes are included exactly and their part is reported apart.

use super::{
    bad, check_finite_deg, describe_subjects, header_in, legend, legend_width, pixel_map, render,
    subject_styles, Dash, Drawn, LegendEntry, LegendRows, Marker, Overlay, PlotSettings,
    SeriesStyle, Subject,
};
use crate::eval::Evaluator;
use crate::integrate::{directional, Method, Settings};
use anyhow::{bail, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Options of the albedo plot: the view directions, the integrator and its node count.
#[derive(Clone, Debug)]
pub struct AlbedoOptions {
    /// View directions, cell-centred in μ over (0, 1].
    pub n_mu: usize,
    /// The integrator that computes each E(μ).
    pub method: Method,
    /// Quadrature nodes per direction (None: the method's default).
    pub samples: Option<usize>,
    /// φo in degrees (matters only for anisotropic models).
    pub phi_deg: f64,
}

impl Default for AlbedoOptions {
    fn default() -> AlbedoOptions {
        AlbedoOptions {
            n_mu: 48,
            method: Method::Peak,
            samples: None,
            phi_deg: 0.0,
        }
    }
}

/// One albedo curve.
#[derive(Clone, Debug)]
pub struct AlbedoCurve {
    /// Index into the subjects of the curve's model.
    pub subject: usize,
    /// The view cosines μ = cosθo, cell-centred over (0, 1], increasing.
    pub mu: Vec<f64>,
    /// E in the plotted channel, delta lobe included.
    pub albedo: Vec<f64>,
    /// E in RGB, delta lobe included.
    pub rgb: Vec<[f64; 3]>,
    /// The delta lobe's part (RGB).
    pub delta: Vec<[f64; 3]>,
    /// The integrator's error estimate (RGB).
    pub error: Vec<[f64; 3]>,
}

/// What an albedo plot shows: one curve per model, with E = 1 drawn.
#[derive(Clone, Debug)]
pub struct AlbedoData {
    /// The title drawn at the top of the picture.
    pub title: String,
    /// The curves, one per subject in the subjects' order.
    pub curves: Vec<AlbedoCurve>,
    /// The top of the vertical axis: a little above 1 and above the highest curve.
    pub y_max: f64,
    /// Integrand (BRDF) evaluations spent over every curve.
    pub evaluations: u64,
}

/// Integrates the curves (with [`crate::integrate::directional`]), without drawing.
pub fn albedo_data(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &AlbedoOptions,
) -> Result<AlbedoData> {
    common.check()?;
    if subjects.is_empty() {
        bail!("an albedo plot needs at least one model");
    }
    if !(2..=4096).contains(&opts.n_mu) {
        return Err(bad(
            "n_mu",
            format!(
                "{} view directions: an albedo plot takes 2 to 4096",
                opts.n_mu
            ),
        ));
    }
    check_finite_deg("phi_deg", "phi_o", opts.phi_deg)?;
    let settings = Settings {
        method: opts.method,
        samples: opts.samples.unwrap_or(opts.method.default_samples()),
        seed: crate::integrate::DEFAULT_SEED,
        white_furnace: common.white_furnace,
    };
    let phi = opts.phi_deg.to_radians();
    let points: Vec<(f64, f64)> = (0..opts.n_mu)
        .map(|k| ((k as f64 + 0.5) / opts.n_mu as f64, phi))
        .collect();
    let mut curves = Vec::new();
    let mut evaluations = 0;
    for (j, s) in subjects.iter().enumerate() {
        let pts = directional(eval, &s.params, &settings, &points)?;
        evaluations += pts.iter().map(|p| p.samples).sum::<u64>();
        curves.push(AlbedoCurve {
            subject: j,
            mu: pts.iter().map(|p| p.mu).collect(),
            albedo: pts
                .iter()
                .map(|p| common.channel.of(p.albedo.to_array()))
                .collect(),
            rgb: pts.iter().map(|p| p.albedo.to_array()).collect(),
            delta: pts.iter().map(|p| p.delta.to_array()).collect(),
            error: pts.iter().map(|p| p.error.to_array()).collect(),
        });
    }
    let max = curves
        .iter()
        .flat_map(|c| c.albedo.iter())
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let title = format!(
        "Directional albedo E(μ), μ = cosθo ({} rule): {}",
        opts.method.name(),
        super::series_names(subjects)
    );
    Ok(AlbedoData {
        title,
        curves,
        // Room above E = 1 (always drawn) and above the highest curve.
        y_max: (max.max(1.0) * 1.08).max(0.1),
        evaluations,
    })
}

/// Integrates and draws the curves into `path` (.png, .svg or .pdf); returns what it drew.
pub fn plot_albedo(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &AlbedoOptions,
    path: &Path,
) -> Result<AlbedoData> {
    super::Format::of(path)?;
    let data = albedo_data(eval, subjects, common, opts)?;
    render(path, common.page(), |root, ink| {
        draw(root, ink, &data, subjects, common)
    })?;
    Ok(data)
}

/// Pixels of curve between two markers: several per curve where curves cross and bunch near
/// grazing μ, so a reader can follow one through the bunch.
const MARKER_SPACING: f64 = 36.0;

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &AlbedoData,
    subjects: &[Subject],
    common: &PlotSettings,
) -> Result<()> {
    let mut lines = describe_subjects(subjects);
    let mut note = "delta lobes included exactly; top axis: θo in degrees".to_string();
    if common.white_furnace {
        note = format!("{note}; white furnace (Fresnel of specular lobes = 1)");
    }
    lines.push(note);
    let body = header_in(common.style, root, &data.title, &lines)?;
    let styles = subject_styles(subjects);
    let entries = legend_entries(subjects, &styles);
    let (w, h) = body.dim_in_pixel();
    let paper = common.style == super::Style::Paper;
    // A paper figure's legend goes in rows under the chart, whose axes take only the room
    // their labels need (and half of the last μ label right of the chart); on the screen the legend is a column of at least 150 px, but never
    // more than a third of the canvas.
    let rows = LegendRows::new(&entries, w as f64 - 4.0);
    let (plot_area, legend_area, legend_w) = if paper {
        let (a, b) = body.split_vertically(h - rows.height() - 2);
        (a, b, 0)
    } else {
        let legend_w = legend_width(&body, &entries).max(150).min(w / 3);
        let (a, b) = body.split_horizontally(w - legend_w);
        (a, b, legend_w)
    };
    let (_, h) = plot_area.dim_in_pixel();
    let (margin, bottom, top, left) = if paper {
        (6, 34, 30, 44)
    } else {
        (16, 44, 36, 60)
    };
    // About one μ label per 55 px (a label of "0.5" and room on either side), one E label per
    // 28 px of the plot's height (about 80 px go to the axes): at least 3, and at most plotters'
    // default of 11 (the θo axis: 10), which a screen canvas has room for.
    let x_fit = ((w - legend_w) / 55).max(3) as usize;
    let y_labels = (h.saturating_sub(80) / 28).clamp(3, 11) as usize;
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(margin)
        .margin_right(if paper { 12 } else { margin })
        .x_label_area_size(bottom)
        .top_x_label_area_size(top)
        .y_label_area_size(left)
        .build_cartesian_2d(0.0..1.0, 0.0..data.y_max)
        .drawing("the albedo chart")?
        .set_secondary_coord(0.0..1.0, 0.0..data.y_max);
    chart
        .configure_mesh()
        .x_labels(x_fit.min(11))
        .y_labels(y_labels)
        .x_desc("μ = cos θo")
        .y_desc(format!("E ({})", common.channel.label()))
        .label_style((super::FONT, 13))
        .axis_desc_style((super::FONT, 14))
        .light_line_style(BLACK.mix(0.05))
        .draw()
        .drawing("the albedo axes")?;
    // Top axis: θo = acos μ in degrees at the bottom axis's μ ticks.
    chart
        .configure_secondary_axes()
        .x_labels(x_fit.min(10))
        .x_label_formatter(&|mu: &f64| format!("{:.0}°", mu.clamp(0.0, 1.0).acos().to_degrees()))
        .x_desc("θo (degrees)")
        .label_style((super::FONT, 12))
        .axis_desc_style((super::FONT, 13))
        .draw()
        .drawing("the θo axis")?;
    let px = pixel_map(chart.plotting_area());
    ink.line(
        &[px((0.0, 1.0)), px((1.0, 1.0))],
        RGBColor(120, 120, 120),
        2.0,
        Dash::Dashed,
        1.0,
    );
    draw_curves(ink, &px, data, &styles);
    if paper {
        rows.draw(&legend_area, ink, &entries)?;
    } else {
        legend(&legend_area, ink, &entries)?;
    }
    Ok(())
}

/// One legend entry per subject, then the dashed line at E = 1.
fn legend_entries(subjects: &[Subject], styles: &[SeriesStyle]) -> Vec<LegendEntry> {
    subjects
        .iter()
        .zip(styles)
        .map(|(s, st)| LegendEntry {
            label: s.label.clone(),
            colour: st.colour,
            dash: st.dash,
            marker: st.marker,
        })
        .chain(std::iter::once(LegendEntry {
            label: "E = 1: energy conserved".to_string(),
            colour: RGBColor(120, 120, 120),
            dash: Dash::Dashed,
            marker: Marker::None,
        }))
        .collect()
}

/// Every E(μ) curve through `px` (a chart point to canvas pixels), with its markers.
fn draw_curves(
    ink: &mut Overlay,
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    data: &AlbedoData,
    styles: &[SeriesStyle],
) {
    for c in &data.curves {
        let st = styles[c.subject];
        let pts: Vec<(f64, f64)> =
            c.mu.iter()
                .zip(&c.albedo)
                .map(|(&m, &e)| px((m, e)))
                .collect();
        ink.line(&pts, st.colour, 2.0, st.dash, 1.0);
        let phase = (c.subject % 4) as f64 / 4.0;
        ink.markers_along(&pts, st.marker, st.colour, MARKER_SPACING, phase);
    }
}
