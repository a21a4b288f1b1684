//! Environment light on a sphere: what both backends need to sum f cos θi L over every texel of
//! a lat-long map for every pixel of an orthographic view of the unit sphere (docs/design.md §15).
//!
//! Conventions (Mitsuba 3's `envmap`): +y up; texel row i of an H-row map spans
//! θ ∈ [π i / H, π (i + 1) / H] from +y, column j of W spans φ ∈ [2π j / W, 2π (j + 1) / W], and
//! a direction is (sin θ sin φ, cos θ, −sin θ cos φ), so that u = atan2(x, −z) / 2π mod 1 and
//! v = acos(y) / π. A texel's radiance is constant over the texel, whose solid angle is exactly
//! (cos θ0 − cos θ1) Δφ; the sum takes f cos θi at the texel's centre (θ and φ at the middle of
//! their ranges).
//!
//! The view: the sphere seen from +z (ωo = +z in the world) by an orthographic camera whose frame
//! spans [−1, 1]², row 0 at +y, column 0 at −x; a pixel's centre (x, y) with x² + y² < 1 sees the
//! point n = (x, y, √(1 − x² − y²)), whose tangent is +x made perpendicular to n (t ∝ x̂ − (x̂·n) n)
//! and bitangent b = n × t.

use crate::input::BadInput;
use glam::DVec3;
use std::f64::consts::PI;

/// The largest side of a map, in texels: a 16k × 8k map is far beyond what lighting a sphere
/// needs (every pixel sums every texel), and the bound keeps a header from asking for memory.
pub const MAX_MAP_SIDE: u32 = 16384;

/// The most texels a map may hold: 2^25 (a 8192 × 4096 map), 400 MiB as f32 RGB.
pub const MAX_MAP_TEXELS: u64 = 1 << 25;

/// A lat-long environment map: linear RGB radiance per texel, row 0 at +y, finite and ≥ 0.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    width: u32,
    height: u32,
    texels: Vec<[f32; 3]>,
}

impl EnvMap {
    /// The map of `width` × `height` texels in row order (row 0 at +y, column 0 at φ = 0).
    /// Refuses a side of 0 or over [`MAX_MAP_SIDE`], more than [`MAX_MAP_TEXELS`], a texel count
    /// that is not width × height, and a NaN, ±Inf or negative value, naming the first (its row
    /// and column).
    pub fn new(width: u32, height: u32, texels: Vec<[f32; 3]>) -> Result<EnvMap, BadInput> {
        check_size(width, height)?;
        if texels.len() as u64 != width as u64 * height as u64 {
            return Err(BadInput::new(
                "env",
                format!(
                    "an environment map of {width} x {height} texels was given {} texels",
                    texels.len()
                ),
            ));
        }
        if let Some(k) = texels
            .iter()
            .position(|t| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            let (row, col) = (k / width as usize, k % width as usize);
            return Err(BadInput::new(
                "env",
                format!(
                    "texel (row {row}, column {col}) of the environment map is {:?}; radiance must be finite and >= 0",
                    texels[k]
                ),
            ));
        }
        Ok(EnvMap {
            width,
            height,
            texels,
        })
    }

    /// Texels per row.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The radiance of every texel, row by row.
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.texels
    }

    /// The radiance of texel (row, column).
    pub fn texel(&self, row: u32, col: u32) -> [f32; 3] {
        self.texels[row as usize * self.width as usize + col as usize]
    }

    /// Every texel as its centre's direction and its radiance times its solid angle: the terms
    /// both backends sum.
    pub fn weighted_texels(&self) -> WeightedTexels {
        let (w, h) = (self.width, self.height);
        let terms = (0..h)
            .flat_map(|i| {
                let omega = texel_solid_angle(w, h, i);
                (0..w).map(move |j| (i, j, omega))
            })
            .map(|(i, j, omega)| {
                let l = DVec3::from_array(self.texel(i, j).map(f64::from));
                (texel_direction(w, h, i, j), l * omega)
            })
            .collect();
        WeightedTexels { width: w, terms }
    }
}

/// A map's texels as the sums take them: row by row, each the world direction of its centre and
/// its radiance times its solid angle (L ΔΩ per channel). The directions are those of
/// [`texel_direction`], on which the sums' horizon skips rely ([`visible_columns`]).
#[derive(Clone, Debug, PartialEq)]
pub struct WeightedTexels {
    /// Texels per row: the sums add each row first, then the rows.
    pub width: u32,
    /// (direction, L ΔΩ) of every texel, row by row.
    pub terms: Vec<(DVec3, DVec3)>,
}

