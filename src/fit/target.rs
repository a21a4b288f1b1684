//! What a fit is measured against: a target's samples, each a direction pair with the target's
//! value there, the pair's cosθi and its solid-angle weight ([`crate::loss::Bin`]).
//!
//! Every kind of target becomes the same list:
//!
//! - a model (built-in, a `.brdf` file, or a MERL file's lookup) is evaluated at the centres of
//!   MERL's 90 × 90 × 180 half/difference bins ([`crate::merl::bin_centre`]);
//! - a MERL `.binary` file gives its own values at those same bins, without the lookup, and
//!   without the bins it marks missing (a negative stored value in any channel);
//! - a lobe table (`.npy` with its JSON sidecar, as `lobe table` writes them) gives its cells at
//!   the cell centres of the grid the sidecar names; a cell whose value is negative or not finite
//!   counts as missing.
//!
//! On the MERL bins every pair is turned about the normal by φh = 2π·v(k), v the base-2 radical
//! inverse of the bin index k: an isotropic model sees the same values as at φh = 0, and an
//! anisotropic one is sampled over every azimuth. Pairs with cosθi ≤ 0 or cosθo ≤ 0 (below the
//! horizon, where f = 0 by convention) are not samples.
//!
//! A bin's weight is its share of the (ωi, ωo) measure. In half/difference angles
//! dωi dωo = 4 cosθd dωh dωd (Rusinkiewicz 1998) = 4 cosθd sinθd sinθh dθh dφh dθd dφd; MERL's θh
//! axis is θh = (π/2)u² with u uniform over the bins, so dθh ∝ u du and a MERL bin weighs
//! cosθd sinθd sinθh u (constant factors dropped: only ratios count). A `full` or `isotropic`
//! table's cell weighs sinθi sinθo, a `halfdiff` table's cosθd sinθd sinθh.
//!
//! Where more valid bins remain than the fit's sample size, an evenly spaced subset in storage
//! order is kept: sample j is valid bin ⌊(j + ½)·N/M⌋ of N, for j < M. It is deterministic (the
//! same target always gives the same sample) and spread over every axis.

use crate::eval::Evaluator;
use crate::grid::{half_diff_to_pair, Grid};
use crate::input::BadInput;
use crate::loss::Bin;
use crate::merl;
use crate::model::ParamSet;
use anyhow::{bail, Context, Result};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// What to fit against.
#[derive(Clone, Debug)]
pub enum Target {
    /// A model with its parameters (built-in, a loaded `.brdf` file or a MERL model).
    Model(ParamSet),
    /// A MERL `.binary` file, read bin by bin.
    Merl(PathBuf),
    /// A lobe table: the `.npy` (or any sibling of it: `.json`, `.exr`) with its JSON sidecar.
    Table(PathBuf),
}

impl Target {
    /// The target a path or model name stands for: `.binary` is a MERL file, `.npy` / `.json` a
    /// lobe table; anything else is for the caller to resolve as a model.
    pub fn file_kind(spec: &str) -> Option<Target> {
        let path = Path::new(spec.trim());
        match path.extension().and_then(|e| e.to_str()) {
            Some("binary") => Some(Target::Merl(path.to_path_buf())),
            Some("npy") | Some("json") => Some(Target::Table(path.to_path_buf())),
            _ => None,
        }
    }

    /// A short description for reports: the model's name and parameters, or the file.
    pub fn describe(&self) -> String {
        match self {
            Target::Model(p) => format!("{} {}", p.model().name(), p.to_text()),
            Target::Merl(p) => format!("MERL file {}", p.display()),
            Target::Table(p) => format!("lobe table {}", p.display()),
        }
    }
}

