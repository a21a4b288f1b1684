//! The `merl` lookup: f of a MERL table at a pair, in f64: the twin of `glsl/brdf/merl.glsl`, line by line, with
//! libm's atan2 where the GLSL has `merl_angle`. The nearest-bin lookup is MERL's reader's.

use super::sample::{pdf_cosine, reflect, sample_cosine, Sample};
use crate::grid::{dphi_cell, pair_to_half_diff, theta_cell};
use glam::{DVec2, DVec3};
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

/// Slices of the tabulated sampler in cos θo: slice j holds ωo with 1 − cos θo in [j, j + 1)/32
/// (finer in θo towards grazing, where a measured lobe changes fastest).
pub const SAMPLER_SLICES: usize = 32;
/// Rows of the sampler's half-vector cells: MERL's own θh bins (θh = (π/2)(k/90)²).
pub const SAMPLER_ROWS: usize = DIMS[0];
/// Columns of the sampler's half-vector cells: φh − φo in [0, 2π) in equal steps.
pub const SAMPLER_COLUMNS: usize = 64;
/// The share of draws made by the cosine rather than the table (a defensive mixture,
/// Hesterberg 1995, "Weighted average importance sampling and defensive mixture
/// distributions"): the density stays above cos θi/π · 0.1 wherever f may be nonzero, which
/// bounds every weight by 10 π f, whatever the table's cells miss between their centres.
pub const SAMPLER_COSINE_SHARE: f64 = 0.1;

/// Where the sampler's tables start in the model's data buffer, in floats, after the three
/// channels of the bins; then `omc`, the slices' shares, the marginal and the conditional CDFs,
/// each as [`MerlSampler::gpu_floats`] lays them out ([`SAMPLER_FLOATS`] in all).
pub const SAMPLER_OFFSET: usize = 3 * BINS;
/// Floats of the sampler's tables: 91 row edges, 32 shares, 32 × 91 marginal and 32 × 90 × 65
/// conditional CDF values.
pub const SAMPLER_FLOATS: usize = (SAMPLER_ROWS + 1)
    + SAMPLER_SLICES
    + SAMPLER_SLICES * (SAMPLER_ROWS + 1)
    + SAMPLER_SLICES * SAMPLER_ROWS * (SAMPLER_COLUMNS + 1);

/// A MERL table's importance sampler (docs/design.md §13.4): per slice of θo, a piecewise-constant
/// density over the half vector's (θh, φh − φo) cells, each cell's probability proportional to
/// the target f cos θi times the half-vector Jacobian 4 (ωo·h) times the cell's solid angle, all
/// at its centre for the slice's central ωo; ωi = the reflection of ωo about h, mixed with the
/// cosine ([`SAMPLER_COSINE_SHARE`]). The tables are kept as the f32 the GPU reads, so that both
/// sides choose the same cell for the same numbers; the twin of `glsl/brdf/merl.glsl`'s
/// `sample_merl` and `pdf_merl`.
#[derive(Clone, Debug, PartialEq)]
pub struct MerlSampler {
    /// 1 − cos θ at the rows' edges, 91 values from 0 to 1.
    omc: Vec<f32>,
    /// Per slice, the table's share of draws: 1 − [`SAMPLER_COSINE_SHARE`], or 0 for a slice
    /// whose cells are all black (the cosine alone then).
    share: Vec<f32>,
    /// Per slice, the rows' CDF (91 values, 0 to 1).
    marginal: Vec<f32>,
    /// Per slice and row, the columns' CDF (65 values, 0 to 1).
    conditional: Vec<f32>,
}

/// 2 sin²(θ/2) = 1 − cos θ without cancellation near θ = 0.
fn one_minus_cos(theta: f64) -> f64 {
    let s = (0.5 * theta).sin();
    2.0 * s * s
}

/// The CDF of `weights` as f32, from exactly 0 to exactly 1 (non-decreasing: each partial sum
/// rounds alike); None when they sum to 0.
fn cdf_f32(weights: &[f64]) -> Option<Vec<f32>> {
    let total: f64 = weights.iter().sum();
    if !(total > 0.0) {
        return None;
    }
    let mut out = Vec::with_capacity(weights.len() + 1);
    let mut sum = 0.0;
    out.push(0.0);
    for w in &weights[..weights.len() - 1] {
        sum += w;
        out.push((sum / total).min(1.0) as f32);
    }
    out.push(1.0);
    Some(out)
}

/// The uniform CDF over `n` entries, for rows and slices that are never chosen.
fn cdf_uniform(n: usize) -> Vec<f32> {
    (0..=n).map(|k| (k as f64 / n as f64) as f32).collect()
}

