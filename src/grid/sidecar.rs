//! The axes of a table's JSON sidecar: each axis's name, size, range and cell centres.

use super::Grid;
use serde_json::json;
use std::f64::consts::{FRAC_PI_2, PI};

impl Grid {
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
