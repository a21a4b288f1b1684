//! `lobe preview`: the labelled contact sheet of shaded objects, or every preview of a scene.

use super::run::run_scene;
use super::{bar, open_session, BackendArgs};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use glam::DVec3;
use lobe::material;
use lobe::preview::{self, LightKind, Scene, Shape, Sheet};
use std::path::{Path, PathBuf};

use lobe::preview::MAX_SHEET_PIXELS;

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum ShapeArg {
    /// A sphere of radius 1, three units in front of the camera.
    Sphere,
    /// The lab's regular icosahedron (circumradius 1, flat faces) in the same place.
    Icosahedron,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum LightsArg {
    /// Point lights at the lab's positions, in the camera's space (OpenGL eye space, w = 1).
    Point,
    /// Directional lights toward the lab's vectors (OpenGL w = 0).
    Directional,
}

#[derive(Args)]
pub struct PreviewArgs {
    /// Render every preview a scene file asks for instead (see `lobe run --help`), with its own
    /// lights, camera and settings; the other flags except --backend and --device do not apply.
    #[arg(long, value_name = "SCENE.toml")]
    scene: Option<PathBuf>,
    /// With --scene: the folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR", requires = "scene")]
    output_dir: Option<PathBuf>,
    /// Output PNG (tone-mapped, labelled); the linear radiance goes to the .exr beside it.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH.png",
        default_value = "preview.png"
    )]
    output: PathBuf,
    /// Models, one column each (repeatable or comma-separated; default: every model).
    #[arg(long = "model", value_delimiter = ',')]
    models: Vec<String>,
    /// Material presets, one row each (repeatable or comma-separated; default: tin, gold, glazed_ceramic, granite).
    #[arg(long = "material", value_delimiter = ',')]
    materials: Vec<String>,
    /// The object in every cell.
    #[arg(long, value_enum, default_value_t = ShapeArg::Sphere)]
    shape: ShapeArg,
    /// How the lab's light vectors (0,0,1), (0,1,1), (1,0,1), (-1,0,1) are read.
    #[arg(long, value_enum, default_value_t = LightsArg::Point)]
    lights: LightsArg,
    /// Cell size in pixels (square).
    #[arg(long, default_value_t = lobe::preview::DEFAULT_CELL)]
    cell: u32,
    /// Exposure of the PNG in stops (EV): radiance is multiplied by 2^EV before sRGB encoding.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f64,
    /// Radiance of a uniform white sky, one number or r,g,b (default 0: the lab has no ambient light).
    /// Approximated as its irradiance pi*A arriving along the normal: exact for Lambert only.
    #[arg(long, value_name = "A or R,G,B")]
    ambient: Option<String>,
    #[command(flatten)]
    backend: BackendArgs,
}

/// `--ambient`: one grey radiance or r,g,b, each finite and >= 0.
fn parse_ambient(text: &str) -> Result<DVec3> {
    let nums: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--ambient '{text}': expected one number or r,g,b"))?;
    let v = match nums[..] {
        [g] => DVec3::splat(g),
        [r, g, b] => DVec3::new(r, g, b),
        _ => bail!("--ambient '{text}': expected one number or r,g,b"),
    };
    if !v.is_finite() || v.min_element() < 0.0 {
        bail!("--ambient '{text}': radiance must be finite and >= 0");
    }
    Ok(v)
}

pub fn run(a: PreviewArgs) -> Result<()> {
    if let Some(scene) = &a.scene {
        return run_scene(
            scene,
            a.output_dir.as_deref().unwrap_or(Path::new(".")),
            &a.backend,
            lobe::scene::Outputs::PREVIEWS,
        );
    }
    if a.output.extension().and_then(|e| e.to_str()) != Some("png") {
        bail!(
            "-o {}: the output must end in .png (the .exr is written beside it)",
            a.output.display()
        );
    }
    if !a.exposure.is_finite() {
        bail!(
            "--exposure {}: expected a finite number of stops",
            a.exposure
        );
    }
    let max_cell = lobe::scene::MAX_PREVIEW_CELL;
    if !(1..=max_cell).contains(&a.cell) {
        bail!(
            "--cell {}: expected a cell size in [1, {max_cell}] pixels",
            a.cell
        );
    }
    let ambient = match &a.ambient {
        None => DVec3::ZERO,
        Some(text) => parse_ambient(text)?,
    };
    let models = super::models_or_all(&a.models)?;
    let materials: Vec<String> = if a.materials.is_empty() {
        material::names().into_iter().map(String::from).collect()
    } else {
        a.materials.clone()
    };
    let pixels = (materials.len() * models.len()) as u64 * u64::from(a.cell).pow(2);
    if pixels > MAX_SHEET_PIXELS {
        bail!(
            "--cell {}: {} materials x {} models of {}x{} pixels is {pixels} pixels; a sheet is at \
             most {MAX_SHEET_PIXELS} (use a smaller --cell or fewer --models, --materials)",
            a.cell,
            materials.len(),
            models.len(),
            a.cell,
            a.cell
        );
    }
    let sheet = Sheet::new(&materials, &models)?;
    let shape = match a.shape {
        ShapeArg::Sphere => Shape::Sphere,
        ShapeArg::Icosahedron => Shape::Icosahedron,
    };
    let kind = match a.lights {
        LightsArg::Point => LightKind::Point,
        LightsArg::Directional => LightKind::Directional,
    };
    let scene = Scene::lab(a.cell, shape, kind, ambient);
    let exr_path = a.output.with_extension("exr");
    // Both files checked before the render; they replace the old pair together or not at all.
    let set = lobe::output::FileSet::new(&[&exr_path, &a.output])?;
    let session = open_session(&a.backend)?;
    let backend = session.backend_name();
    let progress = bar(models.len() as u64, "{msg} [{bar:30}] {pos}/{len} columns");
    progress.set_message(format!("preview on {backend}"));
    let started = std::time::Instant::now();
    let image = session.preview(&sheet, &scene, &mut |done, _| {
        progress.set_position(done as u64)
    })?;
    let render_time = started.elapsed();
    progress.finish_and_clear();
    preview::encode_exr(&image, &sheet, &scene, &backend, &set[0])?;
    let caption = preview::caption(&scene, a.exposure, &backend);
    let (png_w, png_h) = preview::encode_png(&image, &sheet, a.exposure, &caption, &set[1])?;
    set.commit()?;
    eprintln!(
        "lobe: rendered {} x {} cells of {} px in {:.2} s on {}; wrote {} ({png_w}x{png_h}, labelled) and {} ({}x{}, linear radiance)",
        sheet.materials.len(),
        sheet.models.len(),
        a.cell,
        render_time.as_secs_f64(),
        backend,
        a.output.display(),
        exr_path.display(),
        image.width(),
        image.height()
    );
    Ok(())
}
