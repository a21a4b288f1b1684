//! The general microfacet model (Cook & Torrance 1982; Walter et al. 2007; Heitz 2014):
//! f = diffuse/π + specular · F(c_d) · D(h) · G(ωi, ωo) / (4 c_i c_o), with
//! D ∈ {Beckmann, GGX}, isotropic or anisotropic α; G ∈ {V-cavity, separable Smith,
//! height-correlated Smith}; for Beckmann's Smith G1 the exact erf form or Walter's rational fit;
//! F ∈ {none, Schlick (from `ior` or `f0`), exact dielectric, exact conductor}; optionally
//! Kulla & Conty's multiple-scattering lobe ([`super::kulla_conty`]) on top of the specular one.
//! Twin of `glsl/brdf/microfacet.glsl`, where each component choice is a specialization constant,
//! so a pipeline holds only the components it uses.

pub use super::components::{
    BeckmannG1, Distribution, Fresnel, Masking, MicrofacetConfig, Multiscatter,
};
use super::info::{white_specular_alone, LutAxis, ModelInfo};
use super::kulla_conty;
use super::params::ParamSpec;
use super::sample::{
    luminance, mixture_share, pdf_cosine, pdf_vndf, reflect, sample_cosine, sample_vndf, Sample,
};
use super::sampling::{beckmann_exponent, SamplingLobes};
use super::terms::{
    alpha_tan2, half_vector_from_sum, lambda_beckmann, lambda_ggx, r0_from_ior, D_beckmann, D_ggx,
    F_conductor, F_dielectric, F_schlick, G1_beckmann_rational, G_v_cavity,
};
use super::{f32x3, Layout, Model, ParamSet};
use crate::axis::Mapping;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};
use std::mem::offset_of;

/// Keys whose absence means something: alpha_x and alpha_y fall back to alpha, f0 to the IOR.
pub const OPTIONAL_KEYS: &[&str] = &["alpha_x", "alpha_y", "f0"];

/// The parameter table: the five component choices (their options from the enums of
/// [`super::components`], their defaults [`MicrofacetConfig::DEFAULT`]), then the roughness,
/// Fresnel inputs and the two weights.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::choice(
        "distribution",
        Distribution::NAMES,
        MicrofacetConfig::DEFAULT.distribution as usize,
        "normal distribution D",
    ),
    ParamSpec::choice(
        "masking",
        Masking::NAMES,
        MicrofacetConfig::DEFAULT.masking as usize,
        "masking-shadowing G",
    ),
    ParamSpec::choice(
        "beckmann_g1",
        BeckmannG1::NAMES,
        MicrofacetConfig::DEFAULT.beckmann_g1 as usize,
        "Beckmann's Smith G1: erf form or Walter 2007's rational fit",
    ),
    ParamSpec::choice(
        "fresnel",
        Fresnel::NAMES,
        MicrofacetConfig::DEFAULT.fresnel as usize,
        "Fresnel factor F",
    ),
    ParamSpec::choice(
        "multiscatter",
        Multiscatter::NAMES,
        MicrofacetConfig::DEFAULT.multiscatter as usize,
        "multiple scattering: none, or Kulla-Conty's lobe from lobe's own E(mu, alpha) tables",
    ),
    ParamSpec::positive(
        "alpha",
        1.0,
        0.3,
        "roughness (RMS slope for Beckmann, width for GGX)",
    ),
    ParamSpec::positive(
        "alpha_x",
        1.0,
        0.3,
        "roughness along +x; when set, overrides alpha (anisotropic)",
    ),
    ParamSpec::positive(
        "alpha_y",
        1.0,
        0.3,
        "roughness along +y; when set, overrides alpha (anisotropic)",
    ),
    ParamSpec::scalar(
        "ior",
        1.0,
        5.0,
        1.5,
        "IOR for fresnel=dielectric, and for schlick unless f0 is set",
    ),
    ParamSpec::rgb(
        "f0",
        0.04,
        "Schlick's R0 for fresnel=schlick; when set, overrides the one from ior",
    ),
    ParamSpec::rgb_range(
        "eta",
        0.01,
        10.0,
        0.2,
        "real part of a conductor's IOR (fresnel=conductor)",
    ),
    ParamSpec::rgb_range(
        "k",
        0.0,
        10.0,
        3.0,
        "imaginary part of a conductor's IOR (fresnel=conductor)",
    ),
    ParamSpec::rgb("specular", 1.0, "multiplier of the microfacet lobe"),
    ParamSpec::rgb("diffuse", 0.0, "Lambertian base"),
];

