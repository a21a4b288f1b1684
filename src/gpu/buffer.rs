//! Storage buffers and where their memory lives. Each buffer has a memory type chosen per use by
//! [`place`]:
//!
//! - inputs (written by the host, read by a kernel) live in device-local memory. Where some
//!   device-local type is also host-visible (resizable BAR, or one memory for everything as on
//!   lavapipe) the buffer is mapped and written directly; otherwise the host writes a staging
//!   buffer and one `vkCmdCopyBuffer` moves it to the device-local buffer before any kernel runs.
//! - outputs (written by a kernel, read back by the host) are read from host-cached memory, never
//!   through the uncached, write-combined BAR window. Where some device-local type is also
//!   host-cached (lavapipe, integrated GPUs) the kernel writes it and the host reads it directly;
//!   otherwise the kernel writes device-local memory and the same command buffer copies it to a
//!   host-cached staging buffer after the dispatch, so a double-buffered runner reads one chunk
//!   back while the next runs.
//!
//! Lavapipe has one memory type that is device-local, host-visible, coherent and cached, so every
//! buffer there is direct: no copy is made. [`super::DeviceOptions::force_staging`] takes the
//! staging path anyway, so that it can be tested there. Mapped memory is always coherent (never
//! flushed or invalidated). The kernels stream: each element is read or written once.

use super::device::Device;
use super::error::{Context, GpuError, Result};
use ash::vk;

/// What a buffer is for, which decides its memory type ([`place`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryUse {
    /// Written by the host, read by a kernel (parameters, directions, nodes).
    Input,
    /// Written by a kernel, read back by the host (table cells, partial sums, pixels).
    Output,
}

const DL: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
const HV: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_VISIBLE;
const HC: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_COHERENT;
const CA: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_CACHED;

const fn or(flags: &[vk::MemoryPropertyFlags]) -> vk::MemoryPropertyFlags {
    let mut raw = 0;
    let mut k = 0;
    while k < flags.len() {
        raw |= flags[k].as_raw();
        k += 1;
    }
    vk::MemoryPropertyFlags::from_raw(raw)
}

/// The memory types `use_` accepts for a buffer the host maps and a kernel binds (no staging),
/// best first: device-local and mapped (with HOST_CACHED for outputs). The last entries, plain
/// host-visible memory, serve only a device without any device-local type.
pub fn memory_preferences(use_: MemoryUse) -> &'static [vk::MemoryPropertyFlags] {
    const IN: &[vk::MemoryPropertyFlags] = &[or(&[DL, HV, HC]), or(&[HV, HC])];
    const OUT: &[vk::MemoryPropertyFlags] = &[
        or(&[DL, HV, HC, CA]),
        or(&[HV, HC, CA]),
        or(&[DL, HV, HC]),
        or(&[HV, HC]),
    ];
    match use_ {
        MemoryUse::Input => IN,
        MemoryUse::Output => OUT,
    }
}

/// The memory types a staging buffer for `use_` accepts, best first: any host-visible coherent
/// memory for uploads (write-combined is fine for a sequential write), host-cached memory for
/// read-backs.
pub fn staging_preferences(use_: MemoryUse) -> &'static [vk::MemoryPropertyFlags] {
    const IN: &[vk::MemoryPropertyFlags] = &[or(&[HV, HC])];
    const OUT: &[vk::MemoryPropertyFlags] = &[or(&[HV, HC, CA]), or(&[HV, HC])];
    match use_ {
        MemoryUse::Input => IN,
        MemoryUse::Output => OUT,
    }
}

