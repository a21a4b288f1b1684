//! A model's parameters as the command line states them: the model's defaults, then a material
//! preset, then `key=value` assignments.

use crate::material;
use crate::model::{Model, ParamError, ParamSet};
use anyhow::bail;

/// Resolves a model's parameters as the CLI does: the model's defaults, then the material preset
/// (if any), then each `key=value` assignment in order.
pub fn resolve_params(
    model: &str,
    material: Option<&str>,
    sets: &[String],
) -> Result<ParamSet, ParamError> {
    let model = Model::from_name(model)?;
    let mut params = match material {
        Some(name) => material::preset(name, model)?,
        None => ParamSet::defaults(model),
    };
    for s in sets {
        params.set_text(s)?;
    }
    Ok(params)
}

impl ParamSet {
    /// The built-in material preset `material` (tin, gold, …) for the model named `model`.
    pub fn preset(material: &str, model: &str) -> Result<ParamSet, ParamError> {
        material::preset(material, Model::from_name(model)?)
    }
}

/// A model spec split into its name and its own assignments: `phong{shininess=50,diffuse=0.1}`
/// gives ("phong", ["shininess=50", "diffuse=0.1"]); a comma not followed by KEY= belongs to
/// the value before it (an rgb triple).
pub fn split_spec(spec: &str) -> anyhow::Result<(&str, Vec<String>)> {
    let spec = spec.trim();
    let Some(open) = spec.find('{') else {
        if spec.contains('}') {
            bail!("model '{spec}': a '}}' without its '{{'; write NAME{{KEY=VALUE,...}}");
        }
        return Ok((spec, Vec::new()));
    };
    let Some(inner) = spec[open + 1..].strip_suffix('}') else {
        bail!("model '{spec}': the parameters must end with '}}', as in phong{{shininess=50}}");
    };
    let mut sets: Vec<String> = Vec::new();
    for piece in inner.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        match sets.last_mut() {
            Some(last) if !piece.contains('=') => {
                last.push(',');
                last.push_str(piece);
            }
            _ => sets.push(piece.to_string()),
        }
    }
    // One spec names a value once: which of two would win is not for lobe to guess.
    let key = |set: &str| set.split('=').next().unwrap_or_default().trim().to_string();
    for (k, set) in sets.iter().enumerate() {
        if let Some(again) = sets[k + 1..].iter().find(|s| key(s) == key(set)) {
            bail!(
                "model '{spec}': '{}' is given twice ({set} and {again}); give each parameter once",
                key(set)
            );
        }
    }
    Ok((spec[..open].trim(), sets))
}
