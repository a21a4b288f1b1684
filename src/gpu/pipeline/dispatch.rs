//! Dispatching a pipeline's kernel: its buffers bound, one chunk at a time recorded, submitted
//! and waited for within the chunk's time limit, with timestamps where the queue has them.

use super::*;

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
    read_backs: Vec<crate::gpu::buffer::ReadBack>,
    /// The buffers filled with zeros before each dispatch ([`Kernel::cleared`]).
    clears: Vec<vk::Buffer>,
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
            clears: bindings
                .iter()
                .zip(buffers)
                .filter(|((b, _), _)| pipe.kernel.cleared().contains(b))
                .map(|(_, buf)| buf.buffer)
                .collect(),
        };
        // SAFETY: create infos outlive their calls; `s` releases what exists when dropped.
        unsafe {
            s.create_descriptor_set(bindings)?;
            s.create_command_buffer()?;
            s.create_timestamp_queries()?;
            s.bind_buffers(bindings, buffers)?;
        }
        Ok(s)
    }

    /// Creates a descriptor pool sized for `bindings` and allocates the one set from it.
    ///
    /// # Safety
    /// Called once, on a dispatcher under construction.
    unsafe fn create_descriptor_set(
        &mut self,
        bindings: &[(u32, vk::DescriptorType)],
    ) -> Result<()> {
        let d = &self.pipe.dev.device;
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
        self.pool = d
            .create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes),
                None,
            )
            .ctx("creating a descriptor pool")?;
        let layouts = [self.pipe.set_layout];
        self.set = d
            .allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(self.pool)
                    .set_layouts(&layouts),
            )
            .ctx("allocating a descriptor set")?[0];
        Ok(())
    }

    /// Creates the command pool, its one command buffer (reset and recorded again per chunk)
    /// and the fence each submission signals.
    ///
    /// # Safety
    /// Called once, on a dispatcher under construction.
    unsafe fn create_command_buffer(&mut self) -> Result<()> {
        let d = &self.pipe.dev.device;
        self.cmd_pool = d
            .create_command_pool(
                &vk::CommandPoolCreateInfo::default()
                    .queue_family_index(self.pipe.dev.queue_family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )
            .ctx("creating a command pool")?;
        self.cmd = d
            .allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(self.cmd_pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1),
            )
            .ctx("allocating a command buffer")?[0];
        self.fence = d
            .create_fence(&vk::FenceCreateInfo::default(), None)
            .ctx("creating a fence")?;
        Ok(())
    }

    /// Creates the pool of the two timestamps around each dispatch, where the queue has
    /// timestamps.
    ///
    /// # Safety
    /// Called once, on a dispatcher under construction.
    unsafe fn create_timestamp_queries(&mut self) -> Result<()> {
        if self.pipe.dev.timestamp_bits > 0 {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(2);
            self.queries = self
                .pipe
                .dev
                .device
                .create_query_pool(&info, None)
                .ctx("creating a timestamp query pool")?;
        }
        Ok(())
    }

    /// Points the descriptor set's `bindings` at `buffers` (in the same order), through a texel
    /// view for each texel-buffer binding.
    ///
    /// # Safety
    /// Called once, after [`Dispatcher::create_descriptor_set`]; the buffers outlive the
    /// dispatcher.
    unsafe fn bind_buffers(
        &mut self,
        bindings: &[(u32, vk::DescriptorType)],
        buffers: &[&Buffer<'_>],
    ) -> Result<()> {
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
        let views = self.create_texel_views(bindings, buffers)?;
        let writes: Vec<_> = bindings
            .iter()
            .zip(infos.iter().zip(&views))
            .map(|(&(b, ty), (info, view))| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(b)
                    .descriptor_type(ty);
                if ty == vk::DescriptorType::UNIFORM_TEXEL_BUFFER {
                    w.texel_buffer_view(view)
                } else {
                    w.buffer_info(info)
                }
            })
            .collect();
        self.pipe.dev.device.update_descriptor_sets(&writes, &[]);
        Ok(())
    }

    /// A view per binding of `bindings`: a texel view of its buffer (kept in `views`, released
    /// with the dispatcher) for a texel-buffer binding, a null view for any other.
    ///
    /// # Safety
    /// The buffers outlive the dispatcher.
    unsafe fn create_texel_views(
        &mut self,
        bindings: &[(u32, vk::DescriptorType)],
        buffers: &[&Buffer<'_>],
    ) -> Result<Vec<[vk::BufferView; 1]>> {
        let d = &self.pipe.dev.device;
        // A texel buffer's view covers at most maxTexelBufferElements texels; the kernel
        // reads through it only where the host found the list fits (TEXEL_DIRECTIONS).
        let max_texels = self.pipe.dev.limits.max_texel_buffer_elements as u64;
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
                self.views.push(view);
                views.push([view]);
            } else {
                views.push([vk::BufferView::null()]);
            }
        }
        Ok(views)
    }

    /// Dispatches one chunk and waits for it.
    pub fn run_one(&self, chunk: &ChunkPush) -> Result<()> {
        self.submit(chunk)?;
        self.wait()
    }

    /// Runs `total` items in chunks of at most `chunk`, reading each chunk's results back from
    /// `out` as one RGB triple (three f32) per item, in order: the loop of the kernels that make
    /// a colour per pixel. `stop` is asked before each chunk; once it says so, the triples made so
    /// far come back (the caller says why it stopped).
    pub fn run_rgb(
        &self,
        out: &Buffer<'_>,
        total: u64,
        chunk: u64,
        stop: &dyn Fn() -> bool,
    ) -> Result<Vec<[f32; 3]>> {
        let mut rgb = Vec::with_capacity(total as usize);
        let mut first = 0u64;
        while first < total && !stop() {
            let count = chunk.min(total - first);
            self.run_one(&ChunkPush {
                first: first as u32,
                count: count as u32,
                n_wo: 0,
                n_wi: 0,
            })?;
            let values = out.read_f32(count as usize * 3);
            rgb.extend(values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            first += count;
        }
        Ok(rgb)
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
            if !self.clears.is_empty() {
                for &b in &self.clears {
                    d.cmd_fill_buffer(self.cmd, b, 0, vk::WHOLE_SIZE, 0);
                }
                let fill_done = [vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::SHADER_WRITE)];
                d.cmd_pipeline_barrier(
                    self.cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::DependencyFlags::empty(),
                    &fill_done,
                    &[],
                    &[],
                );
            }
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
            crate::gpu::buffer::record_read_back(&pipe.dev, self.cmd, &self.read_backs);
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
