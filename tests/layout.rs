//! The std430 blocks the host writes must have the byte layout the GLSL kernels read. The truth
//! for GLSL is the compiled SPIR-V itself: member offsets (OpMemberDecorate Offset) and the
//! array stride of the block array, read from the modules embedded in the binary.

use lobe::gpu::spirv::struct_layout;
use lobe::model::kernels::spirv;
use lobe::model::Model;

#[test]
fn parameter_blocks_match_between_rust_and_glsl() {
    for model in Model::ALL {
        let (rust_fields, rust_size) = model.gpu_layout();
        for kernel in ["table", "pairs", "sample"] {
            let words = spirv(kernel, model.name())
                .unwrap_or_else(|| panic!("no {kernel} kernel for {}", model.name()));
            let glsl = struct_layout(words, model.gpu_struct_name()).unwrap_or_else(|| {
                panic!(
                    "{kernel}/{}: no struct {} in the SPIR-V",
                    model.name(),
                    model.gpu_struct_name()
                )
            });
            let glsl_fields: Vec<(String, usize)> = glsl
                .members
                .iter()
                .map(|(n, o)| (n.clone(), *o as usize))
                .collect();
            let rust: Vec<(String, usize)> = rust_fields
                .iter()
                .map(|(n, o)| (n.to_string(), *o))
                .collect();
            assert_eq!(
                glsl_fields,
                rust,
                "{kernel}/{}: field names and offsets differ (GLSL left, Rust right)",
                model.name()
            );
            assert_eq!(
                glsl.array_stride,
                Some(rust_size as u32),
                "{kernel}/{}: std430 size of {} (array stride) differs from the Rust struct's size",
                model.name(),
                model.gpu_struct_name()
            );
        }
    }
}

#[test]
fn pair_and_chunk_blocks_match() {
    use lobe::gpu::pipeline::ChunkPush;
    use lobe::gpu::GpuPair;
    use std::mem::{offset_of, size_of};
    let pairs = struct_layout(spirv("pairs", "lambert").unwrap(), "Pair").expect("struct Pair");
    let expected = vec![
        ("wi".to_string(), offset_of!(GpuPair, wi) as u32),
        (
            "param_index".to_string(),
            offset_of!(GpuPair, param_index) as u32,
        ),
        ("wo".to_string(), offset_of!(GpuPair, wo) as u32),
        ("pad".to_string(), offset_of!(GpuPair, pad) as u32),
    ];
    assert_eq!(pairs.members, expected);
    assert_eq!(pairs.array_stride, Some(size_of::<GpuPair>() as u32));
    let chunk = struct_layout(spirv("table", "lambert").unwrap(), "Chunk")
        .expect("push constant block Chunk");
    let expected = vec![
        ("first".to_string(), offset_of!(ChunkPush, first) as u32),
        ("count".to_string(), offset_of!(ChunkPush, count) as u32),
        ("n_wo".to_string(), offset_of!(ChunkPush, n_wo) as u32),
        ("n_wi".to_string(), offset_of!(ChunkPush, n_wi) as u32),
    ];
    assert_eq!(chunk.members, expected);
}

/// The draws kernel's request block (`DrawRequest` in glsl/kernels/sample.comp) and its host twin.
#[test]
fn draw_request_block_matches() {
    use lobe::gpu::GpuDrawRequest;
    use std::mem::{offset_of, size_of};
    let request = struct_layout(spirv("sample", "lambert").unwrap(), "DrawRequest")
        .expect("struct DrawRequest");
    let expected: Vec<(String, u32)> = [
        ("wo", offset_of!(GpuDrawRequest, wo)),
        ("seed", offset_of!(GpuDrawRequest, seed)),
        ("group", offset_of!(GpuDrawRequest, group)),
        ("first_lo", offset_of!(GpuDrawRequest, first_lo)),
        ("first_hi", offset_of!(GpuDrawRequest, first_hi)),
        ("pad", offset_of!(GpuDrawRequest, pad)),
    ]
    .into_iter()
    .map(|(n, o)| (n.to_string(), o as u32))
    .collect();
    assert_eq!(request.members, expected);
    let size = size_of::<GpuDrawRequest>() as u32;
    assert!(request.array_stride.is_none_or(|s| s == size));
}

/// Only the models and kernels that exist are embedded: one module per (kernel, model).
#[test]
fn one_module_per_kernel_and_model() {
    for model in Model::ALL {
        for kernel in ["table", "pairs"] {
            assert!(
                spirv(kernel, model.name()).is_some(),
                "{kernel}/{}",
                model.name()
            );
        }
    }
    assert!(spirv("table", "no_such_model").is_none());
}
