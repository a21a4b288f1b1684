//! The canvas every plot kind draws on: scales, palette, text, legends, the sub-pixel [`Overlay`]
//! layer, SVG output, its rasterisation and its conversion to PDF.

mod legend;
mod overlay;
mod palette;
mod pdf;
mod raster;
mod scale;
mod svg;
mod text;

pub use legend::*;
pub use overlay::*;
pub use palette::*;
pub use pdf::*;
pub use raster::*;
pub use scale::*;
pub use svg::*;
pub use text::*;

use anyhow::{anyhow, Result};
use plotters::prelude::*;

/// The pieces of the contour line `value = level` of a grid of `nx` × `ny` values (row-major,
/// row k at `ys[k]`, column j at `xs[j]`), by marching squares with linear interpolation along
/// the cell edges: one segment per crossing pair in each square of four neighbouring values.
pub fn contour_segments(
    values: &[f64],
    xs: &[f64],
    ys: &[f64],
    level: f64,
) -> Vec<((f64, f64), (f64, f64))> {
    let (nx, ny) = (xs.len(), ys.len());
    let v = |j: usize, k: usize| values[k * nx + j];
    let mut out = Vec::new();
    for k in 0..ny.saturating_sub(1) {
        for j in 0..nx.saturating_sub(1) {
            // The square's corners, counter-clockwise from the bottom left.
            let corners = [(j, k), (j + 1, k), (j + 1, k + 1), (j, k + 1)];
            let mut cuts = Vec::new();
            for e in 0..4 {
                let (a, b) = (corners[e], corners[(e + 1) % 4]);
                let (va, vb) = (v(a.0, a.1), v(b.0, b.1));
                if !(va.is_finite() && vb.is_finite()) || (va < level) == (vb < level) {
                    continue;
                }
                let t = (level - va) / (vb - va);
                let at = |c: (usize, usize)| (xs[c.0], ys[c.1]);
                let (pa, pb) = (at(a), at(b));
                cuts.push((pa.0 + t * (pb.0 - pa.0), pa.1 + t * (pb.1 - pa.1)));
            }
            for pair in cuts.chunks_exact(2) {
                out.push((pair[0], pair[1]));
            }
        }
    }
    out
}

/// A float version of a 2D chart's coordinate map: chart units to canvas pixels without
/// rounding. `pa` is the chart's plotting area.
pub(crate) fn pixel_map<DB: DrawingBackend>(
    pa: &DrawingArea<
        DB,
        plotters::coord::cartesian::Cartesian2d<
            plotters::coord::types::RangedCoordf64,
            plotters::coord::types::RangedCoordf64,
        >,
    >,
) -> impl Fn((f64, f64)) -> (f64, f64) {
    let (px, py) = pa.get_pixel_range();
    let (xr, yr) = (pa.get_x_range(), pa.get_y_range());
    move |(x, y)| {
        let u = (x - xr.start) / (xr.end - xr.start);
        let v = (y - yr.start) / (yr.end - yr.start);
        (
            px.start as f64 + u * (px.end - px.start) as f64,
            py.end as f64 - v * (py.end - py.start) as f64,
        )
    }
}

/// Maps plotters' errors (whose types depend on the backend) to anyhow with what was drawn.
pub(crate) trait Drawn<T> {
    /// The result, its error turned into "drawing {what}: {error}".
    fn drawing(self, what: &str) -> Result<T>;
}

impl<T, E: std::fmt::Display> Drawn<T> for std::result::Result<T, E> {
    fn drawing(self, what: &str) -> Result<T> {
        self.map_err(|e| anyhow!("drawing {what}: {e}"))
    }
}
