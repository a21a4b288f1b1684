//! Storage buffers in host-visible, coherent memory, mapped for their whole life, of a memory type
//! chosen per use by [`choose_memory`]: inputs (written by the host, read by a kernel) prefer
//! device-local memory the host can write (resizable BAR, or one memory for both as on lavapipe);
//! outputs (written by a kernel, read back by the host) prefer host-cached memory, so that the
//! read-back is not an uncached read through the write-combined BAR window. Lavapipe has one memory
//! type that is device-local, host-visible, coherent and cached, which serves both. The kernels
//! stream: each element is read or written once.

use super::device::Device;
use super::error::{Context, GpuError, Result};
use ash::vk;

/// What a buffer is for, which decides its memory type ([`choose_memory`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryUse {
    /// Written by the host, read by a kernel (parameters, directions, nodes).
    Input,
    /// Written by a kernel, read back by the host (table cells, partial sums, pixels).
    Output,
}

/// The memory types `use_` accepts, best first. Every one is host-visible and coherent (the
/// buffers are mapped and never flushed or invalidated).
pub fn memory_preferences(use_: MemoryUse) -> &'static [vk::MemoryPropertyFlags] {
    const DL: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
    const HV: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_VISIBLE;
    const HC: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_COHERENT;
    const CA: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_CACHED;
    const IN: &[vk::MemoryPropertyFlags] = &[
        vk::MemoryPropertyFlags::from_raw(DL.as_raw() | HV.as_raw() | HC.as_raw()),
        vk::MemoryPropertyFlags::from_raw(HV.as_raw() | HC.as_raw()),
    ];
    const OUT: &[vk::MemoryPropertyFlags] = &[
        vk::MemoryPropertyFlags::from_raw(DL.as_raw() | HV.as_raw() | HC.as_raw() | CA.as_raw()),
        vk::MemoryPropertyFlags::from_raw(HV.as_raw() | HC.as_raw() | CA.as_raw()),
        vk::MemoryPropertyFlags::from_raw(DL.as_raw() | HV.as_raw() | HC.as_raw()),
        vk::MemoryPropertyFlags::from_raw(HV.as_raw() | HC.as_raw()),
    ];
    match use_ {
        MemoryUse::Input => IN,
        MemoryUse::Output => OUT,
    }
}

/// The memory type a buffer for `use_` takes among `type_bits` (the buffer's allowed types) of
/// a device with memory properties `props`: the first of [`memory_preferences`] that some type
/// has, the lowest such index; None if no allowed type is host-visible and coherent.
pub fn choose_memory(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    use_: MemoryUse,
) -> Option<u32> {
    memory_preferences(use_).iter().find_map(|&flags| {
        (0..props.memory_type_count.min(vk::MAX_MEMORY_TYPES as u32)).find(|&i| {
            type_bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    })
}

/// One mapped storage buffer on a device, released when dropped.
pub struct Buffer<'d> {
    dev: &'d Device,
    pub(crate) buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    ptr: *mut u8,
    pub(crate) size: u64,
}

impl<'d> Buffer<'d> {
    /// Creates and maps an input buffer ([`MemoryUse::Input`]) of at least `size` bytes (16 at
    /// least); `what` names it in error messages ("parameter", "albedo node").
    pub fn new(dev: &'d Device, size: u64, what: &str) -> Result<Buffer<'d>> {
        Self::with_use(dev, size, what, MemoryUse::Input)
    }

    /// [`Buffer::new`] for a kernel's output ([`MemoryUse::Output`]).
    pub fn output(dev: &'d Device, size: u64, what: &str) -> Result<Buffer<'d>> {
        Self::with_use(dev, size, what, MemoryUse::Output)
    }

    /// [`Buffer::new`] for `use_`.
    pub fn with_use(dev: &'d Device, size: u64, what: &str, use_: MemoryUse) -> Result<Buffer<'d>> {
        let size = size.max(16);
        let d = &dev.device;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            // Any buffer may be read as a texel buffer too (the table kernel's direction lists).
            .usage(
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info on a live device; every object is released on the error paths.
        unsafe {
            let buffer = d
                .create_buffer(&info, None)
                .ctx(&format!("creating the {what} buffer ({size} bytes)"))?;
            let req = d.get_buffer_memory_requirements(buffer);
            let Some(type_index) = choose_memory(&dev.memory, req.memory_type_bits, use_) else {
                d.destroy_buffer(buffer, None);
                return Err(GpuError::Limit(format!(
                    "the device has no host-visible coherent memory for the {what} buffer"
                )));
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
            let mapped = d
                .bind_buffer_memory(buffer, memory, 0)
                .and_then(|_| d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()));
            match mapped {
                Ok(ptr) => Ok(Buffer {
                    dev,
                    buffer,
                    memory,
                    ptr: ptr.cast(),
                    size,
                }),
                Err(r) => {
                    d.destroy_buffer(buffer, None);
                    d.free_memory(memory, None);
                    Err(r).ctx(&format!("binding and mapping the {what} buffer"))
                }
            }
        }
    }

    /// Copies `data` to the start of the buffer.
    pub fn write(&mut self, data: &[u8]) {
        assert!(
            data.len() as u64 <= self.size,
            "write of {} bytes into a {}-byte buffer",
            data.len(),
            self.size
        );
        // SAFETY: the mapping covers `size` bytes and the GPU is idle (every dispatch is waited for).
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), self.ptr, data.len()) };
    }

    /// The first `n` f32 values of the buffer.
    pub fn read_f32(&self, n: usize) -> &[f32] {
        assert!((n * 4) as u64 <= self.size);
        // SAFETY: the mapping is 4-byte aligned (Vulkan maps at least at minMemoryMapAlignment),
        // covers `size` bytes, and the GPU is idle.
        unsafe { std::slice::from_raw_parts(self.ptr as *const f32, n) }
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
            self.dev.device.unmap_memory(self.memory);
            self.dev.device.destroy_buffer(self.buffer, None);
            self.dev.device.free_memory(self.memory, None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DL: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
    const HV: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_VISIBLE;
    const HC: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_COHERENT;
    const CA: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_CACHED;

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

    #[test]
    fn lavapipe_has_one_memory_type_for_everything() {
        // Mesa lavapipe: a single type, device-local, host-visible, coherent and cached.
        let p = props(&[DL | HV | HC | CA]);
        assert_eq!(choose_memory(&p, 1, MemoryUse::Input), Some(0));
        assert_eq!(choose_memory(&p, 1, MemoryUse::Output), Some(0));
    }

    #[test]
    fn a_discrete_gpu_reads_back_from_cached_memory_and_writes_inputs_through_the_bar() {
        // The types of a discrete GPU with resizable BAR (as NVIDIA drivers list them):
        // 0 device-local only, 1 host-visible coherent (write-combined system memory),
        // 2 host-visible coherent cached (system memory), 3 device-local host-visible (BAR).
        let p = props(&[DL, HV | HC, HV | HC | CA, DL | HV | HC]);
        assert_eq!(choose_memory(&p, 0b1111, MemoryUse::Input), Some(3));
        assert_eq!(choose_memory(&p, 0b1111, MemoryUse::Output), Some(2));
        // Without the BAR type, inputs go to plain host-visible memory.
        assert_eq!(choose_memory(&p, 0b0111, MemoryUse::Input), Some(1));
        // A buffer that allows only device-local memory cannot be mapped.
        assert_eq!(choose_memory(&p, 0b0001, MemoryUse::Output), None);
    }
}
