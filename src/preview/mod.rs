//! `lobe preview`: a contact sheet of shaded objects, rows = materials, columns = models, under
//! the lab report's lights (docs/design.md §3). The GPU renders it with
//! `glsl/kernels/preview.comp`; this file is that kernel's f64 twin (the functions below mirror
//! it line by line) plus the sheet, the EXR (linear radiance) and the labelled, tone-mapped PNG.
//!
//! The scene, the same in every cell so that cells differ only in model and material:
//! - Camera at the origin looking down −z, +y up, +x right (OpenGL's eye space), square pixels,
//!   a vertical field of view of [`FOV_Y_DEG`], pixel centres at (x + ½, y + ½), row 0 on top.
//! - One object per cell centred at [`OBJECT_CENTRE`] = (0, 0, −3): a sphere of radius 1, or the
//!   lab's icosahedron of circumradius 1 (vertices at the cyclic permutations of (0, ±1, ±φ),
//!   scaled; flat faces, so each face has one normal).
//! - The lab's four lights at (0,0,1), (0,1,1), (1,0,1), (−1,0,1), read as **point lights at those
//!   positions in the camera's space**. Why: the lab gives them together with "camera at the
//!   origin", which is how OpenGL's fixed pipeline states light positions (GL_POSITION with w = 1,
//!   in eye coordinates); with the object in front of the camera, they sit one unit behind the
//!   image plane: a head light and three more above, right of and left of it, all lighting the
//!   visible side. `LightKind::Directional` reads the same vectors as directions toward the lights
//!   (OpenGL's w = 0) instead.
//! - All lights have the same intensity, chosen so that a white Lambertian at the object's point
//!   nearest to the camera (normal toward the camera) has radiance 1:
//!   I = π / Σ_l cosθ_l / d_l². Exposure 0 then maps a white diffuse surface to just below clip.
//! - Shading frame (docs/design.md §2: n = +z, t = +x, b = +y): n the outward normal,
//!   t = normalize(+y × n) — the sphere's lines of latitude, so the anisotropic presets are
//!   "brushed" horizontally — and b = n × t. Where n = ±y (never on a visible sphere point: those
//!   face away from the camera), t = +x.
//! - Radiance toward the camera: L = Σ_l f(ωi, ωo) cosθi I_l / d_l² (directional: E_l instead of
//!   I_l / d_l²). No shadow rays: a single convex object cannot shadow itself beyond cosθi ≤ 0,
//!   which the one-sided rule already makes 0.
//! - Delta lobes (`smooth_layered`, `coupled`): a point light is mirrored into the camera only
//!   along one exact direction (measure zero), so the spike adds nothing; the image shows the
//!   non-delta part, as lobe tables do. A real renderer would draw a pinpoint there.
//! - Ambient (`--ambient A`, off by default: the lab has none): a uniform sky of radiance A would
//!   add A·E(ωo), the directional albedo, which needs an integrator per pixel. Instead its
//!   irradiance π A is taken as arriving along the normal: L += A π f(n, ωo). Exact for Lambert,
//!   close for the diffuse models, and for a glossy lobe a soft highlight at the centre of the
//!   sphere (where ωo = n) in place of the true, uniform albedo; the mirror spike's exact share,
//!   A·F_s(c_o), is left out because the GLSL side has no delta function to mirror.
//!
//! The files: this one holds the scene and [`render`]; `shade.rs` the CPU twin of the kernel
//! (intersection, shading, radiance); `sheet.rs` the sheet's layout, its EXR and its labelled PNG;
//! `label.rs` the text the PNG's labels are drawn with.

mod label;
mod shade;
mod sheet;

pub use shade::{icosahedron_normal, intersect, radiance_along, render_cells_cpu, shade};
pub use sheet::{
    caption, encode_exr, encode_png, read_exr, srgb_encode, tone_map, write_exr, write_png, Sheet,
    SheetImage,
};

use crate::eval::{Backend, Evaluator};
use crate::gpu::preview::{GpuLight, GpuObject, GpuSceneHeader};
use crate::model::{Brdf, Model, Reference};
use anyhow::{bail, Context, Result};
use glam::DVec3;
use std::f64::consts::PI;

