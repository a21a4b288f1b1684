//! Scenes: a TOML file naming materials (a model with parameters, or a built-in preset), lights,
//! a camera, and the outputs to produce: lobe tables, albedos and previews. `lobe run FILE` makes
//! everything the scene asks for; `lobe table --scene FILE` only its tables.
//!
//! ```toml
//! name = "lab"
//! ambient = 0.0                      # radiance of a uniform sky: one number or [r, g, b]
//!
//! [camera]
//! position = [0.0, 0.0, 0.0]         # looks down -z, +y up (OpenGL eye space)
//! fov_y_deg = 45.0
//!
//! [[lights]]
//! position = [0.0, 0.0, 1.0]
//! kind = "point"                     # or "directional" (position read as a direction)
//! # intensity = 1.0                  # default: all lights equal, a white Lambertian facing the
//!                                    # camera reads 1 (see `preview`)
//! [[materials]]
//! name = "gold"
//! model = "cook_torrance"
//! preset = "gold"                    # optional: start from a built-in preset
//! params = { roughness = 0.12 }      # optional: then these (numbers, [r, g, b] or names)
//!
//! [[tables]]
//! material = "gold"
//! grid = "auto"                      # auto (isotropic when the material is), full, isotropic,
//!                                    # halfdiff (theta_h, theta_d, phi_d; 4 axes when anisotropic)
//! n_theta = 32                       # cells over theta in [0, 90 deg], for theta_i and theta_o
//! n_phi = 64                         # cells over phi in [0, 360 deg); isotropic: n_phi/2 over [0, 180]
//! output = "gold.exr"                # relative to the output folder; .npy and .json beside it
//!
//! [[albedos]]
//! material = "gold"
//! method = "peak"                    # optional: any `lobe albedo --method` (default peak)
//! samples = 65536                    # optional: nodes per view direction
//! output = "gold-albedo.json"        # E at mu = 0.1, 0.25, 0.5, 0.75, 1 and the hemispherical albedo
//!
//! [[previews]]
//! materials = ["gold"]               # rows; default: every material
//! models = ["cook_torrance"]         # columns; default: the models of those materials
//! shape = "sphere"                   # or "icosahedron"
//! cell = 128
//! output = "lab.png"                 # the .exr (linear radiance) beside it
//! ```
//!
//! A preview is a contact sheet (rows materials, columns models): a cell whose model is not the
//! material's own takes the material's preset for that model, so such a sheet needs presets.
//!
//! Every error names the file, the line and the column of the offending text.

use crate::eval::Evaluator;
use crate::grid::Grid;
use crate::model::{Model, ParamSet, Value};
use crate::preview::{self, LightKind, Shape, Sheet};
use crate::{interrupt, material};
use anyhow::{bail, Context, Result};
use glam::DVec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Cells above which a table is refused before any work starts: the GPU kernel's 32-bit cell
/// index (48 GiB of float32 RGB), as `lobe table` refuses it.
pub use crate::table::MAX_TABLE_CELLS;
/// Largest preview cell, pixels (as `lobe preview --cell`).
pub const MAX_PREVIEW_CELL: u32 = 4096;
/// Largest scene file read, bytes: a scene is a few hundred lines; anything far larger is not one.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// A scene error located in its file.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.line, self.column, self.message
        )
    }
}

impl std::error::Error for SceneError {}

