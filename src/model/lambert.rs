//! Lambert: f = albedo / π. Twin of `glsl/brdf/lambert.glsl`.

use super::params::ParamSpec;
use super::{f32x3, Layout, ParamSet};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use std::f64::consts::FRAC_1_PI;
use std::mem::offset_of;

pub const PARAMS: &[ParamSpec] = &[ParamSpec::rgb(
    "albedo",
    0.8,
    "reflectance: the directional albedo at every angle",
)];

#[derive(Clone, Copy, Debug)]
pub struct Lambert {
    pub albedo: DVec3,
}

/// std430 twin of the GLSL `LambertParams` (a vec3 rounds the struct up to 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LambertParams {
    pub albedo: [f32; 3],
    pub _pad: f32,
}

pub const GPU_LAYOUT: Layout = &[("albedo", offset_of!(LambertParams, albedo))];

impl Lambert {
    pub fn new(p: &ParamSet) -> Self {
        Lambert {
            albedo: p.rgb("albedo"),
        }
    }

    pub fn gpu_params(&self) -> LambertParams {
        LambertParams {
            albedo: f32x3(self.albedo),
            _pad: 0.0,
        }
    }
}

pub fn lambert(p: &Lambert, _wi: DVec3, _wo: DVec3) -> DVec3 {
    p.albedo * FRAC_1_PI
}
