//! Two BRDFs on the same bins: what `lobe compare A B` reports.
//!
//! Both models are evaluated at the centre of every bin of one grid ([`Bins`]): a lobe-table grid
//! ([`Grid`]) or MERL's own half/difference bins. Each bin carries its solid-angle measure in
//! (ωi, ωo) (the Jacobian of its coordinates; cell widths are equal along each axis and cancel):
//!
//! - `full`, `isotropic`: sinθi · sinθo;
//! - `halfdiff`: dωi dωo = 4 cosθd dωh dωd, so sinθh · sinθd · cosθd (Rusinkiewicz 1998);
//! - MERL's bins: θh = (π/2)u² with u uniform, so dθh ∝ u and the weight is u · sinθh · sinθd ·
//!   cosθd.
//!
//! Bins with ωi or ωo at or below the horizon (both models are 0 there by the one-sided rule)
//! and bins where a MERL file has no data (a negative stored value, see [`Side::missing`]) are
//! left out. The distances are those of [`crate::loss`], with A the reference: the floored
//! relative difference (RMS, and the largest with its bin and channel), the cosine-weighted log
//! error, and relative L2 ‖B − A‖/‖A‖. The albedo difference E_A(μ) − E_B(μ) at chosen μ and
//! the hemispherical Ē_A − Ē_B come from the albedo integrators ([`crate::integrate`]), delta
//! lobes included.

use crate::backend::Query;
use crate::eval::Evaluator;
use crate::grid::{angles_deg, half_diff_to_pair, pair_to_half_diff, theta_cell, Grid};
use crate::input::BadInput;
use crate::integrate::{self, Settings};
use crate::loss::{self, Bin, ChannelErrors};
use crate::merl::{self, lookup::merl_coordinates};
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;
use serde_json::json;
use std::sync::Arc;

/// The bins both models are evaluated at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bins {
    /// The cells of a lobe-table grid.
    Grid(Grid),
    /// MERL's 90 × 90 × 180 half/difference bins, at their centres ([`merl::bin_centre`]).
    Merl,
}

impl Bins {
    /// How many bins, below the horizon included.
    pub fn cells(&self) -> u64 {
        match self {
            Bins::Grid(g) => g.cells().unwrap_or(u64::MAX),
            Bins::Merl => merl::BINS as u64,
        }
    }

    /// `isotropic 45,45,90` or `merl 90,90,180 (MERL's bins)`.
    pub fn describe(&self) -> String {
        match self {
            Bins::Grid(g) => {
                let shape: Vec<String> = g.shape().iter().map(|n| n.to_string()).collect();
                format!("{} {}", g.name(), shape.join(","))
            }
            Bins::Merl => "merl 90,90,180 (MERL's half/difference bins)".to_string(),
        }
    }

    /// (ωi, ωo) of bin `cell` and its weight (module docs).
    pub fn bin(&self, cell: u64) -> ((DVec3, DVec3), f64) {
        match self {
            Bins::Grid(g) => {
                let idx = g.index(cell);
                let pair = g.pair(&idx);
                let weight = match g {
                    Grid::Full {
                        n_theta_i,
                        n_theta_o,
                        ..
                    } => {
                        theta_cell(idx[0], *n_theta_i).sin() * theta_cell(idx[2], *n_theta_o).sin()
                    }
                    Grid::Isotropic {
                        n_theta_i,
                        n_theta_o,
                        ..
                    } => {
                        theta_cell(idx[0], *n_theta_i).sin() * theta_cell(idx[1], *n_theta_o).sin()
                    }
                    Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => {
                        let a = g.angles(&idx);
                        a[0].sin() * a[2].sin() * a[2].cos()
                    }
                };
                (pair, weight)
            }
            Bins::Merl => {
                let k = cell as usize;
                let (h, d, p) = (
                    k / (merl::DIMS[1] * merl::DIMS[2]),
                    (k / merl::DIMS[2]) % merl::DIMS[1],
                    k % merl::DIMS[2],
                );
                let [th, td, pd] = merl::bin_centre(h, d, p);
                let u = (h as f64 + 0.5) / merl::DIMS[0] as f64;
                (
                    half_diff_to_pair(th, 0.0, td, pd),
                    u * th.sin() * td.sin() * td.cos(),
                )
            }
        }
    }

