//! The image views' cells: for cell (row, col) of a `res` × `res` view, the pair of directions it
//! evaluates and the factor its f is multiplied by (the lit objects' are in [`super::objects`]).

use crate::grid::half_diff_to_pair;
use crate::plot::hemisphere::{cell_direction, cell_point, Projection};
use crate::plot::polar::light_direction;
use glam::DVec3;

/// What an image view's cells depend on besides their place, radians: the polar plot's light
/// (θi) and the slice's φd.
#[derive(Clone, Copy, Debug)]
pub(super) struct Setting {
    pub theta_i: f64,
    pub phi_d: f64,
}

/// What one cell of an image view evaluates: a pair of directions and the factor its f is
/// multiplied by, or None for a cell the view leaves empty (NaN).
pub(super) type Cell =
    fn(res: usize, row: usize, col: usize, at: Setting) -> Option<(DVec3, DVec3, f64)>;

/// The slice's φd when a request names none: 90°, where both directions of every cell stay
/// above the horizon (where MERL slices are shown).
pub(super) const DEFAULT_PHI_D_DEG: f64 = 90.0;

/// The hemisphere of ωo on the equal-area disc, rows from the top (+y), for the polar plot's
/// light.
pub(super) fn hemisphere_cell(
    res: usize,
    row: usize,
    col: usize,
    at: Setting,
) -> Option<(DVec3, DVec3, f64)> {
    let (x, y) = cell_point(res, row, col);
    let wo = cell_direction(Projection::EqualArea, x, y)?;
    Some((light_direction(at.theta_i), wo, 1.0))
}

/// The θh × θd slice at φh = 0 and the request's φd, θh along the columns and θd down the rows,
/// cell-centred over [0°, 90°); a cell whose ωi or ωo falls below the horizon is empty (at
/// φd = 90° none does: both stay at cos θd cos θh above it).
pub(super) fn slice_cell(
    res: usize,
    row: usize,
    col: usize,
    at: Setting,
) -> Option<(DVec3, DVec3, f64)> {
    let step = std::f64::consts::FRAC_PI_2 / res as f64;
    let theta_h = (col as f64 + 0.5) * step;
    let theta_d = (row as f64 + 0.5) * step;
    let (wi, wo) = half_diff_to_pair(theta_h, 0.0, theta_d, at.phi_d);
    (wi.z > 0.0 && wo.z > 0.0).then_some((wi, wo, 1.0))
}

/// The 3D lobe's mesh: ωo at θo = (row + ½)·90°/res down the rows and φo = col·360°/res along
/// the columns (the page closes each ring), for the polar plot's light.
pub(super) fn lobe_cell(
    res: usize,
    row: usize,
    col: usize,
    at: Setting,
) -> Option<(DVec3, DVec3, f64)> {
    let theta_o = (row as f64 + 0.5) * std::f64::consts::FRAC_PI_2 / res as f64;
    let phi_o = col as f64 * std::f64::consts::TAU / res as f64;
    Some((
        light_direction(at.theta_i),
        crate::grid::direction(theta_o, phi_o),
        1.0,
    ))
}
