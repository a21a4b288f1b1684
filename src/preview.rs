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

use crate::eval::{Backend, Evaluator};
use crate::gpu::preview::{GpuLight, GpuObject, GpuSceneHeader};
use crate::material;
use crate::model::{Brdf, Model, ParamSet, Reference};
use crate::output::write_atomic;
use anyhow::{bail, Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;

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

/// The golden ratio.
const PHI: f64 = 1.618_033_988_749_895;
/// Inradius / circumradius of a regular icosahedron: φ² / (√3 √(1 + φ²)).
const ICOSAHEDRON_INRADIUS: f64 = 0.794_654_472_291_766_1;

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

/// Outward unit normal of face k (0..19) of the icosahedron with vertices at the cyclic
/// permutations of (0, ±1, ±φ): the face centres are the vertices of the dual dodecahedron,
/// (±1, ±1, ±1) and the cyclic permutations of (±1/φ, 0, ±φ), all of length √3.
pub fn icosahedron_normal(k: usize) -> DVec3 {
    let sign = |bit: usize| if k & bit != 0 { -1.0 } else { 1.0 };
    let v = if k < 8 {
        DVec3::new(sign(1), sign(2), sign(4))
    } else {
        let j = k - 8;
        let a = if j & 1 != 0 { -1.0 / PHI } else { 1.0 / PHI };
        let b = if j & 2 != 0 { -PHI } else { PHI };
        match j >> 2 {
            0 => DVec3::new(a, 0.0, b),
            1 => DVec3::new(b, a, 0.0),
            _ => DVec3::new(0.0, b, a),
        }
    };
    v / 3f64.sqrt()
}

/// Nearest hit of the ray t·d (t > 0, from the camera at the origin) with the scene's object: t
/// and the outward unit normal.
pub fn intersect(scene: &Scene, d: DVec3) -> Option<(f64, DVec3)> {
    let (c, r) = (scene.centre, scene.radius);
    match scene.shape {
        Shape::Sphere => {
            // Haines, Günther & Akenine-Möller, "Precision improvements for ray/sphere
            // intersection" (Ray Tracing Gems, 2019, ch. 7): the discriminant as r² − |c − b d|²
            // has no cancellation at the silhouette, and the near root as c/q avoids b − √disc.
            let b = d.dot(c);
            let f = c - b * d;
            let disc = r * r - f.dot(f);
            if disc < 0.0 || b <= 0.0 {
                return None;
            }
            let q = b + disc.sqrt();
            let t = (c.dot(c) - r * r) / q;
            Some((t, (t * d - c) / r))
        }
        Shape::Icosahedron => {
            // Convex polyhedron as the intersection of its face half-spaces (Haines, "Fast
            // ray-convex polyhedron intersection", Graphics Gems II, 1991).
            let inradius = r * ICOSAHEDRON_INRADIUS;
            let (mut t_near, mut t_far) = (0.0f64, f64::INFINITY);
            let mut n = DVec3::Z;
            for k in 0..20 {
                let nk = icosahedron_normal(k);
                let offset = inradius + nk.dot(c);
                let denom = nk.dot(d);
                if denom == 0.0 {
                    if offset < 0.0 {
                        return None;
                    }
                    continue;
                }
                let t = offset / denom;
                if denom < 0.0 {
                    if t > t_near {
                        t_near = t;
                        n = nk;
                    }
                } else {
                    t_far = t_far.min(t);
                }
            }
            (t_near > 0.0 && t_near <= t_far).then_some((t_near, n))
        }
    }
}

/// The radiance toward the camera from the point p = t·d with outward normal n.
pub fn shade(r: &Reference, scene: &Scene, p: DVec3, n: DVec3, d: DVec3) -> DVec3 {
    let t = DVec3::Y.cross(n);
    let tl = t.length();
    // Same threshold as the kernel: n within ~1e-6 rad of ±y has no latitude direction.
    let t = if tl > 1e-6 { t / tl } else { DVec3::X };
    let bt = n.cross(t);
    let local = |w: DVec3| DVec3::new(w.dot(t), w.dot(bt), w.dot(n));
    let wo = local(-d);
    let mut radiance = DVec3::ZERO;
    for light in &scene.lights {
        let (to_light, e) = match light.kind {
            LightKind::Point => {
                let l = light.position - p;
                (l, light.intensity / l.length_squared())
            }
            LightKind::Directional => (light.position, light.intensity),
        };
        let wi = local(to_light.normalize());
        radiance += r.eval(wi, wo) * wi.z.max(0.0) * e;
    }
    radiance + scene.ambient * PI * r.eval(DVec3::Z, wo)
}

/// The radiance along the camera ray d (0 where it misses).
pub fn radiance_along(r: &Reference, scene: &Scene, d: DVec3) -> DVec3 {
    match intersect(scene, d) {
        Some((t, n)) => shade(r, scene, t * d, n, d),
        None => DVec3::ZERO,
    }
}

/// Every pixel of one cell per reference, in the GPU's order (cell, row from the top, column).
pub fn render_cells_cpu(refs: &[Reference], scene: &Scene) -> Vec<[f32; 3]> {
    let (w, h) = (scene.cell_width as usize, scene.cell_height as usize);
    let mut out = vec![[0.0f32; 3]; refs.len() * w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(row, line)| {
        let (cell, y) = (row / h, row % h);
        for (x, px) in line.iter_mut().enumerate() {
            let l = radiance_along(&refs[cell], scene, scene.camera_ray(x as u32, y as u32));
            *px = [l.x as f32, l.y as f32, l.z as f32];
        }
    });
    out
}

/// Which model and material each cell holds: `params[column][row]`.
#[derive(Clone, Debug)]
pub struct Sheet {
    /// The rows' material names, top to bottom.
    pub materials: Vec<String>,
    /// The columns' models, left to right.
    pub models: Vec<Model>,
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
                    .map(|name| material::preset(name, m))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Sheet {
            materials: materials.to_vec(),
            models: models.to_vec(),
            params,
        })
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
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|Vec2(x, y)| {
        let [r, g, b] = image.pixel(x, y);
        (r, g, b)
    });
    let mut layer = Layer::new(
        (image.width(), image.height()),
        LayerAttributes::named("lobe preview"),
        Encoding::FAST_LOSSLESS,
        channels,
    );
    let columns: Vec<&str> = sheet.models.iter().map(|m| m.name()).collect();
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
    write_atomic(path, |w| {
        Image::from_layer(layer)
            .write()
            .to_buffered(w)
            .map_err(|e| anyhow::anyhow!("EXR encoder: {e}"))
            .with_context(|| format!("writing {}", path.display()))
    })
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

