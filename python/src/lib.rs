//! `lobe._lobe`: the native half of the `lobe` Python package. Every call resolves a parameter
//! set the way the command line does and runs one [`lobe::Session`] job; the package's
//! `__init__.py` checks the arrays and keyword arguments and shapes the results.

mod chi2;
mod compare;
mod errors;
mod fit;
mod job;
mod light;
mod luts;
mod model;
mod plot;
mod sample;

use errors::{invalid, GpuError, InvalidValuesError};
use lobe::glam::DVec3;
use lobe::grid::Grid;
use lobe::Query;
use lobe::{AlbedoSettings, BackendKind, Session, SessionOptions};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A lobe session: an open backend (a Vulkan device or the f64 CPU reference) and the pipelines
/// built on it. `lobe::Session` is `Send + Sync`, so one object serves every Python thread
/// without a lock of its own.
#[pyclass(frozen, name = "_Session", module = "lobe._lobe")]
pub(crate) struct PySession {
    pub(crate) inner: Session,
}

/// A flat vector as an array of `shape`.
pub(crate) fn array<'py, T: numpy::Element>(
    py: Python<'py>,
    values: Vec<T>,
    shape: Vec<usize>,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<T>>> {
    PyArray1::from_vec(py, values).reshape(shape)
}

/// The (ωi, ωo) pairs of two (N, 3) arrays of the same length.
pub(crate) fn pairs(
    wi: &PyReadonlyArray2<'_, f64>,
    wo: &PyReadonlyArray2<'_, f64>,
) -> Vec<(DVec3, DVec3)> {
    let (wi, wo) = (wi.as_array(), wo.as_array());
    wi.rows()
        .into_iter()
        .zip(wo.rows())
        .map(|(a, b)| (DVec3::new(a[0], a[1], a[2]), DVec3::new(b[0], b[1], b[2])))
        .collect()
}

/// The integrator `method` with `samples` nodes a direction (its default when None), drawing
/// from the stream `seed` when it is a Monte Carlo method.
pub(crate) fn settings(
    method: &str,
    samples: Option<usize>,
    seed: u32,
    white_furnace: bool,
) -> PyResult<AlbedoSettings> {
    let method =
        lobe::integrate::Method::from_name(method).map_err(|e| errors::from_anyhow("method", e))?;
    Ok(AlbedoSettings {
        method,
        samples: samples.unwrap_or(method.default_samples()),
        seed,
        white_furnace,
    })
}

pub(crate) fn grid_of(grid: &str, res: &[usize]) -> PyResult<Grid> {
    let text: Vec<String> = res.iter().map(usize::to_string).collect();
    Grid::parse(grid, &text.join(",")).map_err(|e| invalid("res", e))
}

#[pymethods]
impl PySession {
    #[new]
    #[pyo3(signature = (backend, device))]
    fn new(py: Python<'_>, backend: &str, device: Option<String>) -> PyResult<Self> {
        let backend = match backend {
            "gpu" => BackendKind::Gpu,
            "cpu" => BackendKind::Cpu,
            other => {
                return Err(invalid(
                    "backend",
                    format!("'{other}' is not a backend; give \"gpu\" or \"cpu\""),
                ))
            }
        };
        let opts = SessionOptions {
            backend,
            device,
            ..SessionOptions::default()
        };
        let inner = py.detach(|| Session::open(opts)).map_err(errors::to_py)?;
        Ok(PySession { inner })
    }

    fn backend_name(&self) -> String {
        self.inner.backend_name()
    }

