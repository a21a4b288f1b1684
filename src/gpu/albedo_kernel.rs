//! The GPU path of directional albedo (`glsl/kernels/albedo.comp`): E(ωo) = Σ_k w_k f(ωi_k, ωo)
//! as a reduction. Nothing but partial sums come back (one per workgroup, or on a CPU driver one
//! per invocation); the host adds each sum's partials in f64. The quadrature rules themselves
//! live in `src/integrate/`.

use super::buffer::Buffer;
use super::pipeline::{albedo_lane_partials, ChunkPush, Dispatcher, Kernel, LOCAL_SIZE};
use super::{Gpu, GpuError, GpuPair, Result};
use crate::finite::InvalidCount;
use crate::model::Model;
use glam::DVec3;

/// Nodes one invocation sums on a GPU (a workgroup's span is [`LOCAL_SIZE`] times this): 16
/// terms in f32, then log2(64) = 6 levels of the workgroup's tree, so at most 22 roundings
/// (≲ 22 × 2^-24 ≈ 1.3e-6 relative, ~1e-7 typically).
pub const NODES_PER_INVOCATION: u32 = 16;

/// Nodes one invocation sums on a CPU driver, where each invocation writes its own partial
/// (LANE_PARTIALS): four running sums of at most 16 terms each, added pairwise (18 roundings at
/// most), then the host's f64 sum. Four times the GPU's span means a quarter of the partials to
/// read back and add. Twin of LANE_SPAN_NODES in glsl/kernels/albedo.comp, whose loop over a
/// whole span tests no bounds.
pub const LANE_NODES_PER_INVOCATION: u32 = 64;

/// Nodes one albedo dispatch sums at most: 64M, about 0.1–3 s on lavapipe here depending on the
/// model, so that a model's own bound on each wait (`Model::chunk_timeout`, a `.brdf` shader's
/// 10 s) and Ctrl-C see dispatches of the same size on every device, whatever its span.
pub const DISPATCH_NODES: usize = 1 << 26;

/// The nodes one workgroup of the albedo kernel sums on this kind of device.
pub fn span_nodes(cpu_driver: bool) -> usize {
    let per_invocation = if albedo_lane_partials(cpu_driver) {
        LANE_NODES_PER_INVOCATION
    } else {
        NODES_PER_INVOCATION
    };
    (LOCAL_SIZE * per_invocation) as usize
}

/// Push constants of `albedo.comp` (`AlbedoJob`). `dispatch_count` sits where [`ChunkPush`] keeps
/// `count`, which the dispatcher turns into the number of workgroups; the test below pins it.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AlbedoPush {
    /// The span of this dispatch's workgroup 0.
    pub first_span: u32,
    /// Workgroups times evaluations per workgroup; read by the host's dispatcher only.
    pub dispatch_count: u32,
    /// Padding; always 0.
    pub pad: [u32; 2],
}

/// One workgroup's work: nodes `begin..end` of the node buffer at one (parameter set, view
/// direction). The std430 twin of `Span` in `glsl/kernels/albedo.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AlbedoSpan {
    /// ωo, the unit direction to the viewer.
    pub wo: [f32; 3],
    /// Which parameter block evaluates it.
    pub param_index: u32,
    /// The first node.
    pub begin: u32,
    /// One past the last node.
    pub end: u32,
    /// 1 where the nodes are offsets from the mirror direction of ωo ([`AlbedoSum::mirror`]).
    pub mirror: u32,
    /// Padding to the std430 size of 32 bytes; always 0.
    pub pad: u32,
}

/// One sum an albedo dispatch makes: Σ w f(ωi, ωo) over nodes `begin..begin + len` of the node
/// buffer, with parameter block `param` at ωo = `wo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoSum {
    /// ωo, the unit direction to the viewer (xyz as f32, as the kernel reads it).
    pub wo: [f32; 3],
    /// Index of the parameter block in the `blocks` given with it.
    pub param: usize,
    /// The list's first node in the node buffer.
    pub begin: usize,
    /// The list's length.
    pub len: usize,
    /// The nodes are (ωi − r)ₓ, (ωi − r)ᵧ, ωi.z, w with r = (−ωo.x, −ωo.y, ωo.z) the mirror
    /// direction of ωo, computed in f64 ([`mirror_node`]): the kernel then forms ωi + ωo without
    /// the cancellation of its tangential parts near r.
    pub mirror: bool,
}

