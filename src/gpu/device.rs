//! Instance, device selection and the queue. A real GPU is preferred over a CPU driver
//! (lavapipe); [`DeviceOptions::name_contains`] picks by name, and [`DeviceOptions::validation`]
//! turns on the Khronos validation layer and counts what it reports, per device.

use super::error::{Context, GpuError, Result};
use ash::vk;
use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

unsafe extern "system" fn on_validation_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let serious = vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR;
    if severity.intersects(serious) {
        // SAFETY: `user` is the device's counter (`Arc::as_ptr`), which outlives the messenger.
        if let Some(count) = (user as *const AtomicUsize).as_ref() {
            count.fetch_add(1, Ordering::SeqCst);
        }
        let text = if data.is_null() || (*data).p_message.is_null() {
            "(no message)".into()
        } else {
            CStr::from_ptr((*data).p_message).to_string_lossy()
        };
        eprintln!("lobe: Vulkan validation {severity:?}: {text}");
    }
    vk::FALSE
}

/// Options for opening a device.
#[derive(Clone, Debug, Default)]
pub struct DeviceOptions {
    /// Pick the first device whose name contains this (case-insensitive).
    pub name_contains: Option<String>,
    /// Turn on the Khronos validation layer (package `vulkan-validationlayers`); every warning
    /// or error it reports is printed to stderr and counted ([`Device::validation_messages`]).
    pub validation: bool,
    /// Make every dispatch end as if the device had been lost (`VK_ERROR_DEVICE_LOST` from the
    /// fence wait), so that the path a real GPU reset takes (the message, the exit status, no
    /// partial output) can be tested without crashing a GPU.
    pub inject_device_lost: bool,
    /// Stage every buffer through a copy, as where device-local memory is not host-visible
    /// (see `src/gpu/buffer/`), even on a device that maps it directly: tests the staging
    /// path on lavapipe. The command line sets it with `LOBE_STAGING=1`.
    pub force_staging: bool,
    /// Make a GPU's kernel choices (one evaluation per invocation, lists read from storage
    /// buffers, the albedo workgroup tree) even on a CPU driver: tests on lavapipe the variants
    /// that only a GPU would otherwise run. Tests set it with `LOBE_GPU_KERNELS=1`.
    pub gpu_kernels: bool,
}

/// An open Vulkan device with one compute queue.
pub struct Device {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug: Option<Messenger>,
    pub(crate) device: ash::Device,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    /// Valid bits of the compute queue's timestamps (0: no timestamp queries).
    pub(crate) timestamp_bits: u32,
    pub(crate) memory: vk::PhysicalDeviceMemoryProperties,
    pub(crate) limits: vk::PhysicalDeviceLimits,
    name: String,
    /// The driver and its version ([`Device::driver`]).
    driver: String,
    device_type: vk::PhysicalDeviceType,
    /// Held around every queue submission (Vulkan requires the queue externally synchronised).
    pub(crate) queue_lock: Mutex<()>,
    /// See [`DeviceOptions::inject_device_lost`].
    pub(crate) inject_device_lost: bool,
    /// See [`DeviceOptions::force_staging`].
    pub(crate) force_staging: bool,
    /// See [`DeviceOptions::gpu_kernels`].
    gpu_kernels: bool,
    /// Staging copies submitted so far (uploads and read-backs).
    staging_copies: std::sync::atomic::AtomicU64,
    /// Warnings and errors the validation layer reported on this device (shared: the messenger
    /// holds a pointer to it, taken with `Arc::as_ptr`, which moving the `Arc` leaves valid).
    validation_messages: Arc<AtomicUsize>,
    /// Set when a submission timed out: it may still run, so nothing it could touch is freed.
    hung: std::sync::atomic::AtomicBool,
}

fn device_name(props: &vk::PhysicalDeviceProperties) -> String {
    props
        .device_name_as_c_str()
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_else(|_| "?".into())
}