    /// Refuses bins `params` cannot be evaluated on (an anisotropic set on bins that hold only
    /// the isotropic half of the angles, a grid too large); `side` names the model in the
    /// message. The refusal is a [`BadInput`] tagged `grid` or `cells`.
    pub fn check(&self, params: &ParamSet, side: &str) -> Result<()> {
        let grid = match self {
            Bins::Grid(g) => *g,
            Bins::Merl => merl::write::GRID,
        };
        crate::table::check_grid(params, &grid).map_err(|e| {
            let option = crate::input::option_of(&e).unwrap_or("grid");
            let tag = if option == "cells" { "cells" } else { "grid" };
            anyhow::Error::from(BadInput::new(tag, format!("{side}: {e:#}")))
        })?;
        Ok(())
    }
}

/// One side of a comparison: a parameter set and, for a MERL file, which of its bins hold no
/// data.
#[derive(Clone, Debug)]
pub struct Side {
    /// The model and its parameters.
    pub params: ParamSet,
    /// For a MERL file with missing data: one flag per MERL bin ([`merl::bin`]), true where a
    /// channel's stored value is negative. A compared bin whose pair falls in such a bin is left
    /// out.
    pub missing: Option<Arc<Vec<bool>>>,
}

impl Side {
    /// A side without missing data.
    pub fn new(params: ParamSet) -> Side {
        Side {
            params,
            missing: None,
        }
    }

    fn is_missing(&self, wi: DVec3, wo: DVec3) -> bool {
        let Some(mask) = &self.missing else {
            return false;
        };
        let [th, _, td, pd] = pair_to_half_diff(wi, wo);
        let u = merl_coordinates(th, td, pd);
        let axis = |x: f64, n: usize| (x.max(0.0) as usize).min(n - 1);
        mask[merl::bin(
            axis(u[0], merl::DIMS[0]),
            axis(u[1], merl::DIMS[1]),
            axis(u[2], merl::DIMS[2]),
        )]
    }
}

/// The missing-data flags of a MERL table (one per bin, true where any channel's stored value is
/// negative), or None when it has no missing data.
pub fn missing_bins(path: &std::path::Path) -> Result<Option<Arc<Vec<bool>>>> {
    let table = merl::read(path)?;
    if table.missing == 0 {
        return Ok(None);
    }
    let raw = crate::input::read_regular(path, "MERL file", crate::merl::FILE_BYTES as u64)?;
    let stored = |k: usize| {
        let at = merl::HEADER_BYTES + 8 * k;
        f64::from_le_bytes(raw[at..at + 8].try_into().unwrap_or([0; 8]))
    };
    Ok(Some(Arc::new(
        (0..merl::BINS)
            .map(|k| (0..3).any(|c| stored(k + c * merl::BINS) < 0.0))
            .collect(),
    )))
}

/// What [`compare`] computes besides the bins.
#[derive(Clone, Debug)]
pub struct Options {
    /// The bins both models are evaluated at.
    pub bins: Bins,
    /// Evaluate with every specular Fresnel factor at 1 (docs/design.md §3).
    pub white_furnace: bool,
    /// μ = cosθo of the directional albedo differences (each in (0, 1]); empty with `albedo`
    /// None.
    pub mus: Vec<f64>,
    /// The albedo integrator, or None to skip the albedo differences.
    pub albedo: Option<Settings>,
}

/// Where the largest relative difference is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Largest {
    /// θi in degrees.
    pub theta_i_deg: f64,
    /// θo in degrees.
    pub theta_o_deg: f64,
    /// φo − φi in degrees, in [0, 360).
    pub phi_deg: f64,
    /// The channel: 0 red, 1 green, 2 blue.
    pub channel: usize,
    /// A's value there, 1/sr.
    pub a: f64,
    /// B's value there, 1/sr.
    pub b: f64,
}