/// The microfacet model's parameters, resolved for the f64 formula: the optional keys have
/// fallen back to what their absence means.
#[derive(Clone, Copy, Debug)]
pub struct Microfacet {
    /// The component choices.
    pub config: MicrofacetConfig,
    /// Roughness along t = +x: `alpha_x` if set, else `alpha`.
    pub alpha_x: f64,
    /// Roughness along b = +y: `alpha_y` if set, else `alpha`.
    pub alpha_y: f64,
    /// Relative index of refraction, for the exact dielectric Fresnel and for R0 when `f0` is
    /// unset.
    pub ior: f64,
    /// Schlick's R0: `f0` if set, else from `ior`.
    pub f0: DVec3,
    /// Real part of the conductor's complex IOR, per channel.
    pub eta: DVec3,
    /// Imaginary part κ of the conductor's complex IOR, per channel.
    pub k: DVec3,
    /// Multiplier of the microfacet lobe, linear RGB.
    pub specular: DVec3,
    /// Reflectance of the Lambertian base, linear RGB.
    pub diffuse: DVec3,
    /// F_avg = 2∫₀¹ F(μ) μ dμ of the chosen Fresnel factor, per channel, for the Kulla–Conty
    /// lobe ([`fresnel_average`]).
    pub f_avg: DVec3,
}

/// std430 twin of the GLSL `MicrofacetParams`: the parameters rounded to f32, with everything
/// that depends on them alone computed once here in f64 ([`Microfacet::gpu_params`]), so that the
/// kernel spends its arithmetic per cell only on what depends on the directions.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MicrofacetParams {
    /// `specular`.
    pub specular: [f32; 3],
    /// αx².
    pub alpha2_x: f32,
    /// `diffuse` / π.
    pub diffuse_over_pi: [f32; 3],
    /// αy².
    pub alpha2_y: f32,
    /// Schlick's R0 (`f0`, or from `ior` when unset).
    pub f0: [f32; 3],
    /// 1 / αx².
    pub inv_alpha2_x: f32,
    /// 1 − R0.
    pub one_minus_f0: [f32; 3],
    /// 1 / αy².
    pub inv_alpha2_y: f32,
    /// The conductor's (η − 1)(η + 1) − κ², per channel.
    pub conductor_e2m1k2: [f32; 3],
    /// D's normalisation 1 / (π αx αy).
    pub d_norm: f32,
    /// The conductor's 4 η² κ², per channel.
    pub conductor_q4: [f32; 3],
    /// The dielectric's (ior − 1)(ior + 1).
    pub dielectric_e2m1: f32,
    /// F_ms / (π L_avg) of the Kulla–Conty lobe per channel ([`kulla_conty::fresnel_ms`]); 0
    /// where L_avg is 0 or the lobe is off.
    pub kc_scale: [f32; 3],
    /// `kc_scale` with F_avg = 1, for the white furnace.
    pub kc_scale_white: f32,
    /// The Lagrange weights in r = √α of [`kulla_conty::lagrange`] at α = √(αx αy).
    pub kc_weights: [f32; 4],
    /// The first knot of those weights.
    pub kc_row: u32,
    /// The sampler's luminances ([`Microfacet::lobe_luminances`]): of `specular` F_avg,
    pub lobe_luminance: f32,
    /// of the Kulla–Conty lobe's `specular` F_ms,
    pub kc_luminance: f32,
    /// and of the same with F_avg = 1 (white furnace).
    pub kc_luminance_white: f32,
}

