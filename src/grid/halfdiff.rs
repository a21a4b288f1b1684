//! Rusinkiewicz's half/difference angles (1998) to direction pairs and back.

use super::angles::direction;
use glam::DVec3;

/// (ωi, ωo) of Rusinkiewicz's half/difference angles (radians): the half vector
/// h = (θh, φh), and ωi = Rz(φh) Ry(θh) d with d = (θd, φd) in h's frame; ωo is ωi's mirror
/// about h. Cells whose ωi or ωo falls below the horizon hold f = 0 (docs/design.md §2).
pub fn half_diff_to_pair(theta_h: f64, phi_h: f64, theta_d: f64, phi_d: f64) -> (DVec3, DVec3) {
    let h = direction(theta_h, phi_h);
    let d = direction(theta_d, phi_d);
    // Ry(θh), then Rz(φh).
    let (st, ct) = theta_h.sin_cos();
    let y = DVec3::new(d.x * ct + d.z * st, d.y, -d.x * st + d.z * ct);
    let (sp, cp) = phi_h.sin_cos();
    let wi = DVec3::new(y.x * cp - y.y * sp, y.x * sp + y.y * cp, y.z);
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wi, wo)
}

/// Rusinkiewicz's half/difference angles [θh, φh, θd, φd] (radians) of a pair, the inverse of
/// [`half_diff_to_pair`], built as MERL's reference reader builds them: h = (ωi + ωo)/|ωi + ωo|,
/// and d = ωi rotated by −φh about n, then by −θh about the bitangent (0, 1, 0). The rotations
/// take cos and sin of φh and θh from h itself (h_x/|h_xy|, h_y/|h_xy|, h_z, |h_xy|; φh = 0 where
/// |h_xy| = 0, as atan2(0, 0) = 0): the same rotations as through the angles, without their
/// rounding. θh, θd ∈ [0, π], φh, φd ∈ (−π, π]. Twin of `merl_half_diff` in
/// `glsl/brdf/merl.glsl`, which returns (θh, θd, φd).
pub fn pair_to_half_diff(wi: DVec3, wo: DVec3) -> [f64; 4] {
    let h = (wi + wo).normalize();
    let sin_h = h.truncate().length();
    let (cos_phi, sin_phi) = if sin_h > 0.0 {
        (h.x / sin_h, h.y / sin_h)
    } else {
        (1.0, 0.0)
    };
    let t = DVec3::new(
        cos_phi * wi.x + sin_phi * wi.y,
        cos_phi * wi.y - sin_phi * wi.x,
        wi.z,
    );
    let d = DVec3::new(h.z * t.x - sin_h * t.z, t.y, sin_h * t.x + h.z * t.z);
    [
        sin_h.atan2(h.z),
        h.y.atan2(h.x),
        d.truncate().length().atan2(d.z),
        d.y.atan2(d.x),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`pair_to_half_diff`] inverts [`half_diff_to_pair`] (both are exact rotations, so only
    /// rounding separates them), and the pair ωi = ωo = n has every angle 0.
    #[test]
    fn half_diff_angles_invert_their_pairs() {
        for &(th, ph, td, pd) in &[
            (0.3, 0.0, 0.7, 1.1),
            (1e-4, 2.0, 0.2, -2.5),
            (1.2, -1.0, 0.05, 3.0),
            (0.6, 3.1, 1.4, -0.1),
        ] {
            let (wi, wo) = half_diff_to_pair(th, ph, td, pd);
            let a = pair_to_half_diff(wi, wo);
            for (got, want) in a.iter().zip([th, ph, td, pd]) {
                assert!(
                    (got - want).abs() < 1e-12,
                    "{a:?} vs {:?}",
                    [th, ph, td, pd]
                );
            }
        }
        assert_eq!(pair_to_half_diff(DVec3::Z, DVec3::Z), [0.0; 4]);
    }
}
