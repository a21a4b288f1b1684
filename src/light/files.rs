//! `lobe light`'s output set, written as one [`FileSet`]: every destination checked before the
//! work, the files in place together or none of them. `exact` and `split_sum` write `P.exr`
//! (linear radiance, float32 R, G, B), `P.png` (tone-mapped) and `P.json` (the settings);
//! `both` writes `P.exr` (exact), `P_split_sum.exr`, `P_error.exr` (split sum − exact, signed),
//! a PNG beside each, and `P.json` (with the error figures). A model without a split sum writes
//! under `both` only the exact sum's EXR and PNG and the JSON.

use super::{LightImage, Method};
use crate::output::{file_name, sibling, FileSet, Pending};
use crate::preview::tone_map;
use anyhow::{bail, Result};
use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};

/// An image of the set, with its EXR header's `lobe.*` text and the PNG it gets.
pub struct Image {
    image: LightImage,
    attributes: Vec<(&'static str, String)>,
    signed: bool,
}

impl Image {
    /// Radiance: its PNG is L · 2^EV clipped and sRGB-encoded.
    pub fn radiance(image: LightImage, attributes: Vec<(&'static str, String)>) -> Image {
        Image {
            image,
            attributes,
            signed: false,
        }
    }

    /// A signed difference: its PNG is [`super::ERROR_TONE_MAP`].
    pub fn signed(image: LightImage, attributes: Vec<(&'static str, String)>) -> Image {
        Image {
            image,
            attributes,
            signed: true,
        }
    }
}

/// The name of the EXR `exr_path` gets with `suffix` (`""`, `"_split_sum"`, `"_error"`).
pub fn file_name_of(exr_path: &Path, suffix: &str) -> String {
    file_name(&sibling(exr_path, suffix, "exr"))
}

/// The paths of the set for `exr_path` and `method` (`has_split`: whether the model has a split
/// sum), the EXR and PNG of each image in order, the JSON last. Refuses a path that does not end
/// in `.exr`.
pub fn paths(exr_path: &Path, method: Method, has_split: bool) -> Result<Vec<PathBuf>> {
    if exr_path.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "-o {}: the output must end in .exr (the .png and .json are written beside it)",
            exr_path.display()
        );
    }
    let suffixes: &[&str] = match method {
        Method::Both if has_split => &["", "_split_sum", "_error"],
        _ => &[""],
    };
    let mut out = Vec::new();
    for s in suffixes {
        out.push(sibling(exr_path, s, "exr"));
        out.push(sibling(exr_path, s, "png"));
    }
    out.push(sibling(exr_path, "", "json"));
    Ok(out)
}

/// The set's files, checked before any work ([`FileSet::new`]).
pub fn create(exr_path: &Path, method: Method, has_split: bool) -> Result<FileSet> {
    let paths = paths(exr_path, method, has_split)?;
    let refs: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
    FileSet::new(&refs)
}

/// Writes `images` into the set made by [`create`] (as many as it has EXR and PNG pairs): each
/// one's EXR and PNG (at `exposure` stops), and `settings` as the JSON; then commits the set.
pub fn write(set: FileSet, images: &[Image], exposure: f64, settings: &Value) -> Result<()> {
    for (k, im) in images.iter().enumerate() {
        encode_exr(&im.image, &im.attributes, &set[2 * k])?;
        if im.signed {
            encode_signed_png(&im.image, &set[2 * k + 1])?;
        } else {
            encode_png(&im.image, exposure, &set[2 * k + 1])?;
        }
    }
    let mut w = set[2 * images.len()].writer();
    serde_json::to_writer_pretty(&mut w, settings)?;
    w.write_all(b"\n")?;
    w.finish()?;
    set.commit()
}

fn encode_exr(
    image: &LightImage,
    attributes: &[(&'static str, String)],
    out: &Pending,
) -> Result<()> {
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
    let rgb: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| p.map(|v| tone_map(v as f32, exposure)))
        .collect();
    write_png(image.size, &rgb, out)
}

/// The PNG of a signed image ([`super::ERROR_TONE_MAP`]): the mean over channels divided by
/// its largest magnitude, red where positive, blue where negative, sRGB-encoded.
fn encode_signed_png(image: &LightImage, out: &Pending) -> Result<()> {
    let mean = |p: &[f64; 3]| (p[0] + p[1] + p[2]) / 3.0;
    let largest = image
        .pixels
        .iter()
        .map(|p| mean(p).abs())
        .fold(0.0, f64::max);
    let scale = if largest > 0.0 { 1.0 / largest } else { 0.0 };
    let rgb: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| {
            let e = mean(p) * scale;
            let v = tone_map(e.abs() as f32, 0.0);
            if e >= 0.0 {
                [v, 0, 0]
            } else {
                [0, 0, v]
            }
        })
        .collect();
    write_png(image.size, &rgb, out)
}

fn write_png(size: u32, rgb: &[u8], out: &Pending) -> Result<()> {
    let path = out.dest().to_path_buf();
    let mut w = out.writer();
    {
        let mut encoder = png::Encoder::new(&mut w, size, size);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let png_error = |e| crate::output::encoder_error(&path, "PNG encoder", e);
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(rgb).map_err(png_error)?;
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
