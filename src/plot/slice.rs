//! The θh × θd image in Rusinkiewicz's half/difference coordinates (Rusinkiewicz 1998, "A New
//! Change of Variables for Efficient BRDF Representation"), at one φd, as MERL data are shown.
//!
//! From (θh, φh, θd, φd): h = (sinθh cosφh, sinθh sinφh, cosθh) and d = (sinθd cosφd,
//! sinθd sinφd, cosθd) in the frame where h is the pole, so ωi = Rz(φh)·Ry(θh)·d and ωo is ωi
//! reflected about h, ωo = 2(ωi·h)h − ωi. The image takes φh = 0 (isotropic models do not depend
//! on it). At φd = 90° both directions stay above the horizon for every θh, θd < 90°, which is
//! why MERL slices are usually shown there; at other φd the part below the horizon is f = 0 and
//! drawn grey. The colour is always logarithmic: a specular peak spans decades.

use super::{
    anchored, bad, check_finite_deg, colour_bar, colour_map, fmt_value, header_in, pixel_map, rad,
    render, wrap_to_width, Drawn, Overlay, PlotSettings, Scale, Subject,
};
use crate::eval::Evaluator;
use anyhow::{bail, Result};
use glam::DVec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use std::path::Path;

/// Options of the θh × θd slice: its resolution and its φd.
#[derive(Clone, Debug)]
pub struct SliceOptions {
    /// Cells along θh and along θd.
    pub res: usize,
    /// φd in degrees.
    pub phi_d_deg: f64,
}

impl Default for SliceOptions {
    fn default() -> SliceOptions {
        SliceOptions {
            res: 90,
            phi_d_deg: 90.0,
        }
    }
}

/// One slice image.
#[derive(Clone, Debug)]
pub struct SlicePanel {
    /// Index into the subjects of the panel's model.
    pub subject: usize,
    /// res × res values, row k = θd cell k (θd growing), column l = θh cell l (θh growing);
    /// cell-centred angles (k + ½)·90°/res. Zero where a direction is below the horizon.
    pub values: Vec<f64>,
}

/// What a θh × θd slice plot shows: one panel per model, all on one logarithmic colour scale.
#[derive(Clone, Debug)]
pub struct SliceData {
    /// The title drawn at the top of the picture.
    pub title: String,
    /// The largest value (the colour saturates at `scale.hi`, the COLOUR_QUANTILE of them).
    pub max: f64,
    /// Cells along θh and along θd.
    pub res: usize,
    /// φd of every panel, in degrees.
    pub phi_d_deg: f64,
    /// The images, one per subject in the subjects' order.
    pub panels: Vec<SlicePanel>,
    /// The logarithmic colour scale every panel shares.
    pub scale: Scale,
    /// BRDF evaluations spent: res² per panel.
    pub evaluations: u64,
}

impl SliceData {
    /// θ in degrees of cell k (the same for θh and θd).
    pub fn theta_deg(&self, k: usize) -> f64 {
        (k as f64 + 0.5) * 90.0 / self.res as f64
    }
}

pub use crate::grid::half_diff_to_pair;

