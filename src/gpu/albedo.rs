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
        let expected = if per_wo { n_nodes * wo.len() } else { n_nodes };
        if nodes.len() != expected {
            return Err(GpuError::Limit(format!(
                "albedo: {} nodes given, {expected} expected ({n_nodes} per direction, {} directions, per_wo = {per_wo})",
                nodes.len(),
                wo.len()
            )));
        }
        if wo.is_empty() || n_nodes == 0 {
            return Ok(vec![[0.0; 3]; wo.len()]);
        }
        let pipe = self.pipeline(Kernel::Albedo, model, white_furnace, false)?;
        let limits = &self.dev.limits;
        let max_groups = limits.max_compute_work_group_count[0] as u64;
        let range = limits.max_storage_buffer_range as u64;
        // The span per workgroup: NODES_PER_INVOCATION per invocation, more if one direction
        // would otherwise need more workgroups than one dispatch may have.
        let mut span = (LOCAL_SIZE * NODES_PER_INVOCATION) as u64;
        let n = n_nodes as u64;
        if n.div_ceil(span) > max_groups {
            span = n.div_ceil(max_groups).div_ceil(LOCAL_SIZE as u64) * LOCAL_SIZE as u64;
        }
        let groups_per_wo = n.div_ceil(span);
        let node_bytes = 16 * n;
        if node_bytes > range {
            return Err(GpuError::Limit(format!(
                "albedo: {n_nodes} nodes per direction need {node_bytes} bytes, over this device's storage buffer range of {range}; use fewer nodes per direction"
            )));
        }
        // Directions per dispatch: bounded by the workgroup count, and with per-direction nodes
        // by the buffer range and a memory budget (crate::gpu::CHUNK_OUTPUT_BYTES).
        let mut wo_per_chunk = (max_groups / groups_per_wo).max(1);
        if per_wo {
            wo_per_chunk =
                wo_per_chunk.min((super::CHUNK_OUTPUT_BYTES.min(range) / node_bytes).max(1));
        }
        let wo_per_chunk = wo_per_chunk.min(wo.len() as u64) as usize;
        let per_group = (LOCAL_SIZE * pipe.evals_per_invocation) as u64;

        let mut param_buf = Buffer::new(&self.dev, block.len() as u64, "parameter")?;
        param_buf.write(block);
        let node_count = if per_wo {
            n_nodes * wo_per_chunk
        } else {
            n_nodes
        };
        let mut node_buf = Buffer::new(&self.dev, 16 * node_count as u64, "albedo node")?;
        if !per_wo {
            node_buf.write(bytemuck::cast_slice(nodes));
        }
        let mut wo_buf = Buffer::new(&self.dev, 16 * wo_per_chunk as u64, "view direction")?;
        let groups_max = groups_per_wo * wo_per_chunk as u64;
        let out_buf = Buffer::new(&self.dev, 12 * groups_max, "albedo partial sum")?;
        let dispatcher = Dispatcher::new(&pipe, &[&param_buf, &node_buf, &wo_buf, &out_buf])?;
        let mut out = Vec::with_capacity(wo.len());
        for (c, part) in wo.chunks(wo_per_chunk).enumerate() {
            wo_buf.write(bytemuck::cast_slice(part));
            if per_wo {
                let first = c * wo_per_chunk * n_nodes;
                node_buf.write(bytemuck::cast_slice(
                    &nodes[first..first + part.len() * n_nodes],
                ));
            }
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
                out.push(sum);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn albedo_push_shares_the_dispatch_count_slot() {
        assert_eq!(size_of::<AlbedoPush>(), size_of::<ChunkPush>());
        assert_eq!(
            offset_of!(AlbedoPush, dispatch_count),
            offset_of!(ChunkPush, count)
        );
    }
}
