//! What the albedo integrator asks of a model: the shape of its peaked lobes, so that the
//! `importance` rule can draw points where the integrand is large without knowing any model by
//! name. (Whether f carries V-cavity masking, whose kinks the `peak` rule aligns with, is
//! [`Model::has_v_cavity_masking`](crate::model::Model::has_v_cavity_masking).)

use crate::model::ParamSet;
use glam::DVec3;

/// A model seen as a diffuse part plus peaked lobes about the mirror direction r of ωo, each
/// lobe matched near its peak by a power cosine (r·ωi)^n of the same width.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingLobes {
    /// How much the diffuse part reflects, per channel (weighs the cosine density).
    pub diffuse: DVec3,
    /// How much the peaked lobes reflect, per channel (weighs the power-cosine lobes).
    pub specular: DVec3,
    /// The power-cosine exponents n of the lobe along the two tangent axes; equal for an
    /// isotropic lobe.
    pub exponents: [f64; 2],
}

impl ParamSet {
    /// The peaked lobes of this model at these parameters, or None for a model without one
    /// (lambert, oren_nayar, and the layered models, whose mirror spike the integrator adds
    /// exactly). The exponent matches the lobe's width for small angles α between ωi and r:
    /// - `phong`: n = shininess, exactly its lobe;
    /// - `blinn_phong`: c_h^N with θh ≈ α/2: cos^N(α/2) ≈ e^{−Nα²/8} = cos^{N/4}α, so n = N/4;
    /// - `ashikhmin_shirley`: likewise n = nu/4 and n = nv/4 (two widths when anisotropic);
    /// - `cook_torrance` (and `microfacet`, per axis): Beckmann's e^{−tan²θh/m²} ≈ e^{−α²/(4m²)}
    ///   = cos^n α with n = 1/(2m²).
    pub fn sampling_lobes(&self) -> Option<SamplingLobes> {
        (self.model().info().sampling_lobes)(self)
    }
}

/// Beckmann's e^{−tan²θh/m²} ≈ e^{−α²/(4m²)} = cos^n α near the peak: n = 1/(2m²).
pub fn beckmann_exponent(m: f64) -> f64 {
    0.5 / (m * m)
}

/// [`super::ModelInfo::sampling_lobes`] of a model without peaked lobes.
pub fn no_lobes(_: &ParamSet) -> Option<SamplingLobes> {
    None
}
