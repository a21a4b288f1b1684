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
//!
//! Here: [`Buffer`], its creation, mapping and release. `memory.rs` chooses the memory types
//! ([`place`]); `staging.rs` records the copies of staged buffers.

mod memory;
mod staging;

pub use memory::{
    choose_memory, memory_preferences, place, staging_preferences, MemoryUse, Placement,
};
pub(crate) use staging::{record_read_back, ReadBack};

use super::device::Device;
use super::error::{Context, GpuError, Result};
use ash::vk;
use memory::first_of;
use staging::upload;

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

    /// The first `n` u32 values of the buffer, as [`Buffer::read_f32`] reads f32.
    pub fn read_u32(&self, n: usize) -> &[u32] {
        bytemuck::cast_slice(self.read_f32(n))
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

/// The table runner's buffers, kept from one table to the next: its two chunk outputs and its
/// three inputs (parameter block, light list, view list). Fresh buffers cost the first touch of
/// every page on each table (on lavapipe a buffer's memory is fresh host memory; measured: with
/// fresh outputs page faults were a quarter of a table's CPU time, and fresh inputs took 0.4 ms
/// of a 12 ms table). A buffer is replaced only when a table needs it larger. Holds its device,
/// so the buffers cannot outlive it.
pub(crate) struct KeptTable {
    /// Declared before `dev`, so dropped before it.
    outs: Option<[Buffer<'static>; 2]>,
    /// One word per output, set by the kernel where it made an invalid value; declared before
    /// `dev`, so dropped before it.
    flags: Option<[Buffer<'static>; 2]>,
    /// Declared before `dev`, so dropped before it; indexed by [`TableInput`].
    inputs: [Option<Buffer<'static>>; 3],
    dev: std::sync::Arc<Device>,
}

/// An input of the table runner, as [`KeptTable`] keeps it.
#[derive(Clone, Copy, Debug)]
pub(crate) enum TableInput {
    /// The model's parameter block.
    Params = 0,
    /// The light directions.
    Lights = 1,
    /// The view directions.
    Views = 2,
}

impl TableInput {
    /// How errors name the buffer.
    fn what(self) -> &'static str {
        match self {
            TableInput::Params => "parameter",
            TableInput::Lights => "light direction",
            TableInput::Views => "view direction",
        }
    }
}

// SAFETY: the mappings are memory these buffers own, reached only through `&self` or
// `&mut self`; the runner holds the set behind a mutex and takes it out for one job at a time, so
// moving it to another thread moves sole use.
unsafe impl Send for KeptTable {}

impl KeptTable {
    /// No buffers yet, on `dev`.
    pub fn new(dev: &std::sync::Arc<Device>) -> KeptTable {
        KeptTable {
            outs: None,
            flags: None,
            inputs: [None, None, None],
            dev: dev.clone(),
        }
    }

    /// The device, for the lifetime the buffers claim.
    fn device(&self) -> &'static Device {
        // SAFETY: the Arc keeps the device at one address while `self` holds it; the buffers
        // that borrow it are dropped before the Arc (field order) and never handed out for
        // longer than a borrow of `self` ([`KeptTable::buffers`]).
        unsafe { &*std::sync::Arc::as_ptr(&self.dev) }
    }

    /// Makes sure each output buffer holds at least `size` bytes (the old pair is released
    /// before a larger one is made), and that each has its invalid-value flag.
    pub fn reserve_outputs(&mut self, size: u64) -> Result<()> {
        let d = self.device();
        if self.flags.is_none() {
            self.flags = Some([
                Buffer::output(d, 4, "invalid-value flag")?,
                Buffer::output(d, 4, "invalid-value flag")?,
            ]);
        }
        if self.outs.as_ref().is_some_and(|o| o[0].size >= size) {
            return Ok(());
        }
        self.outs = None;
        self.outs = Some([
            Buffer::output(d, size, "output")?,
            Buffer::output(d, size, "output")?,
        ]);
        Ok(())
    }

    /// Copies `data` into the input `which`, made larger first where it does not fit.
    pub fn write_input(&mut self, which: TableInput, data: &[u8]) -> Result<()> {
        let d = self.device();
        let slot = &mut self.inputs[which as usize];
        if !slot.as_ref().is_some_and(|b| b.size >= data.len() as u64) {
            // Released before the larger one is made.
            *slot = None;
        }
        let buffer = match slot {
            Some(b) => b,
            None => slot.insert(Buffer::new(d, data.len() as u64, which.what())?),
        };
        buffer.write(data)
    }

    /// The three inputs (in [`TableInput`] order), the two outputs and their flags, for as
    /// long as `self` is borrowed. Panics unless every input was written and the outputs
    /// reserved: the runner does both before it binds them.
    pub fn buffers(&self) -> ([&Buffer<'_>; 3], &[Buffer<'_>; 2], &[Buffer<'_>; 2]) {
        let input = |k: TableInput| {
            self.inputs[k as usize]
                .as_ref()
                .expect("the table runner writes its inputs before binding them")
        };
        (
            [
                input(TableInput::Params),
                input(TableInput::Lights),
                input(TableInput::Views),
            ],
            self.outs
                .as_ref()
                .expect("the table runner reserves its outputs before binding them"),
            self.flags
                .as_ref()
                .expect("the table runner reserves its outputs before binding them"),
        )
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
