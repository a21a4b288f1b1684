//! `lobe models`: the catalogue of models, parameters and material presets.

use anyhow::Result;
use clap::{Args, ValueEnum};
use lobe::catalogue;
use lobe::material;
use std::io::Write;

/// What `lobe models` prints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Format {
    /// The catalogue for people.
    Text,
    /// The catalogue as one JSON object: models with their parameters, and materials.
    Json,
}

#[derive(Args)]
pub struct ModelsArgs {
    /// Output format, as every command that prints a report takes it.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
    /// The same as --format json.
    #[arg(long, conflicts_with = "format")]
    json: bool,
}

pub fn run(a: ModelsArgs) -> Result<()> {
    let mut out = super::stdout();
    if a.json || a.format == Format::Json {
        writeln!(out, "{}", serde_json::to_string_pretty(&catalogue::json())?)?;
        return Ok(());
    }
    write!(out, "{}", catalogue::text())?;
    writeln!(
        out,
        "\nmaterials (--material), each file in data/materials/ citing its source:\n  \
         {}: the lab report's materials and colours, every model\n  \
         {}: metals, F0 from measured n, k (data/conductors.toml) as the specular colour of \
         phong, blinn_phong, ashikhmin_shirley; the exact conductor Fresnel in microfacet\n  \
         {}: ColorChecker patches (Pascale 2006 sRGB, decoded to linear) as the albedo of \
         lambert, oren_nayar, eon",
        material::names().join(", "),
        material::names_of(material::METALS).join(", "),
        material::names_of(material::DIFFUSE).join(", ")
    )?;
    Ok(())
}
