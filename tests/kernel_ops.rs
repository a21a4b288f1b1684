//! How much arithmetic one evaluation of each built-in model costs in its compiled table kernel,
//! counted from the embedded SPIR-V: divisions, square roots, inverse square roots,
//! transcendentals (exp, log, pow) and all arithmetic, one per scalar lane.
//!
//! The count starts at the model's GLSL function (`microfacet(…)`), follows every call (each
//! call counts its callee again, as inlining would) and every block reachable under the
//! pipeline's specialization constants: a branch on a specialization constant follows its taken
//! side only, a branch on data follows both, and a loop body counts once. It is a static count
//! of the code a driver receives, deterministic and independent of the machine.
//!
//! `cargo test --release --test kernel_ops -- --nocapture` prints the table.

use lobe::model::components::{
    BeckmannG1, Distribution, Fresnel, Masking, MicrofacetConfig, Multiscatter,
};
use lobe::model::eon::EonConfig;
use lobe::model::Model;
use rspirv::dr::{Function, Instruction, Module, Operand};
use rspirv::spirv::{Decoration, Op, Word};
use std::collections::{HashMap, HashSet};

#[path = "kernel_ops/dependence.rs"]
mod dependence;
use dependence::Dep;

/// Operation counts of one evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Ops {
    div: u32,
    sqrt: u32,
    rsqrt: u32,
    transcendental: u32,
    total: u32,
}

/// GLSL.std.450 instruction numbers (the extended instruction set's specification).
mod glsl450 {
    pub const POW: u32 = 26;
    pub const EXP: u32 = 27;
    pub const LOG: u32 = 28;
    pub const EXP2: u32 = 29;
    pub const LOG2: u32 = 30;
    pub const SQRT: u32 = 31;
    pub const INVERSE_SQRT: u32 = 32;
    pub const LENGTH: u32 = 66;
    pub const NORMALIZE: u32 = 69;
}

struct Counter<'m> {
    module: &'m Module,
    functions: HashMap<Word, &'m Function>,
    /// Values of the constants and specialization constants this pipeline fixes.
    constants: HashMap<Word, u64>,
    /// Scalar lanes of each type id (1 for scalars).
    lanes: HashMap<Word, u32>,
    /// Result type of each id defined anywhere.
    result_types: HashMap<Word, Word>,
    /// Float scalar and vector types.
    float_types: HashSet<Word>,
}

fn id(op: &Operand) -> Word {
    match op {
        Operand::IdRef(w) => *w,
        other => panic!("expected an id, got {other:?}"),
    }
}

impl<'m> Counter<'m> {
    fn new(module: &'m Module, spec: &HashMap<u32, u32>) -> Self {
        let mut spec_ids = HashMap::new();
        for a in &module.annotations {
            if let [Operand::IdRef(t), Operand::Decoration(Decoration::SpecId), Operand::LiteralBit32(n)] =
                a.operands.as_slice()
            {
                spec_ids.insert(*t, *n);
            }
        }
        let mut c = Counter {
            module,
            functions: HashMap::new(),
            constants: HashMap::new(),
            lanes: HashMap::new(),
            result_types: HashMap::new(),
            float_types: HashSet::new(),
        };
        for f in &module.functions {
            let def = f.def.as_ref().expect("function definition");
            c.functions.insert(def.result_id.expect("function id"), f);
            for i in f
                .parameters
                .iter()
                .chain(f.blocks.iter().flat_map(|b| &b.instructions))
            {
                if let (Some(r), Some(t)) = (i.result_id, i.result_type) {
                    c.result_types.insert(r, t);
                }
            }
        }
        for i in &module.types_global_values {
            let r = match i.result_id {
                Some(r) => r,
                None => continue,
            };
            if let Some(t) = i.result_type {
                c.result_types.insert(r, t);
            }
            let fixed = |default: u64| {
                spec_ids
                    .get(&r)
                    .and_then(|n| spec.get(n))
                    .map_or(default, |v| u64::from(*v))
            };
            match i.class.opcode {
                Op::TypeFloat => drop(c.float_types.insert(r)),
                Op::TypeVector => {
                    if let Some(Operand::LiteralBit32(n)) = i.operands.get(1) {
                        c.lanes.insert(r, *n);
                    }
                    if c.float_types.contains(&id(&i.operands[0])) {
                        c.float_types.insert(r);
                    }
                }
                Op::Constant => {
                    if let Some(Operand::LiteralBit32(v)) = i.operands.first() {
                        c.constants.insert(r, u64::from(*v));
                    }
                }
                Op::ConstantTrue => drop(c.constants.insert(r, 1)),
                Op::ConstantFalse => drop(c.constants.insert(r, 0)),
                Op::SpecConstantTrue => drop(c.constants.insert(r, fixed(1))),
                Op::SpecConstantFalse => drop(c.constants.insert(r, fixed(0))),
                Op::SpecConstant => {
                    if let Some(Operand::LiteralBit32(v)) = i.operands.first() {
                        c.constants.insert(r, fixed(u64::from(*v)));
                    }
                }
                Op::SpecConstantOp => {
                    if let Some(v) = c.fold(i) {
                        c.constants.insert(r, v);
                    }
                }
                _ => {}
            }
        }
        c
    }

