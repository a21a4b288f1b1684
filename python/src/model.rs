//! A model as Python names it: a built-in name, `NAME{KEY=VALUE,...}`, a `.brdf` file or a MERL
//! file, then a material preset, then the parameters (KEY=VALUE texts the package builds from a
//! dict), in the order the command line applies them.

use crate::errors::{from_anyhow, to_py};
use lobe::ParamSet;
use pyo3::exceptions::PyFileNotFoundError;
use pyo3::prelude::*;
use std::path::Path;

/// The model's name after loading it when `name` is a file (a `.brdf` shader or a MERL
/// `PATH.binary`, each loaded once per process).
fn model_name(name: &str) -> PyResult<String> {
    let is_merl = lobe::merl::model::is_merl_path(name);
    if !is_merl && !lobe::brdf::is_brdf_path(name) {
        return Ok(name.to_string());
    }
    let path = Path::new(name.trim());
    if !path.exists() {
        return Err(PyFileNotFoundError::new_err(format!(
            "model: no such file: {}",
            path.display()
        )));
    }
    if is_merl {
        let loaded = lobe::merl::model::load(path).map_err(|e| from_anyhow("model", e))?;
        return Ok(loaded.model.name().to_string());
    }
    let loaded = lobe::brdf::load(path, &lobe::brdf::LoadOptions::default())
        .map_err(|e| from_anyhow("model", e.into()))?;
    Ok(loaded.model.name().to_string())
}

/// The parameter set of `spec` with `material` and then `sets` applied; the spec's own
/// assignments come last, as on the command line.
pub fn resolve(spec: &str, material: Option<&str>, sets: &[String]) -> PyResult<ParamSet> {
    let (name, own) = lobe::spec::split_spec(spec).map_err(|e| from_anyhow("model", e))?;
    let name = model_name(name)?;
    let mut params =
        lobe::resolve_params(&name, material, &[]).map_err(|e| to_py(lobe::Error::Param(e)))?;
    for set in sets.iter().chain(&own) {
        params
            .set_text(set)
            .map_err(|e| to_py(lobe::Error::Param(e)))?;
    }
    Ok(params)
}

/// One parameter set per entry of `sets_list`, each from the same spec and material.
pub fn resolve_rows(
    spec: &str,
    material: Option<&str>,
    sets_list: &[Vec<String>],
) -> PyResult<Vec<ParamSet>> {
    sets_list
        .iter()
        .map(|sets| resolve(spec, material, sets))
        .collect()
}