/// The driver and its version: "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)" from the driver properties
/// (Vulkan 1.2, or VK_KHR_driver_properties), else the version number the device reports, whose
/// encoding is the vendor's.
fn driver_name(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    props: &vk::PhysicalDeviceProperties,
) -> String {
    // SAFETY: enumeration on a live instance and physical device.
    let extensions = unsafe { instance.enumerate_device_extension_properties(physical) };
    let has_extension = extensions.is_ok_and(|list| {
        list.iter()
            .any(|e| e.extension_name_as_c_str() == Ok(ash::khr::driver_properties::NAME))
    });
    if props.api_version >= vk::API_VERSION_1_2 || has_extension {
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
        // SAFETY: the chained struct is one the device supports (checked above).
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let text = |c: std::result::Result<&std::ffi::CStr, std::ffi::FromBytesUntilNulError>| {
            c.map(|c| c.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        let (name, info) = (
            text(driver.driver_name_as_c_str()),
            text(driver.driver_info_as_c_str()),
        );
        if !name.is_empty() || !info.is_empty() {
            return format!("{name} {info}").trim().to_string();
        }
    }
    format!("driver version {:#x}", props.driver_version)
}

/// Real GPUs first, then virtual, then CPU drivers such as lavapipe.
fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

/// The validation layer's messenger, with the loader of its extension.
type Messenger = (ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT);

/// What [`Device::finish_open`] has created, in order, before it describes the device.
struct Opened {
    entry: ash::Entry,
    instance: ash::Instance,
    debug: Option<Messenger>,
    validation_messages: Arc<AtomicUsize>,
    physical: vk::PhysicalDevice,
    queue_family: u32,
    device: ash::Device,
}

/// Creates the messenger that prints and counts, in `counter`, the validation layer's warnings
/// and errors.
fn create_messenger(
    entry: &ash::Entry,
    instance: &ash::Instance,
    counter: &Arc<AtomicUsize>,
) -> Result<Messenger> {
    let loader = ash::ext::debug_utils::Instance::new(entry, instance);
    let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(on_validation_message))
        .user_data(Arc::as_ptr(counter) as *mut c_void);
    // SAFETY: the callback is a plain function that lives for the whole program.
    match unsafe { loader.create_debug_utils_messenger(&info, None) } {
        Ok(m) => Ok((loader, m)),
        Err(r) => Err(GpuError::Vk {
            what: "creating the validation messenger".into(),
            result: r,
        }),
    }
}

/// Creates the logical device on `physical` with one queue of `queue_family`.
fn create_logical_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    queue_family: u32,
) -> Result<ash::Device> {
    let priorities = [1.0f32];
    let queue_info = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let info = vk::DeviceCreateInfo::default().queue_create_infos(&queue_info);
    // SAFETY: physical comes from this instance; the create info outlives the call.
    unsafe { instance.create_device(physical, &info, None) }.map_err(|r| GpuError::Vk {
        what: "creating the logical device".into(),
        result: r,
    })
}

/// Releases the messenger, then the instance (a later step of opening failed).
///
/// # Safety
/// Nothing else created from the instance is still alive.
unsafe fn destroy_instance(instance: &ash::Instance, debug: &Option<Messenger>) {
    if let Some((loader, m)) = debug {
        loader.destroy_debug_utils_messenger(*m, None);
    }
    instance.destroy_instance(None);
}

