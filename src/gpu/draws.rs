//! The draws kernel (`glsl/kernels/sample.comp`): the model's sampler for one ωo, draw i with the
//! numbers of [`crate::random::draw_numbers`], in chunks; and the sampling test's counting kernel
//! (`glsl/kernels/chi2.comp`): the same draws counted in cells on the device.

use super::buffer::Buffer;
use super::pipeline::{ChunkPush, Dispatcher, Kernel};
use super::Gpu;
use crate::interrupt::CancelToken;
use crate::model::Model;
use rayon::prelude::*;

/// The std430 twin of `DrawRequest` in `glsl/kernels/sample.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuDrawRequest {
    /// ωo, the unit direction to the viewer, in the local frame.
    pub wo: [f32; 3],
    /// The stream's seed.
    pub seed: u32,
    /// The group of four dimensions (a direction's index in the sampling test).
    pub group: u32,
    /// The first draw's index, low 32 bits.
    pub first_lo: u32,
    /// The first draw's index, high 32 bits.
    pub first_hi: u32,
    /// Padding to the std430 size of 32 bytes; always 0.
    pub pad: u32,
}

/// Floats the kernel stores per draw: ωi (3), pdf, weight (3), delta, pdf at ωi, f cos θi (3).
pub const DRAW_FLOATS: usize = 12;

impl Gpu {
    /// `count` draws of `model`'s sampler for the request's ωo, draws `request.first ..`, with
    /// the parameter block `block`: [`DRAW_FLOATS`] f32 per draw, in order. Stops between
    /// chunks once `cancel` is set; each chunk's wait is bounded as every kernel's is.
    pub fn sample_draws(
        &self,
        model: Model,
        block: &[u8],
        request: GpuDrawRequest,
        count: usize,
        white_furnace: bool,
        cancel: Option<&CancelToken>,
    ) -> std::result::Result<Vec<f32>, anyhow::Error> {
        if count > u32::MAX as usize {
            anyhow::bail!("{count} draws in one request; at most 2^32 - 1");
        }
        let pipe = self.pipeline(Kernel::Sample, model, white_furnace, false)?;
        // max_chunk bounds outputs of 12 bytes; a draw stores 48, a quarter as many per chunk.
        let chunk = ((self.max_chunk(&pipe, 0) / 4).max(1) as usize).min(count.max(1));
        let mut param_buf = Buffer::new(&self.dev, block.len() as u64, "parameter")?;
        param_buf.write(block)?;
        let mut request_buf = Buffer::new(
            &self.dev,
            std::mem::size_of::<GpuDrawRequest>() as u64,
            "draw request",
        )?;
        request_buf.write(bytemuck::bytes_of(&request))?;
        let out_buf = Buffer::output(&self.dev, (chunk * DRAW_FLOATS * 4) as u64, "draws")?;
        let dispatcher = Dispatcher::new(&pipe, &[&param_buf, &request_buf, &out_buf])?;
        let mut out = Vec::with_capacity(count * DRAW_FLOATS);
        let mut done = 0usize;
        while done < count {
            if let Some(c) = cancel {
                c.check()?;
            }
            let n = chunk.min(count - done);
            let push = ChunkPush {
                first: done as u32,
                count: n as u32,
                n_wo: 0,
                n_wi: 0,
            };
            dispatcher.run_one(&push)?;
            out.extend(out_buf.read_f32(n * DRAW_FLOATS));
            done += n;
        }
        Ok(out)
    }
}

/// Word offsets of the counting kernel's tallies in each of its [`CHI2_HISTOGRAM_COPIES`]
/// blocks of tallies and in the counts [`Gpu::chi2_counts`] adds up (twins of the `COUNT_*`
/// constants of `glsl/kernels/chi2.comp`): draws outside the cells (below the horizon or pdf 0),
/// delta draws, invalid draws (ωi or pdf not finite, pdf negative), draws off unit length, draws
/// above the horizon with pdf 0, non-finite weights, draws leaving with a weight, draws below the
/// horizon with a pdf; then the largest relative weight and pdf errors as f32 bits.
pub const COUNT_LOST: usize = 0;
/// See [`COUNT_LOST`].
pub const COUNT_DELTA: usize = 1;
/// See [`COUNT_LOST`].
pub const COUNT_INVALID: usize = 2;
/// See [`COUNT_LOST`].
pub const COUNT_NON_UNIT: usize = 3;
/// See [`COUNT_LOST`].
pub const COUNT_ZERO_PDF: usize = 4;
/// See [`COUNT_LOST`].
pub const COUNT_NON_FINITE_WEIGHT: usize = 5;
/// See [`COUNT_LOST`].
pub const COUNT_WEIGHT_OUTSIDE: usize = 6;
/// See [`COUNT_LOST`].
pub const COUNT_PDF_BELOW: usize = 7;
/// See [`COUNT_LOST`].
pub const COUNT_WEIGHT_ERROR: usize = 8;
/// See [`COUNT_LOST`].
pub const COUNT_PDF_ERROR: usize = 9;
/// The words of a block of tallies (one 64-byte cache line); the cells' counts start at this
/// word of the counts [`Gpu::chi2_counts`] adds up.
pub const COUNT_HEADER: usize = 16;
/// The counting kernel keeps its tallies and the cells' counts this many times over, workgroup
/// w adding to copy w mod CHI2_HISTOGRAM_COPIES (twin of `HISTOGRAM_COPIES` in
/// `glsl/kernels/chi2.comp`), so that concurrent workgroups seldom add to one word at once; the
/// host adds the copies. On lavapipe's two threads the cells' copies took GGX α = 0.3's 10⁸
/// draws from 2.8–2.9 s to 2.4–2.8 s (one copy: the cells' cache lines pass between the cores
/// at nearly every draw), and the tallies' copies took that test's sampling from 1.18–1.21 s to
/// 1.14–1.15 s.
pub const CHI2_HISTOGRAM_COPIES: usize = 16;

