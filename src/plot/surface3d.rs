//! The lobe as a 3D surface for one ωi: the wireframe of r(ωo) = value(ωo)·ωo over the
//! hemisphere, where value is f (or f·cosθi) in one channel, in 1/sr. With a logarithmic scale
//! the radius is the position on that scale instead (0 at max·10^-decades, 1 at the maximum).
//!
//! The chart's vertical axis is the surface normal z; its other two axes are x and y.

use super::{
    bad, check_curves, check_finite_deg, fmt_value, header_in, legend, rad, render, subject_styles,
    text_style, Dash, Drawn, LegendEntry, LegendRows, Marker, Overlay, PlotSettings, Scale,
    SeriesStyle, Subject,
};
use crate::eval::Evaluator;
use crate::grid::direction;
use anyhow::Result;
use glam::DVec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Options of the 3D wireframe: the incidence directions (one panel each) and the wireframe's rings
/// and meridians.
#[derive(Clone, Debug)]
pub struct Surface3dOptions {
    /// θi in degrees: one panel each.
    pub theta_i_deg: Vec<f64>,
    /// φi of every incidence direction, in degrees.
    pub phi_i_deg: f64,
    /// Rings of constant θo, from the pole to 89.5° (just above the horizon).
    pub n_theta: usize,
    /// Meridians of constant φo, 360°/n_phi apart.
    pub n_phi: usize,
}

impl Default for Surface3dOptions {
    fn default() -> Surface3dOptions {
        Surface3dOptions {
            theta_i_deg: vec![45.0],
            phi_i_deg: 0.0,
            n_theta: 60,
            n_phi: 72,
        }
    }
}

/// The last ring's θo: just above the horizon, where a one-sided f is still nonzero.
const LAST_RING_DEG: f64 = 89.5;

/// One wireframe.
#[derive(Clone, Debug)]
pub struct Surface3dPanel {
    /// Index into the subjects of the panel's model.
    pub subject: usize,
    /// θi of the panel, in degrees.
    pub theta_i_deg: f64,
    /// φi of the panel, in degrees.
    pub phi_i_deg: f64,
    /// n_theta × n_phi surface points (x, y, z) in chart units, row-major in (θo, φo).
    pub points: Vec<[f64; 3]>,
    /// The plotted value at each point, 1/sr.
    pub values: Vec<f64>,
    /// (θo, φo) in degrees of the largest value.
    pub peak_deg: (f64, f64),
}

/// What a 3D wireframe plot shows: one panel per (model, θi), all on one radial scale.
#[derive(Clone, Debug)]
pub struct Surface3dData {
    /// The title drawn at the top of the picture.
    pub title: String,
    /// Rings of constant θo in each panel.
    pub n_theta: usize,
    /// Meridians of constant φo in each panel.
    pub n_phi: usize,
    /// The wireframes, subject by subject and, within a subject, in the order of the θi given.
    pub panels: Vec<Surface3dPanel>,
    /// The radial scale: linear radius f, or the position on a logarithmic scale.
    pub scale: Scale,
    /// Half the extent of the chart's axes, in chart units.
    pub extent: f64,
    /// BRDF evaluations spent: n_theta × n_phi per panel.
    pub evaluations: u64,
}

fn theta_o_deg(k: usize, n: usize) -> f64 {
    LAST_RING_DEG * k as f64 / (n - 1) as f64
}

fn phi_o_deg(l: usize, n: usize) -> f64 {
    360.0 * l as f64 / n as f64
}