/// 1-based line and column (in characters) of byte `offset` of `text`.
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |k| k + 1);
    (line, before[start..].chars().count() + 1)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: Option<String>,
    #[allow(dead_code)]
    description: Option<String>,
    camera: Option<Spanned<CameraFile>>,
    ambient: Option<Spanned<toml::Value>>,
    #[serde(default)]
    lights: Vec<Spanned<LightFile>>,
    #[serde(default)]
    materials: Vec<Spanned<MaterialFile>>,
    #[serde(default)]
    tables: Vec<Spanned<TableFile>>,
    #[serde(default)]
    albedos: Vec<Spanned<AlbedoFile>>,
    #[serde(default)]
    previews: Vec<Spanned<PreviewFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    position: Option<Spanned<[f64; 3]>>,
    fov_y_deg: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightFile {
    position: Spanned<[f64; 3]>,
    kind: Option<Spanned<String>>,
    intensity: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    name: Spanned<String>,
    model: Spanned<String>,
    preset: Option<Spanned<String>>,
    #[serde(default)]
    params: BTreeMap<String, Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TableFile {
    material: Spanned<String>,
    grid: Option<Spanned<String>>,
    n_theta: Option<Spanned<i64>>,
    n_phi: Option<Spanned<i64>>,
    #[serde(default)]
    white_furnace: bool,
    output: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AlbedoFile {
    material: Spanned<String>,
    #[serde(default)]
    white_furnace: bool,
    /// Quadrature method and nodes per view direction (default: `lobe albedo`'s).
    method: Option<Spanned<String>>,
    samples: Option<Spanned<i64>>,
    output: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PreviewFile {
    materials: Option<Vec<Spanned<String>>>,
    models: Option<Vec<Spanned<String>>>,
    shape: Option<Spanned<String>>,
    cell: Option<Spanned<i64>>,
    exposure: Option<Spanned<f64>>,
    output: Spanned<String>,
}

/// A named material: a validated parameter set (its model included).
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub params: ParamSet,
    /// The built-in preset it started from, if any.
    pub preset: Option<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SceneLight {
    pub position: DVec3,
    pub kind: LightKind,
    /// RGB; None: the preview's normalisation (a white Lambertian facing the camera reads 1).
    pub intensity: Option<DVec3>,
}

#[derive(Clone, Debug)]
pub struct TableJob {
    pub material: usize,
    pub grid: Grid,
    pub white_furnace: bool,
    pub output: PathBuf,
}

#[derive(Clone, Debug)]
pub struct AlbedoJob {
    pub material: usize,
    pub white_furnace: bool,
    pub method: crate::integrate::Method,
    pub samples: usize,
    pub output: PathBuf,
}

/// The most quadrature nodes per view direction a scene may ask for (GPU node buffers of 16 MiB
/// per direction; far beyond what any rule needs for 1e-6).
pub const MAX_ALBEDO_SAMPLES: i64 = 1 << 20;

#[derive(Clone, Debug)]
pub struct PreviewJob {
    pub materials: Vec<usize>,
    pub models: Vec<Model>,
    pub shape: Shape,
    pub cell: u32,
    pub exposure: f64,
    pub output: PathBuf,
}

/// A parsed, validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub file: String,
    pub name: String,
    pub camera_position: DVec3,
    pub fov_y_deg: f64,
    pub ambient: DVec3,
    pub lights: Vec<SceneLight>,
    pub materials: Vec<Material>,
    pub tables: Vec<TableJob>,
    pub albedos: Vec<AlbedoJob>,
    pub previews: Vec<PreviewJob>,
}

/// Builds located errors for one file.
struct Locator<'a> {
    file: &'a str,
    text: &'a str,
}

impl Locator<'_> {
    fn at(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        let (line, column) = line_column(self.text, span.start);
        SceneError {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        }
    }
}

fn rgb_of(v: &toml::Value) -> Option<DVec3> {
    let num = |x: &toml::Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
    match v {
        toml::Value::Array(a) if a.len() == 3 => {
            let c: Vec<f64> = a.iter().filter_map(num).collect();
            (c.len() == 3).then(|| DVec3::new(c[0], c[1], c[2]))
        }
        x => num(x).map(DVec3::splat),
    }
}

/// Reads and parses the scene at `path`.
pub fn load(path: &Path) -> Result<Scene> {
    let meta =
        std::fs::metadata(path).with_context(|| format!("cannot read scene {}", path.display()))?;
    if meta.is_dir() {
        bail!("cannot read scene {}: it is a folder", path.display());
    }
    if meta.len() > MAX_SCENE_BYTES {
        bail!(
            "scene {} is {} bytes; a scene file is at most {MAX_SCENE_BYTES} bytes",
            path.display(),
            meta.len()
        );
    }
    let bytes =
        std::fs::read(path).with_context(|| format!("cannot read scene {}", path.display()))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let (line, column) = line_column(
            &String::from_utf8_lossy(e.as_bytes()),
            e.utf8_error().valid_up_to(),
        );
        anyhow::anyhow!(
            "{}:{line}:{column}: the scene is not UTF-8 text",
            path.display()
        )
    })?;
    Ok(parse(&text, &path.display().to_string())?)
}

