//! The text of the contact sheet's labels: DejaVu Sans, the font the plots draw with (embedded
//! by the `dejavu` crate, so no system font is read), laid out and rasterised by `ab_glyph` and
//! blended onto an 8-bit RGB canvas. The rasteriser computes each pixel's coverage of the glyph's
//! outline in f32 from the embedded font alone, so the same text always gives the same bytes.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use anyhow::{anyhow, Result};

/// An 8-bit RGB image, row-major from the top left.
pub struct Canvas {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// width × height pixels of (r, g, b).
    pub rgb: Vec<u8>,
}

impl Canvas {
    /// A canvas of one colour.
    pub fn new(width: usize, height: usize, background: [u8; 3]) -> Canvas {
        Canvas {
            width,
            height,
            rgb: background.repeat(width * height),
        }
    }

    /// Pixel (x, y); pixels outside the canvas read as black.
    pub fn get(&self, x: usize, y: usize) -> [u8; 3] {
        if x < self.width && y < self.height {
            let k = 3 * (y * self.width + x);
            [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
        } else {
            [0; 3]
        }
    }

    /// Sets pixel (x, y); pixels outside the canvas are left out.
    pub fn put(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let k = 3 * (y * self.width + x);
            self.rgb[k..k + 3].copy_from_slice(&c);
        }
    }

    /// Mixes `c` into pixel (x, y) by `coverage` (clamped to [0, 1]), channel by channel in the
    /// 8-bit values, rounded to the nearest.
    fn blend(&mut self, x: usize, y: usize, c: [u8; 3], coverage: f32) {
        let a = coverage.clamp(0.0, 1.0);
        if a == 0.0 {
            return;
        }
        let old = self.get(x, y);
        let mixed: [u8; 3] = std::array::from_fn(|k| {
            (old[k] as f32 + (c[k] as f32 - old[k] as f32) * a).round() as u8
        });
        self.put(x, y, mixed);
    }
}

/// DejaVu Sans at some pixel sizes: measures and draws single lines of text.
pub struct Typeface {
    font: FontRef<'static>,
}

impl Typeface {
    /// DejaVu Sans Regular, as the plots use it.
    pub fn dejavu_sans() -> Result<Typeface> {
        let font = FontRef::try_from_slice(dejavu::sans::regular())
            .map_err(|_| anyhow!("the embedded DejaVu Sans font could not be parsed"))?;
        Ok(Typeface { font })
    }

    /// The height in pixels of a line at `size`: ascender to descender, which is what a size
    /// means to `ab_glyph` (`PxScale`).
    pub fn line_height(size: f32) -> usize {
        size.ceil() as usize
    }

