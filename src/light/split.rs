//! The split sum (Karis 2013, "Real Shading in Unreal Engine 4"; docs/design.md §15.3), taken
//! exactly over the map's texels: for each pixel the map prefiltered about the mirror direction
//! r by the model's D with n = v = r, times the DFG scale and bias of lobe's engine table at
//! (n·v, α) applied to F0 and F90, plus the Lambertian part ρ/π · Σ L (n·l)⁺ ΔΩ. Computed in f64 on
//! the host for both backends (the prefilter evaluates D, not the model's f); the DFG table is
//! the one `lobe albedo --engine dfg` writes, computed on the evaluator's backend.

use super::LightImage;
use crate::backend::light::{sphere_pixels, texel_solid_angle, EnvMap, SpherePixel};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::lut::engine::{compute_engine, EngineKind, EngineSpec, EngineTable};
use crate::model::split_sum::{split_sum_lobe, SpecularLobe, SplitSumLobe};
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::FRAC_1_PI;

/// Cells of the DFG table along n·v and along the perceptual roughness √α: the 32 × 32 that
/// `lobe albedo --engine dfg` writes by default.
pub const DFG_CELLS: usize = 32;

/// Texel terms per band of rows (the progress steps and the unit Ctrl-C waits for).
const TERMS_PER_BAND: u64 = 1 << 26;

/// The model's description for the split sum, or a refusal naming the model.
pub fn lobe_of(params: &ParamSet, white_furnace: bool) -> Result<SplitSumLobe, BadInput> {
    split_sum_lobe(params, white_furnace).ok_or_else(|| {
        BadInput::new(
            "method",
            format!(
                "model {}: this model has no microfacet lobe the split sum can prefilter (it covers lambert, microfacet and cook_torrance); use --method exact",
                params.model().name()
            ),
        )
    })
}

/// The map's texels as the prefilter takes them: direction, L ΔΩ and ΔΩ, row by row.
pub(crate) struct Texels {
    terms: Vec<(DVec3, DVec3, f64)>,
}

impl Texels {
    pub(crate) fn new(map: &EnvMap) -> Texels {
        let (w, h) = (map.width(), map.height());
        let weighted = map.weighted_texels();
        let terms = weighted
            .terms
            .iter()
            .enumerate()
            .map(|(k, &(d, l_omega))| (d, l_omega, texel_solid_angle(w, h, k as u32 / w)))
            .collect();
        Texels { terms }
    }

    /// Karis' prefiltered radiance about `r` with n = v = r: Σ L D(r·h) (r·l)⁺ ΔΩ over
    /// Σ D(r·h) (r·l)⁺ ΔΩ, h the half vector of l and r.
    pub(crate) fn prefiltered(&self, r: DVec3, lobe: &SpecularLobe) -> DVec3 {
        let (mut num, mut den) = (DVec3::ZERO, 0.0);
        for &(l, l_omega, omega) in &self.terms {
            let c = r.dot(l);
            if c > 0.0 {
                let h = (l + r).normalize();
                let w = lobe.d(r.dot(h)) * c;
                num += l_omega * w;
                den += omega * w;
            }
        }
        if den > 0.0 {
            num / den
        } else {
            DVec3::ZERO
        }
    }

    /// The irradiance Σ L (n·l)⁺ ΔΩ at normal `n`.
    fn irradiance(&self, n: DVec3) -> DVec3 {
        self.terms
            .iter()
            .map(|&(l, l_omega, _)| l_omega * n.dot(l).max(0.0))
            .sum()
    }
}

/// The two rows of the DFG table that bracket a lobe's √α, and where √α falls between them.
pub struct DfgRows {
    /// Rows k0 and k0 + 1 of the [`DFG_CELLS`]² engine table ([`EngineTable::values`]'s layout).
    pub table: EngineTable,
    /// The weight of the second row: √α's position between the two rows' centres, clamped to
    /// [0, 1] (an engine's clamp-to-edge below the first centre and above the last).
    pub weight: f64,
}

