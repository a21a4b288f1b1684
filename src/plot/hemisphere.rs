//! Hemisphere heat map: f over every ωo for one ωi (or, with `reverse`, over every ωi for one
//! ωo), seen from above the surface, with the horizon as the unit circle.
//!
//! Projections of a direction (θ, φ) to the disc point r·(cosφ, sinφ), both with r(90°) = 1 so
//! that the horizon stays visible:
//! - equal-area (Lambert azimuthal): r = √2·sin(θ/2); equal areas of solid angle cover equal
//!   areas of the picture, so the picture's mean colour is the lobe's mean over the hemisphere;
//! - Nusselt: r = sinθ, the orthographic view from above; areas are weighted by cosθ, so the
//!   picture shows what each direction contributes to an irradiance-type integral.
//!
//! Every panel is one (model, fixed direction); all panels share one colour scale.

use super::{
    bad, check_deg, check_finite_deg, colour_bar, describe_subjects, draw_placed, fmt_value,
    header_in, pixel_map, rad, render, text_style, Dash, Drawn, Overlay, Placed, PlotSettings,
    Scale, Style, Subject, LABEL_GAP,
};
use crate::eval::Evaluator;
pub use crate::grid::angles_deg;
use crate::grid::direction;
use anyhow::{bail, Result};
use glam::DVec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::f64::consts::SQRT_2;
use std::path::Path;

mod cells;
mod marks;
use cells::draw_cells;

/// How a direction (θ, φ) of the hemisphere maps to the disc point r·(cosφ, sinφ); both put the
/// horizon at r = 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// Lambert's azimuthal equal-area projection, r = √2·sin(θ/2): equal solid angles cover equal
    /// areas.
    EqualArea,
    /// The Nusselt (orthographic) projection, r = sinθ: areas are weighted by cosθ.
    Nusselt,
}

impl Projection {
    /// The projection's name on the command line: `equal-area` or `nusselt`.
    pub fn name(self) -> &'static str {
        match self {
            Projection::EqualArea => "equal-area",
            Projection::Nusselt => "nusselt",
        }
    }

    /// The projection called `name`; an unknown name is an error that lists the projections.
    pub fn from_name(name: &str) -> Result<Projection> {
        match name {
            "equal-area" => Ok(Projection::EqualArea),
            "nusselt" => Ok(Projection::Nusselt),
            _ => bail!("unknown projection '{name}'; the projections are: equal-area, nusselt"),
        }
    }

    /// Disc radius of the polar angle θ.
    pub fn radius(self, theta: f64) -> f64 {
        match self {
            Projection::EqualArea => SQRT_2 * (theta / 2.0).sin(),
            Projection::Nusselt => theta.sin(),
        }
    }

    /// θ of the disc radius r ∈ [0, 1].
    pub fn theta(self, r: f64) -> f64 {
        let r = r.clamp(0.0, 1.0);
        match self {
            Projection::EqualArea => 2.0 * (r / SQRT_2).asin(),
            Projection::Nusselt => r.asin(),
        }
    }

    /// The disc point of a direction given by its angles.
    pub fn point(self, theta: f64, phi: f64) -> (f64, f64) {
        let r = self.radius(theta);
        (r * phi.cos(), r * phi.sin())
    }
}

/// Options of the hemisphere heat map: the fixed directions (one panel each), which of ωi and ωo is
/// fixed, the projection and the resolution.
#[derive(Clone, Debug)]
pub struct HemisphereOptions {
    /// θ of the fixed direction in degrees (ωi, or ωo with `reverse`): one panel each.
    pub theta_deg: Vec<f64>,
    /// φ of the fixed direction in degrees.
    pub phi_deg: f64,
    /// Map f over ωi for a fixed ωo instead.
    pub reverse: bool,
    /// How directions map to the disc.
    pub projection: Projection,
    /// Cells across the disc's diameter.
    pub res: usize,
}

impl Default for HemisphereOptions {
    fn default() -> HemisphereOptions {
        HemisphereOptions {
            theta_deg: vec![0.0, 30.0, 60.0, 80.0],
            phi_deg: 0.0,
            reverse: false,
            projection: Projection::EqualArea,
            res: 128,
        }
    }
}

/// One heat map.
#[derive(Clone, Debug)]
pub struct HemispherePanel {
    /// Index into the subjects of the panel's model.
    pub subject: usize,
    /// θ of the fixed direction, in degrees.
    pub theta_deg: f64,
    /// φ of the fixed direction, in degrees.
    pub phi_deg: f64,
    /// res × res cells, row-major from the top (+y) row, left (−x) first; NaN outside the disc.
    pub values: Vec<f64>,
    /// Angles (θ, φ) in degrees of the cell with the largest value.
    pub peak_deg: (f64, f64),
    /// The mirror direction of the fixed one, (θ, φ + 180°) in degrees, φ in [0, 360).
    pub mirror_deg: (f64, f64),
}