/// An albedo of A, of B and their difference, RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoPair {
    /// μ = cosθo (NaN for the hemispherical albedo).
    pub mu: f64,
    /// A's albedo.
    pub a: [f64; 3],
    /// B's albedo.
    pub b: [f64; 3],
    /// a − b.
    pub difference: [f64; 3],
}

impl AlbedoPair {
    fn new(mu: f64, a: DVec3, b: DVec3) -> AlbedoPair {
        AlbedoPair {
            mu,
            a: a.to_array(),
            b: b.to_array(),
            difference: (a - b).to_array(),
        }
    }
}

/// What `lobe compare` reports (module docs).
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The bins, as [`Bins::describe`] words them.
    pub bins: String,
    /// Bins compared.
    pub used: u64,
    /// Bins at or below the horizon, left out.
    pub below_horizon: u64,
    /// Bins left out for a MERL file's missing data.
    pub missing: u64,
    /// Weighted RMS of the floored relative difference over bins and channels.
    pub relative_rms: f64,
    /// Largest floored relative difference.
    pub relative_max: f64,
    /// Where it is.
    pub largest: Option<Largest>,
    /// The cosine-weighted log error of B against A.
    pub log_error: ChannelErrors,
    /// ‖B − A‖ / ‖A‖, weighted.
    pub relative_l2: ChannelErrors,
    /// E_A(μ) − E_B(μ) at each μ asked for.
    pub directional: Vec<AlbedoPair>,
    /// Ē_A − Ē_B (hemispherical albedo).
    pub hemispherical: Option<AlbedoPair>,
}

/// The channel names, red, green, blue.
pub const CHANNELS: [&str; 3] = ["r", "g", "b"];

/// Pairs evaluated per call to the backend: large enough to amortise a dispatch, small enough
/// for steady progress and bounded memory.
const CHUNK: u64 = 1 << 16;