    /// The value of a specialization-constant operation over integers and booleans, where every
    /// operand is known.
    fn fold(&self, i: &Instruction) -> Option<u64> {
        let op = match i.operands.first() {
            Some(Operand::LiteralSpecConstantOpInteger(op)) => *op,
            _ => return None,
        };
        let args: Option<Vec<u64>> = i.operands[1..]
            .iter()
            .map(|o| self.constants.get(&id(o)).copied())
            .collect();
        let a = args?;
        let b = |x: bool| u64::from(x);
        Some(match (op, a.as_slice()) {
            (Op::IEqual | Op::LogicalEqual, [x, y]) => b(x == y),
            (Op::INotEqual | Op::LogicalNotEqual, [x, y]) => b(x != y),
            (Op::LogicalAnd, [x, y]) => b(*x != 0 && *y != 0),
            (Op::LogicalOr, [x, y]) => b(*x != 0 || *y != 0),
            (Op::LogicalNot, [x]) => b(*x == 0),
            (Op::ULessThan, [x, y]) => b(x < y),
            (Op::UGreaterThan, [x, y]) => b(x > y),
            (Op::Select, [c, x, y]) => {
                if *c != 0 {
                    *x
                } else {
                    *y
                }
            }
            _ => return None,
        })
    }

    fn lanes_of(&self, value: Word) -> u32 {
        self.result_types
            .get(&value)
            .and_then(|t| self.lanes.get(t))
            .copied()
            .unwrap_or(1)
    }

    /// Counts one instruction (not following calls).
    fn count(&self, i: &Instruction, ops: &mut Ops) {
        let lanes = i.result_id.map_or(1, |r| self.lanes_of(r));
        match i.class.opcode {
            Op::FDiv
            | Op::UDiv
            | Op::SDiv
            | Op::FMod
            | Op::FRem
            | Op::UMod
            | Op::SMod
            | Op::SRem => {
                ops.div += lanes;
                ops.total += lanes;
            }
            Op::Dot => ops.total += 2 * self.lanes_of(id(&i.operands[0])) - 1,
            Op::ExtInst => {
                let number = match i.operands.get(1) {
                    Some(Operand::LiteralExtInstInteger(n)) => *n,
                    _ => return,
                };
                let width = i.operands.get(2).map_or(1, |o| self.lanes_of(id(o)));
                match number {
                    glsl450::SQRT => ops.sqrt += lanes,
                    glsl450::INVERSE_SQRT => ops.rsqrt += lanes,
                    glsl450::POW | glsl450::EXP | glsl450::LOG | glsl450::EXP2 | glsl450::LOG2 => {
                        ops.transcendental += lanes
                    }
                    _ => {}
                }
                // length = sqrt(dot(x, x)); normalize = x * inversesqrt(dot(x, x)).
                ops.total += match number {
                    glsl450::LENGTH => {
                        ops.sqrt += 1;
                        2 * width
                    }
                    glsl450::NORMALIZE => {
                        ops.rsqrt += 1;
                        3 * width
                    }
                    _ => lanes,
                };
            }
            Op::FAdd
            | Op::FSub
            | Op::FMul
            | Op::FNegate
            | Op::IAdd
            | Op::ISub
            | Op::IMul
            | Op::SNegate
            | Op::VectorTimesScalar
            | Op::Select
            | Op::ConvertFToU
            | Op::ConvertFToS
            | Op::ConvertSToF
            | Op::ConvertUToF
            | Op::FOrdEqual
            | Op::FOrdNotEqual
            | Op::FOrdLessThan
            | Op::FOrdGreaterThan
            | Op::FOrdLessThanEqual
            | Op::FOrdGreaterThanEqual
            | Op::FUnordNotEqual
            | Op::IEqual
            | Op::INotEqual
            | Op::ULessThan
            | Op::UGreaterThan
            | Op::SLessThan
            | Op::SGreaterThan
            | Op::SLessThanEqual
            | Op::SGreaterThanEqual
            | Op::LogicalAnd
            | Op::LogicalOr
            | Op::LogicalNot
            | Op::BitwiseAnd
            | Op::ShiftRightLogical
            | Op::ShiftRightArithmetic => ops.total += lanes,
            _ => {}
        }
    }