/// Byte offset of every field of [`MicrofacetParams`], checked against the compiled kernels.
pub const GPU_LAYOUT: Layout = &[
    ("specular", offset_of!(MicrofacetParams, specular)),
    ("alpha2_x", offset_of!(MicrofacetParams, alpha2_x)),
    (
        "diffuse_over_pi",
        offset_of!(MicrofacetParams, diffuse_over_pi),
    ),
    ("alpha2_y", offset_of!(MicrofacetParams, alpha2_y)),
    ("f0", offset_of!(MicrofacetParams, f0)),
    ("inv_alpha2_x", offset_of!(MicrofacetParams, inv_alpha2_x)),
    ("one_minus_f0", offset_of!(MicrofacetParams, one_minus_f0)),
    ("inv_alpha2_y", offset_of!(MicrofacetParams, inv_alpha2_y)),
    (
        "conductor_e2m1k2",
        offset_of!(MicrofacetParams, conductor_e2m1k2),
    ),
    ("d_norm", offset_of!(MicrofacetParams, d_norm)),
    ("conductor_q4", offset_of!(MicrofacetParams, conductor_q4)),
    (
        "dielectric_e2m1",
        offset_of!(MicrofacetParams, dielectric_e2m1),
    ),
    ("kc_scale", offset_of!(MicrofacetParams, kc_scale)),
    (
        "kc_scale_white",
        offset_of!(MicrofacetParams, kc_scale_white),
    ),
    ("kc_weights", offset_of!(MicrofacetParams, kc_weights)),
    ("kc_row", offset_of!(MicrofacetParams, kc_row)),
    (
        "lobe_luminance",
        offset_of!(MicrofacetParams, lobe_luminance),
    ),
    ("kc_luminance", offset_of!(MicrofacetParams, kc_luminance)),
    (
        "kc_luminance_white",
        offset_of!(MicrofacetParams, kc_luminance_white),
    ),
];

/// What the rest of the crate knows about this model (see [`super::registry`]).
pub const INFO: ModelInfo = ModelInfo {
    name: "microfacet",
    description: "general microfacet: Beckmann or GGX D, V-cavity or Smith G, Schlick or exact Fresnel, plus diffuse",
    params: PARAMS,
    optional_keys: OPTIONAL_KEYS,
    gpu_struct: "MicrofacetParams",
    gpu_layout: GPU_LAYOUT,
    gpu_size: std::mem::size_of::<MicrofacetParams>(),
    has_delta: false,
    pow_lobe: false,
    has_specular_fresnel: true,
    lut_axis: LutAxis { keys: &["alpha"], lo: 0.01, hi: 1.0, mapping: Mapping::Square },
    white: white_specular_alone,
    stability_edges,
    exponent: microfacet_exponent_at,
    is_isotropic,
    sampling_lobes: microfacet_lobes,
    v_cavity: has_v_cavity,
    interleave_table: true,
};

/// |x| of Beckmann's exp(−(h_x²/α_x² + h_y²/α_y²)/h_z²) at (ωi, ωo); GGX has no exponential.
fn microfacet_exponent_at(p: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    match p.model() {
        Model::Microfacet(c) if c.distribution == Distribution::Beckmann => {
            let h = (wi + wo).normalize_or_zero();
            let m = Microfacet::new(p);
            (h.x * h.x / (m.alpha_x * m.alpha_x) + h.y * h.y / (m.alpha_y * m.alpha_y))
                / (h.z * h.z)
        }
        _ => 0.0,
    }
}

fn is_isotropic(p: &ParamSet) -> bool {
    Microfacet::new(p).is_isotropic()
}

