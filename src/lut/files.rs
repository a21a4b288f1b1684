//! A LUT's files: the `.exr`, the two `.npy` files and the `.json` sidecar, written as one set
//! and read back (the layout is in [`crate::lut`]'s documentation).

use super::{check_max_error, compute, LutSpec, LutSummary};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::output::{FileSet, Pending};
use crate::table::{exr_rgb, exr_text, npy};
use anyhow::{bail, Context, Result};
use exr::prelude::*;
use glam::DVec3;
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The three files beside `exr_path` (which must end in `.exr`): (npy of E, npy of E_avg, json).
pub fn sibling_paths(exr_path: &Path) -> Result<(PathBuf, PathBuf, PathBuf)> {
    if exr_path.extension().and_then(|e| e.to_str()) != Some("exr") {
        return Err(BadInput::new(
            "path",
            format!(
                "the LUT path {} must end in .exr (the .npy and .json files go beside it)",
                exr_path.display()
            ),
        )
        .into());
    }
    let stem = exr_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok((
        exr_path.with_extension("npy"),
        exr_path.with_file_name(format!("{stem}_avg.npy")),
        exr_path.with_extension("json"),
    ))
}

/// Computes the LUT on `eval` and writes `exr_path` (`.exr`), its two `.npy` files and its
/// `.json` sidecar (see [`crate::lut`]'s documentation). `progress` receives (rows done, rows).
pub fn write(
    eval: &Evaluator,
    spec: &LutSpec,
    exr_path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<LutSummary> {
    let (npy_path, avg_path, json_path) = sibling_paths(exr_path)?;
    // Checked and created before anything is computed; the data first, the sidecar last.
    let members = [npy_path.as_path(), &avg_path, exr_path, &json_path];
    let set = FileSet::new_set(crate::output::LUT_SET, &members, 3)?;
    let (npy_tmp, avg_tmp, exr_tmp, json_tmp) = (&set[0], &set[1], &set[2], &set[3]);
    let mut lut = compute(eval, spec, progress)?;
    check_max_error(lut.max_error, spec.max_error)?;
    let flat = |v: &[DVec3]| -> Vec<f32> {
        v.iter()
            .flat_map(|c| [c.x as f32, c.y as f32, c.z as f32])
            .collect()
    };
    write_npy(npy_tmp, &[spec.n_p, spec.n_mu, 3], &flat(&lut.e), &npy_path)?;
    write_npy(avg_tmp, &[spec.n_p, 3], &flat(&lut.e_avg), &avg_path)?;
    write_exr(exr_tmp, spec, &lut)?;
    let sidecar = sidecar_json(spec, &lut, eval, exr_path, &npy_path, &avg_path);
    let mut w = json_tmp.writer();
    w.write_all((serde_json::to_string_pretty(&sidecar)? + "\n").as_bytes())
        .map_err(|e| crate::output::encoder_error(&json_path, "JSON", e))?;
    w.finish()?;
    set.commit()?;
    lut.files = vec![exr_path.to_path_buf(), npy_path, avg_path, json_path];
    Ok(lut)
}

/// One EXR layer of float32 channels named `names`, each `width × height` values taken from
/// `values` (interleaved, `names.len()` per texel).
pub(super) fn exr_channels_layer(
    name: &str,
    width: usize,
    height: usize,
    names: &[&str],
    values: &[f32],
) -> Layer<AnyChannels<FlatSamples>> {
    let n = names.len();
    let channels = names
        .iter()
        .enumerate()
        .map(|(c, &ch)| {
            AnyChannel::new(
                ch,
                FlatSamples::F32(values.iter().skip(c).step_by(n).copied().collect()),
            )
        })
        .collect();
    Layer::new(
        (width, height),
        LayerAttributes::named(name),
        crate::output::EXR_ENCODING,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    )
}

/// Writes `values` as an f32 `.npy` of `shape` to `file` (the pending file of `dest`).
pub(super) fn write_npy(
    file: &Pending,
    shape: &[usize],
    values: &[f32],
    dest: &Path,
) -> Result<()> {
    let mut w = file.writer();
    w.write_all(&npy::header(shape))
        .and_then(|_| npy::write_f32(&mut w, values))
        .map_err(|e| crate::output::encoder_error(dest, "npy", e))?;
    w.finish()
}

/// The last component of `p`, as the sidecars name their files.
pub(super) fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn sidecar_json(
    spec: &LutSpec,
    lut: &LutSummary,
    eval: &Evaluator,
    exr_path: &Path,
    npy_path: &Path,
    avg_path: &Path,
) -> serde_json::Value {
    // The fixed parameters: every entry but the axis keys.
    let mut fixed = spec.params.to_json();
    if let Some(map) = fixed.as_object_mut() {
        for k in &spec.keys {
            map.remove(k);
        }
    }
    json!({
        "kind": "albedo look-up table",
        "model": spec.params.model().name(),
        "parameters": fixed,
        "white_furnace": spec.white_furnace,
        "values": "E(mu, p): directional albedo, delta lobe included; E_avg(p) = 2 * integral of E(mu, p) mu dmu over [0, 1]; linear RGB, dimensionless",
        "mu_axis": {
            "name": "mu = cos(theta_o)",
            "count": spec.n_mu,
            "centring": "cell-centred: mu_j = (j + 0.5) / count, j = 0 .. count - 1",
            "values": lut.mus,
        },
        "parameter_axis": {
            "keys": spec.keys,
            "lo": spec.lo,
            "hi": spec.hi,
            "count": spec.n_p,
            "mapping": spec.mapping.name(),
            "formula": spec.mapping.formula(),
            "centring": "cell-centred: t_k = (k + 0.5) / count, k = 0 .. count - 1, p_k = formula(t_k)",
            "values": lut.ps,
        },
        "phi_o_deg": spec.phi.to_degrees(),
        "method": spec.method.name(),
        "samples": spec.samples,
        "max_error_estimate": lut.max_error,
        "backend": eval.name(),
        "seconds": lut.seconds,
        "files": {
            "exr": file_name(exr_path),
            "exr_layout": "layer E: width = mu count (x = j), height = parameter count (y = k); layer E_avg: width 1, height = parameter count; channels R, G, B float32",
            "npy": file_name(npy_path),
            "npy_shape": [spec.n_p, spec.n_mu, 3],
            "npy_avg": file_name(avg_path),
            "npy_avg_shape": [spec.n_p, 3],
            "dtype": "float32",
        },
    })
}

fn exr_layer(
    name: &str,
    width: usize,
    height: usize,
    values: &[DVec3],
) -> Layer<AnyChannels<FlatSamples>> {
    let flat: Vec<f32> = values
        .iter()
        .flat_map(|v| [v.x as f32, v.y as f32, v.z as f32])
        .collect();
    exr_channels_layer(name, width, height, &["R", "G", "B"], &flat)
}

fn write_exr(out: &Pending, spec: &LutSpec, lut: &LutSummary) -> Result<()> {
    let mut e = exr_layer("E", spec.n_mu, spec.n_p, &lut.e);
    let text = |s: String| exr_text(&s);
    let attrs = [
        ("lobe.model", spec.params.model().name().to_string()),
        ("lobe.parameters", spec.params.to_text()),
        ("lobe.white_furnace", spec.white_furnace.to_string()),
        ("lobe.lut_keys", spec.keys.join(",")),
        ("lobe.lut_range", format!("{},{}", spec.lo, spec.hi)),
        ("lobe.lut_mapping", spec.mapping.formula().to_string()),
        (
            "lobe.lut_centring",
            "mu_j = (j + 0.5)/width; t_k = (k + 0.5)/height".to_string(),
        ),
        ("lobe.method", spec.method.name().to_string()),
    ];
    for (k, v) in attrs {
        e.attributes.other.insert(Text::new_or_panic(k), text(v));
    }
    let avg = exr_layer("E_avg", 1, spec.n_p, &lut.e_avg);
    let bounds = IntegerBounds::from_dimensions((spec.n_mu, spec.n_p));
    let image = Image::empty(ImageAttributes::new(bounds))
        .with_layer(e)
        .with_layer(avg);
    crate::output::write_exr(out, |w| image.write().to_buffered(w))
}

/// A LUT read back: E as (Np, Nμ) rows of RGB and E_avg per row, from either file kind.
#[derive(Clone, Debug, PartialEq)]
pub struct LutData {
    /// Cells along μ (the table's width).
    pub n_mu: usize,
    /// Cells along p (the table's height).
    pub n_p: usize,
    /// E(μ_j, p_k) at index k·Nμ + j.
    pub e: Vec<[f32; 3]>,
    /// E_avg(p_k), one per row.
    pub e_avg: Vec<[f32; 3]>,
}

fn triples(v: &[f32]) -> Vec<[f32; 3]> {
    v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Reads the two `.npy` files of the LUT written at `exr_path`.
pub fn read_npy(exr_path: &Path) -> Result<LutData> {
    let (npy_path, avg_path, _) = sibling_paths(exr_path)?;
    let (shape, e) = npy::read(&npy_path)?;
    let (avg_shape, avg) = npy::read(&avg_path)?;
    if shape.len() != 3 || shape[2] != 3 || avg_shape != [shape[0], 3] {
        bail!(
            "{} and {}: shapes {shape:?} and {avg_shape:?} are not (Np, Nmu, 3) and (Np, 3)",
            npy_path.display(),
            avg_path.display()
        );
    }
    Ok(LutData {
        n_mu: shape[1],
        n_p: shape[0],
        e: triples(&e),
        e_avg: triples(&avg),
    })
}

/// Reads the `.exr` of a LUT (layers `E` and `E_avg`).
pub fn read_exr(exr_path: &Path) -> Result<LutData> {
    let image = read_all_flat_layers_from_file(exr_path)
        .with_context(|| format!("reading {}", exr_path.display()))?;
    let layer = |name: &str| {
        image
            .layer_data
            .iter()
            .find(|l| l.attributes.layer_name == Some(Text::new_or_panic(name)))
            .with_context(|| format!("{}: no layer '{name}'", exr_path.display()))
    };
    let rgb = |l: &Layer<AnyChannels<FlatSamples>>| exr_rgb(l, exr_path);
    let (e, avg) = (layer("E")?, layer("E_avg")?);
    if avg.size.0 != 1 || avg.size.1 != e.size.1 {
        bail!(
            "{}: layer E_avg is {}x{}, expected 1x{}",
            exr_path.display(),
            avg.size.0,
            avg.size.1,
            e.size.1
        );
    }
    Ok(LutData {
        n_mu: e.size.0,
        n_p: e.size.1,
        e: rgb(e)?,
        e_avg: rgb(avg)?,
    })
}
