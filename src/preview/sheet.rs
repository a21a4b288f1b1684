//! The contact sheet: which model and material each cell holds, its linear image, the EXR that
//! keeps the radiance and the PNG that shows it tone-mapped, with the models' names above the
//! columns, the materials' names left of the rows and a caption below, all in DejaVu Sans
//! (`label.rs`).

use super::label::{Canvas, Typeface};
use super::{ambient_text, LightKind, Scene};
use crate::material;
use crate::model::{Model, ParamSet};
use crate::output::Pending;
use anyhow::{bail, Context, Result};
use std::path::Path;

/// Which model and material each cell holds: `params[column][row]`.
#[derive(Clone, Debug)]
pub struct Sheet {
    /// The rows' material names, top to bottom.
    pub materials: Vec<String>,
    /// The columns' models, left to right.
    pub models: Vec<Model>,
    /// The columns' labels, left to right: each model's name ([`Sheet::model_names`]) unless
    /// two columns of one model need telling apart.
    pub columns: Vec<String>,
    /// The preset of each row's material for each column's model.
    pub params: Vec<Vec<ParamSet>>,
}

impl Sheet {
    /// The built-in presets of `materials` (rows) for `models` (columns).
    pub fn new(materials: &[String], models: &[Model]) -> Result<Sheet> {
        if materials.is_empty() || models.is_empty() {
            bail!("a preview sheet needs at least one material and one model");
        }
        let params = models
            .iter()
            .map(|&m| {
                materials
                    .iter()
                    .map(|name| match material::preset(name, m) {
                        // The lab materials know no model defined at run time (a .brdf file,
                        // say): its column shows its own defaults in every row.
                        Err(crate::model::ParamError::NoPreset { .. })
                            if matches!(m, Model::Runtime(_)) =>
                        {
                            Ok(ParamSet::defaults(m))
                        }
                        r => r,
                    })
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Sheet {
            materials: materials.to_vec(),
            models: models.to_vec(),
            columns: Sheet::model_names(models),
            params,
        })
    }

    /// The default column labels: each model's name.
    pub fn model_names(models: &[Model]) -> Vec<String> {
        models.iter().map(|m| m.name().to_string()).collect()
    }

    /// The same sheet with every parameter rounded to f32, as the GPU receives it.
    pub fn rounded_to_f32(&self) -> Sheet {
        let mut s = self.clone();
        for column in &mut s.params {
            for p in column.iter_mut() {
                *p = p.rounded_to_f32();
            }
        }
        s
    }

    /// Each cell's model (with its components) and parameters, row by row, for file headers.
    pub fn cells_text(&self) -> String {
        let mut out = Vec::new();
        for (row, material) in self.materials.iter().enumerate() {
            for column in &self.params {
                let p = &column[row];
                let model = p.model().label();
                out.push(format!("{material} / {model}: {}", p.to_text()));
            }
        }
        out.join("; ")
    }
}

/// Linear RGB radiance of the whole sheet: cells only (labels go to the PNG), row-major from the
/// top left; cell (row, col) is the block of pixels [col·W, (col+1)·W) × [row·H, (row+1)·H).
#[derive(Clone, Debug)]
pub struct SheetImage {
    /// Cells down the sheet: one per material.
    pub rows: usize,
    /// Cells across the sheet: one per model.
    pub cols: usize,
    /// Width of a cell, in pixels.
    pub cell_width: usize,
    /// Height of a cell, in pixels.
    pub cell_height: usize,
    /// width() × height() pixels of linear RGB radiance, row-major from the top left.
    pub rgb: Vec<[f32; 3]>,
}

impl SheetImage {
    /// The sheet's width in pixels: `cols × cell_width`.
    pub fn width(&self) -> usize {
        self.cols * self.cell_width
    }

    /// The sheet's height in pixels: `rows × cell_height`.
    pub fn height(&self) -> usize {
        self.rows * self.cell_height
    }

    /// Radiance of pixel (x, y) of the whole sheet, row 0 on top.
    pub fn pixel(&self, x: usize, y: usize) -> [f32; 3] {
        self.rgb[y * self.width() + x]
    }