/// Compares B against A on `opts.bins` (module docs); `progress` receives (bins done, bins in
/// all) for the table part.
pub fn compare(
    eval: &Evaluator,
    a: &Side,
    b: &Side,
    opts: &Options,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Comparison> {
    opts.bins.check(&a.params, "A")?;
    opts.bins.check(&b.params, "B")?;
    for &mu in &opts.mus {
        if !(mu > 0.0 && mu <= 1.0) {
            return Err(
                BadInput::new("mu", format!("mu = {mu}: expected cos(theta_o) in (0, 1]")).into(),
            );
        }
    }
    let cells = opts.bins.cells();
    let mut bins = Vec::new();
    let mut cell_of = Vec::new();
    let (mut fa, mut fb) = (Vec::new(), Vec::new());
    let (mut below, mut missing) = (0u64, 0u64);
    let mut first = 0u64;
    while first < cells {
        eval.check_cancelled()?;
        let end = (first + CHUNK).min(cells);
        let mut pairs = Vec::with_capacity((end - first) as usize);
        let mut kept = Vec::with_capacity((end - first) as usize);
        for cell in first..end {
            let ((wi, wo), weight) = opts.bins.bin(cell);
            if wi.z <= 0.0 || wo.z <= 0.0 {
                below += 1;
                continue;
            }
            if a.is_missing(wi, wo) || b.is_missing(wi, wo) {
                missing += 1;
                continue;
            }
            pairs.push((wi, wo));
            kept.push((cell, wi.z, weight));
        }
        if !pairs.is_empty() {
            fa.extend(eval.eval_pairs(
                Query::one(&a.params).with_white_furnace(opts.white_furnace),
                &pairs,
            )?);
            fb.extend(eval.eval_pairs(
                Query::one(&b.params).with_white_furnace(opts.white_furnace),
                &pairs,
            )?);
        }
        for (cell, cos_i, weight) in kept {
            bins.push(Bin { cos_i, weight });
            cell_of.push(cell);
        }
        progress(end, cells);
        first = end;
    }
    let rel = loss::relative_difference(&bins, &fa, &fb);
    let largest = rel.argmax.filter(|_| rel.max > 0.0).map(|(k, c)| {
        let ((wi, wo), _) = opts.bins.bin(cell_of[k]);
        let (ti, pi) = angles_deg(wi);
        let (to, po) = angles_deg(wo);
        Largest {
            theta_i_deg: ti,
            theta_o_deg: to,
            phi_deg: (po - pi).rem_euclid(360.0),
            channel: c,
            a: fa[k][c],
            b: fb[k][c],
        }
    });
    let mut out = Comparison {
        bins: opts.bins.describe(),
        used: bins.len() as u64,
        below_horizon: below,
        missing,
        relative_rms: rel.rms,
        relative_max: rel.max,
        largest,
        log_error: loss::cosine_log_error(&bins, &fa, &fb),
        relative_l2: loss::relative_l2(&bins, &fa, &fb),
        directional: Vec::new(),
        hemispherical: None,
    };
    drop((fa, fb, bins, cell_of));
    if let Some(settings) = &opts.albedo {
        let (directional, hemispherical) = albedo_pairs(eval, a, b, opts, settings)?;
        out.directional = directional;
        out.hemispherical = Some(hemispherical);
    }
    Ok(out)
}

/// The directional albedo of both sides at `opts.mus` and their hemispherical albedo, with
/// `settings`' integrator under the comparison's white-furnace switch.
fn albedo_pairs(
    eval: &Evaluator,
    a: &Side,
    b: &Side,
    opts: &Options,
    settings: &Settings,
) -> Result<(Vec<AlbedoPair>, AlbedoPair)> {
    let settings = Settings {
        white_furnace: opts.white_furnace,
        ..*settings
    };
    let points: Vec<(f64, f64)> = opts.mus.iter().map(|&m| (m, 0.0)).collect();
    let ea = integrate::directional(eval, &a.params, &settings, &points)?;
    let eb = integrate::directional(eval, &b.params, &settings, &points)?;
    let directional = ea
        .iter()
        .zip(&eb)
        .map(|(x, y)| AlbedoPair::new(x.mu, x.albedo, y.albedo))
        .collect();
    let ha = integrate::hemispherical(eval, &a.params, &settings, 0.0)?;
    let hb = integrate::hemispherical(eval, &b.params, &settings, 0.0)?;
    Ok((directional, AlbedoPair::new(f64::NAN, ha.albedo, hb.albedo)))
}

impl Comparison {
    /// The report as JSON (the `--format json` of `lobe compare`).
    pub fn to_json(&self) -> serde_json::Value {
        let errors = |e: &ChannelErrors| json!({ "total": e.total, "rgb": e.channel });
        let albedo = |p: &AlbedoPair| json!({ "a": p.a, "b": p.b, "a_minus_b": p.difference });
        json!({
            "bins": self.bins,
            "bins_compared": self.used,
            "bins_below_horizon": self.below_horizon,
            "bins_missing": self.missing,
            "relative_floor": loss::RELATIVE_FLOOR,
            "relative_rms": self.relative_rms,
            "relative_max": self.relative_max,
            "relative_max_at": self.largest.map(|l| json!({
                "theta_i_deg": l.theta_i_deg,
                "theta_o_deg": l.theta_o_deg,
                "phi_o_minus_phi_i_deg": l.phi_deg,
                "channel": CHANNELS[l.channel],
                "a": l.a,
                "b": l.b,
            })),
            "cosine_log_error": errors(&self.log_error),
            "relative_l2": errors(&self.relative_l2),
            "directional_albedo": self.directional.iter().map(|p| {
                let mut v = albedo(p);
                v["mu"] = json!(p.mu);
                v
            }).collect::<Vec<_>>(),
            "hemispherical_albedo": self.hemispherical.as_ref().map(albedo),
        })
    }
}