    /// The blocks of `f` reachable from its entry under the fixed constants.
    fn reachable(&self, f: &Function) -> Vec<usize> {
        let blocks: HashMap<Word, usize> = f
            .blocks
            .iter()
            .enumerate()
            .map(|(k, b)| {
                (
                    b.label.as_ref().and_then(|l| l.result_id).expect("label"),
                    k,
                )
            })
            .collect();
        let mut seen = HashSet::new();
        let mut order = Vec::new();
        let mut todo = vec![0usize];
        while let Some(k) = todo.pop() {
            if !seen.insert(k) {
                continue;
            }
            order.push(k);
            let last = f.blocks[k].instructions.last().expect("terminator");
            let mut go = |w: &Operand| todo.push(blocks[&id(w)]);
            match last.class.opcode {
                Op::Branch => go(&last.operands[0]),
                Op::BranchConditional => match self.constants.get(&id(&last.operands[0])) {
                    Some(&v) => go(&last.operands[if v != 0 { 1 } else { 2 }]),
                    None => {
                        go(&last.operands[1]);
                        go(&last.operands[2]);
                    }
                },
                Op::Switch => {
                    for o in last.operands[1..]
                        .iter()
                        .filter(|o| matches!(o, Operand::IdRef(_)))
                    {
                        go(o);
                    }
                }
                _ => {}
            }
        }
        order.sort_unstable();
        order
    }

    /// Counts one call of `function`, following its calls and the blocks reachable under the
    /// fixed constants.
    fn function(&self, function: Word, ops: &mut Ops) {
        let f = self.functions[&function];
        for k in self.reachable(f) {
            for i in &f.blocks[k].instructions {
                self.count(i, ops);
                if i.class.opcode == Op::FunctionCall {
                    self.function(id(&i.operands[0]), ops);
                }
            }
        }
    }

