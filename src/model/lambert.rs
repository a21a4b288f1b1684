//! Lambert: f = albedo / π. Twin of `glsl/brdf/lambert.glsl`.

use super::params::ParamSpec;
use super::registry::{always_isotropic, no_exponent, white_albedo, LutAxis, ModelInfo};
use super::{f32x3, Layout, ParamSet};
use crate::lut::Mapping;
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

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "lambert",
    description: "ideal diffuse: albedo/pi",
    params: PARAMS,
    gpu_struct: "LambertParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<LambertParams>(),
    has_delta: false,
    pow_lobe: false,
    has_specular_fresnel: false,
    lut_axis: LutAxis {
        keys: &["albedo"],
        lo: 0.0,
        hi: 1.0,
        mapping: Mapping::Linear,
    },
    white: white_albedo,
    stability_edges: |_| STABILITY_EDGES.to_vec(),
    exponent: no_exponent,
    is_isotropic: always_isotropic,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[&["albedo=0"], &["albedo=1"]];

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