/// Draws per dispatch of the counting kernel at most: 2²⁴ keeps each chunk's counts far below
/// 2³² and a chunk well under a second on a CPU driver, so that the cancellation token is
/// heard soon.
const CHI2_CHUNK: u64 = 1 << 24;

/// Draws per dispatch at most where the host counts the cells: 2²¹ cell indices (8 MiB) stay in
/// a CPU's cache between the kernel's stores and the host's counting, and the buffer's pages are
/// touched once.
const HOST_CHUNK: u64 = 1 << 21;

/// Where the counting kernel counts each draw in its cell (its HOST_COUNTS switch).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellCounting {
    /// Each draw adds 1 to its cell in [`CHI2_HISTOGRAM_COPIES`] copies of the cells on the
    /// device, which the host adds up after each chunk: a GPU's way, whose atomic adds are
    /// cheap and whose draws are too many to copy back.
    Device,
    /// Each draw stores its cell index (one word, no atomic) at its place in the chunk, and the
    /// host counts them: a CPU driver's way, where an atomic add is a locked instruction per
    /// lane. On lavapipe's two threads, 10⁸ draws of GGX α = 0.3 took 1.9–2.1 s with atomic
    /// adds against 1.8–1.9 s stored, in one run.
    Host,
}

impl CellCounting {
    /// The way of a device: [`CellCounting::Host`] on a CPU driver, else
    /// [`CellCounting::Device`].
    pub fn for_device(cpu_driver: bool) -> CellCounting {
        if cpu_driver {
            CellCounting::Host
        } else {
            CellCounting::Device
        }
    }
}

/// The counting kernel's cell indices at most per piece of host counting (one rayon task with
/// its own counts).
const HOST_COUNT_PIECE: usize = 1 << 20;

/// Adds one to `cells[i]` for each of `indices` below `cells.len()` (the others are the
/// kernel's `NO_CELL`: draws not counted in a cell), in pieces across the host's threads,
/// which are idle while the host counts.
fn count_indices(indices: &[u32], cells: &mut [u64]) {
    let n = cells.len();
    let pieces: Vec<Vec<u32>> = indices
        .par_chunks(HOST_COUNT_PIECE)
        .map(|piece| {
            let mut counts = vec![0u32; n];
            for &i in piece {
                if let Some(c) = counts.get_mut(i as usize) {
                    *c += 1;
                }
            }
            counts
        })
        .collect();
    for piece in pieces {
        for (total, c) in cells.iter_mut().zip(piece) {
            *total += u64::from(c);
        }
    }
}

