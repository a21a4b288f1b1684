//! Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model", eqs. 4 and 5.
//! Twin of `glsl/brdf/ashikhmin_shirley.glsl`.

use super::info::{no_v_cavity, white_specular_alone, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sample::{luminance, mixture_share, pdf_cosine, reflect, sample_cosine, Sample};
use super::sampling::SamplingLobes;
use super::terms::{
    half_vector_from_sum, log1m, one_minus_cos_theta, pow1m, pow5_complement, F_specular,
};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::mem::offset_of;

/// The parameter table: the substrate's reflectance, the coat's R0, and the exponents nu
/// (along t = +x) and nv (along b = +y) in [0, 10⁶].
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("diffuse", 0.5, "reflectance of the diffuse substrate"),
    ParamSpec::rgb("specular", 0.05, "R0 of the coat's Schlick Fresnel"),
    ParamSpec::scalar(
        "nu",
        0.0,
        1e6,
        100.0,
        "Phong-like exponent along the tangent t = +x",
    ),
    ParamSpec::scalar(
        "nv",
        0.0,
        1e6,
        100.0,
        "Phong-like exponent along the bitangent b = +y",
    ),
];

/// Ashikhmin–Shirley's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct AshikhminShirley {
    /// Reflectance of the diffuse substrate, linear RGB.
    pub diffuse: DVec3,
    /// R0 of the coat's Schlick Fresnel, linear RGB.
    pub specular: DVec3,
    /// Exponent along the tangent t = +x.
    pub nu: f64,
    /// Exponent along the bitangent b = +y.
    pub nv: f64,
}

/// std430 twin of the GLSL `AshikhminShirleyParams`: what the kernel reads, computed once per parameter set in
/// f64 ([`AshikhminShirley::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct AshikhminShirleyParams {
    /// 28/(23π) `diffuse` (1 − `specular`).
    pub diffuse_scale: [f32; 3],
    /// `nu`.
    pub nu: f32,
    /// `specular` (the coat's R0).
    pub specular: [f32; 3],
    /// `nv`.
    pub nv: f32,
    /// 1 − `specular`.
    pub one_minus_specular: [f32; 3],
    /// √((nu + 1)(nv + 1))/(8π).
    pub spec_norm: f32,
    /// (nu + nv)/2, the exponent at h = n.
    pub mean_exponent: f32,
    /// The luminance of the base's `diffuse` (1 − `specular`), against which the sampler weighs
    /// the coat ([`ashikhmin_shirley_lobe_probability`]).
    pub base_luminance: f32,
    /// Padding to the std430 size of 64 bytes; always 0.
    pub _pad: [f32; 2],
}

/// Byte offset of every field of [`AshikhminShirleyParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    (
        "diffuse_scale",
        offset_of!(AshikhminShirleyParams, diffuse_scale),
    ),
    ("nu", offset_of!(AshikhminShirleyParams, nu)),
    ("specular", offset_of!(AshikhminShirleyParams, specular)),
    ("nv", offset_of!(AshikhminShirleyParams, nv)),
    (
        "one_minus_specular",
        offset_of!(AshikhminShirleyParams, one_minus_specular),
    ),
    ("spec_norm", offset_of!(AshikhminShirleyParams, spec_norm)),
    (
        "mean_exponent",
        offset_of!(AshikhminShirleyParams, mean_exponent),
    ),
    (
        "base_luminance",
        offset_of!(AshikhminShirleyParams, base_luminance),
    ),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "ashikhmin_shirley",
    description: "Ashikhmin-Shirley anisotropic Phong: rough coat over a coupled diffuse base",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "AshikhminShirleyParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<AshikhminShirleyParams>(),
    has_delta: false,
    pow_lobe: true,
    has_specular_fresnel: true,
    lut_axis: LutAxis {
        keys: &["nu", "nv"],
        lo: 1.0,
        hi: 10000.0,
        mapping: Mapping::Log,
    },
    white: white_specular_alone,
    stability_edges: |_| STABILITY_EDGES.to_vec(),
    exponent: ashikhmin_shirley_exponent_at,
    is_isotropic,
    sampling_lobes: ashikhmin_shirley_lobes,
    v_cavity: no_v_cavity,
    interleave_table: true,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[
    &["diffuse=0", "specular=1", "nu=0", "nv=0"],
    &["diffuse=0", "specular=1", "nu=1e5", "nv=1e5"],
    &["diffuse=0", "specular=1", "nu=0", "nv=1e5"],
    &["diffuse=0", "specular=1", "nu=1e5", "nv=0"],
    &["diffuse=0", "specular=1", "nu=1", "nv=1e5"],
    &["diffuse=0", "specular=1", "nu=1e6", "nv=1e6"],
    &["diffuse=1", "specular=0", "nu=1e5", "nv=0"],
];

