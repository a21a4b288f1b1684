//! Scenes: a TOML file naming materials (a model with parameters, or a built-in preset), lights,
//! a camera, and the outputs to produce: lobe tables, albedos and previews. `lobe run FILE` makes
//! everything the scene asks for; `lobe table --scene FILE` only its tables. docs/scenes.md
//! lists every key with its type, default and valid range; this is its example:
//!
//! ```toml
//! name = "gold-study"
//! ambient = 0.0                      # radiance of a uniform sky: one number or [r, g, b]
//!
//! [camera]
//! position = [0.0, 0.0, 0.0]         # looks down -z, +y up (OpenGL eye space)
//! fov_y_deg = 45.0
//!
//! # No intensity: all lights are equal, scaled so that a white Lambertian facing the camera
//! # reads 1 (see `preview`).
//! [[lights]]
//! position = [0.0, 0.0, 1.0]         # kind = "point" (default) or "directional"
//!
//! [[lights]]
//! position = [1.0, 0.0, 1.0]
//!
//! [[materials]]
//! name = "gold"
//! model = "cook_torrance"
//! preset = "gold"                    # optional: start from a built-in preset
//! params = { roughness = 0.12 }      # optional: then these (numbers, [r, g, b] or names)
//!
//! [[materials]]
//! name = "brushed"
//! model = "ashikhmin_shirley"
//! preset = "tin"
//!
//! [[tables]]
//! material = "gold"                  # grid = "auto": isotropic, as gold is
//! n_theta = 32                       # cells over theta in [0, 90 deg], for theta_i and theta_o
//! n_dphi = 32                        # cells over dphi in [0, 180 deg] (default n_phi / 2)
//! output = "tables/gold.exr"         # relative to the output folder; .npy and .json beside it
//!
//! [[tables]]
//! material = "brushed"               # anisotropic: the full grid
//! n_theta = 16
//! n_phi = 32                         # cells over phi in [0, 360 deg), for phi_i and phi_o
//! output = "tables/brushed.exr"
//!
//! [[albedos]]
//! material = "gold"                  # method (default peak), samples, seed: as `lobe albedo`
//! output = "albedo/gold.json"        # E at mu = 0.1, 0.25, 0.5, 0.75, 1 and the hemispherical albedo
//!
//! [[previews]]
//! models = ["cook_torrance", "ashikhmin_shirley"]   # columns; rows: materials (default all)
//! cell = 96
//! output = "study.png"               # the .exr (linear radiance) beside it
//! ```
//!
//! Table resolution: `n_phi` (default 64) always counts cells over the full circle
//! [0, 360 deg). The isotropic grids (`isotropic`, and `halfdiff` on an isotropic material) have
//! one azimuth axis over the half circle [0, 180 deg] instead (dphi, or phi_d), whose cells
//! `n_dphi` gives; without it the axis takes n_phi / 2 cells, the same angular step. An odd
//! n_phi there, n_phi with n_dphi, and n_dphi on a grid without that axis are refused, and each
//! table's log line states every axis's cells and the key they come from
//! ([`TableJob::resolution`]): a requested resolution is never changed silently.
//!
//! A preview is a contact sheet (rows materials, columns models, one column per model name): a
//! cell whose model is the material's own shows the material's parameters, any other cell the
//! material's preset for that model, so such a sheet needs presets.
//!
//! Output paths stay inside the output folder: absolute paths and `..` parts are refused when the
//! scene is parsed, and paths leaving it through a symbolic link before the run starts. The
//! output folder and the sub-folders outputs name are created as needed. A run is one
//! transaction: every output is staged, then all replace the old files together, or none does.
//! A run's summary lists every file written (a table's three, an albedo's one, a preview's two).
//!
//! Every error names the file, the line and the column of the offending text.

mod parse;
mod run;

pub use parse::parse;

