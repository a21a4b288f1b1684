//! The Vulkan compute runner: device, buffers, pipelines, dispatch, read-back. Work larger than
//! one buffer binding or one dispatch is split into chunks; buffers are sized for one chunk, so
//! memory stays bounded whatever the job's size.

pub mod albedo_kernel;
mod backend;
pub mod buffer;
pub mod device;
mod draws;
pub mod error;
mod light;
pub mod pipeline;
pub mod preview;
pub mod spirv;
mod sums;

use crate::model::Model;
use buffer::{Buffer, TableInput};
pub use device::{Device, DeviceOptions};
pub use draws::{
    CellCounting, GpuDrawRequest, CHI2_HISTOGRAM_COPIES, COUNT_HEADER, COUNT_LOST, COUNT_PDF_ERROR,
    COUNT_WEIGHT_ERROR, DRAW_FLOATS,
};
pub use error::{GpuError, Result, INSTALL_HINT};
use pipeline::{ChunkPush, Dispatcher, Kernel, Pipeline, TableWalk};
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// Where progress notes go (a pipeline built, and its build time); the CLI prints them to stderr
/// when `LOBE_LOG=1`.
pub type LogSink = Arc<dyn Fn(&str) + Send + Sync>;

/// Locks a mutex whose data stays consistent even if a holder panicked (a cache, a list).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// How long one chunk may run before we call the device hung.
pub const CHUNK_TIMEOUT: Duration = Duration::from_secs(300);

/// Bytes of output per chunk: large enough to amortise a submit, small enough to stay well under
/// lavapipe's 128 MiB binding limit and to keep memory bounded.
pub const CHUNK_OUTPUT_BYTES: u64 = 48 << 20;

/// What the pairs kernel stores at each pair (the chunk's third push-constant word): twin of
/// `PAIRS_F` and `PAIRS_DENSITY` in `glsl/kernels/pairs.comp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
enum PairsOutput {
    /// f, three channels.
    F = 0,
    /// The model's sampling density, in the first channel.
    Density = 1,
}

/// One direction pair for the pairs kernel; the std430 twin of `Pair` in `glsl/kernels/pairs.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuPair {
    /// ωi, the unit direction to the light, in the local frame.
    pub wi: [f32; 3],
    /// Index of the parameter block that evaluates this pair.
    pub param_index: u32,
    /// ωo, the unit direction to the viewer, in the local frame.
    pub wo: [f32; 3],
    /// Padding to the std430 size of 32 bytes; always 0.
    pub pad: u32,
}

/// What tells pipelines apart: the kernel, the model (with its component choices), the
/// white-furnace and fast-pow specialization constants, the kernel's own switch
/// ([`Pipeline::kernel_switches`]) and the table walk.
type PipelineKey = (Kernel, Model, bool, bool, [bool; 2], TableWalk);

/// The specialization switches of a table pipeline.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TableSwitches {
    /// Every Fresnel factor of a specular lobe replaced by 1.
    pub white_furnace: bool,
    /// cos^n lobes by GLSL's plain pow (exp2(n log2 x)): a speed-for-accuracy variant.
    pub fast_pow: bool,
    /// Only the cells with θo index ≥ θi index of an isotropic table with equal θ axes, packed
    /// row after row ([`crate::backend::UpperTriangle`], docs/design.md §4.5).
    pub upper_triangle: bool,
}

/// Receives each finished chunk of a table: its first cell's index and its RGB values.
pub type TableSink<'a, E> = dyn FnMut(u64, &[f32]) -> std::result::Result<(), E> + 'a;

/// The pipelines built so far on one device; each is built on first use only. `Send` and `Sync`:
/// the cache is behind a mutex and queue submissions are serialised by the device.
pub struct Gpu {
    dev: Arc<Device>,
    pipelines: Mutex<HashMap<PipelineKey, Arc<Pipeline>>>,
    built: Mutex<Vec<(String, Duration)>>,
    log: Option<LogSink>,
    /// The table runner's buffers, kept from one table to the next.
    table_buffers: Mutex<Option<buffer::KeptTable>>,
    /// Output bytes per table chunk in place of the device kind's ([`table_choice`]).
    table_chunk_bytes: Option<u64>,
}

