//! Which values of a kernel depend on the parameter block alone: a flow-insensitive dependence
//! analysis of the SPIR-V from the model's function through every call, under the pipeline's
//! specialization constants (the blocks [`Counter::reachable`] finds).

use super::{id, Counter};
use rspirv::dr::{Function, Operand};
use rspirv::spirv::{Op, Word};
use std::collections::{HashMap, HashSet};

/// What a value depends on: constants alone, the parameter block (and constants), or the cell
/// (its directions, or data the kernel reads).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Dep {
    Const,
    Param,
    Cell,
}

/// Floating-point arithmetic: what a kernel should not spend on the parameters alone.
fn is_float_arithmetic(op: Op) -> bool {
    matches!(
        op,
        Op::FAdd
            | Op::FSub
            | Op::FMul
            | Op::FDiv
            | Op::FNegate
            | Op::FMod
            | Op::FRem
            | Op::VectorTimesScalar
            | Op::Dot
            | Op::ExtInst
    )
}

/// The dependences in one function: each pointer's root (a parameter or a local variable, which
/// access chains alias), what each root's memory holds, and each value.
#[derive(Clone, PartialEq)]
struct Flow {
    root: HashMap<Word, Word>,
    memory: HashMap<Word, Dep>,
    values: HashMap<Word, Dep>,
    /// The parameters: their dependence is given by the caller.
    fixed: HashSet<Word>,
}

impl Flow {
    fn value(&self, w: Word) -> Dep {
        self.values.get(&w).copied().unwrap_or(Dep::Const)
    }

    /// What a pointer points at; memory outside the function (a buffer) holds data.
    fn pointee(&self, ptr: Word) -> Dep {
        self.root
            .get(&ptr)
            .and_then(|b| self.memory.get(b))
            .copied()
            .unwrap_or(Dep::Cell)
    }

    /// A store raises what the pointer's root holds (parameters keep the caller's dependence).
    fn store(&mut self, ptr: Word, d: Dep) {
        if let Some(b) = self.root.get(&ptr).copied() {
            if !self.fixed.contains(&b) {
                let m = self.memory.entry(b).or_insert(Dep::Const);
                *m = (*m).max(d);
            }
        }
    }
}

impl Counter<'_> {
    /// The name glslang gave an id, up to its parameter list.
    fn name_of(&self, target: Word) -> String {
        self.module
            .debug_names
            .iter()
            .find_map(|n| match n.operands.as_slice() {
                [Operand::IdRef(t), Operand::LiteralString(s)] if *t == target => {
                    Some(s.split('(').next().unwrap_or(s).to_string())
                }
                _ => None,
            })
            .unwrap_or_else(|| format!("%{target}"))
    }

    /// The indices of `f`'s parameters that it stores into (its `out` and `inout` parameters).
    fn written_parameters(&self, f: &Function) -> HashSet<usize> {
        let params: Vec<Word> = f.parameters.iter().filter_map(|p| p.result_id).collect();
        let mut root: HashMap<Word, Word> = params.iter().map(|&p| (p, p)).collect();
        let mut out = HashSet::new();
        for i in f.blocks.iter().flat_map(|b| &b.instructions) {
            match i.class.opcode {
                Op::AccessChain | Op::InBoundsAccessChain => {
                    if let (Some(r), Some(&base)) = (i.result_id, root.get(&id(&i.operands[0]))) {
                        root.insert(r, base);
                    }
                }
                Op::Store => {
                    if let Some(base) = root.get(&id(&i.operands[0])) {
                        out.insert(params.iter().position(|p| p == base).expect("a parameter"));
                    }
                }
                _ => {}
            }
        }
        out
    }

    /// One pass over the reachable instructions of `f`, raising the dependences it finds.
    fn step(&self, f: &Function, blocks: &[usize], flow: &mut Flow) {
        for i in blocks.iter().flat_map(|&k| &f.blocks[k].instructions) {
            match i.class.opcode {
                Op::Variable => {
                    let r = i.result_id.expect("variable id");
                    flow.root.insert(r, r);
                    flow.memory.entry(r).or_insert(Dep::Const);
                }
                Op::AccessChain | Op::InBoundsAccessChain => {
                    let base = id(&i.operands[0]);
                    let b = flow.root.get(&base).copied().unwrap_or(base);
                    flow.root.insert(i.result_id.expect("access chain id"), b);
                    flow.memory.entry(b).or_insert(Dep::Cell);
                }
                Op::Load => {
                    let d = flow.pointee(id(&i.operands[0]));
                    flow.values.insert(i.result_id.expect("load id"), d);
                }
                Op::Store => {
                    let d = flow.value(id(&i.operands[1]));
                    flow.store(id(&i.operands[0]), d);
                }
                Op::FunctionCall => {
                    // The result, and what the callee writes through its out parameters, depend
                    // on all of the arguments.
                    let args: Vec<Word> = i.operands[1..].iter().map(id).collect();
                    let all = args
                        .iter()
                        .map(|&a| flow.pointee(a))
                        .max()
                        .unwrap_or(Dep::Const);
                    for k in self.written_parameters(self.functions[&id(&i.operands[0])]) {
                        flow.store(args[k], all);
                    }
                    if let Some(r) = i.result_id {
                        flow.values.insert(r, all);
                    }
                }
                _ => {
                    if let Some(r) = i.result_id {
                        let d = i
                            .operands
                            .iter()
                            .filter_map(|o| match o {
                                Operand::IdRef(w) => Some(flow.value(*w)),
                                _ => None,
                            })
                            .max()
                            .unwrap_or(Dep::Const);
                        flow.values.insert(r, d);
                    }
                }
            }
        }
    }

    /// Float arithmetic in `function` (and the functions it calls) whose operands depend on the
    /// parameter block and constants alone, given what each of its pointer parameters points at;
    /// each as "function: opcode".
    pub fn parameter_only_ops(&self, function: Word, params: &[Dep], out: &mut Vec<String>) {
        let f = self.functions[&function];
        let blocks = self.reachable(f);
        let mut flow = Flow {
            root: HashMap::new(),
            memory: HashMap::new(),
            values: HashMap::new(),
            fixed: HashSet::new(),
        };
        for (k, p) in f.parameters.iter().enumerate() {
            let r = p.result_id.expect("parameter id");
            flow.root.insert(r, r);
            flow.memory.insert(r, params[k]);
            flow.fixed.insert(r);
        }
        // Every step only raises a dependence in a finite lattice, so this ends.
        loop {
            let before = flow.clone();
            self.step(f, &blocks, &mut flow);
            if flow == before {
                break;
            }
        }
        let name = self.name_of(function);
        for i in blocks.iter().flat_map(|&k| &f.blocks[k].instructions) {
            if i.class.opcode == Op::FunctionCall {
                let deps: Vec<Dep> = i.operands[1..]
                    .iter()
                    .map(|a| flow.pointee(id(a)))
                    .collect();
                self.parameter_only_ops(id(&i.operands[0]), &deps, out);
                continue;
            }
            let float = i.result_type.is_some_and(|t| self.float_types.contains(&t));
            let param = i.result_id.is_some_and(|r| flow.value(r) == Dep::Param);
            if float && param && is_float_arithmetic(i.class.opcode) {
                out.push(format!("{name}: {:?}", i.class.opcode));
            }
        }
    }
}
