//! The screen style's half disc: its size in the plot area, the rings and spokes, the axis
//! caption, the incidence lines and the arrows of delta lobes.

use super::*;
use plotters::coord::types::RangedCoordf64;

/// The chart the half disc is drawn on, in plane units.
type Chart<DB> =
    DrawingArea<DB, plotters::coord::cartesian::Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Height of one axis caption line, in canvas pixels (14 px text plus 3 px leading).
const CAPTION_LINE_PX: f64 = (14 + 3) as f64;

/// Where the half disc sits: the chart's ranges in plane units (the horizon circle has radius 1).
pub(super) struct Frame {
    px_per_unit: f64,
    pub(super) x_half: f64,
    pub(super) y_bottom: f64,
    pub(super) y_top: f64,
    /// Where the axis caption's first line starts.
    caption_top: f64,
}

impl Frame {
    /// The largest equal-scale frame of `pw` x `ph` pixels that holds the half disc, its labels
    /// and `caption_lines` lines of axis caption.
    pub(super) fn fit(pw: f64, ph: f64, caption_lines: usize) -> Frame {
        let (half_w, y_hi) = (1.12, 1.09);
        // Below the diameter: the radial tick labels (from y = -0.02, 16 px) and the caption's
        // lines, or 0.14 chart units where that is more (a screen canvas, whose one caption line
        // fits there).
        let labels_px = 16.0 + caption_lines as f64 * CAPTION_LINE_PX;
        let below_px = |ppu: f64| (0.14 * ppu).max(0.02 * ppu + labels_px);
        let mut px_per_unit = (pw / (2.0 * half_w)).min(ph / (y_hi + 0.14));
        if below_px(px_per_unit) > 0.14 * px_per_unit {
            px_per_unit = (pw / (2.0 * half_w)).min((ph - labels_px).max(1.0) / (y_hi + 0.02));
        }
        let y_lo = -below_px(px_per_unit) / px_per_unit;
        let caption_top = (-0.08f64).min(-0.02 - 16.0 / px_per_unit);
        let x_half = pw / px_per_unit / 2.0;
        // Spare height goes equally above and below the half disc.
        let spare = ph / px_per_unit - (y_hi - y_lo);
        Frame {
            px_per_unit,
            x_half,
            y_bottom: y_lo - spare / 2.0,
            y_top: y_hi + spare / 2.0,
            caption_top,
        }
    }

