//! `lobe bench`: evaluations per second of every model, on each backend asked for.

use super::table::GridArg;
use super::{bar, open_session, BackendArg, BackendArgs, TableFormat};
use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use lobe::bench::Throughput;
use lobe::grid::Grid;
use lobe::ParamSet;
use lobe::Query;
use std::io::Write;

/// What `lobe bench` times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BenchTask {
    /// A lobe table on the --res grid, output discarded.
    Table,
    /// Directional albedo at 32 view directions by Gauss-Legendre nodes.
    Albedo,
    /// An albedo look-up table: the model's default axis, 32 x 32 cells, the peak rule at 32768
    /// nodes per direction (as `lobe albedo --lut --samples 32768`, no file written).
    Lut,
    /// The sampling test: 2^22 draws of the model's sampler at theta_o = 45 deg, counted and
    /// judged (as `lobe chi2 --samples 2^22`); rates are draws per second.
    Chi2,
    /// The lit sphere's exact sum: 64^2 pixels under the built-in sky (as `lobe light --method
    /// exact --size 64 --env sky`); rates are texel terms (pixels x texels) per second.
    Light,
}

#[derive(Args)]
pub struct BenchArgs {
    /// Models to measure (default: all), comma-separated; each at its defaults, then --material
    /// and --set, then its own {KEY=VALUE,...}: --models 'phong{shininess=50},microfacet'.
    #[arg(long, conflicts_with = "model")]
    models: Vec<String>,
    /// One model to measure (the same as --models MODEL), optionally with its own parameters:
    /// --model 'microfacet{distribution=beckmann,alpha=0.3}'.
    #[arg(long)]
    model: Option<String>,
    /// Set a parameter, KEY=VALUE; rgb values as r,g,b or one number. Repeatable; applied after
    /// --material, to every model measured.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Start every model measured from a material preset: tin, gold, glazed_ceramic, granite.
    #[arg(long)]
    material: Option<String>,
    /// Replace every Fresnel factor of a specular lobe by 1 in every task.
    #[arg(long)]
    white_furnace: bool,
    /// Grid of each timed table.
    #[arg(long, value_enum, default_value_t = GridArg::Isotropic)]
    grid: GridArg,
    /// Resolution of each timed table, as `lobe table --res` reads it for --grid (default:
    /// 128,128,256 isotropic; 32,128,32,128 full; 90,90,180 halfdiff, about 4e6 cells each but
    /// halfdiff's 1.5e6).
    #[arg(long)]
    res: Option<String>,
    /// Timed runs per measurement (the median is reported), after one warm-up run.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// What to time, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "table,albedo"
    )]
    tasks: Vec<BenchTask>,
    /// Time lobe tables only, not albedo integration (drops `albedo` from --tasks).
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
    let names: Vec<String> = a.model.iter().cloned().chain(a.models.clone()).collect();
    // Split on the commas outside braces, so that a model's own {KEY=VALUE,...} stays whole.
    let specs: Vec<String> = match names.is_empty() {
        true => super::models_or_all(&[])?
            .iter()
            .map(|m| m.name().to_string())
            .collect(),
        false => super::split_specs(&names),
    };
    // Every parameter set is resolved before anything is timed, so a bad --set fails at once.
    let sets: Vec<ParamSet> = specs
        .iter()
        .map(|spec| super::resolve(spec, a.material.as_deref(), &a.sets))
        .collect::<Result<_>>()?;
    let res = a.res.as_deref().unwrap_or(match a.grid {
        GridArg::Isotropic => "128,128,256",
        GridArg::Full => "32,128,32,128",
        GridArg::Halfdiff => "90,90,180",
    });
    let grid = Grid::parse(a.grid.name(), res).map_err(|e| anyhow!("--res: {e}"))?;
    super::check_held_cells("--res", &grid)?;
    super::check_repeats("--repeats", a.repeats)?;
    let tasks: Vec<BenchTask> = a
        .tasks
        .iter()
        .copied()
        .filter(|t| !(a.no_albedo && *t == BenchTask::Albedo))
        .collect();
    let mut rows = Vec::new();
    for backend in &a.backend {
        // One session per backend measured, each opened as the backend flags of any command.
        let session = open_session(&BackendArgs {
            backend: *backend,
            device: a.device.clone(),
        })?;
        let name = session.backend_name();
        let progress = bar(
            (sets.len() * tasks.len()) as u64,
            "{msg} [{bar:30}] {pos}/{len}",
        );
        for params in &sets {
            for task in &tasks {
                progress.set_message(format!(
                    "bench {} {task:?} on {name}",
                    params.model().name()
                ));
                let wf = a.white_furnace;
                rows.push(match task {
                    BenchTask::Table => session.bench_table_with(
                        Query::one(params).with_white_furnace(wf),
                        &grid,
                        a.repeats,
                    )?,
                    BenchTask::Albedo => session
                        .bench_albedo(Query::one(params).with_white_furnace(wf), a.repeats)?,
                    BenchTask::Lut => {
                        session.bench_lut(Query::one(params).with_white_furnace(wf), a.repeats)?
                    }
                    BenchTask::Chi2 => {
                        session.bench_chi2(Query::one(params).with_white_furnace(wf), a.repeats)?
                    }
                    BenchTask::Light => {
                        session.bench_light(Query::one(params).with_white_furnace(wf), a.repeats)?
                    }
                });
                progress.inc(1);
            }
        }
        progress.finish_and_clear();
    }
    let mut out = super::stdout();
    match a.format {
        TableFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?,
        TableFormat::Csv => print_csv(&mut out, &rows)?,
        TableFormat::Table => print_table(&mut out, &a, &grid, &rows)?,
    }
    Ok(())
}

