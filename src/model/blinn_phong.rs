//! Blinn–Phong with the (N+8)/(8π) normalization and the lab report's mapping N = 8192^(1−s).
//! Twin of `glsl/brdf/blinn_phong.glsl`.

use super::info::{always_isotropic, no_v_cavity, white_specular_alone, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sample::{
    luminance, mixture_share, pdf_cosine, pdf_power_cosine, reflect, sample_cosine,
    sample_power_cosine, Sample,
};
use super::sampling::SamplingLobes;
use super::terms::{half_vector, log1m, one_minus_cos_theta, pow1m};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};
use std::mem::offset_of;

/// The parameter table: diffuse and specular reflectance, and the smoothness s in [0, 1].
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("diffuse", 0.5, "Lambertian reflectance"),
    ParamSpec::rgb("specular", 0.5, "specular reflectance"),
    ParamSpec::scalar(
        "smoothness",
        0.0,
        1.0,
        0.5,
        "s: exponent N = 8192^(1-s) (s=0.1 sharp, s=0.9 broad)",
    ),
];

/// Blinn–Phong's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct BlinnPhong {
    /// Lambertian reflectance, linear RGB.
    pub diffuse: DVec3,
    /// Weight of the half-vector lobe, linear RGB.
    pub specular: DVec3,
    /// s in [0, 1]; the exponent is N = 8192^(1−s), so 0 is the sharpest lobe and 1 is N = 1.
    pub smoothness: f64,
}

/// std430 twin of the GLSL `BlinnPhongParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`BlinnPhong::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BlinnPhongParams {
    /// `diffuse` / π.
    pub diffuse_over_pi: [f32; 3],
    /// N = 8192^(1−s) ([`blinn_phong_exponent`]).
    pub exponent: f32,
    /// `specular` (N + 8)/(8π).
    pub specular_norm: [f32; 3],
    /// [`blinn_phong_lobe_probability`], for the sampler.
    pub lobe_probability: f32,
}

/// Byte offset of every field of [`BlinnPhongParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    (
        "diffuse_over_pi",
        offset_of!(BlinnPhongParams, diffuse_over_pi),
    ),
    ("exponent", offset_of!(BlinnPhongParams, exponent)),
    ("specular_norm", offset_of!(BlinnPhongParams, specular_norm)),
    (
        "lobe_probability",
        offset_of!(BlinnPhongParams, lobe_probability),
    ),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "blinn_phong",
    description: "normalized Blinn-Phong: diffuse + (N+8)/(8pi) cos^N theta_h, N = 8192^(1-s)",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "BlinnPhongParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<BlinnPhongParams>(),
    has_delta: false,
    pow_lobe: true,
    has_specular_fresnel: false,
    lut_axis: LutAxis {
        keys: &["smoothness"],
        lo: 0.0,
        hi: 1.0,
        mapping: Mapping::Linear,
    },
    white: white_specular_alone,
    stability_edges: |_| STABILITY_EDGES.to_vec(),
    exponent: blinn_phong_exponent_at,
    is_isotropic: always_isotropic,
    sampling_lobes: blinn_phong_lobes,
    v_cavity: no_v_cavity,
    interleave_table: false,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[
    &["diffuse=0", "specular=1", "smoothness=0"],
    &["diffuse=0", "specular=1", "smoothness=1e-4"],
    &["diffuse=0", "specular=1", "smoothness=0.5"],
    &["diffuse=0", "specular=1", "smoothness=0.9999"],
    &["diffuse=0", "specular=1", "smoothness=1"],
];

/// |x| of c_h^N = exp(N log c_h) at (ωi, ωo), with log c_h from 1 − c_h without cancellation.
fn blinn_phong_exponent_at(p: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    let h = (wi + wo).normalize_or_zero();
    blinn_phong_exponent(p.scalar("smoothness")) * log1m(one_minus_cos_theta(h)).abs()
}