    /// Pixel (x, y) of cell (row, col).
    pub fn cell_pixel(&self, row: usize, col: usize, x: usize, y: usize) -> [f32; 3] {
        self.pixel(col * self.cell_width + x, row * self.cell_height + y)
    }
}

/// The PNG's caption: lights, exposure, ambient and backend in a line.
pub fn caption(scene: &Scene, exposure: f64, backend: &str) -> String {
    let kind = match scene.lights.first().map(|l| l.kind) {
        Some(LightKind::Directional) => "directional",
        _ => "point",
    };
    let at: Vec<String> = scene
        .lights
        .iter()
        .map(|l| format!("({},{},{})", l.position.x, l.position.y, l.position.z))
        .collect();
    let ambient = ambient_text(scene.ambient);
    format!(
        "{} {kind} lights {}, camera at 0 looking down -z; exposure {exposure:+.1} ev; ambient {ambient}; {backend}",
        scene.lights.len(),
        at.join(" ")
    )
}

/// Writes the sheet's linear radiance as EXR (float32 R, G, B), with the layout, the rows, the
/// columns and the scene in the header; through a temporary file renamed into place.
pub fn write_exr(
    image: &SheetImage,
    sheet: &Sheet,
    scene: &Scene,
    backend: &str,
    path: &Path,
) -> Result<()> {
    let out = Pending::new(path)?;
    encode_exr(image, sheet, scene, backend, &out)?;
    out.commit()
}

/// [`write_exr`] into `out`, a file of a set the caller commits.
pub fn encode_exr(
    image: &SheetImage,
    sheet: &Sheet,
    scene: &Scene,
    backend: &str,
    out: &Pending,
) -> Result<()> {
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|Vec2(x, y)| {
        let [r, g, b] = image.pixel(x, y);
        (r, g, b)
    });
    let mut layer = Layer::new(
        (image.width(), image.height()),
        LayerAttributes::named("lobe preview"),
        crate::output::EXR_ENCODING,
        channels,
    );
    let columns = &sheet.columns;
    let attrs = [
        ("lobe.kind", "preview".to_string()),
        ("lobe.rows", sheet.materials.join(",")),
        ("lobe.columns", columns.join(",")),
        (
            "lobe.layout",
            format!(
                "cells of {}x{} pixels; cell (row, col) = pixels [col*{0}, (col+1)*{0}) x [row*{1}, (row+1)*{1})",
                image.cell_width, image.cell_height
            ),
        ),
        ("lobe.cells", sheet.cells_text()),
        ("lobe.scene", scene.describe()),
        (
            "lobe.units",
            "linear RGB radiance toward the camera; lights scaled so a white Lambertian facing the camera reads 1; delta lobes not included".to_string(),
        ),
        ("lobe.backend", backend.to_string()),
    ];
    for (k, v) in attrs {
        layer
            .attributes
            .other
            .insert(Text::new_or_panic(k), crate::table::exr_text(&v));
    }
    crate::output::write_exr(out, |w| Image::from_layer(layer).write().to_buffered(w))
}

/// Reads an EXR written by [`write_exr`] back: (width, height, rgb row-major).
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>)> {
    use exr::prelude::*;
    let image = read_first_flat_layer_from_file(path)
        .with_context(|| format!("reading {}", path.display()))?;
    let layer = &image.layer_data;
    Ok((
        layer.size.0,
        layer.size.1,
        crate::table::exr_rgb(layer, path)?,
    ))
}

/// The sRGB transfer function (IEC 61966-2-1:1999) of a linear value in [0, 1].
pub fn srgb_encode(linear: f64) -> f64 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// An 8-bit sRGB value of linear radiance at `exposure` stops: L·2^EV, clipped to [0, 1].
pub fn tone_map(linear: f32, exposure: f64) -> u8 {
    let v = (linear as f64 * exposure.exp2()).clamp(0.0, 1.0);
    (srgb_encode(v) * 255.0).round() as u8
}

