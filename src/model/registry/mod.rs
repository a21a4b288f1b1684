//! What the crate knows about each model, stated once, by the model's own file, as a
//! [`ModelInfo`] (`info.rs` beside this file). The rest of the crate asks the model ([`Model::info`]
//! and the methods built on it) instead of matching on its name. Adding a built-in model is its GLSL file, its Rust twin
//! (with its `INFO`), and its registry entry: the `Model` variant and its place in `Model::ALL`,
//! the `Brdf` variant with its three dispatch arms (`src/model/mod.rs`), and its line in
//! [`Model::info`] (docs/architecture.md §2.1).

pub mod components;
pub mod info;
pub mod kernels;
pub mod runtime;
pub mod sampling;

use crate::model::params::ParamError;
use crate::model::{Model, ModelInfo, ParamSet};
use glam::DVec3;

impl Model {
    /// The model's description; every other question about it is answered from here.
    pub fn info(self) -> &'static ModelInfo {
        use crate::model::*;
        match self {
            Model::Lambert => &lambert::INFO,
            Model::Phong => &phong::INFO,
            Model::BlinnPhong => &blinn_phong::INFO,
            Model::OrenNayar => &oren_nayar::INFO,
            Model::CookTorrance => &cook_torrance::INFO,
            Model::SmoothLayered => &smooth_layered::INFO,
            Model::Coupled => &coupled::INFO,
            Model::AshikhminShirley => &ashikhmin_shirley::INFO,
            Model::Microfacet(_) => &microfacet::INFO,
            Model::Eon(_) => &eon::INFO,
            Model::Runtime(r) => r.info(),
        }
    }

    /// A label that tells component choices apart: `microfacet[ggx/smith_correlated/schlick]`,
    /// `eon[exact]` (just the name for models without choices).
    pub fn label(self) -> String {
        match self {
            Model::Microfacet(c) => format!("{}[{}]", self.name(), c.label()),
            Model::Eon(c) => format!("{}[{}]", self.name(), c.label()),
            _ => self.name().to_string(),
        }
    }

    /// The model with every component choice it offers: one entry per pipeline (`microfacet`
    /// gives all its combinations, `eon` its three multiple-scattering choices, other models
    /// themselves).
    pub fn variants(self) -> Vec<Model> {
        match self {
            Model::Microfacet(_) => crate::model::microfacet::MicrofacetConfig::all()
                .into_iter()
                .map(Model::Microfacet)
                .collect(),
            Model::Eon(_) => crate::model::eon::EonConfig::all()
                .into_iter()
                .map(Model::Eon)
                .collect(),
            m => vec![m],
        }
    }
}

impl ParamSet {
    /// This set in the model's white configuration, and whether that runs under the white
    /// furnace.
    pub fn white_configuration(&self) -> Result<(ParamSet, bool), ParamError> {
        let mut p = self.clone();
        let wf = (self.model().info().white)(&mut p)?;
        Ok((p, wf))
    }

    /// The same function as a `microfacet` parameter set, where the model is one
    /// (`cook_torrance` is Beckmann, V-cavity, Schlick), or None.
    pub fn as_microfacet(&self) -> Option<ParamSet> {
        match self.model() {
            Model::Microfacet(_) => Some(self.clone()),
            Model::CookTorrance => crate::model::cook_torrance::as_microfacet(self),
            _ => None,
        }
    }

    /// |x| of the exponential the model evaluates at (ωi, ωo) ([`ModelInfo::exponent`]).
    pub fn exponent_at(&self, wi: DVec3, wo: DVec3) -> f64 {
        (self.model().info().exponent)(self, wi, wo)
    }
}