/// Evaluates the slices (one `eval_pairs` call per subject, φh = 0), without drawing.
pub fn slice_data(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &SliceOptions,
) -> Result<SliceData> {
    common.check()?;
    if subjects.is_empty() {
        bail!("a slice plot needs at least one model");
    }
    if !(4..=2048).contains(&opts.res) {
        return Err(bad(
            "res",
            format!("{} cells per axis: a slice takes 4 to 2048", opts.res),
        ));
    }
    check_finite_deg("phi_d_deg", "phi_d", opts.phi_d_deg)?;
    let n = opts.res;
    let cell = |k: usize| rad((k as f64 + 0.5) * 90.0 / n as f64);
    let pairs: Vec<(DVec3, DVec3)> = (0..n * n)
        .map(|k| half_diff_to_pair(cell(k % n), 0.0, cell(k / n), rad(opts.phi_d_deg)))
        .collect();
    let mut panels = Vec::new();
    let mut evaluations = 0;
    for (j, subject) in subjects.iter().enumerate() {
        let f = eval.eval_pairs(common.query(&subject.params), &pairs)?;
        evaluations += f.len() as u64;
        let values = f
            .iter()
            .zip(&pairs)
            .map(|(rgb, (wi, _))| {
                let w = if common.cos { wi.z.max(0.0) } else { 1.0 };
                common.channel.of(rgb.map(|x| x * w))
            })
            .collect();
        panels.push(SlicePanel { subject: j, values });
    }
    let all: Vec<f64> = panels
        .iter()
        .flat_map(|p| p.values.iter())
        .copied()
        .collect();
    let scale = Scale::fit(&all, true, common.decades, COLOUR_QUANTILE);
    let max = all
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let what = if common.cos { "f·cosθi" } else { "f" };
    let title = format!(
        "{what} over θh × θd (Rusinkiewicz), φd = {}°: {}",
        fmt_value(opts.phi_d_deg),
        super::series_names(subjects)
    );
    Ok(SliceData {
        title,
        max,
        res: n,
        phi_d_deg: opts.phi_d_deg,
        panels,
        scale,
        evaluations,
    })
}

/// Evaluates and draws the slices into `path` (.png, .svg or .pdf); returns what it drew.
pub fn plot_slice(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &SliceOptions,
    path: &Path,
) -> Result<SliceData> {
    super::Format::of(path)?;
    let data = slice_data(eval, subjects, common, opts)?;
    render(path, common.page(), |root, ink| {
        draw(root, ink, &data, subjects, common)
    })?;
    Ok(data)
}

/// The colour scale's top: the 99th percentile of the values. Near θd = 90° a microfacet
/// model's 1/(c_i c_o) grows without bound (10⁵ for gold at θd = 89.5°), and a scale topped by
/// that one row would leave the rest of the image at the bottom colour.
pub const COLOUR_QUANTILE: f64 = 0.99;

/// Grey for cells with f = 0 (a direction below the horizon): not part of the colour scale.
const ZERO_GREY: RGBColor = RGBColor(215, 215, 215);

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &SliceData,
    subjects: &[Subject],
    common: &PlotSettings,
) -> Result<()> {
    let mut lines = super::describe_subjects(subjects);
    let mut note = format!(
        "φh = 0°; grey: f = 0 (a direction below the horizon); colour saturates above {} (99th \
         percentile; max {})",
        fmt_value(data.scale.hi),
        fmt_value(data.max)
    );
    if !common.switches().is_empty() {
        note = format!("{note}; {}", common.switches());
    }
    lines.push(note);
    let body = header_in(common.style, root, &data.title, &lines)?;
    let (w, _) = body.dim_in_pixel();
    let (maps, bar) = body.split_horizontally(w - 110);
    if common.style == super::Style::Paper {
        // As many panels side by side as are at least PAPER_PANEL_WIDTH wide.
        let cols = ((w - 110) / PAPER_PANEL_WIDTH).max(1) as usize;
        let cols = cols.min(data.panels.len());
        let areas = maps.split_evenly((data.panels.len().div_ceil(cols), cols));
        for (panel, area) in data.panels.iter().zip(areas.iter()) {
            paper_panel(area, ink, panel, data, subjects)?;
        }
        let caption = format!("{}, log scale", common.quantity());
        return colour_bar(&bar, &data.scale, &caption);
    }
    let areas = maps.split_evenly((1, data.panels.len()));
    let n = data.res;
    let step = 90.0 / n as f64;
    for (panel, area) in data.panels.iter().zip(areas.iter()) {
        let mut builder = ChartBuilder::on(area);
        builder
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(54);
        if data.panels.len() > 1 {
            builder.caption(&subjects[panel.subject].label, (super::FONT, 15));
        }
        let mut chart = builder
            .build_cartesian_2d(0.0..90.0, 0.0..90.0)
            .drawing("a slice chart")?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("θh (degrees)")
            .y_desc("θd (degrees)")
            .label_style((super::FONT, 13))
            .axis_desc_style((super::FONT, 14))
            .x_labels(7)
            .y_labels(7)
            .x_label_formatter(&|v| format!("{}°", fmt_value(*v)))
            .y_label_formatter(&|v| format!("{}°", fmt_value(*v)))
            .draw()
            .drawing("the slice axes")?;
        let pa = chart.plotting_area();
        for row in 0..n {
            let mut col = 0;
            while col < n {
                let colour_at = |c: usize| {
                    let v = panel.values[row * n + c];
                    if v > 0.0 && v.is_finite() {
                        colour_map(data.scale.unit(v))
                    } else {
                        ZERO_GREY
                    }
                };
                let colour = colour_at(col);
                let mut end = col + 1;
                while end < n && colour_at(end) == colour {
                    end += 1;
                }
                pa.draw(&Rectangle::new(
                    [
                        (col as f64 * step, row as f64 * step),
                        (end as f64 * step, (row + 1) as f64 * step),
                    ],
                    colour.filled(),
                ))
                .drawing("the slice")?;
                col = end;
            }
        }
    }
    colour_bar(
        &bar,
        &data.scale,
        &format!("{}, log scale", common.quantity()),
    )?;
    Ok(())
}