/// Label colours (sRGB 8-bit).
const LABEL_BACKGROUND: [u8; 3] = [32, 32, 32];
const LABEL_TEXT: [u8; 3] = [225, 225, 225];
const CAPTION_TEXT: [u8; 3] = [150, 150, 150];
/// Empty pixels around a label.
const LABEL_PAD: usize = 4;
/// Sizes (pixels from ascender to descender) the model and material names are tried at, largest
/// first: the first at which every model's name fits its column is used, else the last, with
/// names cut at the cell's edge. 16 px gives DejaVu Sans capitals about 10 px tall.
const LABEL_SIZES: [f32; 4] = [16.0, 14.0, 12.0, 10.0];
/// The caption's largest size (never larger than the names): it carries the set-up rather than
/// the subject.
const CAPTION_SIZE: f32 = 12.0;
/// Space between two caption lines, in pixels.
const CAPTION_LEADING: usize = 2;

/// Where the parts of the labelled sheet lie in the PNG.
#[derive(Clone, Debug, PartialEq)]
struct Layout {
    /// The size of the model and material names (one of [`LABEL_SIZES`]).
    label_size: f32,
    /// Width of the material names' margin: the cells start at this x.
    left: usize,
    /// Height of the model names' band: the cells start at this y.
    top: usize,
    /// The caption's size: [`CAPTION_SIZE`], or the names' size where that is smaller.
    caption_size: f32,
    /// The caption, wrapped to the PNG's width.
    caption_lines: Vec<String>,
    /// The PNG's width and height.
    width: usize,
    height: usize,
}

impl Layout {
    fn new(face: &Typeface, image: &SheetImage, sheet: &Sheet, caption: &str) -> Layout {
        let cw = image.cell_width;
        let fits = |size: f32| sheet.columns.iter().all(|c| face.width(c, size) + 2 <= cw);
        let label_size = LABEL_SIZES
            .into_iter()
            .find(|&s| fits(s))
            .unwrap_or(LABEL_SIZES[LABEL_SIZES.len() - 1]);
        let top = Typeface::line_height(label_size) + 2 * LABEL_PAD;
        let left = sheet
            .materials
            .iter()
            .map(|m| face.width(m, label_size))
            .max()
            .unwrap_or(0)
            + 2 * LABEL_PAD;
        let width = left + image.width();
        let caption_size = CAPTION_SIZE.min(label_size);
        let caption_lines = face.wrap(caption, width.saturating_sub(2 * LABEL_PAD), caption_size);
        let caption_height = caption_lines.len()
            * (Typeface::line_height(caption_size) + CAPTION_LEADING)
            + 2 * LABEL_PAD;
        Layout {
            label_size,
            left,
            top,
            caption_size,
            caption_lines,
            width,
            height: top + image.height() + caption_height,
        }
    }
}

/// The labelled sheet as 8-bit sRGB pixels, and where its parts lie.
fn compose(
    image: &SheetImage,
    sheet: &Sheet,
    exposure: f64,
    caption: &str,
) -> Result<(Canvas, Layout)> {
    let face = Typeface::dejavu_sans()?;
    let layout = Layout::new(&face, image, sheet, caption);
    let (cw, ch) = (image.cell_width, image.cell_height);
    let (left, top, size) = (layout.left, layout.top, layout.label_size);
    let line = Typeface::line_height(size);
    let mut canvas = Canvas::new(layout.width, layout.height, LABEL_BACKGROUND);
    for y in 0..image.height() {
        for x in 0..image.width() {
            let c = image.pixel(x, y).map(|v| tone_map(v, exposure));
            canvas.put(left + x, top + y, c);
        }
    }
    for (col, label) in sheet.columns.iter().enumerate() {
        let label = label.as_str();
        let x0 = left + col * cw;
        let x = x0 + cw.saturating_sub(face.width(label, size)) / 2;
        // A name cut at the cell's edge keeps one clear pixel before the next column's name.
        let max_x = x0 + cw.saturating_sub(1).max(1);
        face.draw(&mut canvas, label, x, LABEL_PAD, size, max_x, LABEL_TEXT);
    }
    for (row, label) in sheet.materials.iter().enumerate() {
        let y = top + row * ch + ch.saturating_sub(line) / 2;
        face.draw(&mut canvas, label, LABEL_PAD, y, size, left, LABEL_TEXT);
    }
    let caption_size = layout.caption_size;
    let pitch = Typeface::line_height(caption_size) + CAPTION_LEADING;
    for (k, text) in layout.caption_lines.iter().enumerate() {
        let y = top + image.height() + LABEL_PAD + k * pitch;
        let (x, max_x) = (LABEL_PAD, layout.width);
        face.draw(&mut canvas, text, x, y, caption_size, max_x, CAPTION_TEXT);
    }
    Ok((canvas, layout))
}

