//! `lobe stability`: every model over the edges of its domain; fails on any NaN, Inf or
//! negative value.

use super::{bar, open_session, BackendArg, BackendArgs};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use lobe::stability;
use std::io::Write;

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum StabilityFormat {
    Table,
    Json,
}

#[derive(Args)]
pub struct StabilityArgs {
    /// Models to sweep, comma-separated (default: every model with each of its component
    /// choices). A model with choices (`microfacet`, `eon`) means all of them.
    #[arg(long, value_delimiter = ',')]
    models: Vec<String>,
    // With gpu (the default) the GPU and the CPU reference are swept and compared; with cpu the
    // CPU reference alone (no Vulkan device needed).
    #[command(flatten)]
    backend: BackendArgs,
    /// The same as --backend cpu: sweep the CPU reference alone (no GPU-vs-CPU errors).
    #[arg(long)]
    cpu_only: bool,
    /// Print a row for every parameter edge, not only those where something is off.
    #[arg(long)]
    all: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = StabilityFormat::Table)]
    format: StabilityFormat,
}

pub fn run(a: StabilityArgs) -> Result<()> {
    let models = stability::models_named(&super::model_files(&a.models)?)?;
    let progress = bar(models.len() as u64, "{msg} [{bar:30}] {pos}/{len}");
    let mut step = |label: &str| {
        progress.set_message(format!("stability {label}"));
        progress.inc(1);
    };
    let mut backend = a.backend.clone();
    if a.cpu_only {
        backend.backend = BackendArg::Cpu;
    }
    let session = open_session(&backend)?;
    let report = session.stability(models, &mut step)?;
    progress.finish_and_clear();
    let mut out = super::stdout();
    match a.format {
        StabilityFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?,
        StabilityFormat::Table => write!(out, "{}", stability::format_table(&report, a.all))?,
    }
    let bad = report.bad_values();
    if bad > 0 {
        bail!("{bad} NaN, infinite or negative values on valid input (see the table)");
    }
    Ok(())
}
