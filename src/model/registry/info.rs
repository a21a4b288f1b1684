//! The description every built-in model states about itself in its own file ([`ModelInfo`]),
//! and the small functions many of them share in it; the registry (`registry/mod.rs`) answers
//! the rest of the crate's questions from these.

use super::sampling::SamplingLobes;
use crate::axis::Mapping;
use crate::model::params::{ParamError, ParamSpec, Value};
use crate::model::{Layout, Model, ParamSet};
use glam::DVec3;

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
    /// Whether one evaluation is a long chain of square roots and divisions (Ashikhmin–Shirley,
    /// EON, the microfacet model): the table kernel runs 8 of them interleaved on the CPU drivers
    /// that gain from it (INTERLEAVED, `gpu::table_interleaves`). Lighter models ran
    /// slower so (docs/design.md §6.3).
    pub interleave_table: bool,
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