impl BlinnPhong {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        BlinnPhong {
            diffuse: p.rgb("diffuse"),
            specular: p.rgb("specular"),
            smoothness: p.scalar("smoothness"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> BlinnPhongParams {
        let n = blinn_phong_exponent(self.smoothness);
        BlinnPhongParams {
            diffuse_over_pi: f32x3(self.diffuse * FRAC_1_PI),
            exponent: n as f32,
            specular_norm: f32x3(self.specular * ((n + 8.0) / (8.0 * PI))),
            lobe_probability: blinn_phong_lobe_probability(self) as f32,
        }
    }
}

/// N = 8192^(1−s) = 2^(13(1−s)).
pub fn blinn_phong_exponent(smoothness: f64) -> f64 {
    (13.0 * (1.0 - smoothness)).exp2()
}

/// f in 1/sr for ωi (to the light) and ωo (to the viewer) above the horizon, without the cosine.
pub fn blinn_phong(p: &BlinnPhong, wi: DVec3, wo: DVec3) -> DVec3 {
    blinn_phong_from_sum(p, wi, wo, wi + wo)
}

/// [`blinn_phong`] with s = ωi + ωo given (the GLSL albedo kernel's exact sum:
/// [`half_vector_from_sum`](super::terms::half_vector_from_sum)).
pub fn blinn_phong_from_sum(p: &BlinnPhong, _wi: DVec3, _wo: DVec3, s: DVec3) -> DVec3 {
    let h = s.normalize();
    let n = blinn_phong_exponent(p.smoothness);
    let lobe = (n + 8.0) / (8.0 * PI) * pow1m(one_minus_cos_theta(h), n);
    p.diffuse * FRAC_1_PI + p.specular * lobe
}

/// c_h^N with θh ≈ α/2 near the mirror direction: cos^N(α/2) ≈ e^{−Nα²/8} = cos^{N/4}α, n = N/4.
fn blinn_phong_lobes(p: &ParamSet) -> Option<SamplingLobes> {
    let m = BlinnPhong::new(p);
    let n = blinn_phong_exponent(m.smoothness) / 4.0;
    Some(SamplingLobes {
        diffuse: m.diffuse,
        specular: m.specular,
        exponents: [n; 2],
    })
}

/// The probability of drawing from the half-vector lobe rather than the cosine: the two
/// reflectances' luminances (the (N + 8)/(8π) normalisation makes the lobe reflect about
/// `specular` near normal incidence).
pub fn blinn_phong_lobe_probability(p: &BlinnPhong) -> f64 {
    mixture_share(luminance(p.specular), luminance(p.diffuse))
}

/// Draws ωi from the mixture of the half-vector lobe and the cosine, chosen by `uc` with
/// [`blinn_phong_lobe_probability`]: for the lobe, h by a power cosine c_hᴺ about the normal
/// (Lafortune & Willems 1994's lobe, in half-vector space) and ωi the reflection of ωo about h,
/// which leaves the hemisphere where ωo·h < c_o/(2 c_h) (lost: weight 0, pdf 0).
pub fn sample_blinn_phong(p: &BlinnPhong, wo: DVec3, uc: f64, u: DVec2) -> Sample {
    let wi = if uc < blinn_phong_lobe_probability(p) {
        let h = sample_power_cosine(DVec3::Z, blinn_phong_exponent(p.smoothness), u);
        reflect(wo, h)
    } else {
        sample_cosine(u)
    };
    Sample::from_draw(wi, pdf_blinn_phong(p, wi, wo), |wi| blinn_phong(p, wi, wo))
}

/// The density of [`sample_blinn_phong`]: (1 − P) cos θi/π + P (N + 1)/(2π) c_hᴺ / (4 ωo·h),
/// h = normalize(ωi + ωo), the last factor the Jacobian of the reflection (Walter et al. 2007,
/// eq. 14); 0 below the horizon.
pub fn pdf_blinn_phong(p: &BlinnPhong, wi: DVec3, wo: DVec3) -> f64 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let (h, c_d) = half_vector(wi, wo);
    let lobe = blinn_phong_lobe_probability(p);
    let n = blinn_phong_exponent(p.smoothness);
    // c_d = |ωi + ωo|/2 ≥ (c_i + c_o)/2 > 0 for both directions above the horizon.
    (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_power_cosine(DVec3::Z, n, h) / (4.0 * c_d)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn blinn_phong_sampler_and_pdf() {
        // N = 8192^(1−s): 90.5, 5300 and 2.5.
        for (set, width) in [
            (&["smoothness=0.5"][..], 0.2),
            (&["diffuse=0.1", "specular=0.9", "smoothness=0.05"], 0.03),
            (&["diffuse=0", "specular=1", "smoothness=0.9"], 1.0),
        ] {
            check_reference(&params(Model::BlinnPhong, set), false, width);
        }
    }
}
