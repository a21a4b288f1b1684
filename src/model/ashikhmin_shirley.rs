//! Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model", eqs. 4 and 5.
//! Twin of `glsl/brdf/ashikhmin_shirley.glsl`.

use super::info::{no_v_cavity, white_specular_alone, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sampling::SamplingLobes;
use super::terms::{
    half_vector_from_sum, log1m, one_minus_cos_theta, pow1m, pow5_complement, F_specular,
};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
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
    /// Padding to the std430 size of 64 bytes; always 0.
    pub _pad: [f32; 3],
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
            _pad: [0.0; 3],
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
