//! Fitting a model's free parameters to a target, as `lobe fit` does.

use crate::errors::{from_anyhow, invalid};
use crate::{job, model, PySession};
use lobe::fit::{FitOptions, Space, Target};
use lobe::loss::LossKind;
use pyo3::exceptions::PyFileNotFoundError;
use pyo3::prelude::*;

/// The keys a spec and its sets give values to: those cannot also be fitted.
fn fixed_keys(spec: &str, sets: &[String]) -> PyResult<Vec<String>> {
    let (_, own) = lobe::resolve::split_spec(spec).map_err(|e| from_anyhow("model", e))?;
    Ok(own
        .iter()
        .chain(sets)
        .filter_map(|s| s.split_once('=').map(|(k, _)| k.trim().to_string()))
        .collect())
}

/// The fit's report as JSON text (what `lobe fit --format json` prints).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, target, target_sets, model, sets, free, loss, max_bins, starts, max_iters))]
pub fn fit(
    py: Python<'_>,
    session: &Bound<'_, PySession>,
    target: &str,
    target_sets: Vec<String>,
    model: &str,
    sets: Vec<String>,
    free: Vec<String>,
    loss: &str,
    max_bins: usize,
    starts: usize,
    max_iters: u64,
) -> PyResult<String> {
    let target = match Target::file_kind(target) {
        Some(file) => {
            if !target_sets.is_empty() {
                return Err(invalid(
                    "target_params",
                    format!("the target {target} is a file, which has no parameters to set"),
                ));
            }
            if !std::path::Path::new(target.trim()).exists() {
                return Err(PyFileNotFoundError::new_err(format!(
                    "target: no such file: {target}"
                )));
            }
            file
        }
        None => Target::Model(model::resolve(target, None, &target_sets)?),
    };
    let base = model::resolve(model, None, &sets)?;
    let fixed = fixed_keys(model, &sets)?;
    let space = Space::new(base, &free, &fixed).map_err(|e| from_anyhow("free", e))?;
    let loss = match loss {
        "log" => LossKind::CosineLog,
        "l2" => LossKind::RelativeL2,
        other => {
            return Err(invalid(
                "loss",
                format!("'{other}' is not a loss; give \"log\" or \"l2\""),
            ))
        }
    };
    let opts = FitOptions {
        loss,
        max_bins,
        starts,
        max_iters,
    };
    let s = &session.get().inner;
    let report = job::run(py, s, || s.fit(&target, &space, &opts, &|_| {}))?;
    serde_json::to_string(&report.to_json(&target))
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}
