//! The `merl` lookup: f of a MERL table at a pair, in f64: the twin of `glsl/brdf/merl.glsl`, line by line, with
//! libm's atan2 where the GLSL has `merl_angle`. The nearest-bin lookup is MERL's reader's.

use crate::grid::{dphi_cell, pair_to_half_diff, theta_cell};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// Bins per axis: θh, θd, φd (φd over [0, π)).
pub const DIMS: [usize; 3] = [90, 90, 180];

/// Bins per channel, 90 × 90 × 180.
pub const BINS: usize = DIMS[0] * DIMS[1] * DIMS[2];

/// A file's table: f in 1/sr at every bin, planar (channel c of bin k at `c * BINS + k`), missing
/// bins as 0.
#[derive(Clone, Debug, PartialEq)]
pub struct MerlTable {
    /// stored × the file's scale ([`crate::merl::SCALE`]), 3 × [`BINS`] values, planar.
    pub values: Vec<f64>,
    /// How many stored values were negative (missing), over all three channels.
    pub missing: usize,
}

/// The bin of (θh, θd, φd) = (`h`, `d`, `p`): `p + 180 (d + 90 h)`.
pub fn bin(h: usize, d: usize, p: usize) -> usize {
    p + DIMS[2] * (d + DIMS[1] * h)
}

/// The angles (θh, θd, φd) at the centre of bin (`h`, `d`, `p`): each axis's continuous
/// coordinate ([`merl_coordinates`]) at k + ½, so θh = (π/2)((h + ½)/90)², θd =
/// (d + ½)(π/2)/90 and φd = (p + ½)π/180. The θd and φd centres are those of lobe's `halfdiff`
/// grid at 90,90,180; its θh cells are uniform, these are not.
pub fn bin_centre(h: usize, d: usize, p: usize) -> [f64; 3] {
    let u = (h as f64 + 0.5) / DIMS[0] as f64;
    [
        FRAC_PI_2 * u * u,
        theta_cell(d, DIMS[1]),
        dphi_cell(p, DIMS[2]),
    ]
}

/// The options of the model's `lookup` parameter, in the order of their GPU indices.
pub const LOOKUPS: &[&str] = &["nearest", "trilinear"];

/// How a pair's value comes out of the bins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    /// The bin the pair falls in (MERL's reader): piecewise constant.
    Nearest,
    /// Trilinear between the eight bin centres around the pair's bin coordinates: beyond the
    /// first or last centre of θh and θd the edge bin holds; φd wraps (f(φd) = f(φd + π), so bin
    /// 179 neighbours bin 0).
    Trilinear,
}

impl Lookup {
    /// The lookup of option index `k` of [`LOOKUPS`] (as the parameter block carries it).
    pub fn from_index(k: f64) -> Lookup {
        if k == 1.0 {
            Lookup::Trilinear
        } else {
            Lookup::Nearest
        }
    }
}

/// The continuous bin coordinates of (θh, θd, φd): MERL's reader takes the floor of each (θh →
/// 90 √(θh/(π/2)), θd → 90 θd/(π/2), φd + π where negative, then 180 φd/π), so bin k spans
/// [k, k + 1) and its centre is k + ½.
pub fn merl_coordinates(theta_h: f64, theta_d: f64, phi_d: f64) -> [f64; 3] {
    let phi_d = if phi_d < 0.0 { phi_d + PI } else { phi_d };
    [
        if theta_h <= 0.0 {
            0.0
        } else {
            DIMS[0] as f64 * (theta_h / FRAC_PI_2).sqrt()
        },
        DIMS[1] as f64 * theta_d / FRAC_PI_2,
        DIMS[2] as f64 * phi_d / PI,
    ]
}

fn merl_bin(t: &[f64], h: usize, d: usize, p: usize) -> DVec3 {
    let k = bin(h, d, p);
    DVec3::new(t[k], t[k + BINS], t[k + 2 * BINS])
}

/// `k` clamped to [0, n − 1].
fn clamp_axis(k: i64, n: usize) -> usize {
    k.clamp(0, n as i64 - 1) as usize
}

/// MERL's reader: the bin the coordinates fall in, each clamped to its axis.
pub fn merl_nearest(t: &[f64], u: [f64; 3]) -> DVec3 {
    let h = clamp_axis(u[0] as i64, DIMS[0]);
    let d = clamp_axis(u[1] as i64, DIMS[1]);
    let p = clamp_axis(u[2] as i64, DIMS[2]);
    merl_bin(t, h, d, p)
}

