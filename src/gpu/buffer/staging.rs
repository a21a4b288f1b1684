//! The copies between a staged buffer and its staging buffer: an upload before any kernel reads
//! an input, and the read-back a dispatch records after its kernel for each staged output.

use crate::gpu::device::Device;
use crate::gpu::error::{Context, GpuError, Result};
use ash::vk;

/// A read-back a dispatch records after its kernel: the device-local output `src` into its
/// staging buffer `dst`, `size` bytes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ReadBack {
    pub(super) src: vk::Buffer,
    pub(super) dst: vk::Buffer,
    pub(super) size: u64,
}

/// Records what makes a kernel's writes readable by the host: a barrier to host reads where
/// every output is direct, or a barrier to transfers, the staged outputs' copies (`copies`),
/// and a barrier from those copies to host reads.
///
/// # Safety
/// `cmd` is recording, after the dispatch, on `dev`; the buffers of `copies` outlive its
/// execution.
pub(crate) unsafe fn record_read_back(dev: &Device, cmd: vk::CommandBuffer, copies: &[ReadBack]) {
    let d = &dev.device;
    let barrier = |src_stage, dst_stage, src_access, dst_access| {
        let b = vk::MemoryBarrier::default()
            .src_access_mask(src_access)
            .dst_access_mask(dst_access);
        d.cmd_pipeline_barrier(
            cmd,
            src_stage,
            dst_stage,
            vk::DependencyFlags::empty(),
            &[b],
            &[],
            &[],
        );
    };
    if copies.is_empty() {
        barrier(
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::PipelineStageFlags::HOST,
            vk::AccessFlags::SHADER_WRITE,
            vk::AccessFlags::HOST_READ,
        );
        return;
    }
    barrier(
        vk::PipelineStageFlags::COMPUTE_SHADER,
        vk::PipelineStageFlags::TRANSFER,
        vk::AccessFlags::SHADER_WRITE,
        vk::AccessFlags::TRANSFER_READ,
    );
    for c in copies {
        let region = [vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: c.size,
        }];
        d.cmd_copy_buffer(cmd, c.src, c.dst, &region);
    }
    dev.count_staging_copies(copies.len() as u64);
    barrier(
        vk::PipelineStageFlags::TRANSFER,
        vk::PipelineStageFlags::HOST,
        vk::AccessFlags::TRANSFER_WRITE,
        vk::AccessFlags::HOST_READ,
    );
}

/// Copies `size` bytes of the staging buffer `src` to the device-local `dst` and waits, at most
/// [`crate::gpu::CHUNK_TIMEOUT`]; a barrier makes the copy visible to every later kernel.
/// On a timeout the device is marked hung and the command pool and fence are leaked.
pub(super) fn upload(dev: &Device, src: vk::Buffer, dst: vk::Buffer, size: u64) -> Result<()> {
    if let Some(e) = dev.refuse_if_hung() {
        return Err(e);
    }
    let d = &dev.device;
    let timeout = crate::gpu::CHUNK_TIMEOUT;
    // SAFETY: create infos outlive their calls; the pool and fence are released below unless the
    // copy may still run.
    unsafe {
        let pool = d
            .create_command_pool(
                &vk::CommandPoolCreateInfo::default().queue_family_index(dev.queue_family),
                None,
            )
            .ctx("creating a command pool for an upload")?;
        let fence = match d.create_fence(&vk::FenceCreateInfo::default(), None) {
            Ok(f) => f,
            Err(r) => {
                d.destroy_command_pool(pool, None);
                return Err(r).ctx("creating a fence for an upload");
            }
        };
        let release = || {
            d.destroy_fence(fence, None);
            d.destroy_command_pool(pool, None);
        };
        let recorded = record_upload(d, pool, src, dst, size);
        let cmd = match recorded {
            Ok(c) => c,
            Err(r) => {
                release();
                return Err(r).ctx("recording an upload");
            }
        };
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        let submitted = {
            let _queue = dev.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
            d.queue_submit(dev.queue, &submit, fence)
        };
        if let Err(r) = submitted {
            release();
            return Err(r).ctx("submitting an upload");
        }
        dev.count_staging_copies(1);
        match d.wait_for_fences(&[fence], true, timeout.as_nanos() as u64) {
            Ok(()) => {
                release();
                Ok(())
            }
            Err(vk::Result::TIMEOUT) => {
                dev.mark_hung();
                Err(GpuError::Timeout {
                    what: "an upload through a staging buffer".into(),
                    seconds: timeout.as_secs(),
                })
            }
            Err(r) => {
                release();
                Err(r).ctx("uploading through a staging buffer")
            }
        }
    }
}

/// Records, in a command buffer allocated from `pool`, the copy of `size` bytes from `src` to
/// `dst` and the barrier that makes it visible to every later kernel.
///
/// # Safety
/// `pool` belongs to `d` and is not in use on another thread; `src` and `dst` are buffers of `d`
/// of at least `size` bytes.
unsafe fn record_upload(
    d: &ash::Device,
    pool: vk::CommandPool,
    src: vk::Buffer,
    dst: vk::Buffer,
    size: u64,
) -> std::result::Result<vk::CommandBuffer, vk::Result> {
    let cmd = d.allocate_command_buffers(
        &vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1),
    )?[0];
    d.begin_command_buffer(
        cmd,
        &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
    )?;
    let region = [vk::BufferCopy {
        src_offset: 0,
        dst_offset: 0,
        size,
    }];
    d.cmd_copy_buffer(cmd, src, dst, &region);
    let b = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::SHADER_READ);
    d.cmd_pipeline_barrier(
        cmd,
        vk::PipelineStageFlags::TRANSFER,
        vk::PipelineStageFlags::COMPUTE_SHADER,
        vk::DependencyFlags::empty(),
        &[b],
        &[],
        &[],
    );
    d.end_command_buffer(cmd)?;
    Ok(cmd)
}
