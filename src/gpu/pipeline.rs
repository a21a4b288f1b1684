//! Compute pipelines, one per (kernel, model, white furnace), specialised at creation:
//! constant 0 = WHITE_FURNACE, 1 = workgroup size, 2 = evaluations per invocation.
//! A pipeline carries exactly one model; nothing is built until a command needs it.

use super::buffer::Buffer;
use super::device::Device;
use super::error::{Context, GpuError, Result};
use super::CHUNK_TIMEOUT;
use crate::model::kernels::KernelSource;
use ash::vk;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Which kernel of `glsl/kernels/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Outer product of a wi list and a wo list (bindings 0 params, 1 wi, 2 wo, 3 out, 4 and 5
    /// wi and wo as texel buffers).
    Table,
    /// Explicit (wi, wo, parameter index) pairs (bindings 0 params, 1 pairs, 3 out).
    Pairs,
    /// `lobe preview`: one shaded pixel per evaluation (bindings 0 params, 1 scene, 2 objects,
    /// 3 out); see glsl/kernels/preview.comp.
    Preview,
    /// Directional albedo as a workgroup reduction over quadrature nodes (bindings 0 params,
    /// 1 nodes, 2 entries, 3 partial sums, 4 the nodes as a texel buffer); see
    /// glsl/kernels/albedo.comp and src/gpu/albedo.rs.
    Albedo,
}

impl Kernel {
    /// The kernel's file name in `glsl/kernels/` without its extension, as SPIR-V is looked up.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Table => "table",
            Kernel::Pairs => "pairs",
            Kernel::Preview => "preview",
            Kernel::Albedo => "albedo",
        }
    }

    /// The kernel's bindings, in the order its buffers are given to [`Dispatcher::new`].
    pub(crate) fn bindings(self) -> &'static [(u32, vk::DescriptorType)] {
        const S: vk::DescriptorType = vk::DescriptorType::STORAGE_BUFFER;
        const T: vk::DescriptorType = vk::DescriptorType::UNIFORM_TEXEL_BUFFER;
        match self {
            // 4 and 5: the wi and wo lists again, as texel buffers (TEXEL_DIRECTIONS).
            Kernel::Table => &[(0, S), (1, S), (2, S), (3, S), (4, T), (5, T)],
            Kernel::Pairs => &[(0, S), (1, S), (3, S)],
            Kernel::Preview => &[(0, S), (1, S), (2, S), (3, S)],
            // 4: the nodes again, as a texel buffer (TEXEL_NODES).
            Kernel::Albedo => &[(0, S), (1, S), (2, S), (3, S), (4, T)],
        }
    }
}

/// The binding of a model's data table (a measured BRDF's bins, read-only storage buffer) in
/// every kernel of a model that has one ([`crate::model::Model::data`]): a measured BRDF's bins, the
/// microfacet model's Kulla–Conty table. The pipelines of models without one do not have this
/// binding.
pub const MODEL_DATA_BINDING: u32 = 7;

/// A model's data table on the device, with the device it lives on.
struct ModelData {
    /// Declared before `_dev`, so dropped first.
    buffer: Buffer<'static>,
    _dev: Arc<Device>,
}

// SAFETY: the buffer's mapping is written once, in `ModelData::new`, before the value is shared;
// afterwards only kernels read the buffer, and the `Device` is `Send + Sync`.
unsafe impl Send for ModelData {}
// SAFETY: as for `Send`: no method writes through a shared `ModelData`.
unsafe impl Sync for ModelData {}

impl ModelData {
    /// Uploads `bytes` to a new buffer on `dev`.
    fn new(dev: &Arc<Device>, model: &str, bytes: &[u8]) -> Result<ModelData> {
        let range = dev.limits.max_storage_buffer_range as u64;
        if bytes.len() as u64 > range {
            return Err(GpuError::Limit(format!(
                "the data table of model {model} takes {} bytes, over this device's storage buffer range of {range}",
                bytes.len()
            )));
        }
        let mut buffer = Buffer::new(dev, bytes.len() as u64, "model data")?;
        buffer.write(bytes)?;
        // SAFETY: a `Buffer` uses its `&Device` only to reach the device (in `Drop`); the `Arc`
        // kept beside it holds that `Device` at the same address until after `buffer` is
        // dropped (fields drop in declaration order).
        let buffer = unsafe { std::mem::transmute::<Buffer<'_>, Buffer<'static>>(buffer) };
        Ok(ModelData {
            buffer,
            _dev: dev.clone(),
        })
    }
}

/// Specialization constant id of FAST_POW (glsl/common.glsl).
pub const FAST_POW_ID: u32 = 10;

/// Specialization constant id of TEXEL_DIRECTIONS (glsl/kernels/table.comp) and TEXEL_NODES
/// (glsl/kernels/albedo.comp): read a list through a texel buffer.
pub const TEXEL_DIRECTIONS_ID: u32 = 20;

/// Specialization constant id of LANE_PARTIALS (glsl/kernels/albedo.comp): every invocation
/// writes its own partial sum, no workgroup tree.
pub const LANE_PARTIALS_ID: u32 = 21;

/// Whether the albedo kernel writes one partial sum per invocation (LANE_PARTIALS) rather than
/// one per workgroup. On a CPU driver a barrier switches between the workgroup's SIMD slices,
/// and the tree's seven barriers per workgroup cost more than storing 64 partials and adding
/// them on the host; on a GPU the tree is cheap and keeps the read-back small.
pub fn albedo_lane_partials(cpu_driver: bool) -> bool {
    cpu_driver
}

/// The format of a direction list read as a texel buffer: one vec4 per direction.
pub const TEXEL_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Workgroup size. 64 suits lavapipe and is a multiple of every GPU's wave width.
pub const LOCAL_SIZE: u32 = 64;

/// Evaluations one invocation of `kernel` makes (specialization constant 2). On a CPU driver
/// several per invocation amortise the invocation overhead: 8 for the table kernel, 4 for the
/// others. On a GPU one per invocation keeps every lane busy, except in the table kernel, which
/// writes 4 cells as 3 vec4 stores and so makes a multiple of 4.
pub fn evals_per_invocation(kernel: Kernel, cpu_driver: bool) -> u32 {
    match (kernel, cpu_driver) {
        (Kernel::Table, true) => 8,
        (Kernel::Table, false) => 4,
        (_, true) => 4,
        (_, false) => 1,
    }
}

/// Push constants: see `Chunk` in `glsl/kernels/eval.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ChunkPush {
    /// Index of the chunk's first element in the whole job.
    pub first: u32,
    /// Number of elements in this chunk.
    pub count: u32,
    /// Length of the wo list (the table kernel only; 0 elsewhere).
    pub n_wo: u32,
    /// Length of the wi list (the table kernel only; 0 elsewhere).
    pub n_wi: u32,
}

