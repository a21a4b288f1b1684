//! Keys beside a plot: the legend of overlaid series and the colour bar of a heat map.

use super::*;
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One entry of a hand-drawn legend: a sample of a curve that the plot draws, and its label.
#[derive(Clone, Debug)]
pub struct LegendEntry {
    /// The text drawn beside the line sample.
    pub label: String,
    /// The line's colour.
    pub colour: RGBColor,
    /// The line's pattern.
    pub dash: Dash,
    /// The symbol along the line.
    pub marker: Marker,
}

/// The width in pixels a legend of `entries` needs: the sample, the widest label and margins.
pub(crate) fn legend_width<DB: DrawingBackend>(
    _area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> u32 {
    let widest = entries
        .iter()
        .map(|e| text_width(&e.label, svg_em(LEGEND_TEXT), false))
        .fold(0.0, f64::max);
    widest.ceil() as u32 + LABEL_X + LABEL_MARGIN
}

/// Text size of legend labels, in pixels.
const LEGEND_TEXT: u32 = 14;

/// Where a label starts, from the legend's left edge: after the 40-pixel line sample.
const LABEL_X: u32 = 56;

/// Space kept right of the longest label, in pixels.
const LABEL_MARGIN: u32 = 8;

/// Height of a legend row of one line, and of each further line of a wrapped label, in pixels.
const ROW: i32 = 22;
const LINE: i32 = 16;

/// A legend in its own column: a sample of each entry's curve (colour, pattern and marker) and
/// its label, wrapped to the column's width (never shortened).
pub(crate) fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    entries: &[LegendEntry],
) -> Result<()> {
    let size = LEGEND_TEXT;
    let (w, h) = area.dim_in_pixel();
    let (ox, oy) = area.get_base_pixel();
    // A column narrower than 150 px (a paper figure's) gets a 24-px sample, to leave the labels
    // room.
    let (sample, label_x) = if w < 150 { (24, 40) } else { (40, LABEL_X) };
    let room = w.saturating_sub(label_x + LABEL_MARGIN) as f64;
    let wrapped: Vec<Vec<String>> = entries
        .iter()
        .map(|e| wrap_to_width(&e.label, room, size, false))
        .collect();
    let height = |lines: &Vec<String>| ROW + LINE * (lines.len().max(1) as i32 - 1);
    let total: i32 = wrapped.iter().map(height).sum();
    let mut y = ((h as i32 - total) / 2).max(10);
    for (e, lines) in entries.iter().zip(&wrapped) {
        let mid = y + ROW / 2;
        let (x0, x1, yy) = ((ox + 8) as f64, (ox + 8 + sample) as f64, (oy + mid) as f64);
        ink.line(&[(x0, yy), (x1, yy)], e.colour, 2.0, e.dash, 1.0);
        ink.marker(((x0 + x1) / 2.0, yy), e.marker, e.colour, 4.0);
        for (k, line) in lines.iter().enumerate() {
            area.draw(&Text::new(
                line.clone(),
                (label_x as i32, mid + LINE * k as i32),
                anchored(size, HPos::Left, VPos::Center),
            ))
            .drawing("the legend")?;
        }
        y += height(lines);
    }
    Ok(())
}

/// A vertical colour bar with tick labels and a caption, filling `area`, in the plots' colour map.
pub(crate) fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: &Scale,
    caption: &str,
) -> Result<()> {
    colour_bar_with(area, scale, caption, &colour_map)
}

/// [`colour_bar`] in the colour `colour` gives t ∈ [0, 1] (a diverging map, say).
pub(crate) fn colour_bar_with<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: &Scale,
    caption: &str,
    colour: &dyn Fn(f64) -> RGBColor,
) -> Result<()> {
    let (w, h) = area.dim_in_pixel();
    let (x0, x1) = (10i32, 34i32);
    let (y0, y1) = (30i32, h as i32 - 30);
    let steps = (y1 - y0).max(1);
    for k in 0..steps {
        let t = 1.0 - (k as f64 + 0.5) / steps as f64;
        area.draw(&Rectangle::new(
            [(x0, y0 + k), (x1, y0 + k + 1)],
            colour(t).filled(),
        ))
        .drawing("the colour bar")?;
    }
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))
        .drawing("the colour bar")?;
    for v in scale.ticks() {
        let t = scale.unit(v);
        let y = y1 - (t * (y1 - y0) as f64).round() as i32;
        area.draw(&PathElement::new(vec![(x1, y), (x1 + 5, y)], BLACK))
            .drawing("the colour bar")?;
        area.draw(&Text::new(
            fmt_value(v),
            (x1 + 8, y),
            anchored(13, HPos::Left, VPos::Center),
        ))
        .drawing("the colour bar")?;
    }
    let style = text_style(14, BLACK)
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Bottom));
    area.draw(&Text::new(
        caption.to_string(),
        (w as i32 - 4, (y0 + y1) / 2),
        style,
    ))
    .drawing("the colour bar")?;
    Ok(())
}