impl Gpu {
    /// `count` draws of `model`'s sampler for the request's ωo, draws `request.first ..`,
    /// counted in `n_phi` × `n_cos` cells of (φ, cosθ) with the draw checks
    /// (glsl/kernels/chi2.comp), the first `checked` of them with the weight checks too. Each
    /// chunk's counts are added into `counts` (the tallies at the `COUNT_*` offsets, the
    /// largest errors' f32 bits kept as the larger, then a count per cell from
    /// `COUNT_HEADER`; `COUNT_HEADER + n_phi · n_cos` words), the cells counted where
    /// `cell_counting` says. Stops between chunks once `cancel` is set.
    #[allow(clippy::too_many_arguments)] // the draws' request and the cells, as the kernel takes them
    pub fn chi2_counts(
        &self,
        model: Model,
        block: &[u8],
        request: GpuDrawRequest,
        [count, checked]: [u64; 2],
        [n_phi, n_cos]: [u32; 2],
        (white_furnace, cell_counting): (bool, CellCounting),
        cancel: Option<&CancelToken>,
        counts: &mut [u64],
    ) -> std::result::Result<(), anyhow::Error> {
        let cells = n_phi as usize * n_cos as usize;
        if cells == 0 || counts.len() != COUNT_HEADER + cells {
            anyhow::bail!(
                "{} counts for {n_phi} × {n_cos} cells; expected {}",
                counts.len(),
                COUNT_HEADER + cells
            );
        }
        if count > u32::MAX as u64 {
            anyhow::bail!("{count} draws in one request; at most 2^32 - 1");
        }
        if n_phi > 0xffff || n_cos > 0xffff {
            anyhow::bail!(
                "{n_phi} × {n_cos} cells: the counting kernel takes at most 65535 steps in φ and in cosθ; use fewer cells or the CPU backend"
            );
        }
        let host = cell_counting == CellCounting::Host;
        let tally_words = CHI2_HISTOGRAM_COPIES * COUNT_HEADER;
        let words = tally_words
            + if host {
                0
            } else {
                CHI2_HISTOGRAM_COPIES * cells
            };
        let range = self.dev.limits.max_storage_buffer_range as u64;
        if (words as u64) * 4 > range {
            anyhow::bail!(
                "{n_phi} × {n_cos} cells need {} bytes of counts on the device ({CHI2_HISTOGRAM_COPIES} copies), over its storage buffer range of {range}; use fewer cells or the CPU backend",
                words * 4
            );
        }
        // One pipeline for the checked chunks and one for the others: a CPU driver runs a
        // branch's two sides under masks, and the checks' f and pdf then cost every draw.
        let pipeline = |checks: bool| {
            self.pipeline_with(Kernel::Chi2, model, white_furnace, false, [host, checks])
        };
        let pipe = pipeline(false)?;
        let per_group = (super::pipeline::LOCAL_SIZE * pipe.evals_per_invocation) as u64;
        let by_dispatch = self.dev.limits.max_compute_work_group_count[0] as u64 * per_group;
        let by_range = if host {
            (range / 4).min(HOST_CHUNK)
        } else {
            u64::MAX
        };
        let chunk = CHI2_CHUNK.min(by_dispatch).min(by_range).max(1);
        let mut param_buf = Buffer::new(&self.dev, block.len() as u64, "parameter")?;
        param_buf.write(block)?;
        let mut request_buf = Buffer::new(
            &self.dev,
            std::mem::size_of::<GpuDrawRequest>() as u64,
            "draw request",
        )?;
        request_buf.write(bytemuck::bytes_of(&request))?;
        let counts_buf = Buffer::output(&self.dev, (words * 4) as u64, "counts")?;
        // Device counting never touches the indices; its binding still needs a buffer.
        let index_bytes = if host { chunk.min(count.max(1)) * 4 } else { 4 };
        let indices_buf = Buffer::output(&self.dev, index_bytes, "cell indices")?;
        let buffers = [&param_buf, &request_buf, &counts_buf, &indices_buf];
        let dispatcher = Dispatcher::new(&pipe, &buffers)?;
        // Built only where some draws are checked.
        let checking_pipe = if checked > 0 {
            Some(pipeline(true)?)
        } else {
            None
        };
        let checking = match &checking_pipe {
            Some(p) => Some(Dispatcher::new(p, &buffers)?),
            None => None,
        };
        let mut done = 0u64;
        while done < count {
            if let Some(c) = cancel {
                c.check()?;
            }
            // A chunk's draws are all checked or none: it ends where the checked ones do.
            let checks = done < checked;
            let end = if checks { checked.min(count) } else { count };
            let n = chunk.min(end - done);
            let push = ChunkPush {
                first: done as u32,
                count: n as u32,
                n_wo: n_phi | (n_cos << 16),
                n_wi: 0,
            };
            match (&checking, checks) {
                (Some(d), true) => d.run_one(&push)?,
                _ => dispatcher.run_one(&push)?,
            }
            let got = counts_buf.read_u32(words);
            let (tallies, copies) = got.split_at(tally_words);
            for block in tallies.chunks_exact(COUNT_HEADER) {
                for (k, (total, &c)) in counts.iter_mut().zip(block).enumerate() {
                    if k == COUNT_WEIGHT_ERROR || k == COUNT_PDF_ERROR {
                        // Non-negative floats' bits order as the numbers do.
                        *total = (*total).max(u64::from(c));
                    } else {
                        *total += u64::from(c);
                    }
                }
            }
            if host {
                count_indices(
                    indices_buf.read_u32(n as usize),
                    &mut counts[COUNT_HEADER..],
                );
            }
            for copy in copies.chunks_exact(cells) {
                for (total, &c) in counts[COUNT_HEADER..].iter_mut().zip(copy) {
                    *total += u64::from(c);
                }
            }
            done += n;
        }
        Ok(())
    }
}

/// Fails the build if the request's size drifts from the kernel's 32 bytes.
const _: () = assert!(std::mem::size_of::<GpuDrawRequest>() == 32);