/// What a hemisphere heat map shows: one panel per (model, fixed direction), all on one colour
/// scale.
#[derive(Clone, Debug)]
pub struct HemisphereData {
    /// The title drawn at the top of the picture.
    pub title: String,
    /// Cells across each panel's diameter.
    pub res: usize,
    /// The projection the panels were computed in.
    pub projection: Projection,
    /// Whether ωo was fixed and the map is over ωi.
    pub reverse: bool,
    /// The heat maps, subject by subject and, within a subject, in the order of the θ given.
    pub panels: Vec<HemispherePanel>,
    /// The colour scale every panel shares.
    pub scale: Scale,
    /// BRDF evaluations spent: the cells inside the disc, times panels.
    pub evaluations: u64,
}

/// Centre of cell (row, col) in disc coordinates.
pub fn cell_point(res: usize, row: usize, col: usize) -> (f64, f64) {
    let h = 2.0 / res as f64;
    (-1.0 + (col as f64 + 0.5) * h, 1.0 - (row as f64 + 0.5) * h)
}

/// The direction at a disc point, or None outside the horizon.
pub fn cell_direction(projection: Projection, x: f64, y: f64) -> Option<DVec3> {
    let r = x.hypot(y);
    if r > 1.0 {
        return None;
    }
    Some(direction(projection.theta(r), y.atan2(x)))
}

/// Evaluates the heat maps (one `eval_pairs` call per subject), without drawing.
pub fn hemisphere_data(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &HemisphereOptions,
) -> Result<HemisphereData> {
    check_request(subjects, common, opts)?;
    let n = opts.res;
    let cells: Vec<Option<DVec3>> = (0..n * n)
        .map(|k| {
            let (x, y) = cell_point(n, k / n, k % n);
            cell_direction(opts.projection, x, y)
        })
        .collect();
    let inside: Vec<DVec3> = cells.iter().flatten().copied().collect();
    let mut panels = Vec::new();
    let mut evaluations = 0u64;
    for (j, subject) in subjects.iter().enumerate() {
        let mut pairs = Vec::with_capacity(inside.len() * opts.theta_deg.len());
        for &t in &opts.theta_deg {
            let fixed = direction(rad(t), rad(opts.phi_deg));
            pairs.extend(inside.iter().map(
                |&d| {
                    if opts.reverse {
                        (d, fixed)
                    } else {
                        (fixed, d)
                    }
                },
            ));
        }
        let f = eval.eval_pairs(common.query(&subject.params), &pairs)?;
        evaluations += f.len() as u64;
        for (a, &t) in opts.theta_deg.iter().enumerate() {
            let part = &f[a * inside.len()..(a + 1) * inside.len()];
            let mut next = part.iter().zip(&pairs[a * inside.len()..]);
            let values: Vec<f64> = cells
                .iter()
                .map(|c| match c {
                    None => f64::NAN,
                    Some(_) => {
                        let (rgb, (wi, _)) = next.next().expect("one value per inside cell");
                        let w = if common.cos { wi.z } else { 1.0 };
                        common.channel.of(rgb.map(|x| x * w))
                    }
                })
                .collect();
            let peak_deg = peak_direction(&values, &cells);
            panels.push(HemispherePanel {
                subject: j,
                theta_deg: t,
                phi_deg: opts.phi_deg,
                values,
                peak_deg,
                mirror_deg: (t, (opts.phi_deg + 180.0).rem_euclid(360.0)),
            });
        }
    }
    let all: Vec<f64> = panels
        .iter()
        .flat_map(|p| p.values.iter())
        .copied()
        .collect();
    let scale = Scale::fit(&all, common.log, common.decades, 1.0);
    let (fixed, over) = if opts.reverse {
        ("ωo", "ωi")
    } else {
        ("ωi", "ωo")
    };
    let what = if common.cos { "f·cosθi" } else { "f" };
    let title = format!(
        "{what} over every {over} for fixed {fixed} ({} projection): {}",
        opts.projection.name(),
        super::series_names(subjects)
    );
    Ok(HemisphereData {
        title,
        res: n,
        projection: opts.projection,
        reverse: opts.reverse,
        panels,
        scale,
        evaluations,
    })
}

