//! The table-resolution section: E(μ) computed from isotropic lobe tables of growing resolution,
//! as a user holding such a table would compute it (see the notes of [`crate::tradeoff`]).

use super::setup::{albedo_errors, backend_tag, AlbedoSetup};
use super::{mark_pareto, Row, Section};
use crate::bench::median;
use crate::eval::Evaluator;
use crate::grid::{theta_cell, Grid};
use crate::input::BadInput;
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

/// The isotropic grid of table resolution `n`: n × n × 2n cells in (θi, θo, Δφ).
pub fn table_grid(n: usize) -> Grid {
    Grid::Isotropic {
        n_theta_i: n,
        n_theta_o: n,
        n_dphi: 2 * n,
    }
}

/// E(μ) (delta excluded) from an isotropic lobe table in table order (θi, θo, Δφ, rgb): linear
/// interpolation in θo between the two nearest cell centres (held constant beyond the first and
/// the last), midpoint cell sums in θi and Δφ with dω = sinθi dθi dΔφ and the cosine cosθi, the
/// Δφ ∈ [0, π] half doubled for the even other half.
pub fn table_albedo(
    table: &[f32],
    n_theta_i: usize,
    n_theta_o: usize,
    n_dphi: usize,
    mu: f64,
) -> DVec3 {
    debug_assert_eq!(table.len(), n_theta_i * n_theta_o * n_dphi * 3);
    let d_theta_o = FRAC_PI_2 / n_theta_o as f64;
    // Position of θo in units of cells, from the first centre.
    let x = (mu.clamp(0.0, 1.0).acos() / d_theta_o - 0.5).clamp(0.0, (n_theta_o - 1) as f64);
    let k0 = x.floor() as usize;
    let k1 = (k0 + 1).min(n_theta_o - 1);
    let t = x - k0 as f64;
    let w_dphi = 2.0 * PI / n_dphi as f64;
    let d_theta_i = FRAC_PI_2 / n_theta_i as f64;
    let mut sum = DVec3::ZERO;
    for i in 0..n_theta_i {
        let theta_i = theta_cell(i, n_theta_i);
        let w = theta_i.cos() * theta_i.sin() * d_theta_i * w_dphi;
        let row = |k: usize| {
            let base = ((i * n_theta_o + k) * n_dphi) * 3;
            let mut s = DVec3::ZERO;
            for c in table[base..base + n_dphi * 3].chunks_exact(3) {
                s += DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
            }
            s
        };
        sum += w * ((1.0 - t) * row(k0) + t * row(k1));
    }
    sum
}

/// Measures E(μ) from tables at each resolution of `setup` on each backend.
pub fn measure_tables(
    backends: &[Evaluator],
    params: &ParamSet,
    setup: &AlbedoSetup,
    truth: &[DVec3],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    if !params.is_isotropic() {
        return Err(BadInput::new(
            "sections",
            "the table-resolution section needs an isotropic parameter set (the isotropic table \
             (theta_i, theta_o, dphi) cannot hold this one); leave that section out",
        )
        .into());
    }
    let mut rows = Vec::new();
    for backend in backends {
        for &n in &setup.table_res {
            backend.check_cancelled()?;
            let grid = table_grid(n);
            let cells = grid.cells().unwrap_or(0);
            progress(&format!("table {n} {}", backend_tag(backend)));
            let run = || -> Result<Vec<DVec3>> {
                let mut table = Vec::with_capacity(cells as usize * 3);
                backend.eval_table(params, &grid, &mut |_, v| {
                    table.extend_from_slice(v);
                    Ok(())
                })?;
                Ok(setup
                    .mus
                    .iter()
                    .map(|&mu| table_albedo(&table, n, n, 2 * n, mu))
                    .collect())
            };
            let values = run()?;
            let (max_error, rms_error) = albedo_errors(&values, truth);
            let mut walls = Vec::new();
            for _ in 0..setup.repeats {
                let t = Instant::now();
                std::hint::black_box(run()?);
                walls.push(t.elapsed().as_secs_f64() * 1e3);
            }
            rows.push(Row {
                section: Section::TableResolution,
                variant: format!("table {n}x{n}x{}, {}", 2 * n, backend_tag(backend)),
                backend: backend.name(),
                samples: Some(cells),
                cost: median(walls),
                cost_unit: Section::TableResolution.cost_unit().into(),
                kernel_cost: None,
                max_error,
                rms_error,
                error_kind: Section::TableResolution.error_kind().into(),
                pareto: false,
                variance_per_sample: None,
            });
        }
    }
    mark_pareto(&mut rows);
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_table_integrates_to_its_albedo_within_the_midpoint_error() {
        // f = ρ/π: E = ρ exactly; the midpoint rule in θi of cosθ sinθ = sin(2θ)/2 errs by
        // about h²/6 relative (h = Δθi), interpolation in θo and the Δφ sum not at all.
        let (n, rho) = (16usize, 0.7f64);
        let table = vec![(rho / PI) as f32; n * n * 2 * n * 3];
        let h = FRAC_PI_2 / n as f64;
        for mu in [0.05, 0.5, 1.0] {
            let e = table_albedo(&table, n, n, 2 * n, mu);
            for c in e.to_array() {
                assert!(
                    (c / rho - 1.0).abs() < h * h / 6.0 * 1.1,
                    "mu {mu}: {c} vs {rho} (h²/6 = {:e})",
                    h * h / 6.0
                );
            }
        }
    }

    #[test]
    fn interpolation_in_theta_o_is_linear_between_centres() {
        // A table whose value is the θo cell index k: at θo halfway between centres 2 and 3 the
        // interpolated f is 2.5 everywhere, so E = 2.5 × Σ weights.
        let n = 8usize;
        let mut table = vec![0f32; n * n * 2 * n * 3];
        for i in 0..n {
            for k in 0..n {
                for d in 0..2 * n {
                    for c in 0..3 {
                        table[((i * n + k) * 2 * n + d) * 3 + c] = k as f32;
                    }
                }
            }
        }
        let ones = vec![1f32; table.len()];
        let theta = 0.5 * (theta_cell(2, n) + theta_cell(3, n));
        let e = table_albedo(&table, n, n, 2 * n, theta.cos());
        let w = table_albedo(&ones, n, n, 2 * n, theta.cos());
        assert!((e.x / w.x - 2.5).abs() < 1e-12, "{} vs 2.5", e.x / w.x);
    }
}