impl DfgRows {
    /// The (scale, bias) at `mu`, bilinear between cell centres with the edges clamped, as a GPU
    /// sampler reads an RG texture.
    pub fn at(&self, mu: f64) -> (f64, f64) {
        let t = &self.table;
        let n = t.mus.len();
        let x = (mu * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let j0 = (x.floor() as usize).min(n - 1);
        let (j1, fx) = ((j0 + 1).min(n - 1), x - j0 as f64);
        let at = |k: usize, j: usize, c: usize| t.values[(k * n + j) * 2 + c];
        let lerp = |a: f64, b: f64, w: f64| a + (b - a) * w;
        let ch = |c| {
            lerp(
                lerp(at(0, j0, c), at(0, j1, c), fx),
                lerp(at(1, j0, c), at(1, j1, c), fx),
                self.weight,
            )
        };
        (ch(0), ch(1))
    }
}

/// The rows of lobe's engine DFG table (`lobe albedo --engine dfg` with the lobe's D and G,
/// [`DFG_CELLS`]² cells, r_k = (k + ½)/N, α = r²) that bracket √α of `lobe`: computed as a table
/// of two rows over r ∈ [k0/N, (k0 + 2)/N], whose cell centres are the full table's rows k0 and
/// k0 + 1, so that its numbers are the full table's without the other 30 rows' cost.
pub fn dfg_rows(eval: &Evaluator, lobe: &SpecularLobe) -> Result<DfgRows> {
    let n = DFG_CELLS;
    let y = (lobe.alpha.sqrt() * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
    let k0 = (y.floor() as usize).min(n - 2);
    let mut spec = EngineSpec::new(EngineKind::Dfg, &lobe.lut_sets)?;
    spec.lut.n_mu = n;
    spec.lut.n_p = 2;
    spec.lut.lo = k0 as f64 / n as f64;
    spec.lut.hi = (k0 + 2) as f64 / n as f64;
    Ok(DfgRows {
        table: compute_engine(eval, &spec, &mut |_, _| {})?,
        weight: (y - k0 as f64).clamp(0.0, 1.0),
    })
}

/// The split sum at one pixel.
fn pixel_value(
    texels: &Texels,
    lobe: &SplitSumLobe,
    dfg: Option<&DfgRows>,
    p: &SpherePixel,
) -> [f64; 3] {
    let n = p.n;
    let mu = n.z;
    let mut value = DVec3::ZERO;
    if let (Some(s), Some(table)) = (&lobe.specular, dfg) {
        let r = (2.0 * mu * n - DVec3::Z).normalize();
        let (scale, bias) = table.at(mu);
        value += s.weight * texels.prefiltered(r, s) * (s.f0 * scale + s.f90 * bias);
    }
    if lobe.diffuse != DVec3::ZERO {
        value += lobe.diffuse * FRAC_1_PI * texels.irradiance(n);
    }
    value.to_array()
}

/// The split sum of `params` under `map`, `size` × `size` pixels (0 outside the sphere), in
/// bands of rows; `progress` gets (rows done, rows). Refuses a model without a description
/// ([`lobe_of`]).
pub fn split_sum(
    eval: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    map: &EnvMap,
    size: u32,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<LightImage> {
    super::check_image_size(size)?;
    let lobe = lobe_of(params, white_furnace)?;
    progress(0, size as u64);
    let dfg = match &lobe.specular {
        Some(s) => Some(dfg_rows(eval, s)?),
        None => None,
    };
    let texels = Texels::new(map);
    let per_row = size as u64 * texels.terms.len() as u64;
    let band = (TERMS_PER_BAND / per_row.max(1)).clamp(1, size as u64) as u32;
    let mut pixels = vec![[0.0f64; 3]; size as usize * size as usize];
    let mut row = 0u32;
    while row < size {
        eval.check_cancelled()?;
        let end = (row + band).min(size);
        let band_pixels = sphere_pixels(size, row..end);
        let values: Vec<[f64; 3]> = band_pixels
            .par_iter()
            .map(|p| pixel_value(&texels, &lobe, dfg.as_ref(), p))
            .collect();
        for (p, v) in band_pixels.iter().zip(values) {
            pixels[(p.row * size + p.col) as usize] = v;
        }
        row = end;
        progress(row as u64, size as u64);
    }
    Ok(LightImage { size, pixels })
}

/// How far the split sum is from the exact sum, over the pixels inside the sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorFigures {
    /// √(mean of (split − exact)²) over the sphere's pixels and the three channels.
    pub rms: f64,
    /// The largest |split − exact| / exact over pixels and channels where exact > 0.
    pub max_relative: f64,
    /// The pixel (row, column) of `max_relative`.
    pub at: (u32, u32),
    /// n·v at that pixel.
    pub mu: f64,
}

/// The error figures of `split` against `exact` (images of the same size).
pub fn error_figures(exact: &LightImage, split: &LightImage) -> ErrorFigures {
    let size = exact.size;
    let (mut sq, mut count) = (0.0, 0usize);
    let mut worst = ErrorFigures {
        rms: 0.0,
        max_relative: 0.0,
        at: (0, 0),
        mu: 0.0,
    };
    for p in sphere_pixels(size, 0..size) {
        let (e, s) = (exact.at(p.row, p.col), split.at(p.row, p.col));
        for c in 0..3 {
            let d = s[c] - e[c];
            sq += d * d;
            count += 1;
            if e[c] > 0.0 && d.abs() / e[c] > worst.max_relative {
                worst.max_relative = d.abs() / e[c];
                worst.at = (p.row, p.col);
                worst.mu = p.n.z;
            }
        }
    }
    worst.rms = if count > 0 {
        (sq / count as f64).sqrt()
    } else {
        0.0
    };
    worst
}

/// split − exact per pixel and channel.
pub fn difference(exact: &LightImage, split: &LightImage) -> LightImage {
    LightImage {
        size: exact.size,
        pixels: exact
            .pixels
            .iter()
            .zip(&split.pixels)
            .map(|(e, s)| [s[0] - e[0], s[1] - e[1], s[2] - e[2]])
            .collect(),
    }
}