/// The lab's light positions (docs/design.md §3), in the camera's space (see the module's notes).
pub const LAB_LIGHTS: [[f64; 3]; 4] = [
    [0.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
];
/// Centre of every cell's object: three units in front of the camera.
pub const OBJECT_CENTRE: [f64; 3] = [0.0, 0.0, -3.0];
/// The sphere's radius and the icosahedron's circumradius.
pub const OBJECT_RADIUS: f64 = 1.0;
/// Vertical field of view: the sphere (angular radius asin(1/3) = 19.5°) then fills 85 % of the
/// cell's height, leaving a dark margin between cells.
pub const FOV_Y_DEG: f64 = 45.0;
/// Default cell size in pixels.
pub const DEFAULT_CELL: u32 = 128;

/// The most pixels of a contact sheet's cells: 2^26 (an 8192 x 8192 sheet), about 1 GB with the
/// linear radiance, the sRGB image and the encoders' buffers.
pub const MAX_SHEET_PIXELS: u64 = 1 << 26;

/// The object drawn in every cell of the sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A sphere of radius [`OBJECT_RADIUS`], shaded with its smooth normal.
    Sphere,
    /// The lab report's regular icosahedron of circumradius [`OBJECT_RADIUS`], one normal per flat
    /// face.
    Icosahedron,
}

impl Shape {
    /// Every shape, in the order the error for an unknown name lists them.
    pub const ALL: [Shape; 2] = [Shape::Sphere, Shape::Icosahedron];

    /// The shape's name on the command line and in scene files: `sphere` or `icosahedron`.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Sphere => "sphere",
            Shape::Icosahedron => "icosahedron",
        }
    }

    /// The shape called `name`; an unknown name is an error that lists the shapes.
    pub fn from_name(name: &str) -> Result<Shape> {
        Shape::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .with_context(|| format!("unknown shape '{name}'; the shapes are: sphere, icosahedron"))
    }

    /// The code `preview.comp` switches on.
    fn gpu_code(self) -> u32 {
        match self {
            Shape::Sphere => 0,
            Shape::Icosahedron => 1,
        }
    }
}

/// How the lab's light vectors are read (see the module's notes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    /// A point light at the position; intensity in W/sr, falling off as 1/d².
    Point,
    /// A light infinitely far along the vector; intensity is the irradiance at normal incidence.
    Directional,
}

/// One light of a preview scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// A point light's position in the camera's space, or, for a directional light, the vector
    /// toward it.
    pub position: DVec3,
    /// How `position` is read.
    pub kind: LightKind,
    /// RGB: W/sr (point) or W/m² (directional).
    pub intensity: DVec3,
}

/// Everything a cell's image depends on besides the model and its parameters. Every number is
/// representable in f32, so the GPU and the CPU twin start from identical inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Width of every cell, in pixels.
    pub cell_width: u32,
    /// Height of every cell, in pixels.
    pub cell_height: u32,
    /// tan(vertical field of view / 2).
    pub tan_half_fov: f64,
    /// The object in every cell.
    pub shape: Shape,
    /// The object's centre in the camera's space.
    pub centre: DVec3,
    /// The sphere's radius, or the icosahedron's circumradius.
    pub radius: f64,
    /// The lights whose contributions add up to the radiance.
    pub lights: Vec<Light>,
    /// RGB radiance of a uniform sky; 0 in the lab.
    pub ambient: DVec3,
}

fn f32_exact(x: f64) -> f64 {
    x as f32 as f64
}

fn f32_exact3(v: DVec3) -> DVec3 {
    DVec3::new(f32_exact(v.x), f32_exact(v.y), f32_exact(v.z))
}

