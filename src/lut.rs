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
//! Files, written like lobe tables as one [`ArtifactSet`](crate::output::ArtifactSet) (a temporary file beside each
//! destination, renamed into place only when all are complete; no partial file on error):
//! - `PATH.exr`: float32 RGB, layer `E` (Nμ wide, x = j; Np tall, y = k) and layer `E_avg`
//!   (1 wide, Np tall), with `lobe.*` header attributes;
//! - `PATH.npy`: E, shape (Np, Nμ, 3); `PATH_avg.npy`: E_avg, shape (Np, 3);
//! - `PATH.json`: the sidecar: model, fixed parameters, axis key, range, mapping, centring,
//!   method, samples, the axes' values and the largest error estimate.

use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::integrate::{albedo_rows, Method, Settings};
use crate::model::{Model, ParamKind, ParamSet, Value};
use anyhow::{Context, Result};
use glam::DVec3;
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;

pub mod engine;
mod estimate;
mod files;

pub use crate::axis::Mapping;
pub use estimate::{largest_entry, ErrorEntry};
use files::{check_path, AVG};
pub use files::{read_exr, read_npy, sibling_paths, write, LutData};

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
    /// The Monte Carlo methods' stream ([`Settings::seed`]; the rules ignore it).
    pub seed: u32,
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
                "the largest error estimate {largest:.3e} exceeds the limit {limit:.3e}; nothing was written (use more samples or another method)"
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
    /// tables), the default method at its default node count, the model's Fresnel factors (set
    /// `white_furnace` to replace them by 1).
    pub fn new(params: ParamSet) -> LutSpec {
        let (keys, lo, hi, mapping) = default_axis(params.model());
        LutSpec {
            params,
            white_furnace: false,
            keys: keys.into_iter().map(String::from).collect(),
            lo,
            hi,
            mapping,
            n_mu: 32,
            n_p: 32,
            method: Method::Peak,
            samples: Method::Peak.default_samples(),
            seed: crate::integrate::DEFAULT_SEED,
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
        self.check_keys()?;
        self.check_range()?;
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

    /// The axis keys: at least one, each a numeric parameter of the model.
    fn check_keys(&self) -> Result<()> {
        let model = self.params.model();
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
        Ok(())
    }

    /// The range LO,HI: ordered, fit for the mapping, and its cell centres valid values of
    /// every key.
    fn check_range(&self) -> Result<()> {
        let model = self.params.model();
        let (lo, hi) = (self.lo, self.hi);
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
            "seed": spec.method.sampler().map(|_| spec.seed),
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
        seed: spec.seed,
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
