//! Albedo look-up tables (`lobe albedo --lut`, docs/design.md §5): the directional albedo
//! E(μ, p) over view cosines μ and one parameter axis p (roughness, shininess, smoothness, σ, …),
//! and Kulla–Conty's E_avg(p) = 2∫₀¹ E(μ, p) μ dμ, the tables real-time engines load for energy
//! compensation.
//!
//! Axes (both cell-centred, as docs/design.md §4's angles are):
//! - μ_j = (j + ½)/Nμ, j = 0 … Nμ − 1: cells of equal width in μ = cosθo over (0, 1], so no
//!   entry sits at grazing μ = 0 (where E is a limit) and a bilinear lookup at μ reads cell j at
//!   u = μ.
//! - p_k = map(t_k), t_k = (k + ½)/Np, with `map` one of [`Mapping`]: linear lo + (hi − lo)t,
//!   log lo·(hi/lo)^t, square lo + (hi − lo)t² (denser at lo: uniform in √p), or perceptual
//!   (lo + (hi − lo)t)², the engines' convention α = r² with lo and hi given in r (from 0: cell
//!   centres never reach it).
//!
//! E includes the delta lobe (`smooth_layered`, `coupled`); E_avg is taken at the view azimuth
//! φo of the spec (it equals the hemispherical albedo for an isotropic model).
//!
//! Files, written like lobe tables as one [`FileSet`] (a temporary file beside each destination,
//! renamed into place only when all are complete; no partial file on error):
//! - `PATH.exr`: float32 RGB, layer `E` (Nμ wide, x = j; Np tall, y = k) and layer `E_avg`
//!   (1 wide, Np tall), with `lobe.*` header attributes;
//! - `PATH.npy`: E, shape (Np, Nμ, 3); `PATH_avg.npy`: E_avg, shape (Np, 3);
//! - `PATH.json`: the sidecar: model, fixed parameters, axis key, range, mapping, centring,
//!   method, samples, the axes' values and the largest error estimate.

use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::integrate::{albedo_rows, Method, Settings};
use crate::model::{Model, ParamKind, ParamSet, Value};
use crate::output::{FileSet, Pending};
use crate::table::{exr_rgb, exr_text, npy};
use anyhow::{bail, Context, Result};
use exr::prelude::*;
use glam::DVec3;
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};

pub mod engine;
mod estimate;

pub use crate::axis::Mapping;
pub use estimate::{large_error_warning, largest_entry, ErrorEntry};

/// The parameter axis a model's LUT sweeps by default, as the model states it
/// ([`crate::model::ModelInfo::lut_axis`]): (keys set together, lo, hi, mapping).
pub fn default_axis(model: Model) -> (Vec<&'static str>, f64, f64, Mapping) {
    let a = model.info().lut_axis;
    (a.keys.to_vec(), a.lo, a.hi, a.mapping)
}

/// What to tabulate and how.
#[derive(Clone, Debug)]
pub struct LutSpec {
    /// Every parameter but the axis (whose keys are overwritten per row).
    pub params: ParamSet,
    /// Evaluate with every specular Fresnel factor at 1 (docs/design.md §3).
    pub white_furnace: bool,
    /// The parameter keys of the axis, all set to p.
    pub keys: Vec<String>,
    /// Lower end of the parameter axis (the mapping's value at t = 0).
    pub lo: f64,
    /// Upper end of the parameter axis (the mapping's value at t = 1).
    pub hi: f64,
    /// How axis cells map to parameter values.
    pub mapping: Mapping,
    /// Cells along μ (the table's width), at most [`MAX_RES`].
    pub n_mu: usize,
    /// Cells along p (the table's height), at most [`MAX_RES`].
    pub n_p: usize,
    /// The integrator of every entry.
    pub method: Method,
    /// Nodes per view direction (ignored by the reference).
    pub samples: usize,
    /// View azimuth φo in radians (matters for anisotropic models only).
    pub phi: f64,
    /// Whether to compute E_avg(p) too (150 more view directions a row); without it
    /// [`LutSummary::e_avg`] is empty.
    pub with_avg: bool,
    /// Refuse the table, writing nothing, when its largest error estimate exceeds this.
    pub max_error: Option<f64>,
}

/// An error estimate above 2^-10, the spacing of half floats just below 1, makes a table
/// coarser than the 16-bit texture an engine stores it in: `lobe albedo` warns about it.
pub const LARGE_ERROR: f64 = 1.0 / 1024.0;

