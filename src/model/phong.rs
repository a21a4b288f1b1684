//! Normalized Phong (Lafortune & Willems 1994): f = diffuse/π + specular (n+2)/(2π) max(0, r·ωo)^n,
//! r = 2 c_i n − ωi. Twin of `glsl/brdf/phong.glsl`.

use super::info::{always_isotropic, no_v_cavity, white_specular_alone, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sample::{
    luminance, mirror, mixture_share, pdf_cosine, pdf_power_cosine, sample_cosine,
    sample_power_cosine, Sample,
};
use super::sampling::SamplingLobes;
use super::terms::{log1m, pow1m};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};
use std::mem::offset_of;

/// The parameter table: diffuse and specular reflectance, and the exponent n in [0, 10⁶].
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("diffuse", 0.5, "Lambertian reflectance"),
    ParamSpec::rgb("specular", 0.5, "specular reflectance at normal incidence"),
    ParamSpec::scalar(
        "shininess",
        0.0,
        1e6,
        32.0,
        "Phong exponent n (the lab report's largest is 8192)",
    ),
];

/// Phong's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct Phong {
    /// Lambertian reflectance, linear RGB.
    pub diffuse: DVec3,
    /// Weight of the specular lobe, linear RGB; the lobe integrates to this at normal incidence.
    pub specular: DVec3,
    /// The exponent n of cos^n of the angle between the mirror direction of ωi and ωo.
    pub shininess: f64,
}

/// std430 twin of the GLSL `PhongParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`Phong::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PhongParams {
    /// `diffuse` / π.
    pub diffuse_over_pi: [f32; 3],
    /// The exponent n.
    pub shininess: f32,
    /// `specular` (n + 2)/(2π).
    pub specular_norm: [f32; 3],
    /// [`phong_lobe_probability`], for the sampler.
    pub lobe_probability: f32,
}

/// Byte offset of every field of [`PhongParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    ("diffuse_over_pi", offset_of!(PhongParams, diffuse_over_pi)),
    ("shininess", offset_of!(PhongParams, shininess)),
    ("specular_norm", offset_of!(PhongParams, specular_norm)),
    (
        "lobe_probability",
        offset_of!(PhongParams, lobe_probability),
    ),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "phong",
    description:
        "normalized Phong (Lafortune-Willems): diffuse + (n+2)/(2pi) cos^n of the mirror angle",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "PhongParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<PhongParams>(),
    has_delta: false,
    pow_lobe: true,
    has_specular_fresnel: false,
    // Exponents 1 to 8192 (the lab report's largest): three and a half decades.
    lut_axis: LutAxis {
        keys: &["shininess"],
        lo: 1.0,
        hi: 8192.0,
        mapping: Mapping::Log,
    },
    white: white_specular_alone,
    stability_edges: |_| STABILITY_EDGES.to_vec(),
    exponent: phong_exponent_at,
    is_isotropic: always_isotropic,
    sampling_lobes: phong_lobes,
    v_cavity: no_v_cavity,
    interleave_table: false,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[
    &["diffuse=0", "specular=1", "shininess=0"],
    &["diffuse=0", "specular=1", "shininess=1e-4"],
    &["diffuse=0", "specular=1", "shininess=1"],
    &["diffuse=0", "specular=1", "shininess=8192"],
    &["diffuse=0", "specular=1", "shininess=1e5"],
    &["diffuse=0", "specular=1", "shininess=1e6"],
];

/// |x| of the lobe's power cos^n = exp(n log(r·ωo)) at (ωi, ωo): n |log(1 − s)| with
/// 1 − r·ωo = s = |r − ωo|²/2 computed without cancellation, capped short of 1 where the log
/// runs to −∞ (the lobe is 0 there on both sides).
fn phong_exponent_at(p: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    let r = DVec3::new(-wi.x, -wi.y, wi.z);
    let s = (0.5 * (r - wo).length_squared()).min(0.999_999);
    p.scalar("shininess") * log1m(s).abs()
}

