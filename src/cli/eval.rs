//! `lobe eval`: f at direction pairs given on the command line or in a pairs file.

use super::{open_session, BackendArgs, ModelArgs};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use lobe::pairs;
use std::io::Write;
use std::path::PathBuf;

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum Format {
    Csv,
    Json,
}

#[derive(Args)]
pub struct EvalArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    backend: BackendArgs,
    /// Light direction wi as THETA,PHI in degrees (theta in [0, 180]; f = 0 below the horizon).
    #[arg(
        long = "wi-deg",
        visible_alias = "wi",
        value_name = "THETA,PHI",
        requires = "wo",
        conflicts_with = "pairs",
        allow_hyphen_values = true
    )]
    wi: Option<String>,
    /// View direction wo as THETA,PHI in degrees.
    #[arg(
        long = "wo-deg",
        visible_alias = "wo",
        value_name = "THETA,PHI",
        requires = "wi",
        allow_hyphen_values = true
    )]
    wo: Option<String>,
    /// CSV file of pairs with the header theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg.
    #[arg(long, value_name = "FILE.csv")]
    pairs: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    format: Format,
}

pub fn run(a: EvalArgs) -> Result<()> {
    let params = a.model.params()?;
    let angles: Vec<[f64; 4]> = match (&a.wi, &a.wo, &a.pairs) {
        (Some(wi), Some(wo), None) => {
            let [ti, pi] = pairs::parse_direction(wi).context("--wi-deg")?;
            let [to, po] = pairs::parse_direction(wo).context("--wo-deg")?;
            vec![[ti, pi, to, po]]
        }
        (None, None, Some(path)) => pairs::read_csv(path)?,
        _ => bail!("give either --wi-deg THETA,PHI --wo-deg THETA,PHI or --pairs FILE.csv"),
    };
    let session = open_session(&a.backend)?;
    let values = session.eval_pairs(&params, a.model.white_furnace, &pairs::directions(&angles))?;
    let mut out = std::io::stdout().lock();
    match a.format {
        Format::Csv => {
            writeln!(out, "{}", [pairs::HEADER, "r,g,b"].join(","))?;
            for ([ti, pi, to, po], [r, g, b]) in angles.iter().zip(&values) {
                writeln!(out, "{ti},{pi},{to},{po},{r},{g},{b}")?;
            }
        }
        Format::Json => {
            let rows: Vec<_> = angles
                .iter()
                .zip(&values)
                .map(|([ti, pi, to, po], rgb)| {
                    serde_json::json!({"theta_i_deg": ti, "phi_i_deg": pi, "theta_o_deg": to, "phi_o_deg": po, "rgb": rgb})
                })
                .collect();
            let doc = serde_json::json!({
                "model": params.model().name(),
                "parameters": params.to_json(),
                "white_furnace": a.model.white_furnace,
                "backend": session.backend_name(),
                "units": "1/sr, linear RGB, without the cosine; delta lobes excluded",
                "values": rows,
            });
            writeln!(out, "{}", serde_json::to_string_pretty(&doc)?)?;
        }
    }
    Ok(())
}