/// Evaluates the wireframes (one `eval_pairs` call per subject), without drawing.
pub fn surface3d_data(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &Surface3dOptions,
) -> Result<Surface3dData> {
    check_request(subjects, common, opts)?;
    let (nt, np) = (opts.n_theta, opts.n_phi);
    let wo: Vec<DVec3> = (0..nt * np)
        .map(|k| direction(rad(theta_o_deg(k / np, nt)), rad(phi_o_deg(k % np, np))))
        .collect();
    let mut raw = Vec::new();
    let mut evaluations = 0;
    for (j, subject) in subjects.iter().enumerate() {
        let mut pairs = Vec::with_capacity(wo.len() * opts.theta_i_deg.len());
        for &t in &opts.theta_i_deg {
            let wi = direction(rad(t), rad(opts.phi_i_deg));
            pairs.extend(wo.iter().map(|&o| (wi, o)));
        }
        let f = eval.eval_pairs(common.query(&subject.params), &pairs)?;
        evaluations += f.len() as u64;
        for (a, &t) in opts.theta_i_deg.iter().enumerate() {
            let w = if common.cos { rad(t).cos() } else { 1.0 };
            let values: Vec<f64> = f[a * wo.len()..(a + 1) * wo.len()]
                .iter()
                .map(|c| common.channel.of(c.map(|x| x * w)))
                .collect();
            raw.push((j, t, values));
        }
    }
    let max = raw
        .iter()
        .flat_map(|r| r.2.iter())
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let scale = Scale::from_max(max, common.log, common.decades);
    let radius = |v: f64| {
        if !v.is_finite() {
            0.0
        } else if scale.log {
            scale.unit(v)
        } else {
            v.max(0.0)
        }
    };
    let extent = if scale.log { 1.0 } else { scale.hi };
    let panels = raw
        .into_iter()
        .map(|(subject, t, values)| {
            let points = values
                .iter()
                .zip(&wo)
                .map(|(&v, o)| {
                    let p = *o * radius(v);
                    // Chart axes: (x, z up, y).
                    [p.x, p.z, p.y]
                })
                .collect();
            let mut best = 0;
            for (k, v) in values.iter().enumerate() {
                if *v > values[best] {
                    best = k;
                }
            }
            Surface3dPanel {
                subject,
                theta_i_deg: t,
                phi_i_deg: opts.phi_i_deg,
                points,
                values,
                peak_deg: (theta_o_deg(best / np, nt), phi_o_deg(best % np, np)),
            }
        })
        .collect();
    let what = if common.cos { "f·cosθi" } else { "f" };
    let title = format!(
        "The lobe r(ωo) = {what}·ωo for ωi at φi = {}°: {}",
        fmt_value(opts.phi_i_deg),
        super::series_names(subjects)
    );
    Ok(Surface3dData {
        title,
        n_theta: nt,
        n_phi: np,
        panels,
        scale,
        extent,
        evaluations,
    })
}

/// The options and subjects of a 3d plot, checked before any evaluation.
fn check_request(
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &Surface3dOptions,
) -> Result<()> {
    check_curves(subjects, common, "3d", &opts.theta_i_deg)?;
    check_finite_deg("phi_i_deg", "phi_i", opts.phi_i_deg)?;
    if !(4..=1024).contains(&opts.n_theta) || !(4..=2048).contains(&opts.n_phi) {
        return Err(bad(
            "n_theta",
            format!(
                "{} rings and {} meridians: a 3d wireframe takes 4 to 1024 rings and 4 to 2048 meridians",
                opts.n_theta, opts.n_phi
            ),
        ));
    }
    Ok(())
}

/// Evaluates and draws the wireframes into `path` (.png, .svg or .pdf); returns what it drew.
pub fn plot_surface3d(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &Surface3dOptions,
    path: &Path,
) -> Result<Surface3dData> {
    super::Format::of(path)?;
    let data = surface3d_data(eval, subjects, common, opts)?;
    render(path, common.page(), |root, ink| {
        draw(root, ink, &data, subjects, common)
    })?;
    Ok(data)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &Surface3dData,
    subjects: &[Subject],
    common: &PlotSettings,
) -> Result<()> {
    let mut lines = super::describe_subjects(subjects);
    let unit = if data.scale.log {
        format!(
            "radius: position on a log scale of {} over {} decades below its maximum {}",
            common.quantity(),
            fmt_value(common.decades),
            fmt_value(data.scale.hi)
        )
    } else {
        format!("axes: components of r in 1/sr ({})", common.quantity())
    };
    let mut note =
        format!("{unit}; vertical axis: the normal z; red: ωi, dashed: mirror direction");
    if !common.switches().is_empty() {
        note = format!("{note}; {}", common.switches());
    }
    lines.push(note);
    let body = header_in(common.style, root, &data.title, &lines)?;
    let (w, h) = body.dim_in_pixel();
    let paper = common.style == super::Style::Paper;
    let styles = subject_styles(subjects);
    let entries: Vec<LegendEntry> = subjects
        .iter()
        .zip(&styles)
        .map(|(s, st)| LegendEntry {
            label: s.label.clone(),
            colour: st.colour,
            dash: Dash::Solid,
            marker: Marker::None,
        })
        .collect();
    // A paper figure's legend goes in rows under the charts, which keep the whole width.
    let rows = LegendRows::new(&entries, w as f64 - 4.0);
    let (charts, legend_area) = if paper && subjects.len() > 1 {
        let (a, b) = body.split_vertically(h - rows.height() - 2);
        (a, Some(b))
    } else if subjects.len() > 1 {
        let (a, b) = body.split_horizontally(w - (w / 5).clamp(160, 300));
        (a, Some(b))
    } else {
        (body, None)
    };
    let n_angles = data.panels.len() / subjects.len();
    let areas = charts.split_evenly((1, n_angles));
    for (a, area) in areas.iter().enumerate() {
        draw_angle(area, data, a, &styles, paper)?;
    }
    match legend_area {
        Some(area) if paper => rows.draw(&area, ink, &entries)?,
        Some(area) => legend(&area, ink, &entries)?,
        None => {}
    }
    Ok(())
}