/// Writes the labelled contact sheet as an 8-bit sRGB PNG: model names above the columns,
/// material names left of the rows, `caption` along the bottom (wrapped); radiance tone-mapped by
/// [`tone_map`] at `exposure` stops. Through a temporary file renamed into place. Returns the
/// PNG's (width, height): the cells plus the label margins. The same input writes the same bytes.
pub fn write_png(
    image: &SheetImage,
    sheet: &Sheet,
    exposure: f64,
    caption: &str,
    path: &Path,
) -> Result<(usize, usize)> {
    let out = Pending::new(path)?;
    let size = encode_png(image, sheet, exposure, caption, &out)?;
    out.commit()?;
    Ok(size)
}

/// [`write_png`] into `out`, a file of a set the caller commits.
pub fn encode_png(
    image: &SheetImage,
    sheet: &Sheet,
    exposure: f64,
    caption: &str,
    out: &Pending,
) -> Result<(usize, usize)> {
    let (canvas, layout) = compose(image, sheet, exposure, caption)?;
    let (width, height) = (layout.width, layout.height);
    let path = out.dest();
    let mut w = out.writer();
    {
        let w = &mut w;
        let mut encoder = png::Encoder::new(w, width as u32, height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let png_error = |e| crate::output::encoder_error(path, "PNG encoder", e);
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(&canvas.rgb).map_err(png_error)?;
        writer.finish().map_err(png_error)?;
    }
    w.finish()?;
    Ok((width, height))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints() {
        assert_eq!(tone_map(0.0, 0.0), 0);
        assert_eq!(tone_map(1.0, 0.0), 255);
        assert_eq!(tone_map(0.5, 1.0), 255);
        // 18 % grey is sRGB 0.4614 (IEC 61966-2-1), 117.6 of 255.
        assert_eq!(tone_map(0.18, 0.0), 118);
    }

    /// A sheet of the first `rows` materials × `models` whose cells hold a ramp (not rendered:
    /// only the labels are under test), `cell` pixels square.
    fn ramp_sheet(rows: usize, models: &[Model], cell: usize) -> (Sheet, SheetImage) {
        let materials: Vec<String> = material::names()[..rows]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let sheet = Sheet::new(&materials, models).unwrap();
        let (w, h) = (models.len() * cell, rows * cell);
        let rgb = (0..w * h)
            .map(|k| [(k % w) as f32 / w as f32, (k / w) as f32 / h as f32, 0.5])
            .collect();
        let image = SheetImage {
            rows,
            cols: models.len(),
            cell_width: cell,
            cell_height: cell,
            rgb,
        };
        (sheet, image)
    }

    /// Checks that the cells are copied untouched, each model's name is inked inside its own
    /// column's band above the cells, each material's name inside its own row's band left of the
    /// cells, the caption below them, and nothing in the top left corner; the text is
    /// anti-aliased and composing again gives the same pixels.
    fn check_labels(rows: usize, models: &[Model], cell: usize) {
        let (sheet, image) = ramp_sheet(rows, models, cell);
        let caption = "4 point lights (0,0,1) (0,1,1) (1,0,1) (-1,0,1), camera at 0 looking down -z; exposure +0.0 ev; ambient none; cpu (f64 reference)";
        let (canvas, l) = compose(&image, &sheet, 0.0, caption).unwrap();
        assert_eq!((canvas.width, canvas.height), (l.width, l.height));
        let what = format!("{rows} rows x {} columns of {cell} px", models.len());
        for y in 0..image.height() {
            for x in 0..image.width() {
                let want = image.pixel(x, y).map(|v| tone_map(v, 0.0));
                assert_eq!(
                    canvas.get(l.left + x, l.top + y),
                    want,
                    "{what}: cell pixel ({x}, {y})"
                );
            }
        }
        let inked = |xs: std::ops::Range<usize>, ys: std::ops::Range<usize>| -> Vec<[u8; 3]> {
            ys.flat_map(|y| xs.clone().map(move |x| (x, y)))
                .map(|(x, y)| canvas.get(x, y))
                .filter(|&c| c != LABEL_BACKGROUND)
                .collect()
        };
        assert!(
            inked(0..l.left, 0..l.top).is_empty(),
            "{what}: ink in the corner"
        );
        for col in 0..models.len() {
            let x0 = l.left + col * cell;
            assert!(
                !inked(x0..x0 + cell, 0..l.top).is_empty(),
                "{what}: no name above column {col}"
            );
        }
        // No name reaches its column's last pixel, so neighbouring names never touch; a name
        // that fits keeps its column's first pixel clear too.
        let fits = sheet
            .columns
            .iter()
            .all(|c| Typeface::dejavu_sans().unwrap().width(c, l.label_size) + 2 <= cell);
        for col in 0..models.len() {
            let x0 = l.left + col * cell;
            assert!(
                inked(x0 + cell - 1..x0 + cell, 0..l.top).is_empty(),
                "{what}: the name above column {col} reaches its last pixel"
            );
            assert!(
                !fits || inked(x0..x0 + 1, 0..l.top).is_empty(),
                "{what}: the name above column {col} reaches its first pixel"
            );
        }
        for row in 0..rows {
            let y0 = l.top + row * cell;
            assert!(
                !inked(0..l.left, y0..y0 + cell).is_empty(),
                "{what}: no name left of row {row}"
            );
            assert!(
                inked(0..l.left, y0..y0 + 1).is_empty(),
                "{what}: a row name crosses the top of row {row}"
            );
        }
        let bottom = l.top + image.height();
        let caption_ink = inked(0..l.width, bottom..l.height);
        assert!(!caption_ink.is_empty(), "{what}: no caption");
        let label_ink = inked(0..l.width, 0..l.top);
        assert!(
            label_ink.iter().any(|&c| c != LABEL_TEXT),
            "{what}: no partly covered pixel, the names are not anti-aliased"
        );
        assert!(
            label_ink
                .iter()
                .all(|c| c.iter().zip(LABEL_TEXT).all(|(&v, t)| v <= t)),
            "{what}: name pixels brighter than the names' colour"
        );
        // The caption is drawn in its own, dimmer colour: blends of the background toward it.
        assert!(
            caption_ink
                .iter()
                .all(|c| c.iter().zip(CAPTION_TEXT).all(|(&v, t)| v <= t)),
            "{what}: caption pixels brighter than the caption's colour"
        );
        let (again, _) = compose(&image, &sheet, 0.0, caption).unwrap();
        assert!(
            again.rgb == canvas.rgb,
            "{what}: composing again changed pixels"
        );
    }

    #[test]
    fn labels_lie_in_their_bands_at_the_default_cell() {
        let models = [Model::Lambert, Model::AshikhminShirley, Model::CookTorrance];
        check_labels(3, &models, 128);
    }

    #[test]
    fn labels_cut_at_small_cells_stay_in_their_bands() {
        let models = [Model::Lambert, Model::AshikhminShirley, Model::CookTorrance];
        check_labels(2, &models, 40);
    }

    #[test]
    fn the_same_sheet_writes_the_same_png_bytes() {
        let (sheet, image) = ramp_sheet(2, &[Model::Phong, Model::OrenNayar], 48);
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
        write_png(&image, &sheet, 0.5, "caption; second part", &a).unwrap();
        write_png(&image, &sheet, 0.5, "caption; second part", &b).unwrap();
        assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap());
    }
}
