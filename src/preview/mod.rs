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
mod sheet;

pub use crate::backend::scene::{Light, LightKind, Scene, Shape};
pub use crate::backend::shade::{
    icosahedron_normal, intersect, radiance_along, render_cells_cpu, shade,
};
pub use sheet::{
    caption, encode_exr, encode_png, read_exr, srgb_encode, tone_map, write_exr, write_png, Sheet,
    SheetImage,
};

use crate::backend::Query;
use crate::eval::Evaluator;
use crate::model::{Model, ParamSet};
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
            e.supports(*model)?;
            let sets: Vec<ParamSet> = group.iter().map(|&row| column[row].clone()).collect();
            let pixels = e
                .backend()
                .preview(
                    Query {
                        sets: &sets,
                        white_furnace: false,
                    },
                    scene,
                )
                .with_context(|| format!("rendering the {} column", model.name()))?;
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