/// Parses and validates a scene. `file` names it in errors. Never panics, whatever the text.
pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
    let loc = Locator { file, text };
    let raw: SceneFile = toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        loc.at(span, e.message().trim().to_string())
    })?;

    // Camera and ambient light.
    let (mut camera_position, mut fov_y_deg) = (DVec3::ZERO, preview::FOV_Y_DEG);
    if let Some(cam) = &raw.camera {
        if let Some(p) = &cam.get_ref().position {
            camera_position = DVec3::from_array(*p.get_ref());
            if !camera_position.is_finite() {
                return Err(loc.at(p.span(), "camera position must be finite"));
            }
        }
        if let Some(f) = &cam.get_ref().fov_y_deg {
            fov_y_deg = *f.get_ref();
            if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
                return Err(loc.at(
                    f.span(),
                    format!(
                        "fov_y_deg = {fov_y_deg}: expected a field of view in (0, 180) degrees"
                    ),
                ));
            }
        }
    }
    let ambient = match &raw.ambient {
        None => DVec3::ZERO,
        Some(a) => match rgb_of(a.get_ref()) {
            Some(v) if v.is_finite() && v.min_element() >= 0.0 => v,
            _ => {
                return Err(loc.at(
                    a.span(),
                    "ambient: expected a radiance >= 0, one number or [r, g, b]",
                ))
            }
        },
    };

    // Lights.
    let mut lights = Vec::new();
    for l in &raw.lights {
        let lf = l.get_ref();
        let position = DVec3::from_array(*lf.position.get_ref());
        if !position.is_finite() {
            return Err(loc.at(lf.position.span(), "light position must be finite"));
        }
        let kind = match lf.kind.as_ref().map(|k| (k.get_ref().as_str(), k.span())) {
            None | Some(("point", _)) => LightKind::Point,
            Some(("directional", _)) => LightKind::Directional,
            Some((other, span)) => {
                return Err(loc.at(
                    span,
                    format!("unknown light kind '{other}'; the kinds are: point, directional"),
                ))
            }
        };
        if kind == LightKind::Directional && position == DVec3::ZERO {
            return Err(loc.at(
                lf.position.span(),
                "a directional light needs a non-zero direction",
            ));
        }
        let intensity = match &lf.intensity {
            None => None,
            Some(i) => match rgb_of(i.get_ref()) {
                Some(v) if v.is_finite() && v.min_element() >= 0.0 => Some(v),
                _ => {
                    return Err(loc.at(
                        i.span(),
                        "light intensity: expected a number >= 0 or [r, g, b]",
                    ))
                }
            },
        };
        lights.push(SceneLight {
            position: position
                - if kind == LightKind::Point {
                    camera_position
                } else {
                    DVec3::ZERO
                },
            kind,
            intensity,
        });
    }
    let explicit = lights.iter().filter(|l| l.intensity.is_some()).count();
    if explicit != 0 && explicit != lights.len() {
        let l = &raw.lights[lights
            .iter()
            .position(|l| l.intensity.is_none())
            .unwrap_or(0)];
        return Err(loc.at(
            l.span(),
            "give every light an intensity, or none (then all are equal and normalised)",
        ));
    }

    // Materials.
    let mut materials: Vec<Material> = Vec::new();
    for m in &raw.materials {
        let mf = m.get_ref();
        let name = mf.name.get_ref().clone();
        if name.trim().is_empty() {
            return Err(loc.at(mf.name.span(), "a material needs a non-empty name"));
        }
        if materials.iter().any(|x| x.name == name) {
            return Err(loc.at(
                mf.name.span(),
                format!("material '{name}' is defined twice"),
            ));
        }
        let model = Model::from_name(mf.model.get_ref())
            .map_err(|e| loc.at(mf.model.span(), e.to_string()))?;
        let mut params = match &mf.preset {
            Some(p) => {
                material::preset(p.get_ref(), model).map_err(|e| loc.at(p.span(), e.to_string()))?
            }
            None => ParamSet::defaults(model),
        };
        for (key, v) in &mf.params {
            let value = match v.get_ref() {
                toml::Value::String(s) => {
                    params
                        .set_text(&format!("{key}={s}"))
                        .map_err(|e| loc.at(v.span(), e.to_string()))?;
                    continue;
                }
                toml::Value::Float(x) => Value::One(*x),
                toml::Value::Integer(i) => Value::One(*i as f64),
                toml::Value::Array(a) if a.len() == 3 => match rgb_of(v.get_ref()) {
                    Some(c) => Value::Three(c.to_array()),
                    None => {
                        return Err(loc.at(
                            v.span(),
                            format!("parameter '{key}': expected three numbers [r, g, b]"),
                        ))
                    }
                },
                other => {
                    return Err(loc.at(
                        v.span(),
                        format!(
                            "parameter '{key}': expected a number, [r, g, b] or a name, not {}",
                            other.type_str()
                        ),
                    ))
                }
            };
            params
                .set(key, value)
                .map_err(|e| loc.at(v.span(), e.to_string()))?;
        }
        materials.push(Material {
            name,
            params,
            preset: mf.preset.as_ref().map(|p| p.get_ref().clone()),
        });
    }
    let find = |s: &Spanned<String>| -> Result<usize, SceneError> {
        materials
            .iter()
            .position(|m| m.name == *s.get_ref())
            .ok_or_else(|| {
                let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
                loc.at(
                    s.span(),
                    format!(
                        "unknown material '{}'; the scene's materials are: {}",
                        s.get_ref(),
                        if names.is_empty() {
                            "(none: add a [[materials]] section)".to_string()
                        } else {
                            names.join(", ")
                        }
                    ),
                )
            })
    };
    let mut outputs: Vec<(PathBuf, Range<usize>)> = Vec::new();
    let mut output = |s: &Spanned<String>, ext: &str, what: &str| -> Result<PathBuf, SceneError> {
        let p = PathBuf::from(s.get_ref());
        if s.get_ref().trim().is_empty() {
            return Err(loc.at(s.span(), format!("{what} output: empty path")));
        }
        if p.extension().and_then(|e| e.to_str()) != Some(ext) {
            return Err(loc.at(
                s.span(),
                format!("{what} output '{}' must end in .{ext}", s.get_ref()),
            ));
        }
        // A table writes .npy and .json beside its .exr, a preview its .exr beside the .png.
        let stem = p.with_extension("");
        if let Some((_, first)) = outputs.iter().find(|(q, _)| *q == stem) {
            let (line, _) = line_column(text, first.start);
            return Err(loc.at(
                s.span(),
                format!(
                    "output '{}' clashes with the output on line {line} (same name before the extension)",
                    s.get_ref()
                ),
            ));
        }
        outputs.push((stem, s.span()));
        Ok(p)
    };

    // Tables.
    let mut tables = Vec::new();
    for t in &raw.tables {
        let tf = t.get_ref();
        let material = find(&tf.material)?;
        let params = &materials[material].params;
        let count = |v: &Option<Spanned<i64>>, default: i64, key: &str| {
            let Some(v) = v else {
                return Ok(default as usize);
            };
            let n = *v.get_ref();
            if n < 1 {
                return Err(loc.at(v.span(), format!("{key} = {n}: expected at least 1")));
            }
            usize::try_from(n).map_err(|_| loc.at(v.span(), format!("{key} = {n} is too large")))
        };
        let n_theta = count(&tf.n_theta, 32, "n_theta")?;
        let n_phi = count(&tf.n_phi, 64, "n_phi")?;
        let (kind, kind_span) = match &tf.grid {
            None => ("auto", t.span()),
            Some(g) => (g.get_ref().as_str(), g.span()),
        };
        let halfdiff = kind == "halfdiff";
        let isotropic = match kind {
            "auto" | "halfdiff" => params.is_isotropic(),
            "isotropic" if !params.is_isotropic() => {
                return Err(loc.at(
                    kind_span,
                    format!(
                        "grid = \"isotropic\" needs an isotropic material, but '{}' ({} {}) is anisotropic; use grid = \"full\" or \"auto\"",
                        materials[material].name,
                        params.model().name(),
                        params.to_text()
                    ),
                ))
            }
            "isotropic" => true,
            "full" => false,
            other => {
                return Err(loc.at(
                    kind_span,
                    format!("unknown grid '{other}'; the grids are: auto, full, isotropic, halfdiff"),
                ))
            }
        };
        let grid = if isotropic {
            if n_phi < 2 {
                let span = tf.n_phi.as_ref().map_or(t.span(), |s| s.span());
                return Err(loc.at(
                    span,
                    "n_phi must be at least 2 on the isotropic grid (n_phi/2 cells over [0, 180 deg])",
                ));
            }
            if halfdiff {
                Grid::HalfDiff {
                    n_theta_h: n_theta,
                    n_theta_d: n_theta,
                    n_phi_d: n_phi / 2,
                }
            } else {
                Grid::Isotropic {
                    n_theta_i: n_theta,
                    n_theta_o: n_theta,
                    n_dphi: n_phi / 2,
                }
            }
        } else if halfdiff {
            Grid::HalfDiffFull {
                n_theta_h: n_theta,
                n_phi_h: n_phi,
                n_theta_d: n_theta,
                n_phi_d: n_phi,
            }
        } else {
            Grid::Full {
                n_theta_i: n_theta,
                n_phi_i: n_phi,
                n_theta_o: n_theta,
                n_phi_o: n_phi,
            }
        };
        match grid.cells() {
            Some(c) if c <= MAX_TABLE_CELLS => {}
            _ => {
                let span = tf.n_theta.as_ref().map_or(t.span(), |s| s.span());
                return Err(loc.at(
                    span,
                    format!(
                        "the {} table of '{}' would have more than {MAX_TABLE_CELLS} cells (n_theta = {n_theta}, n_phi = {n_phi}); lower the resolution",
                        grid.name(),
                        materials[material].name
                    ),
                ));
            }
        }
        tables.push(TableJob {
            material,
            grid,
            white_furnace: tf.white_furnace,
            output: output(&tf.output, "exr", "table")?,
        });
    }

    // Albedos.
    let mut albedos = Vec::new();
    for a in &raw.albedos {
        let af = a.get_ref();
        let method = match &af.method {
            None => crate::integrate::Method::Peak,
            Some(m) => crate::integrate::Method::from_name(m.get_ref())
                .map_err(|e| loc.at(m.span(), e.to_string()))?,
        };
        let samples = match &af.samples {
            None => method.default_samples(),
            Some(n) if (16..=MAX_ALBEDO_SAMPLES).contains(n.get_ref()) => *n.get_ref() as usize,
            Some(n) => {
                return Err(loc.at(
                    n.span(),
                    format!(
                    "samples = {}: expected nodes per view direction in [16, {MAX_ALBEDO_SAMPLES}]",
                    n.get_ref()
                ),
                ))
            }
        };
        albedos.push(AlbedoJob {
            material: find(&af.material)?,
            white_furnace: af.white_furnace,
            method,
            samples,
            output: output(&af.output, "json", "albedo")?,
        });
    }

    // Previews.
    let mut previews = Vec::new();
    for p in &raw.previews {
        let pf = p.get_ref();
        let rows: Vec<usize> = match &pf.materials {
            None => (0..materials.len()).collect(),
            Some(list) => list.iter().map(&find).collect::<Result<_, _>>()?,
        };
        if rows.is_empty() {
            return Err(loc.at(p.span(), "a preview needs at least one material"));
        }
        let models: Vec<Model> = match &pf.models {
            None => {
                let mut v: Vec<Model> = Vec::new();
                for &r in &rows {
                    let m = materials[r].params.model();
                    if !v.contains(&m) {
                        v.push(m);
                    }
                }
                v
            }
            Some(list) => {
                if list.is_empty() {
                    return Err(loc.at(p.span(), "a preview needs at least one model"));
                }
                list.iter()
                    .map(|s| {
                        Model::from_name(s.get_ref()).map_err(|e| loc.at(s.span(), e.to_string()))
                    })
                    .collect::<Result<_, _>>()?
            }
        };
        // A cell of another model than the material's own takes the material's preset for it.
        for &r in &rows {
            let m = &materials[r];
            for &model in &models {
                if model.name() != m.params.model().name() && m.preset.is_none() {
                    return Err(loc.at(
                        p.span(),
                        format!(
                            "material '{}' has no preset, so it can be previewed only under its own model {}, not {}; give it a preset or list models = [\"{}\"]",
                            m.name,
                            m.params.model().name(),
                            model.name(),
                            m.params.model().name()
                        ),
                    ));
                }
            }
        }
        let shape = match &pf.shape {
            None => Shape::Sphere,
            Some(s) => {
                Shape::from_name(s.get_ref()).map_err(|e| loc.at(s.span(), e.to_string()))?
            }
        };
        let cell = match &pf.cell {
            None => preview::DEFAULT_CELL,
            Some(c) => match u32::try_from(*c.get_ref()) {
                Ok(v) if (1..=MAX_PREVIEW_CELL).contains(&v) => v,
                _ => {
                    return Err(loc.at(
                        c.span(),
                        format!(
                            "cell = {}: expected a cell size in [1, {MAX_PREVIEW_CELL}] pixels",
                            c.get_ref()
                        ),
                    ))
                }
            },
        };
        let exposure = match &pf.exposure {
            None => 0.0,
            Some(e) if e.get_ref().is_finite() => *e.get_ref(),
            Some(e) => return Err(loc.at(e.span(), "exposure must be a finite number of stops")),
        };
        if lights.is_empty() {
            return Err(loc.at(
                p.span(),
                "a preview needs lights: add [[lights]] sections to the scene",
            ));
        }
        previews.push(PreviewJob {
            materials: rows,
            models,
            shape,
            cell,
            exposure,
            output: output(&pf.output, "png", "preview")?,
        });
    }
    if tables.is_empty() && albedos.is_empty() && previews.is_empty() {
        return Err(loc.at(
            0..0,
            "the scene asks for no output: add [[tables]], [[albedos]] or [[previews]]",
        ));
    }
    Ok(Scene {
        file: file.to_string(),
        name: raw.name.unwrap_or_else(|| "scene".to_string()),
        camera_position,
        fov_y_deg,
        ambient,
        lights,
        materials,
        tables,
        albedos,
        previews,
    })
}