/// A node as [`AlbedoSum::mirror`] lists it: the tangential part of ωi − r, where r is the mirror
/// direction of `wo`, ωi.z and the weight, as f32.
///
/// r is taken from the f64 ωo the rule was made for, not from the f32 ωo the kernel reads: the
/// tangential part of ωi + ωo is then exactly the offset's. Against the f32 ωo it would carry that
/// ωo's rounding (2^-24 in its length and direction), which tilts h by ~2^-24/(2μo), and at
/// grazing view a lobe cut by the horizon gains or loses mass in proportion (GGX α = 0.01 at
/// μo = 0.02: 8e-6 of E). The f32 ωo serves only where its relative rounding is harmless (c_o,
/// Λ(ωo), and ωi's tangential part, which enters Λ(ωi) alone).
pub fn mirror_node(wi: DVec3, weight: f64, wo: DVec3) -> [f32; 4] {
    let (x, y) = (wi.x + wo.x, wi.y + wo.y);
    [x as f32, y as f32, wi.z as f32, weight as f32]
}

/// ωi of a node as the kernel forms it: from a [`mirror_node`] with `mirror`, else as listed.
pub fn node_wi(node: [f32; 4], wo: [f32; 3], mirror: bool) -> [f32; 3] {
    if mirror {
        [node[0] - wo[0], node[1] - wo[1], node[2]]
    } else {
        [node[0], node[1], node[2]]
    }
}

impl Gpu {
    /// A node buffer for [`Gpu::albedo_sums`] of `capacity` nodes, made once and filled again
    /// for each batch of directions (no fresh memory per batch).
    pub fn albedo_nodes(&self, capacity: usize) -> Result<AlbedoNodes<'_>> {
        let range = self.dev.limits.max_storage_buffer_range as u64;
        let bytes = 16 * capacity as u64;
        if bytes > range {
            return Err(GpuError::Limit(format!(
                "albedo: {capacity} nodes need {bytes} bytes, over this device's storage buffer range of {range}; use fewer nodes per direction"
            )));
        }
        Ok(AlbedoNodes {
            buf: Buffer::new(&self.dev, bytes.max(16), "albedo node")?,
            capacity,
            len: 0,
        })
    }

    /// Each of `sums` on the nodes of `nodes` (as filled last), the parameter block of sum s
    /// being `blocks[sums[s].param]` (std430 blocks of one model): E = Σ_k w_k f(ωi_k, ωo) per
    /// sum, in f32 over spans of [`span_nodes`] and in f64 across them. Every span of every sum
    /// is one workgroup, in as few dispatches as the device's workgroup count and
    /// [`DISPATCH_NODES`] allow: a LUT's rows and a rule's coarse check go out together.
    pub fn albedo_sums(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        white_furnace: bool,
        nodes: &AlbedoNodes<'_>,
        sums: &[AlbedoSum],
    ) -> Result<Vec<[f64; 3]>> {
        check_sums(sums, blocks.len(), nodes.len)?;
        let spans = SpanList::of(sums, span_nodes(self.dev.cpu_kernels()));
        let mut out = vec![[0.0f64; 3]; sums.len()];
        if spans.spans.is_empty() {
            return Ok(out);
        }
        // The texel view covers the first maxTexelBufferElements nodes of the buffer.
        let texel_nodes = self.dev.cpu_kernels()
            && nodes.len as u64 <= self.dev.limits.max_texel_buffer_elements as u64;
        let pipe = self.pipeline_with(
            Kernel::Albedo,
            model,
            white_furnace,
            false,
            [texel_nodes, false],
        )?;
        let plan = DispatchPlan::new(self, &spans)?;
        let bufs = SumBuffers::new(self, blocks, &spans, &plan)?;
        let node_buf = &nodes.buf;
        let dispatcher = Dispatcher::new(
            &pipe,
            &[&bufs.params, node_buf, &bufs.spans, &bufs.out, node_buf],
        )?;
        let per_group = (LOCAL_SIZE * pipe.evals_per_invocation) as usize;
        let n_spans = spans.spans.len();
        for first in (0..n_spans).step_by(plan.per_dispatch) {
            let groups = plan.per_dispatch.min(n_spans - first);
            let push = AlbedoPush {
                first_span: first as u32,
                dispatch_count: (groups * per_group) as u32,
                pad: [0; 2],
            };
            dispatcher.run_one(&bytemuck::cast::<AlbedoPush, ChunkPush>(push))?;
            let partials = bufs.out.read_f32(4 * plan.partials_per_span * groups);
            if let Some((invalid, bad)) = first_invalid(partials, plan.partials_per_span) {
                let evaluated = spans.spans[..first + groups]
                    .iter()
                    .map(|s| (s.end - s.begin) as u64)
                    .sum();
                return Err(self.invalid_in_span(
                    model,
                    blocks,
                    white_furnace,
                    nodes,
                    &spans.spans[first + bad],
                    (invalid, evaluated),
                ));
            }
            let owners = &spans.owner[first..first + groups];
            add_partials(&mut out, partials, plan.partials_per_span, owners);
        }
        Ok(out)
    }
}

