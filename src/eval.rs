//! The jobs' handle on a backend: the [`Backend`] behind one interface with the cancellation
//! token, the invalid-value policy and the speed-for-accuracy switches.

use crate::backend::{
    Backend, CpuBackend, DrawRange, DrawRecord, Precision, Quadrants, Query, TableSink,
    UpperTriangle,
};
use crate::finite::InvalidCount;
use crate::gpu::Gpu;
use crate::grid::Grid;
use crate::interrupt::{CancelToken, Interrupted};
use crate::model::{Model, ParamSet};
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::Duration;

/// Cells per chunk of a table evaluated as explicit pairs (`halfdiff`): 48 MiB of f64 pairs.
const PAIR_CHUNK_CELLS: u64 = 1 << 20;

/// Where f is evaluated, and the token that stops long jobs between chunks. Cheap to copy; a
/// [`crate::Session`] hands one out with [`crate::Session::evaluator`].
#[derive(Clone, Copy)]
pub struct Evaluator<'a> {
    backend: &'a dyn Backend,
    cancel: Option<&'a CancelToken>,
    fast_pow: bool,
    /// Tables treat the model as reciprocal though it does not declare it
    /// ([`Evaluator::assuming_reciprocity`]).
    assume_reciprocal: bool,
    /// Where invalid values are counted instead of refused ([`Evaluator::counting_invalid`]).
    tally: Option<&'a Mutex<InvalidCount>>,
}

impl<'a> Evaluator<'a> {
    /// `backend`, never cancelled.
    pub fn on(backend: &'a dyn Backend) -> Evaluator<'a> {
        Evaluator {
            backend,
            cancel: None,
            fast_pow: false,
            assume_reciprocal: false,
            tally: None,
        }
    }

    /// The GPU kernels of `gpu`, never cancelled.
    pub fn gpu(gpu: &'a Gpu) -> Evaluator<'a> {
        Evaluator::on(gpu)
    }

    /// The f64 CPU reference, never cancelled.
    pub const fn cpu() -> Evaluator<'static> {
        Evaluator {
            backend: &CpuBackend,
            cancel: None,
            fast_pow: false,
            assume_reciprocal: false,
            tally: None,
        }
    }

    /// The same backend, stopped between chunks once `cancel` is set.
    pub fn with_cancel(self, cancel: &'a CancelToken) -> Evaluator<'a> {
        Evaluator {
            cancel: Some(cancel),
            ..self
        }
    }

    /// The same backend, with cos^n lobes in tables evaluated by GLSL's plain pow
    /// (exp2(n log2 x)) instead of the careful formulation: a speed-for-accuracy variant that
    /// `lobe tradeoff` measures. The CPU reference ignores it.
    pub fn with_fast_pow(self, fast_pow: bool) -> Evaluator<'a> {
        Evaluator { fast_pow, ..self }
    }

    /// The same backend, with [`Evaluator::eval_table_runs`] treating the model as reciprocal
    /// where `reciprocal` is set, even when it does not declare itself so
    /// ([`Model::is_reciprocal`]): the user's word for a `.brdf` file. Where f is not
    /// reciprocal, such a table holds f(θi, θo, Δφ) with θi ≤ θo in both of its cells.
    pub fn assuming_reciprocity(self, reciprocal: bool) -> Evaluator<'a> {
        Evaluator {
            assume_reciprocal: reciprocal,
            ..self
        }
    }

    /// The same backend, counting NaN, ±Inf and negative values into `tally` and handing them
    /// on, as `eval` and `table` do (docs/design.md §2.1). Without it, [`Evaluator::eval_pairs`]
    /// and [`Evaluator::eval_table`] refuse such values with
    /// [`crate::finite::InvalidValues`] at the first chunk that holds one.
    pub fn counting_invalid(self, tally: &'a Mutex<InvalidCount>) -> Evaluator<'a> {
        Evaluator {
            tally: Some(tally),
            ..self
        }
    }

    /// Applies the policy to a chunk's count: added to the tally, or refused.
    fn check_invalid(&self, params: &ParamSet, count: InvalidCount, job: &str) -> Result<()> {
        match self.tally {
            Some(t) => {
                t.lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner)
                    .merge(count);
                Ok(())
            }
            None => Ok(count.refuse(params.model().name(), job)?),
        }
    }

