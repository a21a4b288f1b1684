//! Shirley's smooth layered model: F_s(c_o) δ_mirror + diffuse/π. The functions here return the
//! non-delta part; [`smooth_layered_delta`] gives the spike's albedo. Twin of
//! `glsl/brdf/smooth_layered.glsl`.

use super::params::ParamSpec;
use super::terms::{r0_from_ior, F_schlick};
use super::{f32x3, Layout, ParamSet};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use std::f64::consts::FRAC_1_PI;
use std::mem::offset_of;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("diffuse", 0.5, "Lambertian base"),
    ParamSpec::scalar(
        "ior",
        1.0,
        5.0,
        1.5,
        "index of refraction of the smooth coat",
    ),
];

#[derive(Clone, Copy, Debug)]
pub struct SmoothLayered {
    pub diffuse: DVec3,
    pub ior: f64,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SmoothLayeredParams {
    pub diffuse: [f32; 3],
    pub ior: f32,
}

pub const GPU_LAYOUT: Layout = &[
    ("diffuse", offset_of!(SmoothLayeredParams, diffuse)),
    ("ior", offset_of!(SmoothLayeredParams, ior)),
];

impl SmoothLayered {
    pub fn new(p: &ParamSet) -> Self {
        SmoothLayered {
            diffuse: p.rgb("diffuse"),
            ior: p.scalar("ior"),
        }
    }

    pub fn gpu_params(&self) -> SmoothLayeredParams {
        SmoothLayeredParams {
            diffuse: f32x3(self.diffuse),
            ior: self.ior as f32,
        }
    }
}

pub fn smooth_layered(p: &SmoothLayered, _wi: DVec3, _wo: DVec3) -> DVec3 {
    p.diffuse * FRAC_1_PI
}

/// Albedo of the mirror spike seen from c_o: F_s(c_o).
pub fn smooth_layered_delta(p: &SmoothLayered, c_o: f64) -> DVec3 {
    F_schlick(c_o, DVec3::splat(r0_from_ior(p.ior)))
}
