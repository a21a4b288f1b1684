//! Shirley et al. 1997, the coupled matte-specular model. The functions here return the non-delta
//! part; [`coupled_delta`] gives the spike's albedo. Twin of `glsl/brdf/coupled.glsl`.

use super::info::{always_isotropic, no_exponent, no_v_cavity, LutAxis, ModelInfo};
use super::params::{ParamError, ParamSpec, Value};
use super::sample::{luminance, mixture_share, pdf_cosine, sample_cosine, Sample};
use super::sampling::no_lobes;
use super::terms::{pow5_complement, r0_from_ior, F_schlick};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::mem::offset_of;

/// The parameter table: the matte substrate's reflectance and the coat's IOR in [1, 5].
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("matte", 0.5, "reflectance of the matte substrate"),
    ParamSpec::scalar(
        "ior",
        1.0,
        5.0,
        1.5,
        "index of refraction of the smooth coat",
    ),
];

/// The coupled model's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct Coupled {
    /// Reflectance of the matte substrate, linear RGB.
    pub matte: DVec3,
    /// Relative index of refraction of the smooth coat, which sets the spike's Schlick R0.
    pub ior: f64,
}

/// std430 twin of the GLSL `CoupledParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`Coupled::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct CoupledParams {
    /// `matte` 21/(20π) (1 − R0).
    pub matte_scale: [f32; 3],
    /// Schlick's R0 from `ior`, for the mirror spike's albedo in the sampler.
    pub r0: f32,
}

/// Byte offset of every field of [`CoupledParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    ("matte_scale", offset_of!(CoupledParams, matte_scale)),
    ("r0", offset_of!(CoupledParams, r0)),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "coupled",
    description:
        "Shirley et al. 1997 coupled matte-specular: mirror spike plus energy-coupled matte",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "CoupledParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<CoupledParams>(),
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
const STABILITY_EDGES: &[&[&str]] = &[
    &["matte=1", "ior=1"],
    &["matte=1", "ior=5"],
    &["matte=0", "ior=5"],
];

/// The white configuration: the matte layer at 1.
fn white_configuration(p: &mut ParamSet) -> Result<bool, ParamError> {
    p.set("matte", Value::One(1.0))?;
    Ok(false)
}

impl Coupled {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        Coupled {
            matte: p.rgb("matte"),
            ior: p.scalar("ior"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> CoupledParams {
        CoupledParams {
            matte_scale: f32x3(self.matte * (21.0 / (20.0 * PI) * (1.0 - r0_from_ior(self.ior)))),
            r0: r0_from_ior(self.ior) as f32,
        }
    }
}

/// The non-delta part in 1/sr, the energy-coupled matte term
/// matte 21/(20π) (1 − R0) (1 − (1 − c_i)⁵)(1 − (1 − c_o)⁵); the spike is in [`coupled_delta`].
pub fn coupled(p: &Coupled, wi: DVec3, wo: DVec3) -> DVec3 {
    let r0 = r0_from_ior(p.ior);
    let k = 21.0 / (20.0 * PI) * (1.0 - r0);
    p.matte * (k * pow5_complement(wi.z) * pow5_complement(wo.z))
}

/// Albedo of the mirror spike seen from c_o: F_s(c_o).
pub fn coupled_delta(p: &Coupled, c_o: f64) -> DVec3 {
    F_schlick(c_o, DVec3::splat(r0_from_ior(p.ior)))
}

/// The probability of choosing the mirror spike: the luminance of its albedo F_s(c_o) against
/// that of `matte` (1 − R0) (1 − (1 − c_o)⁵) (the matte term's directional albedo, exact: 2π∫(1 − (1 − c)⁵) c dc = 20π/21), so that both components' weights are about the total albedo.
pub fn coupled_spike_probability(p: &Coupled, wo: DVec3) -> f64 {
    mixture_share(
        luminance(coupled_delta(p, wo.z)),
        luminance(p.matte) * (1.0 - r0_from_ior(p.ior)) * pow5_complement(wo.z),
    )
}

/// Draws the mirror spike (a delta sample: ωi the mirror direction of ωo, pdf the
/// probability P of choosing it, weight F_s(c_o)/P) with probability
/// [`coupled_spike_probability`] by `uc`, else ωi by the cosine for the non-delta part.
pub fn sample_coupled(p: &Coupled, wo: DVec3, uc: f64, u: DVec2) -> Sample {
    let spike = coupled_spike_probability(p, wo);
    if uc < spike {
        return Sample::spike(wo, spike, coupled_delta(p, wo.z));
    }
    let wi = sample_cosine(u);
    Sample::from_draw(wi, pdf_coupled(p, wi, wo), |wi| coupled(p, wi, wo))
}

/// The density of [`sample_coupled`]'s non-delta draws: (1 − P) cos θi/π, P the spike's
/// probability; over the hemisphere it integrates to 1 − P.
pub fn pdf_coupled(p: &Coupled, wi: DVec3, wo: DVec3) -> f64 {
    (1.0 - coupled_spike_probability(p, wo)) * pdf_cosine(wi)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn coupled_sampler_and_pdf() {
        for set in [&["matte=0.5"][..], &["matte=1", "ior=3"]] {
            check_reference(&params(Model::Coupled, set), false, 0.8);
        }
    }
}
