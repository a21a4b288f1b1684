//! Comparing two models on the same bins, as `lobe compare` does.

use crate::errors::from_anyhow;
use crate::{grid_of, job, model, settings, PySession};
use lobe::compare::{Bins, Options, Side};
use lobe::grid::Grid;
use pyo3::prelude::*;

/// One side: its parameter set, and for a MERL file the bins it lacks.
fn side(spec: &str, sets: &[String]) -> PyResult<(Side, bool)> {
    let mut side = Side::new(model::resolve(spec, None, sets)?);
    let (name, _) = lobe::resolve::split_spec(spec).map_err(|e| from_anyhow("model", e))?;
    let merl = lobe::merl::model::is_merl_path(name);
    if merl {
        side.missing = lobe::compare::missing_bins(std::path::Path::new(name.trim()))
            .map_err(|e| from_anyhow("model", e))?;
    }
    Ok((side, merl))
}

/// The comparison's report as JSON text (what `lobe compare --format json` prints, without the
/// sides, backend and timing it adds).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, a, sets_a, b, sets_b, grid, res, mu, method, samples, albedo, white_furnace))]
pub fn compare(
    py: Python<'_>,
    session: &Bound<'_, PySession>,
    a: &str,
    sets_a: Vec<String>,
    b: &str,
    sets_b: Vec<String>,
    grid: Option<&str>,
    res: Option<Vec<usize>>,
    mu: Vec<f64>,
    method: &str,
    samples: Option<usize>,
    albedo: bool,
    white_furnace: bool,
) -> PyResult<String> {
    let (side_a, merl_a) = side(a, &sets_a)?;
    let (side_b, merl_b) = side(b, &sets_b)?;
    // The defaults of `lobe compare`: MERL's own bins when a side is a MERL file, else the
    // isotropic grid (full where a side is anisotropic), about 2e5 bins.
    let default_res = |grid: &str| -> Vec<usize> {
        match grid {
            "full" => vec![16, 32, 16, 32],
            "isotropic" => vec![45, 45, 90],
            _ => vec![90, 90, 180],
        }
    };
    let bins = match grid {
        None if merl_a || merl_b => Bins::Merl,
        None => {
            let iso = side_a.params.is_isotropic() && side_b.params.is_isotropic();
            let kind = if iso { "isotropic" } else { "full" };
            Bins::Grid(grid_of(kind, &res.unwrap_or_else(|| default_res(kind)))?)
        }
        Some(kind) => {
            let grid: Grid = grid_of(kind, &res.unwrap_or_else(|| default_res(kind)))?;
            Bins::Grid(grid)
        }
    };
    let settings = settings(
        method,
        samples,
        lobe::integrate::DEFAULT_SEED,
        white_furnace,
    )?;
    let opts = Options {
        bins,
        white_furnace,
        mus: if albedo { mu } else { Vec::new() },
        albedo: albedo.then_some(settings),
    };
    let s = &session.get().inner;
    let report = job::run(py, s, || s.compare(&side_a, &side_b, &opts, &mut |_, _| {}))?;
    serde_json::to_string(&report.to_json())
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}
