//! Terms shared by the BRDF models; twin of `glsl/brdf/terms.glsl`, line by line, in f64.

use glam::DVec3;
use std::f64::consts::PI;

/// x⁵ by two squarings.
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

/// [`half_vector`] from s = ωi + ωo given by the caller. The f32 twin's albedo kernel passes the
/// sum formed exactly from a node's offset from the mirror direction (the f32 sum ωi + ωo would
/// keep the roundings of their cancelling tangential parts); in f64 every caller passes ωi + ωo.
pub fn half_vector_from_sum(s: DVec3) -> (DVec3, f64) {
    let len = s.length();
    (s / len, 0.5 * len)
}

/// Half vector h = normalize(ωi + ωo) and c_d = ωi·h = |ωi + ωo|/2 (see the GLSL twin for why).
pub fn half_vector(wi: DVec3, wo: DVec3) -> (DVec3, f64) {
    half_vector_from_sum(wi + wo)
}

/// Normal-incidence reflectance of a dielectric with relative IOR `eta`.
pub fn r0_from_ior(eta: f64) -> f64 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Schlick 1994, eq. 15: F = R0 + (1 - R0)(1 - c)^5.
#[allow(non_snake_case)]
pub fn F_schlick(c: f64, r0: DVec3) -> DVec3 {
    r0 + (DVec3::ONE - r0) * pow5(1.0 - c.min(1.0)) // c ≤ 1: see the GLSL twin
}

/// 1 − (1 − x)⁵ as x(1 + y + y² + y³ + y⁴), y = 1 − x: no cancellation (see the GLSL twin).
pub fn pow5_complement(x: f64) -> f64 {
    let y = 1.0 - x;
    x * (1.0 + y * (1.0 + y * (1.0 + y * (1.0 + y))))
}

/// The Fresnel factor of a specular lobe, or 1 under the white furnace (docs/design.md §3).
#[allow(non_snake_case)]
pub fn F_specular(c: f64, r0: DVec3, white_furnace: bool) -> DVec3 {
    if white_furnace {
        DVec3::ONE
    } else {
        F_schlick(c, r0)
    }
}

/// Anisotropic Beckmann distribution (Heitz 2014, eq. 84); 0 where exp(−e) underflows, so that
/// an underflowing denominator cannot make 0/0 (see the GLSL twin).
#[allow(non_snake_case)]
pub fn D_beckmann(h: DVec3, ax: f64, ay: f64) -> f64 {
    let ch2 = h.z * h.z;
    let e = (h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay)) / ch2;
    let peak = (-e).exp();
    if peak == 0.0 {
        0.0
    } else {
        peak / (PI * ax * ay * ch2 * ch2)
    }
}

/// Anisotropic GGX / Trowbridge–Reitz distribution (Walter et al. 2007 eq. 33; Heitz 2014 eq. 85).
#[allow(non_snake_case)]
pub fn D_ggx(h: DVec3, ax: f64, ay: f64) -> f64 {
    let q = h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay) + h.z * h.z;
    1.0 / (PI * ax * ay * q * q)
}

/// (α tanθ)² of a direction for anisotropic roughness (Heitz 2014, eqs. 80–81).
pub fn alpha_tan2(w: DVec3, ax: f64, ay: f64) -> f64 {
    (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z)
}

/// Smith Λ for GGX (Heitz 2014, eq. 86), without cancellation for small t². The GLSL kernel forms
/// G/(4 c_i c_o) from s = √(c² + (α sinθ)²) instead (`microfacet_vis`, docs/design.md §3).
pub fn lambda_ggx(t2: f64) -> f64 {
    t2 / (2.0 * ((1.0 + t2).sqrt() + 1.0))
}

/// Smith Λ for Beckmann, exact (Heitz 2014, eq. 83), with erfc from libm (f64; the GLSL twin uses
/// Numerical Recipes' erfcc, 1.2e-7 relative).
pub fn lambda_beckmann(t2: f64) -> f64 {
    if t2 <= 0.0 {
        return 0.0;
    }
    let a = 1.0 / t2.sqrt();
    0.5 * ((-a * a).exp() / (a * PI.sqrt()) - libm::erfc(a))
}

