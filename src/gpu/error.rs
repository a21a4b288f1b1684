//! Errors at the GPU boundary are sentences: what was being attempted, and what to do about it.

use ash::vk;

/// The packages that give a Debian/Ubuntu machine a Vulkan loader and a CPU driver (lavapipe).
pub const INSTALL_HINT: &str = "install the Vulkan loader and Mesa's drivers (lavapipe runs Vulkan on the CPU): \
`sudo apt-get install -y libvulkan1 mesa-vulkan-drivers`; or evaluate on the CPU backend (the f64 reference, no Vulkan needed)";

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no Vulkan loader (libvulkan.so.1) could be loaded: {0}; {INSTALL_HINT}")]
    NoLoader(String),
    #[error("the Vulkan loader found no device with a compute queue; {INSTALL_HINT}")]
    NoDevice,
    #[error("no Vulkan device name contains '{wanted}'; the devices are: {available}")]
    NoMatchingDevice { wanted: String, available: String },
    #[error("Vulkan validation was requested (LOBE_VALIDATION=1) but VK_LAYER_KHRONOS_validation is not installed: \
`sudo apt-get install -y vulkan-validationlayers`")]
    NoValidationLayer,
    #[error("the Vulkan device was lost while {0}; the driver or GPU reset. Rerun, pick another device, or use the CPU backend")]
    DeviceLost(String),
    #[error("the GPU did not finish {what} within {seconds} s; the device may be hung. Use smaller work or the CPU backend")]
    Timeout { what: String, seconds: u64 },
    #[error("Vulkan call failed while {what}: {result}")]
    Vk { what: String, result: vk::Result },
    #[error("{0}")]
    Limit(String),
    #[error("no SPIR-V kernel '{kernel}' for model '{model}' was built into this binary")]
    MissingKernel { kernel: String, model: String },
}

pub type Result<T> = std::result::Result<T, GpuError>;

/// Attaches to a Vulkan result what was being attempted.
pub trait Context<T> {
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
