//! The sphere under an environment map, as `lobe light` computes it (the exact sum or the split
//! sum).

use crate::errors::{from_anyhow, invalid};
use crate::{array, job, model, PySession};
use lobe::light::maps;
use numpy::PyReadonlyArray3;
use pyo3::prelude::*;

/// The (size, size, 3) image of `model` lit by `env` (a built-in map's name or a map file's
/// path) or by `env_array`, an (H, W, 3) float32 lat-long map (row 0 at +y); `method` is
/// "exact" or "split_sum".
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, model, material, sets, env, env_array, size, method))]
pub fn light<'py>(
    py: Python<'py>,
    session: &Bound<'_, PySession>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    env: Option<String>,
    env_array: Option<PyReadonlyArray3<'py, f32>>,
    size: u32,
    method: &str,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    let params = model::resolve(model, material, &sets)?;
    let method = match lobe::light::Method::from_name(method) {
        Ok(m @ (lobe::light::Method::Exact | lobe::light::Method::SplitSum)) => m,
        _ => {
            return Err(invalid(
                "method",
                format!("method {method:?}: expected \"exact\" or \"split_sum\""),
            ))
        }
    };
    if method == lobe::light::Method::SplitSum {
        lobe::light::split::lobe_of(&params, false).map_err(|e| invalid("method", e))?;
    }
    lobe::light::check_image_size(size).map_err(|e| invalid("size", e))?;
    let map = env_map(env, env_array)?;
    let s = &session.get().inner;
    let image = job::run(py, s, || match method {
        lobe::light::Method::SplitSum => s.light_split_sum(&params, &map, size, &mut |_, _| {}),
        _ => s.light(&params, &map, size, &mut |_, _| {}),
    })?;
    let values: Vec<f64> = image.pixels.iter().flatten().copied().collect();
    array(py, values, vec![size as usize, size as usize, 3])
}

/// The map a call names: `env_array` (an (H, W, 3) float32 lat-long map, row 0 at +y) or `env`
/// (a built-in map's name or a file's path).
fn env_map(
    env: Option<String>,
    env_array: Option<PyReadonlyArray3<'_, f32>>,
) -> PyResult<lobe::backend::light::EnvMap> {
    Ok(match (env, env_array) {
        (_, Some(a)) => {
            let a = a.as_array();
            let (h, w) = (a.shape()[0], a.shape()[1]);
            let side = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
            lobe::backend::light::check_size(side(w), side(h)).map_err(|e| invalid("env", e))?;
            let texels = a.rows().into_iter().map(|t| [t[0], t[1], t[2]]).collect();
            lobe::backend::light::EnvMap::new(w as u32, h as u32, texels)
                .map_err(|e| invalid("env", e))?
        }
        (Some(name), None) => {
            if maps::Builtin::from_name(&name).is_none() && !std::path::Path::new(&name).exists() {
                return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!(
                    "env: no such file: {name} (nor a built-in map: sky, studio, constant)"
                )));
            }
            maps::resolve(&name).map_err(|e| from_anyhow("env", e))?
        }
        (None, None) => return Err(invalid("env", "give a map name, a path or an array")),
    })
}

/// The split sum's error over `steps` values of the model's roughness (`lobe light --report`)
/// as JSON text: the swept parameter and one object per value with the CSV's columns.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, model, material, sets, white_furnace, env, env_array, size, steps))]
pub fn light_report<'py>(
    py: Python<'py>,
    session: &Bound<'_, PySession>,
    model: &str,
    material: Option<&str>,
    sets: Vec<String>,
    white_furnace: bool,
    env: Option<String>,
    env_array: Option<PyReadonlyArray3<'py, f32>>,
    size: u32,
    steps: usize,
) -> PyResult<String> {
    let params = model::resolve(model, material, &sets)?;
    lobe::light::check_image_size(size).map_err(|e| invalid("size", e))?;
    lobe::light::report::check_steps(steps).map_err(|e| invalid("steps", e))?;
    lobe::light::report::RoughnessAxis::of(&params, white_furnace)
        .map_err(|e| invalid("model", e))?;
    let map = env_map(env, env_array)?;
    let s = &session.get().inner;
    let report = job::run(py, s, || {
        s.light_report(&params, white_furnace, &map, size, steps, &mut |_, _| {})
    })?;
    let rows: Vec<serde_json::Value> = report
        .rows
        .iter()
        .map(|r| {
            serde_json::json!({
                "value": r.value,
                "alpha": r.alpha,
                "rms": r.figures.rms,
                "max_relative": r.figures.max_relative,
                "max_relative_row": r.figures.at.0,
                "max_relative_column": r.figures.at.1,
                "max_relative_n_dot_v": r.figures.mu,
                "mean_relative": r.mean_relative,
                "mean_relative_grazing": r.band_mean_relative[0],
                "mean_relative_middle": r.band_mean_relative[1],
                "mean_relative_normal": r.band_mean_relative[2],
                "lobe_resolved": r.lobe_resolved,
            })
        })
        .collect();
    Ok(serde_json::json!({ "parameter": report.axis.key, "rows": rows }).to_string())
}
