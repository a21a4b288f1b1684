//! A model's sampler as a user calls it: n draws for one ωo ([`draw`]), the density at many
//! direction pairs ([`pdf`]), and the draws as files
//! ([`crate::Session::write_samples`]: `PATH.npy` with `PATH.json`),
//! what `lobe sample`, [`crate::Session::sample`] and Python's `Session.sample` give
//! (docs/design.md §13).
//!
//! Draw i is [`crate::random::draw_numbers`]`(seed, i, 0)` turned into ωi by the backend's
//! sampler ([`crate::Backend::draws`]): the same seed draws the same directions on every door,
//! bit for bit on one backend, and within f32 rounding between the GPU and the f64 reference.
//! Group 0 is also the stream of the sampling test's first view direction (`lobe chi2 --seed`).

use crate::backend::{DrawRange, Query};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::model::{ParamSet, Reference};
use crate::output::{encoder_error, npy, FileSet, SAMPLES_SET};
use anyhow::{bail, Result};
use glam::DVec3;
use serde_json::{json, Value};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The most draws one request makes: 2²², about 4.2 million. The draws are held in memory
/// (57 bytes each, 240 MB at the bound; 64 bytes each in the file); for more, make several
/// requests with other seeds. `lobe chi2` counts 2³⁰ and more without holding them.
pub const MAX_DRAWS: usize = 1 << 22;

/// The most direction pairs one [`pdf`] request evaluates: 2²⁶ (1.5 GiB of input pairs).
pub const MAX_PAIRS: usize = 1 << 26;

/// ωo and ωi may differ from unit length by this much, as Python's `UNIT_LENGTH_TOLERANCE`:
/// directions drawn in f32 (the GPU's) or written out with 7 digits are unit only to about
/// 1e-7, and anything further off is a mistake, not rounding.
pub const UNIT_TOLERANCE: f64 = 1e-5;

/// Draws per backend call: bounds the per-draw records in memory (~100 bytes each) and is how
/// often progress is heard and the cancellation token looked at.
const CHUNK: usize = 1 << 20;

/// The columns of the draws' array, in order (`PATH.npy`, shape (n, 8), float64).
pub const COLUMNS: [&str; 8] = [
    "wi_x", "wi_y", "wi_z", "weight_r", "weight_g", "weight_b", "pdf", "delta",
];

/// n draws of a model's sampler for one ωo (docs/design.md §13), in draw order.
#[derive(Clone, Debug, PartialEq)]
pub struct Samples {
    /// ωo, the unit direction to the viewer in the local frame.
    pub wo: [f64; 3],
    /// The stream's seed: draw i used `random::draw_numbers(seed, i, 0)`.
    pub seed: u32,
    /// The directions drawn, ωi towards the light (a lost draw keeps its ωi below the horizon).
    pub wi: Vec<[f64; 3]>,
    /// f(ωi, ωo) cos θi / pdf per channel; for a delta draw, the spike's albedo over its
    /// probability; 0 for a lost draw.
    pub weight: Vec<[f64; 3]>,
    /// The density over the solid angle of ωi; for a delta draw, the probability of choosing
    /// the spike; 0 for a lost draw.
    pub pdf: Vec<f64>,
    /// Whether each draw is the mirror spike of a layered model (no density over solid angle).
    pub delta: Vec<bool>,
    /// The backend that drew them, as [`Evaluator::name`] says.
    pub backend: String,
}

impl Samples {
    /// How many draws.
    pub fn len(&self) -> usize {
        self.pdf.len()
    }

    /// Whether there are none (a request refuses n = 0, so never for a drawn set).
    pub fn is_empty(&self) -> bool {
        self.pdf.is_empty()
    }

    /// Draws that left the hemisphere: not delta, pdf 0 (their ωi is kept, their weight is 0).
    pub fn lost(&self) -> usize {
        (self.pdf.iter().zip(&self.delta))
            .filter(|(&p, &d)| !d && p == 0.0)
            .count()
    }

    /// Delta draws (the mirror spike).
    pub fn deltas(&self) -> usize {
        self.delta.iter().filter(|&&d| d).count()
    }

    /// The draws as rows of [`COLUMNS`]: n × 8 values, row-major (delta as 1 or 0).
    pub fn rows(&self) -> Vec<f64> {
        self.rows_in(0..self.len())
    }

    /// Rows `range` of [`Samples::rows`].
    pub fn rows_in(&self, range: std::ops::Range<usize>) -> Vec<f64> {
        let mut out = Vec::with_capacity(range.len() * COLUMNS.len());
        for k in range {
            out.extend(self.wi[k]);
            out.extend(self.weight[k]);
            out.push(self.pdf[k]);
            out.push(if self.delta[k] { 1.0 } else { 0.0 });
        }
        out
    }
}