impl Scene {
    /// The lab's set-up (docs/design.md §3) in square cells of `cell` pixels.
    pub fn lab(cell: u32, shape: Shape, kind: LightKind, ambient: DVec3) -> Scene {
        let centre = DVec3::from_array(OBJECT_CENTRE);
        let positions: Vec<DVec3> = LAB_LIGHTS.iter().map(|p| DVec3::from_array(*p)).collect();
        // A white Lambertian at the nearest point, normal +z, has L = Σ E_l / π: make that 1.
        let nearest = centre + DVec3::Z * OBJECT_RADIUS;
        let irradiance_per_unit: f64 = positions
            .iter()
            .map(|&p| match kind {
                LightKind::Point => {
                    let l = p - nearest;
                    (l.z / l.length()).max(0.0) / l.length_squared()
                }
                LightKind::Directional => (p.z / p.length()).max(0.0),
            })
            .sum();
        let intensity = f32_exact(PI / irradiance_per_unit);
        Scene {
            cell_width: cell,
            cell_height: cell,
            tan_half_fov: f32_exact((FOV_Y_DEG.to_radians() / 2.0).tan()),
            shape,
            centre,
            radius: OBJECT_RADIUS,
            lights: positions
                .into_iter()
                .map(|position| Light {
                    position,
                    kind,
                    intensity: DVec3::splat(intensity),
                })
                .collect(),
            ambient: f32_exact3(ambient),
        }
    }

    fn aspect(&self) -> f64 {
        f32_exact(self.cell_width as f64 / self.cell_height as f64)
    }

    /// Unit direction of the camera ray through the centre of pixel (x, y), row 0 on top.
    pub fn camera_ray(&self, x: u32, y: u32) -> DVec3 {
        let (w, h) = (self.cell_width as f64, self.cell_height as f64);
        let u = (2.0 * (x as f64 + 0.5) / w - 1.0) * self.tan_half_fov * self.aspect();
        let v = (1.0 - 2.0 * (y as f64 + 0.5) / h) * self.tan_half_fov;
        DVec3::new(u, v, -1.0).normalize()
    }

    /// The pixel (x, y), continuous, at which the point p (in front of the camera) appears: the
    /// inverse of [`Scene::camera_ray`].
    pub fn project(&self, p: DVec3) -> (f64, f64) {
        let (w, h) = (self.cell_width as f64, self.cell_height as f64);
        let u = p.x / -p.z / (self.tan_half_fov * self.aspect());
        let v = p.y / -p.z / self.tan_half_fov;
        ((u + 1.0) / 2.0 * w - 0.5, (1.0 - v) / 2.0 * h - 0.5)
    }

    /// The GPU's view of the scene for `cells` cells: header and lights.
    pub fn gpu_scene(&self, cells: usize) -> (GpuSceneHeader, Vec<GpuLight>) {
        let a = self.ambient;
        let header = GpuSceneHeader {
            dims: [
                self.cell_width,
                self.cell_height,
                cells as u32,
                self.lights.len() as u32,
            ],
            camera: [self.tan_half_fov as f32, self.aspect() as f32, 0.0, 0.0],
            ambient: [a.x as f32, a.y as f32, a.z as f32, 0.0],
        };
        let lights = self
            .lights
            .iter()
            .map(|l| {
                let (p, i) = (l.position, l.intensity);
                let w = match l.kind {
                    LightKind::Point => 1.0,
                    LightKind::Directional => 0.0,
                };
                GpuLight {
                    position: [p.x as f32, p.y as f32, p.z as f32, w],
                    intensity: [i.x as f32, i.y as f32, i.z as f32, 0.0],
                }
            })
            .collect();
        (header, lights)
    }

    /// One object per cell, cell k shaded with parameter block k.
    pub fn gpu_objects(&self, cells: usize) -> Vec<GpuObject> {
        let c = self.centre;
        (0..cells)
            .map(|k| GpuObject {
                centre: [c.x as f32, c.y as f32, c.z as f32],
                radius: self.radius as f32,
                shape: self.shape.gpu_code(),
                param_index: k as u32,
                pad: [0; 2],
            })
            .collect()
    }

    /// One-line description for file headers and captions.
    pub fn describe(&self) -> String {
        let kind = match self.lights.first().map(|l| l.kind) {
            Some(LightKind::Directional) => "directional",
            _ => "point",
        };
        format!(
            "{} of radius {} at ({}, {}, {}); camera at the origin looking down -z, +y up, vertical fov {} deg; \
{} {kind} lights at {} of intensity {:.4} (a white Lambertian facing the camera reads 1); ambient {}",
            self.shape.name(),
            self.radius,
            self.centre.x,
            self.centre.y,
            self.centre.z,
            FOV_Y_DEG,
            self.lights.len(),
            self.lights
                .iter()
                .map(|l| format!("({}, {}, {})", l.position.x, l.position.y, l.position.z))
                .collect::<Vec<_>>()
                .join(" "),
            self.lights.first().map_or(0.0, |l| l.intensity.x),
            ambient_text(self.ambient),
        )
    }
}