/// A legend laid out in rows under a plot (a narrow paper figure has no room beside it): entries
/// left to right, a new row when the next would pass the width.
pub(crate) struct LegendRows {
    /// Each entry's row and left edge in pixels from the area's left.
    places: Vec<(usize, f64)>,
    /// The number of rows.
    rows: usize,
}

/// Text size of a legend in rows, in pixels.
const ROWS_TEXT: u32 = 13;

/// Height of a row of a legend in rows, in pixels.
pub(crate) const ROWS_HEIGHT: u32 = 14;

/// Length of a row legend's line sample, the space after it and the space after a label.
const ROWS_SAMPLE: f64 = 16.0;
const ROWS_SAMPLE_GAP: f64 = 3.0;
const ROWS_ENTRY_GAP: f64 = 9.0;

impl LegendRows {
    /// The rows `entries` take in a width of `width` pixels. A label wider than a row is drawn
    /// on a row of its own.
    pub fn new(entries: &[LegendEntry], width: f64) -> LegendRows {
        let mut places = Vec::new();
        let (mut row, mut x) = (0usize, 0.0);
        for e in entries {
            let w = ROWS_SAMPLE + ROWS_SAMPLE_GAP + text_width(&e.label, svg_em(ROWS_TEXT), false);
            if x > 0.0 && x + w > width {
                row += 1;
                x = 0.0;
            }
            places.push((row, x));
            x += w + ROWS_ENTRY_GAP;
        }
        LegendRows {
            places,
            rows: if entries.is_empty() { 0 } else { row + 1 },
        }
    }

    /// The height in pixels the rows take.
    pub fn height(&self) -> u32 {
        self.rows as u32 * ROWS_HEIGHT
    }

    /// Draws `entries` (those given to [`LegendRows::new`]) centred in `area`, row by row.
    pub fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        ink: &mut Overlay,
        entries: &[LegendEntry],
    ) -> Result<()> {
        let (w, _) = area.dim_in_pixel();
        let (ox, oy) = area.get_base_pixel();
        for row in 0..self.rows {
            let in_row: Vec<(usize, f64)> = self
                .places
                .iter()
                .enumerate()
                .filter(|(_, p)| p.0 == row)
                .map(|(k, p)| (k, p.1))
                .collect();
            let Some(&(last, last_x)) = in_row.last() else {
                continue;
            };
            let used = last_x
                + ROWS_SAMPLE
                + ROWS_SAMPLE_GAP
                + text_width(&entries[last].label, svg_em(ROWS_TEXT), false);
            let left = ((w as f64 - used) / 2.0).max(0.0);
            let mid = (row as u32 * ROWS_HEIGHT + ROWS_HEIGHT / 2) as i32;
            for (k, x) in in_row {
                let e = &entries[k];
                let x0 = ox as f64 + left + x;
                let y = (oy + mid) as f64;
                ink.line(
                    &[(x0, y), (x0 + ROWS_SAMPLE, y)],
                    e.colour,
                    2.0,
                    e.dash,
                    1.0,
                );
                ink.marker((x0 + ROWS_SAMPLE / 2.0, y), e.marker, e.colour, 3.0);
                area.draw(&Text::new(
                    e.label.clone(),
                    (
                        (left + x + ROWS_SAMPLE + ROWS_SAMPLE_GAP).round() as i32,
                        mid,
                    ),
                    anchored(ROWS_TEXT, HPos::Left, VPos::Center),
                ))
                .drawing("the legend")?;
            }
        }
        Ok(())
    }
}
