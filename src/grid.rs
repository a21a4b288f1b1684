//! Grids of (ωi, ωo) with cell-centred angles (docs/design.md §4):
//! θ_k = (k + ½)(π/2)/Nθ, φ_k = (k + ½)2π/Nφ, Δφ_k = (k + ½)π/NΔφ.
//! The `full` and `isotropic` grids are the outer product of a light-direction list and a
//! view-direction list, cell = i·len(wo) + o, so that a table's row-major index is the cell
//! index. The `halfdiff` grids (Rusinkiewicz 1998's half/difference angles; MERL's layout with
//! uniform cell-centred θh) are not products: each cell's pair comes from [`Grid::pair`].

use glam::DVec3;
use serde_json::json;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::{Arc, Mutex};

/// The angles a lobe table samples, and their resolutions (cells per axis, each at least 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    /// (θi, φi, θo, φo): any model.
    Full {
        /// Cells of θi over [0, π/2].
        n_theta_i: usize,
        /// Cells of φi over [0, 2π).
        n_phi_i: usize,
        /// Cells of θo over [0, π/2].
        n_theta_o: usize,
        /// Cells of φo over [0, 2π).
        n_phi_o: usize,
    },
    /// (θi, θo, Δφ), φi = 0, Δφ = φo − φi ∈ [0, π]: isotropic models only.
    Isotropic {
        /// Cells of θi over [0, π/2].
        n_theta_i: usize,
        /// Cells of θo over [0, π/2].
        n_theta_o: usize,
        /// Cells of Δφ over [0, π].
        n_dphi: usize,
    },
    /// (θh, θd, φd) with φh = 0 and φd ∈ [0, π]: isotropic models (an isotropic, reciprocal f
    /// has f(φd) = f(φd + π), so half the circle holds everything).
    HalfDiff {
        /// Cells of θh over [0, π/2].
        n_theta_h: usize,
        /// Cells of θd over [0, π/2].
        n_theta_d: usize,
        /// Cells of φd over [0, π].
        n_phi_d: usize,
    },
    /// (θh, φh, θd, φd), φh and φd ∈ [0, 2π): any model.
    HalfDiffFull {
        /// Cells of θh over [0, π/2].
        n_theta_h: usize,
        /// Cells of φh over [0, 2π).
        n_phi_h: usize,
        /// Cells of θd over [0, π/2].
        n_theta_d: usize,
        /// Cells of φd over [0, 2π).
        n_phi_d: usize,
    },
}

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
fn direction_product(thetas: impl Iterator<Item = f64>, phis: &[f64]) -> Vec<DVec3> {
    let phis: Vec<(f64, f64)> = phis.iter().map(|p| p.sin_cos()).collect();
    thetas
        .flat_map(|t| {
            let (sin_t, cos_t) = t.sin_cos();
            phis.iter()
                .map(move |&(sin_p, cos_p)| DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t))
        })
        .collect()
}

impl Grid {
    /// Parses a resolution, comma-separated cell counts, for the grid kind `full`, `isotropic` or
    /// `halfdiff` (three numbers: the isotropic half; four: every angle).
    pub fn parse(kind: &str, res: &str) -> Result<Grid, String> {
        let nums: Result<Vec<usize>, _> =
            res.split(',').map(|s| s.trim().parse::<usize>()).collect();
        let nums = nums.map_err(|_| {
            format!("resolution '{res}': expected comma-separated positive integers")
        })?;
        if nums.contains(&0) {
            return Err(format!(
                "resolution '{res}': every cell count must be at least 1"
            ));
        }
        match (kind, nums.as_slice()) {
            ("full", [a, b, c, d]) => Ok(Grid::Full {
                n_theta_i: *a,
                n_phi_i: *b,
                n_theta_o: *c,
                n_phi_o: *d,
            }),
            ("full", _) => Err(format!(
                "resolution '{res}': the full grid takes four numbers NTHETA_I,NPHI_I,NTHETA_O,NPHI_O"
            )),
            ("isotropic", [a, b, c]) => Ok(Grid::Isotropic {
                n_theta_i: *a,
                n_theta_o: *b,
                n_dphi: *c,
            }),
            ("isotropic", _) => Err(format!(
                "resolution '{res}': the isotropic grid takes three numbers NTHETA_I,NTHETA_O,NDPHI"
            )),
            ("halfdiff", [a, b, c]) => Ok(Grid::HalfDiff {
                n_theta_h: *a,
                n_theta_d: *b,
                n_phi_d: *c,
            }),
            ("halfdiff", [a, b, c, d]) => Ok(Grid::HalfDiffFull {
                n_theta_h: *a,
                n_phi_h: *b,
                n_theta_d: *c,
                n_phi_d: *d,
            }),
            ("halfdiff", _) => Err(format!(
                "resolution '{res}': the halfdiff grid takes three numbers NTHETA_H,NTHETA_D,NPHI_D \
                 (isotropic models, phi_d over [0, 180 deg]) or four NTHETA_H,NPHI_H,NTHETA_D,NPHI_D"
            )),
            _ => Err(format!(
                "unknown grid '{kind}'; the grids are: full, isotropic, halfdiff"
            )),
        }
    }

