//! A model's sampler: draws for one ωo and the density at direction pairs, as `lobe sample`
//! draws them (`Session::sample`, `Session::pdf`).

use crate::{array, job, model, PySession};
use lobe::glam::DVec3;
use lobe::Query;
use numpy::{PyArrayDyn, PyReadonlyArray2};
use pyo3::prelude::*;

/// The draws' arrays: wi (n, 3), weight (n, 3), pdf (n,), delta (n,) of bool.
type SampleArrays<'py> = (
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<bool>>,
);

/// n draws of the sampler for `wo` from the stream `seed`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, model, material, sets, white_furnace, wo, n, seed))]
pub fn sample<'py>(
    py: Python<'py>,
    session: &Bound<'py, PySession>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    white_furnace: bool,
    wo: [f64; 3],
    n: usize,
    seed: u32,
) -> PyResult<SampleArrays<'py>> {
    let params = model::resolve(model, material, &sets)?;
    let s = &session.get().inner;
    let wo = DVec3::from_array(wo);
    let drawn = job::run(py, s, || {
        s.sample(
            Query::one(&params).with_white_furnace(white_furnace),
            wo,
            n,
            seed,
        )
    })?;
    let n = drawn.len();
    Ok((
        array(py, drawn.wi.concat(), vec![n, 3])?,
        array(py, drawn.weight.concat(), vec![n, 3])?,
        array(py, drawn.pdf, vec![n])?,
        array(py, drawn.delta, vec![n])?,
    ))
}

/// The sampler's density at each (wi, wo) pair of two (N, 3) arrays: (N,).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, model, material, sets, white_furnace, wi, wo))]
pub fn pdf<'py>(
    py: Python<'py>,
    session: &Bound<'py, PySession>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    white_furnace: bool,
    wi: PyReadonlyArray2<'py, f64>,
    wo: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let params = model::resolve(model, material, &sets)?;
    let pairs = crate::pairs(&wi, &wo);
    let s = &session.get().inner;
    let values = job::run(py, s, || {
        s.pdf(
            Query::one(&params).with_white_furnace(white_furnace),
            &pairs,
        )
    })?;
    let n = values.len();
    array(py, values, vec![n])
}
