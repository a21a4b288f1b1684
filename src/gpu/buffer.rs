//! Storage buffers in host-visible, coherent memory, mapped for their whole life. Lavapipe has
//! one memory type that is device-local, host-visible and coherent; on a discrete GPU we prefer
//! such a type (resizable BAR) and otherwise take plain host-visible memory, which the GPU reads
//! and writes over the bus. The kernels stream: each element is read or written once.

use super::device::Device;
use super::error::{Context, GpuError, Result};
use ash::vk;

/// One mapped storage buffer on a device, released when dropped.
pub struct Buffer<'d> {
    dev: &'d Device,
    pub(crate) buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    ptr: *mut u8,
    pub(crate) size: u64,
}

impl<'d> Buffer<'d> {
    /// Creates and maps a buffer of at least `size` bytes (16 at least); `what` names it in
    /// error messages ("parameter", "albedo node").
    pub fn new(dev: &'d Device, size: u64, what: &str) -> Result<Buffer<'d>> {
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
            let host =
                vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
            let Some(type_index) = dev
                .memory_type(
                    req.memory_type_bits,
                    host | vk::MemoryPropertyFlags::DEVICE_LOCAL,
                )
                .or_else(|| dev.memory_type(req.memory_type_bits, host))
            else {
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
