//! The GPU path of directional albedo (`glsl/kernels/albedo.comp`): E(ωo) = Σ_k w_k f(ωi_k, ωo)
//! as a workgroup reduction. Nothing but one partial sum per workgroup comes back; the host adds
//! each direction's partials in f64. The quadrature rules themselves live in `src/integrate/`.

use super::buffer::Buffer;
use super::pipeline::{ChunkPush, Dispatcher, Kernel, LOCAL_SIZE};
use super::{Gpu, GpuError, Result};
use crate::model::Model;

/// Nodes one invocation sums before the workgroup's tree reduction. 16 keeps the f32 running
/// sums short (16 terms, then log2(64) = 6 tree levels: relative rounding ≲ 22 × 2^-24 ≈ 1.3e-6
/// in the worst case, ~1e-7 typically) while amortising the barriers over many evaluations.
pub const NODES_PER_INVOCATION: u32 = 16;

/// Push constants of `albedo.comp` (`AlbedoJob`). `dispatch_count` sits where [`ChunkPush`] keeps
/// `count`, which the dispatcher turns into the number of workgroups; the test below pins it.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AlbedoPush {
    /// The span of nodes one workgroup sums.
    pub nodes_per_group: u32,
    /// Workgroups times evaluations per workgroup; read by the host's dispatcher only.
    pub dispatch_count: u32,
    /// Nodes per view direction.
    pub n_nodes: u32,
    /// 0 when every view direction shares one node list, else `n_nodes`.
    pub node_stride: u32,
}

/// One (parameter set, view direction) of an albedo dispatch; the std430 twin of `Entry` in
/// `glsl/kernels/albedo.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AlbedoEntry {
    /// ωo, the unit direction to the viewer.
    pub wo: [f32; 3],
    /// Which parameter block evaluates it.
    pub param_index: u32,
    /// Which node list it sums (0 when every entry shares one).
    pub node_list: u32,
    /// Padding to the std430 size of 32 bytes; always 0.
    pub pad: [u32; 3],
}

impl Gpu {
    /// E(ωo) = Σ_k w_k f(ωi_k, ωo) for each `wo[o]` (xyz; w unused), the nodes given as
    /// (ωi.xyz, w): one list of `n_nodes` shared by every ωo, or with `per_wo` one list of
    /// `n_nodes` per ωo, back to back (pad with zero weights). Sums in f32 per workgroup, in f64
    /// across workgroups.
    #[allow(clippy::too_many_arguments)]
    pub fn albedo(
        &self,
        model: Model,
        block: &[u8],
        white_furnace: bool,
        wo: &[[f32; 4]],
        nodes: &[[f32; 4]],
        n_nodes: usize,
        per_wo: bool,
    ) -> Result<Vec<[f64; 3]>> {
        let blocks = [block.to_vec()];
        let mut rows =
            self.albedo_rows(model, &blocks, white_furnace, wo, nodes, n_nodes, per_wo)?;
        Ok(rows.pop().unwrap_or_default())
    }

    /// [`Gpu::albedo`] for several parameter sets of one model at once (`blocks`, std430
    /// parameter blocks): row r of the result holds E of `blocks[r]` at every ωo. The nodes are
    /// uploaded once and serve every row; the (row, ωo) entries go out in as few dispatches as
    /// the device's workgroup count allows.
    #[allow(clippy::too_many_arguments)]
    pub fn albedo_rows(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        white_furnace: bool,
        wo: &[[f32; 4]],
        nodes: &[[f32; 4]],
        n_nodes: usize,
        per_wo: bool,
    ) -> Result<Vec<Vec<[f64; 3]>>> {
        let mut buf = self.albedo_nodes(nodes.len())?;
        buf.fill(nodes.len(), |d| d.copy_from_slice(nodes))?;
        self.albedo_rows_in(model, blocks, white_furnace, wo, &buf, n_nodes, per_wo)
    }