/// Roughness at both ends and at both anisotropic extremes, then each Fresnel term's own edges.
fn stability_edges(model: Model) -> Vec<&'static [&'static str]> {
    let mut out: Vec<&'static [&'static str]> = vec![
        &["diffuse=0", "alpha=1e-4"],
        &["diffuse=0", "alpha=1"],
        &["diffuse=0", "alpha_x=1e-4", "alpha_y=1"],
        &["diffuse=0", "alpha_x=1", "alpha_y=1e-4"],
    ];
    if let Model::Microfacet(c) = model {
        out.extend_from_slice(match c.fresnel {
            Fresnel::Schlick => &[
                &["alpha=1e-4", "f0=0"],
                &["alpha=1e-4", "f0=1"],
                &["alpha=1e-4", "ior=1"],
                &["alpha=1e-4", "ior=5"],
            ],
            Fresnel::Dielectric => &[&["alpha=1e-4", "ior=1"], &["alpha=1e-4", "ior=5"]],
            Fresnel::Conductor => &[
                &["alpha=1e-4", "eta=0.01", "k=10"],
                &["alpha=1e-4", "eta=10", "k=0"],
                &["alpha=1e-4", "eta=1", "k=0"],
            ],
            Fresnel::None => &[],
        });
    }
    out
}

impl Microfacet {
    /// Reads the parameters from a validated set of this model, resolving the optional keys.
    pub fn new(p: &ParamSet) -> Self {
        let alpha = p.scalar("alpha");
        let pick = |key: &str| if p.is_set(key) { p.scalar(key) } else { alpha };
        let ior = p.scalar("ior");
        let mut m = Microfacet {
            config: MicrofacetConfig::from_values(|k| p.get(k)),
            alpha_x: pick("alpha_x"),
            alpha_y: pick("alpha_y"),
            ior,
            f0: if p.is_set("f0") {
                p.rgb("f0")
            } else {
                DVec3::splat(r0_from_ior(ior))
            },
            eta: p.rgb("eta"),
            k: p.rgb("k"),
            specular: p.rgb("specular"),
            diffuse: p.rgb("diffuse"),
            f_avg: DVec3::ONE,
        };
        m.f_avg = fresnel_average(&m);
        m
    }

    /// What [`microfacet_lobe_probability`] weighs, from the parameters alone: the luminances
    /// of `specular` F_avg, of the Kulla–Conty lobe's `specular` F_ms (0 without that lobe) and of
    /// the latter with F_avg = 1 (the white furnace's), F_ms = [`kulla_conty::fresnel_ms`] at the
    /// table's L_avg(α), α = √(αx αy).
    pub fn lobe_luminances(&self) -> [f64; 3] {
        let lobe = luminance(self.specular * self.f_avg);
        if !self.config.kulla_conty() {
            return [lobe, 0.0, 0.0];
        }
        let table = &kulla_conty::tables()[kulla_conty::table_index(self.config)];
        let avg_loss = table.avg_at((self.alpha_x * self.alpha_y).sqrt());
        let ms = |f_avg: DVec3| {
            luminance(self.specular * f_avg.map(|f| kulla_conty::fresnel_ms(f, avg_loss)))
        };
        [lobe, ms(self.f_avg), ms(DVec3::ONE)]
    }

    /// Whether the two roughnesses are equal, so that f depends on φi and φo only through φo − φi.
    pub fn is_isotropic(&self) -> bool {
        self.alpha_x == self.alpha_y
    }

    /// The block the GPU kernels read: the parameters and what depends on them alone, computed
    /// in f64 and rounded to f32.
    pub fn gpu_params(&self) -> MicrofacetParams {
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let e2m1 = |eta: f64| (eta - 1.0) * (eta + 1.0);
        let (row, weights, scale, scale_white) = self.kulla_conty_constants();
        let lum = self.lobe_luminances();
        MicrofacetParams {
            specular: f32x3(self.specular),
            alpha2_x: (ax * ax) as f32,
            diffuse_over_pi: f32x3(self.diffuse * FRAC_1_PI),
            alpha2_y: (ay * ay) as f32,
            f0: f32x3(self.f0),
            inv_alpha2_x: (1.0 / (ax * ax)) as f32,
            one_minus_f0: f32x3(DVec3::ONE - self.f0),
            inv_alpha2_y: (1.0 / (ay * ay)) as f32,
            conductor_e2m1k2: f32x3(self.eta.map(e2m1) - self.k * self.k),
            d_norm: (FRAC_1_PI / (ax * ay)) as f32,
            conductor_q4: f32x3(4.0 * self.eta * self.eta * self.k * self.k),
            dielectric_e2m1: e2m1(self.ior) as f32,
            kc_scale: f32x3(scale),
            kc_scale_white: scale_white as f32,
            kc_weights: weights.map(|w| w as f32),
            kc_row: row as u32,
            lobe_luminance: lum[0] as f32,
            kc_luminance: lum[1] as f32,
            kc_luminance_white: lum[2] as f32,
        }
    }

