//! Cook & Torrance 1982: Beckmann D, V-cavity G, Schlick's Fresnel.
//! Twin of `glsl/brdf/cook_torrance.glsl`.

use super::components::Distribution;
use super::info::{always_isotropic, white_specular_alone, LutAxis, ModelInfo};
use super::params::ParamSpec;
use super::sample::{
    luminance, mixture_share, pdf_cosine, pdf_vndf, reflect, sample_cosine, sample_vndf, Sample,
};
use super::sampling::{beckmann_exponent, SamplingLobes};
use super::terms::{half_vector_from_sum, r0_from_ior, D_beckmann, F_specular, G_v_cavity};
use super::{f32x3, Layout, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::FRAC_1_PI;
use std::mem::offset_of;

/// The parameter table: diffuse and specular weights, the IOR in [1, 5] and the Beckmann slope
/// m in (0, 1].
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::rgb("diffuse", 0.2, "kD x colour: Lambertian part"),
    ParamSpec::rgb(
        "specular",
        0.8,
        "kS x colour: weight of the microfacet lobe",
    ),
    ParamSpec::scalar(
        "ior",
        1.0,
        5.0,
        1.5,
        "index of refraction eta for Schlick's R0",
    ),
    ParamSpec::positive("roughness", 1.0, 0.3, "m: Beckmann RMS slope"),
];

/// Cook–Torrance's parameters, resolved for the f64 formula.
#[derive(Clone, Copy, Debug)]
pub struct CookTorrance {
    /// Lambertian reflectance, linear RGB.
    pub diffuse: DVec3,
    /// Weight of the microfacet lobe, linear RGB.
    pub specular: DVec3,
    /// Relative index of refraction η, from which Schlick's R0 = ((η − 1)/(η + 1))² follows.
    pub ior: f64,
    /// Beckmann RMS slope m.
    pub roughness: f64,
}

/// std430 twin of the GLSL `CookTorranceParams`: what the kernel reads, computed once per
/// parameter set in f64 ([`CookTorrance::gpu_params`]) and rounded to f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct CookTorranceParams {
    /// `diffuse` / π.
    pub diffuse_over_pi: [f32; 3],
    /// 1 / m².
    pub inv_alpha2: f32,
    /// `specular`.
    pub specular: [f32; 3],
    /// D's normalisation 1 / (π m²).
    pub d_norm: f32,
    /// Schlick's R0 from `ior`.
    pub r0: f32,
    /// 1 − R0.
    pub one_minus_r0: f32,
    /// [`cook_torrance_lobe_probability`], for the sampler.
    pub lobe_probability: f32,
    /// The same under the white furnace.
    pub lobe_probability_white: f32,
}

/// Byte offset of every field of [`CookTorranceParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    (
        "diffuse_over_pi",
        offset_of!(CookTorranceParams, diffuse_over_pi),
    ),
    ("inv_alpha2", offset_of!(CookTorranceParams, inv_alpha2)),
    ("specular", offset_of!(CookTorranceParams, specular)),
    ("d_norm", offset_of!(CookTorranceParams, d_norm)),
    ("r0", offset_of!(CookTorranceParams, r0)),
    ("one_minus_r0", offset_of!(CookTorranceParams, one_minus_r0)),
    (
        "lobe_probability",
        offset_of!(CookTorranceParams, lobe_probability),
    ),
    (
        "lobe_probability_white",
        offset_of!(CookTorranceParams, lobe_probability_white),
    ),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "cook_torrance",
    description: "Cook-Torrance: Beckmann D, V-cavity G, Schlick F, plus diffuse",
    params: PARAMS,
    optional_keys: &[],
    gpu_struct: "CookTorranceParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<CookTorranceParams>(),
    has_delta: false,
    pow_lobe: false,
    has_specular_fresnel: true,
    // m = 0.01 (the sharpest lobe of the lab report's materials) to 1, denser where E changes
    // fastest.
    lut_axis: LutAxis {
        keys: &["roughness"],
        lo: 0.01,
        hi: 1.0,
        mapping: Mapping::Square,
    },
    white: white_specular_alone,
    stability_edges: |_| STABILITY_EDGES.to_vec(),
    exponent: cook_torrance_exponent_at,
    is_isotropic: always_isotropic,
    sampling_lobes: cook_torrance_lobes,
    v_cavity: |_| true,
    interleave_table: false,
};

/// The parameter edges `lobe stability` sweeps.
const STABILITY_EDGES: &[&[&str]] = &[
    &["diffuse=0", "specular=1", "roughness=1e-4", "ior=1"],
    &["diffuse=0", "specular=1", "roughness=1e-4", "ior=5"],
    &["diffuse=0", "specular=1", "roughness=1e-2", "ior=1"],
    &["diffuse=0", "specular=1", "roughness=1e-2", "ior=5"],
    &["diffuse=0", "specular=1", "roughness=1", "ior=1"],
    &["diffuse=0", "specular=1", "roughness=1", "ior=5"],
];

/// |x| of Beckmann's exp(−tan²θh/m²) at (ωi, ωo).
fn cook_torrance_exponent_at(p: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    let h = (wi + wo).normalize_or_zero();
    let m = p.scalar("roughness");
    (h.x * h.x + h.y * h.y) / (h.z * h.z) / (m * m)
}

impl CookTorrance {
    /// Reads the parameters from a validated set of this model.
    pub fn new(p: &ParamSet) -> Self {
        CookTorrance {
            diffuse: p.rgb("diffuse"),
            specular: p.rgb("specular"),
            ior: p.scalar("ior"),
            roughness: p.scalar("roughness"),
        }
    }

