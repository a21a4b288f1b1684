//! `lobe light`'s output set: `P.exr` (linear radiance, float32 R, G, B), `P.png` (tone-mapped)
//! and `P.json` (the settings), written as one [`FileSet`]: every destination checked before the
//! work, the three files in place together or none of them.

use super::LightImage;
use crate::output::{sibling, FileSet, Pending};
use crate::preview::tone_map;
use anyhow::{bail, Result};
use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The paths of the set for `exr_path`: the EXR, the PNG and the JSON beside it. Refuses a path
/// that does not end in `.exr`.
pub fn paths(exr_path: &Path) -> Result<[PathBuf; 3]> {
    if exr_path.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "-o {}: the output must end in .exr (the .png and .json are written beside it)",
            exr_path.display()
        );
    }
    Ok([
        exr_path.to_path_buf(),
        sibling(exr_path, "", "png"),
        sibling(exr_path, "", "json"),
    ])
}

/// The set's files, checked before any work ([`FileSet::new`]).
pub fn create(exr_path: &Path) -> Result<FileSet> {
    let [exr, png, json] = paths(exr_path)?;
    FileSet::new(&[&exr, &png, &json])
}

/// Writes `image` into the set made by [`create`]: its EXR with `attributes` (`lobe.*` text) in
/// the header, its PNG at `exposure` stops, and `settings` as the JSON; then commits the set.
pub fn write(
    set: FileSet,
    image: &LightImage,
    attributes: &[(&str, String)],
    exposure: f64,
    settings: &Value,
) -> Result<()> {
    encode_exr(image, attributes, &set[0])?;
    encode_png(image, exposure, &set[1])?;
    let mut w = set[2].writer();
    serde_json::to_writer_pretty(&mut w, settings)?;
    w.write_all(b"\n")?;
    w.finish()?;
    set.commit()
}

fn encode_exr(image: &LightImage, attributes: &[(&str, String)], out: &Pending) -> Result<()> {
    use exr::prelude::*;
    let size = image.size as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y)| {
        let [r, g, b] = image.pixels[y * size + x];
        (r as f32, g as f32, b as f32)
    });
    let mut layer = Layer::new(
        (size, size),
        LayerAttributes::named("lobe light"),
        crate::output::EXR_ENCODING,
        channels,
    );
    for (k, v) in attributes {
        layer
            .attributes
            .other
            .insert(Text::new_or_panic(*k), crate::output::exr_text(v));
    }
    crate::output::write_exr(out, |w| Image::from_layer(layer).write().to_buffered(w))
}

/// The PNG: each channel L · 2^EV clipped to [0, 1] and sRGB-encoded
/// ([`crate::preview::tone_map`]).
fn encode_png(image: &LightImage, exposure: f64, out: &Pending) -> Result<()> {
    let size = image.size;
    let rgb: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| p.map(|v| tone_map(v as f32, exposure)))
        .collect();
    let path = out.dest().to_path_buf();
    let mut w = out.writer();
    {
        let mut encoder = png::Encoder::new(&mut w, size, size);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let png_error = |e| crate::output::encoder_error(&path, "PNG encoder", e);
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(&rgb).map_err(png_error)?;
        writer.finish().map_err(png_error)?;
    }
    w.finish()?;
    Ok(())
}

/// Reads a light EXR back: (size, row-major RGB).
pub fn read_exr(path: &Path) -> Result<(usize, Vec<[f32; 3]>)> {
    let (w, h, rgb) = crate::preview::read_exr(path)?;
    if w != h {
        bail!(
            "{}: a light image is square, this is {w} x {h}",
            path.display()
        );
    }
    Ok((w, rgb))
}
