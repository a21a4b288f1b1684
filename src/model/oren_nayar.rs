//! Oren & Nayar 1994, the qualitative model, written without angles.
//! Twin of `glsl/brdf/oren_nayar.glsl`.

use super::info::{always_isotropic, no_exponent, no_v_cavity, white_albedo, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sample::{pdf_cosine, sample_by_cosine, Sample};
use super::sampling::no_lobes;
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2};
use std::mem::offset_of;

/// The parameter table: the facets' albedo and the slope deviation σ in [0, π/2] radians.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("albedo", 0.8, "reflectance of the facets"),
    ParamSpec::scalar(
        "sigma",
        0.0,
        FRAC_PI_2,
        0.3,
        "roughness: standard deviation of facet slope angle, radians",
    ),
];

/// Oren–Nayar's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct OrenNayar {
    /// Reflectance of the Lambertian facets, linear RGB.
    pub albedo: DVec3,
    /// Standard deviation of the facet slope angle, radians; 0 is Lambert.
    pub sigma: f64,
}

/// std430 twin of the GLSL `OrenNayarParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`OrenNayar::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct OrenNayarParams {
    /// `albedo` / π.
    pub albedo_over_pi: [f32; 3],
    /// The coefficient A ([`OrenNayar::a_b`]).
    pub a: f32,
    /// The coefficient B.
    pub b: f32,
    /// Padding to the std430 size of 32 bytes; always 0.
    pub _pad: [f32; 3],
}

/// Byte offset of every field of [`OrenNayarParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    (
        "albedo_over_pi",
        offset_of!(OrenNayarParams, albedo_over_pi),
    ),
    ("a", offset_of!(OrenNayarParams, a)),
    ("b", offset_of!(OrenNayarParams, b)),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "oren_nayar",
    description: "Oren-Nayar qualitative model: rough diffuse with retro-reflection",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "OrenNayarParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<OrenNayarParams>(),
    has_delta: false,
    pow_lobe: false,
    has_specular_fresnel: false,
    lut_axis: LutAxis {
        keys: &["sigma"],
        lo: 0.0,
        hi: FRAC_PI_2,
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
const STABILITY_EDGES: &[&[&str]] = &[
    &["sigma=0"],
    &["sigma=1e-4"],
    &["albedo=1", "sigma=1.5707963267948966"],
];

impl OrenNayar {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        OrenNayar {
            albedo: p.rgb("albedo"),
            sigma: p.scalar("sigma"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> OrenNayarParams {
        let (a, b) = self.a_b();
        OrenNayarParams {
            albedo_over_pi: f32x3(self.albedo * FRAC_1_PI),
            a: a as f32,
            b: b as f32,
            _pad: [0.0; 3],
        }
    }

    /// The coefficients A and B of the qualitative model.
    pub fn a_b(&self) -> (f64, f64) {
        let s2 = self.sigma * self.sigma;
        (1.0 - 0.5 * s2 / (s2 + 0.33), 0.45 * s2 / (s2 + 0.09))
    }
}

/// f = albedo/π (A + B max(0, cos(φi − φo)) sinα tanβ) in 1/sr, written with dot products:
/// sinα tanβ cos(φi − φo) = (ωi·ωo − c_i c_o)/max(c_i, c_o).
pub fn oren_nayar(p: &OrenNayar, wi: DVec3, wo: DVec3) -> DVec3 {
    let (a, b) = p.a_b();
    let s = (wi.dot(wo) - wi.z * wo.z).max(0.0);
    p.albedo * FRAC_1_PI * (a + b * s / wi.z.max(wo.z))
}

/// Draws ωi by the cosine ([`sample_by_cosine`]): the weight is albedo (A + B max(0,
/// cos(φi − φo)) sinα tanβ), which is at most albedo (A + B tan θo) for ωo fixed. `uc` is
/// unused.
pub fn sample_oren_nayar(p: &OrenNayar, wo: DVec3, _uc: f64, u: DVec2) -> Sample {
    sample_by_cosine(u, |wi| oren_nayar(p, wi, wo))
}

/// The density of [`sample_oren_nayar`]: cos θi / π.
pub fn pdf_oren_nayar(_p: &OrenNayar, wi: DVec3, _wo: DVec3) -> f64 {
    pdf_cosine(wi)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn oren_nayar_sampler_and_pdf() {
        for set in [&["sigma=0.3"][..], &["albedo=0.5", "sigma=1.2"]] {
            check_reference(&params(Model::OrenNayar, set), false, 0.8);
        }
    }
}