/// A map row whose largest n·d, cos θ n_y + sin θ |n_xz| over its polar angle θ, is below
/// −`HORIZON_MARGIN` lies wholly below the pixel's horizon: every texel's computed cos θi is
/// negative (the rounding of these dot products is about 1e-16 in f64, 1e-7 in f32), so the row
/// is skipped whole and the sum is unchanged (`glsl/kernels/light.comp` has the same constant).
pub const HORIZON_MARGIN: f64 = 1e-5;

/// Whether the row whose first texel's direction is `d0` lies wholly below the horizon of normal
/// `n` ([`HORIZON_MARGIN`]).
pub fn row_below_horizon(d0: DVec3, n: DVec3) -> bool {
    let n_xz = (n.x * n.x + n.z * n.z).sqrt();
    let d_xz = (d0.x * d0.x + d0.z * d0.z).sqrt();
    d0.y * n.y + d_xz * n_xz < -HORIZON_MARGIN
}

/// How many columns [`visible_columns`] adds on each side of the arc it computes: one column's
/// angle, 2π / W ≥ 3.8e-4 rad at the largest map side, is far more than the f32 error of the
/// kernel's acos and atan (about 1e-6 rad) and covers the step from the arc to whole columns.
pub const COLUMN_MARGIN: f64 = 1.0;

/// The columns of a lat-long row, `width` texels whose first has direction `d0`, that may lie
/// above the horizon of normal `n`, as two ranges in increasing order (either may be empty); the
/// sums visit only these, in order, and every other column's computed cos θi is negative.
///
/// Over a row of polar angle θ, the texel at azimuth φ has n·d = cos θ n_y + sin θ |n_xz|
/// cos(φ − ψ) with ψ = atan2(n_x, −n_z) (the texel directions of [`texel_direction`]), which is
/// below −[`HORIZON_MARGIN`] wherever cos(φ − ψ) < c = (−`HORIZON_MARGIN` − cos θ n_y) /
/// (sin θ |n_xz|), i.e. outside the arc |φ − ψ| ≤ acos(c). The margin in c (at least
/// `HORIZON_MARGIN`, since sin θ |n_xz| ≤ 1) is far more than the rounding of c, and
/// [`COLUMN_MARGIN`] columns are added on each side of the arc.
pub fn visible_columns(d0: DVec3, n: DVec3, width: u32) -> [std::ops::Range<u32>; 2] {
    let full = [0..width, 0..0];
    let n_xz = (n.x * n.x + n.z * n.z).sqrt();
    let d_xz = (d0.x * d0.x + d0.z * d0.z).sqrt();
    let across = d_xz * n_xz;
    if !(across > 0.0) {
        return full;
    }
    let c = (-HORIZON_MARGIN - d0.y * n.y) / across;
    if c <= -1.0 {
        return full;
    }
    let w = width as f64;
    let half = c.min(1.0).acos() * w / (2.0 * PI) + COLUMN_MARGIN;
    if 2.0 * half + 1.0 >= w {
        return full;
    }
    // Column j's centre lies at φ = 2π (j + 0.5) / W; ψ's column is then ψ W / 2π − 0.5.
    let centre = n.x.atan2(-n.z) * w / (2.0 * PI) - 0.5;
    let (mut lo, mut hi) = (
        (centre - half).ceil() as i64,
        (centre + half).floor() as i64,
    );
    let wi = width as i64;
    if lo < 0 {
        lo += wi;
        hi += wi;
    }
    if hi >= wi {
        [0..(hi - wi + 1) as u32, lo as u32..width]
    } else {
        [lo as u32..(hi + 1) as u32, 0..0]
    }
}

impl WeightedTexels {
    /// L_o at `pixel` from these texels with `f` as f(ωi, ωo) in the local frame (the CPU
    /// reference's sum; `glsl/kernels/light.comp` is its twin): per map row, Σ f cos θi L ΔΩ
    /// over the texels above the pixel's horizon (cos θi > 0), then the rows' sums in order; a
    /// row wholly below the horizon ([`row_below_horizon`]) is skipped without looking at its
    /// texels.
    pub fn light_pixel(&self, pixel: &SpherePixel, f: impl Fn(DVec3, DVec3) -> DVec3) -> DVec3 {
        let wo = pixel.wo();
        let mut total = DVec3::ZERO;
        for row in self.terms.chunks(self.width.max(1) as usize) {
            if row_below_horizon(row[0].0, pixel.n) {
                continue;
            }
            let mut sum = DVec3::ZERO;
            for span in visible_columns(row[0].0, pixel.n, row.len() as u32) {
                for &(d, weight) in &row[span.start as usize..span.end as usize] {
                    let wi = pixel.local(d);
                    if wi.z > 0.0 {
                        sum += f(wi, wo) * wi.z * weight;
                    }
                }
            }
            total += sum;
        }
        total
    }
}