/// The first of `prefs` that some type in `type_bits` has, the lowest such index.
fn first_of(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    prefs: &[vk::MemoryPropertyFlags],
) -> Option<u32> {
    prefs.iter().find_map(|&flags| {
        (0..props.memory_type_count.min(vk::MAX_MEMORY_TYPES as u32)).find(|&i| {
            type_bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    })
}

/// The memory type a directly mapped buffer for `use_` takes among `type_bits` (the buffer's
/// allowed types) of a device with memory properties `props`: the first of
/// [`memory_preferences`] that some type has, the lowest such index; None if no allowed type is
/// host-visible and coherent.
pub fn choose_memory(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    use_: MemoryUse,
) -> Option<u32> {
    first_of(props, type_bits, memory_preferences(use_))
}

/// Where a buffer's memory lives ([`place`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// One buffer, mapped by the host and bound by the kernel, of this memory type.
    Direct(u32),
    /// A device-local buffer the kernel binds (`device`, a memory type index) and a mapped
    /// staging buffer (`staging`) the host writes or reads, joined by a copy on the device.
    Staged {
        /// Memory type of the buffer the kernel binds.
        device: u32,
        /// Memory type of the host's staging buffer.
        staging: u32,
    },
}

/// Where a buffer for `use_` lives on a device with memory properties `props`, its kernel-side
/// buffer allowing the types `type_bits` and a staging buffer `staging_bits`: direct where a
/// device-local type serves the use mapped (host-visible for inputs, host-visible and cached for
/// outputs), else staged through device-local memory, and also staged when `force_staging` (if
/// the device has device-local memory at all). A device without device-local memory maps plain
/// host-visible memory. None if nothing fits.
pub fn place(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    staging_bits: u32,
    use_: MemoryUse,
    force_staging: bool,
) -> Option<Placement> {
    let best = memory_preferences(use_)[0];
    if !force_staging {
        if let Some(t) = first_of(props, type_bits, &[best]) {
            return Some(Placement::Direct(t));
        }
    }
    match first_of(props, type_bits, &[DL]) {
        Some(device) => first_of(props, staging_bits, staging_preferences(use_))
            .map(|staging| Placement::Staged { device, staging }),
        None => choose_memory(props, type_bits, use_).map(Placement::Direct),
    }
}

/// A Vulkan buffer with its own memory.
struct Raw {
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
}

impl Raw {
    /// Creates a buffer of `size` bytes for `usage`, its memory of the type `pick` chooses from
    /// the buffer's allowed types (None: `no_memory` is the error); `what` names it in errors.
    fn new(
        dev: &Device,
        size: u64,
        usage: vk::BufferUsageFlags,
        what: &str,
        pick: impl FnOnce(u32) -> std::result::Result<u32, GpuError>,
    ) -> Result<Raw> {
        let d = &dev.device;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info on a live device; every object is released on the error paths.
        unsafe {
            let buffer = d
                .create_buffer(&info, None)
                .ctx(&format!("creating the {what} buffer ({size} bytes)"))?;
            let req = d.get_buffer_memory_requirements(buffer);
            let type_index = match pick(req.memory_type_bits) {
                Ok(t) => t,
                Err(e) => {
                    d.destroy_buffer(buffer, None);
                    return Err(e);
                }
            };
            let alloc = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(type_index);
            let memory = match d.allocate_memory(&alloc, None) {
                Ok(m) => m,
                Err(r) => {
                    d.destroy_buffer(buffer, None);
                    return Err(r).ctx(&format!(
                        "allocating {} bytes for the {what} buffer",
                        req.size
                    ));
                }
            };
            if let Err(r) = d.bind_buffer_memory(buffer, memory, 0) {
                d.destroy_buffer(buffer, None);
                d.free_memory(memory, None);
                return Err(r).ctx(&format!("binding the {what} buffer's memory"));
            }
            Ok(Raw { buffer, memory })
        }
    }

    /// Releases the buffer and its memory (unmapped first where `mapped`).
    ///
    /// # Safety
    /// No submission that uses the buffer may still run.
    unsafe fn destroy(&self, dev: &Device, mapped: bool) {
        if mapped {
            dev.device.unmap_memory(self.memory);
        }
        dev.device.destroy_buffer(self.buffer, None);
        dev.device.free_memory(self.memory, None);
    }
}

/// One storage buffer on a device, released when dropped: mapped directly, or a device-local
/// buffer with a mapped staging buffer beside it ([`Placement`]).
pub struct Buffer<'d> {
    dev: &'d Device,
    /// The buffer kernels bind.
    pub(crate) buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    /// The staging buffer the host maps, where the buffer is staged.
    staging: Option<Raw>,
    use_: MemoryUse,
    /// The host's mapping: of `memory`, or of the staging buffer's.
    ptr: *mut u8,
    pub(crate) size: u64,
}

/// A read-back a dispatch records after its kernel: the device-local output `src` into its
/// staging buffer `dst`, `size` bytes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ReadBack {
    src: vk::Buffer,
    dst: vk::Buffer,
    size: u64,
}

/// Usage of every buffer a kernel binds: storage, texel (the table kernel reads its direction
/// lists that way), and either end of a staging copy.
const KERNEL_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw(),
);