/// The options and subjects of a hemisphere plot, checked before any evaluation.
fn check_request(
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &HemisphereOptions,
) -> Result<()> {
    common.check()?;
    if subjects.is_empty() {
        bail!("a hemisphere plot needs at least one model");
    }
    if opts.theta_deg.is_empty() {
        return Err(bad(
            "theta_deg",
            "give at least one angle theta for the fixed direction".into(),
        ));
    }
    for &t in &opts.theta_deg {
        check_deg("theta_deg", "theta of the fixed direction", t, 0.0, 90.0)?;
    }
    check_finite_deg("phi_deg", "phi of the fixed direction", opts.phi_deg)?;
    if !(8..=2048).contains(&opts.res) {
        return Err(bad(
            "res",
            format!(
                "{} cells across: a hemisphere map takes 8 to 2048",
                opts.res
            ),
        ));
    }
    Ok(())
}

/// (θ, φ) in degrees of the cell with the largest finite value (the first of equals), NaN when
/// none is finite.
fn peak_direction(values: &[f64], cells: &[Option<DVec3>]) -> (f64, f64) {
    let mut best: Option<usize> = None;
    for (k, v) in values.iter().enumerate() {
        if v.is_finite() && best.is_none_or(|b| *v > values[b]) {
            best = Some(k);
        }
    }
    match best.and_then(|k| cells[k]) {
        Some(d) => angles_deg(d),
        None => (f64::NAN, f64::NAN),
    }
}

/// Evaluates and draws the heat maps into `path` (.png, .svg or .pdf); returns what it drew.
pub fn plot_hemisphere(
    eval: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &HemisphereOptions,
    path: &Path,
) -> Result<HemisphereData> {
    super::Format::of(path)?;
    let data = hemisphere_data(eval, subjects, common, opts)?;
    render(path, common.page(), |root, ink| {
        draw(root, ink, &data, subjects, common, opts)
    })?;
    Ok(data)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &HemisphereData,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &HemisphereOptions,
) -> Result<()> {
    let mut lines = describe_subjects(subjects);
    let mut note = format!(
        "seen from above: +x (φ = 0°) right, +y (φ = 90°) up; rings at θ = 30°, 60°, horizon 90°; \
         × mirror direction, ○ the fixed {}",
        if data.reverse { "ωo" } else { "ωi" }
    );
    if !common.switches().is_empty() {
        note = format!("{note}; {}", common.switches());
    }
    lines.push(note);
    let body = header_in(common.style, root, &data.title, &lines)?;
    let (w, _) = body.dim_in_pixel();
    let (maps, bar) = body.split_horizontally(w - COLOUR_BAR_WIDTH);
    let n_angles = opts.theta_deg.len();
    let cols = panel_columns(w - COLOUR_BAR_WIDTH, n_angles);
    // Each subject's panels take `rows_each` rows of `cols` panels.
    let rows_each = n_angles.div_ceil(cols);
    let areas = maps.split_evenly((subjects.len() * rows_each, cols));
    for (k, panel) in data.panels.iter().enumerate() {
        let (subject, angle) = (k / n_angles, k % n_angles);
        let cell = (subject * rows_each + angle / cols) * cols + angle % cols;
        draw_panel(&areas[cell], ink, panel, data, subjects, opts, common.style)?;
    }
    let caption = format!(
        "{}{}",
        common.quantity(),
        if data.scale.log { ", log scale" } else { "" }
    );
    colour_bar(&bar, &data.scale, &caption)?;
    Ok(())
}

/// The width of a hemisphere picture's colour bar with its tick labels and caption, in pixels.
pub const COLOUR_BAR_WIDTH: u32 = 110;

/// The narrowest panel drawn side by side with the next, in pixels: narrower, the azimuth
/// labels of neighbours run into each other, and the panels wrap onto more rows.
pub const MIN_PANEL_WIDTH: u32 = 90;

/// How many of a subject's `n_angles` panels stand in one row of a map area `width` pixels wide:
/// all of them, unless that makes them narrower than [`MIN_PANEL_WIDTH`] (a paper figure).
pub fn panel_columns(width: u32, n_angles: usize) -> usize {
    let fit = (width / MIN_PANEL_WIDTH).max(1) as usize;
    n_angles.min(fit).max(1)
}