    /// The Kulla–Conty lobe's constants at α = √(αx αy): the first knot and the weights of the
    /// stencil in r = √α, and F_ms / (π L_avg) for F_avg and for F_avg = 1 (as
    /// [`kulla_conty::lobe`] and [`kulla_conty::fresnel_ms`]); zeros when the lobe is off.
    fn kulla_conty_constants(&self) -> (usize, [f64; 4], DVec3, f64) {
        if !self.config.kulla_conty() {
            return (0, [0.0; 4], DVec3::ZERO, 0.0);
        }
        let table = &kulla_conty::tables()[kulla_conty::table_index(self.config)];
        let alpha = (self.alpha_x * self.alpha_y).sqrt();
        let (row, weights) = kulla_conty::lagrange(alpha.sqrt() * (kulla_conty::KNOTS - 1) as f64);
        let avg_loss = table.avg_at(alpha);
        if avg_loss <= 0.0 {
            return (row, weights, DVec3::ZERO, 0.0);
        }
        let scale = |f_avg: f64| kulla_conty::fresnel_ms(f_avg, avg_loss) / (PI * avg_loss);
        (row, weights, self.f_avg.map(scale), scale(1.0))
    }

    /// Smith Λ of direction w for the chosen distribution (and G1 variant for Beckmann).
    fn lambda(&self, w: DVec3) -> f64 {
        let t2 = alpha_tan2(w, self.alpha_x, self.alpha_y);
        match (self.config.distribution, self.config.beckmann_g1) {
            (Distribution::Ggx, _) => lambda_ggx(t2),
            (Distribution::Beckmann, BeckmannG1::Exact) => lambda_beckmann(t2),
            // Λ implied by the rational G1 = 1/(1 + Λ), so that both Smith forms can use it.
            (Distribution::Beckmann, BeckmannG1::Rational) => 1.0 / G1_beckmann_rational(t2) - 1.0,
        }
    }
}

/// F_avg = 2∫₀¹ F(μ) μ dμ of the model's Fresnel factor, per channel: 1 for `none`, Schlick's
/// closed form F0 + (1 − F0)/21, and for the exact dielectric and conductor the rule of
/// [`kulla_conty::fresnel_average`] (Gauss–Legendre, 8 × 8 points). The host computes it once
/// per parameter set; the GPU reads it from the parameter block.
pub fn fresnel_average(p: &Microfacet) -> DVec3 {
    match p.config.fresnel {
        Fresnel::None => DVec3::ONE,
        Fresnel::Schlick => p.f0 + (DVec3::ONE - p.f0) / 21.0,
        Fresnel::Dielectric => {
            DVec3::splat(kulla_conty::fresnel_average(|c| F_dielectric(c, p.ior)))
        }
        Fresnel::Conductor => {
            let channel = |i: usize| {
                kulla_conty::fresnel_average(|c| {
                    F_conductor(c, DVec3::splat(p.eta[i]), DVec3::splat(p.k[i])).x
                })
            };
            DVec3::new(channel(0), channel(1), channel(2))
        }
    }
}

/// f = diffuse/π + specular F D G/(4 c_i c_o) + specular F_ms f_ms in 1/sr, without the cosine, with the
/// components of `p.config` (f_ms, Kulla & Conty's lobe, only with `multiscatter=kulla_conty`:
/// [`kulla_conty`]); `white_furnace` sets F = 1, and so F_avg = F_ms = 1.
pub fn microfacet(p: &Microfacet, wi: DVec3, wo: DVec3, white_furnace: bool) -> DVec3 {
    microfacet_from_sum(p, wi, wo, wi + wo, white_furnace)
}

