//! Lobe tables on disk: NumPy `.npy` (shape = the grid's axes, then 3) with a JSON sidecar, and an
//! OpenEXR mosaic of 2D slices, one per light direction: one [`ArtifactSet`], so a failed run
//! leaves no partial file and never replaces a good one.
//!
//! EXR mosaic layout (also written into the EXR header as `lobe.layout`):
//! - full grid: a slice per (θi, φi) is NPHI_O pixels wide (φo) and NTHETA_O tall (θo); slices
//!   tile the image with φi across and θi down. Pixel (x, y) holds
//!   θi = y / NTHETA_O, θo = y % NTHETA_O, φi = x / NPHI_O, φo = x % NPHI_O (cell indices).
//! - isotropic grid: a slice per θi is NDPHI wide (Δφ) and NTHETA_O tall (θo); slices sit side by
//!   side. Pixel (x, y) holds θi = x / NDPHI, Δφ = x % NDPHI, θo = y.

use crate::backend::Query;
use crate::eval::Evaluator;
use crate::finite::InvalidCount;
use crate::grid::Grid;
use crate::input::BadInput;
use crate::model::ParamSet;
use crate::output::{sibling, ArtifactSet, FileSet, Provenance};
use anyhow::{bail, Context, Result};
use exr::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

pub use crate::output::{exr_text, npy};

/// The most a table's JSON sidecar may hold when it is read back (one is a few KiB: axes,
/// model, parameters).
pub const MAX_SIDECAR_BYTES: u64 = 1 << 20;

/// Cells above which a table is refused before any work starts: 2^32 − 1, the GPU kernel's 32-bit
/// cell index (48 GiB of float32 RGB).
pub const MAX_TABLE_CELLS: u64 = u32::MAX as u64;

/// The longest side of a table's EXR mosaic, pixels: 2^22. The EXR encoder holds whole rows, about
/// 55 bytes per pixel of a row, so a one-row mosaic of 6e7 pixels took 3.3 GB for a 720 MB table;
/// at this side a row costs at most ~230 MB. Useful grids stay far below it (a 1024 x 2048 φ
/// plane is 2^21 pixels wide).
pub const MAX_MOSAIC_SIDE: usize = 1 << 22;

/// Checks a table request before any work starts and returns its cell count: a grid that holds
/// only the isotropic half of the angles needs an isotropic parameter set, the table has at most
/// [`MAX_TABLE_CELLS`] cells, and the path ends in `.exr` (the `.npy` and `.json` go beside it).
/// Refusals are [`BadInput`]s tagged `grid`, `cells` or `path`.
pub fn check_request(params: &ParamSet, grid: &Grid, exr_path: &Path) -> Result<u64> {
    let cells = check_grid(params, grid)?;
    if exr_path.extension().and_then(|e| e.to_str()) != Some("exr") {
        return Err(BadInput::new(
            "path",
            format!(
                "the table path {} must end in .exr (the .npy and .json are written beside it)",
                exr_path.display()
            ),
        )
        .into());
    }
    Ok(cells)
}

/// The grid part of [`check_request`]: isotropy and size, for tables made in memory too.
pub fn check_grid(params: &ParamSet, grid: &Grid) -> Result<u64> {
    if grid.needs_isotropy() && !params.is_isotropic() {
        let instead = match grid {
            Grid::Isotropic { .. } => "the full grid",
            _ => "the halfdiff grid with four numbers NTHETA_H,NPHI_H,NTHETA_D,NPHI_D",
        };
        return Err(BadInput::new(
            "grid",
            format!(
                "the {} grid {:?} holds only the isotropic half of the angles, but {} with {} is anisotropic; use {instead}",
                grid.name(),
                grid.shape(),
                params.model().name(),
                params.to_text()
            ),
        )
        .into());
    }
    let cells = grid.cells().filter(|&c| c <= MAX_TABLE_CELLS).ok_or_else(|| {
        BadInput::new(
            "cells",
            format!(
                "a table of shape {:?} would have more than {MAX_TABLE_CELLS} cells; lower the resolution",
                grid.shape()
            ),
        )
    })?;
    let (w, h, _) = mosaic(grid);
    if w.max(h) > MAX_MOSAIC_SIDE {
        return Err(BadInput::new(
            "cells",
            format!(
                "a table of shape {:?} would be an EXR mosaic of {w} x {h} pixels; a side is at most \
                 {MAX_MOSAIC_SIDE} pixels (spread the cells over more axes)",
                grid.shape()
            ),
        )
        .into());
    }
    Ok(cells)
}