/// [`Lookup::Trilinear`] at the coordinates `u`.
pub fn merl_trilinear(t: &[f64], u: [f64; 3]) -> DVec3 {
    let c = u.map(|x| x - 0.5);
    let base = c.map(f64::floor);
    let w = [c[0] - base[0], c[1] - base[1], c[2] - base[2]];
    let mut f = DVec3::ZERO;
    for k in 0..8 {
        let (dh, dd, dp) = (k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let weight = |s: usize, x: f64| if s == 1 { x } else { 1.0 - x };
        let wk = weight(dh, w[0]) * weight(dd, w[1]) * weight(dp, w[2]);
        let h = clamp_axis(base[0] as i64 + dh as i64, DIMS[0]);
        let d = clamp_axis(base[1] as i64 + dd as i64, DIMS[1]);
        let p = (base[2] as i64 + dp as i64).rem_euclid(DIMS[2] as i64) as usize;
        f += wk * merl_bin(t, h, d, p);
    }
    f
}

/// f(ωi, ωo) from `table` (the caller applies the one-sided rule, as for every model).
pub fn merl(table: &MerlTable, lookup: Lookup, wi: DVec3, wo: DVec3) -> DVec3 {
    let [theta_h, _, theta_d, phi_d] = pair_to_half_diff(wi, wo);
    let u = merl_coordinates(theta_h, theta_d, phi_d);
    match lookup {
        Lookup::Trilinear => merl_trilinear(&table.values, u),
        Lookup::Nearest => merl_nearest(&table.values, u),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::half_diff_to_pair;

    /// A table whose value at bin (h, d, p) is (h, d, p) itself.
    fn index_table() -> MerlTable {
        let mut values = vec![0.0; 3 * BINS];
        for h in 0..DIMS[0] {
            for d in 0..DIMS[1] {
                for p in 0..DIMS[2] {
                    let k = bin(h, d, p);
                    values[k] = h as f64;
                    values[k + BINS] = d as f64;
                    values[k + 2 * BINS] = p as f64;
                }
            }
        }
        MerlTable { values, missing: 0 }
    }

    /// At every bin centre both lookups give that bin: nearest because the centre lies inside
    /// it, trilinear because all its weight is on that centre (up to rounding of the angles).
    #[test]
    fn bin_centres_give_their_bins() {
        let t = index_table();
        for (h, d, p) in [
            (0, 0, 0),
            (1, 5, 179),
            (44, 30, 90),
            (89, 2, 7),
            (10, 60, 1),
        ] {
            let [th, td, pd] = bin_centre(h, d, p);
            let (wi, wo) = half_diff_to_pair(th, 0.0, td, pd);
            let want = DVec3::new(h as f64, d as f64, p as f64);
            assert_eq!(merl(&t, Lookup::Nearest, wi, wo), want, "bin {h} {d} {p}");
            let f = merl(&t, Lookup::Trilinear, wi, wo);
            assert!(
                (f - want).abs().max_element() < 1e-9,
                "bin {h} {d} {p}: {f}"
            );
        }
    }

    /// Halfway between two φd centres the trilinear lookup is their mean, and across the φd
    /// seam (bin 179 to bin 0) it wraps.
    #[test]
    fn trilinear_interpolates_and_wraps_phi_d() {
        let t = index_table();
        assert_eq!(merl_trilinear(&t.values, [10.5, 20.5, 31.0]).z, 30.5);
        // u = 0.25: a quarter of the way from centre 179 (at −0.5) to centre 0 (at 0.5).
        assert!(
            (merl_trilinear(&t.values, [10.5, 20.5, 0.25]).z - 0.75 * 0.0 - 0.25 * 179.0).abs()
                < 1e-12
        );
        // θh below the first centre: the edge bin.
        assert_eq!(merl_trilinear(&t.values, [0.1, 20.5, 31.5]).x, 0.0);
    }

    /// MERL's reader's index at a few hand-worked angles: θh = (π/2)(k/90)² is the start of bin
    /// k; φd < 0 is moved by π; every axis is clamped.
    #[test]
    fn coordinates_follow_the_reader() {
        let u = merl_coordinates(FRAC_PI_2 * (30.0f64 / 90.0).powi(2), 0.0, -PI / 2.0);
        assert!((u[0] - 30.0).abs() < 1e-12 && u[1] == 0.0 && (u[2] - 90.0).abs() < 1e-12);
        let t = index_table();
        assert_eq!(
            merl_nearest(&t.values, [95.0, -1.0, 180.0]),
            DVec3::new(89.0, 0.0, 179.0)
        );
    }
}