/// Refuses a sum that reaches past the `n_nodes` nodes filled or names a parameter block past
/// the `n_blocks` given.
fn check_sums(sums: &[AlbedoSum], n_blocks: usize, n_nodes: usize) -> Result<()> {
    for s in sums {
        if s.begin + s.len > n_nodes || s.param >= n_blocks {
            return Err(GpuError::Limit(format!(
                "albedo: a sum over nodes {}..{} with parameter block {} of a buffer of {} nodes and {} blocks",
                s.begin,
                s.begin + s.len,
                s.param,
                n_nodes,
                n_blocks
            )));
        }
    }
    Ok(())
}

/// Each sum's spans, one workgroup each, and which sum each span belongs to.
struct SpanList {
    spans: Vec<AlbedoSpan>,
    /// The index in the sums of span k's sum.
    owner: Vec<usize>,
    /// Nodes a span holds at most ([`span_nodes`]).
    span: usize,
}

impl SpanList {
    /// `sums` cut into spans of at most `span` nodes, in order.
    fn of(sums: &[AlbedoSum], span: usize) -> SpanList {
        let mut spans = Vec::new();
        let mut owner = Vec::new();
        for (i, s) in sums.iter().enumerate() {
            for begin in (s.begin..s.begin + s.len).step_by(span) {
                spans.push(AlbedoSpan {
                    wo: s.wo,
                    param_index: s.param as u32,
                    begin: begin as u32,
                    end: (begin + span).min(s.begin + s.len) as u32,
                    mirror: s.mirror as u32,
                    pad: 0,
                });
                owner.push(i);
            }
        }
        SpanList { spans, owner, span }
    }
}

/// How the spans go out: partials each span writes, and spans (workgroups) per dispatch.
struct DispatchPlan {
    /// One rgb partial (as a vec4) per workgroup, or per invocation (LANE_PARTIALS).
    partials_per_span: usize,
    /// Workgroups one dispatch runs at most.
    per_dispatch: usize,
    /// Bytes of the span list.
    span_bytes: usize,
}