/// Refuses a map size outside the bounds ([`MAX_MAP_SIDE`], [`MAX_MAP_TEXELS`]), before any
/// texel is read.
pub fn check_size(width: u32, height: u32) -> Result<(), BadInput> {
    if !(1..=MAX_MAP_SIDE).contains(&width) || !(1..=MAX_MAP_SIDE).contains(&height) {
        return Err(BadInput::new(
            "env",
            format!(
                "an environment map of {width} x {height} texels; each side must be in [1, {MAX_MAP_SIDE}]"
            ),
        ));
    }
    let texels = width as u64 * height as u64;
    if texels > MAX_MAP_TEXELS {
        return Err(BadInput::new(
            "env",
            format!(
                "an environment map of {width} x {height} = {texels} texels; at most {MAX_MAP_TEXELS}"
            ),
        ));
    }
    Ok(())
}

/// The world direction of (θ from +y, φ): (sin θ sin φ, cos θ, −sin θ cos φ), Mitsuba's
/// lat-long convention.
pub fn latlong_direction(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * sp, ct, -st * cp)
}

/// The centre's direction of texel (row `i`, column `j`) of a `w` × `h` map.
pub fn texel_direction(w: u32, h: u32, i: u32, j: u32) -> DVec3 {
    let theta = PI * (i as f64 + 0.5) / h as f64;
    let phi = 2.0 * PI * (j as f64 + 0.5) / w as f64;
    latlong_direction(theta, phi)
}

/// The exact solid angle of a texel of row `i`: (cos θ0 − cos θ1) · 2π / w, the cosine
/// difference as 2 sin((θ0 + θ1)/2) sin((θ1 − θ0)/2), which keeps its relative accuracy at the
/// poles where cos θ0 and cos θ1 nearly cancel.
pub fn texel_solid_angle(w: u32, h: u32, i: u32) -> f64 {
    let dtheta = PI / h as f64;
    let mid = dtheta * (i as f64 + 0.5);
    2.0 * mid.sin() * (0.5 * dtheta).sin() * (2.0 * PI / w as f64)
}

/// A pixel of the sphere's view in the world: its normal, tangent and bitangent, and ωo in its
/// local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpherePixel {
    /// The pixel's row (0 at the top, +y).
    pub row: u32,
    /// The pixel's column (0 at the left, −x).
    pub col: u32,
    /// The outward normal n at the point the pixel's centre sees.
    pub n: DVec3,
    /// The tangent t: +x made perpendicular to n.
    pub t: DVec3,
    /// The bitangent b = n × t.
    pub b: DVec3,
}

impl SpherePixel {
    /// A world direction in the pixel's local frame (t, b, n).
    pub fn local(&self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.t), d.dot(self.b), d.dot(self.n))
    }

    /// ωo = +z (toward the camera) in the local frame.
    pub fn wo(&self) -> DVec3 {
        self.local(DVec3::Z)
    }
}

/// The centre of pixel (`row`, `col`) of a `size` × `size` view of the frame [−1, 1]² (row 0 at
/// +y, column 0 at −x): (x, y).
pub fn pixel_centre(size: u32, row: u32, col: u32) -> (f64, f64) {
    let s = size as f64;
    (
        -1.0 + (2.0 * col as f64 + 1.0) / s,
        1.0 - (2.0 * row as f64 + 1.0) / s,
    )
}

/// The sphere's pixel (`row`, `col`), or None where its centre misses the sphere
/// (x² + y² ≥ 1: the pixel is 0). The tangent frame: t = (x̂ − x n)/|x̂ − x n|, since x̂·n = x;
/// |x̂ − x n|² = 1 − x² > y² ≥ 0 inside the disc, so the frame is defined at every pixel centre
/// but where y = 0 and |x| → 1, the sphere's "poles" about the x axis on its silhouette, which no
/// pixel centre reaches (|x| ≤ 1 − 1/size there). Should rounding make |x̂ − x n| vanish
/// (it cannot for size ≤ 2^26), the tangent falls back to b̂ = +y made perpendicular.
pub fn sphere_pixel(size: u32, row: u32, col: u32) -> Option<SpherePixel> {
    let (x, y) = pixel_centre(size, row, col);
    let r2 = x * x + y * y;
    if r2 >= 1.0 {
        return None;
    }
    let n = DVec3::new(x, y, (1.0 - r2).sqrt());
    let along_x = DVec3::X - x * n;
    let t = if along_x.length_squared() > 1e-24 {
        along_x.normalize()
    } else {
        (DVec3::Y - y * n).normalize()
    };
    let b = n.cross(t);
    Some(SpherePixel { row, col, n, t, b })
}