/// One compute pipeline: a kernel specialised for one model, white furnace on or off, and
/// fast-pow on or off, with its descriptor layout and its running GPU time.
pub struct Pipeline {
    dev: Arc<Device>,
    /// The kernel it runs.
    pub kernel: Kernel,
    module: vk::ShaderModule,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    /// Evaluations one invocation makes (specialization constant 2): see
    /// [`evals_per_invocation`].
    pub evals_per_invocation: u32,
    /// Whether the table kernel reads its direction lists as texel buffers
    /// (TEXEL_DIRECTIONS).
    pub texel_directions: bool,
    /// How long creating the pipeline took (the driver compiles the shader here).
    pub build_time: Duration,
    /// `kernel/model-label`, with " (white furnace)" where it applies; used in logs and errors.
    pub label: String,
    /// GPU time of every dispatch so far, from timestamp queries (nanoseconds).
    pub gpu_ns: AtomicU64,
    /// The model's own bound on each chunk's wait, if it has one (else [`CHUNK_TIMEOUT`]).
    pub model_timeout: Option<Duration>,
    /// The model's data table, bound at [`MODEL_DATA_BINDING`] by every dispatcher.
    data: Option<ModelData>,
}

impl Pipeline {
    /// Builds the pipeline of `kernel` from a model's `source`, specialised for
    /// `white_furnace` and `fast_pow`, and times the build.
    pub fn new(
        dev: &Arc<Device>,
        kernel: Kernel,
        source: &KernelSource,
        white_furnace: bool,
        fast_pow: bool,
        texel_directions: bool,
    ) -> Result<Pipeline> {
        let start = Instant::now();
        let model = source.model;
        let bytes = source.spirv;
        let words = ash::util::read_spv(&mut std::io::Cursor::new(bytes)).map_err(|e| {
            GpuError::Limit(format!("embedded SPIR-V for {model} is unreadable: {e}"))
        })?;
        let evals_per_invocation = evals_per_invocation(kernel, dev.cpu_kernels());
        let label = format!(
            "{}/{}{}",
            kernel.name(),
            source.label,
            if white_furnace {
                " (white furnace)"
            } else {
                ""
            }
        );
        let d = &dev.device;
        let mut p = Pipeline {
            dev: dev.clone(),
            kernel,
            module: vk::ShaderModule::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            evals_per_invocation,
            texel_directions,
            build_time: Duration::ZERO,
            label,
            gpu_ns: AtomicU64::new(0),
            model_timeout: source.timeout,
            data: None,
        };
        if let Some(bytes) = source.data {
            p.data = Some(ModelData::new(dev, model, bytes)?);
        }
        // SAFETY: create infos outlive their calls; on failure `p` is dropped and releases what exists.
        unsafe {
            p.module = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
                .ctx("creating a shader module")?;
            let bindings: Vec<_> = p
                .bindings()
                .iter()
                .map(|&(b, ty)| {
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(b)
                        .descriptor_type(ty)
                        .descriptor_count(1)
                        .stage_flags(vk::ShaderStageFlags::COMPUTE)
                })
                .collect();
            p.set_layout = d
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                    None,
                )
                .ctx("creating a descriptor set layout")?;
            let push = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .offset(0)
                .size(std::mem::size_of::<ChunkPush>() as u32)];
            let set_layouts = [p.set_layout];
            p.layout = d
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default()
                        .set_layouts(&set_layouts)
                        .push_constant_ranges(&push),
                    None,
                )
                .ctx("creating a pipeline layout")?;
            // Constants 0-2 and FAST_POW_ID are every kernel's; 3.. are the model's component
            // choices (glsl/common.glsl, glsl/brdf/<model>.glsl).
            let mut ids: Vec<u32> = vec![0, 1, 2, FAST_POW_ID];
            let mut spec_data: Vec<u32> = vec![
                white_furnace as u32,
                LOCAL_SIZE,
                evals_per_invocation,
                fast_pow as u32,
            ];
            if matches!(kernel, Kernel::Table | Kernel::Albedo) {
                ids.push(TEXEL_DIRECTIONS_ID);
                spec_data.push(texel_directions as u32);
            }
            if kernel == Kernel::Albedo {
                ids.push(LANE_PARTIALS_ID);
                spec_data.push(albedo_lane_partials(dev.cpu_kernels()) as u32);
            }
            for (k, &v) in source.spec_constants.iter().enumerate() {
                ids.push(3 + k as u32);
                spec_data.push(v);
            }
            let entries: Vec<_> = ids
                .iter()
                .enumerate()
                .map(|(k, &id)| vk::SpecializationMapEntry {
                    constant_id: id,
                    offset: 4 * k as u32,
                    size: 4,
                })
                .collect();
            let spec = vk::SpecializationInfo::default()
                .map_entries(&entries)
                .data(bytemuck::cast_slice(&spec_data));
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(p.module)
                .name(c"main")
                .specialization_info(&spec);
            let info = [vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(p.layout)];
            p.pipeline = d
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
                .map_err(|(_, r)| r)
                .ctx(&format!("creating the compute pipeline {}", p.label))?[0];
        }
        p.build_time = start.elapsed();
        Ok(p)
    }

    /// The kernel's bindings, and [`MODEL_DATA_BINDING`] where the model has a data table.
    fn bindings(&self) -> Vec<(u32, vk::DescriptorType)> {
        let data = self
            .data
            .as_ref()
            .map(|_| (MODEL_DATA_BINDING, vk::DescriptorType::STORAGE_BUFFER));
        self.kernel.bindings().iter().copied().chain(data).collect()
    }

    /// Runs the kernel once per chunk over bound buffers (in binding order), waiting for each.
    pub fn dispatch(&self, buffers: &[&Buffer<'_>], chunks: &[ChunkPush]) -> Result<()> {
        Dispatcher::new(self, buffers)?.run(chunks)
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        if self.dev.is_hung() {
            // A timed-out submission may still run this pipeline: leak it.
            return;
        }
        let d = &self.dev.device;
        // SAFETY: the device is idle after every dispatch; release in reverse order of creation.
        unsafe {
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
            d.destroy_shader_module(self.module, None);
        }
    }
}