impl DispatchPlan {
    /// The plan for `spans` on `gpu`'s device: every buffer a dispatch binds stays within the
    /// device's storage-buffer range, every dispatch within its workgroup count and
    /// [`DISPATCH_NODES`].
    fn new(gpu: &Gpu, spans: &SpanList) -> Result<DispatchPlan> {
        let limits = &gpu.dev.limits;
        let partials_per_span = if albedo_lane_partials(gpu.dev.cpu_kernels()) {
            LOCAL_SIZE as usize
        } else {
            1
        };
        let range = limits.max_storage_buffer_range as usize;
        let span_bytes = std::mem::size_of_val(spans.spans.as_slice());
        if span_bytes > range {
            return Err(GpuError::Limit(format!(
                "albedo: {} workgroup spans need {span_bytes} bytes, over this device's storage buffer range of {range}; use fewer rows, directions or nodes per call",
                spans.spans.len()
            )));
        }
        let per_dispatch = (limits.max_compute_work_group_count[0] as usize)
            .min(range / (16 * partials_per_span))
            .min(DISPATCH_NODES / spans.span)
            .min(spans.spans.len());
        Ok(DispatchPlan {
            partials_per_span,
            per_dispatch,
            span_bytes,
        })
    }
}

/// The buffers of one [`Gpu::albedo_sums`] call beside the node buffer: the parameter blocks and
/// the spans, written once, and one dispatch's partial sums. The fields are declared in reverse
/// order of creation, so that they are dropped in it.
struct SumBuffers<'d> {
    out: Buffer<'d>,
    spans: Buffer<'d>,
    params: Buffer<'d>,
}

impl<'d> SumBuffers<'d> {
    /// Creates the buffers on `gpu`'s device and writes `blocks` and the spans.
    fn new(
        gpu: &'d Gpu,
        blocks: &[Vec<u8>],
        spans: &SpanList,
        plan: &DispatchPlan,
    ) -> Result<SumBuffers<'d>> {
        let params: Vec<u8> = blocks.concat();
        let mut param_buf = Buffer::new(&gpu.dev, params.len() as u64, "parameter")?;
        param_buf.write(&params)?;
        let mut span_buf = Buffer::new(&gpu.dev, plan.span_bytes as u64, "albedo span")?;
        span_buf.write(bytemuck::cast_slice(&spans.spans))?;
        let out = Buffer::output(
            &gpu.dev,
            16 * (plan.partials_per_span * plan.per_dispatch) as u64,
            "albedo partial sum",
        )?;
        Ok(SumBuffers {
            out,
            spans: span_buf,
            params: param_buf,
        })
    }
}

/// The invalid values the kernel counted in a dispatch's `partials` (`per_span` vec4s a span;
/// each partial's w counts them, docs/design.md §2.1) and the index of the first span that holds
/// one; None where there are none.
fn first_invalid(partials: &[f32], per_span: usize) -> Option<(u64, usize)> {
    let invalid = partials.chunks_exact(4).map(|q| q[3] as f64).sum::<f64>();
    if invalid == 0.0 {
        return None;
    }
    let bad = partials
        .chunks_exact(4 * per_span)
        .position(|p| p.chunks_exact(4).any(|q| q[3] != 0.0))
        .unwrap_or(0);
    Some((invalid as u64, bad))
}

/// Adds each span's `per_span` partials in f64 to its sum's total in `out`, span k's sum being
/// `owners[k]`.
fn add_partials(out: &mut [[f64; 3]], partials: &[f32], per_span: usize, owners: &[usize]) {
    for (p, &i) in partials.chunks_exact(4 * per_span).zip(owners) {
        let mut sum = [0.0f64; 3];
        for q in p.chunks_exact(4) {
            sum[0] += q[0] as f64;
            sum[1] += q[1] as f64;
            sum[2] += q[2] as f64;
        }
        for (o, s) in out[i].iter_mut().zip(sum) {
            *o += s;
        }
    }
}