/// The chart of the `a`-th incidence angle: axes, every subject's wireframe at that angle, the
/// light and the mirror direction.
fn draw_angle<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    data: &Surface3dData,
    a: usize,
    styles: &[SeriesStyle],
    paper: bool,
) -> Result<()> {
    let n_angles = data.panels.len() / styles.len();
    let e = data.extent;
    let t = data.panels[a].theta_i_deg;
    let phi_i = data.panels[a].phi_i_deg;
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .caption(format!("θi = {}°", fmt_value(t)), (super::FONT, 16))
        .build_cartesian_3d(-e..e, 0.0..e, -e..e)
        .drawing("a 3d chart")?;
    chart.with_projection(|mut pb| {
        pb.yaw = 0.6;
        pb.pitch = 0.35;
        pb.scale = 0.85;
        pb.into_matrix()
    });
    chart
        .configure_axes()
        .light_grid_style(BLACK.mix(0.12))
        .max_light_lines(4)
        .x_labels(if paper { 3 } else { 10 })
        .y_labels(if paper { 3 } else { 10 })
        .z_labels(if paper { 3 } else { 10 })
        .label_style((super::FONT, 11))
        .x_formatter(&|v| fmt_value(*v))
        .y_formatter(&|v| fmt_value(*v))
        .z_formatter(&|v| fmt_value(*v))
        .draw()
        .drawing("the 3d axes")?;
    // On paper the names of x and y stand above the axes' ends, clear of their tick labels.
    let (out, name_pos) = match paper {
        true => (1.15, Pos::new(HPos::Left, VPos::Bottom)),
        false => (1.1, Pos::new(HPos::Left, VPos::Top)),
    };
    let axis_label = |s: &str, p: (f64, f64, f64)| {
        Text::new(s.to_string(), p, text_style(14, BLACK).pos(name_pos))
    };
    chart
        .draw_series([
            axis_label("x", (e * out, 0.0, 0.0)),
            axis_label("y", (0.0, 0.0, e * out)),
            axis_label("z (normal)", (0.0, e * 1.08, 0.0)),
        ])
        .drawing("the axis names")?;
    for (j, panel) in data
        .panels
        .iter()
        .enumerate()
        .filter(|(k, _)| k % n_angles == a)
    {
        let _ = j;
        let colour = styles[panel.subject].colour;
        let (nt, np) = (data.n_theta, data.n_phi);
        let p = |k: usize, l: usize| {
            let q = panel.points[k * np + l % np];
            (q[0], q[1], q[2])
        };
        // Rings every other θ, meridians every fourth φ: dense enough to read the shape.
        for k in (0..nt).step_by(2) {
            chart
                .draw_series(LineSeries::new((0..=np).map(|l| p(k, l)), colour.mix(0.8)))
                .drawing("a ring")?;
        }
        for l in (0..np).step_by(4) {
            chart
                .draw_series(LineSeries::new((0..nt).map(|k| p(k, l)), colour.mix(0.8)))
                .drawing("a meridian")?;
        }
    }
    let wi = direction(rad(t), rad(phi_i)) * e;
    let mirror = DVec3::new(-wi.x, -wi.y, wi.z);
    chart
        .draw_series(LineSeries::new(
            [(0.0, 0.0, 0.0), (wi.x, wi.z, wi.y)],
            RED.stroke_width(3),
        ))
        .drawing("the light direction")?;
    chart
        .draw_series(DashedLineSeries::new(
            [(0.0, 0.0, 0.0), (mirror.x, mirror.z, mirror.y)],
            8,
            5,
            BLACK.stroke_width(2),
        ))
        .drawing("the mirror direction")?;
    Ok(())
}
