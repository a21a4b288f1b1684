//! Lambert: f = albedo / π. Twin of `glsl/brdf/lambert.glsl`.

use super::info::{always_isotropic, no_exponent, no_v_cavity, white_albedo, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sample::{pdf_cosine, sample_by_cosine, Sample};
use super::sampling::no_lobes;
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::FRAC_1_PI;
use std::mem::offset_of;

/// The parameter table: one RGB albedo in [0, 1].
pub const PARAMS: &[ParamSpec] = &[ParamSpec::rgb(
    "albedo",
    0.8,
    "reflectance: the directional albedo at every angle",
)];

/// Lambert's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct Lambert {
    /// Directional albedo, the same at every angle, linear RGB.
    pub albedo: DVec3,
}

/// std430 twin of the GLSL `LambertParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`Lambert::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LambertParams {
    /// `albedo` / π.
    pub albedo_over_pi: [f32; 3],
    /// Padding to the 16-byte size of a std430 struct holding a vec3; always 0.
    pub _pad: f32,
}

/// Byte offset of every field of [`LambertParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[("albedo_over_pi", offset_of!(LambertParams, albedo_over_pi))];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "lambert",
    description: "ideal diffuse: albedo/pi",
    params: PARAMS,
    optional_keys: &[],
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
    sampling_lobes: no_lobes,
    v_cavity: no_v_cavity,
    interleave_table: false,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[&["albedo=0"], &["albedo=1"]];

impl Lambert {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        Lambert {
            albedo: p.rgb("albedo"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> LambertParams {
        LambertParams {
            albedo_over_pi: f32x3(self.albedo * FRAC_1_PI),
            _pad: 0.0,
        }
    }
}

/// f = albedo/π in 1/sr, whatever the directions (the horizon test is the caller's).
pub fn lambert(p: &Lambert, _wi: DVec3, _wo: DVec3) -> DVec3 {
    p.albedo * FRAC_1_PI
}

/// Draws ωi by the cosine (Malley's method, [`sample_by_cosine`]): the density is f's own shape,
/// so the weight is `albedo` exactly. `uc` is unused.
pub fn sample_lambert(p: &Lambert, wo: DVec3, _uc: f64, u: DVec2) -> Sample {
    sample_by_cosine(u, |wi| lambert(p, wi, wo))
}

/// The density of [`sample_lambert`]: cos θi / π.
pub fn pdf_lambert(_p: &Lambert, wi: DVec3, _wo: DVec3) -> f64 {
    pdf_cosine(wi)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn lambert_sampler_and_pdf() {
        check_reference(&params(Model::Lambert, &["albedo=0.8"]), false, 0.8);
    }
}
