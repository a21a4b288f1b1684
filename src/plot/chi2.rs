//! The sampling test's pictures (`lobe chi2 -o`): a row per view direction ωo with, side by side
//! over the test's (φ, cosθ) cells of equal solid angle, the observed histogram, the expected
//! counts N ∫_cell pdf dω and the residual (o − e)/√e in σ, the pictures Mitsuba 3's `chi2.py`
//! shows (read for what it shows, not copied), as PNG, SVG or PDF like every lobe plot.
//!
//! Observed and expected counts share one linear colour scale per row, so that a sampler that
//! agrees with its pdf gives two pictures that look the same. The residual's scale is diverging
//! and symmetric, ±max(|σ|) over the row's cells, at least ±[`MIN_SIGMA_RANGE`]: a correct
//! sampler's residual is noise within a few σ, and a distortion shows as a region of one colour.
//! Cells expected to hold fewer than [`MIN_EXPECTED`] draws are pooled by the statistic and
//! their σ means little; they are drawn grey, except a cell that holds draws where the pdf
//! integrates to 0 (an infinite residual, the strongest colour). The cell the report names as
//! the largest difference ([`crate::chi2::WorstCell`]) is outlined.

use super::{
    colour_bar_with, fmt_value, header_in, render_bytes, Drawn, Format, Overlay, Scale, Style, FONT,
};
use crate::chi2::stats::MIN_EXPECTED;
use crate::chi2::{DirectionResult, Report};
use anyhow::{Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// The residual scale's smallest half-range, in σ: a correct sampler's residuals stay within
/// about ±4σ over 5000 cells, so its picture is drawn on a scale that shows it as noise.
pub const MIN_SIGMA_RANGE: f64 = 4.0;

/// Canvas width, pixels.
const WIDTH: u32 = 1500;
/// Height of one view direction's row of panels, pixels.
const ROW_HEIGHT: u32 = 300;
/// Room for the title and the lines under it.
const HEADER_HEIGHT: u32 = 100;
/// Width of a colour bar with its ticks and caption.
const BAR_WIDTH: u32 = 100;

/// Pooled cells (expected below [`MIN_EXPECTED`], see the module's notes).
const POOLED_GREY: RGBColor = RGBColor(215, 215, 215);

/// What one row shows: the residual of every cell and where its panel lies.
#[derive(Clone, Debug)]
pub struct Chi2Row {
    /// θo, degrees.
    pub theta_o_deg: f64,
    /// φo, degrees.
    pub phi_o_deg: f64,
    /// (o − e)/√e per cell (the test's cell order: cosθ rows of φ steps); NaN for a pooled
    /// cell, +∞ where draws fell in a cell whose expected count is 0.
    pub residual: Vec<f64>,
    /// The colour scale of the observed and expected counts.
    pub counts: Scale,
    /// The residual scale's half-range, σ.
    pub sigma_range: f64,
    /// The cell the report names as the largest difference, if any.
    pub worst_cell: Option<usize>,
    /// The residual panel's plotting area on the canvas, in canvas pixels: (left, top) and
    /// (right, bottom), φ = 0 at the left, cosθ = 0 at the bottom.
    pub residual_area: ((i32, i32), (i32, i32)),
}

/// What [`chi2_picture`] drew.
#[derive(Clone, Debug)]
pub struct Chi2Plot {
    /// The picture's title.
    pub title: String,
    /// A row per view direction, in the report's order.
    pub rows: Vec<Chi2Row>,
    /// The canvas, pixels (a PNG's size; an SVG's in user units).
    pub size: (u32, u32),
}

impl Chi2Row {
    /// The canvas pixel at the centre of `cell` in the residual panel.
    pub fn residual_pixel(&self, cells: &crate::chi2::Cells, cell: usize) -> (i32, i32) {
        let ((l, t), (r, b)) = self.residual_area;
        let (i_phi, i_cos) = (cell % cells.n_phi, cell / cells.n_phi);
        let x = l as f64 + (i_phi as f64 + 0.5) / cells.n_phi as f64 * (r - l) as f64;
        let y = b as f64 - (i_cos as f64 + 0.5) / cells.n_cos as f64 * (b - t) as f64;
        (x.round() as i32, y.round() as i32)
    }
}

/// The residual of one cell, as the module's notes say.
fn residual(observed: u64, expected: f64) -> f64 {
    let o = observed as f64;
    if expected >= MIN_EXPECTED {
        (o - expected) / expected.sqrt()
    } else if (expected.is_nan() || expected <= 0.0) && observed > 0 {
        f64::INFINITY
    } else {
        f64::NAN
    }
}

/// Blue through white to red for t in [−1, 1] (clamped): the residual's diverging map, its ends
/// those of the common "coolwarm" diverging scheme (Moreland 2009).
pub fn diverging(t: f64) -> RGBColor {
    let t = if t.is_nan() { 0.0 } else { t.clamp(-1.0, 1.0) };
    let (end, s) = if t < 0.0 {
        ((59.0, 76.0, 192.0), -t)
    } else {
        ((180.0, 4.0, 38.0), t)
    };
    let mix = |e: f64| (255.0 + (e - 255.0) * s).round() as u8;
    RGBColor(mix(end.0), mix(end.1), mix(end.2))
}

fn row_data(d: &DirectionResult) -> Chi2Row {
    let residual: Vec<f64> = (d.observed.iter().zip(&d.expected))
        .map(|(&o, &e)| residual(o, e))
        .collect();
    let most = (d.observed.iter().map(|&o| o as f64))
        .chain(d.expected.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let largest = (residual.iter())
        .filter(|r| r.is_finite())
        .fold(0.0f64, |m, r| m.max(r.abs()));
    Chi2Row {
        theta_o_deg: d.theta_o_deg,
        phi_o_deg: d.phi_o_deg,
        residual,
        counts: Scale::from_max(most, false, 0.0),
        sigma_range: largest.max(MIN_SIGMA_RANGE),
        worst_cell: d.worst_cell.as_ref().map(|w| w.cell),
        residual_area: ((0, 0), (0, 0)),
    }
}

/// The picture of `report` as the bytes of a `format` file, with `lines` (the model and its
/// parameters) under the title, and what it drew.
pub fn chi2_picture(
    report: &Report,
    lines: &[String],
    format: Format,
) -> Result<(Vec<u8>, Chi2Plot)> {
    let title = format!(
        "sampling test: observed, expected (N ∫pdf over each cell) and (o − e)/√e, {} draws per ωo",
        report.options.samples
    );
    let mut rows: Vec<Chi2Row> = report.directions.iter().map(row_data).collect();
    let size = (
        WIDTH,
        HEADER_HEIGHT + ROW_HEIGHT * report.directions.len().max(1) as u32,
    );
    let page = Style::Screen.page(size);
    let bytes = render_bytes(format, page, |root, ink| {
        draw(root, ink, report, &mut rows, &title, lines)
    })?;
    Ok((bytes, Chi2Plot { title, rows, size }))
}

/// [`chi2_picture`] written to `path` (its format by its extension), atomically.
pub fn write_chi2(path: &Path, report: &Report, lines: &[String]) -> Result<Chi2Plot> {
    let (bytes, plot) = chi2_picture(report, lines, Format::of(path)?)?;
    crate::output::write_atomic(path, |w| {
        std::io::Write::write_all(w, &bytes).with_context(|| format!("writing {}", path.display()))
    })?;
    Ok(plot)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    _ink: &mut Overlay,
    report: &Report,
    rows: &mut [Chi2Row],
    title: &str,
    lines: &[String],
) -> Result<()> {
    let mut lines = lines.to_vec();
    lines.push(format!(
        "cells over φ (0–360°) × cosθ (0–1) of equal solid angle; grey: pooled (expected < {}); \
         outlined: the largest difference; red: more draws than expected, blue: fewer",
        fmt_value(MIN_EXPECTED)
    ));
    let body = header_in(Style::Screen, root, title, &lines)?;
    let bands = body.split_evenly((rows.len().max(1), 1));
    for ((d, row), band) in report.directions.iter().zip(rows.iter_mut()).zip(&bands) {
        let (w, _) = band.dim_in_pixel();
        let panel = (w - 2 * BAR_WIDTH) / 3;
        let (obs, rest) = band.split_horizontally(panel);
        let (exp, rest) = rest.split_horizontally(panel);
        let (count_bar, rest) = rest.split_horizontally(BAR_WIDTH);
        let (res, res_bar) = rest.split_horizontally(panel);
        let verdict = if d.passed { "pass" } else { "REJECTED" };
        let head = format!(
            "θo {}°, φo {}°",
            fmt_value(d.theta_o_deg),
            fmt_value(d.phi_o_deg)
        );
        let count_colour = |v: f64| colour_of_count(&row.counts, v);
        let observed: Vec<f64> = d.observed.iter().map(|&o| o as f64).collect();
        panel_of(
            &obs,
            d,
            &format!("{head}: observed"),
            &|c| count_colour(observed[c]),
            None,
        )?;
        panel_of(
            &exp,
            d,
            &format!("{head}: expected"),
            &|c| count_colour(d.expected[c]),
            None,
        )?;
        colour_bar_with(&count_bar, &row.counts, "draws per cell", &|t| {
            super::colour_map(t)
        })?;
        let range = row.sigma_range;
        let residual = row.residual.clone();
        let caption = format!(
            "{head}: (o − e)/√e, p = {}, {verdict}",
            if d.p_value.is_nan() {
                "n/a".to_string()
            } else {
                format!("{:.2e}", d.p_value)
            }
        );
        row.residual_area = panel_of(
            &res,
            d,
            &caption,
            &|c| {
                let r = residual[c];
                if r.is_nan() {
                    POOLED_GREY
                } else {
                    diverging(r / range)
                }
            },
            row.worst_cell,
        )?;
        let scale = Scale {
            lo: -range,
            hi: range,
            log: false,
        };
        colour_bar_with(&res_bar, &scale, "residual (σ)", &|t| {
            diverging(2.0 * t - 1.0)
        })?;
    }
    Ok(())
}

fn colour_of_count(scale: &Scale, v: f64) -> RGBColor {
    if v.is_finite() {
        super::colour_map(scale.unit(v))
    } else {
        POOLED_GREY
    }
}

/// One panel: the cells of `d` coloured by `colour`, axes in φ (degrees) and cosθ, `outline`'s
/// cell outlined; returns the plotting area's corners on the canvas.
fn panel_of<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &DirectionResult,
    caption: &str,
    colour: &dyn Fn(usize) -> RGBColor,
    outline: Option<usize>,
) -> Result<((i32, i32), (i32, i32))> {
    let cells = d.cells;
    let mut chart = ChartBuilder::on(area)
        .margin(8)
        .caption(caption, (FONT, 14))
        .x_label_area_size(36)
        .y_label_area_size(44)
        .build_cartesian_2d(0.0..360.0, 0.0..1.0)
        .drawing("a sampling-test panel")?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("φ (degrees)")
        .y_desc("cosθ")
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .x_labels(5)
        .y_labels(3)
        .draw()
        .drawing("the panel's axes")?;
    let pa = chart.plotting_area();
    let dphi = 360.0 / cells.n_phi as f64;
    let dmu = 1.0 / cells.n_cos as f64;
    for i_cos in 0..cells.n_cos {
        let mut i_phi = 0;
        while i_phi < cells.n_phi {
            let c = colour(i_cos * cells.n_phi + i_phi);
            let mut end = i_phi + 1;
            while end < cells.n_phi && colour(i_cos * cells.n_phi + end) == c {
                end += 1;
            }
            pa.draw(&Rectangle::new(
                [
                    (i_phi as f64 * dphi, i_cos as f64 * dmu),
                    (end as f64 * dphi, (i_cos + 1) as f64 * dmu),
                ],
                c.filled(),
            ))
            .drawing("the cells")?;
            i_phi = end;
        }
    }
    if let Some(cell) = outline {
        let ([p0, p1], [m0, m1]) = cells.bounds(cell);
        pa.draw(&Rectangle::new(
            [(p0.to_degrees(), m0), (p1.to_degrees(), m1)],
            BLACK.stroke_width(2),
        ))
        .drawing("the largest difference")?;
    }
    let (xs, ys) = pa.get_pixel_range();
    Ok(((xs.start, ys.start), (xs.end, ys.end)))
}
