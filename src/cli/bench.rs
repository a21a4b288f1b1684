//! `lobe bench`: evaluations per second of every model, on each backend asked for.

use super::{bar, open_session, BackendArg, BackendArgs, TableFormat};
use anyhow::{anyhow, Result};
use clap::Args;
use lobe::grid::Grid;
use lobe::ParamSet;
use std::io::Write;

#[derive(Args)]
pub struct BenchArgs {
    /// Models to measure (default: all), comma-separated.
    #[arg(long, value_delimiter = ',')]
    models: Vec<String>,
    /// Isotropic grid NTHETA_I,NTHETA_O,NDPHI of each timed table.
    #[arg(long, default_value = "128,128,256")]
    res: String,
    /// Timed runs per measurement (the median is reported), after one warm-up run.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Time lobe tables only, not albedo integration.
    #[arg(long)]
    no_albedo: bool,
    /// Backends to measure, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "gpu,cpu")]
    backend: Vec<BackendArg>,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long, value_name = "SUBSTRING")]
    device: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
}

pub fn run(a: BenchArgs) -> Result<()> {
    let models = super::models_or_all(&a.models)?;
    let grid = Grid::parse("isotropic", &a.res).map_err(|e| anyhow!("--res: {e}"))?;
    super::check_held_cells("--res", &grid)?;
    super::check_repeats("--repeats", a.repeats)?;
    let mut rows = Vec::new();
    for backend in &a.backend {
        // One session per backend measured, each opened as the backend flags of any command.
        let session = open_session(&BackendArgs {
            backend: *backend,
            device: a.device.clone(),
        })?;
        let name = session.backend_name();
        let progress = bar(models.len() as u64, "{msg} [{bar:30}] {pos}/{len}");
        for m in &models {
            progress.set_message(format!("bench {} on {name}", m.name()));
            let params = ParamSet::defaults(*m);
            rows.push(session.bench_table(&params, &grid, a.repeats)?);
            if !a.no_albedo {
                rows.push(session.bench_albedo(&params, a.repeats)?);
            }
            progress.inc(1);
        }
        progress.finish_and_clear();
    }
    let mut out = super::stdout();
    match a.format {
        TableFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?,
        TableFormat::Csv => {
            writeln!(
                out,
                "model,task,backend,evaluations,wall_evals_per_s,kernel_evals_per_s"
            )?;
            for r in &rows {
                let k = r.kernel_per_s.map(|k| k.to_string()).unwrap_or_default();
                writeln!(
                    out,
                    "{},{},{},{},{},{k}",
                    r.model, r.task, r.backend, r.evaluations, r.wall_per_s
                )?;
            }
        }
        TableFormat::Table => {
            writeln!(
                out,
                "evaluations per second, median of {} runs: table = {} cells of an isotropic table; \
                 albedo = {} view directions x {} nodes (Gauss-Legendre, with its coarse check)",
                a.repeats,
                grid.cells().unwrap_or(0),
                lobe::bench::ALBEDO_DIRECTIONS,
                lobe::bench::ALBEDO_RULE.nodes(glam::DVec3::Z).len()
                    + lobe::bench::ALBEDO_RULE.coarse().0.nodes(glam::DVec3::Z).len()
            )?;
            writeln!(
                out,
                "{:<18} {:<7} {:<44} {:>14} {:>16}",
                "model", "task", "backend", "wall (M/s)", "kernel (M/s)"
            )?;
            for r in &rows {
                let k = r
                    .kernel_per_s
                    .map(|k| format!("{:.1}", k / 1e6))
                    .unwrap_or_else(|| "-".into());
                writeln!(
                    out,
                    "{:<18} {:<7} {:<44} {:>14.1} {:>16}",
                    r.model,
                    r.task,
                    r.backend,
                    r.wall_per_s / 1e6,
                    k
                )?;
            }
        }
    }
    Ok(())
}