    /// A node buffer for [`Gpu::albedo_rows_in`] of `capacity` nodes, made once and filled
    /// again for each batch of directions (no fresh memory per batch).
    pub fn albedo_nodes(&self, capacity: usize) -> Result<AlbedoNodes<'_>> {
        let range = self.dev.limits.max_storage_buffer_range as u64;
        let bytes = 16 * capacity as u64;
        if bytes > range {
            return Err(GpuError::Limit(format!(
                "albedo: {capacity} nodes need {bytes} bytes, over this device's storage buffer range of {range}; use fewer nodes per direction"
            )));
        }
        Ok(AlbedoNodes {
            buf: Buffer::new(&self.dev, bytes, "albedo node")?,
            capacity,
            len: 0,
        })
    }

    /// [`Gpu::albedo_rows`] on the nodes of `nodes` (as filled last).
    #[allow(clippy::too_many_arguments)]
    pub fn albedo_rows_in(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        white_furnace: bool,
        wo: &[[f32; 4]],
        nodes: &AlbedoNodes<'_>,
        n_nodes: usize,
        per_wo: bool,
    ) -> Result<Vec<Vec<[f64; 3]>>> {
        let expected = if per_wo { n_nodes * wo.len() } else { n_nodes };
        if nodes.len != expected {
            return Err(GpuError::Limit(format!(
                "albedo: {} nodes given, {expected} expected ({n_nodes} per direction, {} directions, per_wo = {per_wo})",
                nodes.len,
                wo.len()
            )));
        }
        if wo.is_empty() || n_nodes == 0 || blocks.is_empty() {
            return Ok(vec![vec![[0.0; 3]; wo.len()]; blocks.len()]);
        }
        let limits = &self.dev.limits;
        let max_groups = limits.max_compute_work_group_count[0] as u64;
        // The texel view covers the first maxTexelBufferElements nodes of the buffer.
        let texel_nodes =
            self.dev.is_cpu() && nodes.len as u64 <= limits.max_texel_buffer_elements as u64;
        let pipe = self.pipeline_with(Kernel::Albedo, model, white_furnace, false, texel_nodes)?;
        // The span per workgroup: NODES_PER_INVOCATION per invocation, more if one direction
        // would otherwise need more workgroups than one dispatch may have.
        let mut span = (LOCAL_SIZE * NODES_PER_INVOCATION) as u64;
        let n = n_nodes as u64;
        if n.div_ceil(span) > max_groups {
            span = n.div_ceil(max_groups).div_ceil(LOCAL_SIZE as u64) * LOCAL_SIZE as u64;
        }
        let groups_per_wo = n.div_ceil(span);
        // Entries (row, ωo), row-major, in chunks the workgroup count allows.
        let entries: Vec<AlbedoEntry> = (0..blocks.len())
            .flat_map(|r| {
                wo.iter().enumerate().map(move |(o, w)| AlbedoEntry {
                    wo: [w[0], w[1], w[2]],
                    param_index: r as u32,
                    node_list: if per_wo { o as u32 } else { 0 },
                    pad: [0; 3],
                })
            })
            .collect();
        let per_chunk = ((max_groups / groups_per_wo).max(1) as usize).min(entries.len());
        let per_group = (LOCAL_SIZE * pipe.evals_per_invocation) as u64;

        let params: Vec<u8> = blocks.concat();
        let mut param_buf = Buffer::new(&self.dev, params.len() as u64, "parameter")?;
        param_buf.write(&params)?;
        let node_buf = &nodes.buf;
        let entry_bytes = std::mem::size_of::<AlbedoEntry>() as u64;
        let mut entry_buf = Buffer::new(&self.dev, entry_bytes * per_chunk as u64, "albedo entry")?;
        let groups_max = groups_per_wo * per_chunk as u64;
        let out_buf = Buffer::output(&self.dev, 12 * groups_max, "albedo partial sum")?;
        let dispatcher = Dispatcher::new(
            &pipe,
            &[&param_buf, node_buf, &entry_buf, &out_buf, node_buf],
        )?;
        let mut sums = Vec::with_capacity(entries.len());
        for part in entries.chunks(per_chunk) {
            entry_buf.write(bytemuck::cast_slice(part))?;
            let groups = groups_per_wo * part.len() as u64;
            let push = AlbedoPush {
                nodes_per_group: span as u32,
                dispatch_count: (groups * per_group) as u32,
                n_nodes: n_nodes as u32,
                node_stride: if per_wo { n_nodes as u32 } else { 0 },
            };
            dispatcher.run_one(&bytemuck::cast::<AlbedoPush, ChunkPush>(push))?;
            let partials = out_buf.read_f32(groups as usize * 3);
            for o in 0..part.len() {
                let mut sum = [0.0f64; 3];
                let g0 = o * groups_per_wo as usize;
                for g in g0..g0 + groups_per_wo as usize {
                    for (ch, s) in sum.iter_mut().enumerate() {
                        *s += partials[3 * g + ch] as f64;
                    }
                }
                sums.push(sum);
            }
        }
        Ok(sums.chunks(wo.len()).map(<[_]>::to_vec).collect())
    }
}

/// The node list of [`Gpu::albedo_rows_in`]: one buffer of (ωi.xyz, w) nodes, mapped once and
/// written in place by [`AlbedoNodes::fill`] for each batch of directions.
pub struct AlbedoNodes<'d> {
    buf: Buffer<'d>,
    capacity: usize,
    len: usize,
}

impl AlbedoNodes<'_> {
    /// How many nodes the buffer holds at most.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Lets `fill` write the first `len` nodes in place (every one of them: the buffer holds
    /// the previous batch's nodes); they are what the next [`Gpu::albedo_rows_in`] sums.
    pub fn fill(&mut self, len: usize, fill: impl FnOnce(&mut [[f32; 4]])) -> Result<()> {
        if len > self.capacity {
            return Err(GpuError::Limit(format!(
                "albedo: {len} nodes into a buffer of {}",
                self.capacity
            )));
        }
        self.len = len;
        self.buf
            .write_in_place(16 * len, |bytes| fill(bytemuck::cast_slice_mut(bytes)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn albedo_entry_has_its_std430_size() {
        assert_eq!(size_of::<AlbedoEntry>(), 32);
        assert_eq!(offset_of!(AlbedoEntry, param_index), 12);
        assert_eq!(offset_of!(AlbedoEntry, node_list), 16);
    }

    #[test]
    fn albedo_push_shares_the_dispatch_count_slot() {
        assert_eq!(size_of::<AlbedoPush>(), size_of::<ChunkPush>());
        assert_eq!(
            offset_of!(AlbedoPush, dispatch_count),
            offset_of!(ChunkPush, count)
        );
    }
}