/// Which outputs of a scene to produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outputs {
    pub tables: bool,
    pub albedos: bool,
    pub previews: bool,
}

impl Outputs {
    pub const ALL: Outputs = Outputs {
        tables: true,
        albedos: true,
        previews: true,
    };
    pub const TABLES: Outputs = Outputs {
        tables: true,
        albedos: false,
        previews: false,
    };
    pub const ALBEDOS: Outputs = Outputs {
        tables: false,
        albedos: true,
        previews: false,
    };
    pub const PREVIEWS: Outputs = Outputs {
        tables: false,
        albedos: false,
        previews: true,
    };
}

/// What a run produced, and what it could not.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Files written, each with a one-line description.
    pub written: Vec<(PathBuf, String)>,
}

/// View directions μ = cos θo at which a scene's [[albedos]] report E(μ) (φo = 0), beside the
/// hemispherical albedo: grazing, halfway and normal view, as `lobe albedo` by default, and two
/// between.
pub const ALBEDO_MU: [f64; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

/// Creates the folder an output goes in (a scene's outputs may name sub-folders).
fn create_parent(path: &Path) -> Result<()> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating the folder {}", parent.display()))?;
    }
    Ok(())
}

fn f32_exact(x: f64) -> f64 {
    x as f32 as f64
}

