//! The speed-for-accuracy picture of `lobe tradeoff`: one log-log panel per section of the
//! report (evaluation, integration, table resolution), error against cost, every measured variant
//! a marker (circle: f32 on the GPU; triangle: f64 on the CPU), the Pareto front drawn as the
//! staircase that bounds what this device can reach, its points ringed and labelled.
//!
//! The panels do not share axes: their costs are different quantities (ns per evaluation, ms per
//! albedo, ms per table) and so are their errors (relative error of f, absolute error of E).

use super::{fmt_value, header, palette, render, Drawn, FONT};
use crate::integrate::Method;
use crate::tradeoff::{Report, Row, Section};
use anyhow::{bail, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// The front's colour: vermilion, apart from the Okabe–Ito colours of the methods.
const FRONT: RGBColor = RGBColor(200, 30, 30);

/// A value that is not positive (an exact rule on a polynomial integrand can hit 0 exactly)
/// cannot sit on a log axis: it is drawn at the panel's floor, this factor below the smallest
/// positive value, and the note under the title says so.
const ZERO_FLOOR_FACTOR: f64 = 0.25;

/// Default picture size: three panels side by side.
pub const DEFAULT_SIZE: (u32, u32) = (1800, 720);

/// One panel as drawn.
#[derive(Clone, Debug)]
pub struct Panel {
    /// The report section the panel shows.
    pub section: Section,
    /// The cost axis's caption, with its unit.
    pub x_label: String,
    /// The error axis's caption.
    pub y_label: String,
    /// The cost axis's range (logarithmic).
    pub x_range: (f64, f64),
    /// The error axis's range (logarithmic).
    pub y_range: (f64, f64),
    /// Every point: (cost, error as drawn, on the front).
    pub points: Vec<(f64, f64, bool)>,
    /// The front's labels, cheapest first.
    pub front: Vec<String>,
}

/// What [`plot_pareto`] drew.
#[derive(Clone, Debug)]
pub struct ParetoPlot {
    /// The title drawn at the top of the picture: the subject and the device.
    pub title: String,
    /// One panel per section of the report that has rows, in the report's order.
    pub panels: Vec<Panel>,
}

fn is_gpu(r: &Row) -> bool {
    r.backend.starts_with("gpu")
}

/// The short label of a front point: the variant without repeating the section's common words.
fn short_label(r: &Row) -> String {
    r.variant.replace(" nodes", "")
}

/// A colour per integration method (in `Method::ALL` order), per backend elsewhere.
fn colour_of(r: &Row) -> RGBColor {
    match r.section {
        Section::Integration => {
            let k = Method::ALL
                .iter()
                .position(|m| r.variant.starts_with(&format!("{} ", m.name())))
                .unwrap_or(0);
            palette(k)
        }
        _ => {
            if is_gpu(r) {
                palette(0)
            } else {
                palette(2)
            }
        }
    }
}

fn panel_data(report: &Report, section: Section) -> Panel {
    let rows: Vec<&Row> = report.rows_of(section).collect();
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let (mut x_lo, mut x_hi) = (f64::INFINITY, 0.0f64);
    let (mut y_lo, mut y_hi) = (f64::INFINITY, 0.0f64);
    for r in &rows {
        if positive(r.cost) {
            x_lo = x_lo.min(r.cost);
            x_hi = x_hi.max(r.cost);
        }
        if positive(r.max_error) {
            y_lo = y_lo.min(r.max_error);
            y_hi = y_hi.max(r.max_error);
        }
    }
    if !x_lo.is_finite() {
        (x_lo, x_hi) = (1.0, 10.0);
    }
    if !y_lo.is_finite() {
        (y_lo, y_hi) = (1e-16, 1.0);
    }
    let any_zero = rows.iter().any(|r| !positive(r.max_error));
    if any_zero {
        y_lo *= ZERO_FLOOR_FACTOR;
    }
    // Margins of a fraction of a decade; the lower end snaps down to a power of ten, because
    // plotters' log axis labels only from the first power of ten in range onwards (a range
    // inside one decade would otherwise show no tick label at all).
    let pad = |lo: f64, hi: f64| {
        let (l, h) = (lo.log10(), hi.log10());
        let extra = 0.15 * (h - l).max(0.5);
        // Just below the power of ten, so that rounding in powf cannot lift it out of range.
        let bottom = 10f64.powf((l - extra).floor()) * (1.0 - 1e-9);
        (bottom, 10f64.powf(h + extra).max(10.0 * bottom))
    };
    let x_range = pad(x_lo, x_hi);
    let y_range = pad(y_lo, y_hi);
    let floor = if any_zero { y_lo } else { y_range.0 };
    let points = rows
        .iter()
        .map(|r| {
            let e = if positive(r.max_error) {
                r.max_error
            } else {
                floor
            };
            (r.cost.max(x_range.0), e, r.pareto)
        })
        .collect();
    let mut front: Vec<&&Row> = rows.iter().filter(|r| r.pareto).collect();
    front.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let (x_label, y_label) = match section {
        Section::Evaluation => (
            "cost: ns per evaluation (log)",
            "max relative error of f (log)",
        ),
        Section::Integration => (
            "cost: ms per directional albedo (log)",
            "max |E − E_ref| (log)",
        ),
        Section::TableResolution => (
            "cost: ms per table + its E(μ) (log)",
            "max |E − E_ref| (log)",
        ),
    };
    Panel {
        section,
        x_label: x_label.to_string(),
        y_label: y_label.to_string(),
        x_range,
        y_range,
        points,
        front: front.iter().map(|r| short_label(r)).collect(),
    }
}

/// Draws the report's sections as log-log Pareto panels into `path` (.png or .svg by its
/// extension), `size` in pixels; the file appears only when complete.
pub fn plot_pareto(report: &Report, size: (u32, u32), path: &Path) -> Result<ParetoPlot> {
    super::Format::of(path)?;
    let (w, h) = size;
    if !(400..=8000).contains(&w) || !(300..=8000).contains(&h) {
        return Err(crate::input::BadInput::new(
            "size",
            format!(
                "plot size {w}x{h}: width must lie in [400, 8000] and height in [300, 8000] pixels"
            ),
        )
        .into());
    }
    let sections = report.sections();
    if sections.is_empty() {
        bail!("nothing to plot: the trade-off report has no rows");
    }
    let data = ParetoPlot {
        title: format!(
            "Speed vs accuracy: {}{}",
            report.subject,
            report
                .device
                .as_deref()
                .map(|d| format!(" on {d}"))
                .unwrap_or_else(|| " (CPU only)".into())
        ),
        panels: sections.iter().map(|&s| panel_data(report, s)).collect(),
    };
    render(path, size, |root, _ink| draw(root, report, &data))?;
    Ok(data)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    report: &Report,
    data: &ParetoPlot,
) -> Result<()> {
    let mut lines = vec![format!(
        "{}: {}",
        report.params.model().name(),
        report.params.to_text()
    )];
    lines.push(
        "log-log; circles: f32 on the GPU, triangles: f64 on the CPU; red staircase: the Pareto \
         front (no other variant is both cheaper and more accurate), its points ringed and labelled"
            .to_string(),
    );
    if data
        .panels
        .iter()
        .zip(report.sections())
        .any(|(p, s)| report.rows_of(s).any(|r| r.max_error <= 0.0) && !p.points.is_empty())
    {
        lines.push("an error of exactly 0 is drawn on the panel's lowest line".to_string());
    }
    let body = header(root, &data.title, &lines)?;
    let panels = body.split_evenly((1, data.panels.len()));
    let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
    for (area, panel) in panels.iter().zip(&data.panels) {
        draw_panel(root, area, report, panel, &mut placed)?;
    }
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    area: &DrawingArea<DB, Shift>,
    report: &Report,
    panel: &Panel,
    placed: &mut Vec<(i32, i32, i32, i32)>,
) -> Result<()> {
    let rows: Vec<&Row> = report.rows_of(panel.section).collect();
    let (x0, x1) = panel.x_range;
    let (y0, y1) = panel.y_range;
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!(
                "{} (cost in {})",
                panel.section.name(),
                panel.section.cost_unit()
            ),
            (FONT, 17),
        )
        .margin(14)
        .x_label_area_size(48)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .drawing("a Pareto panel")?;
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_labels(12)
        .y_labels(12)
        .x_label_formatter(&|v| fmt_value(*v))
        .y_label_formatter(&|v| fmt_value(*v))
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(BLACK.mix(0.05))
        .draw()
        .drawing("the Pareto axes")?;

    let stairs = front_stairs(panel);
    chart
        .draw_series(LineSeries::new(stairs, FRONT.stroke_width(2)))
        .drawing("the Pareto front")?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], FRONT.stroke_width(2)));

    // Markers: the legend gets one entry per colour group.
    let mut legend_done: Vec<String> = Vec::new();
    for (r, &(c, e, on_front)) in rows.iter().zip(&panel.points) {
        let colour = colour_of(r);
        let style = colour.filled();
        let group = legend_group(r);
        let series = if is_gpu(r) {
            chart
                .draw_series(std::iter::once(Circle::new((c, e), 5, style)))
                .drawing("a variant")?
        } else {
            chart
                .draw_series(std::iter::once(TriangleMarker::new((c, e), 7, style)))
                .drawing("a variant")?
        };
        if !legend_done.contains(&group) {
            let gpu = is_gpu(r) || r.section == Section::Integration;
            series.label(group.clone()).legend(move |(x, y)| {
                if gpu {
                    Circle::new((x + 9, y), 5, colour.filled()).into_dyn()
                } else {
                    TriangleMarker::new((x + 9, y), 7, colour.filled()).into_dyn()
                }
            });
            legend_done.push(group);
        }
        if on_front {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (c, e),
                    9,
                    FRONT.stroke_width(2),
                )))
                .drawing("a front point")?;
        }
    }
    // The lower left (cheap and accurate) is where no variant can be: the legend goes there.
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .label_font((FONT, 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .draw()
        .drawing("the Pareto legend")?;

    let to_px = |p: (f64, f64)| chart.backend_coord(&p);
    draw_front_labels(root, area, &rows, panel, &to_px, placed)?;
    Ok(())
}

/// The front's staircase: from each point along the cost axis to the next point's cost, then
/// down to its error; the region above and to the right of it is what this device can reach.
fn front_stairs(panel: &Panel) -> Vec<(f64, f64)> {
    let mut front: Vec<(f64, f64)> = panel
        .points
        .iter()
        .filter(|p| p.2)
        .map(|p| (p.0, p.1))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut stairs = Vec::new();
    for (k, &(c, e)) in front.iter().enumerate() {
        if k > 0 {
            stairs.push((c, front[k - 1].1));
        }
        stairs.push((c, e));
    }
    if let Some(&(_, e)) = front.last() {
        stairs.push((panel.x_range.1, e));
    }
    if let Some(&(c, _)) = front.first() {
        stairs.insert(0, (c, panel.y_range.1));
    }
    stairs
}

/// The legend entry a variant's marker falls under: its integration rule, or its device.
fn legend_group(r: &Row) -> String {
    match r.section {
        Section::Integration => r.variant.split(' ').next().unwrap_or("").to_string(),
        _ => if is_gpu(r) { "f32 GPU" } else { "f64 CPU" }.to_string(),
    }
}

/// Labels of the front's points, each at the first free spot of a few around its point
/// (`to_px` maps a point to canvas pixels); `placed` holds the boxes of labels drawn so far.
fn draw_front_labels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    area: &DrawingArea<DB, Shift>,
    rows: &[&Row],
    panel: &Panel,
    to_px: &dyn Fn((f64, f64)) -> (i32, i32),
    placed: &mut Vec<(i32, i32, i32, i32)>,
) -> Result<()> {
    let size = 12u32;
    let mut front_rows: Vec<(&Row, (f64, f64))> = rows
        .iter()
        .zip(&panel.points)
        .filter(|(_, p)| p.2)
        .map(|(r, p)| (*r, (p.0, p.1)))
        .collect();
    front_rows.sort_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
    let (ax, ay) = area.get_base_pixel();
    let (aw, ah) = area.dim_in_pixel();
    for (r, (c, e)) in front_rows {
        let label = short_label(r);
        let (px, py) = to_px((c, e));
        let tw = (label.chars().count() as f64 * 0.56 * size as f64).ceil() as i32;
        let th = size as i32 + 2;
        let candidates = [
            (12, -th - 4),
            (12, 6),
            (-tw - 12, -th - 4),
            (-tw - 12, 6),
            (12, -2 * th - 6),
            (12, th + 8),
            (-tw / 2, -th - 14),
            (-tw / 2, 14),
        ];
        let inside = |b: (i32, i32, i32, i32)| {
            b.0 >= ax && b.1 >= ay && b.2 <= ax + aw as i32 && b.3 <= ay + ah as i32
        };
        let overlaps = |b: (i32, i32, i32, i32), placed: &[(i32, i32, i32, i32)]| {
            placed
                .iter()
                .any(|q| b.0 < q.2 && q.0 < b.2 && b.1 < q.3 && q.1 < b.3)
        };
        let boxes: Vec<(i32, i32, i32, i32)> = candidates
            .iter()
            .map(|&(dx, dy)| (px + dx, py + dy, px + dx + tw, py + dy + th))
            .collect();
        let chosen = boxes
            .iter()
            .copied()
            .find(|&b| inside(b) && !overlaps(b, placed))
            .or_else(|| boxes.iter().copied().find(|&b| inside(b)))
            .unwrap_or(boxes[0]);
        placed.push(chosen);
        root.draw(&Text::new(
            label,
            (chosen.0, chosen.1),
            super::text_style(size, RGBColor(120, 20, 20)).pos(Pos::new(HPos::Left, VPos::Top)),
        ))
        .drawing("a front label")?;
    }
    Ok(())
}