/// An 8-bit RGB canvas.
struct Canvas {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

impl Canvas {
    fn put(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let k = 3 * (y * self.width + x);
            self.rgb[k..k + 3].copy_from_slice(&c);
        }
    }

    /// Draws `text` (upper-cased) with its top left corner at (x, y), each font pixel a
    /// `scale`×`scale` square; stops at `max_x`.
    fn text(&mut self, text: &str, x: usize, y: usize, scale: usize, max_x: usize, c: [u8; 3]) {
        for (i, ch) in text.chars().enumerate() {
            let x0 = x + i * font::ADVANCE * scale;
            if x0 + font::WIDTH * scale > max_x {
                break;
            }
            for (row, bits) in font::glyph(ch).iter().enumerate() {
                for col in 0..font::WIDTH {
                    if bits >> (font::WIDTH - 1 - col) & 1 == 1 {
                        for dy in 0..scale {
                            for dx in 0..scale {
                                self.put(x0 + col * scale + dx, y + row * scale + dy, c);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Width in pixels of `text` at `scale`.
fn text_width(text: &str, scale: usize) -> usize {
    let n = text.chars().count();
    if n == 0 {
        0
    } else {
        (n * font::ADVANCE - (font::ADVANCE - font::WIDTH)) * scale
    }
}

/// Splits `text` at "; " into lines of at most `width` pixels at scale 1 (a part longer than a
/// line gets a line of its own and is cut when drawn).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for part in text.split("; ") {
        match lines.last_mut() {
            Some(last) if text_width(&format!("{last}; {part}"), 1) <= width => {
                last.push_str("; ");
                last.push_str(part);
            }
            _ => lines.push(part.to_string()),
        }
    }
    lines
}

/// Writes the labelled contact sheet as an 8-bit sRGB PNG: model names above the columns,
/// material names left of the rows, `caption` along the bottom (wrapped); radiance tone-mapped by
/// [`tone_map`] at `exposure` stops. Through a temporary file renamed into place. Returns the
/// PNG's (width, height): the cells plus the label margins.
pub fn write_png(
    image: &SheetImage,
    sheet: &Sheet,
    exposure: f64,
    caption: &str,
    path: &Path,
) -> Result<(usize, usize)> {
    let (cw, ch) = (image.cell_width, image.cell_height);
    let columns: Vec<String> = sheet.models.iter().map(|m| m.name().to_string()).collect();
    // Labels at twice the font's size where every column name fits its cell, else at 1.
    let scale = if columns.iter().all(|l| text_width(l, 2) + 2 <= cw) {
        2
    } else {
        1
    };
    let line = font::HEIGHT * scale + 2 * LABEL_PAD;
    let left = sheet
        .materials
        .iter()
        .map(|m| text_width(m, scale))
        .max()
        .unwrap_or(0)
        + 2 * LABEL_PAD;
    let width = left + image.width();
    let caption_lines = wrap(caption, width.saturating_sub(2 * LABEL_PAD));
    let caption_height = caption_lines.len() * (font::HEIGHT + LABEL_PAD) + LABEL_PAD;
    let height = line + image.height() + caption_height;
    let mut canvas = Canvas {
        width,
        height,
        rgb: LABEL_BACKGROUND.repeat(width * height),
    };
    for y in 0..image.height() {
        for x in 0..image.width() {
            let c = image.pixel(x, y).map(|v| tone_map(v, exposure));
            canvas.put(left + x, line + y, c);
        }
    }
    for (col, label) in columns.iter().enumerate() {
        let x0 = left + col * cw;
        let x = x0 + cw.saturating_sub(text_width(label, scale)) / 2;
        canvas.text(label, x, LABEL_PAD, scale, x0 + cw, LABEL_TEXT);
    }
    for (row, label) in sheet.materials.iter().enumerate() {
        let y = line + row * ch + ch.saturating_sub(font::HEIGHT * scale) / 2;
        canvas.text(label, LABEL_PAD, y, scale, left, LABEL_TEXT);
    }
    for (k, text) in caption_lines.iter().enumerate() {
        let y = line + image.height() + LABEL_PAD + k * (font::HEIGHT + LABEL_PAD);
        canvas.text(text, LABEL_PAD, y, 1, width, CAPTION_TEXT);
    }

    write_atomic(path, |w| {
        let mut encoder = png::Encoder::new(w, width as u32, height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder
            .write_header()
            .with_context(|| format!("writing {}", path.display()))?;
        writer
            .write_image_data(&canvas.rgb)
            .with_context(|| format!("writing {}", path.display()))?;
        writer
            .finish()
            .with_context(|| format!("writing {}", path.display()))
    })?;
    Ok((width, height))
}

/// A 5×7 bitmap font of upper-case letters, digits and the punctuation that names and captions
/// use; lower case is drawn as upper case. Each glyph is seven rows, top first, of five bits,
/// the leftmost pixel in bit 4 (the classic 5×7 dot-matrix shapes).
mod font {
    pub const WIDTH: usize = 5;
    pub const HEIGHT: usize = 7;
    /// Glyph width plus one column of space.
    pub const ADVANCE: usize = 6;

    pub fn glyph(c: char) -> [u8; 7] {
        match c.to_ascii_uppercase() {
            'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
            'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
            'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
            'D' => [0x1E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1E],
            'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
            'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
            'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
            'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
            'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
            'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
            'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
            'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
            'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
            'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
            'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
            'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
            'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
            'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
            'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
            'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
            'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
            'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
            'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
            'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
            'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
            'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
            '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
            '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
            '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
            '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
            '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
            '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
            '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
            '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
            '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
            '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
            '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
            '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
            '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
            '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
            ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
            ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
            ';' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x04, 0x08],
            '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
            '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
            '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
            ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
            '[' => [0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E],
            ']' => [0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E],
            ' ' => [0; 7],
            _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04], // '?'
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosahedron_normals_are_the_twenty_face_directions() {
        let normals: Vec<DVec3> = (0..20).map(icosahedron_normal).collect();
        for (k, n) in normals.iter().enumerate() {
            assert!(
                (n.length() - 1.0).abs() < 1e-12,
                "face {k}: |n| = {}",
                n.length()
            );
            for m in &normals[..k] {
                assert!(n.dot(*m) < 1.0 - 1e-6, "face {k} repeats another");
            }
        }
        // Each vertex (0, ±1, ±φ) touches five faces; their planes all pass through it.
        let circumradius = (1.0 + PHI * PHI).sqrt();
        let vertex = DVec3::new(0.0, 1.0, PHI) / circumradius;
        let touching = normals
            .iter()
            .filter(|n| (n.dot(vertex) - ICOSAHEDRON_INRADIUS).abs() < 1e-12)
            .count();
        assert_eq!(touching, 5);
    }

    #[test]
    fn camera_ray_and_project_are_inverse() {
        let scene = Scene::lab(64, Shape::Sphere, LightKind::Point, DVec3::ZERO);
        for (x, y) in [(0, 0), (10, 50), (63, 63), (32, 5)] {
            let d = scene.camera_ray(x, y);
            let (px, py) = scene.project(d * 3.0);
            assert!((px - x as f64).abs() < 1e-9 && (py - y as f64).abs() < 1e-9);
        }
    }

    #[test]
    fn white_lambertian_reads_one_at_the_nearest_point() {
        let mut p = ParamSet::defaults(Model::Lambert);
        p.set_text("albedo=1").unwrap();
        let r = Reference::new(&p, false);
        for kind in [LightKind::Point, LightKind::Directional] {
            let scene = Scene::lab(65, Shape::Sphere, kind, DVec3::ZERO);
            let l = radiance_along(&r, &scene, -DVec3::Z);
            assert!((l - DVec3::ONE).abs().max_element() < 1e-6, "{kind:?}: {l}");
        }
    }

    #[test]
    fn ambient_is_exact_for_lambert() {
        let mut p = ParamSet::defaults(Model::Lambert);
        p.set_text("albedo=0.5").unwrap();
        let r = Reference::new(&p, false);
        let mut scene = Scene::lab(33, Shape::Sphere, LightKind::Point, DVec3::splat(0.25));
        scene.lights.clear();
        let l = radiance_along(&r, &scene, scene.camera_ray(20, 11));
        assert!((l - DVec3::splat(0.125)).abs().max_element() < 1e-12, "{l}");
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(tone_map(0.0, 0.0), 0);
        assert_eq!(tone_map(1.0, 0.0), 255);
        assert_eq!(tone_map(0.5, 1.0), 255);
        // 18 % grey is sRGB 0.4614 (IEC 61966-2-1), 117.6 of 255.
        assert_eq!(tone_map(0.18, 0.0), 118);
    }

    #[test]
    fn every_glyph_fits_five_columns() {
        for c in (' '..='~').chain(['φ']) {
            assert!(font::glyph(c).iter().all(|&r| r < 32), "{c}");
        }
    }
}