/// Refuses a result whose largest error estimate `largest` exceeds `limit` (`--max-error`), with
/// a [`BadInput`] tagged `max-error` that names both.
pub fn check_max_error(largest: f64, limit: Option<f64>) -> Result<()> {
    match limit {
        Some(limit) if !(largest <= limit) => Err(BadInput::new(
            "max-error",
            format!(
                "the largest error estimate {largest:.3e} exceeds the limit {limit:.3e}; nothing was written (use more --samples or another --method)"
            ),
        )
        .into()),
        _ => Ok(()),
    }
}

/// Largest table side: a LUT is a lookup table, not a lobe table.
pub const MAX_RES: usize = 4096;

impl LutSpec {
    /// The model's default axis ([`default_axis`]) at 32 × 32 cells (the size of Kulla–Conty's
    /// tables), the default method at its default node count.
    pub fn new(params: ParamSet, white_furnace: bool) -> LutSpec {
        let (keys, lo, hi, mapping) = default_axis(params.model());
        LutSpec {
            params,
            white_furnace,
            keys: keys.into_iter().map(String::from).collect(),
            lo,
            hi,
            mapping,
            n_mu: 32,
            n_p: 32,
            method: Method::Peak,
            samples: Method::Peak.default_samples(),
            phi: 0.0,
            with_avg: true,
            max_error: None,
        }
    }

    /// μ at each cell centre.
    pub fn mus(&self) -> Vec<f64> {
        (0..self.n_mu)
            .map(|j| (j as f64 + 0.5) / self.n_mu as f64)
            .collect()
    }

    /// p at each cell centre.
    pub fn ps(&self) -> Vec<f64> {
        (0..self.n_p)
            .map(|k| {
                let t = (k as f64 + 0.5) / self.n_p as f64;
                self.mapping.apply(self.lo, self.hi, t)
            })
            .collect()
    }

    /// The parameters of row k: the axis keys set to p (validated like any user input).
    pub fn params_at(&self, p: f64) -> Result<ParamSet> {
        let mut set = self.params.clone();
        for key in &self.keys {
            set.set(key, Value::One(p))
                .with_context(|| format!("the LUT axis {key} = {p}"))?;
        }
        Ok(set)
    }

    /// Checks the axis and the sizes, with errors that name the input and its valid range:
    /// [`BadInput`]s tagged `keys`, `range`, `mapping`, `res` or `phi`.
    pub fn validate(&self) -> Result<()> {
        let model = self.params.model();
        let (lo, hi) = (self.lo, self.hi);
        // A refused key, with the keys that would do.
        let keys_error = |problem: String| -> anyhow::Error {
            let keys = numeric_keys(model).join(", ");
            let message = format!(
                "{problem}; the numeric parameters of {} are: {keys}",
                model.name()
            );
            BadInput::new("keys", message).into()
        };
        if self.keys.is_empty() {
            if numeric_keys(model).is_empty() {
                return Err(BadInput::new(
                    "keys",
                    format!(
                        "the model {} has no numeric parameter to put on a LUT axis (a LUT is E(mu, p) over one)",
                        model.name()
                    ),
                )
                .into());
            }
            return Err(keys_error("the LUT axis needs a parameter key".into()));
        }
        // The keys first: a choice's range (0, 0) would otherwise be blamed on a range the user
        // never gave.
        for key in &self.keys {
            match model
                .params()
                .iter()
                .find(|s| s.key == key)
                .map(|s| &s.kind)
            {
                None => {
                    let problem = format!(
                        "LUT axis key '{key}': {} has no such parameter",
                        model.name()
                    );
                    return Err(keys_error(problem));
                }
                Some(ParamKind::Choice(_)) => {
                    return Err(keys_error(format!(
                        "LUT axis key '{key}' is a choice, not a number"
                    )));
                }
                Some(_) => {}
            }
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(BadInput::new(
                "range",
                format!("the LUT range LO,HI = {lo},{hi}: expected LO < HI"),
            )
            .into());
        }
        if self.mapping == Mapping::Log && lo <= 0.0 {
            return Err(BadInput::new(
                "mapping",
                format!("the LUT range LO,HI = {lo},{hi} with the log mapping: LO must be > 0"),
            )
            .into());
        }
        if self.mapping == Mapping::Perceptual && lo < 0.0 {
            return Err(BadInput::new(
                "mapping",
                format!(
                    "the LUT range LO,HI = {lo},{hi} with the perceptual mapping (p = r^2): LO must be >= 0"
                ),
            )
            .into());
        }
        for key in &self.keys {
            let Some(spec) = model.params().iter().find(|s| s.key == key) else {
                continue;
            };
            // The ends may sit on the boundary of the key's range (alpha from 0): only the
            // cell centres are evaluated, and they must be valid values.
            let ends = [0.0, 1.0].map(|t| self.mapping.apply(lo, hi, t));
            let n = self.n_p.max(1) as f64;
            let inner = [0.5 / n, 1.0 - 0.5 / n].map(|t| self.mapping.apply(lo, hi, t));
            let outside = ends.iter().any(|&v| !(v >= spec.min && v <= spec.max))
                || inner.iter().any(|&v| spec.check(v).is_err());
            if outside {
                return Err(BadInput::new(
                    "range",
                    format!(
                        "the LUT range LO,HI = {lo},{hi} ({}): {key} must lie in {} (the range's ends may touch its bounds, the cell centres may not)",
                        self.mapping.formula(),
                        spec.range_text()
                    ),
                )
                .into());
            }
        }
        if let Some(m) = self.max_error {
            if !(m >= 0.0) {
                return Err(BadInput::new(
                    "max-error",
                    format!("the error limit {m}: expected a number >= 0"),
                )
                .into());
            }
        }
        for (name, n) in [("NMU", self.n_mu), ("NP", self.n_p)] {
            if n == 0 || n > MAX_RES {
                return Err(BadInput::new(
                    "res",
                    format!("the LUT size {name} = {n} must lie in [1, {MAX_RES}]"),
                )
                .into());
            }
        }
        if !self.phi.is_finite() {
            return Err(BadInput::new(
                "phi",
                format!(
                    "the view azimuth phi = {} rad: expected a finite angle",
                    self.phi
                ),
            )
            .into());
        }
        Ok(())
    }
}