impl Scene {
    /// The preview scene of this file's lights, camera and ambient light, for one cell size and
    /// shape. Lights without an intensity are normalised as the lab's are (a white Lambertian at
    /// the object's point nearest the camera, normal toward it, reads 1).
    pub fn preview_scene(&self, cell: u32, shape: Shape) -> Result<preview::Scene> {
        let mut s = preview::Scene::lab(cell, shape, LightKind::Point, self.ambient);
        s.tan_half_fov = f32_exact((self.fov_y_deg.to_radians() / 2.0).tan());
        let nearest = s.centre + DVec3::Z * s.radius;
        let auto = self.lights.iter().all(|l| l.intensity.is_none());
        let irradiance: f64 = self
            .lights
            .iter()
            .map(|l| match l.kind {
                LightKind::Point => {
                    let d = l.position - nearest;
                    (d.z / d.length()).max(0.0) / d.length_squared()
                }
                LightKind::Directional => (l.position.z / l.position.length()).max(0.0),
            })
            .sum();
        if auto && irradiance <= 0.0 {
            bail!(
                "{}: no light reaches the side of the object that faces the camera, so the lights cannot be normalised; give each light an intensity",
                self.file
            );
        }
        let auto_intensity = f32_exact(std::f64::consts::PI / irradiance);
        s.lights = self
            .lights
            .iter()
            .map(|l| preview::Light {
                position: DVec3::new(
                    f32_exact(l.position.x),
                    f32_exact(l.position.y),
                    f32_exact(l.position.z),
                ),
                kind: l.kind,
                intensity: l
                    .intensity
                    .map(|i| DVec3::new(f32_exact(i.x), f32_exact(i.y), f32_exact(i.z)))
                    .unwrap_or(DVec3::splat(auto_intensity)),
            })
            .collect();
        Ok(s)
    }

