//! Shirley's smooth layered model: F_s(c_o) δ_mirror + diffuse/π. The functions here return the
//! non-delta part; [`smooth_layered_delta`] gives the spike's albedo. Twin of
//! `glsl/brdf/smooth_layered.glsl`.

use super::info::{always_isotropic, no_exponent, no_v_cavity, LutAxis, ModelInfo};
use super::params::{ParamError, ParamSpec, Value};
use super::sample::{luminance, mixture_share, pdf_cosine, sample_cosine, Sample};
use super::sampling::no_lobes;
use super::terms::{r0_from_ior, F_schlick};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::FRAC_1_PI;
use std::mem::offset_of;

/// The parameter table: the Lambertian base and the coat's IOR in [1, 5].
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

/// The smooth layered model's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct SmoothLayered {
    /// Reflectance of the Lambertian base, linear RGB.
    pub diffuse: DVec3,
    /// Relative index of refraction of the smooth coat, which sets the spike's Schlick R0.
    pub ior: f64,
}

/// std430 twin of the GLSL `SmoothLayeredParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`SmoothLayered::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SmoothLayeredParams {
    /// `diffuse` / π (the mirror spike is the integrators' and the draws kernel's, from `r0`).
    pub diffuse_over_pi: [f32; 3],
    /// Schlick's R0 from `ior`, for the mirror spike's albedo in the sampler.
    pub r0: f32,
}

/// Byte offset of every field of [`SmoothLayeredParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    (
        "diffuse_over_pi",
        offset_of!(SmoothLayeredParams, diffuse_over_pi),
    ),
    ("r0", offset_of!(SmoothLayeredParams, r0)),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "smooth_layered",
    description:
        "Shirley's smooth layered: Fresnel mirror spike (delta) over Lambert; gains energy",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "SmoothLayeredParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<SmoothLayeredParams>(),
    has_delta: true,
    pow_lobe: false,
    has_specular_fresnel: false,
    lut_axis: LutAxis {
        keys: &["ior"],
        lo: 1.0,
        hi: 3.0,
        mapping: Mapping::Linear,
    },
    white: white_configuration,
    stability_edges: |_| STABILITY_EDGES.to_vec(),
    exponent: no_exponent,
    is_isotropic: always_isotropic,
    sampling_lobes: no_lobes,
    v_cavity: no_v_cavity,
    interleave_table: false,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[&["diffuse=1", "ior=1"], &["diffuse=0", "ior=5"]];

/// The white configuration: diffuse = 1 − R0, so that the layer would reflect exactly 1 at
/// normal incidence if it conserved energy (it gains towards grazing, which `lobe energy` shows).
fn white_configuration(p: &mut ParamSet) -> Result<bool, ParamError> {
    let r0 = r0_from_ior(p.scalar("ior"));
    p.set("diffuse", Value::One(1.0 - r0))?;
    Ok(false)
}

impl SmoothLayered {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        SmoothLayered {
            diffuse: p.rgb("diffuse"),
            ior: p.scalar("ior"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> SmoothLayeredParams {
        SmoothLayeredParams {
            diffuse_over_pi: f32x3(self.diffuse * FRAC_1_PI),
            r0: r0_from_ior(self.ior) as f32,
        }
    }
}

/// The non-delta part, diffuse/π in 1/sr; the mirror spike is in [`smooth_layered_delta`].
pub fn smooth_layered(p: &SmoothLayered, _wi: DVec3, _wo: DVec3) -> DVec3 {
    p.diffuse * FRAC_1_PI
}

/// Albedo of the mirror spike seen from c_o: F_s(c_o).
pub fn smooth_layered_delta(p: &SmoothLayered, c_o: f64) -> DVec3 {
    F_schlick(c_o, DVec3::splat(r0_from_ior(p.ior)))
}

/// The probability of choosing the mirror spike: the luminance of its albedo F_s(c_o) against
/// that of `diffuse` (the base's albedo, exact), so that both components' weights are about the total albedo.
pub fn smooth_layered_spike_probability(p: &SmoothLayered, wo: DVec3) -> f64 {
    mixture_share(
        luminance(smooth_layered_delta(p, wo.z)),
        luminance(p.diffuse),
    )
}

/// Draws the mirror spike (a delta sample: ωi the mirror direction of ωo, pdf the
/// probability P of choosing it, weight F_s(c_o)/P) with probability
/// [`smooth_layered_spike_probability`] by `uc`, else ωi by the cosine for the non-delta part.
pub fn sample_smooth_layered(p: &SmoothLayered, wo: DVec3, uc: f64, u: DVec2) -> Sample {
    let spike = smooth_layered_spike_probability(p, wo);
    if uc < spike {
        return Sample::spike(wo, spike, smooth_layered_delta(p, wo.z));
    }
    let wi = sample_cosine(u);
    Sample::from_draw(wi, pdf_smooth_layered(p, wi, wo), |wi| {
        smooth_layered(p, wi, wo)
    })
}

/// The density of [`sample_smooth_layered`]'s non-delta draws: (1 − P) cos θi/π, P the spike's
/// probability; over the hemisphere it integrates to 1 − P.
pub fn pdf_smooth_layered(p: &SmoothLayered, wi: DVec3, wo: DVec3) -> f64 {
    (1.0 - smooth_layered_spike_probability(p, wo)) * pdf_cosine(wi)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn smooth_layered_sampler_and_pdf() {
        for set in [&["diffuse=0.5"][..], &["diffuse=0.1", "ior=3"]] {
            check_reference(&params(Model::SmoothLayered, set), false, 0.8);
        }
    }
}
