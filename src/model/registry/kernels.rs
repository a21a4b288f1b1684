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