/// A descriptor set bound to a job's buffers, a command buffer and a fence, reused per chunk.
pub struct Dispatcher<'p> {
    pipe: &'p Pipeline,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    cmd_pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// Two timestamps around each dispatch; null where the queue has none.
    queries: vk::QueryPool,
    /// Views of the buffers bound as texel buffers.
    views: Vec<vk::BufferView>,
    /// Whether a submission has not been waited for yet.
    in_flight: std::cell::Cell<bool>,
    /// The staged outputs' copies recorded after each dispatch.
    read_backs: Vec<super::buffer::ReadBack>,
}

impl<'p> Dispatcher<'p> {
    /// Binds `buffers` to the kernel's bindings, in their order (panics on a wrong count: the
    /// callers are this crate's own runners), and the model's data table to
    /// [`MODEL_DATA_BINDING`] where it has one.
    pub fn new(pipe: &'p Pipeline, buffers: &[&Buffer<'_>]) -> Result<Dispatcher<'p>> {
        assert_eq!(
            buffers.len(),
            pipe.kernel.bindings().len(),
            "kernel {} takes {} buffers",
            pipe.kernel.name(),
            pipe.kernel.bindings().len()
        );
        let bindings = &pipe.bindings()[..];
        let data = pipe.data.as_ref().map(|d| &d.buffer);
        let buffers: &[&Buffer<'_>] = &buffers.iter().copied().chain(data).collect::<Vec<_>>();
        let d = &pipe.dev.device;
        let mut s = Dispatcher {
            pipe,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            cmd_pool: vk::CommandPool::null(),
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            queries: vk::QueryPool::null(),
            views: Vec::new(),
            in_flight: std::cell::Cell::new(false),
            read_backs: buffers.iter().filter_map(|b| b.read_back()).collect(),
        };
        // SAFETY: create infos outlive their calls; `s` releases what exists when dropped.
        unsafe {
            let sizes: Vec<vk::DescriptorPoolSize> = [
                vk::DescriptorType::STORAGE_BUFFER,
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            ]
            .into_iter()
            .map(|ty| vk::DescriptorPoolSize {
                ty,
                descriptor_count: bindings.iter().filter(|b| b.1 == ty).count() as u32,
            })
            .filter(|p| p.descriptor_count > 0)
            .collect();
            s.pool = d
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(1)
                        .pool_sizes(&sizes),
                    None,
                )
                .ctx("creating a descriptor pool")?;
            let layouts = [pipe.set_layout];
            s.set = d
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(s.pool)
                        .set_layouts(&layouts),
                )
                .ctx("allocating a descriptor set")?[0];
            let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
                .iter()
                .map(|b| {
                    [vk::DescriptorBufferInfo {
                        buffer: b.buffer,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    }]
                })
                .collect();
            // A texel buffer's view covers at most maxTexelBufferElements texels; the kernel
            // reads through it only where the host found the list fits (TEXEL_DIRECTIONS).
            let max_texels = pipe.dev.limits.max_texel_buffer_elements as u64;
            let mut views: Vec<[vk::BufferView; 1]> = Vec::new();
            for (&(_, ty), b) in bindings.iter().zip(buffers) {
                if ty == vk::DescriptorType::UNIFORM_TEXEL_BUFFER {
                    let range = (b.size / 16).min(max_texels) * 16;
                    let info = vk::BufferViewCreateInfo::default()
                        .buffer(b.buffer)
                        .format(TEXEL_FORMAT)
                        .offset(0)
                        .range(range);
                    let view = d
                        .create_buffer_view(&info, None)
                        .ctx("creating a texel buffer view")?;
                    s.views.push(view);
                    views.push([view]);
                } else {
                    views.push([vk::BufferView::null()]);
                }
            }
            let writes: Vec<_> = bindings
                .iter()
                .zip(infos.iter().zip(&views))
                .map(|(&(b, ty), (info, view))| {
                    let w = vk::WriteDescriptorSet::default()
                        .dst_set(s.set)
                        .dst_binding(b)
                        .descriptor_type(ty);
                    if ty == vk::DescriptorType::UNIFORM_TEXEL_BUFFER {
                        w.texel_buffer_view(view)
                    } else {
                        w.buffer_info(info)
                    }
                })
                .collect();
            d.update_descriptor_sets(&writes, &[]);
            s.cmd_pool = d
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(pipe.dev.queue_family)
                        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                    None,
                )
                .ctx("creating a command pool")?;
            s.cmd = d
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(s.cmd_pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .ctx("allocating a command buffer")?[0];
            s.fence = d
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .ctx("creating a fence")?;
            if pipe.dev.timestamp_bits > 0 {
                let info = vk::QueryPoolCreateInfo::default()
                    .query_type(vk::QueryType::TIMESTAMP)
                    .query_count(2);
                s.queries = d
                    .create_query_pool(&info, None)
                    .ctx("creating a timestamp query pool")?;
            }
        }
        Ok(s)
    }

    /// Dispatches one chunk and waits for it.
    pub fn run_one(&self, chunk: &ChunkPush) -> Result<()> {
        self.submit(chunk)?;
        self.wait()
    }

    /// Records and submits one chunk without waiting for it ([`Dispatcher::wait`] does): a
    /// runner with two dispatchers reads one chunk back while the other runs.
    pub fn submit(&self, chunk: &ChunkPush) -> Result<()> {
        let pipe = self.pipe;
        if let Some(e) = pipe.dev.refuse_if_hung() {
            return Err(e);
        }
        assert!(
            !self.in_flight.get(),
            "a dispatcher submits one chunk at a time"
        );
        let d = &pipe.dev.device;
        let per_group = (LOCAL_SIZE * pipe.evals_per_invocation) as u64;
        let groups = (chunk.count as u64).div_ceil(per_group);
        let max_groups = pipe.dev.limits.max_compute_work_group_count[0] as u64;
        if groups > max_groups {
            return Err(GpuError::Limit(format!(
                "a chunk of {} evaluations needs {groups} workgroups; this device allows {max_groups}",
                chunk.count
            )));
        }
        // SAFETY: the command buffer is idle (`in_flight` is false: its fence was waited on).
        unsafe {
            d.reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .ctx("resetting a command buffer")?;
            d.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .ctx("beginning a command buffer")?;
            d.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::COMPUTE, pipe.pipeline);
            d.cmd_bind_descriptor_sets(
                self.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipe.layout,
                0,
                &[self.set],
                &[],
            );
            d.cmd_push_constants(
                self.cmd,
                pipe.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                bytemuck::bytes_of(chunk),
            );
            if self.queries != vk::QueryPool::null() {
                d.cmd_reset_query_pool(self.cmd, self.queries, 0, 2);
                d.cmd_write_timestamp(
                    self.cmd,
                    vk::PipelineStageFlags::TOP_OF_PIPE,
                    self.queries,
                    0,
                );
            }
            d.cmd_dispatch(self.cmd, groups as u32, 1, 1);
            if self.queries != vk::QueryPool::null() {
                d.cmd_write_timestamp(
                    self.cmd,
                    vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                    self.queries,
                    1,
                );
            }
            // Make the shader's writes visible to the host's reads of the mapped output.
            super::buffer::record_read_back(&pipe.dev, self.cmd, &self.read_backs);
            d.end_command_buffer(self.cmd)
                .ctx("ending a command buffer")?;
            let cmds = [self.cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            d.reset_fences(&[self.fence]).ctx("resetting a fence")?;
            {
                // vkQueueSubmit needs the queue externally synchronised: one submit at a time.
                let _queue = pipe
                    .dev
                    .queue_lock
                    .lock()
                    .unwrap_or_else(|e| e.into_inner());
                d.queue_submit(pipe.dev.queue, &submit, self.fence)
                    .ctx(&format!("submitting {}", pipe.label))?;
            }
        }
        self.in_flight.set(true);
        Ok(())
    }

    /// Waits for the submitted chunk, at most [`CHUNK_TIMEOUT`] (or the model's own limit). On a timeout the submission may
    /// still run: the device is marked hung ([`Device::mark_hung`]) and from then on nothing
    /// that work could touch (this dispatcher's fence and command pool, the job's buffers, the
    /// device) is released: it is leaked instead.
    pub fn wait(&self) -> Result<()> {
        let pipe = self.pipe;
        if !self.in_flight.get() {
            return Ok(());
        }
        let d = &pipe.dev.device;
        // SAFETY: the fence belongs to this dispatcher's last submission.
        let waited = unsafe {
            let timeout = pipe.model_timeout.unwrap_or(CHUNK_TIMEOUT);
            let w = d.wait_for_fences(&[self.fence], true, timeout.as_nanos() as u64);
            if pipe.dev.inject_device_lost {
                // Let the real work finish, then report what a lost device reports.
                w.and(Err(vk::Result::ERROR_DEVICE_LOST))
            } else {
                w
            }
        };
        match waited {
            Ok(()) => {
                self.in_flight.set(false);
                self.record_gpu_time()?;
                Ok(())
            }
            Err(vk::Result::TIMEOUT) => {
                pipe.dev.mark_hung();
                if let Some(limit) = pipe.model_timeout {
                    return Err(GpuError::ModelTimeout {
                        what: pipe.label.clone(),
                        seconds: limit.as_secs_f64(),
                    });
                }
                Err(GpuError::Timeout {
                    what: pipe.label.clone(),
                    seconds: CHUNK_TIMEOUT.as_secs(),
                })
            }
            Err(r) => {
                // A lost device runs nothing any more: the submission is over.
                self.in_flight.set(false);
                Err(r).ctx(&format!("running {}", pipe.label))
            }
        }
    }

    /// Adds the last dispatch's GPU time, from its two timestamps, to the pipeline's total.
    fn record_gpu_time(&self) -> Result<()> {
        if self.queries == vk::QueryPool::null() {
            return Ok(());
        }
        let mut stamps = [0u64; 2];
        // SAFETY: both queries were written by the command buffer whose fence we waited on.
        unsafe {
            self.pipe.dev.device.get_query_pool_results(
                self.queries,
                0,
                &mut stamps,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .ctx("reading timestamp queries")?;
        let bits = self.pipe.dev.timestamp_bits;
        let mask = if bits >= 64 {
            u64::MAX
        } else {
            (1u64 << bits) - 1
        };
        let ticks = stamps[1].wrapping_sub(stamps[0]) & mask;
        let ns = ticks as f64 * self.pipe.dev.limits.timestamp_period as f64;
        self.pipe.gpu_ns.fetch_add(ns as u64, Ordering::Relaxed);
        Ok(())
    }

    /// Dispatches every chunk in order, waiting for each; stops at the first failure.
    pub fn run(&self, chunks: &[ChunkPush]) -> Result<()> {
        chunks.iter().try_for_each(|c| self.run_one(c))
    }
}

impl Drop for Dispatcher<'_> {
    fn drop(&mut self) {
        let d = &self.pipe.dev.device;
        // A submission not waited for (an error elsewhere dropped us): wait, bounded.
        if self.in_flight.get() && !self.pipe.dev.is_hung() && self.wait().is_err() {
            self.in_flight.set(self.pipe.dev.is_hung());
        }
        if self.in_flight.get() || self.pipe.dev.is_hung() {
            // The work may still run and use what we hold: leak it rather than free it.
            return;
        }
        // SAFETY: the fence was waited on; release in reverse order of creation.
        unsafe {
            for &v in &self.views {
                d.destroy_buffer_view(v, None);
            }
            if self.queries != vk::QueryPool::null() {
                d.destroy_query_pool(self.queries, None);
            }
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.cmd_pool, None);
            d.destroy_descriptor_pool(self.pool, None);
        }
    }
}