impl Device {
    /// Opens the best device (a real GPU before a CPU driver), or the one `opts` names.
    pub fn open(opts: &DeviceOptions) -> Result<Device> {
        // SAFETY: loading the system's Vulkan loader; the library stays loaded while `entry` lives.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))?;
        let validation = opts.validation;
        let layer_name = c"VK_LAYER_KHRONOS_validation";
        let mut layers = Vec::new();
        let mut extensions = Vec::new();
        if validation {
            // SAFETY: plain enumeration on a loaded entry.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .ctx("listing instance layers")?;
            if !available
                .iter()
                .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == layer_name))
            {
                return Err(GpuError::NoValidationLayer);
            }
            layers.push(layer_name.as_ptr());
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let app = vk::ApplicationInfo::default()
            .application_name(c"lobe")
            .application_version(1)
            .api_version(vk::API_VERSION_1_1);
        let info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        // SAFETY: the create info and the strings it points to outlive the call.
        let instance = unsafe { entry.create_instance(&info, None) }.map_err(|r| match r {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => GpuError::NoDevice,
            r => GpuError::Vk {
                what: "creating the Vulkan instance".into(),
                result: r,
            },
        })?;
        // finish_open releases the instance itself if a later step fails.
        Self::finish_open(entry, instance, validation, opts)
    }

    /// Opens the device on `instance`: the validation messenger where asked, the device
    /// `opts` picks, its queue and what the device says about itself.
    fn finish_open(
        entry: ash::Entry,
        instance: ash::Instance,
        validation: bool,
        opts: &DeviceOptions,
    ) -> Result<Device> {
        let validation_messages = Arc::new(AtomicUsize::new(0));
        let debug = if validation {
            match create_messenger(&entry, &instance, &validation_messages) {
                Ok(m) => Some(m),
                Err(e) => {
                    // SAFETY: nothing else was created from the instance.
                    unsafe { instance.destroy_instance(None) };
                    return Err(e);
                }
            }
        } else {
            None
        };
        let opened = Self::pick(&instance, opts).and_then(|(physical, queue_family)| {
            create_logical_device(&instance, physical, queue_family)
                .map(|device| (physical, queue_family, device))
        });
        match opened {
            Ok((physical, queue_family, device)) => Ok(Self::describe(
                Opened {
                    entry,
                    instance,
                    debug,
                    validation_messages,
                    physical,
                    queue_family,
                    device,
                },
                opts,
            )),
            Err(e) => {
                // SAFETY: no device was created from the instance; the messenger goes first.
                unsafe { destroy_instance(&instance, &debug) };
                Err(e)
            }
        }
    }

    /// The [`Device`] of what was opened: its queue, the queue's timestamp bits, the memory
    /// types, limits, name and driver, and the options that stay with it.
    fn describe(o: Opened, opts: &DeviceOptions) -> Device {
        let instance = &o.instance;
        // SAFETY: queries on a live instance and a physical device of it; queue 0 of a family
        // we asked one queue of.
        let (timestamp_bits, queue, memory, props) = unsafe {
            (
                instance.get_physical_device_queue_family_properties(o.physical)
                    [o.queue_family as usize]
                    .timestamp_valid_bits,
                o.device.get_device_queue(o.queue_family, 0),
                instance.get_physical_device_memory_properties(o.physical),
                instance.get_physical_device_properties(o.physical),
            )
        };
        let driver = driver_name(instance, o.physical, &props);
        Device {
            _entry: o.entry,
            instance: o.instance,
            debug: o.debug,
            device: o.device,
            queue,
            queue_family: o.queue_family,
            timestamp_bits,
            memory,
            limits: props.limits,
            name: device_name(&props),
            driver,
            device_type: props.device_type,
            queue_lock: Mutex::new(()),
            inject_device_lost: opts.inject_device_lost,
            force_staging: opts.force_staging,
            gpu_kernels: opts.gpu_kernels,
            staging_copies: Default::default(),
            validation_messages: o.validation_messages,
            hung: Default::default(),
        }
    }

    fn pick(instance: &ash::Instance, opts: &DeviceOptions) -> Result<(vk::PhysicalDevice, u32)> {
        // SAFETY: enumeration on a live instance.
        let physicals =
            unsafe { instance.enumerate_physical_devices() }.ctx("listing Vulkan devices")?;
        let mut candidates = Vec::new();
        for pd in physicals {
            let props = unsafe { instance.get_physical_device_properties(pd) };
            let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
            if let Some(qf) = families
                .iter()
                .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            {
                candidates.push((pd, qf as u32, device_name(&props), props.device_type));
            }
        }
        if candidates.is_empty() {
            return Err(GpuError::NoDevice);
        }
        candidates.sort_by_key(|c| type_rank(c.3));
        if let Some(wanted) = &opts.name_contains {
            let w = wanted.to_lowercase();
            return candidates
                .iter()
                .find(|c| c.2.to_lowercase().contains(&w))
                .map(|c| (c.0, c.1))
                .ok_or_else(|| GpuError::NoMatchingDevice {
                    wanted: wanted.clone(),
                    available: candidates
                        .iter()
                        .map(|c| c.2.clone())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
        }
        Ok((candidates[0].0, candidates[0].1))
    }

    /// The device's name as the driver reports it.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The driver and its version, e.g. "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)".
    pub fn driver(&self) -> &str {
        &self.driver
    }

    /// How many warnings and errors the validation layer has reported on this device so far
    /// (always 0 without [`DeviceOptions::validation`]).
    pub fn validation_messages(&self) -> usize {
        self.validation_messages.load(Ordering::SeqCst)
    }

    /// How many staging copies (uploads to device-local buffers and read-backs from them) were
    /// submitted on this device so far: 0 where every buffer is mapped directly.
    pub fn staging_copies(&self) -> u64 {
        self.staging_copies.load(Ordering::Relaxed)
    }

    /// Adds `n` to [`Device::staging_copies`].
    pub(crate) fn count_staging_copies(&self, n: u64) {
        self.staging_copies.fetch_add(n, Ordering::Relaxed);
    }

    /// Whether this is a CPU implementation such as lavapipe.
    pub fn is_cpu(&self) -> bool {
        self.device_type == vk::PhysicalDeviceType::CPU
    }

    /// Whether the kernels take their CPU-driver variants: on a CPU implementation, unless
    /// [`DeviceOptions::gpu_kernels`] asks for a GPU's.
    pub fn cpu_kernels(&self) -> bool {
        self.is_cpu() && !self.gpu_kernels
    }

    /// Records that a submission timed out and may still run: from then on the device takes no
    /// more work, and buffers, dispatchers, pipelines and the device itself are leaked when
    /// dropped instead of being freed under it.
    pub fn mark_hung(&self) {
        self.hung.store(true, Ordering::SeqCst);
    }

    /// Whether a submission timed out on this device ([`Device::mark_hung`]).
    pub fn is_hung(&self) -> bool {
        self.hung.load(Ordering::SeqCst)
    }

    /// [`GpuError::Hung`] once the device is hung.
    pub(crate) fn refuse_if_hung(&self) -> Option<GpuError> {
        self.is_hung().then_some(GpuError::Hung)
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        if self.is_hung() {
            // Work may still run on it: waiting could block for ever, destroying is undefined.
            return;
        }
        // SAFETY: every object created from the device is owned by something that borrows it and has
        // been dropped already; release in reverse order of creation.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
            if let Some((loader, m)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