    /// The pen positions of `text`'s glyphs at `size` from a pen at 0 (advances plus kerning),
    /// and the pen after the last glyph.
    fn layout(&self, text: &str, size: f32) -> (Vec<(ab_glyph::GlyphId, f32)>, f32) {
        let scaled = self.font.as_scaled(PxScale::from(size));
        let mut pen = 0.0f32;
        let mut prev = None;
        let mut glyphs = Vec::with_capacity(text.len());
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            if let Some(p) = prev {
                pen += scaled.kern(p, id);
            }
            glyphs.push((id, pen));
            pen += scaled.h_advance(id);
            prev = Some(id);
        }
        (glyphs, pen)
    }

    /// The width in pixels of `text` at `size`, rounded up: the advance of the whole line.
    pub fn width(&self, text: &str, size: f32) -> usize {
        self.layout(text, size).1.ceil() as usize
    }

    /// Draws `text` at `size` with its line's top left corner at (x, y) (the baseline one ascent
    /// below, on a whole pixel so that horizontal strokes stay sharp) in colour `c`. Glyphs whose
    /// ink would reach `max_x` or beyond are left out, and so is the rest of the line.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &self,
        canvas: &mut Canvas,
        text: &str,
        x: usize,
        y: usize,
        size: f32,
        max_x: usize,
        c: [u8; 3],
    ) {
        let scale = PxScale::from(size);
        let baseline = y as f32 + self.font.as_scaled(scale).ascent().round();
        let (glyphs, _) = self.layout(text, size);
        for (id, pen) in glyphs {
            let glyph = id.with_scale_and_position(scale, point(x as f32 + pen, baseline));
            let Some(outline) = self.font.outline_glyph(glyph) else {
                continue; // a space: nothing to draw
            };
            let bounds = outline.px_bounds();
            if bounds.max.x > max_x as f32 {
                break;
            }
            let (x0, y0) = (bounds.min.x as i64, bounds.min.y as i64);
            outline.draw(|gx, gy, coverage| {
                let (px, py) = (x0 + gx as i64, y0 + gy as i64);
                if px >= 0 && py >= 0 {
                    canvas.blend(px as usize, py as usize, c, coverage);
                }
            });
        }
    }

    /// Splits `text` at "; " into lines at most `width` pixels wide at `size`; a part wider than
    /// a line is broken between words (a single word wider than a line keeps a line of its own).
    pub fn wrap(&self, text: &str, width: usize, size: f32) -> Vec<String> {
        let mut lines: Vec<String> = Vec::new();
        for part in text.split("; ") {
            match lines.last_mut() {
                Some(last) if self.width(&format!("{last}; {part}"), size) <= width => {
                    last.push_str("; ");
                    last.push_str(part);
                }
                _ => lines.extend(self.wrap_words(part, width, size)),
            }
        }
        lines
    }

    /// `part` broken greedily between words into lines at most `width` pixels wide.
    fn wrap_words(&self, part: &str, width: usize, size: f32) -> Vec<String> {
        let mut lines: Vec<String> = Vec::new();
        for word in part.split(' ') {
            match lines.last_mut() {
                Some(last) if self.width(&format!("{last} {word}"), size) <= width => {
                    last.push(' ');
                    last.push_str(word);
                }
                _ => lines.push(word.to_string()),
            }
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WHITE: [u8; 3] = [255; 3];

    /// The pixels of `text` drawn white on black at `size` in a canvas of its own.
    fn drawn(text: &str, size: f32) -> Canvas {
        let face = Typeface::dejavu_sans().unwrap();
        let (w, h) = (face.width(text, size) + 4, Typeface::line_height(size) + 4);
        let mut canvas = Canvas::new(w, h, [0; 3]);
        face.draw(&mut canvas, text, 2, 2, size, w, WHITE);
        canvas
    }

    #[test]
    fn text_is_anti_aliased_and_stays_in_its_line() {
        let c = drawn("cook_torrance", 14.0);
        let inked: Vec<(usize, usize, u8)> = (0..c.height)
            .flat_map(|y| (0..c.width).map(move |x| (x, y)))
            .map(|(x, y)| (x, y, c.get(x, y)[0]))
            .filter(|p| p.2 > 0)
            .collect();
        assert!(inked.iter().any(|p| p.2 == 255), "no fully covered pixel");
        assert!(
            inked.iter().any(|p| p.2 > 0 && p.2 < 255),
            "no partly covered pixel: not anti-aliased"
        );
        // Overlay stays within the line box (2 px margin each side), descender of '_' included.
        for &(x, y, _) in &inked {
            assert!(
                (2..c.width - 2).contains(&x) && (2..c.height - 2).contains(&y),
                "({x}, {y})"
            );
        }
    }

    #[test]
    fn lower_case_differs_from_upper_case_and_drawing_repeats_exactly() {
        let (lower, upper) = (drawn("granite", 16.0), drawn("GRANITE", 16.0));
        assert_ne!(lower.rgb, upper.rgb);
        assert_eq!(lower.rgb, drawn("granite", 16.0).rgb);
    }

    #[test]
    fn a_line_is_cut_at_max_x() {
        let face = Typeface::dejavu_sans().unwrap();
        let mut canvas = Canvas::new(200, 20, [0; 3]);
        face.draw(&mut canvas, "ashikhmin_shirley", 0, 0, 14.0, 40, WHITE);
        for y in 0..20 {
            for x in 40..200 {
                assert_eq!(canvas.get(x, y), [0; 3], "({x}, {y}) is past max_x");
            }
        }
        assert!((0..40).any(|x| (0..20).any(|y| canvas.get(x, y) != [0; 3])));
    }

    #[test]
    fn wrap_keeps_every_line_within_the_width() {
        let face = Typeface::dejavu_sans().unwrap();
        let text =
            "4 point lights (0,0,1) (0,1,1), camera at 0; exposure +0.0 ev; ambient none; cpu";
        let lines = face.wrap(text, 150, 12.0);
        assert!(lines.len() > 1);
        // Lines break at "; " or between words: nothing but those separators is lost.
        let bare = |t: &str| t.replace([';', ' '], "");
        assert_eq!(bare(&lines.concat()), bare(text));
        for l in &lines {
            assert!(face.width(l, 12.0) <= 150, "{l}");
        }
    }

    #[test]
    fn wrap_breaks_a_part_wider_than_a_line_between_words() {
        let face = Typeface::dejavu_sans().unwrap();
        let text = "White furnace: each sphere under a uniform white sky of radiance 1, so a pixel reads its albedo";
        let lines = face.wrap(text, 200, 12.0);
        assert!(lines.len() > 2, "{lines:?}");
        assert_eq!(lines.join(" "), text);
        for l in &lines {
            assert!(face.width(l, 12.0) <= 200, "{l} is wider than 200 px");
        }
    }
}