/// |x| of c_h^e = exp(e log c_h) at (ωi, ωo), e the anisotropic exponent.
fn ashikhmin_shirley_exponent_at(p: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    let h = (wi + wo).normalize_or_zero();
    ashikhmin_shirley_exponent(h, p.scalar("nu"), p.scalar("nv"))
        * log1m(one_minus_cos_theta(h)).abs()
}

/// Isotropic exactly when nu = nv.
fn is_isotropic(p: &ParamSet) -> bool {
    p.scalar("nu") == p.scalar("nv")
}

impl AshikhminShirley {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        AshikhminShirley {
            diffuse: p.rgb("diffuse"),
            specular: p.rgb("specular"),
            nu: p.scalar("nu"),
            nv: p.scalar("nv"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> AshikhminShirleyParams {
        AshikhminShirleyParams {
            diffuse_scale: f32x3(28.0 / (23.0 * PI) * self.diffuse * (DVec3::ONE - self.specular)),
            nu: self.nu as f32,
            specular: f32x3(self.specular),
            nv: self.nv as f32,
            one_minus_specular: f32x3(DVec3::ONE - self.specular),
            spec_norm: (((self.nu + 1.0) * (self.nv + 1.0)).sqrt() / (8.0 * PI)) as f32,
            mean_exponent: (0.5 * (self.nu + self.nv)) as f32,
            base_luminance: luminance(self.diffuse * (DVec3::ONE - self.specular)) as f32,
            _pad: [0.0; 2],
        }
    }
}

/// (nu h_x² + nv h_y²)/(1 − c_h²) with 1 − c_h² = h_x² + h_y²; finite at h = n (see the GLSL twin).
pub fn ashikhmin_shirley_exponent(h: DVec3, nu: f64, nv: f64) -> f64 {
    let (hx2, hy2) = (h.x * h.x, h.y * h.y);
    let s = hx2 + hy2;
    if s > 0.0 {
        (nu * hx2 + nv * hy2) / s
    } else {
        0.5 * (nu + nv)
    }
}

/// f = ρ_s + ρ_d in 1/sr (eqs. 4 and 5), without the cosine; `white_furnace` sets the coat's
/// Fresnel to 1.
pub fn ashikhmin_shirley(p: &AshikhminShirley, wi: DVec3, wo: DVec3, white_furnace: bool) -> DVec3 {
    ashikhmin_shirley_from_sum(p, wi, wo, wi + wo, white_furnace)
}

/// [`ashikhmin_shirley`] with s = ωi + ωo given (the GLSL albedo kernel's exact sum:
/// [`half_vector_from_sum`]).
pub fn ashikhmin_shirley_from_sum(
    p: &AshikhminShirley,
    wi: DVec3,
    wo: DVec3,
    s: DVec3,
    white_furnace: bool,
) -> DVec3 {
    let (h, c_d) = half_vector_from_sum(s);
    let (c_i, c_o) = (wi.z, wo.z);
    let e = ashikhmin_shirley_exponent(h, p.nu, p.nv);
    let spec = ((p.nu + 1.0) * (p.nv + 1.0)).sqrt() / (8.0 * PI) * pow1m(one_minus_cos_theta(h), e)
        / (c_d * c_i.max(c_o));
    let rho_s = spec * F_specular(c_d, p.specular, white_furnace);
    let rho_d = 28.0 / (23.0 * PI)
        * p.diffuse
        * (DVec3::ONE - p.specular)
        * (pow5_complement(0.5 * c_i) * pow5_complement(0.5 * c_o));
    rho_s + rho_d
}

/// c_h^e as for Blinn–Phong: n = nu/4 and nv/4 along the two axes. The coat's Fresnel rises to 1
/// at grazing whatever R0 (`specular`) is: weigh the lobe as if it reflected everything, the base
/// by what the coat lets through.
fn ashikhmin_shirley_lobes(p: &ParamSet) -> Option<SamplingLobes> {
    let m = AshikhminShirley::new(p);
    Some(SamplingLobes {
        diffuse: m.diffuse * (DVec3::ONE - m.specular),
        specular: DVec3::ONE,
        exponents: [m.nu / 4.0, m.nv / 4.0],
    })
}

/// A half vector h from Ashikhmin & Shirley 2000, §3 (eq. 9): φ = atan(√((nu + 1)/(nv + 1))
/// tan(π ξ/2)) in the first quadrant, ξ = 4u₁ − q, and the quadrant q = ⌊4u₁⌋ by the density's
/// symmetry in φ → π − φ, π + φ, −φ; cos θh = (1 − u₂)^{1/(nu cos²φ + nv sin²φ + 1)}. Its density is
/// [`pdf_ashikhmin_shirley_h`].
pub fn sample_ashikhmin_shirley_h(nu: f64, nv: f64, u: DVec2) -> DVec3 {
    let x = 4.0 * u.x;
    let q = (x as usize).min(3);
    let t = 0.5 * PI * (x - q as f64);
    // atan2 of the two scaled sides: no tan to overflow at ξ → 1.
    let phi1 = ((nu + 1.0).sqrt() * t.sin()).atan2((nv + 1.0).sqrt() * t.cos());
    let phi = match q {
        0 => phi1,
        1 => PI - phi1,
        2 => PI + phi1,
        _ => 2.0 * PI - phi1,
    };
    let (c, s) = (phi.cos(), phi.sin());
    let e = nu * c * c + nv * s * s;
    // 1 − cos θh = −expm1(ln(1 − u₂)/(e + 1)): no cancellation for large exponents. 1 − u₂
    // rather than u₂ (the same law): the generator gives u = 0 and never 1, and u₂ = 0 would
    // give θh = π/2, a draw of density 0 below the horizon.
    let one_minus_c = -((-u.y).ln_1p() / (e + 1.0)).exp_m1();
    let sin_h = (one_minus_c * (2.0 - one_minus_c)).max(0.0).sqrt();
    DVec3::new(sin_h * c, sin_h * s, 1.0 - one_minus_c)
}

/// The density of [`sample_ashikhmin_shirley_h`] over the solid angle of h (Ashikhmin &
/// Shirley 2000, eq. 8): √((nu + 1)(nv + 1))/(2π) c_h^{nu cos²φh + nv sin²φh}.
pub fn pdf_ashikhmin_shirley_h(nu: f64, nv: f64, h: DVec3) -> f64 {
    let e = ashikhmin_shirley_exponent(h, nu, nv);
    ((nu + 1.0) * (nv + 1.0)).sqrt() / (2.0 * PI) * pow1m(one_minus_cos_theta(h), e)
}

/// The probability of drawing from the coat's lobe rather than the cosine: the luminances of
/// the coat's Fresnel factor at c_o (1 under the white furnace), which its lobe reflects about,
/// and of the base's `diffuse` (1 − R0), which bounds the base's albedo.
pub fn ashikhmin_shirley_lobe_probability(
    p: &AshikhminShirley,
    wo: DVec3,
    white_furnace: bool,
) -> f64 {
    let coat = luminance(F_specular(wo.z, p.specular, white_furnace));
    mixture_share(coat, luminance(p.diffuse * (DVec3::ONE - p.specular)))
}

/// Draws ωi from the mixture of the coat's half-vector lobe ([`sample_ashikhmin_shirley_h`],
/// ωi the reflection of ωo about h, eq. 10's sampling) and the cosine for the base, chosen by
/// `uc` with [`ashikhmin_shirley_lobe_probability`]. Reflections below the horizon are lost.
pub fn sample_ashikhmin_shirley(
    p: &AshikhminShirley,
    wo: DVec3,
    uc: f64,
    u: DVec2,
    white_furnace: bool,
) -> Sample {
    let wi = if uc < ashikhmin_shirley_lobe_probability(p, wo, white_furnace) {
        reflect(wo, sample_ashikhmin_shirley_h(p.nu, p.nv, u))
    } else {
        sample_cosine(u)
    };
    Sample::from_draw(wi, pdf_ashikhmin_shirley(p, wi, wo, white_furnace), |wi| {
        ashikhmin_shirley(p, wi, wo, white_furnace)
    })
}

/// The density of [`sample_ashikhmin_shirley`]: (1 − P) cos θi/π + P p_h(h)/(4 ωo·h)
/// (Ashikhmin & Shirley 2000, eq. 10), h = normalize(ωi + ωo), P the lobe's probability; 0
/// below the horizon.
pub fn pdf_ashikhmin_shirley(
    p: &AshikhminShirley,
    wi: DVec3,
    wo: DVec3,
    white_furnace: bool,
) -> f64 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let (h, c_d) = half_vector_from_sum(wi + wo);
    let lobe = ashikhmin_shirley_lobe_probability(p, wo, white_furnace);
    // c_d = |ωi + ωo|/2 ≥ (c_i + c_o)/2 > 0 for both directions above the horizon.
    (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_ashikhmin_shirley_h(p.nu, p.nv, h) / (4.0 * c_d)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn ashikhmin_shirley_sampler_and_pdf() {
        for (set, width, white) in [
            (&["nu=100", "nv=100"][..], 0.2, false),
            (&["nu=10", "nv=1000", "specular=0.5"], 0.2, false),
            (&["diffuse=0.2", "nu=1e4", "nv=1e4"], 0.02, true),
        ] {
            check_reference(&params(Model::AshikhminShirley, set), white, width);
        }
    }
}