/// A target as the fit sees it: direction pairs, the target's values, and the bins' cosθi and
/// weights (module docs).
#[derive(Clone, Debug, Default)]
pub struct Samples {
    /// (ωi, ωo) of each sample.
    pub pairs: Vec<(DVec3, DVec3)>,
    /// The target's f at each pair, 1/sr, RGB.
    pub values: Vec<[f64; 3]>,
    /// cosθi and the weight of each sample.
    pub bins: Vec<Bin>,
    /// Bins of the target's grid, valid or not.
    pub grid_bins: usize,
    /// Bins without data (missing values).
    pub missing: usize,
    /// Bins above the horizon with data, before the sample was taken.
    pub valid: usize,
    /// The grid the samples come from, in words.
    pub grid: String,
}

/// One candidate bin before sampling.
struct Candidate {
    pair: (DVec3, DVec3),
    weight: f64,
    /// Index of the bin in its target's storage, for looking its value up.
    index: usize,
}

/// Base-2 radical inverse of `k`: 0.b0 b1 b2… from k's bits, in [0, 1).
pub fn radical_inverse_2(k: usize) -> f64 {
    (k as u64).reverse_bits() as f64 / 2f64.powi(64)
}

/// The pair of MERL bin (`h`, `d`, `p`), turned by φh (module docs), and the bin's weight.
fn merl_bin_pair(h: usize, d: usize, p: usize) -> ((DVec3, DVec3), f64) {
    let [theta_h, theta_d, phi_d] = merl::bin_centre(h, d, p);
    let k = merl::bin(h, d, p);
    let phi_h = std::f64::consts::TAU * radical_inverse_2(k);
    let u = (h as f64 + 0.5) / merl::DIMS[0] as f64;
    let weight = theta_d.cos() * theta_d.sin() * theta_h.sin() * u;
    (half_diff_to_pair(theta_h, phi_h, theta_d, phi_d), weight)
}

fn above_horizon(pair: &(DVec3, DVec3)) -> bool {
    pair.0.z > 0.0 && pair.1.z > 0.0
}

/// Every MERL bin above the horizon, in storage order.
fn merl_candidates(keep: impl Fn(usize) -> bool) -> Vec<Candidate> {
    let mut out = Vec::new();
    for h in 0..merl::DIMS[0] {
        for d in 0..merl::DIMS[1] {
            for p in 0..merl::DIMS[2] {
                let index = merl::bin(h, d, p);
                let (pair, weight) = merl_bin_pair(h, d, p);
                if above_horizon(&pair) && weight > 0.0 && keep(index) {
                    out.push(Candidate {
                        pair,
                        weight,
                        index,
                    });
                }
            }
        }
    }
    out
}

/// The evenly spaced subset of `n` items that keeps `m` (all of them when `m` is 0 or ≥ `n`).
fn spread(n: usize, m: usize) -> Vec<usize> {
    if m == 0 || m >= n {
        return (0..n).collect();
    }
    (0..m)
        .map(|j| (((j as f64 + 0.5) * n as f64 / m as f64) as usize).min(n - 1))
        .collect()
}

/// The samples of `target`, at most `max_bins` of them (0: every valid bin). A model target is
/// evaluated on `eval`. Refuses a target without any valid bin.
pub fn samples(target: &Target, eval: &Evaluator, max_bins: usize) -> Result<Samples> {
    let s = match target {
        Target::Model(params) => model_samples(params, eval, max_bins)?,
        Target::Merl(path) => merl_samples(path, max_bins)?,
        Target::Table(path) => table_samples(path, max_bins)?,
    };
    if s.pairs.is_empty() {
        return Err(BadInput::new(
            "target",
            format!(
                "target {}: none of its {} bins has data above the horizon ({} missing); a fit needs at least one",
                target.describe(),
                s.grid_bins,
                s.missing
            ),
        )
        .into());
    }
    Ok(s)
}

fn merl_grid_text() -> String {
    format!(
        "MERL half/difference bins {}x{}x{} (theta_h warped as MERL's sqrt index)",
        merl::DIMS[0],
        merl::DIMS[1],
        merl::DIMS[2]
    )
}

