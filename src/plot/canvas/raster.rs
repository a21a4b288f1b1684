//! PNG: the drawn SVG rasterised by resvg with the embedded fonts.

use anyhow::{anyhow, Context, Result};
use std::sync::OnceLock;

/// The fonts resvg draws text with: the embedded DejaVu Sans (regular and bold) as every
/// family, so that no system font is read.
pub(crate) fn font_db() -> std::sync::Arc<resvg::usvg::fontdb::Database> {
    static DB: OnceLock<std::sync::Arc<resvg::usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = resvg::usvg::fontdb::Database::new();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.load_font_data(dejavu::sans::bold().to_vec());
        db.set_sans_serif_family("DejaVu Sans");
        std::sync::Arc::new(db)
    })
    .clone()
}

/// The drawn SVG `svg` as usvg's tree, its text in the embedded fonts.
pub(crate) fn svg_tree(svg: &str) -> Result<resvg::usvg::Tree> {
    let options = resvg::usvg::Options {
        font_family: "DejaVu Sans".to_string(),
        fontdb: font_db(),
        ..Default::default()
    };
    resvg::usvg::Tree::from_str(svg, &options).context("reading the drawn SVG")
}

/// The SVG `svg` (of `size` pixels) as an 8-bit sRGB PNG, anti-aliased by resvg.
pub fn rasterise(svg: &str, size: (u32, u32)) -> Result<Vec<u8>> {
    let tree = svg_tree(svg)?;
    let (w, h) = size;
    let mut pixmap = resvg::tiny_skia::Pixmap::new(w, h)
        .ok_or_else(|| anyhow!("cannot make a {w}x{h} image"))?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    // The background is opaque white, so the premultiplied RGBA pixels are plain RGB.
    let rgb: Vec<u8> = pixmap
        .data()
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().context("encoding the PNG")?;
        writer.write_image_data(&rgb).context("encoding the PNG")?;
    }
    Ok(out)
}