    /// The block the GPU kernels read, rounded to f32.
    pub fn gpu_params(&self) -> CookTorranceParams {
        let m2 = self.roughness * self.roughness;
        let r0 = r0_from_ior(self.ior);
        CookTorranceParams {
            diffuse_over_pi: f32x3(self.diffuse * FRAC_1_PI),
            inv_alpha2: (1.0 / m2) as f32,
            specular: f32x3(self.specular),
            d_norm: (FRAC_1_PI / m2) as f32,
            r0: r0 as f32,
            one_minus_r0: (1.0 - r0) as f32,
            lobe_probability: cook_torrance_lobe_probability(self, false) as f32,
            lobe_probability_white: cook_torrance_lobe_probability(self, true) as f32,
        }
    }
}

/// f = diffuse/π + specular F D G/(4 c_i c_o) in 1/sr, without the cosine; `white_furnace`
/// sets F = 1.
pub fn cook_torrance(p: &CookTorrance, wi: DVec3, wo: DVec3, white_furnace: bool) -> DVec3 {
    cook_torrance_from_sum(p, wi, wo, wi + wo, white_furnace)
}

/// [`cook_torrance`] with s = ωi + ωo given (the GLSL albedo kernel's exact sum:
/// [`half_vector_from_sum`]).
pub fn cook_torrance_from_sum(
    p: &CookTorrance,
    wi: DVec3,
    wo: DVec3,
    s: DVec3,
    white_furnace: bool,
) -> DVec3 {
    let (h, c_d) = half_vector_from_sum(s);
    let (c_i, c_o) = (wi.z, wo.z);
    let d = D_beckmann(h, p.roughness, p.roughness);
    let g = G_v_cavity(h.z, c_d, c_i, c_o);
    let f = F_specular(c_d, DVec3::splat(r0_from_ior(p.ior)), white_furnace);
    p.diffuse * FRAC_1_PI + p.specular * f * (d * g / (4.0 * c_i * c_o))
}

/// The `microfacet` configuration equal to `p`: Beckmann D with α = m, V-cavity masking,
/// Schlick's Fresnel from the IOR (tests/microfacet.rs checks the two agree).
pub fn as_microfacet(p: &ParamSet) -> Option<ParamSet> {
    use super::microfacet::MicrofacetConfig;
    let mut m = ParamSet::defaults(super::Model::Microfacet(MicrofacetConfig::DEFAULT));
    for (k, v) in [
        ("distribution", "beckmann"),
        ("masking", "v_cavity"),
        ("beckmann_g1", "exact"),
        ("fresnel", "schlick"),
    ] {
        m.set_text(&format!("{k}={v}")).ok()?;
    }
    m.set("alpha", p.get("roughness")).ok()?;
    m.set("ior", p.get("ior")).ok()?;
    m.set("diffuse", p.get("diffuse")).ok()?;
    m.set("specular", p.get("specular")).ok()?;
    Some(m)
}

/// Beckmann's lobe as a power cosine of the mirror angle (n = 1/(2m²)).
fn cook_torrance_lobes(p: &ParamSet) -> Option<SamplingLobes> {
    let m = CookTorrance::new(p);
    Some(SamplingLobes {
        diffuse: m.diffuse,
        specular: m.specular,
        exponents: [beckmann_exponent(m.roughness); 2],
    })
}

/// The probability of drawing from the Beckmann lobe rather than the cosine: the luminance of
/// `specular` times Schlick's average R0 + (1 − R0)/21 (1 under the white furnace), the lobe's
/// albedo with masking's loss ignored, against that of `diffuse`.
pub fn cook_torrance_lobe_probability(p: &CookTorrance, white_furnace: bool) -> f64 {
    let r0 = r0_from_ior(p.ior);
    let f_avg = if white_furnace {
        1.0
    } else {
        r0 + (1.0 - r0) / 21.0
    };
    mixture_share(luminance(p.specular) * f_avg, luminance(p.diffuse))
}

/// Draws ωi from the mixture of ωo reflected about a Beckmann visible normal of slope m
/// ([`sample_vndf`], Heitz & d'Eon 2014; f's masking is V-cavity, the draws follow Smith's
/// visible normals, and the density says so) and the cosine for the diffuse part, chosen by
/// `uc` with [`cook_torrance_lobe_probability`]. Reflections below the horizon are lost.
pub fn sample_cook_torrance(
    p: &CookTorrance,
    wo: DVec3,
    uc: f64,
    u: DVec2,
    white_furnace: bool,
) -> Sample {
    let m = p.roughness;
    let wi = if uc < cook_torrance_lobe_probability(p, white_furnace) {
        reflect(wo, sample_vndf(Distribution::Beckmann, wo, m, m, u))
    } else {
        sample_cosine(u)
    };
    Sample::from_draw(wi, pdf_cook_torrance(p, wi, wo, white_furnace), |wi| {
        cook_torrance(p, wi, wo, white_furnace)
    })
}

/// The density of [`sample_cook_torrance`]: (1 − P) cos θi/π + P [`pdf_vndf`] (Beckmann, m).
pub fn pdf_cook_torrance(p: &CookTorrance, wi: DVec3, wo: DVec3, white_furnace: bool) -> f64 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let lobe = cook_torrance_lobe_probability(p, white_furnace);
    let m = p.roughness;
    (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_vndf(Distribution::Beckmann, wi, wo, m, m)
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::super::Model;

    #[test]
    fn cook_torrance_sampler_and_pdf() {
        for (set, width) in [
            (&["roughness=0.05"][..], 0.1),
            (&["roughness=0.8", "ior=3"], 1.0),
        ] {
            check_reference(&params(Model::CookTorrance, set), false, width);
        }
    }
}
