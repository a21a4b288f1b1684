//! The draws kernel (`glsl/kernels/sample.comp`): the model's sampler for one ωo, draw i with the
//! numbers of [`crate::random::draw_numbers`], in chunks; and the sampling test's counting kernel
//! (`glsl/kernels/chi2.comp`): the same draws counted in cells on the device.

use super::buffer::Buffer;
use super::pipeline::{ChunkPush, Dispatcher, Kernel};
use super::Gpu;
use crate::interrupt::CancelToken;
use crate::model::Model;

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

/// Word offsets of the counting kernel's tallies in its counts buffer (twins of the `COUNT_*`
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
/// The cells' counts start at this word.
pub const COUNT_HEADER: usize = 16;
/// The counting kernel keeps the cells' counts this many times over, workgroup w adding to copy
/// w mod CHI2_HISTOGRAM_COPIES (twin of `HISTOGRAM_COPIES` in `glsl/kernels/chi2.comp`), so that
/// concurrent workgroups seldom add to one cell at once; the host adds the copies. On lavapipe's
/// two threads this took GGX α = 0.3's 10⁸ draws from 2.8–2.9 s to 2.4–2.8 s (one copy: the
/// cells' cache lines pass between the cores at nearly every draw).
pub const CHI2_HISTOGRAM_COPIES: usize = 16;

/// Draws per dispatch of the counting kernel at most: 2²⁴ keeps each chunk's counts far below
/// 2³² and a chunk well under a second on a CPU driver, so that the cancellation token is
/// heard soon.
const CHI2_CHUNK: u64 = 1 << 24;

impl Gpu {
    /// `count` draws of `model`'s sampler for the request's ωo, draws `request.first ..`,
    /// counted in `n_phi` × `n_cos` cells of (φ, cosθ) on the device, with the draw checks
    /// (glsl/kernels/chi2.comp). Each chunk's counts are added into `counts` (the tallies at the
    /// `COUNT_*` offsets, the largest errors' f32 bits kept as the larger, then a count per cell
    /// from `COUNT_HEADER`, the kernel's `CHI2_HISTOGRAM_COPIES` summed;
    /// `COUNT_HEADER + n_phi · n_cos` words). Stops between chunks once
    /// `cancel` is set.
    #[allow(clippy::too_many_arguments)] // the draws' request and the cells, as the kernel takes them
    pub fn chi2_counts(
        &self,
        model: Model,
        block: &[u8],
        request: GpuDrawRequest,
        count: u64,
        [n_phi, n_cos]: [u32; 2],
        white_furnace: bool,
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
        let words = COUNT_HEADER + CHI2_HISTOGRAM_COPIES * cells;
        let range = self.dev.limits.max_storage_buffer_range as u64;
        if (words as u64) * 4 > range {
            anyhow::bail!(
                "{n_phi} × {n_cos} cells need {} bytes of counts on the device ({CHI2_HISTOGRAM_COPIES} copies), over its storage buffer range of {range}; use fewer cells or the CPU backend",
                words * 4
            );
        }
        let pipe = self.pipeline(Kernel::Chi2, model, white_furnace, false)?;
        let per_group = (super::pipeline::LOCAL_SIZE * pipe.evals_per_invocation) as u64;
        let by_dispatch = self.dev.limits.max_compute_work_group_count[0] as u64 * per_group;
        let chunk = CHI2_CHUNK.min(by_dispatch).max(1);
        let mut param_buf = Buffer::new(&self.dev, block.len() as u64, "parameter")?;
        param_buf.write(block)?;
        let mut request_buf = Buffer::new(
            &self.dev,
            std::mem::size_of::<GpuDrawRequest>() as u64,
            "draw request",
        )?;
        request_buf.write(bytemuck::bytes_of(&request))?;
        let counts_buf = Buffer::output(&self.dev, (words * 4) as u64, "counts")?;
        let dispatcher = Dispatcher::new(&pipe, &[&param_buf, &request_buf, &counts_buf])?;
        let mut done = 0u64;
        while done < count {
            if let Some(c) = cancel {
                c.check()?;
            }
            let n = chunk.min(count - done);
            let push = ChunkPush {
                first: done as u32,
                count: n as u32,
                n_wo: n_phi,
                n_wi: n_cos,
            };
            dispatcher.run_one(&push)?;
            let got = counts_buf.read_u32(words);
            let (tallies, copies) = got.split_at(COUNT_HEADER);
            for (k, (total, &c)) in counts.iter_mut().zip(tallies).enumerate() {
                if k == COUNT_WEIGHT_ERROR || k == COUNT_PDF_ERROR {
                    // Non-negative floats' bits order as the numbers do.
                    *total = (*total).max(u64::from(c));
                } else {
                    *total += u64::from(c);
                }
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
