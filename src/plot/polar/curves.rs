//! The curves of a polar plot, drawn alike on the screen and the paper layout.

use super::{radius, style_of, PolarData, SeriesStyle};
use crate::plot::{rad, Overlay};

/// The plane point at radius `rho` along the signed angle `s_deg` from the normal.
pub(super) fn at(rho: f64, s_deg: f64) -> (f64, f64) {
    let s = rad(s_deg);
    (rho * s.sin(), rho * s.cos())
}

/// Draws every curve (θi of `theta_i_deg` set its colour or pattern), its line and then markers every `marker_step` pixels along it, through
/// `px` (a plane point to canvas pixels); returns the points drawn.
pub(super) fn draw_curves(
    ink: &mut Overlay,
    data: &PolarData,
    styles: &[SeriesStyle],
    theta_i_deg: &[f64],
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    marker_step: f64,
) -> Vec<(f64, f64)> {
    let angle_index = |t: f64| theta_i_deg.iter().position(|&a| a == t).unwrap_or(0);
    let mut drawn = Vec::new();
    for (s, &peak) in data.series.iter().zip(&data.peaks) {
        let (colour, marker, dash) = style_of(s, styles, angle_index(s.theta_i_deg));
        let pts: Vec<(f64, f64)> = s
            .theta_o_deg
            .iter()
            .zip(&s.value)
            .map(|(&a, &v)| px(at(radius(data, peak, v), a)))
            .collect();
        ink.line(&pts, colour, 2.0, dash, 1.0);
        let phase = (s.subject % 3) as f64 / 3.0;
        ink.markers_along(&pts, marker, colour, marker_step, phase);
        drawn.extend(pts);
    }
    drawn
}