impl Gpu {
    /// The refusal of an albedo job whose kernel counted `(invalid, evaluated)` values: the span
    /// that held the first is evaluated again as pairs (a few thousand at most) to find which
    /// node it was and what kinds its span holds.
    fn invalid_in_span(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        white_furnace: bool,
        nodes: &AlbedoNodes<'_>,
        span: &AlbedoSpan,
        (invalid, evaluated): (u64, u64),
    ) -> GpuError {
        let all: &[f32] = nodes.buf.read_f32(4 * nodes.len);
        let (begin, end) = (span.begin as usize, span.end as usize);
        let pairs: Vec<GpuPair> = all[4 * begin..4 * end]
            .chunks_exact(4)
            .map(|n| GpuPair {
                wi: node_wi([n[0], n[1], n[2], n[3]], span.wo, span.mirror != 0),
                param_index: 0,
                wo: span.wo,
                pad: 0,
            })
            .collect();
        let block = [blocks[span.param_index as usize].clone()];
        let f = match self.eval_pairs(model, &block, &pairs, white_furnace) {
            Ok(f) => f,
            Err(e) => return e,
        };
        let dir = |v: [f32; 3]| DVec3::from_array(v.map(f64::from));
        let mut span_count = InvalidCount::default();
        for (k, (v, p)) in f.iter().zip(&pairs).enumerate() {
            span_count.add(begin as u64 + k as u64, v.map(f64::from), || {
                (Some((dir(p.wi), dir(p.wo))), None)
            });
        }
        // The kernel counts values, not kinds: the kinds are told for the first span.
        let mut count = InvalidCount {
            evaluated,
            invalid,
            ..InvalidCount::default()
        };
        if let Some(mut first) = span_count.first.take() {
            first.place = Some(format!(
                "a quadrature node; its span of {} nodes at this view direction holds {}",
                pairs.len(),
                crate::finite::kinds_text(&span_count)
            ));
            count.first = Some(first);
        }
        // Without a first (the pairs kernel found none where the reduction did: only a driver
        // that rounds the two differently could), the refusal stands on the kernel's count.
        GpuError::InvalidValues(crate::finite::InvalidValues {
            model: model.name().to_string(),
            job: "albedo".to_string(),
            count,
        })
    }
}

/// The node lists of [`Gpu::albedo_sums`]: one buffer of (ωi.xyz, w) nodes, mapped once and
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

    /// Lets `fill` write the first `len` nodes in place; they are what the next
    /// [`Gpu::albedo_sums`] reads. Nodes it leaves alone keep what the buffer held (a list
    /// shared by every batch stays at the front while the rest changes).
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
    fn albedo_span_has_its_std430_size() {
        assert_eq!(size_of::<AlbedoSpan>(), 32);
        assert_eq!(offset_of!(AlbedoSpan, param_index), 12);
        assert_eq!(offset_of!(AlbedoSpan, begin), 16);
        assert_eq!(offset_of!(AlbedoSpan, end), 20);
        assert_eq!(offset_of!(AlbedoSpan, mirror), 24);
    }

    #[test]
    fn models_take_mirror_sums_where_their_glsl_defines_the_entry() {
        // The host sends mirror offsets exactly to the models whose GLSL defines MODEL_EVAL_SUM;
        // the kernel would otherwise evaluate every other model from reconstructed ωi.
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("glsl/brdf");
        for model in Model::ALL {
            let path = dir.join(format!("{}.glsl", model.name()));
            let text = std::fs::read_to_string(&path).expect("the model's GLSL");
            assert_eq!(
                text.contains("#define MODEL_EVAL_SUM"),
                model.sums_from_mirror_offsets(),
                "{}",
                path.display()
            );
        }
    }

    #[test]
    fn mirror_nodes_give_back_the_node_and_the_exact_sum() {
        // ωi = r + offset at the kernel's f32 ωo; the offset is the tangential part of ωi + ωo.
        let wo = DVec3::new(0.9998, 0.0, 0.02).normalize();
        let wi = DVec3::new(-0.9997, 0.011, 0.0203).normalize();
        let node = mirror_node(wi, 0.25, wo);
        let wo32 = [wo.x as f32, wo.y as f32, wo.z as f32];
        let back = node_wi(node, wo32, true);
        for c in 0..3 {
            assert!((back[c] as f64 - wi[c]).abs() < 2e-7, "{back:?} vs {wi}");
        }
        assert_eq!(node[0], (wi.x + wo.x) as f32);
        assert_eq!(node[1], (wi.y + wo.y) as f32);
        assert_eq!(node[3], 0.25);
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
