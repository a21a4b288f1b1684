//! `lobe tradeoff`: cost and error of each speed-for-accuracy variant of a model, with a Pareto
//! plot.

use super::{
    bar, open_session, parse_size, session_error, with_flag, BackendArgs, ModelArgs, TableFormat,
};
use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use lobe::grid::Grid;
use lobe::tradeoff::{AlbedoSetup, Options, Section};
use std::io::Write;
use std::path::PathBuf;

/// The sections of the report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum SectionArg {
    /// Variants of f (f64 reference, f32 kernel, plain pow, Fresnel, G1 and masking choices).
    Evaluation,
    /// Each fixed albedo rule over a ladder of node counts, on each backend.
    Integration,
    /// E(mu) integrated from isotropic lobe tables of each resolution.
    TableResolution,
}

impl From<SectionArg> for Section {
    fn from(s: SectionArg) -> Section {
        match s {
            SectionArg::Evaluation => Section::Evaluation,
            SectionArg::Integration => Section::Integration,
            SectionArg::TableResolution => Section::TableResolution,
        }
    }
}

#[derive(Args)]
pub struct TradeoffArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    backend: BackendArgs,
    /// Sections to measure, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "evaluation,integration,table-resolution"
    )]
    sections: Vec<SectionArg>,
    /// A smaller version of every section (the defaults of the flags below shrink): a first look.
    #[arg(long)]
    quick: bool,
    /// Evaluation: isotropic grid NTHETA_I,NTHETA_O,NDPHI on which errors are measured (full grid
    /// with the same angular density for an anisotropic parameter set) [default: 32,32,64;
    /// --quick 16,16,32].
    #[arg(long)]
    error_res: Option<String>,
    /// Evaluation: isotropic grid NTHETA_I,NTHETA_O,NDPHI on which costs are timed [default:
    /// 96,96,192; --quick 48,48,96].
    #[arg(long)]
    timing_res: Option<String>,
    /// Timed runs per variant, after one untimed run; the median is reported [default: 5;
    /// --quick 2].
    #[arg(long)]
    repeats: Option<usize>,
    /// Integration and tables: view directions as mu = cos(theta_o), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = super::default_mus())]
    mu: Vec<f64>,
    /// Integration: quadrature nodes per albedo, comma-separated [default:
    /// 256,1024,4096,16384,65536; --quick 256,1024,4096].
    #[arg(long, value_delimiter = ',')]
    samples: Vec<usize>,
    /// Tables: resolutions N (N x N x 2N cells in theta_i, theta_o, dphi), comma-separated
    /// [default: 8,16,32,64,128; --quick 8,16,32].
    #[arg(long, value_delimiter = ',')]
    table_res: Vec<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
    /// Write the log-log Pareto plot here (.png or .svg) [default: tradeoff-MODEL.png, or
    /// tradeoff-MATERIAL-MODEL.png with --material, in the current folder].
    #[arg(long, value_name = "PATH", conflicts_with = "no_plot")]
    plot: Option<PathBuf>,
    /// Write no plot.
    #[arg(long)]
    no_plot: bool,
    /// Plot size WIDTHxHEIGHT in pixels (SVG: user units).
    #[arg(long, default_value = "1800x720")]
    size: String,
}

/// The flag behind a refused trade-off option.
fn tradeoff_flag(option: &str) -> Option<String> {
    let flag = match option {
        "mus" => "--mu",
        "samples" => "--samples",
        "table_res" => "--table-res",
        "repeats" => "--repeats",
        "sections" => "--sections",
        "size" => "--size",
        _ => return None,
    };
    Some(flag.to_string())
}

pub fn run(a: TradeoffArgs) -> Result<()> {
    let params = a.model.params()?;
    let sections: Vec<Section> = a.sections.iter().map(|&s| s.into()).collect();
    let mut albedo = if a.quick {
        AlbedoSetup::quick()
    } else {
        AlbedoSetup::standard()
    };
    albedo.mus = a.mu.clone();
    if !a.samples.is_empty() {
        albedo.samples = a.samples.clone();
    }
    if !a.table_res.is_empty() {
        albedo.table_res = a.table_res.clone();
    }
    if let Some(r) = a.repeats {
        albedo.repeats = r;
    }
    let grid = |flag: &str, text: &Option<String>, standard: &str, quick: &str| {
        let res = text
            .as_deref()
            .unwrap_or(if a.quick { quick } else { standard });
        let grid = Grid::parse("isotropic", res).map_err(|e| anyhow!("{flag}: {e}"))?;
        super::check_held_cells(flag, &grid)?;
        Ok::<Grid, anyhow::Error>(grid)
    };
    for &n in &albedo.samples {
        super::check_samples("--samples", n)?;
    }
    for &n in &albedo.table_res {
        super::check_held_cells("--table-res", &lobe::tradeoff::table_grid(n))?;
    }
    super::check_repeats("--repeats", albedo.repeats)?;
    let opts = Options {
        sections,
        error_grid: lobe::tradeoff::error_grid_for(
            &params,
            grid("--error-res", &a.error_res, "32,32,64", "16,16,32")?,
        ),
        timing_grid: grid("--timing-res", &a.timing_res, "96,96,192", "48,48,96")?,
        eval_repeats: albedo.repeats,
        albedo,
    };
    let plot_path = (!a.no_plot).then(|| {
        a.plot.clone().unwrap_or_else(|| {
            PathBuf::from(match &a.model.material {
                Some(m) => format!("tradeoff-{m}-{}.png", params.model().name()),
                None => format!("tradeoff-{}.png", params.model().name()),
            })
        })
    });
    let size = parse_size("--size", &a.size, "1800x720")?;
    if let Some(p) = &plot_path {
        // Refused before minutes of measuring, not after.
        lobe::plot::Format::of(p)?;
    }
    let progress = bar(0, "{msg} [{bar:30}] {pos}/{len}");
    let material = a.model.material.as_deref();
    let mut step = |step: usize, steps: usize, what: &str| {
        progress.set_length(steps as u64);
        progress.set_position(step as u64);
        progress.set_message(what.to_string());
    };
    let session = open_session(&a.backend)?;
    let report = with_flag(
        session
            .tradeoff(&params, material, &opts, &mut step)
            .map_err(session_error),
        tradeoff_flag,
    )?;
    progress.finish_and_clear();
    let mut out = super::stdout();
    match a.format {
        TableFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&report.to_json())?)?,
        TableFormat::Csv => report.write_csv(&mut out)?,
        TableFormat::Table => report.write_table(&mut out)?,
    }
    if let Some(p) = plot_path {
        with_flag(
            lobe::plot::pareto::plot_pareto(&report, size, &p),
            tradeoff_flag,
        )?;
        eprintln!("lobe: wrote {}", p.display());
    }
    Ok(())
}
