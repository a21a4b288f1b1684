//! The direction regions of the sweep (see the module's notes), already rounded to f32.

use crate::grid::direction;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// One region of direction pairs.
#[derive(Clone, Debug)]
pub struct Region {
    /// The region's name, as the report's rows show it.
    pub name: &'static str,
    /// (ωi, ωo) pairs, both above the horizon, already rounded to f32 and widened back.
    pub pairs: Vec<(DVec3, DVec3)>,
}

/// Cosines of θ toward the horizon: θ → 90°.
pub const GRAZING_COS: [f64; 5] = [1e-7, 1e-6, 1e-5, 1e-4, 1e-3];
/// Angular offsets from the mirror direction, radians.
pub const MIRROR_OFFSETS: [f64; 5] = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2];

/// Rounds to what the GPU receives, widened back to f64.
fn as_f32(v: DVec3) -> DVec3 {
    DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64)
}

/// The direction with cos θ = c exactly (sin θ from c without going through θ).
fn dir_cos(c: f64, phi: f64) -> DVec3 {
    let s = (1.0 - c * c).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), c)
}

/// The direction regions, already rounded to f32 (see the module's notes).
pub fn regions() -> Vec<Region> {
    let (mirror, near_mirror) = mirror_pairs();
    let round = |v: Vec<(DVec3, DVec3)>| -> Vec<(DVec3, DVec3)> {
        v.into_iter().map(|(a, b)| (as_f32(a), as_f32(b))).collect()
    };
    vec![
        Region {
            name: "interior",
            pairs: round(interior_pairs()),
        },
        Region {
            name: "grazing",
            pairs: round(grazing_pairs()),
        },
        Region {
            name: "wi=wo",
            pairs: round(same_pairs()),
        },
        Region {
            name: "mirror",
            pairs: round(mirror),
        },
        Region {
            name: "near-mirror",
            pairs: round(near_mirror),
        },
        Region {
            name: "opposite-grazing",
            pairs: round(opposite_pairs()),
        },
    ]
}

fn deg(d: f64) -> f64 {
    d.to_radians()
}

/// The azimuth of most regions' first direction.
const PHI0_DEG: f64 = 20.0;

/// Polar angles of the ωi = ωo and mirror regions, radians.
fn thetas() -> [f64; 6] {
    [0.0, 1e-4, deg(10.0), deg(45.0), deg(80.0), deg(89.9)]
}

/// An interior reference set: θi over 0..85°, each with five (θo, Δφ).
fn interior_pairs() -> Vec<(DVec3, DVec3)> {
    let phi0 = deg(PHI0_DEG);
    let mut interior = Vec::new();
    for ti in [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0] {
        for (to, dphi) in [
            (0.0, 0.0),
            (30.0, 90.0),
            (60.0, 180.0),
            (45.0, 135.0),
            (80.0, 30.0),
        ] {
            interior.push((
                direction(deg(ti), phi0),
                direction(deg(to), phi0 + deg(dphi)),
            ));
        }
    }
    interior
}

/// θ → 90° on either side or both.
fn grazing_pairs() -> Vec<(DVec3, DVec3)> {
    let phi0 = deg(PHI0_DEG);
    let mut grazing = Vec::new();
    for c in GRAZING_COS {
        for (to, dphi) in [
            (0.0, 0.0),
            (45.0, 180.0),
            (45.0, 90.0),
            (80.0, 180.0),
            (80.0, 0.0),
        ] {
            let other = direction(deg(to), phi0 + deg(dphi));
            grazing.push((dir_cos(c, phi0), other));
            grazing.push((other, dir_cos(c, phi0)));
        }
        for c2 in GRAZING_COS {
            for dphi in [90.0, 150.0] {
                grazing.push((dir_cos(c, phi0), dir_cos(c2, phi0 + deg(dphi))));
            }
        }
    }
    grazing
}

/// ωi = ωo, down to grazing.
fn same_pairs() -> Vec<(DVec3, DVec3)> {
    let phi0 = deg(PHI0_DEG);
    let mut same = Vec::new();
    for t in thetas() {
        for phi in [0.0, phi0, deg(200.0)] {
            let w = direction(t, phi);
            same.push((w, w));
        }
    }
    for c in GRAZING_COS {
        for phi in [0.0, phi0, deg(200.0)] {
            let w = dir_cos(c, phi);
            same.push((w, w));
        }
    }
    same
}

/// ωi the mirror of ωo (h = n), and within [`MIRROR_OFFSETS`] of it.
fn mirror_pairs() -> (Vec<(DVec3, DVec3)>, Vec<(DVec3, DVec3)>) {
    let phi0 = deg(PHI0_DEG);
    let mut mirror = Vec::new();
    let mut near_mirror = Vec::new();
    for t in thetas() {
        for phi in [0.0, phi0] {
            mirror.push((direction(t, phi), direction(t, phi + PI)));
            for d in MIRROR_OFFSETS {
                let to = (t + d).min(FRAC_PI_2 - 1e-7);
                near_mirror.push((direction(t, phi), direction(to, phi + PI)));
                near_mirror.push((direction(t, phi), direction(t, phi + PI + d)));
            }
        }
    }
    (mirror, near_mirror)
}

/// Opposite grazing directions: |ωi + ωo| = 2 cos θ → 0 and h → n.
fn opposite_pairs() -> Vec<(DVec3, DVec3)> {
    let phi0 = deg(PHI0_DEG);
    let mut opposite = Vec::new();
    for c in GRAZING_COS {
        for phi in [0.0, phi0] {
            // Exactly opposite in azimuth: ωi + ωo = (0, 0, 2c), h = n, c_d = c.
            opposite.push((dir_cos(c, phi), dir_cos(c, phi + PI)));
            for c2 in GRAZING_COS {
                if c2 != c {
                    opposite.push((dir_cos(c, phi), dir_cos(c2, phi + PI)));
                }
            }
            for d in MIRROR_OFFSETS {
                opposite.push((dir_cos(c, phi), dir_cos(c, phi + PI + d)));
            }
        }
    }
    opposite
}