/// The largest k < n with `cdf[k] ≤ u` (`cdf[0] = 0 ≤ u < 1 = cdf[n]`), and where u lies within
/// `[cdf[k], cdf[k + 1])` as a fraction in [0, 1): `merl_search` in the GLSL.
pub fn merl_search(cdf: &[f32], u: f64) -> (usize, f64) {
    let (mut lo, mut hi) = (0, cdf.len() - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cdf[mid] as f64 <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (a, b) = (cdf[lo] as f64, cdf[lo + 1] as f64);
    let t = if b > a { (u - a) / (b - a) } else { 0.0 };
    (lo, t.clamp(0.0, 1.0))
}

/// The slice of ωo: ⌊32 (1 − cos θo)⌋, the last for ωo at the horizon.
pub fn merl_slice(wo: DVec3) -> usize {
    ((SAMPLER_SLICES as f64 * (1.0 - wo.z)) as usize).min(SAMPLER_SLICES - 1)
}

/// cos and sin of ωo's azimuth, (1, 0) for ωo along the normal: the rotation that takes the
/// slice's frame (ωo in the xz-plane) to the surface's.
fn azimuth(wo: DVec3) -> (f64, f64) {
    let r = (wo.x * wo.x + wo.y * wo.y).sqrt();
    if r > 0.0 {
        (wo.x / r, wo.y / r)
    } else {
        (1.0, 0.0)
    }
}

/// The column step, 2π/64.
const COLUMN_STEP: f64 = 2.0 * PI / SAMPLER_COLUMNS as f64;

impl MerlSampler {
    /// Tabulates `table`'s sampler from its nearest-bin values.
    pub fn new(table: &MerlTable) -> MerlSampler {
        let omc: Vec<f32> = (0..=SAMPLER_ROWS)
            .map(|k| {
                let u = k as f64 / SAMPLER_ROWS as f64;
                one_minus_cos(FRAC_PI_2 * u * u) as f32
            })
            .collect();
        let omc64: Vec<f64> = omc.iter().map(|&x| x as f64).collect();
        let mut share = Vec::with_capacity(SAMPLER_SLICES);
        let mut marginal = Vec::with_capacity(SAMPLER_SLICES * (SAMPLER_ROWS + 1));
        let mut conditional =
            Vec::with_capacity(SAMPLER_SLICES * SAMPLER_ROWS * (SAMPLER_COLUMNS + 1));
        for j in 0..SAMPLER_SLICES {
            let z = 1.0 - (j as f64 + 0.5) / SAMPLER_SLICES as f64;
            let wo = DVec3::new((1.0 - z * z).sqrt(), 0.0, z);
            let mut rows = Vec::with_capacity(SAMPLER_ROWS);
            let mut slice_conditional = Vec::with_capacity(SAMPLER_ROWS * (SAMPLER_COLUMNS + 1));
            for k in 0..SAMPLER_ROWS {
                let m = 0.5 * (omc64[k] + omc64[k + 1]);
                let (cos_h, sin_h) = (1.0 - m, (m * (2.0 - m)).max(0.0).sqrt());
                let solid_angle = (omc64[k + 1] - omc64[k]) * COLUMN_STEP;
                let cells: Vec<f64> = (0..SAMPLER_COLUMNS)
                    .map(|c| {
                        let phi = (c as f64 + 0.5) * COLUMN_STEP;
                        let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                        let wi = 2.0 * wo.dot(h) * h - wo;
                        if wi.z <= 0.0 {
                            return 0.0;
                        }
                        let f = merl(table, Lookup::Nearest, wi, wo);
                        let y = 0.2126 * f.x + 0.7152 * f.y + 0.0722 * f.z;
                        y.max(0.0) * wi.z * 4.0 * wo.dot(h) * solid_angle
                    })
                    .collect();
                rows.push(cells.iter().sum::<f64>());
                slice_conditional
                    .extend(cdf_f32(&cells).unwrap_or_else(|| cdf_uniform(SAMPLER_COLUMNS)));
            }
            match cdf_f32(&rows) {
                Some(cdf) => {
                    share.push((1.0 - SAMPLER_COSINE_SHARE) as f32);
                    marginal.extend(cdf);
                }
                None => {
                    share.push(0.0);
                    marginal.extend(cdf_uniform(SAMPLER_ROWS));
                }
            }
            conditional.extend(slice_conditional);
        }
        MerlSampler {
            omc,
            share,
            marginal,
            conditional,
        }
    }

    /// The tables as the GPU reads them after the bins: omc, share, marginal, conditional.
    pub fn gpu_floats(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(SAMPLER_FLOATS);
        out.extend(&self.omc);
        out.extend(&self.share);
        out.extend(&self.marginal);
        out.extend(&self.conditional);
        out
    }

    fn marginal_of(&self, j: usize) -> &[f32] {
        &self.marginal[j * (SAMPLER_ROWS + 1)..(j + 1) * (SAMPLER_ROWS + 1)]
    }

    fn conditional_of(&self, j: usize, k: usize) -> &[f32] {
        let at = (j * SAMPLER_ROWS + k) * (SAMPLER_COLUMNS + 1);
        &self.conditional[at..at + SAMPLER_COLUMNS + 1]
    }

    /// A draw for ωo (above the horizon): `uc` below the slice's share draws a half vector from
    /// the table and reflects ωo about it, otherwise ωi is drawn by the cosine; weight f cos θi /
    /// pdf with f from `f` and the mixture's density [`MerlSampler::pdf`].
    pub fn sample(&self, wo: DVec3, uc: f64, u: DVec2, f: impl FnOnce(DVec3) -> DVec3) -> Sample {
        let j = merl_slice(wo);
        let wi = if uc < self.share[j] as f64 {
            let (k, tr) = merl_search(self.marginal_of(j), u.x);
            let (c, tc) = merl_search(self.conditional_of(j, k), u.y);
            let (a, b) = (self.omc[k] as f64, self.omc[k + 1] as f64);
            let m = a + tr * (b - a);
            let (cos_h, sin_h) = (1.0 - m, (m * (2.0 - m)).max(0.0).sqrt());
            let phi = (c as f64 + tc) * COLUMN_STEP;
            let (x, y) = (sin_h * phi.cos(), sin_h * phi.sin());
            let (ca, sa) = azimuth(wo);
            let h = DVec3::new(ca * x - sa * y, sa * x + ca * y, cos_h);
            reflect(wo, h)
        } else {
            sample_cosine(u)
        };
        Sample::from_draw(wi, self.pdf(wi, wo), f)
    }

    /// The density over the solid angle of ωi of [`MerlSampler::sample`]'s draws (both
    /// directions above the horizon): share × p(h's cell)/(ΔΩ(cell) 4 ωo·h) + the rest × cos θi/π.
    pub fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let j = merl_slice(wo);
        let share = self.share[j] as f64;
        let cosine = (1.0 - share) * pdf_cosine(wi);
        if share == 0.0 {
            return cosine;
        }
        let h = (wi + wo).normalize();
        let (ca, sa) = azimuth(wo);
        let (x, y) = (ca * h.x + sa * h.y, ca * h.y - sa * h.x);
        // 1 − cos θh = sin²θh / (1 + cos θh), without the cancellation of 1 − h.z.
        let m = (x * x + y * y) / (1.0 + h.z);
        let (k, _) = merl_search(&self.omc, m.min(1.0));
        let phi = y.atan2(x).rem_euclid(2.0 * PI);
        let c = ((phi / COLUMN_STEP) as usize).min(SAMPLER_COLUMNS - 1);
        let rows = self.marginal_of(j);
        let cols = self.conditional_of(j, k);
        let p = (rows[k + 1] as f64 - rows[k] as f64) * (cols[c + 1] as f64 - cols[c] as f64);
        let solid_angle = (self.omc[k + 1] as f64 - self.omc[k] as f64) * COLUMN_STEP;
        share * p / (solid_angle * 4.0 * wo.dot(h)) + cosine
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

    /// The search returns the entry whose interval holds u, skipping empty ones, and where u
    /// lies within it; the CDFs run from exactly 0 to exactly 1.
    #[test]
    fn the_cdf_search_skips_empty_entries() {
        let cdf = cdf_f32(&[1.0, 0.0, 0.0, 3.0]).unwrap();
        assert_eq!(cdf, vec![0.0, 0.25, 0.25, 0.25, 1.0]);
        assert_eq!(merl_search(&cdf, 0.0), (0, 0.0));
        assert_eq!(merl_search(&cdf, 0.125), (0, 0.5));
        assert_eq!(merl_search(&cdf, 0.25), (3, 0.0));
        assert_eq!(merl_search(&cdf, 0.625), (3, 0.5));
        assert!(cdf_f32(&[0.0, 0.0]).is_none());
        assert_eq!(merl_slice(DVec3::Z), 0);
        assert_eq!(merl_slice(DVec3::new(1.0, 0.0, 1e-9)), SAMPLER_SLICES - 1);
    }

    /// Every draw's density is the sampler's pdf at its ωi, and the table's draws reflect ωo
    /// about a half vector (ωi + ωo along h with |ωi| = 1), on a table with one bright bin row.
    #[test]
    fn draws_carry_their_own_density() {
        let mut values = vec![0.0; 3 * BINS];
        for d in 0..DIMS[1] {
            for p in 0..DIMS[2] {
                for c in 0..3 {
                    values[bin(3, d, p) + c * BINS] = 5.0;
                    values[bin(40, d, p) + c * BINS] = 0.1;
                }
            }
        }
        let s = MerlSampler::new(&MerlTable { values, missing: 0 });
        assert_eq!(s.gpu_floats().len(), SAMPLER_FLOATS);
        let wo = DVec3::new(0.5, 0.3, (1.0f64 - 0.34).sqrt());
        for i in 0..2000u64 {
            let (uc, u) = crate::random::draw_numbers(3, i, 0);
            let d = s.sample(wo, uc, u, |_| DVec3::ONE);
            if d.pdf == 0.0 {
                assert!(d.wi.z <= 0.0, "draw {i} lost above the horizon");
                continue;
            }
            assert!((d.wi.length() - 1.0).abs() < 1e-12, "draw {i}");
            let p = s.pdf(d.wi, wo);
            assert!(
                (d.pdf - p).abs() <= 1e-12 * p,
                "draw {i}: {} against {p}",
                d.pdf
            );
        }
    }
}
