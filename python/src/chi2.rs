//! The sampling test of a model's sampler, as `lobe chi2` runs it, on the session's backend.

use crate::{job, model, PySession};
use pyo3::prelude::*;

/// The test's report as JSON text (what `lobe chi2 --format json` prints).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, model, material, sets, white_furnace, theta_o_deg, phi_o_deg, samples, seed, significance, checked_draws))]
pub fn chi2(
    py: Python<'_>,
    session: &Bound<'_, PySession>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    white_furnace: bool,
    theta_o_deg: Vec<f64>,
    phi_o_deg: Vec<f64>,
    samples: u64,
    seed: u32,
    significance: f64,
    checked_draws: Option<u64>,
) -> PyResult<String> {
    let params = model::resolve(model, material, &sets)?;
    let options = lobe::chi2::Options {
        directions: theta_o_deg
            .iter()
            .zip(&phi_o_deg)
            .map(|(&t, &p)| [t, p])
            .collect(),
        samples,
        seed,
        significance,
        cells: None,
        checked_draws,
    };
    let s = &session.get().inner;
    let report = job::run(py, s, || {
        s.chi2(&params, white_furnace, &options, &mut |_, _| {})
    })?;
    serde_json::to_string(&report.to_json_for(&params))
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}