use crate::grid::Grid;
use crate::material;
use crate::model::{Model, ParamSet};
use crate::preview::{self, LightKind, Shape};
use anyhow::{bail, Context, Result};
use glam::DVec3;
use std::fmt;
use std::path::{Path, PathBuf};

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
    /// The scene file's name, as the error messages print it.
    pub file: String,
    /// 1-based line of the offending text.
    pub line: usize,
    /// 1-based column, in characters, of the offending text.
    pub column: usize,
    /// What is wrong, as a sentence naming the key and its valid values.
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

/// A named material: a validated parameter set (its model included).
#[derive(Clone, Debug)]
pub struct Material {
    /// The name tables, albedos and previews refer to it by; unique in the scene.
    pub name: String,
    /// The model and its parameters: the defaults or the preset, then the section's `params`.
    pub params: ParamSet,
    /// The built-in preset it started from, if any.
    pub preset: Option<String>,
}

/// A `[[lights]]` section, as the previews use it.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneLight {
    /// A point light's position in the camera's frame (the file's position minus the camera's), or,
    /// for a directional light, the vector toward the light as given.
    pub position: DVec3,
    /// Whether the light is a point at `position` or infinitely far along it.
    pub kind: LightKind,
    /// RGB; None: the preview's normalisation (a white Lambertian facing the camera reads 1).
    pub intensity: Option<DVec3>,
}

/// A `[[tables]]` section: one lobe table to write.
#[derive(Clone, Debug)]
pub struct TableJob {
    /// Index of the tabulated material in [`Scene::materials`].
    pub material: usize,
    /// The grid of direction pairs, with its cells per axis.
    pub grid: Grid,
    /// Evaluate with every Fresnel factor of a specular lobe set to 1.
    pub white_furnace: bool,
    /// Where the `.exr` goes, relative to the output folder (the `.npy` and `.json` go beside it).
    pub output: PathBuf,
    /// Why this grid, and how each axis's cells follow from the section's keys (for the log):
    /// the isotropic grids' azimuth covers [0, 180 deg], so its cells are not `n_phi`'s.
    pub resolution: String,
}

/// Cells over theta in [0, 90 deg] when a table gives no `n_theta`.
pub const DEFAULT_N_THETA: usize = 32;
/// Cells over phi in [0, 360 deg) when a table gives no `n_phi` (and no `n_dphi`): 32 over
/// [0, 180 deg] on the isotropic grids.
pub const DEFAULT_N_PHI: usize = 64;

/// An `[[albedos]]` section: one albedo report to write.
#[derive(Clone, Debug)]
pub struct AlbedoJob {
    /// Index of the integrated material in [`Scene::materials`].
    pub material: usize,
    /// Integrate with every Fresnel factor of a specular lobe set to 1.
    pub white_furnace: bool,
    /// The quadrature rule.
    pub method: crate::integrate::Method,
    /// Quadrature nodes per view direction, in [16, [`MAX_ALBEDO_SAMPLES`]] (the rule's default
    /// when the section gives none).
    pub samples: usize,
    /// The Monte Carlo methods' stream ([`crate::integrate::Settings::seed`]).
    pub seed: u32,
    /// Where the JSON report goes, relative to the output folder.
    pub output: PathBuf,
}

/// The most quadrature nodes per view direction a scene may ask for (GPU node buffers of 16 MiB
/// per direction; far beyond what any rule needs for 1e-6).
pub const MAX_ALBEDO_SAMPLES: i64 = crate::integrate::MAX_SAMPLES as i64;

/// A `[[previews]]` section: one contact sheet to render.
#[derive(Clone, Debug)]
pub struct PreviewJob {
    /// The rows: indices in [`Scene::materials`].
    pub materials: Vec<usize>,
    /// The columns, one per model name.
    pub models: Vec<Model>,
    /// The object drawn in every cell.
    pub shape: Shape,
    /// Cell size in pixels, in [1, [`MAX_PREVIEW_CELL`]].
    pub cell: u32,
    /// Exposure of the PNG in stops; 0 puts a white Lambertian facing the camera just below clip.
    pub exposure: f64,
    /// Where the PNG goes, relative to the output folder (the `.exr` goes beside it).
    pub output: PathBuf,
}