/// Draws one heat map of `data` into `area`: the cells, the horizon and the rings at 30° and
/// 60°, azimuth labels, the mirror direction (×) and the fixed direction (○); the caption names
/// the subject when there are several. A paper figure's panel leaves its azimuth labels room
/// beside the disc and draws its cells at sub-pixel precision ([`draw_cells`]).
pub(crate) fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    panel: &HemispherePanel,
    data: &HemisphereData,
    subjects: &[Subject],
    opts: &HemisphereOptions,
    style: Style,
) -> Result<()> {
    let paper = style == Style::Paper;
    let (w, h) = area.dim_in_pixel();
    let caption = panel_caption(panel, data, subjects, w, paper);
    let caption_h = match paper {
        true => 2 + CAPTION_LINE * caption.len() as u32,
        false => 22u32,
    };
    let side = w.min(h.saturating_sub(caption_h)).saturating_sub(8).max(20);
    let left = (w - side) / 2;
    let spare = h.saturating_sub(caption_h + side);
    for (k, line) in caption.into_iter().enumerate() {
        area.draw(&Text::new(
            line,
            (
                w as i32 / 2,
                (spare / 2) as i32 + 2 + (k as u32 * CAPTION_LINE) as i32,
            ),
            text_style(14, BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .drawing("a panel caption")?;
    }
    let square = area.margin(
        (caption_h + spare / 2) as i32,
        (spare - spare / 2) as i32,
        left as i32,
        (w - left - side) as i32,
    );
    // A paper panel's disc leaves room for the azimuth labels above and below it; those beside
    // it are drawn only where the panel has room for them (a narrow panel's disc would otherwise
    // shrink to a third of its width).
    let lim = match paper {
        true => {
            let half = side as f64 / 2.0;
            let label = super::svg_em(12) + 2.0 * LABEL_GAP;
            (half / (half - label).max(1.0)).max(1.16)
        }
        false => 1.16,
    };
    let chart = ChartBuilder::on(&square)
        .build_cartesian_2d(-lim..lim, -lim..lim)
        .drawing("a hemisphere chart")?;
    let pa = chart.plotting_area();
    let n = data.res;
    let value = |row: usize, col: usize| cells::filled_value(&panel.values, n, row, col);
    if paper {
        draw_cells(ink, &pixel_map(pa), n, &value, &data.scale);
    } else {
        cells::draw_runs(pa, n, &value, &data.scale)?;
    }
    let px = pixel_map(pa);
    let (c, edge) = (px((0.0, 0.0)), px((1.0, 0.0)));
    // The cells lie within [-1, 1]²; the mask covers that square and a pixel more.
    let (l, t) = px((-1.0, 1.0));
    let (r, b) = px((1.0, -1.0));
    ink.mask_outside_circle((l - 1.0, t - 1.0, r + 1.0, b + 1.0), c, edge.0 - c.0);
    let circle = |theta_deg: f64| -> Vec<(f64, f64)> {
        (0..=360)
            .map(|k| px(opts.projection.point(rad(theta_deg), rad(k as f64))))
            .collect()
    };
    for t in [30.0, 60.0] {
        ink.line(&circle(t), WHITE, 1.0, Dash::Solid, 0.6);
    }
    ink.line(&circle(90.0), BLACK, 1.0, Dash::Solid, 1.0);
    marks::draw_azimuth_labels(area, pa, paper, (c, edge))?;
    marks::draw_directions(ink, &px, panel, opts, (c, edge));
    Ok(())
}

/// Height of a line of a paper panel's caption, in pixels.
const CAPTION_LINE: u32 = 15;

/// A panel's caption lines: the fixed direction, and the subject when there are several. On the
/// screen one line, θ alone when the full line is wider than the panel; on paper the subject and
/// θ wrapped to the panel's width.
fn panel_caption(
    panel: &HemispherePanel,
    data: &HemisphereData,
    subjects: &[Subject],
    w: u32,
    paper: bool,
) -> Vec<String> {
    let theta = format!("θ = {}°", fmt_value(panel.theta_deg));
    if paper {
        if subjects.len() == 1 {
            return vec![theta];
        }
        let label = &subjects[panel.subject].label;
        let line = format!("{label}, {theta}");
        if super::text_width(&line, super::svg_em(14), false) <= w as f64 {
            return vec![line];
        }
        let mut lines = super::wrap_to_width(label, w as f64, 14, false);
        lines.push(theta);
        return lines;
    }
    let fixed = if data.reverse { "ωo" } else { "ωi" };
    let caption = if subjects.len() > 1 {
        format!(
            "{}, {fixed} = ({}°, {}°)",
            subjects[panel.subject].label,
            fmt_value(panel.theta_deg),
            fmt_value(panel.phi_deg)
        )
    } else {
        format!(
            "{fixed}: θ = {}°, φ = {}°",
            fmt_value(panel.theta_deg),
            fmt_value(panel.phi_deg)
        )
    };
    // A panel too narrow for the caption names θ alone.
    if super::text_width(&caption, super::svg_em(14), false) > w as f64 {
        vec![theta]
    } else {
        vec![caption]
    }
}
