//! A `.brdf` shader is untrusted code compiled into lobe's kernels: what it may add to them is
//! checked in the compiled SPIR-V, where no macro or preprocessor trick can hide it.
//!
//! The file's shader may define functions, constants and (through lobe) its parameters, and
//! nothing else. Each kernel is compiled once with a stand-in shader (`BRDF` returning a
//! constant) to take an inventory of what lobe itself puts there: its descriptor bindings,
//! push constants, built-in inputs, `shared` memory, barriers, atomics, texel fetches,
//! capabilities and extensions. The same kernel compiled with the file's shader may hold
//! nothing more (`check`): no resource variable of any storage class beyond lobe's (a block
//! at one of lobe's own bindings counts as one more), no barrier, atomic, image, sampler or
//! subgroup instruction in a function where lobe's kernel has fewer, no pointer conversion, no
//! other capability or extension, and at most [`MAX_PRIVATE_BYTES`] of per-invocation memory
//! (global and local variables) beyond lobe's.

use super::rename::original_names;
use rspirv::dr::{Instruction, Module, Operand};
use rspirv::spirv::{Decoration, Op, StorageClass, Word};
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// Per-invocation memory (global and local variables: arrays, structs) a `.brdf` shader may add
/// to a kernel, bytes. A BRDF needs a few dozen floats; 64 KiB (16384 floats) is far beyond
/// any, while a driver that gives each invocation its own copy (lavapipe: SIMD lanes × threads,
/// a GPU: thousands of invocations in flight) stays within memory. Larger arrays made lavapipe
/// allocate gigabytes, or crash, before the first evaluation.
pub const MAX_PRIVATE_BYTES: u64 = 64 * 1024;

/// A global variable other than Private: a resource, an input or output, or `shared` memory.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Resource {
    class: String,
    set: Option<u32>,
    binding: Option<u32>,
    builtin: Option<String>,
    name: String,
}

/// What a compiled kernel holds that a shader could add to.
#[derive(Debug, Default)]
pub(super) struct Inventory {
    capabilities: BTreeSet<String>,
    extensions: BTreeSet<String>,
    resources: BTreeMap<Resource, usize>,
    /// Instructions of a refused kind, by (function, kind).
    ops: BTreeMap<(String, &'static str), usize>,
    /// Private and Function variables: (name, bytes).
    variables: Vec<(String, u64)>,
}

/// Why the shader was refused: what, and the name in the shader it comes from (to find its line).
#[derive(Debug)]
pub(super) struct Refusal {
    pub name: Option<String>,
    pub message: String,
}

/// The words of a compiled kernel, read.
pub(super) fn inventory(words: &[u32]) -> Result<Inventory, String> {
    let module = rspirv::dr::load_words(words).map_err(|e| format!("unreadable SPIR-V: {e}"))?;
    let names: HashMap<Word, String> = module
        .debug_names
        .iter()
        .filter(|i| i.class.opcode == Op::Name)
        .filter_map(|i| match (&i.operands[..], i.operands.get(1)) {
            ([Operand::IdRef(id), ..], Some(Operand::LiteralString(s))) => Some((*id, s.clone())),
            _ => None,
        })
        .collect();
    let name = |id: Word| names.get(&id).cloned().unwrap_or_default();
    let defs: HashMap<Word, &Instruction> = module
        .types_global_values
        .iter()
        .filter_map(|i| Some((i.result_id?, i)))
        .collect();
    let mut inv = Inventory::default();
    for i in &module.capabilities {
        if let Some(Operand::Capability(c)) = i.operands.first() {
            inv.capabilities.insert(format!("{c:?}"));
        }
    }
    for i in module.extensions.iter().chain(&module.ext_inst_imports) {
        if let Some(Operand::LiteralString(s)) = i.operands.first() {
            inv.extensions.insert(s.clone());
        }
    }
    for v in module
        .types_global_values
        .iter()
        .filter(|i| i.class.opcode == Op::Variable)
    {
        let (Some(id), Some(ty)) = (v.result_id, v.result_type) else {
            continue;
        };
        let pointee = pointee(&defs, ty);
        let var_name = match name(id) {
            n if n.is_empty() => pointee.map(&name).unwrap_or_default(),
            n => n,
        };
        match v.operands.first() {
            Some(Operand::StorageClass(StorageClass::Private)) => {
                let bytes = pointee.map_or(0, |t| size(&defs, t));
                inv.variables.push((var_name, bytes));
            }
            Some(Operand::StorageClass(class)) => {
                let resource = resource(&module, id, format!("{class:?}"), var_name);
                *inv.resources.entry(resource).or_default() += 1;
            }
            _ => {}
        }
    }
    for f in &module.functions {
        let fn_name = f
            .def
            .as_ref()
            .and_then(|d| d.result_id)
            .map(|id| name(id))
            .unwrap_or_default();
        let fn_name = fn_name.split('(').next().unwrap_or("").to_string();
        for i in f.blocks.iter().flat_map(|b| &b.instructions) {
            if i.class.opcode == Op::Variable {
                let bytes = i
                    .result_type
                    .and_then(|t| pointee(&defs, t))
                    .map_or(0, |t| size(&defs, t));
                let n = i.result_id.map(&name).unwrap_or_default();
                inv.variables.push((n, bytes));
            } else if let Some(kind) = refused_kind(i.class.opcode) {
                *inv.ops.entry((fn_name.clone(), kind)).or_default() += 1;
            }
        }
    }
    Ok(inv)
}

/// The kind of a refused instruction, as messages say it; None for one a shader may use.
fn refused_kind(op: Op) -> Option<&'static str> {
    let name = format!("{op:?}");
    if matches!(op, Op::ControlBarrier | Op::MemoryBarrier) {
        Some("a barrier")
    } else if name.starts_with("Atomic") {
        Some("an atomic operation")
    } else if name.starts_with("Image") || name.starts_with("SampledImage") {
        Some("an image or sampler operation")
    } else if name.starts_with("Group") || name.starts_with("Subgroup") {
        Some("a subgroup operation")
    } else if matches!(op, Op::ConvertUToPtr | Op::ConvertPtrToU) {
        Some("a pointer made from an integer")
    } else {
        None
    }
}

