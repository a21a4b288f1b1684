//! A paper panel's heat map drawn cell by cell at sub-pixel precision.

use super::super::{colour_map, Ink, Scale};

/// The cells of an `n` × `n` heat map (`value(row, col)`, row 0 at the top, over [-1, 1]² in
/// chart units mapped by `px`) as rectangles with sub-pixel corners, so that a zoomed picture
/// rasterises them at its own resolution. Each reaches a third of a canvas pixel into its right
/// and lower neighbours, which are drawn over it: no seam of background shows between
/// anti-aliased edges.
pub(super) fn draw_cells(
    ink: &mut Ink,
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    n: usize,
    value: &dyn Fn(usize, usize) -> f64,
    scale: &Scale,
) {
    const OVERLAP_PX: f64 = 1.0 / 3.0;
    let cell = 2.0 / n as f64;
    for row in 0..n {
        for col in 0..n {
            let v = value(row, col);
            if !v.is_finite() {
                continue;
            }
            let (x0, y0) = px((-1.0 + col as f64 * cell, 1.0 - row as f64 * cell));
            let (x1, y1) = px((
                -1.0 + (col + 1) as f64 * cell,
                1.0 - (row + 1) as f64 * cell,
            ));
            let r = (x0, y0, x1 + OVERLAP_PX, y1 + OVERLAP_PX);
            ink.rect(r, colour_map(scale.unit(v)));
        }
    }
}
