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

/// The em size plotters' SVG backend writes for a text style of `size` pixels: it divides by
/// 1.24 (plotters-svg's `font-size`), and resvg draws that em size.
pub fn svg_em(size: u32) -> f64 {
    size as f64 / 1.24
}

/// The advance width in pixels of `text` in DejaVu Sans (bold or regular) at an em size of `em`
/// pixels, with the font's kerning: what resvg draws, measured by ab_glyph from the same
/// embedded font.
pub fn text_width(text: &str, em: f64, bold: bool) -> f64 {
    use ab_glyph::{Font, FontRef};
    static FACES: OnceLock<Option<(FontRef<'static>, FontRef<'static>)>> = OnceLock::new();
    let faces = FACES.get_or_init(|| {
        let regular = FontRef::try_from_slice(dejavu::sans::regular()).ok()?;
        let bold = FontRef::try_from_slice(dejavu::sans::bold()).ok()?;
        Some((regular, bold))
    });
    // register_fonts has parsed the same bytes before any text is drawn; if they did not parse,
    // an estimate of 0.6 em per character stands in.
    let Some((regular, heavy)) = faces else {
        return text.chars().count() as f64 * 0.6 * em;
    };
    let face = if bold { heavy } else { regular };
    let units = face.units_per_em().unwrap_or(2048.0) as f64;
    let mut width = 0.0;
    let mut last = None;
    for c in text.chars() {
        let id = face.glyph_id(c);
        if let Some(prev) = last {
            width += face.kern_unscaled(prev, id) as f64;
        }
        width += face.h_advance_unscaled(id) as f64;
        last = Some(id);
    }
    width * em / units
}

/// `text` broken into lines at most `width` pixels wide at plotters text size `size`: between
/// words, then after commas inside a word too wide, then between characters. Nothing is
/// dropped: the lines joined give back every character of `text`.
pub fn wrap_to_width(text: &str, width: f64, size: u32, bold: bool) -> Vec<String> {
    let em = svg_em(size);
    let fits = |t: &str| text_width(t, em, bold) <= width;
    // Pieces with whether the next one joins without a space (the cuts after commas).
    let mut pieces: Vec<(String, bool)> = Vec::new();
    for word in text.split(' ') {
        if fits(word) {
            pieces.push((word.to_string(), false));
            continue;
        }
        // A word too wide: split after commas, then by characters.
        let mut cur = String::new();
        for c in word.chars() {
            cur.push(c);
            if c == ',' {
                pieces.push((std::mem::take(&mut cur), true));
            }
        }
        match pieces.last_mut() {
            Some(last) if cur.is_empty() => last.1 = false,
            _ => pieces.push((cur, false)),
        }
    }
    let mut lines: Vec<String> = Vec::new();
    let mut glue = false;
    for (piece, glue_next) in pieces {
        let sep = if glue { "" } else { " " };
        glue = glue_next;
        if let Some(last) = lines.last_mut() {
            let joined = format!("{last}{sep}{piece}");
            if fits(&joined) {
                *last = joined;
                continue;
            }
        }
        if fits(&piece) {
            lines.push(piece);
        } else {
            lines.extend(break_chars(&piece, &fits));
        }
    }
    lines
}

/// `piece` cut between characters into lines that fit.
fn break_chars(piece: &str, fits: &dyn Fn(&str) -> bool) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for c in piece.chars() {
        let mut next = cur.clone();
        next.push(c);
        if !cur.is_empty() && !fits(&next) {
            lines.push(std::mem::take(&mut cur));
            next = c.to_string();
        }
        cur = next;
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// The header of a picture in `style`: on the screen [`header`]; a paper figure has none (the
/// paper's caption says what it shows, and the title and parameters stay in the JSON beside the
/// picture), only a small top margin.
pub(crate) fn header_in<DB: DrawingBackend>(
    style: crate::plot::Style,
    root: &DrawingArea<DB, Shift>,
    title: &str,
    lines: &[String],
) -> Result<DrawingArea<DB, Shift>> {
    match style {
        crate::plot::Style::Screen => header(root, title, lines),
        crate::plot::Style::Paper => Ok(root.split_vertically(PAPER_TOP_MARGIN).1),
    }
}

/// The margin above a paper figure's body, in canvas pixels: room for the topmost tick label.
const PAPER_TOP_MARGIN: i32 = 6;

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
    let room = w.saturating_sub(20) as f64;
    for line in wrap_to_width(title, room, title_size, true) {
        root.draw(&Text::new(line, (w as i32 / 2, y), title_style.clone()))
            .drawing("the title")?;
        y += title_size as i32 + 4;
    }
    let style = anchored(small, HPos::Center, VPos::Top);
    for text in lines {
        for line in wrap_to_width(text, room, small, false) {
            root.draw(&Text::new(line, (w as i32 / 2, y), style.clone()))
                .drawing("the title")?;
            y += small as i32 + 3;
        }
    }
    Ok(root.split_vertically(y + 6).1)
}

