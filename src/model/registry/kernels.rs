//! The built-in kernels' SPIR-V, compiled from `glsl/` by `build.rs`: one module per
//! (kernel, model).

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// The SPIR-V bytes of `kernel` specialised for `model`.
pub fn spirv(kernel: &str, model: &str) -> Option<&'static [u8]> {
    SHADERS
        .iter()
        .find(|(k, m, _)| *k == kernel && *m == model)
        .map(|(_, _, b)| *b)
}

/// Everything the Vulkan runner needs to build one kernel of one model, and all it learns about
/// the model: the runner knows no model by name.
#[derive(Clone, Debug)]
pub struct KernelSource {
    /// `model[components]`, for logs and errors.
    pub label: String,
    /// The model's name, for messages about its data table.
    pub model: &'static str,
    /// The SPIR-V module of the kernel with the model's GLSL linked in.
    pub spirv: &'static [u8],
    /// Specialization constants 3.. (the model's component choices).
    pub spec_constants: Vec<u32>,
    /// The read-only data table bound at the model-data binding, if the model has one.
    pub data: Option<&'static [u8]>,
    /// The model's own bound on each chunk's wait, if it sets one.
    pub timeout: Option<std::time::Duration>,
    /// Whether the kernel takes ωi + ωo from offsets to the mirror direction in its sums.
    pub mirror_offsets: bool,
}
