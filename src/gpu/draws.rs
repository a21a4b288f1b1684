//! The draws kernel (`glsl/kernels/sample.comp`): the model's sampler for one ωo, draw i with the
//! numbers of [`crate::random::draw_numbers`], in chunks.

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

/// Fails the build if the request's size drifts from the kernel's 32 bytes.
const _: () = assert!(std::mem::size_of::<GpuDrawRequest>() == 32);