/// Walter et al. 2007, eq. 27: the rational approximation of Beckmann's Smith G1, a = 1/tan θ.
/// The GLSL twin returns numerator and denominator, both multiplied by (α sinθ)², so that a
/// costs it a square root and no division; this form is the readable one.
#[allow(non_snake_case)]
pub fn G1_beckmann_rational(t2: f64) -> f64 {
    if t2 <= 0.0 {
        return 1.0;
    }
    let a = 1.0 / t2.sqrt();
    if a >= 1.6 {
        return 1.0;
    }
    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
}

/// V-cavity masking-shadowing (Cook & Torrance 1982): min(1, 2 c_h c_o / c_d, 2 c_h c_i / c_d).
#[allow(non_snake_case)]
pub fn G_v_cavity(c_h: f64, c_d: f64, c_i: f64, c_o: f64) -> f64 {
    (2.0 * c_h * c_i.min(c_o) / c_d).min(1.0)
}

/// Exact unpolarized dielectric Fresnel reflectance (Walter et al. 2007, eq. 22).
#[allow(non_snake_case)]
pub fn F_dielectric(c: f64, eta: f64) -> f64 {
    // (η − 1)(η + 1) and g − c = (η² − 1)/(g + c): no cancellation as η → 1 (see the GLSL twin).
    let e2m1 = (eta - 1.0) * (eta + 1.0);
    let g2 = e2m1 + c * c;
    if g2 < 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let gpc = g + c;
    if gpc == 0.0 {
        return 0.0; // η = 1 at grazing: no interface
    }
    let a = e2m1 / (gpc * gpc);
    let s2 = 1.0 - c * c;
    let b = (c * g - s2) / (c * g + s2);
    0.5 * a * a * (1.0 + b * b)
}