fn model_samples(params: &ParamSet, eval: &Evaluator, max_bins: usize) -> Result<Samples> {
    let all = merl_candidates(|_| true);
    let valid = all.len();
    let picked: Vec<&Candidate> = spread(valid, max_bins)
        .into_iter()
        .map(|k| &all[k])
        .collect();
    let pairs: Vec<(DVec3, DVec3)> = picked.iter().map(|c| c.pair).collect();
    let values = eval
        .eval_pairs(params, &pairs)
        .with_context(|| format!("evaluating the target {}", params.model().name()))?;
    // A model's value is data everywhere (eval_pairs refuses NaN, ±Inf and negative values).
    let mut s = Samples {
        grid_bins: merl::BINS,
        grid: merl_grid_text(),
        ..Samples::default()
    };
    for (c, v) in picked.iter().zip(values) {
        if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
            s.pairs.push(c.pair);
            s.values.push(v);
            s.bins.push(Bin {
                cos_i: c.pair.0.z,
                weight: c.weight,
            });
        } else {
            s.missing += 1;
        }
    }
    s.valid = valid - s.missing;
    Ok(s)
}

fn merl_samples(path: &Path, max_bins: usize) -> Result<Samples> {
    let table = merl::read(path)?;
    // The reader keeps missing values as 0; which bins they were is in the raw stored values.
    let bytes = crate::input::read_regular(path, "MERL file", merl::FILE_BYTES as u64)?;
    let stored = |c: usize, k: usize| {
        let at = merl::HEADER_BYTES + 8 * (c * merl::BINS + k);
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[at..at + 8]);
        f64::from_le_bytes(b)
    };
    let has_data = |k: usize| (0..3).all(|c| stored(c, k) >= 0.0);
    let missing = (0..merl::BINS).filter(|&k| !has_data(k)).count();
    let all = merl_candidates(has_data);
    let valid = all.len();
    let mut s = Samples {
        grid_bins: merl::BINS,
        missing,
        valid,
        grid: merl_grid_text(),
        ..Samples::default()
    };
    for k in spread(valid, max_bins) {
        let c = &all[k];
        s.pairs.push(c.pair);
        s.values
            .push([0, 1, 2].map(|ch| table.values[ch * merl::BINS + c.index]));
        s.bins.push(Bin {
            cos_i: c.pair.0.z,
            weight: c.weight,
        });
    }
    Ok(s)
}

/// The grid a table's JSON sidecar names: its `grid` kind and the sizes of its angle axes.
pub fn sidecar_grid(sidecar: &serde_json::Value) -> Result<Grid, String> {
    let kind = sidecar
        .get("grid")
        .and_then(|g| g.as_str())
        .ok_or("it has no \"grid\" entry (full, isotropic or halfdiff)")?;
    let axes = sidecar
        .get("axes")
        .and_then(|a| a.as_array())
        .ok_or("it has no \"axes\" list")?;
    let sizes: Vec<String> = axes
        .iter()
        .filter(|a| a.get("name").and_then(|n| n.as_str()) != Some("rgb"))
        .map(|a| {
            a.get("size")
                .and_then(|s| s.as_u64())
                .map(|s| s.to_string())
                .ok_or("an axis without a \"size\"")
        })
        .collect::<Result<_, _>>()?;
    Grid::parse(kind, &sizes.join(","))
}

/// A table cell's weight (module docs) from the grid's angles.
fn cell_weight(grid: &Grid, angles: [f64; 4]) -> f64 {
    match grid {
        Grid::Full { .. } | Grid::Isotropic { .. } => angles[0].sin() * angles[2].sin(),
        Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => {
            angles[2].cos() * angles[2].sin() * angles[0].sin()
        }
    }
}