impl Phong {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        Phong {
            diffuse: p.rgb("diffuse"),
            specular: p.rgb("specular"),
            shininess: p.scalar("shininess"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> PhongParams {
        PhongParams {
            diffuse_over_pi: f32x3(self.diffuse * FRAC_1_PI),
            shininess: self.shininess as f32,
            specular_norm: f32x3(self.specular * ((self.shininess + 2.0) / (2.0 * PI))),
            lobe_probability: phong_lobe_probability(self) as f32,
        }
    }
}

/// f in 1/sr for ωi (to the light) and ωo (to the viewer) above the horizon, without the cosine.
pub fn phong(p: &Phong, wi: DVec3, wo: DVec3) -> DVec3 {
    phong_from_sum(p, wi, wo, wi + wo)
}

/// [`phong`] with s = ωi + ωo given (the GLSL albedo kernel's exact sum:
/// [`half_vector_from_sum`](super::terms::half_vector_from_sum)).
pub fn phong_from_sum(p: &Phong, wi: DVec3, wo: DVec3, s: DVec3) -> DVec3 {
    // r − ωo with r = (−ωi.x, −ωi.y, ωi.z), the mirror of ωi about n = +z (2 c_i n − ωi): its
    // tangential part is −(ωi + ωo)'s. 1 − r·ωo = |r − ωo|²/2 for unit vectors: no cancellation
    // near the mirror direction.
    let d = DVec3::new(-s.x, -s.y, wi.z - wo.z);
    let one_minus_r_wo = 0.5 * d.length_squared();
    let lobe = (p.shininess + 2.0) / (2.0 * PI) * pow1m(one_minus_r_wo, p.shininess);
    p.diffuse * FRAC_1_PI + p.specular * lobe
}

/// The lobe is exactly a power cosine of the mirror angle: n = shininess.
fn phong_lobes(p: &ParamSet) -> Option<SamplingLobes> {
    let m = Phong::new(p);
    Some(SamplingLobes {
        diffuse: m.diffuse,
        specular: m.specular,
        exponents: [m.shininess; 2],
    })
}

/// The probability of drawing from the power-cosine lobe rather than the cosine: the two
/// reflectances' luminances (the lobe reflects `specular` at normal incidence, less where it
/// crosses the horizon; the diffuse part reflects `diffuse` at every angle).
pub fn phong_lobe_probability(p: &Phong) -> f64 {
    mixture_share(luminance(p.specular), luminance(p.diffuse))
}

/// Draws ωi from the mixture of a power-cosine lobe cosⁿ about the mirror direction r of ωo
/// (Lafortune & Willems 1994, §4: the lobe (r_i·ωo)ⁿ of f is (ωi·r)ⁿ, r_i the mirror of ωi)
/// and the cosine for the diffuse part, chosen by `uc` with [`phong_lobe_probability`].
/// Lobe draws below the horizon are lost (weight 0, pdf 0).
pub fn sample_phong(p: &Phong, wo: DVec3, uc: f64, u: DVec2) -> Sample {
    let wi = if uc < phong_lobe_probability(p) {
        sample_power_cosine(mirror(wo), p.shininess, u)
    } else {
        sample_cosine(u)
    };
    Sample::from_draw(wi, pdf_phong(p, wi, wo), |wi| phong(p, wi, wo))
}

/// The density of [`sample_phong`]: (1 − P) cos θi/π + P (n + 1)/(2π) max(0, ωi·r)ⁿ,
/// P = [`phong_lobe_probability`]; 0 below the horizon.
pub fn pdf_phong(p: &Phong, wi: DVec3, wo: DVec3) -> f64 {
    if wi.z <= 0.0 {
        return 0.0;
    }
    let lobe = phong_lobe_probability(p);
    (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_power_cosine(mirror(wo), p.shininess, wi)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn phong_sampler_and_pdf() {
        for (set, width) in [
            (&["shininess=20"][..], 0.3),
            (&["diffuse=0.1", "specular=0.9", "shininess=1e4"], 0.01),
            (&["diffuse=0", "specular=1", "shininess=2"], 0.8),
        ] {
            check_reference(&params(Model::Phong, set), false, width);
        }
    }
}
