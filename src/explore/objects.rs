//! The lit objects of the page's lit view: a sphere and a torus seen from +z (orthographic, the
//! image's x to the right and y up), lit by a distant point light of unit irradiance at normal
//! incidence from the polar plot's light direction, so that a point's radiance is f·cos θi
//! (0 where the object shadows itself). Each cell gives the pair in the surface's local frame
//! (tangent, bitangent, normal) and that cosine.

use super::cells::Setting;
use crate::plot::hemisphere::cell_point;
use crate::plot::polar::light_direction;
use glam::{DVec2, DVec3};

/// The pair of a surface point with normal `n` and tangent `t` (unit, orthogonal) seen from +z
/// under the light, and its factor cos θi (`lit`: the light reaches the point).
fn lit_pair(n: DVec3, t: DVec3, at: Setting, lit: bool) -> (DVec3, DVec3, f64) {
    let b = n.cross(t);
    let local = |w: DVec3| DVec3::new(w.dot(t), w.dot(b), w.dot(n));
    let wi = local(light_direction(at.theta_i));
    let wo = local(DVec3::Z);
    (wi, wo, if lit { wi.z.max(0.0) } else { 0.0 })
}

/// A unit sphere. Each normal's tangent frame is glam's `any_orthonormal_pair` (Duff et al.
/// 2017), so an anisotropic model's tangent turns with the normal. A sphere does not shadow
/// itself.
pub(super) fn sphere_cell(
    res: usize,
    row: usize,
    col: usize,
    at: Setting,
) -> Option<(DVec3, DVec3, f64)> {
    let (x, y) = cell_point(res, row, col);
    let r2 = x * x + y * y;
    if r2 > 1.0 {
        return None;
    }
    let n = DVec3::new(x, y, (1.0 - r2).sqrt());
    let (t, _) = n.any_orthonormal_pair();
    Some(lit_pair(n, t, at, true))
}

/// The torus's radius to the centre of its tube, and the tube's: R + r = 0.92 fits the image
/// ([-1, 1] across) with a margin.
const TORUS_R: f64 = 0.62;
const TORUS_TUBE: f64 = 0.3;

/// The torus's axis: tipped 45° from the view direction towards +y, so that the image shows its
/// hole (the tube's near and far sides are 0.28 apart at the centre) and normals from grazing to
/// facing the viewer, on the ring's outer and inner sides.
const TORUS_AXIS: DVec3 = DVec3::new(
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
    std::f64::consts::FRAC_1_SQRT_2,
);

/// The distance from `p` to the torus, negative inside: exact (the distance to the tube's centre
/// circle less the tube's radius), so sphere tracing may step by it.
fn torus_distance(p: DVec3) -> f64 {
    let h = p.dot(TORUS_AXIS);
    let rho = (p - h * TORUS_AXIS).length();
    DVec2::new(rho - TORUS_R, h).length() - TORUS_TUBE
}

/// The torus's outward normal at a point on (or next to) it: from the nearest point of the tube's
/// centre circle.
fn torus_normal(p: DVec3) -> DVec3 {
    let h = p.dot(TORUS_AXIS);
    let radial = (p - h * TORUS_AXIS).normalize();
    (p - TORUS_R * radial).normalize()
}

/// A ray's march stops at a point this close to the torus: far below a cell (2/256 across at the
/// largest image) and the directions' own rounding matters less than this shift.
const HIT_DISTANCE: f64 = 1e-12;
/// Steps of one march: a ray that grazes the tube at an angle ε shortens its step by a factor
/// about 1 − ε each step, so a ray 0.1° from tangent needs some 14000 to reach [`HIT_DISTANCE`].
const MAX_STEPS: usize = 20_000;
/// Where a ray's march gives up: past the torus's bounding sphere, seen from its start.
const MAX_DISTANCE: f64 = 4.0;
/// A shadow ray starts this far off the surface along the normal, so that its first step is not
/// the point it starts from (a million times [`HIT_DISTANCE`]).
const SHADOW_OFFSET: f64 = 1e-6;

/// Sphere tracing (Hart 1996, "Sphere tracing: a geometric method for the antialiased ray
/// tracing of implicit surfaces"): the distance along `dir` from `origin` to the torus, if the
/// ray meets it.
fn torus_march(origin: DVec3, dir: DVec3) -> Option<f64> {
    let mut t = 0.0;
    for _ in 0..MAX_STEPS {
        let d = torus_distance(origin + t * dir);
        if d < HIT_DISTANCE {
            return Some(t);
        }
        t += d;
        if t > MAX_DISTANCE {
            return None;
        }
    }
    None
}

/// A torus (radii [`TORUS_R`], [`TORUS_TUBE`], axis [`TORUS_AXIS`]). Its tangent runs around the
/// axis (a × p), as a brushed ring's grooves do, so an anisotropic model's `alpha_x` lies along
/// the ring. A point the torus hides from the light is dark.
pub(super) fn torus_cell(
    res: usize,
    row: usize,
    col: usize,
    at: Setting,
) -> Option<(DVec3, DVec3, f64)> {
    let (x, y) = cell_point(res, row, col);
    // The view ray comes from +z, starting outside the bounding sphere (radius R + r < 1).
    let origin = DVec3::new(x, y, 2.0);
    let t = torus_march(origin, -DVec3::Z)?;
    let p = origin - t * DVec3::Z;
    let n = torus_normal(p);
    let tangent = TORUS_AXIS.cross(p).normalize();
    let light = light_direction(at.theta_i);
    let lit = light.dot(n) > 0.0 && torus_march(p + SHADOW_OFFSET * n, light).is_none();
    Some(lit_pair(n, tangent, at, lit))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The march reaches the torus where a ray meets it, and the normal there is the distance's
    /// gradient (a central difference of it).
    #[test]
    fn a_marched_point_is_on_the_torus_with_its_normal() {
        let at = Setting {
            theta_i: 0.5,
            phi_d: std::f64::consts::FRAC_PI_2,
        };
        let res = 33;
        let mut hits = 0;
        for row in 0..res {
            for col in 0..res {
                let (x, y) = cell_point(res, row, col);
                let Some(t) = torus_march(DVec3::new(x, y, 2.0), -DVec3::Z) else {
                    continue;
                };
                hits += 1;
                let p = DVec3::new(x, y, 2.0 - t);
                assert!(
                    torus_distance(p).abs() < 1e-9,
                    "({x}, {y}): {}",
                    torus_distance(p)
                );
                let e = 1e-6;
                let grad = DVec3::new(
                    torus_distance(p + e * DVec3::X) - torus_distance(p - e * DVec3::X),
                    torus_distance(p + e * DVec3::Y) - torus_distance(p - e * DVec3::Y),
                    torus_distance(p + e * DVec3::Z) - torus_distance(p - e * DVec3::Z),
                ) / (2.0 * e);
                let n = torus_normal(p);
                assert!((grad - n).length() < 1e-6, "({x}, {y}): {grad} vs {n}");
                // The view sees the outside of the surface.
                assert!(n.z > 0.0, "({x}, {y}): {n}");
                let (wi, wo, _) = torus_cell(res, row, col, at).unwrap();
                assert!((wi.length() - 1.0).abs() < 1e-12 && (wo.length() - 1.0).abs() < 1e-12);
            }
        }
        // The middle cell looks through the hole.
        assert!(torus_cell(res, res / 2, res / 2, at).is_none());
        assert!(
            hits > res * res / 4,
            "{hits} of {} cells meet the torus",
            res * res
        );
    }
}
