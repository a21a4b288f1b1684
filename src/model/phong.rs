//! Normalized Phong (Lafortune & Willems 1994): f = diffuse/π + specular (n+2)/(2π) max(0, r·ωo)^n,
//! r = 2 c_i n − ωi. Twin of `glsl/brdf/phong.glsl`.

use super::params::ParamSpec;
use super::terms::pow1m;
use super::{f32x3, Layout, ParamSet};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, PI};
use std::mem::offset_of;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("diffuse", 0.5, "Lambertian reflectance"),
    ParamSpec::rgb("specular", 0.5, "specular reflectance at normal incidence"),
    ParamSpec::scalar(
        "shininess",
        0.0,
        1e6,
        32.0,
        "Phong exponent n (the seed's maximum is 8192)",
    ),
];

#[derive(Clone, Copy, Debug)]
pub struct Phong {
    pub diffuse: DVec3,
    pub specular: DVec3,
    pub shininess: f64,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PhongParams {
    pub diffuse: [f32; 3],
    pub shininess: f32,
    pub specular: [f32; 3],
    pub _pad: f32,
}

pub const GPU_LAYOUT: Layout = &[
    ("diffuse", offset_of!(PhongParams, diffuse)),
    ("shininess", offset_of!(PhongParams, shininess)),
    ("specular", offset_of!(PhongParams, specular)),
];

impl Phong {
    pub fn new(p: &ParamSet) -> Self {
        Phong {
            diffuse: p.rgb("diffuse"),
            specular: p.rgb("specular"),
            shininess: p.scalar("shininess"),
        }
    }

    pub fn gpu_params(&self) -> PhongParams {
        PhongParams {
            diffuse: f32x3(self.diffuse),
            shininess: self.shininess as f32,
            specular: f32x3(self.specular),
            _pad: 0.0,
        }
    }
}

pub fn phong(p: &Phong, wi: DVec3, wo: DVec3) -> DVec3 {
    let r = DVec3::new(-wi.x, -wi.y, wi.z); // mirror of wi about n = +z: 2 c_i n − wi
                                            // 1 − r·ωo = |r − ωo|²/2 for unit vectors: no cancellation near the mirror direction.
    let s = 0.5 * (r - wo).length_squared();
    let lobe = (p.shininess + 2.0) / (2.0 * PI) * pow1m(s, p.shininess);
    p.diffuse * FRAC_1_PI + p.specular * lobe
}
