//! What the albedo integrator asks of a model: the shape of its peaked lobes, so that the
//! `importance` rule can draw points where the integrand is large without knowing any model by
//! name. (Whether f carries V-cavity masking, whose kinks the `peak` rule aligns with, is
//! [`Model::has_v_cavity_masking`](super::Model::has_v_cavity_masking).)

use super::{Brdf, ParamSet};
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
        let beckmann = |m: f64| 0.5 / (m * m);
        let (diffuse, specular, exponents) = match Brdf::new(self) {
            Brdf::Phong(p) => (p.diffuse, p.specular, [p.shininess; 2]),
            Brdf::BlinnPhong(p) => {
                let n = 8192f64.powf(1.0 - p.smoothness) / 4.0;
                (p.diffuse, p.specular, [n; 2])
            }
            Brdf::CookTorrance(p) => (p.diffuse, p.specular, [beckmann(p.roughness); 2]),
            // The coat's Fresnel rises to 1 at grazing whatever R0 (`specular`) is: weigh the
            // lobe as if it reflected everything, the base by what the coat lets through.
            Brdf::AshikhminShirley(p) => (
                p.diffuse * (DVec3::ONE - p.specular),
                DVec3::ONE,
                [p.nu / 4.0, p.nv / 4.0],
            ),
            Brdf::Microfacet(p) => (
                p.diffuse,
                p.specular,
                [beckmann(p.alpha_x), beckmann(p.alpha_y)],
            ),
            // A model defined at run time states no lobes: cosine sampling alone.
            Brdf::Lambert(_)
            | Brdf::OrenNayar(_)
            | Brdf::SmoothLayered(_)
            | Brdf::Coupled(_)
            | Brdf::Runtime(_) => return None,
        };
        Some(SamplingLobes {
            diffuse,
            specular,
            exponents,
        })
    }
}