/// [`microfacet`] with s = ωi + ωo given (the GLSL albedo kernel's exact sum:
/// [`half_vector_from_sum`]).
pub fn microfacet_from_sum(
    p: &Microfacet,
    wi: DVec3,
    wo: DVec3,
    s: DVec3,
    white_furnace: bool,
) -> DVec3 {
    let (h, c_d) = half_vector_from_sum(s);
    let (c_i, c_o) = (wi.z, wo.z);
    let d = match p.config.distribution {
        Distribution::Beckmann => D_beckmann(h, p.alpha_x, p.alpha_y),
        Distribution::Ggx => D_ggx(h, p.alpha_x, p.alpha_y),
    };
    let g = match p.config.masking {
        Masking::VCavity => G_v_cavity(h.z, c_d, c_i, c_o),
        Masking::SmithSeparable => 1.0 / ((1.0 + p.lambda(wi)) * (1.0 + p.lambda(wo))),
        Masking::SmithCorrelated => 1.0 / (1.0 + p.lambda(wi) + p.lambda(wo)),
    };
    let f = if white_furnace {
        DVec3::ONE
    } else {
        match p.config.fresnel {
            Fresnel::None => DVec3::ONE,
            Fresnel::Schlick => F_schlick(c_d, p.f0),
            Fresnel::Dielectric => DVec3::splat(F_dielectric(c_d, p.ior)),
            Fresnel::Conductor => F_conductor(c_d, p.eta, p.k),
        }
    };
    let mut out = p.diffuse * FRAC_1_PI + p.specular * f * (d * g / (4.0 * c_i * c_o));
    if p.config.kulla_conty() {
        let table = &kulla_conty::tables()[kulla_conty::table_index(p.config)];
        let alpha = (p.alpha_x * p.alpha_y).sqrt();
        let (f_ms, avg_loss) = kulla_conty::lobe(table, c_i, c_o, alpha);
        let f_avg = if white_furnace { DVec3::ONE } else { p.f_avg };
        let f_ms_colour = DVec3::new(
            kulla_conty::fresnel_ms(f_avg.x, avg_loss),
            kulla_conty::fresnel_ms(f_avg.y, avg_loss),
            kulla_conty::fresnel_ms(f_avg.z, avg_loss),
        );
        out += p.specular * (f_ms_colour * f_ms);
    }
    out
}

/// Beckmann's (or, matched at its peak, GGX's) lobe per tangent axis: n = 1/(2α²).
fn microfacet_lobes(p: &ParamSet) -> Option<SamplingLobes> {
    let m = Microfacet::new(p);
    Some(SamplingLobes {
        diffuse: m.diffuse,
        specular: m.specular,
        exponents: [beckmann_exponent(m.alpha_x), beckmann_exponent(m.alpha_y)],
    })
}

/// V-cavity masking is one of the component choices.
fn has_v_cavity(model: Model) -> bool {
    matches!(model, Model::Microfacet(c) if c.masking == Masking::VCavity)
}

/// The probability of drawing from the specular lobe's visible normals rather than the cosine:
/// the luminance of `specular` F_avg (`specular` under the white furnace), the lobe's albedo
/// under the average Fresnel factor with masking's loss ignored, against that of the cosine's
/// two lobes, `diffuse` and, with Kulla–Conty's lobe, its exact directional albedo at ωo,
/// `specular` F_ms (1 − E(μo)) (its f_ms integrates to that against cos θi).
pub fn microfacet_lobe_probability(p: &Microfacet, wo: DVec3, white_furnace: bool) -> f64 {
    let [lobe, kc, kc_white] = p.lobe_luminances();
    let mut cosine = luminance(p.diffuse);
    if p.config.kulla_conty() {
        let table = &kulla_conty::tables()[kulla_conty::table_index(p.config)];
        let alpha = (p.alpha_x * p.alpha_y).sqrt();
        let kc = if white_furnace { kc_white } else { kc };
        cosine += kc * table.loss_at(wo.z, alpha);
    }
    let lobe = if white_furnace {
        luminance(p.specular)
    } else {
        lobe
    };
    mixture_share(lobe, cosine)
}