    /// The models whose kernels a run of `what` needs, for the log.
    pub fn models_needed(&self, what: Outputs) -> Vec<Model> {
        let mut out: Vec<Model> = Vec::new();
        let mut add = |m: Model| {
            if !out.contains(&m) {
                out.push(m)
            }
        };
        if what.tables {
            for t in &self.tables {
                add(self.materials[t.material].params.model());
            }
        }
        if what.albedos {
            for a in &self.albedos {
                add(self.materials[a.material].params.model());
            }
        }
        if what.previews {
            for p in &self.previews {
                for &m in &p.models {
                    for &r in &p.materials {
                        add(self.cell_params(r, m).map_or(m, |p| p.model()));
                    }
                }
            }
        }
        out
    }

    /// The parameters of preview cell (material `row`, model `model`).
    fn cell_params(&self, row: usize, model: Model) -> Result<ParamSet> {
        let m = &self.materials[row];
        if model.name() == m.params.model().name() {
            return Ok(m.params.clone());
        }
        let preset = m
            .preset
            .as_deref()
            .with_context(|| format!("material '{}' has no preset for {}", m.name, model.name()))?;
        Ok(material::preset(preset, model)?)
    }

    /// Produces the outputs `what` asks for under `out_dir`, evaluating on `e`. `log` receives a
    /// line per output as it is written. Stops with "interrupted" on Ctrl-C (between and inside
    /// outputs), leaving no partial file.
    pub fn run(
        &self,
        e: &Evaluator,
        out_dir: &Path,
        what: Outputs,
        log: &mut dyn FnMut(&str),
    ) -> Result<RunSummary> {
        let mut summary = RunSummary::default();
        if !out_dir.is_dir() {
            bail!(
                "the output folder {} does not exist (create it, or pick another with --output-dir)",
                out_dir.display()
            );
        }
        let at = |p: &Path| out_dir.join(p);
        if what.tables {
            for t in &self.tables {
                interrupt::check()?;
                let m = &self.materials[t.material];
                let path = at(&t.output);
                create_parent(&path)?;
                let meta = crate::table::TableMeta {
                    params: &m.params,
                    white_furnace: t.white_furnace,
                    grid: t.grid,
                    backend: e.name(),
                };
                let started = std::time::Instant::now();
                crate::table::write_table(e, &meta, &path, &mut |_, _| {})
                    .with_context(|| format!("table of material '{}'", m.name))?;
                let line = format!(
                    "table {} ({} {}, {} grid {:?}, {} cells, {:.2} s)",
                    path.display(),
                    m.name,
                    m.params.model().name(),
                    t.grid.name(),
                    t.grid.shape(),
                    t.grid.cells().unwrap_or(0),
                    started.elapsed().as_secs_f64()
                );
                log(&line);
                summary.written.push((path, line));
            }
        }
        if what.albedos {
            for a in &self.albedos {
                interrupt::check()?;
                let m = &self.materials[a.material];
                let path = at(&a.output);
                create_parent(&path)?;
                let settings = crate::integrate::Settings {
                    method: a.method,
                    samples: a.samples,
                    white_furnace: a.white_furnace,
                };
                let points: Vec<(f64, f64)> = ALBEDO_MU.iter().map(|&mu| (mu, 0.0)).collect();
                let report = crate::integrate::albedo_report(e, &m.params, &settings, &points, 0.0)
                    .with_context(|| format!("albedo of material '{}'", m.name))?;
                interrupt::check()?;
                let mut json = report.to_json(&m.params, a.white_furnace, &e.name());
                json["material"] = serde_json::json!(m.name);
                let tmp = crate::table::temp_beside(&path)?;
                serde_json::to_writer_pretty(tmp.as_file(), &json)
                    .with_context(|| format!("writing {}", path.display()))?;
                crate::table::persist(tmp, &path)?;
                let h = report.hemispherical.albedo;
                let line = format!(
                    "albedo {} ({} {}, hemispherical [{:.4}, {:.4}, {:.4}], {:.2} s)",
                    path.display(),
                    m.name,
                    m.params.model().name(),
                    h.x,
                    h.y,
                    h.z,
                    report.seconds
                );
                log(&line);
                summary.written.push((path, line));
            }
        }
        if what.previews {
            for p in &self.previews {
                interrupt::check()?;
                let names: Vec<String> = p
                    .materials
                    .iter()
                    .map(|&r| self.materials[r].name.clone())
                    .collect();
                let params = p
                    .models
                    .iter()
                    .map(|&model| {
                        p.materials
                            .iter()
                            .map(|&r| self.cell_params(r, model))
                            .collect::<Result<Vec<_>>>()
                    })
                    .collect::<Result<Vec<_>>>()?;
                let sheet = Sheet {
                    materials: names,
                    models: p.models.clone(),
                    params,
                };
                let scene = self.preview_scene(p.cell, p.shape)?;
                let path = at(&p.output);
                create_parent(&path)?;
                let exr_path = path.with_extension("exr");
                let started = std::time::Instant::now();
                let image = preview::render(e, &sheet, &scene, &mut |_, _| {})?;
                interrupt::check()?;
                preview::write_exr(&image, &sheet, &scene, &e.name(), &exr_path)?;
                let caption = preview::caption(&scene, p.exposure, &e.name());
                preview::write_png(&image, &sheet, p.exposure, &caption, &path)?;
                let line = format!(
                    "preview {} and {} ({} x {} cells of {} px, {:.2} s)",
                    path.display(),
                    exr_path.display(),
                    sheet.materials.len(),
                    sheet.models.len(),
                    p.cell,
                    started.elapsed().as_secs_f64()
                );
                log(&line);
                summary.written.push((path, line));
            }
        }
        Ok(summary)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_column_counts_from_one() {
        let t = "a = 1\nbé = x\n";
        assert_eq!(line_column(t, 0), (1, 1));
        assert_eq!(line_column(t, 6), (2, 1));
        assert_eq!(line_column(t, 11), (2, 5));
        assert_eq!(line_column(t, 1000), (3, 1));
    }

    #[test]
    fn the_lab_parses() {
        let text = include_str!("../data/scenes/lab.toml");
        let s = parse(text, "lab.toml").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.materials.len(), 4);
        assert_eq!(s.lights.len(), 4);
        assert_eq!(s.ambient, DVec3::ZERO);
        assert_eq!(s.camera_position, DVec3::ZERO);
    }

    #[test]
    fn syntax_error_is_located() {
        let e = parse("name = \"x\"\n[[materials]\n", "s.toml").unwrap_err();
        assert_eq!((e.file.as_str(), e.line), ("s.toml", 2), "{e}");
    }
}