/// "none", one number for a grey sky, or r,g,b; printed as the f32 values they are.
fn ambient_text(a: DVec3) -> String {
    let [r, g, b] = a.to_array().map(|x| x as f32);
    if a == DVec3::ZERO {
        "none".to_string()
    } else if r == g && g == b {
        format!("{r}")
    } else {
        format!("{r},{g},{b}")
    }
}

/// Renders the sheet on `e`, one model (column) at a time: a pipeline carries one model, so each
/// column is one GPU job holding every material's parameter block of that model (or one job per
/// component choice, where materials choose different components of the microfacet model).
/// `progress` receives (columns done, columns).
pub fn render(
    e: &Evaluator,
    sheet: &Sheet,
    scene: &Scene,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<SheetImage> {
    let (w, h) = (scene.cell_width as usize, scene.cell_height as usize);
    if w == 0 || h == 0 {
        bail!("preview cells must be at least 1x1 pixel, not {w}x{h}");
    }
    let (rows, cols) = (sheet.materials.len(), sheet.models.len());
    let mut image = SheetImage {
        rows,
        cols,
        cell_width: w,
        cell_height: h,
        rgb: vec![[0.0; 3]; rows * cols * w * h],
    };
    let width = image.width();
    for (col, column) in sheet.params.iter().enumerate() {
        e.check_cancelled()?;
        // A material may select other components of the same model (the microfacet model's
        // distribution, masking and Fresnel are part of its pipeline): one job per pipeline.
        let mut groups: Vec<(Model, Vec<usize>)> = Vec::new();
        for (row, p) in column.iter().enumerate() {
            match groups.iter_mut().find(|(m, _)| *m == p.model()) {
                Some((_, rows)) => rows.push(row),
                None => groups.push((p.model(), vec![row])),
            }
        }
        for (model, group) in &groups {
            let cells = group.len();
            let pixels = match e.backend() {
                Backend::Gpu(gpu) => {
                    let blocks: Vec<Vec<u8>> = group
                        .iter()
                        .map(|&row| Brdf::new(&column[row]).gpu_block())
                        .collect();
                    let (header, lights) = scene.gpu_scene(cells);
                    let objects = scene.gpu_objects(cells);
                    gpu.render_preview(*model, &blocks, &header, &lights, &objects)
                        .with_context(|| format!("rendering the {} column", model.name()))?
                }
                Backend::Cpu => {
                    model.require_reference("the CPU backend")?;
                    let refs: Vec<Reference> = group
                        .iter()
                        .map(|&row| Reference::new(&column[row], false))
                        .collect();
                    render_cells_cpu(&refs, scene)
                }
            };
            // A pixel is a sum of f cosθi E over the lights: NaN, ±Inf or a negative f shows
            // in it (docs/design.md §2.1), and the preview is refused.
            let mut invalid = crate::finite::InvalidCount::default();
            for (k, px) in pixels.iter().enumerate() {
                invalid.add(k as u64, px.map(f64::from), || {
                    let (cell, rest) = (k / (w * h), k % (w * h));
                    let place = format!(
                        "pixel ({}, {}) of material {}",
                        rest % w,
                        rest / w,
                        sheet.materials[group[cell]]
                    );
                    (None, Some(place))
                });
            }
            invalid.refuse(model.name(), "preview")?;
            for (k, px) in pixels.into_iter().enumerate() {
                let (cell, rest) = (k / (w * h), k % (w * h));
                let (y, x) = (rest / w, rest % w);
                image.rgb[(group[cell] * h + y) * width + col * w + x] = px;
            }
        }
        progress(col + 1, cols);
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_ray_and_project_are_inverse() {
        let scene = Scene::lab(64, Shape::Sphere, LightKind::Point, DVec3::ZERO);
        for (x, y) in [(0, 0), (10, 50), (63, 63), (32, 5)] {
            let d = scene.camera_ray(x, y);
            let (px, py) = scene.project(d * 3.0);
            assert!((px - x as f64).abs() < 1e-9 && (py - y as f64).abs() < 1e-9);
        }
    }
}