/// A text's box on the canvas, centred on (`x`, `y`) in canvas pixels: its advance width
/// measured on the embedded font, its height one em (DejaVu Sans's glyphs reach 0.76 em above
/// the baseline and 0.24 em below it).
#[derive(Clone, Debug)]
pub(crate) struct Placed {
    pub text: String,
    pub x: f64,
    pub y: f64,
    pub half_w: f64,
    pub half_h: f64,
}

/// Space kept between two placed texts, and between a text and the circle it sits around, in
/// canvas pixels.
pub(crate) const LABEL_GAP: f64 = 1.5;

impl Placed {
    /// `text` of plotters text size `size` centred on (`x`, `y`).
    pub fn new(text: String, size: u32, x: f64, y: f64) -> Placed {
        let em = svg_em(size);
        let half_w = text_width(&text, em, false) / 2.0;
        Placed {
            text,
            x,
            y,
            half_w,
            half_h: em / 2.0,
        }
    }

    /// `text` just outside (`outside` true) or just inside the circle of radius `r` about
    /// `centre`, in the direction `angle` (radians clockwise from straight up): its box touches
    /// the circle's tangent there, [`LABEL_GAP`] away.
    pub fn by_circle(
        text: String,
        size: u32,
        centre: (f64, f64),
        r: f64,
        angle: f64,
        outside: bool,
    ) -> Placed {
        let mut p = Placed::new(text, size, 0.0, 0.0);
        let (s, c) = angle.sin_cos();
        let reach = s.abs() * p.half_w + c.abs() * p.half_h + LABEL_GAP;
        let d = if outside { r + reach } else { r - reach };
        p.x = centre.0 + d * s;
        p.y = centre.1 - d * c;
        p
    }

    /// Whether the boxes of `self` and `o`, each grown by half of [`LABEL_GAP`], meet.
    pub fn overlaps(&self, o: &Placed) -> bool {
        (self.x - o.x).abs() < self.half_w + o.half_w + LABEL_GAP
            && (self.y - o.y).abs() < self.half_h + o.half_h + LABEL_GAP
    }

    /// Whether `p` lies in the box.
    pub fn covers(&self, p: (f64, f64)) -> bool {
        (self.x - p.0).abs() <= self.half_w + LABEL_GAP
            && (self.y - p.1).abs() <= self.half_h + LABEL_GAP
    }

    /// Whether the box lies inside the rectangle (x0, y0)–(x1, y1).
    pub fn inside(&self, rect: (f64, f64, f64, f64)) -> bool {
        self.x - self.half_w >= rect.0
            && self.y - self.half_h >= rect.1
            && self.x + self.half_w <= rect.2
            && self.y + self.half_h <= rect.3
    }
}

/// `labels`, in order of priority, less each one that would overlap a label kept before it or
/// one of `fixed`, or cover one of `points` (the curves it must leave readable).
pub(crate) fn keep_apart(
    labels: Vec<Placed>,
    fixed: &[Placed],
    points: &[(f64, f64)],
) -> Vec<Placed> {
    let mut kept: Vec<Placed> = Vec::new();
    for l in labels {
        let clear = kept.iter().chain(fixed).all(|k| !l.overlaps(k))
            && !points.iter().any(|p| l.covers(*p));
        if clear {
            kept.push(l);
        }
    }
    kept
}

/// Draws `label` (placed in canvas pixels) centred on its position on `area`, in `colour` at
/// text size `size`.
pub(crate) fn draw_placed<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    label: &Placed,
    size: u32,
    colour: RGBColor,
) -> Result<()> {
    let (ox, oy) = area.get_base_pixel();
    area.draw(&Text::new(
        label.text.clone(),
        (
            (label.x - ox as f64).round() as i32,
            (label.y - oy as f64).round() as i32,
        ),
        text_style(size, colour).pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .drawing("a label")
}