/// Exact unpolarized conductor Fresnel reflectance for complex IOR η + iκ, per channel (Born &
/// Wolf §14.2; Lagarde 2013). Equals [`F_dielectric`] when κ = 0.
#[allow(non_snake_case)]
pub fn F_conductor(c: f64, eta: DVec3, k: DVec3) -> DVec3 {
    // Sums of squares without cancelling differences; see the GLSL twin for the derivation.
    let tiny = DVec3::splat(1e-30);
    let (c2, s2) = (c * c, 1.0 - c * c);
    let e2m1k2 = (eta - 1.0) * (eta + 1.0) - k * k;
    let t0 = e2m1k2 + DVec3::splat(c2);
    let q = 2.0 * eta * eta * k * k;
    let a2b2 = (t0 * t0 + 2.0 * q).map(f64::sqrt);
    // The larger of a², b² is (|a² + b²| + |t0|)/2, the smaller their product η²κ² over it.
    let w = a2b2 + t0.abs();
    let r = q / w.max(tiny);
    let t0_pos = t0.cmpge(DVec3::ZERO);
    let a2 = DVec3::select(t0_pos, 0.5 * w, r);
    let b2 = DVec3::select(t0_pos, r, 0.5 * w);
    let a = a2.map(f64::sqrt);
    let a2mc2 = DVec3::select(t0_pos, e2m1k2 + r, r - DVec3::splat(c2));
    let amc = a2mc2 / (a + DVec3::splat(c)).max(tiny);
    let apc = a + DVec3::splat(c);
    let rs = (amc * amc + b2) / (apc * apc + b2).max(tiny);
    let ac = a * c;
    let bc2 = b2 * c2;
    let (m, p) = (ac - DVec3::splat(s2), ac + DVec3::splat(s2));
    let rp = rs * (m * m + bc2) / (p * p + bc2).max(tiny);
    0.5 * (rp + rs)
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
                sum += D_beckmann(h, m, m) * t.cos() * t.sin() * dt * 2.0 * PI;
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

    #[test]
    fn schlick_never_drops_below_r0_for_c_above_one() {
        // c_d of f32 unit vectors can exceed 1 by a few ulp.
        assert_eq!(F_schlick(1.0 + 1e-7, DVec3::ZERO), DVec3::ZERO);
    }

    #[test]
    fn pow5_complement_equals_the_direct_form_and_keeps_small_arguments() {
        for x in [0.0f64, 1e-3, 0.1, 0.37, 0.5, 0.9, 1.0] {
            let direct = 1.0 - (1.0 - x).powi(5);
            assert!((pow5_complement(x) - direct).abs() < 1e-15, "x = {x}");
        }
        // 1 − (1 − x)⁵ = 5x − 10x² + …: at x = 1e-20 the direct form gives 0.
        assert!((pow5_complement(1e-20) / 5e-20 - 1.0).abs() < 1e-15);
    }

    /// |z|² of a complex number (re, im).
    fn norm2(z: (f64, f64)) -> f64 {
        z.0 * z.0 + z.1 * z.1
    }

    fn cdiv(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
        let d = norm2(b);
        ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
    }

    /// Fresnel for a complex index n = η + iκ straight from the amplitude coefficients (Born &
    /// Wolf §1.5, §14.2): w = √(n² − s²), r_s = (c − w)/(c + w), r_p = (n² c − w)/(n² c + w),
    /// F = (|r_s|² + |r_p|²)/2 — complex arithmetic, independent of the a, b algebra under test.
    fn fresnel_complex(c: f64, eta: f64, k: f64) -> f64 {
        let n2 = (eta * eta - k * k, 2.0 * eta * k);
        // n² − s² with n² − 1 as (η − 1)(η + 1) − κ², so that the reference itself is exact
        // at an index-matched interface (η = 1, κ = 0 gives z = c², F = 0).
        let z = ((eta - 1.0) * (eta + 1.0) - k * k + c * c, n2.1);
        // Principal square root (Im ≥ 0), with the smaller part from the larger one's
        // (Re w · Im w = Im z / 2) so that it does not cancel.
        let m = norm2(z).sqrt();
        let w = if z.0 >= 0.0 {
            let re = ((m + z.0) / 2.0).sqrt();
            (re, if re > 0.0 { z.1 / (2.0 * re) } else { 0.0 })
        } else {
            let im = ((m - z.0) / 2.0).sqrt();
            (z.1 / (2.0 * im), im)
        };
        let rs = cdiv((c - w.0, -w.1), (c + w.0, w.1));
        let n2c = (n2.0 * c, n2.1 * c);
        let rp = cdiv((n2c.0 - w.0, n2c.1 - w.1), (n2c.0 + w.0, n2c.1 + w.1));
        0.5 * (norm2(rs) + norm2(rp))
    }

    #[test]
    fn conductor_matches_complex_fresnel_and_the_dielectric() {
        // Both are f64 evaluations of the same reflectance; 1e-12 relative leaves room for the
        // conditioning of r_p near its minimum (Brewster-like angle).
        const REL: f64 = 1e-12;
        for &(eta, k) in &[
            (0.2, 3.0),
            (1.0, 0.0),
            (1.0, 1e-4),
            (1.5, 0.0),
            (1.5, 0.2),
            (3.0, 4.0),
            (0.5, 0.0),
        ] {
            for c in [1e-6, 0.01, 0.2, 0.5, 0.8, 1.0] {
                let got = F_conductor(c, DVec3::splat(eta), DVec3::splat(k)).x;
                let want = fresnel_complex(c, eta, k);
                assert!(
                    got >= 0.0 && (got - want).abs() <= REL * want.max(1e-300) + 1e-300,
                    "eta {eta} k {k} c {c}: {got} vs {want}"
                );
                if k == 0.0 {
                    let d = F_dielectric(c, eta);
                    assert!(
                        (got - d).abs() <= REL * d.max(1e-300) + 1e-300,
                        "eta {eta} c {c}: {got} vs dielectric {d}"
                    );
                }
            }
        }
        // An index-matched interface reflects nothing.
        assert_eq!(F_conductor(0.3, DVec3::ONE, DVec3::ZERO), DVec3::ZERO);
    }
}
