//! Terms shared by the BRDF models; twin of `glsl/brdf/terms.glsl`, line by line, in f64.

use glam::DVec3;
use std::f64::consts::PI;

pub fn pow5(x: f64) -> f64 {
    let x2 = x * x;
    x2 * x2 * x
}

/// log(1 − s) for 0 ≤ s < 1, accurate when s is tiny (see the GLSL twin for why and how).
pub fn log1m(s: f64) -> f64 {
    (-s).ln_1p()
}

/// (1 − s)^n, i.e. cos^n given s = 1 − cos, with x^0 = 1 even at x = 0 and 0^n = 0 for n > 0.
pub fn pow1m(s: f64, n: f64) -> f64 {
    if n == 0.0 {
        return 1.0;
    }
    if s >= 1.0 {
        return 0.0;
    }
    (n * log1m(s)).exp()
}

/// 1 − h_z for a unit vector h, as (h_x² + h_y²)/(1 + h_z): no cancellation near h = n.
pub fn one_minus_cos_theta(h: DVec3) -> f64 {
    (h.x * h.x + h.y * h.y) / (1.0 + h.z)
}

/// Half vector h = normalize(ωi + ωo) and c_d = ωi·h = |ωi + ωo|/2 (see the GLSL twin for why).
pub fn half_vector(wi: DVec3, wo: DVec3) -> (DVec3, f64) {
    let s = wi + wo;
    let len = s.length();
    (s / len, 0.5 * len)
}

/// Normal-incidence reflectance of a dielectric with relative IOR `eta`.
pub fn r0_from_ior(eta: f64) -> f64 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Schlick 1994, eq. 15: F = R0 + (1 - R0)(1 - c)^5.
#[allow(non_snake_case)]
pub fn F_schlick(c: f64, r0: DVec3) -> DVec3 {
    r0 + (DVec3::ONE - r0) * pow5(1.0 - c)
}

/// The Fresnel factor of a specular lobe, or 1 under the white furnace (DESIGN §3).
#[allow(non_snake_case)]
pub fn F_specular(c: f64, r0: DVec3, white_furnace: bool) -> DVec3 {
    if white_furnace {
        DVec3::ONE
    } else {
        F_schlick(c, r0)
    }
}

/// Beckmann distribution with RMS slope m; tan^2 from h_x^2 + h_y^2 (see the GLSL twin).
#[allow(non_snake_case)]
pub fn D_beckmann(h: DVec3, m: f64) -> f64 {
    let ch2 = h.z * h.z;
    let tan2 = (h.x * h.x + h.y * h.y) / ch2;
    let m2 = m * m;
    (-tan2 / m2).exp() / (PI * m2 * ch2 * ch2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed form: the Beckmann D is normalized, ∫ D(h) c_h dω_h = 1 over the hemisphere.
    /// Independent quadrature: with t = tan θh, D c_h sinθh dθh = exp(-t²/m²)/(π m²) · 2π t dt... so
    /// the integral is ∫0^∞ exp(-t²/m²) 2t/m² dt = 1. We integrate in θh numerically instead, to
    /// test the code, not the algebra.
    #[test]
    fn beckmann_d_integrates_to_one() {
        // Midpoint rule in θh on [0, π/2), 200 000 cells: error O(N^-2) ≪ 1e-6 for m ≥ 0.05.
        const TOL: f64 = 1e-6;
        for m in [0.05, 0.1, 0.3, 0.7, 1.0] {
            let n = 200_000;
            let dt = (PI / 2.0) / n as f64;
            let mut sum = 0.0;
            for k in 0..n {
                let t = (k as f64 + 0.5) * dt;
                let h = DVec3::new(t.sin(), 0.0, t.cos());
                sum += D_beckmann(h, m) * t.cos() * t.sin() * dt * 2.0 * PI;
            }
            assert!((sum - 1.0).abs() < TOL, "m = {m}: ∫ D c_h dω = {sum}");
        }
    }

    #[test]
    fn schlick_limits() {
        let r0 = DVec3::splat(0.04);
        assert_eq!(F_schlick(1.0, r0), r0);
        assert_eq!(F_schlick(0.0, r0), DVec3::ONE);
        assert!((r0_from_ior(1.5) - 0.04).abs() < 1e-15);
    }
}