fn table_samples(path: &Path, max_bins: usize) -> Result<Samples> {
    let npy = path.with_extension("npy");
    let json = path.with_extension("json");
    let refuse = |problem: String| BadInput::new("target", problem);
    let text = crate::input::read_regular(&json, "JSON sidecar", crate::table::MAX_SIDECAR_BYTES)
        .and_then(|b| Ok(String::from_utf8(b)?))
        .map_err(|e| {
            refuse(format!(
                "table target {}: cannot read its JSON sidecar {}: {e:#}",
                path.display(),
                json.display()
            ))
        })?;
    let sidecar: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        refuse(format!(
            "table target {}: its sidecar is not JSON: {e}",
            json.display()
        ))
    })?;
    let grid = sidecar_grid(&sidecar).map_err(|e| {
        refuse(format!(
            "table target {}: the sidecar does not name a lobe grid: {e}",
            json.display()
        ))
    })?;
    let (shape, values) = crate::table::npy::read(&npy)
        .with_context(|| format!("reading the table {}", npy.display()))?;
    let mut expected = grid.shape();
    expected.push(3);
    if shape != expected {
        bail!(refuse(format!(
            "table target {}: its shape {shape:?} is not the shape {expected:?} of the grid its sidecar names",
            npy.display()
        )));
    }
    let cells = values.len() / 3;
    // A lobe table has no missing-data mark: a NaN, ±Inf or negative cell is an invalid value,
    // refused as every job refuses one (docs/design.md §2.1), not passed over as missing.
    let mut invalid = crate::finite::InvalidCount::default();
    invalid.add_f32(0, &values[..3 * cells], |cell| grid.pair_at(cell));
    invalid
        .refuse(&format!("table {}", npy.display()), "fitting")
        .map_err(|e| BadInput::new("target", e.to_string()))?;
    let mut all = Vec::new();
    for cell in 0..cells {
        let idx = grid.index(cell as u64);
        let pair = grid.pair(&idx);
        let weight = cell_weight(&grid, grid.angles(&idx));
        if above_horizon(&pair) && weight > 0.0 {
            all.push(Candidate {
                pair,
                weight,
                index: cell,
            });
        }
    }
    let valid = all.len();
    let mut s = Samples {
        grid_bins: cells,
        valid,
        grid: format!(
            "{} grid {:?} from {}",
            grid.name(),
            grid.shape(),
            json.display()
        ),
        ..Samples::default()
    };
    for k in spread(valid, max_bins) {
        let c = &all[k];
        let v = &values[3 * c.index..3 * c.index + 3];
        s.pairs.push(c.pair);
        s.values.push([v[0] as f64, v[1] as f64, v[2] as f64]);
        s.bins.push(Bin {
            cos_i: c.pair.0.z,
            weight: c.weight,
        });
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spread_is_even_and_keeps_everything_when_asked() {
        assert_eq!(spread(10, 0), (0..10).collect::<Vec<_>>());
        assert_eq!(spread(10, 20).len(), 10);
        assert_eq!(spread(10, 5), vec![1, 3, 5, 7, 9]);
    }

    #[test]
    fn radical_inverse_is_the_mirrored_bits() {
        assert_eq!(radical_inverse_2(0), 0.0);
        assert_eq!(radical_inverse_2(1), 0.5);
        assert_eq!(radical_inverse_2(2), 0.25);
        assert_eq!(radical_inverse_2(3), 0.75);
    }

    #[test]
    fn merl_bins_turned_by_phi_h_keep_their_half_difference_angles() {
        // The pair of a bin, read back by MERL's own angle construction, lands in the same bin.
        for (h, d, p) in [(10, 20, 30), (45, 5, 170), (80, 60, 2)] {
            let (pair, w) = merl_bin_pair(h, d, p);
            assert!(w > 0.0);
            let [th, _, td, pd] = crate::grid::pair_to_half_diff(pair.0, pair.1);
            let [ch, cd, cp] = merl::bin_centre(h, d, p);
            let pd = if pd < 0.0 {
                pd + std::f64::consts::PI
            } else {
                pd
            };
            assert!(
                (th - ch).abs() < 1e-9 && (td - cd).abs() < 1e-9,
                "{h} {d} {p}"
            );
            assert!((pd - cp).abs() < 1e-9, "{h} {d} {p}: {pd} vs {cp}");
        }
    }
}