/// Refuses `wo` unless it is a finite unit vector (within [`UNIT_TOLERANCE`]) above the
/// horizon, naming the option `option`.
pub fn check_wo(wo: DVec3, option: &'static str) -> Result<(), BadInput> {
    if !wo.is_finite() || (wo.length() - 1.0).abs() > UNIT_TOLERANCE {
        return Err(BadInput::new(
            option,
            format!(
                "ωo = ({}, {}, {}) is not a unit vector (length within {UNIT_TOLERANCE:e} of 1)",
                wo.x, wo.y, wo.z
            ),
        ));
    }
    if wo.z <= 0.0 {
        return Err(BadInput::new(
            option,
            format!(
                "ωo = ({}, {}, {}) is not above the horizon: θo must be in [0, 90) degrees \
                 (ωo.z > 0)",
                wo.x, wo.y, wo.z
            ),
        ));
    }
    Ok(())
}

/// Refuses a draw count outside 1 ..= [`MAX_DRAWS`] (option `"n"`).
pub fn check_count(n: usize) -> Result<(), BadInput> {
    if n == 0 || n > MAX_DRAWS {
        return Err(BadInput::new(
            "n",
            format!("{n} draws: expected from 1 to {MAX_DRAWS} (2^22) draws per request"),
        ));
    }
    Ok(())
}