/// Every pixel of rows `rows` of a `size` view that sees the sphere, row by row.
pub fn sphere_pixels(size: u32, rows: std::ops::Range<u32>) -> Vec<SpherePixel> {
    rows.flat_map(|r| (0..size).filter_map(move |c| sphere_pixel(size, r, c)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The texels' solid angles add up to the sphere's 4π (each is exact, so only rounding
    /// separates them; 1e-12 relative allows a few thousand additions' rounding).
    #[test]
    fn texel_solid_angles_cover_the_sphere() {
        for (w, h) in [(1, 1), (8, 4), (64, 32), (7, 5)] {
            let total: f64 = (0..h).map(|i| w as f64 * texel_solid_angle(w, h, i)).sum();
            assert!(
                (total - 4.0 * PI).abs() < 1e-12 * 4.0 * PI,
                "{w}x{h}: {total}"
            );
        }
        // One row against the cosine difference of its edges (closed form).
        let (w, h, i) = (16u32, 8u32, 3u32);
        let (t0, t1) = (PI * i as f64 / h as f64, PI * (i + 1) as f64 / h as f64);
        let direct = (t0.cos() - t1.cos()) * 2.0 * PI / w as f64;
        assert!((texel_solid_angle(w, h, i) - direct).abs() < 1e-15);
    }

    /// Directions follow Mitsuba's u = atan2(x, −z)/2π mod 1, v = acos(y)/π at texel centres.
    #[test]
    fn texel_directions_follow_the_latlong_convention() {
        let (w, h) = (32u32, 16u32);
        for i in 0..h {
            for j in 0..w {
                let d = texel_direction(w, h, i, j);
                let u = (d.x.atan2(-d.z) / (2.0 * PI)).rem_euclid(1.0);
                let v = d.y.acos() / PI;
                assert!(
                    (u - (j as f64 + 0.5) / w as f64).abs() < 1e-12,
                    "u at {i},{j}"
                );
                assert!(
                    (v - (i as f64 + 0.5) / h as f64).abs() < 1e-12,
                    "v at {i},{j}"
                );
            }
        }
    }

    /// The frame is orthonormal and right-handed at every pixel, the tangent leans on +x, the
    /// centre pixel of an odd view sees +z with t = +x, and corners miss the sphere.
    #[test]
    fn sphere_pixels_have_orthonormal_frames() {
        let size = 33;
        let pixels = sphere_pixels(size, 0..size);
        assert!(!pixels.is_empty());
        for p in &pixels {
            assert!((p.n.length() - 1.0).abs() < 1e-12);
            assert!(p.t.dot(p.n).abs() < 1e-12 && p.b.dot(p.n).abs() < 1e-12);
            assert!(p.t.dot(p.b).abs() < 1e-12);
            assert!((p.t.cross(p.b) - p.n).length() < 1e-12);
            assert!(p.t.x > 0.0, "t leans on +x at ({}, {})", p.row, p.col);
            assert!(p.wo().z > 0.0);
        }
        let c = sphere_pixel(size, 16, 16).unwrap();
        assert!((c.n - DVec3::Z).length() < 1e-12 && (c.t - DVec3::X).length() < 1e-12);
        assert!(sphere_pixel(size, 0, 0).is_none());
        // Row 0 is at +y, column 0 at −x.
        let top = sphere_pixel(size, 1, 16).unwrap();
        assert!(top.n.y > 0.9);
        let left = sphere_pixel(size, 16, 1).unwrap();
        assert!(left.n.x < -0.9);
    }

    /// A NaN, an Inf and a negative texel are refused naming the first bad texel's row and
    /// column; sizes out of bounds are refused before anything else.
    #[test]
    fn bad_texels_and_sizes_are_refused() {
        let mut t = vec![[1.0f32; 3]; 8];
        t[6] = [0.0, f32::NAN, 0.0];
        t[7] = [-1.0, 0.0, 0.0];
        let e = EnvMap::new(4, 2, t).unwrap_err().to_string();
        assert!(e.contains("row 1, column 2"), "{e}");
        let e = EnvMap::new(4, 2, vec![[-0.5, 0.0, 0.0]; 8])
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 0, column 0") && e.contains(">= 0"), "{e}");
        let e = EnvMap::new(0, 2, vec![]).unwrap_err().to_string();
        assert!(e.contains("[1, 16384]"), "{e}");
        let e = check_size(16384, 16384).unwrap_err().to_string();
        assert!(e.contains("at most"), "{e}");
        assert!(EnvMap::new(4, 2, vec![[0.0; 3]; 7]).is_err());
    }
}
