//! `lobe demo`: the main job on the built-in materials. For now a gold lobe table on both grids,
//! a few evaluations on both backends with their differences, written under one folder.

use crate::eval::Evaluator;
use crate::grid::{direction, Grid};
use crate::material;
use crate::model::{Model, ParamSet};
use crate::table::{write_table, TableMeta};
use anyhow::{Context, Result};
use glam::DVec3;
use std::fmt::Write as _;
use std::path::Path;

/// Writes the demo's files into `dir` and returns a human-readable summary.
pub fn run(
    eval: &Evaluator,
    dir: &Path,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<String> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut summary = String::new();
    let gold = material::preset("gold", Model::CookTorrance)?;
    for (name, grid) in [
        (
            "gold_cook_torrance_full.exr",
            Grid::Full {
                n_theta_i: 16,
                n_phi_i: 8,
                n_theta_o: 64,
                n_phi_o: 128,
            },
        ),
        (
            "gold_cook_torrance_isotropic.exr",
            Grid::Isotropic {
                n_theta_i: 90,
                n_theta_o: 90,
                n_dphi: 180,
            },
        ),
    ] {
        let path = dir.join(name);
        let meta = TableMeta {
            params: &gold,
            white_furnace: false,
            grid,
            backend: eval.name(),
        };
        let started = std::time::Instant::now();
        write_table(eval, &meta, &path, &mut |done, all| {
            progress(name, done, all)
        })?;
        writeln!(
            summary,
            "table {} ({} grid, {} cells) in {:.2} s",
            path.display(),
            grid.name(),
            grid.cells().unwrap_or(0),
            started.elapsed().as_secs_f64()
        )?;
    }
    writeln!(summary, "\nf(wi, wo) in 1/sr at the mirror configuration theta_i = theta_o = 30 deg, phi_o = phi_i + 180:")?;
    writeln!(
        summary,
        "{:<16} {:<18} {:>36}   {:>9}",
        "material",
        "model",
        &format!("{} (r, g, b)", eval.name()),
        "cpu diff"
    )?;
    let pair = [(
        direction(30f64.to_radians(), 0.0),
        direction(30f64.to_radians(), std::f64::consts::PI),
    )];
    for mat in material::names() {
        for model in [Model::Lambert, Model::CookTorrance, Model::AshikhminShirley] {
            let p: ParamSet = material::preset(mat, model)?;
            let f = eval.eval_pairs(&p, false, &pair)?[0];
            let c = Evaluator::Cpu.eval_pairs(&p, false, &pair)?[0];
            let rel = (0..3)
                .map(|k| (f[k] - c[k]).abs() / c[k].abs().max(1e-30))
                .fold(0.0, f64::max);
            let rgb = DVec3::from_array(f);
            writeln!(
                summary,
                "{mat:<16} {:<18} {:>36}   {rel:>9.1e}",
                model.name(),
                format!("{:.6}, {:.6}, {:.6}", rgb.x, rgb.y, rgb.z)
            )?;
        }
    }
    std::fs::write(dir.join("summary.txt"), &summary)
        .with_context(|| format!("writing {}", dir.join("summary.txt").display()))?;
    Ok(summary)
}