/// What a table holds, for headers and sidecars.
pub struct TableMeta<'a> {
    /// The model and its parameters.
    pub params: &'a ParamSet,
    /// Whether every specular Fresnel factor was 1 (docs/design.md §3).
    pub white_furnace: bool,
    /// The grid the table samples.
    pub grid: Grid,
    /// The backend that evaluated it, as [`Evaluator::name`] says.
    pub backend: String,
}

impl TableMeta<'_> {
    /// What the table evaluates: its parameter set with the white-furnace switch.
    pub fn query(&self) -> Query<'_> {
        Query::one(self.params).with_white_furnace(self.white_furnace)
    }
}

/// The npy and JSON siblings of a table written at `exr_path` (the three files share a stem).
pub fn sibling_paths(exr_path: &Path) -> (PathBuf, PathBuf) {
    (sibling(exr_path, "", "npy"), sibling(exr_path, "", "json"))
}

/// Maps pixel (x, y) of the EXR mosaic to its npy cell index.
type PixelToCell = Box<dyn Fn(usize, usize) -> usize + Sync>;

/// (width, height) of the EXR mosaic and the npy cell index of pixel (x, y).
fn mosaic(grid: &Grid) -> (usize, usize, PixelToCell) {
    match *grid {
        Grid::Full {
            n_theta_i,
            n_phi_i,
            n_theta_o,
            n_phi_o,
        } => (
            n_phi_i * n_phi_o,
            n_theta_i * n_theta_o,
            Box::new(move |x, y| {
                let (ti, to, pi, po) = (y / n_theta_o, y % n_theta_o, x / n_phi_o, x % n_phi_o);
                ((ti * n_phi_i + pi) * n_theta_o + to) * n_phi_o + po
            }),
        ),
        Grid::Isotropic {
            n_theta_i: n_a,
            n_theta_o: n_b,
            n_dphi: n_c,
        }
        | Grid::HalfDiff {
            n_theta_h: n_a,
            n_theta_d: n_b,
            n_phi_d: n_c,
        } => (
            n_a * n_c,
            n_b,
            Box::new(move |x, y| {
                let (a, c, b) = (x / n_c, x % n_c, y);
                (a * n_b + b) * n_c + c
            }),
        ),
        Grid::HalfDiffFull {
            n_theta_h,
            n_phi_h,
            n_theta_d,
            n_phi_d,
        } => mosaic(&Grid::Full {
            n_theta_i: n_theta_h,
            n_phi_i: n_phi_h,
            n_theta_o: n_theta_d,
            n_phi_o: n_phi_d,
        }),
    }
}

fn layout_text(grid: &Grid) -> &'static str {
    match grid {
        Grid::Full { .. } => {
            "mosaic: x = phi_i*NPHI_O + phi_o, y = theta_i*NTHETA_O + theta_o (cell indices)"
        }
        Grid::Isotropic { .. } => "mosaic: x = theta_i*NDPHI + dphi, y = theta_o (cell indices)",
        Grid::HalfDiff { .. } => "mosaic: x = theta_h*NPHI_D + phi_d, y = theta_d (cell indices)",
        Grid::HalfDiffFull { .. } => {
            "mosaic: x = phi_h*NPHI_D + phi_d, y = theta_h*NTHETA_D + theta_d (cell indices)"
        }
    }
}