/// n draws of the sampler of the query's first set for `wo` from the stream `seed` (draw i
/// from `random::draw_numbers(seed, i, 0)`), on `eval`'s backend, in chunks between which
/// `progress(done, n)` is called and the evaluator's cancellation token is looked at.
pub fn draw(
    eval: &Evaluator,
    query: Query,
    wo: DVec3,
    n: usize,
    seed: u32,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Samples> {
    check_wo(wo, "wo")?;
    check_count(n)?;
    let mut out = Samples {
        wo: wo.to_array(),
        seed,
        wi: Vec::with_capacity(n),
        weight: Vec::with_capacity(n),
        pdf: Vec::with_capacity(n),
        delta: Vec::with_capacity(n),
        backend: eval.name(),
    };
    let mut done = 0;
    while done < n {
        eval.check_cancelled()?;
        let count = CHUNK.min(n - done);
        let range = DrawRange {
            first: done as u64,
            ..DrawRange::new(seed, count)
        };
        for d in eval.draws(query, wo, range)? {
            out.wi.push(d.wi);
            out.weight.push(d.weight);
            out.pdf.push(d.pdf);
            out.delta.push(d.delta);
        }
        done += count;
        progress(done, n);
    }
    Ok(out)
}

/// The density of `params`' sampler (with every specular Fresnel factor at 1 under
/// `white_furnace`, which some mixtures' component probabilities depend on) at each (ωi, ωo)
/// pair, over the solid angle of ωi: `Reference::pdf` in f64, whatever the backend (docs/design.md
/// §13: the density is the reference a sampler is checked against, and a few million pairs take
/// a second on the CPU). 0 where either direction is at or below the horizon; delta lobes have
/// no density and are not included. Directions must be finite unit vectors.
pub fn pdf(params: &ParamSet, white_furnace: bool, pairs: &[(DVec3, DVec3)]) -> Result<Vec<f64>> {
    use rayon::prelude::*;
    check_pairs(pairs)?;
    let r = Reference::new(params, white_furnace);
    Ok(pairs.par_iter().map(|(wi, wo)| r.pdf(*wi, *wo)).collect())
}

/// Refuses more than [`MAX_PAIRS`] pairs, or a direction that is not a unit vector, naming it.
pub fn check_pairs(pairs: &[(DVec3, DVec3)]) -> Result<()> {
    if pairs.len() > MAX_PAIRS {
        bail!(BadInput::new(
            "wi",
            format!(
                "{} direction pairs: at most {MAX_PAIRS} (2^26) per request",
                pairs.len()
            ),
        ));
    }
    let unit = |v: DVec3| v.is_finite() && (v.length() - 1.0).abs() <= UNIT_TOLERANCE;
    for (k, (wi, wo)) in pairs.iter().enumerate() {
        for (option, v) in [("wi", wi), ("wo", wo)] {
            if !unit(*v) {
                bail!(BadInput::new(
                    option,
                    format!(
                        "pair {k}: {option} = ({}, {}, {}) is not a unit vector (length within \
                         {UNIT_TOLERANCE:e} of 1)",
                        v.x, v.y, v.z
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Where [`crate::Session::write_samples`] puts the draws of `-o PATH.npy`: the array and,
/// beside it, `PATH.json`.
/// Refuses a path that does not end in `.npy` (option `"path"`).
pub fn paths(npy_path: &Path) -> Result<(PathBuf, PathBuf), BadInput> {
    if npy_path.extension().and_then(|e| e.to_str()) != Some("npy") {
        return Err(BadInput::new(
            "path",
            format!(
                "{}: the draws are written as a NumPy array; give a path ending in .npy (its \
                 sidecar PATH.json is written beside it)",
                npy_path.display()
            ),
        ));
    }
    Ok((npy_path.to_path_buf(), npy_path.with_extension("json")))
}

/// The files of one set of draws, checked and staged before any draw is made.
pub struct SampleFiles {
    set: FileSet,
    npy: PathBuf,
    json: PathBuf,
}

impl SampleFiles {
    /// Stages `PATH.npy` and `PATH.json` (see [`paths`]); fails, naming the file, before any
    /// file is made when a destination cannot be written or belongs to another set.
    pub fn create(npy_path: &Path) -> Result<SampleFiles> {
        let (npy, json) = paths(npy_path)?;
        let set = FileSet::new_set(SAMPLES_SET, &[&npy, &json], 1)?;
        Ok(SampleFiles { set, npy, json })
    }

    /// Writes the draws and their sidecar and commits both, or neither. `params` and
    /// `white_furnace` describe what was drawn.
    pub fn commit(self, samples: &Samples, params: &ParamSet, white_furnace: bool) -> Result<()> {
        let mut w = self.set[0].writer();
        let shape = [samples.len(), COLUMNS.len()];
        w.write_all(&npy::header_f64(&shape))
            .map_err(|e| encoder_error(&self.npy, "npy", e))?;
        // A chunk of rows at a time: the file's bytes are never all in memory beside the draws.
        for first in (0..samples.len()).step_by(1 << 16) {
            let rows = samples.rows_in(first..(first + (1 << 16)).min(samples.len()));
            npy::write_f64(&mut w, &rows).map_err(|e| encoder_error(&self.npy, "npy", e))?;
        }
        w.finish()?;
        let text = serde_json::to_string_pretty(&sidecar(
            samples,
            params,
            white_furnace,
            &crate::output::file_name(&self.npy),
        ))? + "\n";
        let mut w = self.set[1].writer();
        w.write_all(text.as_bytes())
            .map_err(|e| encoder_error(&self.json, "JSON", e))?;
        w.finish()?;
        self.set.commit()
    }
}

/// The sidecar of a set of draws: what was drawn, how, and how to read the array.
pub fn sidecar(samples: &Samples, params: &ParamSet, white_furnace: bool, npy_name: &str) -> Value {
    let [x, y, z] = samples.wo;
    json!({
        "model": params.model().name(),
        "parameters": params.to_json(),
        "white_furnace": white_furnace,
        "backend": samples.backend,
        "wo": samples.wo,
        "theta_o_deg": z.clamp(-1.0, 1.0).acos().to_degrees(),
        "phi_o_deg": y.atan2(x).to_degrees(),
        "seed": samples.seed,
        "draws": samples.len(),
        "lost": samples.lost(),
        "delta": samples.deltas(),
        "npy": npy_name,
        "dtype": "float64",
        "shape": [samples.len(), COLUMNS.len()],
        "columns": COLUMNS,
        "frame": "local shading frame, normal +z; wi towards the light, wo towards the viewer (docs/design.md §2)",
        "values": "row i is draw i: wi (unit vector), weight = f(wi, wo) cos(theta_i) / pdf per linear RGB channel, pdf over the solid angle of wi in 1/sr, delta 1 or 0",
        "random_numbers": "draw i takes (uc, u1, u2) = random::draw_numbers(seed, i, 0): pcg4d of (i low word, i high word, seed, 0), dimensions 0, 1, 2 as k / 2^24 (docs/design.md §14); the same seed gives the same draws",
        "delta_samples": "delta = 1: the mirror spike of a layered model; wi is the mirror direction of wo, pdf is the probability of choosing the spike (not a density), weight is the spike's albedo over that probability; leave such rows out of any histogram over directions",
        "lost_samples": "a draw that leaves the upper hemisphere keeps its wi (wi_z <= 0) with weight 0 and pdf 0 (delta 0); their share approaches 1 minus the integral of pdf over the hemisphere",
    })
}