/// A parsed, validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file's name, as messages print it.
    pub file: String,
    /// The scene's name for the log (`scene` when the file gives none).
    pub name: String,
    /// Where the camera is; the camera looks down −z with +y up.
    pub camera_position: DVec3,
    /// Vertical field of view, in degrees, in (0, 180).
    pub fov_y_deg: f64,
    /// RGB radiance of a uniform sky around the previewed objects.
    pub ambient: DVec3,
    /// The lights, in file order.
    pub lights: Vec<SceneLight>,
    /// The materials, in file order; jobs refer to them by index.
    pub materials: Vec<Material>,
    /// The lobe tables to write, in file order.
    pub tables: Vec<TableJob>,
    /// The albedo reports to write, in file order.
    pub albedos: Vec<AlbedoJob>,
    /// The contact sheets to render, in file order.
    pub previews: Vec<PreviewJob>,
}

/// Reads and parses the scene at `path`.
pub fn load(path: &Path) -> Result<Scene> {
    let bytes = crate::input::read_regular(path, "scene", MAX_SCENE_BYTES)?;
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

/// Which outputs of a scene to produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outputs {
    /// Write the `[[tables]]`.
    pub tables: bool,
    /// Write the `[[albedos]]`.
    pub albedos: bool,
    /// Render the `[[previews]]`.
    pub previews: bool,
}

impl Outputs {
    /// Everything the scene asks for (`lobe run`).
    pub const ALL: Outputs = Outputs {
        tables: true,
        albedos: true,
        previews: true,
    };
    /// Only the tables (`lobe table --scene`).
    pub const TABLES: Outputs = Outputs {
        tables: true,
        albedos: false,
        previews: false,
    };
    /// Only the albedos (`lobe albedo --scene`).
    pub const ALBEDOS: Outputs = Outputs {
        tables: false,
        albedos: true,
        previews: false,
    };
    /// Only the previews (`lobe preview --scene`).
    pub const PREVIEWS: Outputs = Outputs {
        tables: false,
        albedos: false,
        previews: true,
    };
}

/// What a run produced.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Every file written, in order: a table's .exr, .npy and .json, an albedo's .json, a
    /// preview's .png and .exr.
    pub written: Vec<PathBuf>,
    /// One line per output (a table, an albedo, a preview), as `log` received it.
    pub lines: Vec<String>,
}

/// View directions μ = cos θo at which a scene's `[[albedos]]` report E(μ) (φo = 0), beside the
/// hemispherical albedo: grazing, halfway and normal view, as `lobe albedo` by default, and two
/// between.
pub const ALBEDO_MU: [f64; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

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

    /// The parameters of preview cell (material `row`, column `model`): the material's own when
    /// its model has that name (a microfacet material keeps its own components), else its preset
    /// for `model`.
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
        let text = include_str!("../../data/scenes/lab.toml");
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

    /// The first TOML block after `marker` in `text`, with `prefix` taken off each line.
    fn toml_block(text: &str, marker: &str, prefix: &str) -> String {
        let lines: Vec<&str> = text
            .lines()
            .map(|l| {
                l.strip_prefix(prefix)
                    .unwrap_or(l.trim_start_matches(prefix.trim_end()))
            })
            .collect();
        let start = lines
            .iter()
            .position(|l| l.trim() == marker)
            .expect("the example's opening fence");
        let len = lines[start + 1..]
            .iter()
            .position(|l| l.trim() == "```")
            .expect("the example's closing fence");
        lines[start + 1..start + 1 + len].join("\n")
    }

    /// docs/scenes.md's example parses, and the module doc's is the same scene.
    #[test]
    fn the_documented_examples_parse_and_agree() {
        let docs = toml_block(include_str!("../../docs/scenes.md"), "```toml", "");
        let here = toml_block(include_str!("mod.rs"), "```toml", "//! ");
        let a = parse(&docs, "example.toml").unwrap_or_else(|e| panic!("docs/scenes.md: {e}"));
        let b = parse(&here, "example.toml").unwrap_or_else(|e| panic!("module doc: {e}"));
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(a.tables.len(), 2);
        assert_eq!(a.previews[0].models.len(), 2);
    }
}
