//! Drawing a picture once, as SVG, and writing it in the requested format.

use super::*;
use crate::plot::Format;
use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Draws with `draw` on an SVG canvas of `size` and writes it to `path`: as SVG, or for a
/// `.png` rasterised, anti-aliased, by resvg (one drawing for both formats). `draw` gets the
/// plotters canvas and an [`Ink`] layer that is drawn over it. The picture is written to a
/// temporary file beside `path` and renamed over it only when complete: a failed plot leaves
/// no file. The same input gives the same bytes.
pub(crate) fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Ink) -> Result<()>,
) -> Result<()> {
    let bytes = render_bytes(Format::of(path)?, size, draw)?;
    crate::output::write_atomic(path, |w| {
        std::io::Write::write_all(w, &bytes).with_context(|| format!("writing {}", path.display()))
    })
}

/// What `draw` draws on an SVG canvas of `size`, as the bytes of a file in `format` (see
/// [`render`]), for a caller that writes several pictures as one transaction.
pub(crate) fn render_bytes(
    format: Format,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Ink) -> Result<()>,
) -> Result<Vec<u8>> {
    let svg = draw_svg(size, draw)?;
    Ok(match format {
        Format::Svg => svg.into_bytes(),
        Format::Png => rasterise(&svg, size)?,
    })
}

/// The SVG text of what `draw` draws on a white canvas of `size`, its [`Ink`] on top.
pub fn draw_svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>, &mut Ink) -> Result<()>,
) -> Result<String> {
    register_fonts()?;
    let mut svg = String::new();
    let mut ink = Ink::default();
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