/// Evaluates the table on `eval` and writes `exr_path`, its `.npy` and its `.json`, as one
/// transaction ([`FileSet`]): the three appear together, from this run, or not at all. See
/// [`stage_table`].
pub fn write_table(
    eval: &Evaluator,
    meta: &TableMeta,
    exr_path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<InvalidCount> {
    write_table_with(eval, meta, exr_path, false, progress)
}

/// [`write_table`], where `replace_invalid` lets a table with invalid values replace an
/// existing set of the same name (see [`stage_table_with`]).
pub fn write_table_with(
    eval: &Evaluator,
    meta: &TableMeta,
    exr_path: &Path,
    replace_invalid: bool,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<InvalidCount> {
    let mut set = FileSet::empty();
    let count = stage_table_with(eval, meta, exr_path, &mut set, replace_invalid, progress)?;
    set.commit()?;
    Ok(count)
}

/// Evaluates the table on `eval` and writes `exr_path`, its `.npy` and its `.json` into `set`,
/// which commits them (with whatever else it holds). The npy is streamed run by run, each run
/// written at its cells' place (a reciprocal table's mirror cells arrive out of order,
/// [`Evaluator::eval_table_runs`]); the EXR is then written from a memory map of the npy, so no
/// step holds the whole table in memory.
/// `progress` receives (cells done, cells in all).
pub fn stage_table(
    eval: &Evaluator,
    meta: &TableMeta,
    exr_path: &Path,
    set: &mut FileSet,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<InvalidCount> {
    stage_table_with(eval, meta, exr_path, set, false, progress)
}

/// [`stage_table`] with the choice for invalid values (NaN, ±Inf, negative; docs/design.md
/// §2.1). The table keeps them, and returns and records their count in its sidecar; but
/// unless `replace_invalid`, a table holding any is refused (a [`BadInput`] tagged
/// `allow_invalid`, nothing written) where a file of the set exists already, so that it
/// never replaces a good table of the same name.
pub fn stage_table_with(
    eval: &Evaluator,
    meta: &TableMeta,
    exr_path: &Path,
    set: &mut FileSet,
    replace_invalid: bool,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<InvalidCount> {
    let tally = Mutex::new(InvalidCount::default());
    let eval = &eval.counting_invalid(&tally);
    let cells = meta.grid.cells().context("the grid has too many cells")?;
    let mut shape = meta.grid.shape();
    shape.push(3);
    let files = ArtifactSet::stage(set, crate::output::TABLE_SET, exr_path, &[""], &[])?;
    {
        let mut w = files.npy_stream(0, &shape)?;
        let mut done = 0;
        eval.eval_table_runs(meta.query(), &meta.grid, &mut |first, values| {
            // Ctrl-C: stop between chunks; the temporary files are dropped (removed) on the
            // way out and nothing is renamed into place.
            eval.check_cancelled()?;
            w.write_at(first * 3, values)?;
            done += values.len() as u64 / 3;
            progress(done, cells);
            Ok(())
        })?;
        w.finish()?;
    }
    let count = tally
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if !count.is_clean() && !replace_invalid {
        if let Some(old) = files.existing() {
            return Err(BadInput::new(
                "allow_invalid",
                format!(
                    "the {} table holds invalid values, so it does not replace {}: {count}",
                    meta.params.model().name(),
                    old.display()
                ),
            )
            .into());
        }
    }
    // The EXR from the finished npy; the sidecar last.
    let (w, h, index) = mosaic(&meta.grid);
    files.exr_rgb_from_npy(0, "lobe", (w, h), &index, &exr_attributes(meta))?;
    let provenance = Provenance {
        model: meta.params.model().name(),
        parameters: meta.params.to_json(),
        white_furnace: meta.white_furnace,
        backend: &meta.backend,
    };
    files.finish(&provenance, sidecar_fields(meta, exr_path, &count))?;
    Ok(count)
}

/// The sidecar's own fields (the [`Provenance`] fields come with every set).
fn sidecar_fields(meta: &TableMeta, exr_path: &Path, invalid: &InvalidCount) -> serde_json::Value {
    json!({
        "grid": meta.grid.name(),
        "shape": meta.grid.shape().into_iter().chain([3]).collect::<Vec<_>>(),
        "axes": meta.grid.axes_json(),
        "angles": "radians; cell-centred (docs/design.md §4); theta from the normal +z, phi from +x counter-clockwise",
        "values": "f(wi, wo) in 1/sr, linear RGB, without the cosine; delta lobes are not included",
        "units": "1/sr",
        "dtype": "float32",
        "exr": exr_path.file_name().map(|n| n.to_string_lossy().into_owned()),
        "exr_layout": layout_text(&meta.grid),
        "invalid_values": invalid.to_json(),
    })
}

/// The EXR header's `lobe.*` attributes.
fn exr_attributes(meta: &TableMeta) -> [(&'static str, String); 7] {
    [
        ("lobe.model", meta.params.model().name().to_string()),
        ("lobe.parameters", meta.params.to_text()),
        ("lobe.white_furnace", meta.white_furnace.to_string()),
        ("lobe.grid", meta.grid.name().to_string()),
        (
            "lobe.shape",
            meta.grid
                .shape()
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(","),
        ),
        ("lobe.layout", layout_text(&meta.grid).to_string()),
        (
            "lobe.units",
            "1/sr, linear RGB, without the cosine".to_string(),
        ),
    ]
}

/// A table read back from disk, in npy order (cells × rgb).
pub struct TableData {
    /// The grid's axes, then 3 (RGB).
    pub shape: Vec<usize>,
    /// f in 1/sr, row-major over `shape`.
    pub values: Vec<f32>,
    /// The EXR header's lobe.* attributes.
    pub attributes: Vec<(String, String)>,
}

/// Reads the npy of a table.
pub fn read_npy(npy_path: &Path) -> Result<TableData> {
    let (shape, values) = npy::read(npy_path)?;
    Ok(TableData {
        shape,
        values,
        attributes: Vec::new(),
    })
}

/// The R, G and B channels of an EXR layer, pixel by pixel in row-major order.
pub fn exr_rgb(layer: &Layer<AnyChannels<FlatSamples>>, path: &Path) -> Result<Vec<[f32; 3]>> {
    let mut out = vec![[0.0f32; 3]; layer.size.0 * layer.size.1];
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|ch| ch.name == Text::new_or_panic(*name))
            .with_context(|| format!("{}: no channel {name}", path.display()))?;
        for (k, px) in out.iter_mut().enumerate() {
            px[c] = ch.sample_data.value_by_flat_index(k).to_f32();
        }
    }
    Ok(out)
}

/// Reads the EXR mosaic of a table back into npy order, using its own header to undo the mosaic.
pub fn read_exr(exr_path: &Path) -> Result<TableData> {
    let image = read_first_flat_layer_from_file(exr_path)
        .with_context(|| format!("reading {}", exr_path.display()))?;
    let layer = &image.layer_data;
    let mut attributes = Vec::new();
    for (k, v) in &layer.attributes.other {
        if let AttributeValue::Text(t) = v {
            attributes.push((k.to_string(), t.to_string()));
        }
    }
    let attr = |key: &str| {
        attributes
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
    };
    let grid_name = attr("lobe.grid").context("the EXR has no lobe.grid attribute")?;
    let shape_text = attr("lobe.shape").context("the EXR has no lobe.shape attribute")?;
    let grid = Grid::parse(&grid_name, &shape_text).map_err(anyhow::Error::msg)?;
    let (w, h, index) = mosaic(&grid);
    if layer.size.0 != w || layer.size.1 != h {
        bail!(
            "{}: image is {}x{}, the grid needs {w}x{h}",
            exr_path.display(),
            layer.size.0,
            layer.size.1
        );
    }
    let cells = grid.cells().context("grid too large")? as usize;
    let mut values = vec![0.0f32; cells * 3];
    let rgb = exr_rgb(layer, exr_path)?;
    for y in 0..h {
        for x in 0..w {
            let cell = index(x, y);
            values[cell * 3..cell * 3 + 3].copy_from_slice(&rgb[y * w + x]);
        }
    }
    let mut shape = grid.shape();
    shape.push(3);
    Ok(TableData {
        shape,
        values,
        attributes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn option(r: Result<u64>) -> Option<&'static str> {
        crate::input::option_of(&r.unwrap_err())
    }

    #[test]
    fn a_request_is_refused_by_grid_size_and_path_before_any_work() {
        let iso = crate::resolve_params("lambert", None, &[]).unwrap();
        let aniso = crate::resolve_params(
            "ashikhmin_shirley",
            None,
            &["nu=10".into(), "nv=100".into()],
        )
        .unwrap();
        let grid = Grid::parse("isotropic", "4,5,6").unwrap();
        let path = Path::new("t.exr");
        assert_eq!(check_request(&iso, &grid, path).unwrap(), 120);
        assert_eq!(option(check_request(&aniso, &grid, path)), Some("grid"));
        let full = Grid::parse("full", "4,5,6,7").unwrap();
        assert_eq!(check_request(&aniso, &full, path).unwrap(), 840);
        let huge = Grid::parse("isotropic", "100000,100000,100000").unwrap();
        assert_eq!(option(check_request(&iso, &huge, path)), Some("cells"));
        let png = Path::new("t.png");
        assert_eq!(option(check_request(&iso, &grid, png)), Some("path"));
    }
}