/// One CSV line per model, task and backend.
fn print_csv(out: &mut impl Write, rows: &[Throughput]) -> Result<()> {
    writeln!(
        out,
        "model,task,backend,evaluations,wall_evals_per_s,kernel_evals_per_s,cells,wall_cells_per_s"
    )?;
    for r in rows {
        let text = |v: Option<String>| v.unwrap_or_default();
        let k = text(r.kernel_per_s.map(|k| k.to_string()));
        let cells = text(r.cells.map(|c| c.to_string()));
        let cells_per_s = text(r.cells_wall_per_s.map(|c| c.to_string()));
        writeln!(
            out,
            "{},{},{},{},{},{k},{cells},{cells_per_s}",
            r.model, r.task, r.backend, r.evaluations, r.wall_per_s
        )?;
    }
    Ok(())
}

/// What was timed, the drivers, then one line per model, task and backend.
fn print_table(
    out: &mut impl Write,
    a: &BenchArgs,
    grid: &Grid,
    rows: &[Throughput],
) -> Result<()> {
    writeln!(
        out,
        "BRDF evaluations per second (wall, kernel) and table cells written per second (cells), \
             median of {} runs: table = {} cells on the {} grid (where a model's symmetries \
             allow, docs/design.md 4.5-4.6, the GPU evaluates some cells and copies the others: \
             evaluations count the first, cells both); \
             albedo = {} view directions x {} nodes (Gauss-Legendre, with its two coarse levels); \
             lut = {}x{} albedo LUT, peak rule at {} nodes per direction; \
             chi2 = the sampling test's draws per second, {} at theta_o = {} deg; \
             light = the lit sphere's texel terms per second, {}^2 pixels under the 256x128 sky",
        a.repeats,
        grid.cells().unwrap_or(0),
        grid.name(),
        lobe::bench::ALBEDO_DIRECTIONS,
        lobe::bench::ALBEDO_RULE
            .levels(false)
            .iter()
            .map(|r| r.nodes(glam::DVec3::Z).len())
            .sum::<usize>(),
        lobe::bench::LUT_RES,
        lobe::bench::LUT_RES,
        lobe::bench::LUT_SAMPLES,
        lobe::bench::CHI2_SAMPLES,
        lobe::bench::CHI2_THETA_O_DEG,
        lobe::bench::LIGHT_SIZE
    )?;
    let mut drivers: Vec<(&str, &str)> = rows
        .iter()
        .filter_map(|r| Some((r.backend.as_str(), r.driver.as_deref()?)))
        .collect();
    drivers.dedup();
    for (backend, driver) in drivers {
        writeln!(out, "{backend}: driver {driver}")?;
    }
    writeln!(
        out,
        "{:<18} {:<7} {:<44} {:>14} {:>16} {:>15}",
        "model", "task", "backend", "wall (M/s)", "kernel (M/s)", "cells (M/s)"
    )?;
    let millions = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{:.1}", v / 1e6));
    for r in rows {
        writeln!(
            out,
            "{:<18} {:<7} {:<44} {:>14.1} {:>16} {:>15}",
            r.model,
            r.task,
            r.backend,
            r.wall_per_s / 1e6,
            millions(r.kernel_per_s),
            millions(r.cells_wall_per_s)
        )?;
    }
    Ok(())
}