    /// The grid kind as `--grid` names it: `full`, `isotropic` or `halfdiff`.
    pub fn name(&self) -> &'static str {
        match self {
            Grid::Full { .. } => "full",
            Grid::Isotropic { .. } => "isotropic",
            Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => "halfdiff",
        }
    }

    /// Whether the grid holds only the isotropic half of the angles (isotropic models only).
    pub fn needs_isotropy(&self) -> bool {
        matches!(self, Grid::Isotropic { .. } | Grid::HalfDiff { .. })
    }

    /// Whether the grid is the outer product of [`Grid::wi_list`] and [`Grid::wo_list`].
    pub fn is_product(&self) -> bool {
        matches!(self, Grid::Full { .. } | Grid::Isotropic { .. })
    }

    /// (ωi, ωo) of the cell with multi-index `idx` (shape order), for every grid.
    pub fn pair(&self, idx: &[usize]) -> (DVec3, DVec3) {
        let a = self.angles(idx);
        match self {
            Grid::Full { .. } | Grid::Isotropic { .. } => {
                (direction(a[0], a[1]), direction(a[2], a[3]))
            }
            Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => {
                half_diff_to_pair(a[0], a[1], a[2], a[3])
            }
        }
    }

    /// The multi-index (shape order) of row-major cell `cell`.
    pub fn index(&self, cell: u64) -> Vec<usize> {
        let (idx, len) = self.index_array(cell);
        idx[..len].to_vec()
    }

    /// (ωi, ωo) of row-major cell `cell`, without allocating (tables made pair by pair).
    pub fn pair_at(&self, cell: u64) -> (DVec3, DVec3) {
        let (idx, len) = self.index_array(cell);
        self.pair(&idx[..len])
    }

    /// The multi-index of `cell` in a fixed array (every grid has 3 or 4 axes), and its length.
    fn index_array(&self, cell: u64) -> ([usize; 4], usize) {
        let (shape, len) = self.shape_array();
        let mut idx = [0; 4];
        let mut rest = cell;
        for k in (0..len).rev() {
            idx[k] = (rest % shape[k] as u64) as usize;
            rest /= shape[k] as u64;
        }
        (idx, len)
    }

    /// The table's shape without the RGB axis, in `--res` order.
    pub fn shape(&self) -> Vec<usize> {
        let (a, len) = self.shape_array();
        a[..len].to_vec()
    }

    /// The shape in a fixed array (3 or 4 axes) and its length.
    fn shape_array(&self) -> ([usize; 4], usize) {
        match *self {
            Grid::Full {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            } => ([n_theta_i, n_phi_i, n_theta_o, n_phi_o], 4),
            Grid::Isotropic {
                n_theta_i,
                n_theta_o,
                n_dphi,
            } => ([n_theta_i, n_theta_o, n_dphi, 0], 3),
            Grid::HalfDiff {
                n_theta_h,
                n_theta_d,
                n_phi_d,
            } => ([n_theta_h, n_theta_d, n_phi_d, 0], 3),
            Grid::HalfDiffFull {
                n_theta_h,
                n_phi_h,
                n_theta_d,
                n_phi_d,
            } => ([n_theta_h, n_phi_h, n_theta_d, n_phi_d], 4),
        }
    }

    /// Number of cells, or None if it overflows u64.
    pub fn cells(&self) -> Option<u64> {
        self.shape()
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
    }

    /// [`Grid::wi_list`] and [`Grid::wo_list`], shared: the lists of the last grid asked for
    /// are kept (one grid's, process-wide), so that repeated tables of one grid (a benchmark's
    /// runs, a scene's tables) make them once; they took 0.16 ms of a 12 ms table.
    pub fn lists(&self) -> Arc<(Vec<DVec3>, Vec<DVec3>)> {
        static LAST: Mutex<Option<(Grid, Arc<(Vec<DVec3>, Vec<DVec3>)>)>> = Mutex::new(None);
        let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
        match &*last {
            Some((grid, lists)) if grid == self => lists.clone(),
            _ => {
                let lists = Arc::new((self.wi_list(), self.wo_list()));
                *last = Some((*self, lists.clone()));
                lists
            }
        }
    }

    /// Light directions in row-major order of their axes.
    pub fn wi_list(&self) -> Vec<DVec3> {
        match *self {
            Grid::Full {
                n_theta_i, n_phi_i, ..
            } => direction_product(
                (0..n_theta_i).map(|t| theta_cell(t, n_theta_i)),
                &(0..n_phi_i)
                    .map(|p| phi_cell(p, n_phi_i))
                    .collect::<Vec<_>>(),
            ),
            Grid::Isotropic { n_theta_i, .. } => (0..n_theta_i)
                .map(|t| direction(theta_cell(t, n_theta_i), 0.0))
                .collect(),
            // Not a product: see `pair`.
            Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => Vec::new(),
        }
    }

    /// View directions in row-major order of their axes.
    pub fn wo_list(&self) -> Vec<DVec3> {
        match *self {
            Grid::Full {
                n_theta_o, n_phi_o, ..
            } => direction_product(
                (0..n_theta_o).map(|t| theta_cell(t, n_theta_o)),
                &(0..n_phi_o)
                    .map(|p| phi_cell(p, n_phi_o))
                    .collect::<Vec<_>>(),
            ),
            Grid::Isotropic {
                n_theta_o, n_dphi, ..
            } => direction_product(
                (0..n_theta_o).map(|t| theta_cell(t, n_theta_o)),
                &(0..n_dphi)
                    .map(|d| dphi_cell(d, n_dphi))
                    .collect::<Vec<_>>(),
            ),
            Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => Vec::new(),
        }
    }

    /// The grid's four angles in radians of the cell with multi-index `idx` (shape order):
    /// (θi, φi, θo, φo) on `full` and `isotropic` (φi = 0, φo = Δφ), (θh, φh, θd, φd) on
    /// `halfdiff` (φh = 0 on the three-axis grid).
    pub fn angles(&self, idx: &[usize]) -> [f64; 4] {
        match *self {
            Grid::Full {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            } => [
                theta_cell(idx[0], n_theta_i),
                phi_cell(idx[1], n_phi_i),
                theta_cell(idx[2], n_theta_o),
                phi_cell(idx[3], n_phi_o),
            ],
            Grid::Isotropic {
                n_theta_i,
                n_theta_o,
                n_dphi,
            } => [
                theta_cell(idx[0], n_theta_i),
                0.0,
                theta_cell(idx[1], n_theta_o),
                dphi_cell(idx[2], n_dphi),
            ],
            Grid::HalfDiff {
                n_theta_h,
                n_theta_d,
                n_phi_d,
            } => [
                theta_cell(idx[0], n_theta_h),
                0.0,
                theta_cell(idx[1], n_theta_d),
                dphi_cell(idx[2], n_phi_d),
            ],
            Grid::HalfDiffFull {
                n_theta_h,
                n_phi_h,
                n_theta_d,
                n_phi_d,
            } => [
                theta_cell(idx[0], n_theta_h),
                phi_cell(idx[1], n_phi_h),
                theta_cell(idx[2], n_theta_d),
                phi_cell(idx[3], n_phi_d),
            ],
        }
    }

    /// Axis descriptions for the JSON sidecar.
    pub fn axes_json(&self) -> serde_json::Value {
        let theta = |name: &str, n: usize| {
            json!({"name": name, "size": n, "range_rad": [0.0, FRAC_PI_2],
                   "centre_rad": format!("(k + 0.5) * (pi/2) / {n}")})
        };
        let phi = |name: &str, n: usize| json!({"name": name, "size": n, "range_rad": [0.0, 2.0 * PI], "centre_rad": format!("(k + 0.5) * 2pi / {n}")});
        match *self {
            Grid::Full {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            } => json!([
                theta("theta_i", n_theta_i),
                phi("phi_i", n_phi_i),
                theta("theta_o", n_theta_o),
                phi("phi_o", n_phi_o),
                {"name": "rgb", "size": 3}
            ]),
            Grid::Isotropic {
                n_theta_i,
                n_theta_o,
                n_dphi,
            } => json!([
                theta("theta_i", n_theta_i),
                theta("theta_o", n_theta_o),
                {"name": "delta_phi", "size": n_dphi, "range_rad": [0.0, PI],
                 "centre_rad": format!("(k + 0.5) * pi / {n_dphi}"), "note": "phi_o - phi_i; phi_i = 0"},
                {"name": "rgb", "size": 3}
            ]),
            Grid::HalfDiff {
                n_theta_h,
                n_theta_d,
                n_phi_d,
            } => json!([
                theta("theta_h", n_theta_h),
                theta("theta_d", n_theta_d),
                {"name": "phi_d", "size": n_phi_d, "range_rad": [0.0, PI],
                 "centre_rad": format!("(k + 0.5) * pi / {n_phi_d}"),
                 "note": "phi_h = 0; Rusinkiewicz 1998: wi = Rz(phi_h) Ry(theta_h) d(theta_d, phi_d), wo = its mirror about h"},
                {"name": "rgb", "size": 3}
            ]),
            Grid::HalfDiffFull {
                n_theta_h,
                n_phi_h,
                n_theta_d,
                n_phi_d,
            } => json!([
                theta("theta_h", n_theta_h),
                phi("phi_h", n_phi_h),
                theta("theta_d", n_theta_d),
                phi("phi_d", n_phi_d),
                {"name": "rgb", "size": 3}
            ]),
        }
    }
}

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

    /// The shared lists are the grid's own, also when another grid's were asked for in between
    /// (other tests may ask for theirs at the same time).
    #[test]
    fn shared_lists_follow_the_grid() {
        let a = Grid::parse("isotropic", "3,4,5").unwrap();
        let b = Grid::parse("full", "2,3,4,5").unwrap();
        for g in [a, a, b, a, b, b] {
            let lists = g.lists();
            assert_eq!(lists.0, g.wi_list());
            assert_eq!(lists.1, g.wo_list());
        }
    }

    /// The lists hold each cell's pair ([`Grid::pair_at`], [`direction`] of its angles) to the
    /// bit: cell k has light direction k / NWO and view direction k % NWO.
    #[test]
    fn direction_lists_are_each_cells_directions() {
        let grids = [
            Grid::parse("full", "5,12,7,9"),
            Grid::parse("isotropic", "6,11,13"),
        ];
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        for grid in grids.map(Result::unwrap) {
            let (wi, wo) = (grid.wi_list(), grid.wo_list());
            for cell in 0..grid.cells().unwrap() {
                let (k, n) = (cell as usize, wo.len());
                let (a, b) = grid.pair_at(cell);
                assert_eq!(bits(wi[k / n]), bits(a), "{grid:?} cell {cell}");
                assert_eq!(bits(wo[k % n]), bits(b), "{grid:?} cell {cell}");
            }
        }
    }

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

    #[test]
    fn cells_are_centred_and_never_on_the_pole_or_horizon() {
        assert!((theta_cell(0, 2) - PI / 8.0).abs() < 1e-15);
        assert!((theta_cell(1, 2) - 3.0 * PI / 8.0).abs() < 1e-15);
        assert!((phi_cell(0, 4) - PI / 4.0).abs() < 1e-15);
        assert!((dphi_cell(0, 1) - PI / 2.0).abs() < 1e-15);
    }

    #[test]
    fn halfdiff_pairs_have_their_half_and_difference_angles() {
        for res in ["3,4,5", "3,4,5,6"] {
            let g = Grid::parse("halfdiff", res).unwrap();
            for cell in 0..g.cells().unwrap() {
                let idx = g.index(cell);
                let a = g.angles(&idx);
                let (wi, wo) = g.pair(&idx);
                assert!((wi.length() - 1.0).abs() < 1e-12 && (wo.length() - 1.0).abs() < 1e-12);
                let h = (wi + wo).normalize();
                assert!((h.z.acos() - a[0]).abs() < 1e-9, "theta_h at {idx:?}");
                assert!((wi.dot(h).acos() - a[2]).abs() < 1e-9, "theta_d at {idx:?}");
            }
        }
        assert!(Grid::parse("halfdiff", "3,4").is_err());
        assert!(Grid::parse("halfdiff", "3,4,5").unwrap().needs_isotropy());
        assert!(!Grid::parse("halfdiff", "3,4,5,6").unwrap().needs_isotropy());
    }

    #[test]
    fn lists_multiply_to_the_shape() {
        let g = Grid::parse("full", "3,4,5,6").unwrap();
        assert_eq!(
            g.wi_list().len() * g.wo_list().len(),
            g.cells().unwrap() as usize
        );
        let g = Grid::parse("isotropic", "3,5,7").unwrap();
        assert_eq!(g.wi_list().len() * g.wo_list().len(), 105);
        assert!(Grid::parse("isotropic", "3,5").is_err());
        assert!(Grid::parse("full", "3,0,5,5").is_err());
    }
}
