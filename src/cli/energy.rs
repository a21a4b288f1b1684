//! `lobe energy`: every model's largest E(mu), gain and loss, at its presets and over a sweep.

use super::{open_albedo_session, BackendArgs, MethodArg, TableFormat};
use anyhow::{bail, Result};
use clap::Args;
use lobe::energy;
use lobe::integrate::Method;
use std::io::{IsTerminal, Write};

/// The most sweep values: each is a full albedo job for every model, and 1024 points resolve the
/// parameter axis far finer than any LUT the project ships.
const MAX_SWEEP: usize = 1024;

#[derive(Args)]
pub struct EnergyArgs {
    /// Models, comma-separated (default: every model); each may carry its own parameters,
    /// 'microfacet,microfacet{multiscatter=kulla_conty},oren_nayar,eon'. A model with
    /// parameters (its own or from --set) is reported as given and swept from there; one
    /// without, at its presets and swept from its defaults.
    #[arg(long)]
    models: Vec<String>,
    /// Set a parameter of every listed model that has it, KEY=VALUE, or of one model,
    /// MODEL.KEY=VALUE; repeatable. Applied before a model's own {KEY=VALUE}.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Values of each model's main parameter to sweep (its LUT axis: shininess 1..8192 log,
    /// roughness 0.01..1 square, ...), cell-centred; 0 for presets only.
    #[arg(long, default_value_t = 8)]
    sweep: usize,
    /// Integrator (see `lobe albedo --help`).
    #[arg(long, value_enum, default_value_t = MethodArg::Peak)]
    method: MethodArg,
    /// Quadrature nodes per view direction (default: 32768 for peak, else the method's).
    #[arg(long)]
    samples: Option<usize>,
    #[command(flatten)]
    backend: BackendArgs,
    /// Output format.
    #[arg(long, value_enum, default_value_t = TableFormat::Table)]
    format: TableFormat,
}

pub fn run(a: EnergyArgs) -> Result<()> {
    let method = Method::from(a.method);
    if let Some(n) = a.samples {
        super::check_samples("--samples", n)?;
    }
    if a.sweep > MAX_SWEEP {
        bail!(
            "--sweep {}: expected at most {MAX_SWEEP} values (each is an albedo job for every model)",
            a.sweep
        );
    }
    let samples = a.samples.unwrap_or(match method {
        Method::Peak => energy::DEFAULT_PEAK_SAMPLES,
        m => m.default_samples(),
    });
    let series = series(&a)?;
    let bar = indicatif::ProgressBar::new(0);
    // Without a terminal the bar is hidden: say how far it got on stderr, one line per model.
    let plain = !std::io::stderr().is_terminal();
    let session = open_albedo_session(&a.backend, method)?;
    let start = std::time::Instant::now();
    let mut out = super::stdout();
    // Table and CSV lines go out as they are known; JSON is one document, written at the end.
    let labels: Vec<String> = series.iter().map(energy::Series::label).collect();
    let width = energy::model_width(labels.iter().map(String::as_str));
    match a.format {
        TableFormat::Table => write!(out, "{}", energy::table_header(width))?,
        TableFormat::Csv => write!(out, "{}", energy::CSV_HEADER)?,
        TableFormat::Json => {}
    }
    out.flush()?;
    let mut last_model = String::new();
    let opts = lobe::EnergyOptions {
        series,
        sweep: a.sweep,
        method,
        samples,
    };
    let rows = session
        .energy(&opts, &mut |row, done, total| {
            bar.set_length(total);
            bar.set_position(done);
            write_row(&mut out, &bar, a.format, row, width).map_err(|e| lobe::Error::Io {
                what: e.to_string(),
                source: e,
            })?;
            if plain && (row.model != last_model || done == total) {
                eprintln!(
                    "lobe energy: {done}/{total} cases ({}), {:.1} s",
                    row.model,
                    start.elapsed().as_secs_f64()
                );
                last_model = row.model.clone();
            }
            Ok(())
        })
        .map_err(super::session_error)?;
    bar.finish_and_clear();
    match a.format {
        TableFormat::Table => {
            writeln!(
                out,
                "white configuration: colours at 1, specular lobes alone under the white furnace, smooth_layered diffuse = 1 - R0; gain: E > 1 + {} beyond its error estimate; loss = 1 - E_avg; method {} ({} nodes per direction)",
                energy::GAIN_MARGIN,
                method.name(),
                samples
            )?;
        }
        TableFormat::Csv => {}
        TableFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "method": method.name(),
                "samples": samples,
                "gain_margin": energy::GAIN_MARGIN,
                "definition": "white configuration: colours at 1 (lambert, oren_nayar albedo; coupled matte), the specular lobe alone under the white furnace (phong, blinn_phong, cook_torrance, ashikhmin_shirley, microfacet), smooth_layered diffuse = 1 - R0; gain: max E(mu) > 1 + gain_margin beyond its error estimate; loss = 1 - E_avg",
                "rows": rows,
            }))?
        )?,
    }
    Ok(())
}

/// Writes a table or CSV line as soon as its row is known (JSON is written whole at the end).
fn write_row(
    out: &mut super::Stdout,
    bar: &indicatif::ProgressBar,
    format: TableFormat,
    row: &energy::EnergyRow,
    width: usize,
) -> std::io::Result<()> {
    match format {
        TableFormat::Table => bar.suspend(|| write!(out, "{}", energy::table_line(row, width)))?,
        TableFormat::Csv => bar.suspend(|| write!(out, "{}", energy::csv_line(row)))?,
        TableFormat::Json => {}
    }
    out.flush()
}

/// What is reported: every model at its presets, or the models and parameters asked for.
fn series(a: &EnergyArgs) -> Result<Vec<energy::Series>> {
    Ok(if a.models.is_empty() && a.sets.is_empty() {
        super::models_or_all(&[])?
            .into_iter()
            .map(energy::Series::Model)
            .collect()
    } else {
        let specs = if a.models.is_empty() {
            lobe::Model::ALL.map(|m| m.name().to_string()).to_vec()
        } else {
            super::split_specs(&a.models)
        };
        super::resolve_all(&specs, None, &a.sets)?
            .into_iter()
            .map(|(label, p)| {
                if p == lobe::ParamSet::defaults(p.model()) {
                    energy::Series::Model(p.model())
                } else {
                    energy::Series::Params(label, p)
                }
            })
            .collect()
    })
}