    /// The backend.
    pub fn backend(&self) -> &'a dyn Backend {
        self.backend
    }

    /// The arithmetic of the backend's values and sums.
    pub fn precision(&self) -> Precision {
        self.backend.precision()
    }

    /// Ok where the backend can evaluate `model` (the CPU reference needs its f64 twin).
    pub fn supports(&self, model: Model) -> Result<()> {
        self.backend.supports(model)
    }

    /// `Err(Interrupted)` once the cancellation token is set: long loops call it between chunks.
    pub fn check_cancelled(&self) -> Result<(), Interrupted> {
        match self.cancel {
            Some(c) => c.check(),
            None => Ok(()),
        }
    }

    /// The cancellation token, if any.
    pub fn cancel_token(&self) -> Option<&'a CancelToken> {
        self.cancel
    }

    /// A one-line description: the backend and the device.
    pub fn name(&self) -> String {
        self.backend.name()
    }

    /// The device's name, where the backend runs on one.
    pub fn device(&self) -> Option<String> {
        self.backend.device()
    }

    /// The GPU's driver and its version ("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"); None on the CPU.
    pub fn driver(&self) -> Option<String> {
        self.backend.driver()
    }

    /// Device time of every dispatch since the last call, where the backend has such a clock.
    pub fn take_device_time(&self) -> Option<Duration> {
        self.backend.take_device_time()
    }

    /// The draws `range` of the sampler of the query's first set for `wo` ([`Backend::draws`],
    /// docs/design.md §13): the same directions on either backend, stopped between chunks once
    /// the token is set.
    pub fn draws<'q>(
        &self,
        query: impl Into<Query<'q>>,
        wo: DVec3,
        range: DrawRange,
    ) -> Result<Vec<DrawRecord>> {
        self.backend.draws(query.into(), wo, range, self.cancel)
    }

    /// f at each (ωi, ωo) pair, for one parameter set.
    pub fn eval_pairs<'q>(
        &self,
        query: impl Into<Query<'q>>,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>> {
        let query = query.into();
        anyhow::ensure!(
            !query.sets.is_empty(),
            "f needs a parameter set; the query has none"
        );
        let f = self.eval_pairs_unchecked(query, pairs)?;
        let mut count = InvalidCount::default();
        count.add_pairs(0, &f, pairs);
        self.check_invalid(query.params(), count, "evaluating f at direction pairs")?;
        Ok(f)
    }

    fn eval_pairs_unchecked(
        &self,
        query: Query,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>> {
        let mut f = self.backend.pairs(query, pairs)?;
        Ok(f.pop().unwrap_or_default())
    }

    /// f of each parameter set of `sets` at every pair: `[set][pair]`, as the backend computed
    /// them (NaN, ±Inf and negative values included), for jobs that count or refuse such values
    /// themselves. Sets of one model go to the backend as one job, which it may batch.
    pub fn eval_sets_unchecked(
        &self,
        query: Query,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<Vec<[f64; 3]>>> {
        self.check_cancelled()?;
        if query.one_model() {
            return self.backend.pairs(query, pairs);
        }
        query
            .sets
            .iter()
            .map(|p| self.eval_pairs_unchecked(query.for_set(p), pairs))
            .collect()
    }

    /// The lobe table on `grid`, handed to `sink` in order, one chunk at a time, as
    /// (first cell, f32 rgb values).
    pub fn eval_table<'q>(
        &self,
        query: impl Into<Query<'q>>,
        grid: &Grid,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<()> {
        let query = query.into();
        anyhow::ensure!(
            !query.sets.is_empty(),
            "a table needs a parameter set; the query has none"
        );
        self.every_cell(query, grid, &mut self.checked(query.params(), grid, sink))
    }

    /// [`Evaluator::eval_table`] without the check of invalid values (its callers make it once).
    fn every_cell(
        &self,
        query: Query,
        grid: &Grid,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<()> {
        if !grid.is_product() {
            self.eval_table_by_pairs(query, grid, 1, sink)?;
            return Ok(());
        }
        let lists = grid.lists();
        self.backend
            .table(query, &lists.0, &lists.1, self.fast_pow, self.cancel, sink)
    }

    /// The lobe table on `grid`, handed to `sink` as runs of cells (first cell, f32 rgb values)
    /// in any order, each cell once; returns the BRDF evaluations made. For a reciprocal model
    /// ([`Model::is_reciprocal`], or [`Evaluator::assuming_reciprocity`]) with an isotropic
    /// parameter set, mirror cells are copied instead of evaluated (docs/design.md §4.5): on the
    /// isotropic grid with NTHETA_I = NTHETA_O the backend may evaluate only the cells with θi
    /// index ≤ θo index; on the three-axis half/difference grid the f32 backend evaluates the
    /// φd cells k ≤ NPHI_D − 1 − k of each row. On the full grid with NPHI_I a multiple of 4 and
    /// NPHI_O even, the f32 backend evaluates only the light directions with φi in the first
    /// quadrant for a mirror-symmetric model ([`Model::is_mirror_symmetric`], or a reciprocal
    /// model with an isotropic set) and copies the rest (§4.6). Otherwise this is
    /// [`Evaluator::eval_table`], every cell evaluated, in order.
    pub fn eval_table_runs<'q>(
        &self,
        query: impl Into<Query<'q>>,
        grid: &Grid,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<u64> {
        let query = query.into();
        anyhow::ensure!(
            !query.sets.is_empty(),
            "a table needs a parameter set; the query has none"
        );
        let params = query.params();
        let reciprocal = (self.assume_reciprocal || params.model().is_reciprocal())
            // The mirrors take isotropy too (f even in Δφ; the grids refuse other sets).
            && params.is_isotropic();
        match *grid {
            Grid::Isotropic {
                n_theta_i,
                n_theta_o,
                n_dphi,
            } if reciprocal && n_theta_i == n_theta_o && self.backend.makes_upper_triangle() => {
                let triangle = UpperTriangle::new(n_theta_i as u64, n_dphi as u64);
                self.upper_triangle(query, grid, triangle, sink)?;
                return Ok(triangle.cells());
            }
            Grid::Full {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            } if self.backend.precision() == Precision::F32
                && (params.model().is_mirror_symmetric()
                    || (params.model().is_reciprocal() && params.is_isotropic())) =>
            {
                let axes = [n_theta_i, n_phi_i, n_theta_o, n_phi_o].map(|n| n as u64);
                if let Some(quadrants) = Quadrants::new(axes[0], axes[1], axes[2], axes[3]) {
                    self.quadrants(query, grid, quadrants, sink)?;
                    return Ok(quadrants.cells());
                }
            }
            Grid::HalfDiff { n_phi_d, .. }
                if reciprocal && self.backend.precision() == Precision::F32 =>
            {
                let sink = &mut self.checked(params, grid, sink);
                return self.eval_table_by_pairs(query, grid, n_phi_d as u64, sink);
            }
            _ => {}
        }
        self.every_cell(query, grid, &mut self.checked(params, grid, sink))?;
        grid.cells()
            .ok_or_else(|| anyhow::anyhow!("the grid has too many cells"))
    }

    /// `sink` behind the check of invalid values of each run of table cells.
    fn checked<'s>(
        &'s self,
        params: &'s ParamSet,
        grid: &'s Grid,
        sink: &'s mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> impl FnMut(u64, &[f32]) -> Result<()> + 's {
        move |first: u64, values: &[f32]| -> Result<()> {
            let mut count = InvalidCount::default();
            if self.backend.table_chunk_valid() {
                count.evaluated = (values.len() / 3) as u64;
            } else {
                count.add_f32(first, values, |cell| grid.pair_at(cell));
            }
            self.check_invalid(params, count, "evaluating a table")?;
            sink(first, values)
        }
    }

    /// The reciprocal isotropic table from its upper triangle (docs/design.md §4.5): each packed
    /// chunk the backend makes is handed to `sink` with its mirror images.
    fn upper_triangle(
        &self,
        query: Query,
        grid: &Grid,
        triangle: UpperTriangle,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<()> {
        let lists = grid.lists();
        self.backend.table_upper_triangle(
            query,
            &lists.0,
            &lists.1,
            self.fast_pow,
            self.cancel,
            &mut |first, values| {
                self.spread_checked(query.params(), grid, values, sink, &mut |to| {
                    triangle.scatter(first, values, to)
                })
            },
        )
    }

    /// The mirror-symmetric full table from the quarter with φi in the first quadrant
    /// (docs/design.md §4.6): the backend's table of those light directions and every view
    /// direction, each chunk handed to `sink` with its images.
    fn quadrants(
        &self,
        query: Query,
        grid: &Grid,
        quadrants: Quadrants,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<()> {
        let all = grid.wi_list();
        let wi: Vec<DVec3> = quadrants.light_cells().map(|k| all[k]).collect();
        let mut scratch = Vec::new();
        self.backend.table(
            query,
            &wi,
            &grid.wo_list(),
            self.fast_pow,
            self.cancel,
            &mut |first, values| {
                self.spread_checked(query.params(), grid, values, sink, &mut |to| {
                    quadrants.scatter(first, values, &mut scratch, to)
                })
            },
        )
    }

    /// Evaluated cells `values` handed to `sink` by `spread`, as runs of table cells with their
    /// copies, under the check of invalid values. The check reads the evaluated cells once;
    /// only where one is invalid are the runs counted one by one, so that the counts and the
    /// first invalid cell speak of the table's cells.
    fn spread_checked(
        &self,
        params: &ParamSet,
        grid: &Grid,
        values: &[f32],
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
        spread: &mut dyn FnMut(&mut TableSink<'_>) -> Result<()>,
    ) -> Result<()> {
        if !self.backend.table_chunk_valid() && !crate::finite::all_valid_f32(values) {
            return spread(&mut self.checked(params, grid, sink));
        }
        let mut count = InvalidCount::default();
        spread(&mut |at, run| {
            count.evaluated += run.len() as u64 / 3;
            sink(at, run)
        })?;
        self.check_invalid(params, count, "evaluating a table")
    }

    /// A table on a grid that is not an outer product (`halfdiff`): each chunk's (ωi, ωo) pairs
    /// are made on the CPU and evaluated as pairs; memory stays bounded by the chunk. Returns
    /// the evaluations made. With `mirror_row` > 1, the table's last axis (φd, `mirror_row`
    /// cells) is symmetric about its middle, f(φd) = f(π − φd) (docs/design.md §4.5): chunks
    /// hold whole rows, and in each row only cell k ≤ mirror_row − 1 − k is evaluated and
    /// copied to mirror_row − 1 − k.
    fn eval_table_by_pairs(
        &self,
        query: Query,
        grid: &Grid,
        mirror_row: u64,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<u64> {
        let cells = grid
            .cells()
            .ok_or_else(|| anyhow::anyhow!("the grid has too many cells"))?;
        let row = mirror_row.max(1);
        let chunk = (PAIR_CHUNK_CELLS / row).max(1) * row;
        let mirror = |cell: u64| cell - cell % row + (row - 1 - cell % row);
        let (mut first, mut evaluations) = (0u64, 0u64);
        while first < cells {
            let count = chunk.min(cells - first);
            let evaluated: Vec<u64> = (first..first + count)
                .filter(|&cell| cell <= mirror(cell))
                .collect();
            let pairs: Vec<(DVec3, DVec3)> = evaluated
                .par_iter()
                .map(|&cell| grid.pair_at(cell))
                .collect();
            let f = self.eval_pairs_unchecked(query, &pairs)?;
            let mut buf = vec![0.0f32; count as usize * 3];
            for (&cell, v) in evaluated.iter().zip(&f) {
                let v = v.map(|x| x as f32);
                let at = (cell - first) as usize * 3;
                buf[at..at + 3].copy_from_slice(&v);
                if mirror(cell) != cell {
                    let at = (mirror(cell) - first) as usize * 3;
                    buf[at..at + 3].copy_from_slice(&v);
                }
            }
            sink(first, &buf)?;
            evaluations += f.len() as u64;
            first += count;
        }
        Ok(evaluations)
    }
}