    /// The id of the function whose name is `name(…)`.
    fn named(&self, name: &str) -> Word {
        let prefix = format!("{name}(");
        self.module
            .debug_names
            .iter()
            .find_map(|n| match n.operands.as_slice() {
                [Operand::IdRef(t), Operand::LiteralString(s)]
                    if s.starts_with(&prefix) && self.functions.contains_key(t) =>
                {
                    Some(*t)
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("no function {name}(…) in the SPIR-V"))
    }
}

/// The operations of one evaluation of `model` in its table kernel, with its pipeline's
/// specialization constants (the defaults of constants 0 to 2 and 10: no white furnace, the
/// careful pow).
fn ops_per_evaluation(model: Model) -> Ops {
    let module = table_kernel(model);
    let spec = spec_constants(model);
    let counter = Counter::new(&module, &spec);
    let mut ops = Ops::default();
    counter.function(counter.named(model.name()), &mut ops);
    ops
}

fn table_kernel(model: Model) -> Module {
    let bytes = model.spirv("table").expect("table kernel");
    let words: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    rspirv::dr::load_words(words).expect("readable SPIR-V")
}

/// Specialization constants 3.. of the model's pipeline (its component choices).
fn spec_constants(model: Model) -> HashMap<u32, u32> {
    model
        .spec_constants()
        .into_iter()
        .enumerate()
        .map(|(k, v)| (3 + k as u32, v))
        .collect()
}

/// The table job measured against the peer (docs/design.md §11): Beckmann, separable Smith with
/// Walter's rational G1, the exact conductor Fresnel.
const TABLE_JOB: MicrofacetConfig = MicrofacetConfig {
    distribution: Distribution::Beckmann,
    masking: Masking::SmithSeparable,
    beckmann_g1: BeckmannG1::Rational,
    fresnel: Fresnel::Conductor,
    multiscatter: Multiscatter::None,
};

fn models() -> Vec<(String, Model)> {
    let mut out = vec![(
        "microfacet (beckmann, smith_separable, rational, conductor)".to_string(),
        Model::Microfacet(TABLE_JOB),
    )];
    for m in Model::ALL {
        let label = match m {
            Model::Microfacet(c) => format!("microfacet ({})", c.label()),
            m => m.name().to_string(),
        };
        out.push((label, m));
    }
    out
}

#[test]
fn operations_per_evaluation() {
    println!(
        "{:<62} {:>4} {:>4} {:>5} {:>5} {:>5}",
        "model", "div", "sqrt", "rsqrt", "exp..", "total"
    );
    for (label, model) in models() {
        let o = ops_per_evaluation(model);
        println!(
            "{label:<62} {:>4} {:>4} {:>5} {:>5} {:>5}",
            o.div, o.sqrt, o.rsqrt, o.transcendental, o.total
        );
    }
}

/// Every configuration of every built-in model: the microfacet model with each combination of
/// components, EON with each multiple-scattering choice.
fn every_configuration() -> Vec<Model> {
    let mut out: Vec<Model> = Model::ALL
        .into_iter()
        .filter(|m| !matches!(m, Model::Microfacet(_) | Model::Eon(_)))
        .collect();
    out.extend(MicrofacetConfig::all().into_iter().map(Model::Microfacet));
    out.extend(EonConfig::all().into_iter().map(Model::Eon));
    out
}

/// docs/design.md §6.2: what depends on the parameters alone (reciprocals, squares, Fresnel's
/// η/κ terms, normalisations) is computed once per parameter set on the host into the block; a
/// kernel spends no float arithmetic on the block's values and constants alone, in any pipeline.
#[test]
fn no_arithmetic_on_the_parameters_alone() {
    let mut failures = Vec::new();
    for model in every_configuration() {
        let module = table_kernel(model);
        let counter = Counter::new(&module, &spec_constants(model));
        let mut found = Vec::new();
        // The model's function takes (p, wi, wo): the block, then the cell's two directions.
        counter.parameter_only_ops(
            counter.named(model.name()),
            &[Dep::Param, Dep::Cell, Dep::Cell],
            &mut found,
        );
        if !found.is_empty() {
            failures.push(format!("{model:?}: {}", found.join(", ")));
        }
    }
    assert!(
        failures.is_empty(),
        "float arithmetic on the parameters alone, per cell:\n{}",
        failures.join("\n")
    );
}

/// The analysis sees such arithmetic where there is some: with the directions taken as
/// parameters too, every model that computes anything is flagged.
#[test]
fn the_analysis_finds_arithmetic_on_the_parameters() {
    for model in every_configuration() {
        let module = table_kernel(model);
        let counter = Counter::new(&module, &spec_constants(model));
        let mut found = Vec::new();
        counter.parameter_only_ops(
            counter.named(model.name()),
            &[Dep::Param, Dep::Param, Dep::Param],
            &mut found,
        );
        let computes = ops_per_evaluation(model).total > 0;
        assert_eq!(!found.is_empty(), computes, "{model:?}: {found:?}");
    }
}