impl Gpu {
    /// A runner on `dev` with an empty pipeline cache.
    pub fn new(dev: Device) -> Gpu {
        Gpu {
            dev: Arc::new(dev),
            pipelines: Mutex::default(),
            built: Mutex::default(),
            log: None,
            table_buffers: Mutex::default(),
            table_chunk_bytes: None,
        }
    }

    /// Tables in chunks of about `bytes` of output (at least one workgroup's cells) instead
    /// of the device kind's [`CPU_TABLE_CHUNK_BYTES`] or [`CHUNK_OUTPUT_BYTES`]: lets a test
    /// run a small table in several chunks.
    pub fn with_table_chunk_bytes(mut self, bytes: u64) -> Gpu {
        self.table_chunk_bytes = Some(bytes);
        self
    }

    /// Sends a note to `log` for every pipeline built, with its build time.
    pub fn with_log(mut self, log: Option<LogSink>) -> Gpu {
        self.log = log;
        self
    }

    /// The device the pipelines run on.
    pub fn device(&self) -> &Device {
        &self.dev
    }

    /// The pipeline for `key`, built on first use. The cache stays locked while one builds, so
    /// that two threads asking for the same pipeline build it once.
    fn pipeline(
        &self,
        kernel: Kernel,
        model: Model,
        white_furnace: bool,
        fast_pow: bool,
    ) -> Result<Arc<Pipeline>> {
        self.pipeline_with(kernel, model, white_furnace, fast_pow, [false; 2])
    }

    /// [`Gpu::pipeline`] with the kernel's own switches ([`Pipeline::kernel_switches`]).
    fn pipeline_with(
        &self,
        kernel: Kernel,
        model: Model,
        white_furnace: bool,
        fast_pow: bool,
        kernel_switches: [bool; 2],
    ) -> Result<Arc<Pipeline>> {
        self.pipeline_keyed((
            kernel,
            model,
            white_furnace,
            fast_pow,
            kernel_switches,
            TableWalk::default(),
        ))
    }

    /// The pipeline for `key`, built on first use (see [`Gpu::pipeline`]).
    fn pipeline_keyed(&self, key: PipelineKey) -> Result<Arc<Pipeline>> {
        let (kernel, model, white_furnace, fast_pow, kernel_switches, walk) = key;
        let mut cache = lock(&self.pipelines);
        if let Some(p) = cache.get(&key) {
            return Ok(p.clone());
        }
        let source = model
            .kernel_source(kernel.name())
            .ok_or_else(|| GpuError::MissingKernel {
                kernel: kernel.name().into(),
                model: model.name().into(),
            })?;
        let p = Arc::new(Pipeline::new(
            &self.dev,
            kernel,
            &source,
            white_furnace,
            fast_pow,
            kernel_switches,
            walk,
        )?);
        if let Some(log) = &self.log {
            log(&format!(
                "built pipeline {} in {:.1} ms",
                p.label,
                p.build_time.as_secs_f64() * 1e3
            ));
        }
        lock(&self.built).push((p.label.clone(), p.build_time));
        cache.insert(key, p.clone());
        Ok(p)
    }

    /// GPU time (from timestamp queries) of every dispatch since the last call, or None where
    /// the device has no timestamps.
    pub fn take_gpu_time(&self) -> Option<Duration> {
        if self.dev.timestamp_bits == 0 {
            return None;
        }
        let ns: u64 = lock(&self.pipelines)
            .values()
            .map(|p| p.gpu_ns.swap(0, Ordering::Relaxed))
            .sum();
        Some(Duration::from_nanos(ns))
    }

    /// Every pipeline built so far, with its build time.
    pub fn built_pipelines(&self) -> Vec<(String, Duration)> {
        lock(&self.built).clone()
    }

