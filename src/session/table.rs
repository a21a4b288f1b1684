//! Lobe tables: in memory as a [`Table`] (values with their grid), or written as files.

use super::Session;
use crate::backend::Query;
use crate::error::{Error, IntoLobe, Result};
use crate::finite::InvalidCount;
use crate::grid::{dphi_cell, phi_cell, theta_cell, Grid};
use crate::table::TableMeta;
use std::path::Path;

/// A lobe table in memory: f32 RGB per cell of its grid, in 1/sr, cells in the grid's row-major
/// order (the last axis fastest, as in the `.npy` file [`Session::write_table`] writes).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    grid: Grid,
    data: Vec<f32>,
}

/// One axis of a [`Table`]: its name as the table's JSON sidecar spells it, its unit and the
/// angle at the centre of each of its cells (docs/design.md §4).
#[derive(Clone, Debug, PartialEq)]
pub struct TableAxis {
    /// `theta_i`, `phi_i`, `theta_o`, `phi_o`, `delta_phi`, `theta_h`, `phi_h`, `theta_d` or
    /// `phi_d`.
    pub name: &'static str,
    /// The unit of `values`: always `rad`.
    pub unit: &'static str,
    /// The cell centres, one per cell of the axis, increasing.
    pub values: Vec<f64>,
}

/// The angle spans a grid axis covers: θ over [0, π/2], φ over [0, 2π), Δφ or φd over [0, π].
#[derive(Clone, Copy)]
enum Span {
    Theta,
    Phi,
    HalfTurn,
}

impl TableAxis {
    fn new(name: &'static str, span: Span, n: usize) -> TableAxis {
        let centre = match span {
            Span::Theta => theta_cell,
            Span::Phi => phi_cell,
            Span::HalfTurn => dphi_cell,
        };
        TableAxis {
            name,
            unit: "rad",
            values: (0..n).map(|k| centre(k, n)).collect(),
        }
    }
}

impl Table {
    /// The grid the table samples.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Cells per axis, in the grid's order (without the RGB axis).
    pub fn shape(&self) -> Vec<usize> {
        self.grid.shape()
    }

    /// The grid's axes, in the order of [`Table::shape`].
    pub fn axes(&self) -> Vec<TableAxis> {
        use Span::*;
        let axis = TableAxis::new;
        match self.grid {
            Grid::Full {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            } => vec![
                axis("theta_i", Theta, n_theta_i),
                axis("phi_i", Phi, n_phi_i),
                axis("theta_o", Theta, n_theta_o),
                axis("phi_o", Phi, n_phi_o),
            ],
            Grid::Isotropic {
                n_theta_i,
                n_theta_o,
                n_dphi,
            } => vec![
                axis("theta_i", Theta, n_theta_i),
                axis("theta_o", Theta, n_theta_o),
                axis("delta_phi", HalfTurn, n_dphi),
            ],
            Grid::HalfDiff {
                n_theta_h,
                n_theta_d,
                n_phi_d,
            } => vec![
                axis("theta_h", Theta, n_theta_h),
                axis("theta_d", Theta, n_theta_d),
                axis("phi_d", HalfTurn, n_phi_d),
            ],
            Grid::HalfDiffFull {
                n_theta_h,
                n_phi_h,
                n_theta_d,
                n_phi_d,
            } => vec![
                axis("theta_h", Theta, n_theta_h),
                axis("phi_h", Phi, n_phi_h),
                axis("theta_d", Theta, n_theta_d),
                axis("phi_d", Phi, n_phi_d),
            ],
        }
    }

    /// The number of cells.
    pub fn cells(&self) -> usize {
        self.data.len() / 3
    }

    /// The RGB value of the cell at multi-index `index` (one index per axis, in the order of
    /// [`Table::shape`]), or None when an index is out of its axis's range or the count of
    /// indices is not the count of axes.
    pub fn get(&self, index: &[usize]) -> Option<[f32; 3]> {
        let shape = self.grid.shape();
        if index.len() != shape.len() || index.iter().zip(&shape).any(|(i, n)| i >= n) {
            return None;
        }
        let cell = index.iter().zip(&shape).fold(0, |acc, (i, n)| acc * n + i);
        let v = &self.data[cell * 3..cell * 3 + 3];
        Some([v[0], v[1], v[2]])
    }

