//! What the crate knows about each model, stated once, by the model's own file, as a
//! [`ModelInfo`]. The rest of the crate asks the model ([`Model::info`] and the methods built on
//! it) instead of matching on its name. Adding a built-in model is its GLSL file, its Rust twin
//! (with its `INFO`), and its registry entry: the `Model` variant and its place in `Model::ALL`,
//! the `Brdf` variant with its three dispatch arms (`src/model/mod.rs`), and its line in
//! [`Model::info`] (docs/architecture.md §2.1).

pub mod catalogue;
pub mod quadrature;
pub mod runtime;

use crate::axis::Mapping;
use crate::model::params::{ParamError, ParamSpec, Value};
use crate::model::{Layout, Model, ParamSet};
use glam::DVec3;
use quadrature::SamplingLobes;

/// The parameter axis a model's albedo look-up table sweeps by default. Every key takes the same
/// value (Ashikhmin–Shirley's nu and nv: an isotropic lobe); an rgb key is set grey.
#[derive(Clone, Copy, Debug)]
pub struct LutAxis {
    /// The keys set together to each axis value.
    pub keys: &'static [&'static str],
    /// Lower end of the axis range (the mapping's value at t = 0).
    pub lo: f64,
    /// Upper end of the axis range (the mapping's value at t = 1).
    pub hi: f64,
    /// How cells map to values.
    pub mapping: Mapping,
}

/// A model's description: everything the integrators, tables, sweeps and reports need.
#[derive(Clone, Copy, Debug)]
pub struct ModelInfo {
    /// The name used on the command line, in files and as the GLSL function's name.
    pub name: &'static str,
    /// One line for `lobe models`.
    pub description: &'static str,
    /// The parameter table: key, kind, range, default, meaning.
    pub params: &'static [ParamSpec],
    /// Keys whose absence means something (the microfacet model's `alpha_x`, `alpha_y`, `f0`):
    /// reports list them only when set.
    pub optional_keys: &'static [&'static str],
    /// Name of the std430 parameter struct on both sides (`CookTorranceParams`).
    pub gpu_struct: &'static str,
    /// Field offsets of the parameter block, checked against the SPIR-V (tests/layout.rs).
    pub gpu_layout: Layout,
    /// Size of the parameter block in bytes.
    pub gpu_size: usize,
    /// A mirror spike that tables cannot hold: albedo adds it exactly, plots mark it.
    pub has_delta: bool,
    /// A Fresnel factor multiplies a specular lobe: the white furnace changes it.
    pub has_specular_fresnel: bool,
    /// A cos^n power lobe that the fast-pow variant (GLSL's plain pow) changes.
    pub pow_lobe: bool,
    /// The default axis of `lobe albedo --lut`.
    pub lut_axis: LutAxis,
    /// Puts a parameter set in the model's white configuration (colours at 1, specular lobes
    /// alone), returning whether it runs under the white furnace (see `lobe energy`).
    pub white: fn(&mut ParamSet) -> Result<bool, ParamError>,
    /// The parameter edges `lobe stability` sweeps, each a list of `key=value` assignments
    /// applied to the defaults (the defaults themselves are always swept too).
    pub stability_edges: fn(Model) -> Vec<&'static [&'static str]>,
    /// |x| of the exponential exp(x) the model evaluates at (ωi, ωo): the term of the parity
    /// tolerance for GLSL's exp/pow error, which grows with |x| (docs/design.md §10).
    pub exponent: fn(&ParamSet, DVec3, DVec3) -> f64,
    /// Whether f depends on φi and φo only through φo − φi for this parameter set.
    pub is_isotropic: fn(&ParamSet) -> bool,
    /// The peaked lobes the `importance` rule samples (None: cosine sampling alone).
    pub sampling_lobes: fn(&ParamSet) -> Option<SamplingLobes>,
    /// Whether f carries the V-cavity masking min(1, 2 c_h min(c_i, c_o)/c_d), whose kinks the
    /// `peak` rule puts on panel edges (a component choice for `microfacet`).
    pub v_cavity: fn(Model) -> bool,
}

/// [`ModelInfo::exponent`] of a model without exponentials.
pub fn no_exponent(_: &ParamSet, _: DVec3, _: DVec3) -> f64 {
    0.0
}

/// [`ModelInfo::is_isotropic`] of a model that is isotropic for every parameter set.
pub fn always_isotropic(_: &ParamSet) -> bool {
    true
}

/// [`ModelInfo::v_cavity`] of a model without V-cavity masking.
pub fn no_v_cavity(_: Model) -> bool {
    false
}

/// [`ModelInfo::white`] of a diffuse model: its albedo at 1.
pub fn white_albedo(p: &mut ParamSet) -> Result<bool, ParamError> {
    p.set("albedo", Value::One(1.0))?;
    Ok(false)
}

/// [`ModelInfo::white`] of a model with a specular lobe over a diffuse base: the lobe alone, at
/// specular = 1, under the white furnace.
pub fn white_specular_alone(p: &mut ParamSet) -> Result<bool, ParamError> {
    p.set("diffuse", Value::One(0.0))?;
    p.set("specular", Value::One(1.0))?;
    Ok(true)
}

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
