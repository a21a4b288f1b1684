//! A preview scene as the backends render it: the object in every cell, the camera, the lights
//! and the sky (docs/design.md §3; the lab's set-up is made by `Scene::lab` in the preview job).
//! Every number is representable in f32, so the GPU and the CPU twin start from identical inputs.

use anyhow::{Context, Result};
use glam::DVec3;

/// The object drawn in every cell of the sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A sphere, shaded with its smooth normal.
    Sphere,
    /// The lab report's regular icosahedron, one normal per flat face.
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

    /// The code the preview kernel switches on.
    pub fn code(self) -> u32 {
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

impl Scene {
    /// Width / height of a cell, rounded to f32 as the kernel reads it.
    pub fn aspect(&self) -> f64 {
        (self.cell_width as f64 / self.cell_height as f64) as f32 as f64
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
}