fn pointee(defs: &HashMap<Word, &Instruction>, pointer: Word) -> Option<Word> {
    match defs.get(&pointer)?.operands.get(1) {
        Some(Operand::IdRef(t)) => Some(*t),
        _ => None,
    }
}

/// The bytes a variable of type `ty` takes (an upper bound's worth: bools as 4 bytes).
fn size(defs: &HashMap<Word, &Instruction>, ty: Word) -> u64 {
    let Some(def) = defs.get(&ty) else { return 0 };
    let id = |k: usize| match def.operands.get(k) {
        Some(Operand::IdRef(t)) => Some(*t),
        _ => None,
    };
    let literal = |k: usize| match def.operands.get(k) {
        Some(Operand::LiteralBit32(n)) => u64::from(*n),
        _ => 0,
    };
    match def.class.opcode {
        Op::TypeBool => 4,
        Op::TypeInt | Op::TypeFloat => literal(0) / 8,
        Op::TypeVector | Op::TypeMatrix => {
            literal(1).saturating_mul(id(0).map_or(0, |t| size(defs, t)))
        }
        Op::TypeArray => {
            let len = id(1)
                .and_then(|c| defs.get(&c))
                .and_then(|c| match c.operands.first() {
                    Some(Operand::LiteralBit32(n)) => Some(u64::from(*n)),
                    Some(Operand::LiteralBit64(n)) => Some(*n),
                    _ => None,
                })
                .unwrap_or(0);
            len.saturating_mul(id(0).map_or(0, |t| size(defs, t)))
        }
        Op::TypeStruct => def
            .operands
            .iter()
            .filter_map(|o| match o {
                Operand::IdRef(t) => Some(size(defs, *t)),
                _ => None,
            })
            .fold(0u64, u64::saturating_add),
        Op::TypePointer => 8,
        _ => 0,
    }
}