impl<'d> Buffer<'d> {
    /// Creates an input buffer ([`MemoryUse::Input`]) of at least `size` bytes (16 at least);
    /// `what` names it in error messages ("parameter", "albedo node").
    pub fn new(dev: &'d Device, size: u64, what: &str) -> Result<Buffer<'d>> {
        Self::with_use(dev, size, what, MemoryUse::Input)
    }

    /// [`Buffer::new`] for a kernel's output ([`MemoryUse::Output`]).
    pub fn output(dev: &'d Device, size: u64, what: &str) -> Result<Buffer<'d>> {
        Self::with_use(dev, size, what, MemoryUse::Output)
    }

    /// [`Buffer::new`] for `use_`, placed by [`place`].
    pub fn with_use(dev: &'d Device, size: u64, what: &str, use_: MemoryUse) -> Result<Buffer<'d>> {
        let size = size.max(16);
        let force = dev.force_staging;
        let no_memory = || {
            GpuError::Limit(format!(
                "the device has no memory a {what} buffer can use (host-visible and coherent, or device-local with a host-visible staging buffer)"
            ))
        };
        // The kernel's buffer first: its allowed types decide direct or staged (the staging
        // buffer's own allowed types are not known yet, so any are assumed for that choice).
        let mut staged = false;
        let main = Raw::new(dev, size, KERNEL_USAGE, what, |bits| {
            match place(&dev.memory, bits, u32::MAX, use_, force) {
                Some(Placement::Direct(t)) => Ok(t),
                Some(Placement::Staged { device, .. }) => {
                    staged = true;
                    Ok(device)
                }
                None => Err(no_memory()),
            }
        })?;
        let staging = if staged {
            let usage = match use_ {
                MemoryUse::Input => vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryUse::Output => vk::BufferUsageFlags::TRANSFER_DST,
            };
            let what = format!("{what} staging");
            let raw = Raw::new(dev, size, usage, &what, |bits| {
                first_of(&dev.memory, bits, staging_preferences(use_)).ok_or_else(no_memory)
            });
            match raw {
                Ok(r) => Some(r),
                Err(e) => {
                    // SAFETY: nothing has used the buffer yet.
                    unsafe { main.destroy(dev, false) };
                    return Err(e);
                }
            }
        } else {
            None
        };
        let mapped_memory = staging.as_ref().map_or(main.memory, |s| s.memory);
        // SAFETY: the memory is host-visible (chosen so) and not mapped yet.
        let mapped = unsafe {
            dev.device.map_memory(
                mapped_memory,
                0,
                vk::WHOLE_SIZE,
                vk::MemoryMapFlags::empty(),
            )
        };
        match mapped {
            Ok(ptr) => Ok(Buffer {
                dev,
                buffer: main.buffer,
                memory: main.memory,
                staging,
                use_,
                ptr: ptr.cast(),
                size,
            }),
            Err(r) => {
                // SAFETY: nothing has used the buffers yet.
                unsafe {
                    main.destroy(dev, false);
                    if let Some(s) = &staging {
                        s.destroy(dev, false);
                    }
                }
                Err(r).ctx(&format!("mapping the {what} buffer"))
            }
        }
    }

    /// Whether the buffer is staged: the kernel binds device-local memory that the host reaches
    /// through a copy ([`Placement::Staged`]).
    pub fn is_staged(&self) -> bool {
        self.staging.is_some()
    }

    /// Copies `data` to the start of the buffer; a staged input is then copied to its
    /// device-local buffer, and waited for, before this returns.
    pub fn write(&mut self, data: &[u8]) -> Result<()> {
        assert!(
            data.len() as u64 <= self.size,
            "write of {} bytes into a {}-byte buffer",
            data.len(),
            self.size
        );
        // SAFETY: the mapping covers `size` bytes and no submission uses the buffer (every
        // dispatch that reads it has been waited for).
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), self.ptr, data.len()) };
        match &self.staging {
            Some(s) if self.use_ == MemoryUse::Input && !data.is_empty() => {
                upload(self.dev, s.buffer, self.buffer, data.len() as u64)
            }
            _ => Ok(()),
        }
    }

    /// Lets `fill` write the first `len` bytes of the buffer in place, through the host's
    /// mapping (no copy of the data); a staged input is then copied to its device-local buffer,
    /// and waited for, before this returns.
    pub fn write_in_place(&mut self, len: usize, fill: impl FnOnce(&mut [u8])) -> Result<()> {
        assert!(
            len as u64 <= self.size,
            "write of {len} bytes into a {}-byte buffer",
            self.size
        );
        // SAFETY: the mapping covers `size` bytes, this borrow is the only access to it, and no
        // submission uses the buffer (every dispatch that reads it has been waited for).
        fill(unsafe { std::slice::from_raw_parts_mut(self.ptr, len) });
        match &self.staging {
            Some(s) if self.use_ == MemoryUse::Input && len > 0 => {
                upload(self.dev, s.buffer, self.buffer, len as u64)
            }
            _ => Ok(()),
        }
    }

    /// The first `n` f32 values of the buffer (of its staging buffer, where staged: the
    /// dispatch that wrote it copied them there).
    pub fn read_f32(&self, n: usize) -> &[f32] {
        assert!((n * 4) as u64 <= self.size);
        // SAFETY: the mapping is 4-byte aligned (Vulkan maps at least at minMemoryMapAlignment),
        // covers `size` bytes, and the submission that wrote it has been waited for.
        unsafe { std::slice::from_raw_parts(self.ptr as *const f32, n) }
    }