    /// f for each parameter set of `sets_list` at each pair: shape (sets, pairs, 3).
    #[allow(clippy::too_many_arguments)]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        model: &str,
        material: Option<&str>,
        sets_list: Vec<Vec<String>>,
        white_furnace: bool,
        wi: PyReadonlyArray2<'py, f64>,
        wo: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
        let rows = model::resolve_rows(model, material, &sets_list)?;
        let pairs = pairs(&wi, &wo);
        let s = &self.inner;
        let values = job::run(py, s, || {
            s.eval_pairs_sets(Query::sets(&rows).with_white_furnace(white_furnace), &pairs)
        })?;
        let flat: Vec<f64> = values.into_iter().flatten().flatten().collect();
        array(py, flat, vec![rows.len(), pairs.len(), 3])
    }

    /// The table as float32 of shape grid + (3,), and its axes.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn table<'py>(
        &self,
        py: Python<'py>,
        model: &str,
        material: Option<&str>,
        sets: Vec<String>,
        white_furnace: bool,
        grid: &str,
        res: Vec<usize>,
        max_cells: u64,
    ) -> PyResult<(
        Bound<'py, numpy::PyArrayDyn<f32>>,
        Vec<(String, Bound<'py, PyArray1<f64>>)>,
    )> {
        let params = model::resolve(model, material, &sets)?;
        let grid = grid_of(grid, &res)?;
        lobe::table::check_grid(&params, &grid).map_err(|e| errors::from_anyhow("grid", e))?;
        let s = &self.inner;
        let table = job::run(py, s, || {
            s.table(
                Query::one(&params).with_white_furnace(white_furnace),
                &grid,
                max_cells,
            )
        })?;
        let axes = table
            .axes()
            .into_iter()
            .map(|a| (a.name.to_string(), PyArray1::from_vec(py, a.values)))
            .collect();
        let mut shape = table.shape();
        shape.push(3);
        Ok((array(py, table.into_data(), shape)?, axes))
    }

    /// Writes PATH.exr, .npy and .json; returns the count of invalid values kept.
    #[allow(clippy::too_many_arguments)]
    fn write_table(
        &self,
        py: Python<'_>,
        model: &str,
        material: Option<&str>,
        sets: Vec<String>,
        white_furnace: bool,
        grid: &str,
        res: Vec<usize>,
        path: std::path::PathBuf,
        allow_invalid: bool,
    ) -> PyResult<u64> {
        let params = model::resolve(model, material, &sets)?;
        let grid = grid_of(grid, &res)?;
        let s = &self.inner;
        let count = job::run(py, s, || {
            s.write_table(
                Query::one(&params).with_white_furnace(white_furnace),
                grid,
                &path,
                allow_invalid,
                &mut |_, _| {},
            )
        })?;
        Ok(count.invalid)
    }

    /// Directional albedo of each set at each μ: (albedo, error), each (sets, len(mu), 3).
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn albedo<'py>(
        &self,
        py: Python<'py>,
        model: &str,
        material: Option<&str>,
        sets_list: Vec<Vec<String>>,
        white_furnace: bool,
        mu: Vec<f64>,
        phi: f64,
        method: &str,
        samples: Option<usize>,
        seed: u32,
    ) -> PyResult<(
        Bound<'py, numpy::PyArrayDyn<f64>>,
        Bound<'py, numpy::PyArrayDyn<f64>>,
    )> {
        let rows = model::resolve_rows(model, material, &sets_list)?;
        let settings = settings(method, samples, seed, white_furnace)?;
        let points: Vec<(f64, f64)> = mu.iter().map(|&m| (m, phi)).collect();
        let s = &self.inner;
        let per_row = job::run(py, s, || match rows.as_slice() {
            [one] => Ok(vec![s.directional_albedo(one, &settings, &points)?]),
            _ => Ok(s
                .albedo_rows(&rows, &settings, &points, None)?
                .into_iter()
                .map(|(points, _)| points)
                .collect()),
        })?;
        let (mut albedo, mut error) = (Vec::new(), Vec::new());
        for p in per_row.iter().flatten() {
            albedo.extend(p.albedo.to_array());
            error.extend(p.error.to_array());
        }
        let shape = vec![rows.len(), points.len(), 3];
        Ok((array(py, albedo, shape.clone())?, array(py, error, shape)?))
    }

    /// Hemispherical albedo of each set: a dict per set.
    #[allow(clippy::too_many_arguments)]
    fn hemispherical_albedo<'py>(
        &self,
        py: Python<'py>,
        model: &str,
        material: Option<&str>,
        sets_list: Vec<Vec<String>>,
        white_furnace: bool,
        phi: f64,
        method: &str,
        samples: Option<usize>,
        seed: u32,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let rows = model::resolve_rows(model, material, &sets_list)?;
        let settings = settings(method, samples, seed, white_furnace)?;
        let s = &self.inner;
        let hemis = job::run(py, s, || match rows.as_slice() {
            [one] => Ok(vec![s.hemispherical_albedo(one, &settings, phi)?]),
            _ => s
                .albedo_rows(&rows, &settings, &[], Some(phi))?
                .into_iter()
                .map(|(_, h)| {
                    h.ok_or_else(|| lobe::Error::Invalid("no hemispherical albedo".into()))
                })
                .collect(),
        })?;
        hemis
            .iter()
            .map(|h| {
                let d = PyDict::new(py);
                d.set_item("albedo", h.albedo.to_array())?;
                d.set_item("error", h.error.to_array())?;
                d.set_item("delta", h.delta.to_array())?;
                d.set_item("e_avg", h.e_avg.to_array())?;
                d.set_item("e_avg_error", h.e_avg_error.to_array())?;
                d.set_item("directions", h.directions)?;
                d.set_item("samples", h.samples)?;
                d.set_item("stopped_short", h.stopped_short)?;
                Ok(d)
            })
            .collect()
    }
}