    fn max_chunk(&self, pipe: &Pipeline, in_bytes_per_eval: u64) -> u64 {
        let range = self.dev.limits.max_storage_buffer_range as u64;
        let per_group = (pipeline::LOCAL_SIZE * pipe.evals_per_invocation) as u64;
        let by_dispatch = self.dev.limits.max_compute_work_group_count[0] as u64 * per_group;
        let by_output = CHUNK_OUTPUT_BYTES.min(range) / 12;
        let by_input = range.checked_div(in_bytes_per_eval).unwrap_or(u64::MAX);
        by_dispatch.min(by_output).min(by_input).max(1)
    }

    /// f at explicit pairs; `blocks` are std430 parameter blocks and each pair names its block.
    pub fn eval_pairs(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        pairs: &[GpuPair],
        white_furnace: bool,
    ) -> Result<Vec<[f32; 3]>> {
        self.pairs_kernel(model, blocks, pairs, white_furnace, PairsOutput::F)
    }

    /// The model's sampling density (the kernels' `pdf_at`, twin of `Reference::pdf`) at
    /// explicit pairs, as [`Gpu::eval_pairs`] takes them.
    pub fn pdf_pairs(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        pairs: &[GpuPair],
        white_furnace: bool,
    ) -> Result<Vec<f32>> {
        let out = self.pairs_kernel(model, blocks, pairs, white_furnace, PairsOutput::Density)?;
        Ok(out.into_iter().map(|v| v[0]).collect())
    }

