//! A LUT's files: the `.exr`, the two `.npy` files and the `.json` sidecar, written as one set
//! and read back (the layout is in [`crate::lut`]'s documentation).

use super::{check_max_error, compute, LutSpec, LutSummary};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::output::{file_name, npy, sibling, ArtifactSet, ExrLayer, Provenance};
use crate::table::exr_rgb;
use anyhow::{bail, Context, Result};
use exr::prelude::*;
use glam::DVec3;
use serde_json::json;
use std::path::{Path, PathBuf};

/// The suffix of the E_avg array's `.npy` (`PATH_avg.npy`).
pub(super) const AVG: &str = "_avg";

/// Refuses a LUT path that does not end in `.exr` (a [`BadInput`] tagged `path`).
pub(super) fn check_path(exr_path: &Path) -> Result<()> {
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
    Ok(())
}

/// The three files beside `exr_path` (which must end in `.exr`): (npy of E, npy of E_avg, json).
pub fn sibling_paths(exr_path: &Path) -> Result<(PathBuf, PathBuf, PathBuf)> {
    check_path(exr_path)?;
    Ok((
        sibling(exr_path, "", "npy"),
        sibling(exr_path, AVG, "npy"),
        sibling(exr_path, "", "json"),
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
    check_path(exr_path)?;
    // Checked and created before anything is computed.
    let files = ArtifactSet::create(crate::output::LUT_SET, exr_path, &["", AVG], &[])?;
    let paths = [
        files.exr_path(),
        files.npy_path(0),
        files.npy_path(1),
        files.json_path(),
    ];
    let paths: Vec<PathBuf> = paths.into_iter().map(Path::to_path_buf).collect();
    let mut lut = compute(eval, spec, progress)?;
    check_max_error(lut.max_error, spec.max_error)?;
    files.npy(0, &[spec.n_p, spec.n_mu, 3], &rgb(&lut.e))?;
    files.npy(1, &[spec.n_p, 3], &rgb(&lut.e_avg))?;
    write_exr(&files, spec, &lut)?;
    let provenance = Provenance {
        model: spec.params.model().name(),
        parameters: fixed_parameters(spec),
        white_furnace: spec.white_furnace,
        backend: &eval.name(),
    };
    let fields = sidecar_fields(spec, &lut, &files);
    files.commit(&provenance, fields)?;
    lut.files = paths;
    Ok(lut)
}

/// RGB values as interleaved float32.
fn rgb(v: &[DVec3]) -> Vec<f32> {
    v.iter()
        .flat_map(|c| [c.x as f32, c.y as f32, c.z as f32])
        .collect()
}

/// The parameters the table keeps fixed: every entry but the axis keys.
fn fixed_parameters(spec: &LutSpec) -> serde_json::Value {
    let mut fixed = spec.params.to_json();
    if let Some(map) = fixed.as_object_mut() {
        for k in &spec.keys {
            map.remove(k);
        }
    }
    fixed
}

/// The sidecar's own fields (the [`Provenance`] fields come with every set).
fn sidecar_fields(spec: &LutSpec, lut: &LutSummary, files: &ArtifactSet) -> serde_json::Value {
    json!({
        "kind": "albedo look-up table",
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
        "seed": spec.method.sampler().map(|_| spec.seed),
        "max_error_estimate": lut.max_error,
        "seconds": lut.seconds,
        "files": {
            "exr": file_name(files.exr_path()),
            "exr_layout": "layer E: width = mu count (x = j), height = parameter count (y = k); layer E_avg: width 1, height = parameter count; channels R, G, B float32",
            "npy": file_name(files.npy_path(0)),
            "npy_shape": [spec.n_p, spec.n_mu, 3],
            "npy_avg": file_name(files.npy_path(1)),
            "npy_avg_shape": [spec.n_p, 3],
            "dtype": "float32",
        },
    })
}

/// Layer `E` (Nμ × Np, with the `lobe.*` attributes) and layer `E_avg` (1 × Np), RGB.
fn write_exr(files: &ArtifactSet, spec: &LutSpec, lut: &LutSummary) -> Result<()> {
    let attributes = [
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
    let (e, avg) = (rgb(&lut.e), rgb(&lut.e_avg));
    let channels = &["R", "G", "B"];
    files.exr(&[
        ExrLayer {
            name: "E",
            width: spec.n_mu,
            height: spec.n_p,
            channels,
            values: &e,
            attributes: &attributes,
        },
        ExrLayer {
            name: "E_avg",
            width: 1,
            height: spec.n_p,
            channels,
            values: &avg,
            attributes: &[],
        },
    ])
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
