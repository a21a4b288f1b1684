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
    let map = match (env, env_array) {
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
    };
    let s = &session.get().inner;
    let image = job::run(py, s, || match method {
        lobe::light::Method::SplitSum => s.light_split_sum(&params, &map, size, &mut |_, _| {}),
        _ => s.light(&params, &map, size, &mut |_, _| {}),
    })?;
    let values: Vec<f64> = image.pixels.iter().flatten().copied().collect();
    array(py, values, vec![size as usize, size as usize, 3])
}
