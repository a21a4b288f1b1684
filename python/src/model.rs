//! A model as Python names it: a built-in name, `NAME{KEY=VALUE,...}`, a `.brdf` file or a MERL
//! file, then a material preset, then the parameters (KEY=VALUE texts the package builds from a
//! dict), in the order the command line applies them.

use crate::errors::{from_anyhow, to_py};
use lobe::ParamSet;
use pyo3::exceptions::PyFileNotFoundError;
use pyo3::prelude::*;
use std::path::Path;

/// A model file that does not exist, as `FileNotFoundError` (before lobe reads anything).
fn check_file(name: &str) -> PyResult<()> {
    let is_file = lobe::merl::model::is_merl_path(name) || lobe::brdf::is_brdf_path(name);
    let path = Path::new(name.trim());
    if is_file && !path.exists() {
        return Err(PyFileNotFoundError::new_err(format!(
            "model: no such file: {}",
            path.display()
        )));
    }
    Ok(())
}

/// The parameter set of `spec` with `material` and then `sets` applied; the spec's own
/// assignments come last, as on the command line ([`lobe::resolve::resolve_spec`]).
pub fn resolve(spec: &str, material: Option<&str>, sets: &[String]) -> PyResult<ParamSet> {
    let (name, _) = lobe::resolve::split_spec(spec).map_err(|e| from_anyhow("model", e))?;
    check_file(name)?;
    let options = lobe::resolve::SpecOptions::default();
    lobe::resolve::resolve_spec(spec, material, sets, &options, &mut |_| {}).map_err(|e| {
        match e.downcast::<lobe::model::ParamError>() {
            Ok(p) => to_py(lobe::Error::Param(p)),
            Err(e) => from_anyhow("model", e),
        }
    })
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