/// The narrowest slice panel of a paper figure, in canvas pixels: axis labels, a readable image
/// and the panel's caption wrapped onto at most two lines.
const PAPER_PANEL_WIDTH: u32 = 90;

/// Height of a line of a paper panel's caption, in canvas pixels.
const PAPER_CAPTION_LINE: i32 = 14;

/// One slice of a paper figure in `area`: the model's name wrapped above it when there are
/// several, short axis names (the labels carry the degrees), four labels an axis, and the cells
/// drawn at sub-pixel precision so that the zoomed picture rasterises them at its own resolution.
fn paper_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    panel: &SlicePanel,
    data: &SliceData,
    subjects: &[Subject],
) -> Result<()> {
    let (w, _) = area.dim_in_pixel();
    let lines = match data.panels.len() {
        1 => Vec::new(),
        _ => wrap_to_width(&subjects[panel.subject].label, w as f64 - 4.0, 13, false),
    };
    for (k, line) in lines.iter().enumerate() {
        area.draw(&Text::new(
            line.clone(),
            (w as i32 / 2, 2 + PAPER_CAPTION_LINE * k as i32),
            anchored(13, HPos::Center, VPos::Top),
        ))
        .drawing("a slice caption")?;
    }
    let top = 4 + PAPER_CAPTION_LINE * lines.len() as i32;
    let inner = area.margin(top, 0, 0, 0);
    let mut chart = ChartBuilder::on(&inner)
        .margin(4)
        .margin_right(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(0.0..90.0, 0.0..90.0)
        .drawing("a slice chart")?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("θh")
        .y_desc("θd")
        .label_style((super::FONT, 12))
        .axis_desc_style((super::FONT, 13))
        .x_labels(4)
        .y_labels(4)
        .x_label_formatter(&|v| format!("{}°", fmt_value(*v)))
        // The corner's 0° is the θh axis's: the θd axis's would touch it.
        .y_label_formatter(&|v| {
            if *v == 0.0 {
                String::new()
            } else {
                format!("{}°", fmt_value(*v))
            }
        })
        .draw()
        .drawing("the slice axes")?;
    let px = pixel_map(chart.plotting_area());
    // Each cell reaches a third of a canvas pixel into its right and upper neighbours, which are
    // drawn after it: no background shows between anti-aliased edges.
    const OVERLAP_PX: f64 = 1.0 / 3.0;
    let n = data.res;
    let step = 90.0 / n as f64;
    for row in 0..n {
        for col in 0..n {
            let v = panel.values[row * n + col];
            let colour = if v > 0.0 && v.is_finite() {
                colour_map(data.scale.unit(v))
            } else {
                ZERO_GREY
            };
            let (x0, y0) = px((col as f64 * step, row as f64 * step));
            let (x1, y1) = px(((col + 1) as f64 * step, (row + 1) as f64 * step));
            let right = if col + 1 < n { OVERLAP_PX } else { 0.0 };
            let up = if row + 1 < n { OVERLAP_PX } else { 0.0 };
            ink.rect((x0, y0, x1 + right, y1 - up), colour);
        }
    }
    Ok(())
}
