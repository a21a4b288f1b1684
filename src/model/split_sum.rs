//! What the split sum (Karis 2013, "Real Shading in Unreal Engine 4"; docs/design.md §15.3)
//! needs of a model: its microfacet lobe's distribution and roughness, the Fresnel factor's F0
//! and F90, the lobe's weight, and the Lambertian albedo beside it. Models with neither a
//! microfacet lobe nor a Lambertian part have no description: the split sum cannot prefilter
//! them.
//!
//! This description has no GLSL twin: the split sum is computed on the host in f64 whatever the
//! backend (only its DFG rows come from the backend's engine LUT), since it is the
//! approximation under test and its prefilter is a weighted sum over the map's texels, not a
//! kernel's per-pixel work.

use super::microfacet::Microfacet;
use super::registry::components::{Distribution, Fresnel};
use super::terms::{D_beckmann, D_ggx, F_conductor, F_dielectric};
use super::{Model, ParamSet};
use glam::DVec3;

/// A model's microfacet lobe as the split sum takes it: isotropic, its Fresnel factor replaced
/// by Schlick's form F0 + (F90 − F0)(1 − ωi·h)⁵ that the DFG table factors.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecularLobe {
    /// The normal distribution D.
    pub distribution: Distribution,
    /// The roughness α; an anisotropic lobe's √(αx αy).
    pub alpha: f64,
    /// The Fresnel factor at normal incidence, per channel.
    pub f0: DVec3,
    /// The Fresnel factor at grazing incidence, per channel.
    pub f90: DVec3,
    /// The lobe's weight, per channel.
    pub weight: DVec3,
    /// The `--set` assignments that make lobe's engine DFG table (`lobe albedo --engine dfg`)
    /// integrate this lobe's D and G: its distribution, masking and Beckmann G1.
    pub lut_sets: Vec<String>,
}

impl SpecularLobe {
    /// D at a half vector whose cosine with the lobe's axis is `cos_h` (D is isotropic).
    pub fn d(&self, cos_h: f64) -> f64 {
        let c = cos_h.clamp(0.0, 1.0);
        let h = DVec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
        match self.distribution {
            Distribution::Ggx => D_ggx(h, self.alpha, self.alpha),
            Distribution::Beckmann => D_beckmann(h, self.alpha, self.alpha),
        }
    }
}

/// A model as the split sum takes it: a microfacet lobe (if any) and a Lambertian albedo.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitSumLobe {
    /// The microfacet lobe, None for a purely Lambertian model.
    pub specular: Option<SpecularLobe>,
    /// The Lambertian albedo ρ (f = ρ/π), per channel; 0 where the model has none.
    pub diffuse: DVec3,
}

/// The split sum's description of `params`, every Fresnel factor 1 where `white_furnace`; None
/// for a model with no microfacet lobe the split sum can prefilter (every model but `lambert`,
/// `microfacet` and `cook_torrance`).
pub fn split_sum_lobe(params: &ParamSet, white_furnace: bool) -> Option<SplitSumLobe> {
    match params.model() {
        Model::Lambert => Some(SplitSumLobe {
            specular: None,
            diffuse: params.rgb("albedo"),
        }),
        Model::Microfacet(_) => Some(microfacet_lobe(params, white_furnace)),
        Model::CookTorrance => {
            split_sum_lobe(&super::cook_torrance::as_microfacet(params)?, white_furnace)
        }
        _ => None,
    }
}

/// The microfacet model's lobe: α = √(αx αy) (the geometric mean for an anisotropic lobe), F0
/// the chosen Fresnel factor at normal incidence and F90 = 1 (both 1 for `fresnel=none` or the
/// white furnace); the single-scattering lobe only (a Kulla–Conty lobe is not prefiltered).
fn microfacet_lobe(params: &ParamSet, white_furnace: bool) -> SplitSumLobe {
    let m = Microfacet::new(params);
    let f0 = if white_furnace {
        DVec3::ONE
    } else {
        match m.config.fresnel {
            Fresnel::None => DVec3::ONE,
            Fresnel::Schlick => m.f0,
            Fresnel::Dielectric => DVec3::splat(F_dielectric(1.0, m.ior)),
            Fresnel::Conductor => F_conductor(1.0, m.eta, m.k),
        }
    };
    let c = m.config;
    SplitSumLobe {
        specular: Some(SpecularLobe {
            distribution: c.distribution,
            alpha: (m.alpha_x * m.alpha_y).sqrt(),
            f0,
            f90: DVec3::ONE,
            weight: m.specular,
            lut_sets: vec![
                format!("distribution={}", c.distribution.name()),
                format!("masking={}", c.masking.name()),
                format!("beckmann_g1={}", c.beckmann_g1.name()),
            ],
        }),
        diffuse: m.diffuse,
    }
}
