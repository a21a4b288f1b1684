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