/// The catalogue of models, parameters and material presets, as JSON text (`lobe models
/// --json`).
#[pyfunction]
fn models_json() -> PyResult<String> {
    serde_json::to_string(&lobe::catalogue::json())
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}

/// The GPU-vs-f64 parity tolerance at each pair (src/tolerance.rs): (pairs, 3).
#[pyfunction]
fn parity_tolerance<'py>(
    py: Python<'py>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    white_furnace: bool,
    wi: PyReadonlyArray2<'py, f64>,
    wo: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    let p32 = model::resolve(model, material, &sets)?.rounded_to_f32();
    let reference = lobe::Reference::new(&p32, white_furnace);
    let pairs = pairs(&wi, &wo);
    let mut out = Vec::with_capacity(pairs.len() * 3);
    for (wi, wo) in &pairs {
        let c = reference.eval(*wi, *wo);
        let allowed = lobe::tolerance::parity_tolerance(&p32, &reference, *wi, *wo, c);
        out.extend(allowed.to_array());
    }
    array(py, out, vec![pairs.len(), 3])
}

#[pymodule]
fn _lobe(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<PySession>()?;
    m.add_function(wrap_pyfunction!(models_json, m)?)?;
    m.add_function(wrap_pyfunction!(parity_tolerance, m)?)?;
    m.add_function(wrap_pyfunction!(luts::albedo_lut, m)?)?;
    m.add_function(wrap_pyfunction!(luts::engine_lut, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(chi2::chi2, m)?)?;
    m.add_function(wrap_pyfunction!(light::light, m)?)?;
    m.add_function(wrap_pyfunction!(light::light_report, m)?)?;
    m.add_function(wrap_pyfunction!(sample::sample, m)?)?;
    m.add_function(wrap_pyfunction!(sample::pdf, m)?)?;
    m.add_function(wrap_pyfunction!(compare::compare, m)?)?;
    m.add_function(wrap_pyfunction!(plot::plot, m)?)?;
    m.add_function(wrap_pyfunction!(plot::rasterise_svg, m)?)?;
    m.add("GpuError", py.get_type::<GpuError>())?;
    m.add("InvalidValuesError", py.get_type::<InvalidValuesError>())?;
    Ok(())
}