    fn pairs_kernel(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        pairs: &[GpuPair],
        white_furnace: bool,
        output: PairsOutput,
    ) -> Result<Vec<[f32; 3]>> {
        let pipe = self.pipeline(Kernel::Pairs, model, white_furnace, false)?;
        let params: Vec<u8> = blocks.concat();
        let chunk = (self.max_chunk(&pipe, std::mem::size_of::<GpuPair>() as u64) as usize)
            .min(pairs.len().max(1));
        let mut param_buf = Buffer::new(&self.dev, params.len() as u64, "parameter")?;
        param_buf.write(&params)?;
        let mut pair_buf = Buffer::new(
            &self.dev,
            (chunk * std::mem::size_of::<GpuPair>()) as u64,
            "direction pair",
        )?;
        let out_buf = Buffer::output(&self.dev, (chunk * 12) as u64, "output")?;
        let dispatcher = Dispatcher::new(&pipe, &[&param_buf, &pair_buf, &out_buf])?;
        let mut out = Vec::with_capacity(pairs.len());
        for (k, part) in pairs.chunks(chunk).enumerate() {
            pair_buf.write(bytemuck::cast_slice(part))?;
            let push = ChunkPush {
                first: (k * chunk) as u32,
                count: part.len() as u32,
                n_wo: output as u32,
                n_wi: 0,
            };
            dispatcher.run_one(&push)?;
            out.extend(
                out_buf
                    .read_f32(part.len() * 3)
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]]),
            );
        }
        Ok(out)
    }

    /// The outer product table f(`wi[i]`, `wo[o]`), cell = i * wo.len() + o, handed to `sink` one
    /// chunk at a time as (first cell, rgb values). With `switches.upper_triangle`, only the
    /// packed cells of [`crate::backend::UpperTriangle`] (wo.len() a multiple of wi.len()), and
    /// "cell" counts packed cells.
    pub fn eval_table<E: From<GpuError>>(
        &self,
        model: Model,
        block: &[u8],
        wi: &[[f32; 4]],
        wo: &[[f32; 4]],
        switches: TableSwitches,
        sink: &mut TableSink<'_, E>,
    ) -> std::result::Result<(), E> {
        let TableSwitches {
            white_furnace,
            fast_pow,
            upper_triangle,
        } = switches;
        let cells = table_cells(wi.len() as u64, wo.len() as u64, upper_triangle)?;
        if wi.is_empty() || wo.is_empty() {
            return Ok(());
        }
        let choice = table_choice(
            self.dev.cpu_kernels(),
            self.dev.limits.max_texel_buffer_elements as u64,
            wi.len() as u64,
            wo.len() as u64,
        );
        // A row: the view cells from one light direction on (NDPHI of them per θo with the upper
        // triangle, whose rows hold whole θo blocks).
        let row = if upper_triangle {
            wo.len() / wi.len()
        } else {
            wo.len()
        };
        let (evals, row_aligned) =
            pipeline::table_evals_per_invocation(self.dev.cpu_kernels(), row as u64);
        let walk = TableWalk {
            evals,
            upper_triangle,
            row_aligned,
            interleaved: row_aligned
                && evals.is_multiple_of(8)
                && model.info().interleave_table
                && table_interleaves(self.dev.cpu_kernels(), self.dev.driver()),
        };
        let pipe = self.pipeline_keyed((
            Kernel::Table,
            model,
            white_furnace,
            fast_pow,
            [choice.texel_directions, false],
            walk,
        ))?;
        // Whole invocations per chunk, so that every chunk but the last starts on an
        // invocation's first cell (the kernel's `first` is a multiple of its evaluations).
        let per_group = (pipeline::LOCAL_SIZE * pipe.evals_per_invocation) as u64;
        let whole = |bytes: u64| (bytes / 12 / per_group).max(1) * per_group;
        let by_range = whole(self.dev.limits.max_storage_buffer_range as u64);
        let by_dispatch = self.dev.limits.max_compute_work_group_count[0] as u64 * per_group;
        let chunk = chunk_cells(
            cells,
            whole(self.table_chunk_bytes.unwrap_or(choice.chunk_bytes)),
            by_range.min(by_dispatch),
            per_group,
        );
        // The buffers are kept from one table to the next (buffer::KeptTable). Two output
        // buffers, each with its own dispatcher: while the sink takes one chunk, the next one
        // runs into the other buffer. They are sized for whole invocations (the kernel writes
        // the last invocation's cells past the chunk's end into the padding). One chunk is
        // queued at a time: lavapipe (Mesa 22.3.6 and 25.0.7, measured) signals a submission's
        // fence only once the queue has run dry, so with the next chunk queued first, the wait
        // returned after both chunks, and the sink then ran while the device sat idle.
        let mut kept = lock(&self.table_buffers)
            .take()
            .unwrap_or_else(|| buffer::KeptTable::new(&self.dev));
        kept.reserve_outputs(chunk * 12)?;
        kept.write_input(TableInput::Params, block)?;
        kept.write_input(TableInput::Lights, bytemuck::cast_slice(wi))?;
        kept.write_input(TableInput::Views, bytemuck::cast_slice(wo))?;
        let ([param_buf, wi_buf, wo_buf], outs, flags) = kept.buffers();
        let dispatchers = [
            Dispatcher::new(
                &pipe,
                &[
                    param_buf, wi_buf, wo_buf, &outs[0], wi_buf, wo_buf, &flags[0],
                ],
            )?,
            Dispatcher::new(
                &pipe,
                &[
                    param_buf, wi_buf, wo_buf, &outs[1], wi_buf, wo_buf, &flags[1],
                ],
            )?,
        ];
        let push_at = |first: u64| ChunkPush {
            first: first as u32,
            count: chunk.min(cells - first) as u32,
            n_wo: wo.len() as u32,
            n_wi: wi.len() as u32,
        };
        let firsts: Vec<u64> = (0..cells).step_by(chunk as usize).collect();
        dispatchers[0].submit(&push_at(firsts[0]))?;
        for (k, &first) in firsts.iter().enumerate() {
            let slot = k % 2;
            dispatchers[slot].wait()?;
            if let Some(&next) = firsts.get(k + 1) {
                dispatchers[1 - slot].submit(&push_at(next))?;
            }
            let count = chunk.min(cells - first) as usize;
            // The kernel flags any invalid value it makes (its padding's too), so that the
            // sink reads an unflagged chunk for them no more (the host's pass over each chunk
            // took 0.1 ms of its 1.4, with the device waiting).
            let valid = flags[slot].read_u32(1)[0] == 0;
            CHUNK_VALID.with(|v| v.set(valid));
            let sunk = sink(first, outs[slot].read_f32(count * 3));
            CHUNK_VALID.with(|v| v.set(false));
            sunk?;
        }
        drop(dispatchers);
        *lock(&self.table_buffers) = Some(kept);
        Ok(())
    }
}

