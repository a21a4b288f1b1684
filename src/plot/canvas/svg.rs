//! Drawing a picture once, as SVG, and writing it in the requested format.

use super::*;
use crate::plot::Format;
use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// How a drawn canvas becomes the written picture: the canvas the picture is laid out on, and
/// how that canvas is scaled onto the page. A `(width, height)` is a screen page: the canvas as
/// it is, at 96 pixels per inch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Page {
    /// The canvas every size of the drawing (text, margins, lines) is given in, in pixels.
    pub canvas: (u32, u32),
    /// Written pixels per canvas pixel: a PNG is `canvas × zoom` pixels.
    pub zoom: f64,
    /// Written pixels per inch: the page size of a PDF and the physical size of an SVG.
    pub dpi: f64,
    /// The factor on every line width.
    pub stroke: f64,
}

/// The pixels per inch of a screen page: CSS's pixel, and what SVG viewers assume.
pub const SCREEN_DPI: f64 = 96.0;

impl From<(u32, u32)> for Page {
    fn from(canvas: (u32, u32)) -> Page {
        Page {
            canvas,
            zoom: 1.0,
            dpi: SCREEN_DPI,
            stroke: 1.0,
        }
    }
}

impl Page {
    /// The written size in pixels: the canvas times the zoom.
    pub fn pixels(&self) -> (u32, u32) {
        let (w, h) = self.canvas;
        (
            (w as f64 * self.zoom).round() as u32,
            (h as f64 * self.zoom).round() as u32,
        )
    }

    /// Whether the drawn SVG is written as drawn (a screen page).
    fn is_plain(&self) -> bool {
        self.zoom == 1.0 && self.stroke == 1.0
    }

    /// The drawn SVG `svg` sized for this page: its root's width and height set to `width` and
    /// `height` (the view box stays the canvas, so everything scales with them), every
    /// `stroke-width` times [`Page::stroke`].
    fn resize(&self, svg: &str, width: &str, height: &str) -> Result<String> {
        let (w, h) = self.canvas;
        let root = format!("<svg width=\"{w}\" height=\"{h}\" ");
        if !svg.starts_with(&root) {
            return Err(anyhow!("the SVG backend wrote an unexpected root element"));
        }
        let mut out = format!("<svg width=\"{width}\" height=\"{height}\" ");
        let mut rest = &svg[root.len()..];
        const KEY: &str = "stroke-width=\"";
        while let Some(k) = rest.find(KEY) {
            let start = k + KEY.len();
            let end = rest[start..]
                .find('"')
                .ok_or_else(|| anyhow!("an unclosed stroke-width in the drawn SVG"))?
                + start;
            let width: f64 = rest[start..end]
                .parse()
                .map_err(|_| anyhow!("a stroke-width that is no number in the drawn SVG"))?;
            out.push_str(&rest[..start]);
            out.push_str(&fmt_coord(width * self.stroke));
            rest = &rest[end..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// A length for SVG: at most three decimals, no trailing zeros.
fn fmt_coord(v: f64) -> String {
    let s = format!("{v:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Draws with `draw` on an SVG canvas of `page` and writes it to `path`: as SVG, for a `.png`
/// rasterised, anti-aliased, by resvg, or for a `.pdf` converted by svg2pdf (one drawing for
/// every format). `draw` gets the plotters canvas and an [`Overlay`] layer that is drawn over it.
/// The picture is written to a temporary file beside `path` and renamed over it only when
/// complete: a failed plot leaves no file. The same input gives the same bytes.
pub(crate) fn render(
    path: &Path,
    page: impl Into<Page>,
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Overlay) -> Result<()>,
) -> Result<()> {
    let bytes = render_bytes(Format::of(path)?, page, draw)?;
    crate::output::write_atomic(path, |w| {
        std::io::Write::write_all(w, &bytes).with_context(|| format!("writing {}", path.display()))
    })
}

/// What `draw` draws on an SVG canvas of `page`, as the bytes of a file in `format` (see
/// [`render`]), for a caller that writes several pictures as one transaction.
pub(crate) fn render_bytes(
    format: Format,
    page: impl Into<Page>,
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Overlay) -> Result<()>,
) -> Result<Vec<u8>> {
    let page = page.into();
    let svg = draw_svg(page.canvas, draw)?;
    let pixels = page.pixels();
    let in_pixels = |svg: String| -> Result<String> {
        if page.is_plain() {
            return Ok(svg);
        }
        page.resize(&svg, &pixels.0.to_string(), &pixels.1.to_string())
    };
    Ok(match format {
        Format::Svg if page.is_plain() => svg.into_bytes(),
        // Sized in points (1/72 in), so that a document places it at its printed size.
        Format::Svg => {
            let pt = |px: u32| format!("{}pt", fmt_coord(px as f64 * 72.0 / page.dpi));
            page.resize(&svg, &pt(pixels.0), &pt(pixels.1))?
                .into_bytes()
        }
        Format::Png => rasterise(&in_pixels(svg)?, pixels)?,
        Format::Pdf => to_pdf(&in_pixels(svg)?, page.dpi)?,
    })
}

/// The SVG text of what `draw` draws on a white canvas of `size`, its [`Overlay`] on top.
pub fn draw_svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Overlay) -> Result<()>,
) -> Result<String> {
    register_fonts()?;
    let mut svg = String::new();
    let mut ink = Overlay::default();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).drawing("the background")?;
        draw(&root, &mut ink)?;
        root.present().drawing("the picture")?;
    }
    let end = svg
        .rfind("</svg>")
        .ok_or_else(|| anyhow!("the SVG backend wrote no closing tag"))?;
    svg.insert_str(end, &ink.svg);
    Ok(svg)
}
