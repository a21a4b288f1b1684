//! A model's parameters as the command line states them: the model's defaults, then a material
//! preset, then `key=value` assignments.

use crate::material;
use crate::model::{Model, ParamError, ParamSet};

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