thread_local! {
    /// Whether the table chunk being handed to a sink on this thread was flagged free of
    /// invalid values by the kernel ([`crate::backend::Backend::table_chunk_valid`]).
    static CHUNK_VALID: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether the table chunk being handed to a sink on this thread holds only valid values, as
/// the table kernel found them: false outside a sink.
pub fn table_chunk_valid() -> bool {
    CHUNK_VALID.with(|v| v.get())
}

/// The cells the table kernel makes for lists of `n_wi` and `n_wo` directions: every cell, or
/// with `upper_triangle` the packed cells of [`crate::backend::UpperTriangle`]. Refuses a table
/// whose cell index does not fit the kernel's 32 bits (nor then n(n + 1) in its upper-triangle
/// start), and an upper triangle whose view list is not NTHETA × NDPHI directions.
fn table_cells(n_wi: u64, n_wo: u64, upper_triangle: bool) -> Result<u64> {
    let product = n_wi * n_wo;
    if product > u32::MAX as u64 {
        return Err(GpuError::Limit(format!(
            "a table of {product} cells exceeds the GPU kernel's 32-bit cell index (at most {})",
            u32::MAX
        )));
    }
    if !upper_triangle {
        return Ok(product);
    }
    let n_dphi = n_wo.checked_div(n_wi).unwrap_or(0);
    if n_dphi * n_wi != n_wo {
        return Err(GpuError::Limit(format!(
            "an upper-triangle table needs a view list of NTHETA x NDPHI directions; {n_wo} is \
             not a multiple of the {n_wi} light directions"
        )));
    }
    Ok(crate::backend::UpperTriangle::new(n_wi, n_dphi).cells())
}

/// Cells per chunk of a table of `cells` cells: at most `target` (or a quarter more, where that
/// saves a last chunk of less than a quarter of the others: each chunk costs the device a wait
/// for the host, about 0.1 ms on lavapipe), never more than `limit`, as even as whole groups of
/// `per_group` cells allow. `target` and `limit` are multiples of `per_group`.
pub fn chunk_cells(cells: u64, target: u64, limit: u64, per_group: u64) -> u64 {
    let target = target.min(limit);
    let mut count = cells.div_ceil(target).max(1);
    if count > 1 && cells.div_ceil(count - 1) <= (target + target / 4).min(limit) {
        count -= 1;
    }
    (cells.div_ceil(count).div_ceil(per_group) * per_group).min(limit)
}

/// Whether the table kernel runs a row-aligned invocation's 8 evaluations as one interleaved
/// stretch of code (INTERLEAVED in glsl/kernels/table.comp) on a device with this `driver`
/// ("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"): on CPU drivers before Mesa 25, where it was measured
/// faster (the out-of-order core then overlaps one evaluation's chain of square roots and
/// divisions with the next one's). Mesa 25.0.7 compiles it with many more spills and ran it
/// slower; on a GPU, other invocations hide that latency.
pub fn table_interleaves(cpu_driver: bool, driver: &str) -> bool {
    cpu_driver && mesa_major(driver).is_some_and(|major| major < 25)
}

/// The major release of Mesa named in a driver string ("llvmpipe Mesa 22.3.6 …" → 22).
fn mesa_major(driver: &str) -> Option<u32> {
    let after = driver.split_once("Mesa ")?.1;
    after
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

/// How the table kernel runs on a device: the host's choices, made once per job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TableChoice {
    /// Read the direction lists as texel buffers (TEXEL_DIRECTIONS).
    pub texel_directions: bool,
    /// Bytes of output per chunk.
    pub chunk_bytes: u64,
}

/// Output bytes per chunk of a table on a CPU driver: few chunks, since each costs the device a
/// wait for the host (about 0.1 ms on lavapipe), in buffers that stay small. Against 4 MiB, the
/// roughconductor table of `lobe bench` (25 MB of output) ran ×1.01–1.05 faster on Mesa 25.0.7
/// and ×1.03–1.06 on Mesa 22.3.6 (three sets of paired rounds), though its kernel ran ×0.97–0.98
/// as fast in the larger chunks.
pub const CPU_TABLE_CHUNK_BYTES: u64 = 8 << 20;

/// The table kernel's choices for a device: on a CPU driver (`cpu_driver`) texel-buffer
/// direction lists, where both lists fit `max_texel_elements`, and small chunks; on a GPU
/// storage buffers (coalesced loads are as fast there) and [`CHUNK_OUTPUT_BYTES`] chunks (fewer
/// submits).
pub fn table_choice(
    cpu_driver: bool,
    max_texel_elements: u64,
    n_wi: u64,
    n_wo: u64,
) -> TableChoice {
    if cpu_driver {
        TableChoice {
            texel_directions: n_wi.max(n_wo) <= max_texel_elements,
            chunk_bytes: CPU_TABLE_CHUNK_BYTES,
        }
    } else {
        TableChoice {
            texel_directions: false,
            chunk_bytes: CHUNK_OUTPUT_BYTES,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Chunks hold whole groups, stay within the limit, cover the table in the fewest chunks of
    /// at most 5/4 of the target, and come out even.
    #[test]
    fn chunks_are_even_and_a_small_last_one_is_shared_out() {
        let g = 4096;
        for cells in [
            1, 4095, 4096, 100_000, 348_160, 700_000, 2_113_536, 50_000_000,
        ] {
            for (target, limit) in [
                (85 * g, 85 * g),
                (85 * g, 1 << 30),
                (g, g),
                (85 * g, 40 * g),
            ] {
                let chunk = chunk_cells(cells, target, limit, g);
                let count = cells.div_ceil(chunk);
                assert_eq!(chunk % g, 0);
                assert!(chunk <= limit, "{cells} {target} {limit}: {chunk}");
                let soft = (target + target / 4).min(limit);
                assert!(chunk <= soft);
                assert!(count <= cells.div_ceil(target.min(limit)));
                // Even: the last chunk falls short of the others only by their rounding up to
                // whole groups (less than g + 1 cells each).
                let last = cells - (count - 1) * chunk;
                assert!(chunk - last < count * (g + 1), "{cells}: {chunk} {last}");
            }
        }
        // The benchmark's upper triangle (2 113 536 cells): in 4 MiB chunks, six of 352 256
        // cells rather than six full ones and a last one of 24 576; in 8 MiB chunks
        // (CPU_TABLE_CHUNK_BYTES), three of 704 512 rather than three and one of 24 576.
        assert_eq!(chunk_cells(2_113_536, 85 * g, 1 << 30, g), 352_256);
        assert_eq!(chunk_cells(2_113_536, 170 * g, 1 << 30, g), 704_512);
    }

    /// The drivers this rule was measured on, and strings without a Mesa release.
    #[test]
    fn interleaving_follows_the_mesa_release() {
        assert_eq!(mesa_major("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"), Some(22));
        assert_eq!(
            mesa_major("llvmpipe Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"),
            Some(25)
        );
        assert_eq!(mesa_major("NVIDIA 560.35.03"), None);
        assert!(table_interleaves(
            true,
            "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"
        ));
        assert!(!table_interleaves(
            true,
            "llvmpipe Mesa 25.0.7 (LLVM 15.0.6)"
        ));
        assert!(!table_interleaves(false, "radv Mesa 22.3.6"));
        assert!(!table_interleaves(true, "an unknown CPU driver"));
    }
}
