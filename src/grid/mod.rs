//! Grids of (ωi, ωo) with cell-centred angles (docs/design.md §4):
//! θ_k = (k + ½)(π/2)/Nθ, φ_k = (k + ½)2π/Nφ, Δφ_k = (k + ½)π/NΔφ.
//! The `full` and `isotropic` grids are the outer product of a light-direction list and a
//! view-direction list, cell = i·len(wo) + o, so that a table's row-major index is the cell
//! index. The `halfdiff` grids (Rusinkiewicz 1998's half/difference angles; MERL's layout with
//! uniform cell-centred θh) are not products: each cell's pair comes from [`Grid::pair`].
//!
//! The files: the cell centres and directions (`angles.rs`), the half/difference transforms
//! (`halfdiff.rs`), the direction lists of the product grids (`lists.rs`) and the axes of the
//! JSON sidecar (`sidecar.rs`).

mod angles;
mod halfdiff;
mod lists;
mod sidecar;

pub use angles::{
    angles_deg, direction, direction_deg, dphi_cell, phi_cell, sin_cos_deg, theta_cell,
};
pub use halfdiff::{half_diff_to_pair, pair_to_half_diff};

use glam::DVec3;

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
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