fn numeric_keys(model: Model) -> Vec<&'static str> {
    model
        .params()
        .iter()
        .filter(|s| !matches!(s.kind, ParamKind::Choice(_)))
        .map(|s| s.key)
        .collect()
}

/// A computed table.
#[derive(Clone, Debug)]
pub struct LutSummary {
    /// μ at each column's cell centre.
    pub mus: Vec<f64>,
    /// The parameter value of each row.
    pub ps: Vec<f64>,
    /// E(μ_j, p_k) at index k·Nμ + j, delta lobe included.
    pub e: Vec<DVec3>,
    /// E_avg(p_k).
    pub e_avg: Vec<DVec3>,
    /// The largest error estimate of any entry (E or E_avg), absolute.
    pub max_error: f64,
    /// The error estimate of each E entry (largest channel), indexed as `e`.
    pub e_error: Vec<f64>,
    /// The error estimate of each E_avg entry (largest channel), indexed as `e_avg`.
    pub e_avg_error: Vec<f64>,
    /// Wall-clock time of the computation, seconds.
    pub seconds: f64,
    /// The files written (empty for [`compute`]).
    pub files: Vec<PathBuf>,
}

impl LutSummary {
    /// The entry with the largest error estimate (None for an empty table).
    pub fn largest_error(&self) -> Option<ErrorEntry> {
        largest_entry(&self.mus, &self.ps, &self.e_error, &self.e_avg_error)
    }

    /// (smallest, largest) channel of E over the table.
    pub fn e_range(&self) -> (f64, f64) {
        channel_range(&self.e)
    }

    /// (smallest, largest) channel of E_avg over the table.
    pub fn e_avg_range(&self) -> (f64, f64) {
        channel_range(&self.e_avg)
    }

    /// What `lobe albedo --lut --format json` prints: the files, the axis, the sizes, the
    /// method, the ranges of E and E_avg, the largest error estimate and the time.
    pub fn to_json(&self, spec: &LutSpec) -> serde_json::Value {
        let files: Vec<String> = self.files.iter().map(|p| p.display().to_string()).collect();
        let ((e_lo, e_hi), (a_lo, a_hi)) = (self.e_range(), self.e_avg_range());
        json!({
            "files": files,
            "model": spec.params.model().name(),
            "keys": spec.keys,
            "range": [spec.lo, spec.hi],
            "mapping": spec.mapping.name(),
            "res": [spec.n_mu, spec.n_p],
            "method": spec.method.name(),
            "samples": spec.samples,
            "e_range": [e_lo, e_hi],
            "e_avg_range": [a_lo, a_hi],
            "max_error_estimate": self.max_error,
            "seconds": self.seconds,
        })
    }

