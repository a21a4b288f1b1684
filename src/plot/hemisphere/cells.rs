//! A panel's heat map: on paper drawn cell by cell at sub-pixel precision, on a screen in runs
//! of one colour.

use super::super::{colour_map, Drawn, Overlay, Scale};
use anyhow::Result;
use plotters::coord::cartesian::Cartesian2d;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// The cells of an `n` × `n` heat map (`value(row, col)`, row 0 at the top, over [-1, 1]² in
/// chart units mapped by `px`) as rectangles with sub-pixel corners, so that a zoomed picture
/// rasterises them at its own resolution. Each reaches a third of a canvas pixel into its right
/// and lower neighbours, which are drawn over it: no seam of background shows between
/// anti-aliased edges.
pub(super) fn draw_cells(
    ink: &mut Overlay,
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

/// The value of cell (`row`, `col`) of an `n` × `n` map; a cell outside the disc takes the value
/// of a neighbour inside it, so that the cells cover the whole disc: the white mask drawn over
/// them then gives the rim its round, anti-aliased edge.
pub(super) fn filled_value(values: &[f64], n: usize, row: usize, col: usize) -> f64 {
    let v = values[row * n + col];
    if v.is_finite() {
        return v;
    }
    let (r, c) = (row as i64, col as i64);
    [
        (0, 1),
        (0, -1),
        (1, 0),
        (-1, 0),
        (1, 1),
        (1, -1),
        (-1, 1),
        (-1, -1),
    ]
    .iter()
    .map(|(dr, dc)| (r + dr, c + dc))
    .filter(|&(a, b)| a >= 0 && b >= 0 && a < n as i64 && b < n as i64)
    .map(|(a, b)| values[a as usize * n + b as usize])
    .find(|v| v.is_finite())
    .unwrap_or(f64::NAN)
}

/// A screen panel's heat map on the chart `pa` (chart units over [-1, 1]²): runs of cells of
/// one colour along a row are drawn as one rectangle (smaller SVG files).
pub(super) fn draw_runs<DB: DrawingBackend>(
    pa: &DrawingArea<DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    n: usize,
    value: &dyn Fn(usize, usize) -> f64,
    scale: &Scale,
) -> Result<()> {
    let cell = 2.0 / n as f64;
    for row in 0..n {
        let mut col = 0;
        while col < n {
            let v = value(row, col);
            if !v.is_finite() {
                col += 1;
                continue;
            }
            let colour = colour_map(scale.unit(v));
            let mut end = col + 1;
            while end < n {
                let u = value(row, end);
                if !u.is_finite() || colour_map(scale.unit(u)) != colour {
                    break;
                }
                end += 1;
            }
            let (x0, y0) = (-1.0 + col as f64 * cell, 1.0 - row as f64 * cell);
            let (x1, y1) = (-1.0 + end as f64 * cell, 1.0 - (row + 1) as f64 * cell);
            pa.draw(&Rectangle::new([(x0, y0), (x1, y1)], colour.filled()))
                .drawing("the heat map")?;
            col = end;
        }
    }
    Ok(())
}
