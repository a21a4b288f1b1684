//! PDF: the drawn SVG converted by svg2pdf, vector paths and text, the embedded fonts subset into
//! the file, so that the page reads the same without DejaVu installed.

use super::svg_tree;
use anyhow::{anyhow, Result};

/// The SVG `svg` as a one-page PDF whose page is the SVG's size at `dpi` pixels per inch (a
/// 1050-pixel-wide picture at 300 dpi is a 3.5 in = 252 pt page). Text stays text, in the
/// embedded DejaVu Sans.
pub fn to_pdf(svg: &str, dpi: f64) -> Result<Vec<u8>> {
    let tree = svg_tree(svg)?;
    let options = svg2pdf::ConversionOptions {
        embed_text: true,
        ..Default::default()
    };
    let page = svg2pdf::PageOptions { dpi: dpi as f32 };
    svg2pdf::to_pdf(&tree, options, page).map_err(|e| anyhow!("converting the picture to PDF: {e}"))
}
