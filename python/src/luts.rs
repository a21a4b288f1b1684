//! Look-up tables in memory: a model's albedo LUT E(μ, p) with E_avg(p), and the tables real-time
//! engines load (DFG, Kulla–Conty, EON).

use crate::errors::{from_anyhow, invalid};
use crate::{array, job, model, settings, PySession};
use lobe::lut::engine::{EngineKind, EngineSpec};
use lobe::lut::{LutSpec, Mapping};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A LUT request refused by [`LutSpec::validate`], named by the keyword argument it came from.
fn lut_error(e: anyhow::Error) -> PyErr {
    let argument = match lobe::input::option_of(&e) {
        Some("keys") => "param",
        Some("range") => "range",
        Some("mapping") => "mapping",
        Some("res") => "res",
        Some("phi") => "phi",
        _ => "lut",
    };
    from_anyhow(argument, e)
}

/// The albedo LUT as a dict of arrays: `e` (Np, Nμ, 3), `e_avg` (Np, 3), `mu` (Nμ), `p` (Np),
/// `e_error` (Np, Nμ), `e_avg_error` (Np), `max_error`, `keys`, `mapping`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, model, material, sets, white_furnace, param, range, res, mapping, method, samples, seed, phi, with_avg))]
pub fn albedo_lut<'py>(
    py: Python<'py>,
    session: &Bound<'py, PySession>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    white_furnace: bool,
    param: Option<Vec<String>>,
    range: Option<(f64, f64)>,
    res: (usize, usize),
    mapping: Option<&str>,
    method: &str,
    samples: Option<usize>,
    seed: u32,
    phi: f64,
    with_avg: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let params = model::resolve(model, material, &sets)?;
    let s = settings(method, samples, seed, white_furnace)?;
    let mut spec = LutSpec::new(params);
    spec.white_furnace = white_furnace;
    if let Some(keys) = param {
        spec.keys = keys;
    }
    if let Some((lo, hi)) = range {
        (spec.lo, spec.hi) = (lo, hi);
    }
    if let Some(m) = mapping {
        spec.mapping = Mapping::from_name(m).map_err(|e| from_anyhow("mapping", e))?;
    }
    (spec.n_mu, spec.n_p) = res;
    (spec.method, spec.samples, spec.seed) = (s.method, s.samples, s.seed);
    (spec.phi, spec.with_avg) = (phi, with_avg);
    spec.validate().map_err(lut_error)?;
    let session = &session.get().inner;
    let lut = job::run(py, session, || session.albedo_lut(&spec, &mut |_, _| {}))?;
    let (n_p, n_mu) = (lut.ps.len(), lut.mus.len());
    let d = PyDict::new(py);
    let flat = |v: &[lobe::glam::DVec3]| v.iter().flat_map(|c| c.to_array()).collect::<Vec<_>>();
    d.set_item("e", array(py, flat(&lut.e), vec![n_p, n_mu, 3])?)?;
    d.set_item(
        "e_avg",
        array(py, flat(&lut.e_avg), vec![lut.e_avg.len(), 3])?,
    )?;
    d.set_item("mu", array(py, lut.mus.clone(), vec![n_mu])?)?;
    d.set_item("p", array(py, lut.ps.clone(), vec![n_p])?)?;
    d.set_item("e_error", array(py, lut.e_error.clone(), vec![n_p, n_mu])?)?;
    let n_avg = lut.e_avg_error.len();
    d.set_item(
        "e_avg_error",
        array(py, lut.e_avg_error.clone(), vec![n_avg])?,
    )?;
    d.set_item("max_error", lut.max_error)?;
    d.set_item("keys", spec.keys.clone())?;
    d.set_item("mapping", spec.mapping.name())?;
    Ok(d)
}

/// An engine's table as a dict of arrays: `values` (Np, Nμ, channels), `avg` (Np) where the
/// kind has one, `mu`, `p` (the model's parameter), `axis` (before the mapping), `error`,
/// `avg_error`, `max_error`, `channels` (what each channel holds).
#[pyfunction]
#[pyo3(signature = (session, kind, sets, res, method, samples, seed))]
pub fn engine_lut<'py>(
    py: Python<'py>,
    session: &Bound<'py, PySession>,
    kind: &str,
    sets: Vec<String>,
    res: (usize, usize),
    method: &str,
    samples: Option<usize>,
    seed: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let Some(kind) = EngineKind::ALL.into_iter().find(|k| k.name() == kind) else {
        let names: Vec<&str> = EngineKind::ALL.iter().map(|k| k.name()).collect();
        return Err(invalid(
            "kind",
            format!(
                "'{kind}' is not an engine table; the tables are: {}",
                names.join(", ")
            ),
        ));
    };
    let mut spec = EngineSpec::new(kind, &sets).map_err(|e| from_anyhow("params", e))?;
    let s = settings(method, samples, seed, false)?;
    (spec.lut.n_mu, spec.lut.n_p) = res;
    (spec.lut.method, spec.lut.samples, spec.lut.seed) = (s.method, s.samples, s.seed);
    spec.lut.validate().map_err(lut_error)?;
    let session = &session.get().inner;
    let t = job::run(py, session, || session.engine_lut(&spec, &mut |_, _| {}))?;
    let (n_p, n_mu) = (t.ps.len(), t.mus.len());
    let d = PyDict::new(py);
    d.set_item(
        "values",
        array(py, t.values.clone(), vec![n_p, n_mu, t.channels])?,
    )?;
    d.set_item("avg", array(py, t.avg.clone(), vec![t.avg.len()])?)?;
    d.set_item("mu", array(py, t.mus.clone(), vec![n_mu])?)?;
    d.set_item("p", array(py, t.ps.clone(), vec![n_p])?)?;
    d.set_item("axis", array(py, t.axis.clone(), vec![n_p])?)?;
    d.set_item("error", array(py, t.error.clone(), vec![n_p, n_mu])?)?;
    d.set_item(
        "avg_error",
        array(py, t.avg_error.clone(), vec![t.avg_error.len()])?,
    )?;
    d.set_item("max_error", t.max_error)?;
    d.set_item("channels", kind.meaning().to_vec())?;
    Ok(d)
}
