//! Errors at the GPU boundary are sentences: what was being attempted, and what to do about it.

use ash::vk;

/// The packages that give a Debian/Ubuntu machine a Vulkan loader and a CPU driver (lavapipe).
pub const INSTALL_HINT: &str = "install the Vulkan loader and Mesa's drivers (lavapipe runs Vulkan on the CPU): \
`sudo apt-get install -y libvulkan1 mesa-vulkan-drivers`; or evaluate on the CPU backend (the f64 reference, no Vulkan needed)";

/// Why the GPU backend could not start or could not finish a job.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// `libvulkan.so.1` could not be loaded; the text is the loader's own reason.
    #[error("no Vulkan loader (libvulkan.so.1) could be loaded: {0}; {INSTALL_HINT}")]
    NoLoader(String),
    /// The loader works but lists no device with a compute queue.
    #[error("the Vulkan loader found no device with a compute queue; {INSTALL_HINT}")]
    NoDevice,
    /// No device name contains the text asked for.
    #[error("no Vulkan device name contains '{wanted}'; the devices are: {available}")]
    NoMatchingDevice {
        /// The text asked for (`--device`), matched against device names.
        wanted: String,
        /// The names of the devices there are, comma-separated.
        available: String,
    },
    /// The Khronos validation layer was asked for ([`super::DeviceOptions::validation`]) but is not installed.
    #[error(
        "Vulkan validation was requested but VK_LAYER_KHRONOS_validation is not installed: \
`sudo apt-get install -y vulkan-validationlayers`"
    )]
    NoValidationLayer,
    /// The device was lost (a driver or GPU reset); the text says what was running.
    #[error("the Vulkan device was lost while {0}; the driver or GPU reset. Rerun, pick another device, or use the CPU backend")]
    DeviceLost(String),
    /// A submission did not finish within the per-chunk time limit.
    #[error("the GPU did not finish {what} within {seconds} s; the device may be hung, so its memory was left allocated rather than freed under running work. Use smaller work or the CPU backend")]
    Timeout {
        /// The label of the pipeline that was running.
        what: String,
        /// The time limit, seconds.
        seconds: u64,
    },
    /// A submission with a model's own time limit ([`crate::model::Model::chunk_timeout`], set
    /// for kernels compiled at run time) did not finish: its shader may never return.
    #[error("the GPU work {what} did not finish within {seconds} s, the limit for one chunk of this model's work: its shader may never return (a loop without end) or be too slow for that limit; the device may be hung, so its memory was left allocated and it takes no more work")]
    ModelTimeout {
        /// The label of the pipeline that was running.
        what: String,
        /// The time limit, seconds.
        seconds: f64,
    },
    /// A submission on this device timed out earlier: it may still run, so the device takes no
    /// more work.
    #[error("the Vulkan device timed out on an earlier submission and takes no more work; restart, or use the CPU backend")]
    Hung,
    /// Any other failed Vulkan call.
    #[error("Vulkan call failed while {what}: {result}")]
    Vk {
        /// What was being attempted.
        what: String,
        /// The code the call returned.
        result: vk::Result,
    },
    /// The work does not fit a device limit or a kernel's index range, or a kernel's SPIR-V is
    /// unreadable; the text is a sentence saying which.
    #[error("{0}")]
    Limit(String),
    /// A kernel saw NaN, ±Inf or negative BRDF values where the job needs valid ones.
    #[error(transparent)]
    InvalidValues(crate::finite::InvalidValues),
    /// No SPIR-V for this (kernel, model) pair was built into the binary or given at run time.
    #[error("no SPIR-V kernel '{kernel}' for model '{model}' was built into this binary")]
    MissingKernel {
        /// The kernel's name (`table`, `pairs`, `albedo`, `preview`).
        kernel: String,
        /// The model's name.
        model: String,
    },
}

/// The result of a GPU operation.
pub type Result<T> = std::result::Result<T, GpuError>;

/// Attaches to a Vulkan result what was being attempted.
pub trait Context<T> {
    /// Turns a failed Vulkan call into a [`GpuError`] that says what was being attempted
    /// (`what`, such as "running table/phong"); a lost device becomes [`GpuError::DeviceLost`].
    fn ctx(self, what: &str) -> Result<T>;
}

impl<T> Context<T> for std::result::Result<T, vk::Result> {
    fn ctx(self, what: &str) -> Result<T> {
        self.map_err(|result| match result {
            vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(what.to_string()),
            _ => GpuError::Vk {
                what: what.to_string(),
                result,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lost_device_says_so_and_what_to_do() {
        let e = Err::<(), _>(vk::Result::ERROR_DEVICE_LOST)
            .ctx("running table/phong")
            .unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, GpuError::DeviceLost(_)), "{e:?}");
        assert!(
            text.contains("device was lost while running table/phong"),
            "{text}"
        );
        assert!(text.contains("the CPU backend"), "{text}");
    }
}
