//! Any isotropic model as a MERL file: f at the centre of every bin ([`super::bin_centre`]:
//! θh = (π/2)((h + ½)/90)², θd = (d + ½)(π/2)/90, φd = (p + ½)π/180, φh = 0), divided by MERL's
//! channel scale, in the file's planar layout. A bin whose centre puts ωi or ωo at or below the
//! horizon holds 0 (the one-sided rule), not a missing-data mark: the model defines f there.
//! The format keeps φd ∈ [0, π) only, which holds everything for a reciprocal isotropic model
//! (f(φd) = f(φd + π)); a mirror spike (a delta lobe) is not in it, as in every table.

use super::{bin, bin_centre, encode, BINS, DIMS};
use crate::backend::Query;
use crate::eval::Evaluator;
use crate::grid::{half_diff_to_pair, Grid};
use crate::input::BadInput;
use crate::model::ParamSet;
use crate::output::FileSet;
use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// θh rows evaluated per call to the backend: 8 × 16,200 pairs, small enough for steady
/// progress, large enough to amortise a dispatch.
const ROWS_PER_CHUNK: usize = 8;

/// The grid a MERL file samples, for the checks tables share (an isotropic parameter set).
pub const GRID: Grid = Grid::HalfDiff {
    n_theta_h: DIMS[0],
    n_theta_d: DIMS[1],
    n_phi_d: DIMS[2],
};

/// Checks a request before any work: the parameter set is isotropic and the path ends in
/// `.binary`. Refusals are [`BadInput`]s tagged `grid` or `path`.
pub fn check_request(params: &ParamSet, path: &Path) -> Result<()> {
    if !params.is_isotropic() {
        // The table check would suggest a four-angle grid, which no MERL file can hold.
        return Err(BadInput::new(
            "grid",
            format!(
                "a MERL file holds an isotropic BRDF (θh, θd, φd), but {} with {} is anisotropic; \
                 write a lobe table on the full grid or the four-angle halfdiff grid instead",
                params.model().name(),
                params.to_text()
            ),
        )
        .into());
    }
    crate::table::check_grid(params, &GRID)?;
    if path.extension().and_then(|e| e.to_str()) != Some("binary") {
        return Err(BadInput::new(
            "path",
            format!("the MERL file path {} must end in .binary", path.display()),
        )
        .into());
    }
    Ok(())
}

/// The f values (1/sr, planar, 3 × [`BINS`]) of `params` at every bin centre, on `eval`;
/// `progress` receives (bins done, bins in all).
pub fn bin_values(
    eval: &Evaluator,
    query: Query,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Vec<f64>> {
    let mut values = vec![0.0; 3 * BINS];
    let row = DIMS[1] * DIMS[2];
    for rows in (0..DIMS[0]).collect::<Vec<_>>().chunks(ROWS_PER_CHUNK) {
        eval.check_cancelled()?;
        let mut pairs = Vec::with_capacity(rows.len() * row);
        for &h in rows {
            for d in 0..DIMS[1] {
                for p in 0..DIMS[2] {
                    let [th, td, pd] = bin_centre(h, d, p);
                    pairs.push(half_diff_to_pair(th, 0.0, td, pd));
                }
            }
        }
        let f = eval.eval_pairs(query, &pairs)?;
        let first = bin(rows[0], 0, 0);
        for (k, v) in f.iter().enumerate() {
            for (c, x) in v.iter().enumerate() {
                values[c * BINS + first + k] = *x;
            }
        }
        progress((first + f.len()) as u64, BINS as u64);
    }
    Ok(values)
}

/// Writes `params` as the MERL file `path` (see the module's notes), through a [`FileSet`]:
/// complete or not at all, the old file kept until then.
pub fn write(
    eval: &Evaluator,
    query: Query,
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<()> {
    let params = query.params();
    check_request(params, path)?;
    let set = FileSet::new(&[path])?;
    let values = bin_values(eval, query, progress)?;
    {
        let mut w = set[0].writer();
        w.write_all(&encode(&values))
            .with_context(|| format!("writing {}", path.display()))?;
        w.finish()?;
    }
    set.commit()
}