    /// The same for people: one line on the table, then `wrote PATH` per file.
    pub fn write_text(&self, spec: &LutSpec, out: &mut dyn Write) -> std::io::Result<()> {
        let ((e_lo, e_hi), (a_lo, a_hi)) = (self.e_range(), self.e_avg_range());
        writeln!(
            out,
            "{} LUT over mu ({} cells) x {} in [{}, {}] ({} cells, {}): E in [{e_lo:.6}, {e_hi:.6}], E_avg in [{a_lo:.6}, {a_hi:.6}], largest error estimate {:.2e}; {} {} nodes per direction; {:.2} s",
            spec.params.model().name(),
            spec.n_mu,
            spec.keys.join(","),
            spec.lo,
            spec.hi,
            spec.n_p,
            spec.mapping.name(),
            self.max_error,
            spec.method.name(),
            spec.samples,
            self.seconds
        )?;
        for f in &self.files {
            writeln!(out, "wrote {}", f.display())?;
        }
        Ok(())
    }
}

fn channel_range(v: &[DVec3]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(c.min_element()), hi.max(c.max_element()))
        })
}

/// Rows of a LUT computed together: enough to share each direction's nodes across many rows and
/// fill a dispatch, few enough for progress to move on a large table.
const LUT_ROW_BATCH: usize = 32;

/// An RGB error estimate's largest channel, NaN if any channel is (`max_element` would drop it).
fn worst_channel(error: glam::DVec3) -> f64 {
    error
        .to_array()
        .into_iter()
        .fold(0.0, crate::finite::max_or_nan)
}

/// E(μ, p) and E_avg(p) on `eval`; `progress` receives (rows done, rows).
pub fn compute(
    eval: &Evaluator,
    spec: &LutSpec,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<LutSummary> {
    spec.validate()?;
    let start = std::time::Instant::now();
    let (mus, ps) = (spec.mus(), spec.ps());
    let settings = Settings {
        method: spec.method,
        samples: spec.samples,
        white_furnace: spec.white_furnace,
    };
    let points: Vec<(f64, f64)> = mus.iter().map(|&m| (m, spec.phi)).collect();
    let mut e = Vec::with_capacity(mus.len() * ps.len());
    let mut e_avg = Vec::with_capacity(ps.len());
    let (mut e_error, mut e_avg_error) = (Vec::new(), Vec::new());
    // Rows in batches: each batch shares its directions' nodes and its dispatches
    // (integrate::albedo_rows); progress and Ctrl-C act between batches.
    let mut done = 0;
    for batch in ps.chunks(LUT_ROW_BATCH) {
        eval.check_cancelled()?;
        let rows: Vec<ParamSet> = batch
            .iter()
            .map(|&p| spec.params_at(p))
            .collect::<Result<_>>()?;
        // E_avg only where the table has it (an engine DFG table does not).
        let phi = spec.with_avg.then_some(spec.phi);
        for (dir, h) in albedo_rows(eval, &rows, &settings, &points, phi)? {
            for pt in dir {
                e_error.push(worst_channel(pt.error));
                e.push(pt.albedo);
            }
            if let Some(h) = h {
                e_avg_error.push(worst_channel(h.e_avg_error));
                e_avg.push(h.e_avg);
            }
        }
        done += batch.len();
        progress(done as u64, ps.len() as u64);
    }
    let max_error = largest_entry(&mus, &ps, &e_error, &e_avg_error).map_or(0.0, |w| w.error);
    Ok(LutSummary {
        mus,
        ps,
        e,
        e_avg,
        max_error,
        e_error,
        e_avg_error,
        seconds: start.elapsed().as_secs_f64(),
        files: Vec::new(),
    })
}

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
/// `.json` sidecar (see the module's documentation). `progress` receives (rows done, rows).
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

/// Writes `values` as an f32 `.npy` of `shape` to `file` (the pending file of `dest`).
fn write_npy(file: &Pending, shape: &[usize], values: &[f32], dest: &Path) -> Result<()> {
    let mut w = file.writer();
    w.write_all(&npy::header(shape))
        .and_then(|_| npy::write_f32(&mut w, values))
        .map_err(|e| crate::output::encoder_error(dest, "npy", e))?;
    w.finish()
}

fn file_name(p: &Path) -> String {
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
    engine::exr_channels_layer(name, width, height, &["R", "G", "B"], &flat)
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
