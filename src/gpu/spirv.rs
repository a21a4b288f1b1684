//! Just enough SPIR-V reading to check that a GLSL parameter struct has the byte layout of its
//! Rust twin: member names (OpName / OpMemberName), member offsets (OpMemberDecorate Offset) and
//! the stride of the runtime array that holds the struct (OpDecorate ArrayStride).

use std::collections::HashMap;

const OP_NAME: u32 = 5;
const OP_MEMBER_NAME: u32 = 6;
const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
const OP_DECORATE: u32 = 71;
const OP_MEMBER_DECORATE: u32 = 72;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_OFFSET: u32 = 35;

/// The layout of a struct as the shader compiler laid it out.
#[derive(Debug, PartialEq)]
pub struct StructLayout {
    /// (member name, byte offset), in declaration order.
    pub members: Vec<(String, u32)>,
    /// Stride of a runtime array of this struct, i.e. its std430 size.
    pub array_stride: Option<u32>,
}

fn string_at(words: &[u32]) -> String {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|b| *b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Reads the layout of the struct named `name` from SPIR-V bytes; None if it is absent.
pub fn struct_layout(spirv: &[u8], name: &str) -> Option<StructLayout> {
    let words: Vec<u32> = spirv
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if words.first() != Some(&0x0723_0203) {
        return None;
    }
    let mut struct_id = None;
    let mut member_names: HashMap<(u32, u32), String> = HashMap::new();
    let mut offsets: HashMap<(u32, u32), u32> = HashMap::new();
    let mut strides: HashMap<u32, u32> = HashMap::new();
    let mut runtime_arrays: Vec<(u32, u32)> = Vec::new(); // (array id, element type id)
    let mut i = 5;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        let op = words[i] & 0xffff;
        if count == 0 || i + count > words.len() {
            return None;
        }
        let ops = &words[i + 1..i + count];
        match op {
            OP_NAME if string_at(&ops[1..]) == name => struct_id = Some(ops[0]),
            OP_MEMBER_NAME => {
                member_names.insert((ops[0], ops[1]), string_at(&ops[2..]));
            }
            OP_MEMBER_DECORATE if ops[2] == DECORATION_OFFSET => {
                offsets.insert((ops[0], ops[1]), ops[3]);
            }
            OP_DECORATE if ops[1] == DECORATION_ARRAY_STRIDE => {
                strides.insert(ops[0], ops[2]);
            }
            OP_TYPE_RUNTIME_ARRAY => runtime_arrays.push((ops[0], ops[1])),
            _ => {}
        }
        i += count;
    }
    let id = struct_id?;
    let mut members: Vec<(u32, String, u32)> = member_names
        .iter()
        .filter(|((s, _), _)| *s == id)
        .map(|((_, m), n)| {
            (
                *m,
                n.clone(),
                offsets.get(&(id, *m)).copied().unwrap_or(u32::MAX),
            )
        })
        .collect();
    members.sort();
    let array_stride = runtime_arrays
        .iter()
        .find(|(_, elem)| *elem == id)
        .and_then(|(arr, _)| strides.get(arr).copied());
    Some(StructLayout {
        members: members.into_iter().map(|(_, n, o)| (n, o)).collect(),
        array_stride,
    })
}
