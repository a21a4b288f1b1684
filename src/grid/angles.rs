//! Cell centres of the grids' axes and directions from angles, in radians and in degrees.

use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// θ of cell k of n over [0, π/2].
pub fn theta_cell(k: usize, n: usize) -> f64 {
    (k as f64 + 0.5) * FRAC_PI_2 / n as f64
}

/// φ of cell k of n over [0, 2π).
pub fn phi_cell(k: usize, n: usize) -> f64 {
    (k as f64 + 0.5) * 2.0 * PI / n as f64
}

/// Δφ of cell k of n over [0, π].
pub fn dphi_cell(k: usize, n: usize) -> f64 {
    (k as f64 + 0.5) * PI / n as f64
}

/// (sin x, cos x) of an angle x in degrees, exact where x is a multiple of 90°: the angle is
/// reduced to the nearest multiple of 90° (exactly, in degrees) and the remainder, at most 45°, is
/// turned into radians. `x.to_radians().cos()` gives 6.1e-17 at 90°, which put a direction given
/// as θ = 90° a hair above the horizon, where a one-sided BRDF is not zero.
pub fn sin_cos_deg(x: f64) -> (f64, f64) {
    let quadrant = (x / 90.0).round();
    let (s, c) = (x - 90.0 * quadrant).to_radians().sin_cos();
    match (quadrant as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// ω = (sinθ cosφ, sinθ sinφ, cosθ) from angles in degrees, exact on the axes and the horizon
/// ([`sin_cos_deg`]).
pub fn direction_deg(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (sin_t, cos_t) = sin_cos_deg(theta_deg);
    let (sin_p, cos_p) = sin_cos_deg(phi_deg);
    DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t)
}

/// ω = (sinθ cosφ, sinθ sinφ, cosθ).
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// The directions of every (θ, φ) pair of two axes, θ-major: [`direction`] of each pair, from
/// each axis's sines and cosines taken once (the same products, so the same bits).
pub(super) fn direction_product(thetas: impl Iterator<Item = f64>, phis: &[f64]) -> Vec<DVec3> {
    let phis: Vec<(f64, f64)> = phis.iter().map(|p| p.sin_cos()).collect();
    thetas
        .flat_map(|t| {
            let (sin_t, cos_t) = t.sin_cos();
            phis.iter()
                .map(move |&(sin_p, cos_p)| DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t))
        })
        .collect()
}

/// (θ, φ) of a direction in degrees, φ in [0, 360).
pub fn angles_deg(d: DVec3) -> (f64, f64) {
    (
        d.z.clamp(-1.0, 1.0).acos().to_degrees(),
        d.y.atan2(d.x).to_degrees().rem_euclid(360.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: sin and cos of the multiples of 90° are exactly 0 and ±1, and between
    /// them the reduced form agrees with the plain one to rounding.
    #[test]
    fn sin_cos_deg_is_exact_on_the_axes() {
        for k in -8i32..=8 {
            let (s, c) = sin_cos_deg(90.0 * k as f64);
            let expect: (f64, f64) =
                [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0)][k.rem_euclid(4) as usize];
            // -0.0 == 0.0: a zero of either sign is exact.
            assert_eq!((s, c), expect, "{}°", 90 * k);
        }
        for x in [
            -1e6,
            -721.5,
            -30.0,
            1.0,
            44.9,
            45.0,
            45.1,
            89.999,
            135.0,
            300.0,
            1e6 + 0.25,
        ] {
            let (s, c) = sin_cos_deg(x);
            // The plain form rounds x·π/180 first: an absolute error of about ε·|x|·π/180.
            let (r, tol) = (f64::to_radians(x), 4.0 * f64::EPSILON * (1.0 + x.abs()));
            assert!(
                (s - r.sin()).abs() < tol && (c - r.cos()).abs() < tol,
                "{x}°: {s} {c}"
            );
        }
        assert_eq!(direction_deg(90.0, 180.0), DVec3::new(-1.0, 0.0, 0.0));
        assert_eq!(direction_deg(0.0, 37.0).z, 1.0);
    }

    #[test]
    fn cells_are_centred_and_never_on_the_pole_or_horizon() {
        assert!((theta_cell(0, 2) - PI / 8.0).abs() < 1e-15);
        assert!((theta_cell(1, 2) - 3.0 * PI / 8.0).abs() < 1e-15);
        assert!((phi_cell(0, 4) - PI / 4.0).abs() < 1e-15);
        assert!((dphi_cell(0, 1) - PI / 2.0).abs() < 1e-15);
    }
}