    /// The axis caption's lines under the diameter.
    pub(super) fn draw_caption<DB: DrawingBackend>(
        &self,
        pa: &Chart<DB>,
        caption_lines: Vec<String>,
    ) -> Result<()> {
        let line_step = CAPTION_LINE_PX / self.px_per_unit;
        for (k, line) in caption_lines.into_iter().enumerate() {
            pa.draw(&Text::new(
                line,
                (0.0, self.caption_top - k as f64 * line_step),
                text_style(14, BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
            ))
            .drawing("the axis caption")?;
        }
        Ok(())
    }
}

/// Rings at the scale's ticks, the horizon circle, spokes every 15° and the diameter, through
/// `px` (a plane point to canvas pixels).
pub(super) fn draw_frame(ink: &mut Overlay, px: &dyn Fn((f64, f64)) -> (f64, f64), scale: &Scale) {
    let arc = |rho: f64| -> Vec<(f64, f64)> {
        (0..=360)
            .map(|k| px(at(rho, -90.0 + k as f64 / 2.0)))
            .collect()
    };
    let grid = RGBColor(200, 200, 200);
    for &v in &scale.ticks() {
        let rho = scale.unit(v);
        if rho > 0.0 {
            ink.line(&arc(rho), grid, 1.0, Dash::Solid, 1.0);
        }
    }
    ink.line(&arc(1.0), BLACK, 1.0, Dash::Solid, 1.0);
    for k in -6..=6 {
        let spoke = [px((0.0, 0.0)), px(at(1.0, 15.0 * k as f64))];
        ink.line(&spoke, grid, 1.0, Dash::Solid, 1.0);
    }
    ink.line(
        &[px((-1.0, 0.0)), px((1.0, 0.0))],
        BLACK,
        1.0,
        Dash::Solid,
        1.0,
    );
}

/// [`draw_frame`] with its labels: each ring's value under it and each spoke's angle beyond the
/// horizon, in the plane's coordinates of `pa`.
pub(super) fn draw_rings_and_spokes<DB: DrawingBackend>(
    pa: &Chart<DB>,
    ink: &mut Overlay,
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    scale: &Scale,
) -> Result<()> {
    draw_frame(ink, px, scale);
    for &v in &scale.ticks() {
        let rho = scale.unit(v);
        if rho <= 0.0 {
            continue;
        }
        pa.draw(&Text::new(
            fmt_value(v),
            (rho, -0.02),
            text_style(12, BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .drawing("a ring label")?;
    }
    for k in -6..=6 {
        pa.draw(&Text::new(
            format!("{}°", k * 15),
            at(1.05, 15.0 * k as f64),
            text_style(12, BLACK).pos(Pos::new(HPos::Center, VPos::Center)),
        ))
        .drawing("a spoke label")?;
    }
    Ok(())
}

/// The position of θi among the angles drawn, which picks its colour or dash.
fn angle_index(theta_i_deg: &[f64], t: f64) -> usize {
    theta_i_deg.iter().position(|&a| a == t).unwrap_or(0)
}

/// Incidence directions: thin lines towards the light, labelled with θi.
pub(super) fn draw_incidence<DB: DrawingBackend>(
    pa: &Chart<DB>,
    ink: &mut Overlay,
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    subjects: &[Subject],
    theta_i_deg: &[f64],
) -> Result<()> {
    for &t in theta_i_deg {
        let (colour, dash) = if subjects.len() == 1 {
            (palette(angle_index(theta_i_deg, t)), Dash::Solid)
        } else {
            (RGBColor(90, 90, 90), Dash::nth(angle_index(theta_i_deg, t)))
        };
        ink.line(&[px((0.0, 0.0)), px(at(1.0, -t))], colour, 1.0, dash, 0.6);
        pa.draw(&Text::new(
            format!("ωi {}°", fmt_value(t)),
            at(0.93, -t - 2.5),
            text_style(12, colour).pos(Pos::new(HPos::Center, VPos::Center)),
        ))
        .drawing("an incidence label")?;
    }
    Ok(())
}

/// Delta lobes: an arrow to the horizon circle along the mirror direction, labelled with the
/// spike's albedo (it has no finite value to plot).
pub(super) fn draw_deltas<DB: DrawingBackend>(
    pa: &Chart<DB>,
    ink: &mut Overlay,
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    (data, subjects, styles): (&PolarData, &[Subject], &[SeriesStyle]),
    common: &PlotSettings,
    theta_i_deg: &[f64],
) -> Result<()> {
    for d in &data.deltas {
        let colour = if subjects.len() == 1 {
            palette(angle_index(theta_i_deg, d.theta_i_deg))
        } else {
            styles[d.subject].colour
        };
        let tip = at(1.0, d.mirror_deg);
        let back = |da: f64, r: f64| px(at(r, d.mirror_deg + da));
        ink.line(&[px((0.0, 0.0)), px(tip)], colour, 3.0, Dash::Solid, 1.0);
        ink.line(
            &[back(-2.5, 0.93), px(tip), back(2.5, 0.93)],
            colour,
            3.0,
            Dash::Solid,
            1.0,
        );
        let a = d.albedo;
        let label = format!(
            "δ ρ={} ({}, {}, {})",
            fmt_value(common.channel.of(a)),
            fmt_value(a[0]),
            fmt_value(a[1]),
            fmt_value(a[2])
        );
        pa.draw(&Text::new(
            label,
            at(1.0, d.mirror_deg + 4.0),
            text_style(12, colour).pos(Pos::new(HPos::Left, VPos::Bottom)),
        ))
        .drawing("a delta label")?;
    }
    Ok(())
}