    /// The copy a dispatch records after its kernel for this buffer: a staged output's
    /// device-local memory into its staging buffer; None for anything else.
    pub(crate) fn read_back(&self) -> Option<ReadBack> {
        match (&self.staging, self.use_) {
            (Some(s), MemoryUse::Output) => Some(ReadBack {
                src: self.buffer,
                dst: s.buffer,
                size: self.size,
            }),
            _ => None,
        }
    }
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
/// [`super::CHUNK_TIMEOUT`]; a barrier makes the copy visible to every later kernel.
/// On a timeout the device is marked hung and the command pool and fence are leaked.
fn upload(dev: &Device, src: vk::Buffer, dst: vk::Buffer, size: u64) -> Result<()> {
    if let Some(e) = dev.refuse_if_hung() {
        return Err(e);
    }
    let d = &dev.device;
    let timeout = super::CHUNK_TIMEOUT;
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
        let recorded = (|| -> std::result::Result<vk::CommandBuffer, vk::Result> {
            let cmd = d.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1),
            )?[0];
            d.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
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
        })();
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

impl Drop for Buffer<'_> {
    fn drop(&mut self) {
        if self.dev.is_hung() {
            // A timed-out submission may still read or write this memory: leak it.
            return;
        }
        // SAFETY: the GPU is idle after every dispatch; unmap, then release in reverse order.
        unsafe {
            let main = Raw {
                buffer: self.buffer,
                memory: self.memory,
            };
            main.destroy(self.dev, self.staging.is_none());
            if let Some(s) = &self.staging {
                s.destroy(self.dev, true);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn props(types: &[vk::MemoryPropertyFlags]) -> vk::PhysicalDeviceMemoryProperties {
        let mut p = vk::PhysicalDeviceMemoryProperties {
            memory_type_count: types.len() as u32,
            ..Default::default()
        };
        for (t, &f) in p.memory_types.iter_mut().zip(types) {
            t.property_flags = f;
        }
        p
    }

    use MemoryUse::{Input, Output};
    use Placement::{Direct, Staged};

    #[test]
    fn lavapipe_maps_one_memory_type_for_everything() {
        // Mesa lavapipe: a single type, device-local, host-visible, coherent and cached.
        let p = props(&[DL | HV | HC | CA]);
        assert_eq!(place(&p, 1, 1, Input, false), Some(Direct(0)));
        assert_eq!(place(&p, 1, 1, Output, false), Some(Direct(0)));
        // Forced staging binds the same type and stages through it.
        let both = Some(Staged {
            device: 0,
            staging: 0,
        });
        assert_eq!(place(&p, 1, 1, Input, true), both);
        assert_eq!(place(&p, 1, 1, Output, true), both);
    }

    #[test]
    fn a_discrete_gpu_stages_outputs_to_cached_memory_and_writes_inputs_through_the_bar() {
        // The types of a discrete GPU with resizable BAR (as NVIDIA drivers list them):
        // 0 device-local only, 1 host-visible coherent (write-combined system memory),
        // 2 host-visible coherent cached (system memory), 3 device-local host-visible (BAR).
        let p = props(&[DL, HV | HC, HV | HC | CA, DL | HV | HC]);
        assert_eq!(place(&p, 0b1111, 0b1111, Input, false), Some(Direct(3)));
        assert_eq!(
            place(&p, 0b1111, 0b1111, Output, false),
            Some(Staged {
                device: 0,
                staging: 2
            })
        );
        // Without the BAR type, inputs are staged through write-combined system memory.
        assert_eq!(
            place(&p, 0b0111, 0b0111, Input, false),
            Some(Staged {
                device: 0,
                staging: 1
            })
        );
        // Staging needs a host-visible type for the staging buffer.
        assert_eq!(place(&p, 0b0001, 0b0001, Output, false), None);
    }

    #[test]
    fn an_integrated_gpu_maps_cached_device_local_memory() {
        // A unified-memory GPU: 0 device-local, 1 device-local host-visible coherent cached.
        let p = props(&[DL, DL | HV | HC | CA]);
        assert_eq!(place(&p, 0b11, 0b11, Input, false), Some(Direct(1)));
        assert_eq!(place(&p, 0b11, 0b11, Output, false), Some(Direct(1)));
    }

    #[test]
    fn a_device_without_device_local_memory_maps_host_memory() {
        let p = props(&[HV | HC]);
        assert_eq!(place(&p, 1, 1, Input, true), Some(Direct(0)));
        assert_eq!(place(&p, 1, 1, Output, false), Some(Direct(0)));
        assert_eq!(choose_memory(&p, 1, Output), Some(0));
    }
}