/// Draws ωi from the mixture of the specular lobe, ωo reflected about a visible normal of the
/// model's distribution ([`sample_vndf`]: GGX by Dupuy & Benyoub's spherical caps, Beckmann by
/// Heitz & d'Eon's slopes; anisotropic with αx along +x, αy along +y), and the cosine for the
/// diffuse part and the Kulla–Conty lobe, chosen by `uc` with [`microfacet_lobe_probability`].
/// The draws follow the distribution of visible normals whatever masking f uses; reflections
/// below the horizon are lost (weight 0, pdf 0).
pub fn sample_microfacet(
    p: &Microfacet,
    wo: DVec3,
    uc: f64,
    u: DVec2,
    white_furnace: bool,
) -> Sample {
    let wi = if uc < microfacet_lobe_probability(p, wo, white_furnace) {
        reflect(
            wo,
            sample_vndf(p.config.distribution, wo, p.alpha_x, p.alpha_y, u),
        )
    } else {
        sample_cosine(u)
    };
    Sample::from_draw(wi, pdf_microfacet(p, wi, wo, white_furnace), |wi| {
        microfacet(p, wi, wo, white_furnace)
    })
}

/// The density of [`sample_microfacet`]: (1 − P) cos θi/π + P D(h)/(4 c_o (1 + Λ(ωo)))
/// ([`pdf_vndf`], with the distribution's exact Smith Λ, which normalises its visible normals,
/// also where f's masking is V-cavity or Walter's rational G1), P the lobe's probability.
pub fn pdf_microfacet(p: &Microfacet, wi: DVec3, wo: DVec3, white_furnace: bool) -> f64 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let lobe = microfacet_lobe_probability(p, wo, white_furnace);
    let vndf = pdf_vndf(p.config.distribution, wi, wo, p.alpha_x, p.alpha_y);
    (1.0 - lobe) * pdf_cosine(wi) + lobe * vndf
}

#[cfg(test)]
mod sample_tests {
    use super::super::sample::checks::{check_reference, params};
    use super::{MicrofacetConfig, Model};

    #[test]
    fn microfacet_ggx_sampler_and_pdf() {
        for (set, width, white) in [
            (
                &[
                    "distribution=ggx",
                    "alpha=0.05",
                    "diffuse=0.2",
                    "fresnel=schlick",
                ][..],
                0.1,
                false,
            ),
            (
                &["distribution=ggx", "alpha=0.8", "multiscatter=kulla_conty"],
                1.0,
                false,
            ),
            (
                &[
                    "distribution=ggx",
                    "alpha_x=0.1",
                    "alpha_y=0.5",
                    "fresnel=conductor",
                ],
                0.2,
                false,
            ),
            (
                &[
                    "distribution=ggx",
                    "alpha=0.3",
                    "diffuse=0.5",
                    "fresnel=dielectric",
                ],
                0.6,
                true,
            ),
        ] {
            let p = params(Model::Microfacet(MicrofacetConfig::DEFAULT), set);
            check_reference(&p, white, width);
        }
    }

    #[test]
    fn microfacet_beckmann_sampler_and_pdf() {
        for (set, width) in [
            (
                &["distribution=beckmann", "alpha=0.05", "masking=v_cavity"][..],
                0.1,
            ),
            (
                &[
                    "distribution=beckmann",
                    "alpha=0.8",
                    "beckmann_g1=rational",
                    "diffuse=0.3",
                ],
                1.0,
            ),
            (
                &[
                    "distribution=beckmann",
                    "alpha_x=0.1",
                    "alpha_y=0.5",
                    "multiscatter=kulla_conty",
                ],
                0.2,
            ),
        ] {
            let p = params(Model::Microfacet(MicrofacetConfig::DEFAULT), set);
            check_reference(&p, false, width);
        }
    }
}
