//! `lobe models`: the catalogue of models, parameters and material presets.

use anyhow::Result;
use clap::Args;
use lobe::material;
use lobe::model::catalogue;
use std::io::Write;

#[derive(Args)]
pub struct ModelsArgs {
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(a: ModelsArgs) -> Result<()> {
    let mut out = super::stdout();
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&catalogue::json())?)?;
        return Ok(());
    }
    write!(out, "{}", catalogue::text())?;
    let metals: Vec<&str> = material::METALS.iter().map(|(n, _)| *n).collect();
    writeln!(
        out,
        "\nmaterials (--material): {} (lab materials, every model); {} (metals, microfacet only)",
        material::names().join(", "),
        metals.join(", ")
    )?;
    Ok(())
}
