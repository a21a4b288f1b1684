//! Grids of (ωi, ωo) with cell-centred angles (DESIGN §4):
//! θ_k = (k + ½)(π/2)/Nθ, φ_k = (k + ½)2π/Nφ, Δφ_k = (k + ½)π/NΔφ.
//! Every grid is laid out as the outer product of a light-direction list and a view-direction
//! list, cell = i·len(wo) + o, so that a table's row-major index is the cell index.

use glam::DVec3;
use serde_json::json;
use std::f64::consts::{FRAC_PI_2, PI};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    /// (θi, φi, θo, φo): any model.
    Full {
        n_theta_i: usize,
        n_phi_i: usize,
        n_theta_o: usize,
        n_phi_o: usize,
    },
    /// (θi, θo, Δφ), φi = 0, Δφ = φo − φi ∈ [0, π]: isotropic models only.
    Isotropic {
        n_theta_i: usize,
        n_theta_o: usize,
        n_dphi: usize,
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

/// ω = (sinθ cosφ, sinθ sinφ, cosθ).
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

impl Grid {
    /// Parses `--res` for the grid kind `full` or `isotropic`.
    pub fn parse(kind: &str, res: &str) -> Result<Grid, String> {
        let nums: Result<Vec<usize>, _> =
            res.split(',').map(|s| s.trim().parse::<usize>()).collect();
        let nums =
            nums.map_err(|_| format!("--res '{res}': expected comma-separated positive integers"))?;
        if nums.contains(&0) {
            return Err(format!(
                "--res '{res}': every resolution must be at least 1"
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
                "--res '{res}': the full grid takes four numbers NTHETA_I,NPHI_I,NTHETA_O,NPHI_O"
            )),
            ("isotropic", [a, b, c]) => Ok(Grid::Isotropic {
                n_theta_i: *a,
                n_theta_o: *b,
                n_dphi: *c,
            }),
            ("isotropic", _) => Err(format!(
                "--res '{res}': the isotropic grid takes three numbers NTHETA_I,NTHETA_O,NDPHI"
            )),
            _ => Err(format!(
                "unknown grid '{kind}'; the grids are: full, isotropic"
            )),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Grid::Full { .. } => "full",
            Grid::Isotropic { .. } => "isotropic",
        }
    }

    /// The table's shape without the RGB axis, in `--res` order.
    pub fn shape(&self) -> Vec<usize> {
        match *self {
            Grid::Full {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            } => vec![n_theta_i, n_phi_i, n_theta_o, n_phi_o],
            Grid::Isotropic {
                n_theta_i,
                n_theta_o,
                n_dphi,
            } => vec![n_theta_i, n_theta_o, n_dphi],
        }
    }

    /// Number of cells, or None if it overflows u64.
    pub fn cells(&self) -> Option<u64> {
        self.shape()
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
    }

    /// Light directions in row-major order of their axes.
    pub fn wi_list(&self) -> Vec<DVec3> {
        match *self {
            Grid::Full {
                n_theta_i, n_phi_i, ..
            } => (0..n_theta_i)
                .flat_map(|t| {
                    (0..n_phi_i)
                        .map(move |p| direction(theta_cell(t, n_theta_i), phi_cell(p, n_phi_i)))
                })
                .collect(),
            Grid::Isotropic { n_theta_i, .. } => (0..n_theta_i)
                .map(|t| direction(theta_cell(t, n_theta_i), 0.0))
                .collect(),
        }
    }

    /// View directions in row-major order of their axes.
    pub fn wo_list(&self) -> Vec<DVec3> {
        match *self {
            Grid::Full {
                n_theta_o, n_phi_o, ..
            } => (0..n_theta_o)
                .flat_map(|t| {
                    (0..n_phi_o)
                        .map(move |p| direction(theta_cell(t, n_theta_o), phi_cell(p, n_phi_o)))
                })
                .collect(),
            Grid::Isotropic {
                n_theta_o, n_dphi, ..
            } => (0..n_theta_o)
                .flat_map(|t| {
                    (0..n_dphi)
                        .map(move |d| direction(theta_cell(t, n_theta_o), dphi_cell(d, n_dphi)))
                })
                .collect(),
        }
    }

    /// Angles (θi, φi, θo, φo) in radians of the cell with multi-index `idx` (shape order).
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
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_centred_and_never_on_the_pole_or_horizon() {
        assert!((theta_cell(0, 2) - PI / 8.0).abs() < 1e-15);
        assert!((theta_cell(1, 2) - 3.0 * PI / 8.0).abs() < 1e-15);
        assert!((phi_cell(0, 4) - PI / 4.0).abs() < 1e-15);
        assert!((dphi_cell(0, 1) - PI / 2.0).abs() < 1e-15);
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
