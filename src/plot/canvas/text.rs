//! Text: the embedded font, text styles and the wrapped header of a picture.

use super::*;
use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::sync::OnceLock;

/// The font family name every text style uses.
pub const FONT: &str = "sans-serif";

/// Registers the embedded DejaVu Sans once; plotters' ab_glyph backend knows no other fonts.
pub fn register_fonts() -> Result<()> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
            .and_then(|_| {
                plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold())
            })
            .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
    })
    .clone()
    .map_err(|e| anyhow!(e))
}

/// DejaVu Sans of `size` pixels in `colour`, anchored at the text's top left.
pub(crate) fn text_style(size: u32, colour: RGBColor) -> TextStyle<'static> {
    TextStyle {
        font: (FONT, size).into_font(),
        color: colour.to_backend_color(),
        pos: Pos::new(HPos::Left, VPos::Top),
    }
}

/// Black DejaVu Sans of `size` pixels, anchored at (`h`, `v`) of the text.
pub(crate) fn anchored(size: u32, h: HPos, v: VPos) -> TextStyle<'static> {
    text_style(size, BLACK).pos(Pos::new(h, v))
}

/// Characters of `size`-pixel DejaVu Sans that fit in `width` pixels (its mean advance is about
/// 0.55 em for mixed text).
fn chars_in(width: u32, size: u32) -> usize {
    ((width as f64) / (0.55 * size as f64)).max(10.0) as usize
}

/// Greedy word wrap.
fn wrap(text: &str, max: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for w in text.split(' ') {
        if !cur.is_empty() && cur.chars().count() + 1 + w.chars().count() > max {
            lines.push(std::mem::take(&mut cur));
            cur.push_str("    ");
        }
        if !cur.is_empty() && !cur.ends_with("    ") {
            cur.push(' ');
        }
        cur.push_str(w);
    }
    if !cur.trim().is_empty() {
        lines.push(cur);
    }
    lines
}

/// Draws a bold title and smaller wrapped lines at the top of `root`; returns the area below.
pub(crate) fn header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    lines: &[String],
) -> Result<DrawingArea<DB, Shift>> {
    let (w, _) = root.dim_in_pixel();
    let title_size = 22;
    let small = 14;
    let mut y = 8i32;
    let title_style = TextStyle {
        font: (FONT, title_size, FontStyle::Bold).into_font(),
        color: BLACK.to_backend_color(),
        pos: Pos::new(HPos::Center, VPos::Top),
    };
    for line in wrap(title, chars_in(w - 20, title_size)) {
        root.draw(&Text::new(line, (w as i32 / 2, y), title_style.clone()))
            .drawing("the title")?;
        y += title_size as i32 + 4;
    }
    let style = anchored(small, HPos::Center, VPos::Top);
    for text in lines {
        for line in wrap(text, chars_in(w - 20, small)) {
            root.draw(&Text::new(line, (w as i32 / 2, y), style.clone()))
                .drawing("the title")?;
            y += small as i32 + 3;
        }
    }
    Ok(root.split_vertically(y + 6).1)
}