    /// The RGB value of the cell at multi-index `index`, as [`Table::get`].
    ///
    /// # Panics
    /// When [`Table::get`] gives None, as a slice index out of range does.
    pub fn at(&self, index: &[usize]) -> [f32; 3] {
        self.get(index).unwrap_or_else(|| {
            panic!(
                "cell index {index:?} is outside the table's shape {:?}",
                self.grid.shape()
            )
        })
    }

    /// The values, RGB per cell in row-major order: `shape` + `[3]` flattened.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The values without a copy ([`Table::data`]'s order).
    pub fn into_data(self) -> Vec<f32> {
        self.data
    }
}

impl Session {
    /// The lobe table on `grid` in memory: the values [`Session::write_table`] writes into its
    /// `.npy` for the same request, bit for bit. Refuses tables over `max_cells` cells (a bound
    /// on memory: 12 bytes a cell), an anisotropic set on a grid that holds only the isotropic
    /// half of the angles, and a table with an invalid value (NaN, ±Inf, negative), which
    /// [`Session::write_table`] writes and counts.
    ///
    /// ```
    /// use lobe::grid::Grid;
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?;
    /// let grid = Grid::Isotropic { n_theta_i: 2, n_theta_o: 3, n_dphi: 4 };
    /// let t = session.table(&lambert, &grid, 1 << 10)?;
    /// assert_eq!(t.shape(), [2, 3, 4]);
    /// assert_eq!(t.axes()[2].name, "delta_phi");
    /// let f = t.at(&[1, 2, 3]);
    /// assert!((f[0] - 0.5 / std::f32::consts::PI).abs() < 1e-6);
    /// assert_eq!(t.data().len(), 2 * 3 * 4 * 3);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn table<'q>(
        &self,
        query: impl Into<Query<'q>>,
        grid: &Grid,
        max_cells: u64,
    ) -> Result<Table> {
        let query = query.into();
        let cells = grid.cells().filter(|&c| c <= max_cells).ok_or_else(|| {
            Error::Invalid(format!(
                "a table of shape {:?} has more than the {max_cells} cells allowed in memory",
                grid.shape()
            ))
        })?;
        // The runs [`Session::write_table`] streams into its `.npy`, each at its cells' place:
        // one path, so the array and the file hold the same bits (a reciprocal model's mirror
        // cells are copies of the cells evaluated, not evaluations of their own).
        let mut data = vec![0.0; cells as usize * 3];
        let ev = self.evaluator();
        ev.eval_table_runs(query, grid, &mut |first, v| {
            ev.check_cancelled()?;
            let at = first as usize * 3;
            data[at..at + v.len()].copy_from_slice(v);
            Ok(())
        })
        .lobe()?;
        Ok(Table { grid: *grid, data })
    }

    /// Writes the table set `PATH.exr`, `PATH.npy`, `PATH.json` (all or nothing), streaming
    /// chunk by chunk; `progress` gets (cells done, cells). Returns the count of invalid values
    /// (NaN, ±Inf, negative), which the table keeps; a table with any replaces an existing set
    /// only with `replace_invalid` ([`crate::table::stage_table_with`]).
    ///
    /// ```
    /// use lobe::grid::Grid;
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("lambert.exr");
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let grid = Grid::Isotropic { n_theta_i: 2, n_theta_o: 2, n_dphi: 2 };
    /// let invalid = lobe::Session::cpu()
    ///     .write_table(&lambert, grid, &path, false, &mut |_, _| {})?;
    /// assert!(invalid.is_clean());
    /// assert!(path.exists() && dir.path().join("lambert.npy").exists());
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn write_table<'q>(
        &self,
        query: impl Into<Query<'q>>,
        grid: Grid,
        exr_path: &Path,
        replace_invalid: bool,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<InvalidCount> {
        let query = query.into();
        let meta = TableMeta {
            params: query.params(),
            white_furnace: query.white_furnace,
            grid,
            backend: self.backend_name(),
        };
        self.write_table_as(&meta, false, exr_path, replace_invalid, progress)
    }

    /// [`Session::write_table`] of a model taken as reciprocal, f(ωi, ωo) = f(ωo, ωi), where it
    /// does not declare it (a `.brdf` file): on a grid that allows it, each cell with θi ≤ θo is
    /// evaluated and copied into its mirror cell (docs/design.md §4.5), so for a model that is
    /// not reciprocal both cells hold f at the first one's directions.
    ///
    /// ```
    /// use lobe::grid::Grid;
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("phong.exr");
    /// let phong = lobe::ParamSet::for_model("phong")?;
    /// let grid = Grid::Isotropic { n_theta_i: 3, n_theta_o: 3, n_dphi: 2 };
    /// let session = lobe::Session::cpu();
    /// session.write_table_reciprocal(&phong, grid, &path, false, &mut |_, _| {})?;
    /// let npy = std::fs::read(dir.path().join("phong.npy")).unwrap();
    /// // f32 cells after the header: (θi, θo) = (0, 2) and (2, 0) hold the same bytes.
    /// let cell = |i: usize, o: usize| {
    ///     let at = npy.len() - (9 * 2 * 3 * 4) + ((i * 3 + o) * 2 * 3 * 4);
    ///     npy[at..at + 12].to_vec()
    /// };
    /// assert_eq!(cell(0, 2), cell(2, 0));
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn write_table_reciprocal<'q>(
        &self,
        query: impl Into<Query<'q>>,
        grid: Grid,
        exr_path: &Path,
        replace_invalid: bool,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<InvalidCount> {
        let query = query.into();
        let meta = TableMeta {
            params: query.params(),
            white_furnace: query.white_furnace,
            grid,
            backend: self.backend_name(),
        };
        self.write_table_as(&meta, true, exr_path, replace_invalid, progress)
    }

    fn write_table_as(
        &self,
        meta: &TableMeta,
        reciprocal: bool,
        exr_path: &Path,
        replace_invalid: bool,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<InvalidCount> {
        crate::table::check_request(meta.params, &meta.grid, exr_path).lobe()?;
        let eval = self.evaluator().assuming_reciprocity(reciprocal);
        crate::table::write_table_with(&eval, meta, exr_path, replace_invalid, progress).lobe()
    }

    /// Writes `params` as a MERL file at `path` ([`crate::merl::write`]); `progress` receives
    /// (bins done, bins in all).
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// let gold = lobe::ParamSet::preset("gold", "cook_torrance")?;
    /// lobe::Session::cpu()
    ///     .write_merl(&gold, &dir.path().join("gold.binary"), &mut |_, _| {})?;
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn write_merl<'q>(
        &self,
        query: impl Into<Query<'q>>,
        path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<()> {
        let query = query.into();
        crate::merl::write::write(&self.evaluator(), query, path, progress).lobe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ParamSet;

    /// The table stores f32; the CPU reference computes in f64, so a cell and the same pair
    /// evaluated alone agree to f32 rounding (half an ulp, relative 2^-24, with margin).
    const F32_ROUNDING: f64 = 1e-7;

    /// Every cell of `grid` read through `at` is f at that cell's pair, and its axes' values are
    /// the grid's angles for that index.
    fn check_indexing(params: &ParamSet, grid: Grid) {
        let s = Session::cpu();
        let t = s.table(params, &grid, 1 << 12).unwrap();
        assert_eq!(t.shape(), grid.shape());
        assert_eq!(t.cells() as u64, grid.cells().unwrap());
        let axes = t.axes();
        assert_eq!(axes.len(), grid.shape().len());
        for cell in 0..grid.cells().unwrap() {
            let idx = grid.index(cell);
            let want = s.eval_pairs(params, &[grid.pair(&idx)]).unwrap()[0];
            let got = t.at(&idx);
            for c in 0..3 {
                let tol = F32_ROUNDING * want[c].abs().max(1e-30);
                assert!(
                    (got[c] as f64 - want[c]).abs() <= tol,
                    "{grid:?} cell {idx:?} channel {c}: table {} vs pair {}",
                    got[c],
                    want[c]
                );
            }
            // Each axis's value at the index is the angle the grid puts there (the isotropic
            // and 3-axis half/difference grids fix φi or φh = 0 and carry no axis for it).
            let angles = grid.angles(&idx);
            let on_axes: Vec<f64> = match grid.shape().len() {
                4 => angles.to_vec(),
                _ => vec![angles[0], angles[2], angles[3]],
            };
            for (k, a) in axes.iter().enumerate() {
                assert_eq!(a.values[idx[k]], on_axes[k], "{} at {idx:?}", a.name);
            }
        }
    }

    #[test]
    fn at_reads_the_cell_of_each_index_on_every_grid() {
        let aniso = crate::resolve_params(
            "ashikhmin_shirley",
            None,
            &["nu=10".into(), "nv=200".into()],
        )
        .unwrap();
        let gold = crate::resolve_params("cook_torrance", Some("gold"), &[]).unwrap();
        let full = Grid::Full {
            n_theta_i: 2,
            n_phi_i: 3,
            n_theta_o: 4,
            n_phi_o: 5,
        };
        check_indexing(&aniso, full);
        let iso = Grid::Isotropic {
            n_theta_i: 3,
            n_theta_o: 4,
            n_dphi: 5,
        };
        check_indexing(&gold, iso);
        let hd = Grid::HalfDiff {
            n_theta_h: 3,
            n_theta_d: 4,
            n_phi_d: 5,
        };
        check_indexing(&gold, hd);
        let hd_full = Grid::HalfDiffFull {
            n_theta_h: 2,
            n_phi_h: 3,
            n_theta_d: 4,
            n_phi_d: 3,
        };
        check_indexing(&aniso, hd_full);
    }

    #[test]
    fn axes_are_named_as_the_sidecar_names_them() {
        let gold = crate::resolve_params("cook_torrance", Some("gold"), &[]).unwrap();
        for grid in [
            Grid::Full {
                n_theta_i: 1,
                n_phi_i: 2,
                n_theta_o: 1,
                n_phi_o: 2,
            },
            Grid::Isotropic {
                n_theta_i: 1,
                n_theta_o: 1,
                n_dphi: 2,
            },
            Grid::HalfDiff {
                n_theta_h: 1,
                n_theta_d: 1,
                n_phi_d: 2,
            },
            Grid::HalfDiffFull {
                n_theta_h: 1,
                n_phi_h: 2,
                n_theta_d: 1,
                n_phi_d: 2,
            },
        ] {
            let t = Session::cpu().table(&gold, &grid, 64).unwrap();
            let json = grid.axes_json();
            let sidecar: Vec<&str> = json
                .as_array()
                .unwrap()
                .iter()
                .map(|a| a["name"].as_str().unwrap())
                .filter(|&n| n != "rgb")
                .collect();
            let names: Vec<&str> = t.axes().iter().map(|a| a.name).collect();
            assert_eq!(names, sidecar, "{grid:?}");
            assert!(t.axes().iter().all(|a| a.unit == "rad"));
        }
    }

    #[test]
    fn an_index_outside_the_shape_is_none_and_at_panics() {
        let lambert = crate::resolve_params("lambert", None, &[]).unwrap();
        let grid = Grid::Isotropic {
            n_theta_i: 2,
            n_theta_o: 3,
            n_dphi: 4,
        };
        let t = Session::cpu().table(&lambert, &grid, 64).unwrap();
        assert!(t.get(&[1, 2, 3]).is_some());
        for bad in [
            &[2, 0, 0][..],
            &[0, 3, 0],
            &[0, 0, 4],
            &[0, 0],
            &[0, 0, 0, 0],
        ] {
            assert_eq!(t.get(bad), None, "{bad:?}");
        }
        let e = std::panic::catch_unwind(|| t.at(&[0, 3, 0])).unwrap_err();
        let message = e.downcast_ref::<String>().unwrap();
        assert!(
            message.contains("[0, 3, 0]") && message.contains("[2, 3, 4]"),
            "{message}"
        );
        assert_eq!(t.clone().into_data(), t.data());
    }
}