fn resource(module: &Module, id: Word, class: String, name: String) -> Resource {
    let mut r = Resource {
        class,
        set: None,
        binding: None,
        builtin: None,
        name,
    };
    for a in module
        .annotations
        .iter()
        .filter(|a| a.class.opcode == Op::Decorate)
    {
        match &a.operands[..] {
            [Operand::IdRef(t), Operand::Decoration(d), rest @ ..] if *t == id => {
                match (d, rest.first()) {
                    (Decoration::DescriptorSet, Some(Operand::LiteralBit32(n))) => r.set = Some(*n),
                    (Decoration::Binding, Some(Operand::LiteralBit32(n))) => r.binding = Some(*n),
                    (Decoration::BuiltIn, Some(Operand::BuiltIn(b))) => {
                        r.builtin = Some(format!("{b:?}"))
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }
    r
}

/// What a storage class holds, as messages say it.
fn what(r: &Resource) -> String {
    let kind = match r.class.as_str() {
        "Uniform" | "StorageBuffer" => "a buffer block (uniform or storage buffer)",
        "UniformConstant" => "an image, sampler or texture",
        "PushConstant" => "a push-constant block",
        "Workgroup" => "'shared' memory",
        "Input" => "a shader input",
        "Output" => "a shader output",
        other => return format!("a variable in {other} storage"),
    };
    let mut s = kind.to_string();
    if let (Some(set), Some(binding)) = (r.set, r.binding) {
        s += &format!(" at set {set}, binding {binding}");
    }
    if let Some(b) = &r.builtin {
        s += &format!(" (built-in {b})");
    }
    s
}

const ONLY: &str =
    "a .brdf shader may define functions and constants and read its parameters, nothing else";

/// Whether `user` (a kernel compiled with the file's shader) holds nothing beyond `lobe` (the
/// same kernel with the stand-in shader): every refusal. A capability or extension of its own
/// changes how the whole kernel compiles (lobe's blocks too), so then only those are named.
pub(super) fn check(user: &Inventory, lobe: &Inventory) -> Vec<Refusal> {
    let mut out = Vec::new();
    for c in user.capabilities.difference(&lobe.capabilities) {
        out.push(Refusal {
            name: None,
            message: format!("the shader needs the SPIR-V capability {c}, which lobe's kernels do not use (an extension or a type such as double or int64 lobe does not allow); {ONLY}"),
        });
    }
    for e in user.extensions.difference(&lobe.extensions) {
        out.push(Refusal {
            name: None,
            message: format!("the shader needs the SPIR-V extension {e}; {ONLY}"),
        });
    }
    if !out.is_empty() {
        return out;
    }
    for (r, n) in &user.resources {
        if *n > lobe.resources.get(r).copied().unwrap_or(0) {
            let name = original_names(&r.name);
            out.push(Refusal {
                message: format!("'{name}' declares {}; {ONLY}", what(r)),
                name: Some(name),
            });
        }
    }
    for ((function, kind), n) in &user.ops {
        let key = (function.clone(), *kind);
        if *n > lobe.ops.get(&key).copied().unwrap_or(0) {
            let function = original_names(function);
            out.push(Refusal {
                message: format!("the function '{function}' uses {kind}; {ONLY}"),
                name: Some(function),
            });
        }
    }
    // Lobe's own variables, taken out one by one; what remains is the shader's.
    let mut own = lobe.variables.clone();
    let mut added: Vec<&(String, u64)> = Vec::new();
    for v in &user.variables {
        match own.iter().position(|o| o == v) {
            Some(k) => {
                own.swap_remove(k);
            }
            None => added.push(v),
        }
    }
    let total = added.iter().map(|v| v.1).fold(0u64, u64::saturating_add);
    if total > MAX_PRIVATE_BYTES {
        let largest = added.iter().max_by_key(|v| v.1).map(|&v| v.clone());
        let (name, bytes) = largest.unwrap_or_default();
        let name = original_names(&name);
        out.push(Refusal {
            message: format!(
                "the shader's variables take {total} bytes per invocation ('{name}' alone {bytes}); at most {MAX_PRIVATE_BYTES} (64 KiB) are allowed"
            ),
            name: Some(name),
        });
    }
    out
}
