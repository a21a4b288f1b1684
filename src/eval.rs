//! One interface over the two backends: the Vulkan kernels (f32) and the CPU reference (f64).

use crate::finite::InvalidCount;
use crate::gpu::{Gpu, GpuPair, TableSwitches};
use crate::grid::Grid;
use crate::interrupt::{CancelToken, Interrupted};
use crate::model::{Brdf, ParamSet, Reference};
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Mutex;

/// Cells per CPU chunk of a table: bounded memory, enough work for every thread.
const CPU_CHUNK_CELLS: u64 = 1 << 22;

/// Cells per chunk of a table evaluated as explicit pairs (`halfdiff`): 48 MiB of f64 pairs.
const PAIR_CHUNK_CELLS: u64 = 1 << 20;

/// Which backend an [`Evaluator`] runs on.
#[derive(Clone, Copy)]
pub enum Backend<'a> {
    /// The Vulkan kernels, in f32.
    Gpu(&'a Gpu),
    /// The CPU reference, in f64 (rayon over every core).
    Cpu,
}

/// Where f is evaluated, and the token that stops long jobs between chunks. Cheap to copy; a
/// [`crate::Session`] hands one out with [`crate::Session::evaluator`].
#[derive(Clone, Copy)]
pub struct Evaluator<'a> {
    backend: Backend<'a>,
    cancel: Option<&'a CancelToken>,
    fast_pow: bool,
    /// Where invalid values are counted instead of refused ([`Evaluator::counting_invalid`]).
    tally: Option<&'a Mutex<InvalidCount>>,
}

fn f32x4(v: DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

impl<'a> Evaluator<'a> {
    /// The GPU kernels of `gpu`, never cancelled.
    pub fn gpu(gpu: &'a Gpu) -> Evaluator<'a> {
        Evaluator {
            backend: Backend::Gpu(gpu),
            cancel: None,
            fast_pow: false,
            tally: None,
        }
    }

    /// The f64 CPU reference, never cancelled.
    pub const fn cpu() -> Evaluator<'static> {
        Evaluator {
            backend: Backend::Cpu,
            cancel: None,
            fast_pow: false,
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
    pub fn backend(&self) -> Backend<'a> {
        self.backend
    }

    /// The GPU runner, where this evaluates on the GPU.
    pub fn as_gpu(&self) -> Option<&'a Gpu> {
        match self.backend {
            Backend::Gpu(g) => Some(g),
            Backend::Cpu => None,
        }
    }

    /// Whether this evaluates on the GPU.
    pub fn is_gpu(&self) -> bool {
        self.as_gpu().is_some()
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
        match self.backend {
            Backend::Gpu(g) => format!("gpu ({})", g.device().name()),
            Backend::Cpu => "cpu (f64 reference)".to_string(),
        }
    }

    /// The GPU's driver and its version ("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"); None on the CPU.
    pub fn driver(&self) -> Option<String> {
        match self.backend {
            Backend::Gpu(g) => Some(g.device().driver().to_string()),
            Backend::Cpu => None,
        }
    }

    /// f at each (ωi, ωo) pair, for one parameter set.
    pub fn eval_pairs(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>> {
        let f = self.eval_pairs_unchecked(params, white_furnace, pairs)?;
        let mut count = InvalidCount::default();
        count.add_pairs(0, &f, pairs);
        self.check_invalid(params, count, "evaluating f at direction pairs")?;
        Ok(f)
    }

    fn eval_pairs_unchecked(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>> {
        match self.backend {
            Backend::Gpu(gpu) => {
                let block = Brdf::new(params).gpu_block();
                let gp: Vec<GpuPair> = pairs
                    .iter()
                    .map(|(wi, wo)| GpuPair {
                        wi: [wi.x as f32, wi.y as f32, wi.z as f32],
                        param_index: 0,
                        wo: [wo.x as f32, wo.y as f32, wo.z as f32],
                        pad: 0,
                    })
                    .collect();
                let out = gpu.eval_pairs(params.model(), &[block], &gp, white_furnace)?;
                Ok(out.into_iter().map(|c| c.map(f64::from)).collect())
            }
            Backend::Cpu => {
                params.model().require_reference("the CPU backend")?;
                let r = Reference::new(params, white_furnace);
                Ok(pairs
                    .par_iter()
                    .map(|(wi, wo)| r.eval(*wi, *wo).to_array())
                    .collect())
            }
        }
    }

    /// The lobe table on `grid`, handed to `sink` in order, one chunk at a time, as
    /// (first cell, f32 rgb values).
    pub fn eval_table(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        grid: &Grid,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<()> {
        let sink = &mut |first: u64, values: &[f32]| -> Result<()> {
            let mut count = InvalidCount::default();
            count.add_f32(first, values, |cell| grid.pair_at(cell));
            self.check_invalid(params, count, "evaluating a table")?;
            sink(first, values)
        };
        if !grid.is_product() {
            return self.eval_table_by_pairs(params, white_furnace, grid, sink);
        }
        let wi = grid.wi_list();
        let wo = grid.wo_list();
        match self.backend {
            Backend::Gpu(gpu) => {
                let block = Brdf::new(params).gpu_block();
                let wi: Vec<[f32; 4]> = wi.iter().map(|v| f32x4(*v)).collect();
                let wo: Vec<[f32; 4]> = wo.iter().map(|v| f32x4(*v)).collect();
                gpu.eval_table::<anyhow::Error>(
                    params.model(),
                    &block,
                    &wi,
                    &wo,
                    TableSwitches {
                        white_furnace,
                        fast_pow: self.fast_pow,
                    },
                    sink,
                )
            }
            Backend::Cpu => {
                params.model().require_reference("the CPU backend")?;
                let r = Reference::new(params, white_furnace);
                let cells = wi.len() as u64 * wo.len() as u64;
                let n_wo = wo.len() as u64;
                let mut first = 0u64;
                let mut buf = Vec::new();
                while first < cells {
                    let count = CPU_CHUNK_CELLS.min(cells - first);
                    buf.resize(count as usize * 3, 0.0f32);
                    buf.par_chunks_mut(3).enumerate().for_each(|(k, out)| {
                        let cell = first + k as u64;
                        let f = r.eval(wi[(cell / n_wo) as usize], wo[(cell % n_wo) as usize]);
                        out.copy_from_slice(&[f.x as f32, f.y as f32, f.z as f32]);
                    });
                    sink(first, &buf)?;
                    first += count;
                }
                Ok(())
            }
        }
    }

    /// A table on a grid that is not an outer product (`halfdiff`): each chunk's (ωi, ωo) pairs
    /// are made on the CPU and evaluated as pairs; memory stays bounded by the chunk.
    fn eval_table_by_pairs(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        grid: &Grid,
        sink: &mut dyn FnMut(u64, &[f32]) -> Result<()>,
    ) -> Result<()> {
        let cells = grid
            .cells()
            .ok_or_else(|| anyhow::anyhow!("the grid has too many cells"))?;
        let mut first = 0u64;
        while first < cells {
            let count = PAIR_CHUNK_CELLS.min(cells - first);
            let pairs: Vec<(DVec3, DVec3)> = (first..first + count)
                .into_par_iter()
                .map(|cell| grid.pair_at(cell))
                .collect();
            let f = self.eval_pairs_unchecked(params, white_furnace, &pairs)?;
            let buf: Vec<f32> = f.iter().flat_map(|v| v.map(|x| x as f32)).collect();
            sink(first, &buf)?;
            first += count;
        }
        Ok(())
    }
}
