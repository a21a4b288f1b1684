//! Running a fixed rule on a backend: f64 sums on the CPU, the reduction kernel on the GPU, and
//! the error estimate (three levels of the rule, or the replicates' spread) on top.

use super::estimate::three_level_error;
use super::gauss::Estimate;
use super::importance::{REPLICATES, REPLICATE_T};
use super::rules::Rule;
use super::Node;
use crate::eval::{Backend, Evaluator};
use crate::finite;
use crate::model::{Brdf, ParamSet, Reference};
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;

/// E (delta excluded) of a fixed rule at each ωo on `backend`, with the rule's error estimate.
pub fn rule_albedo(
    backend: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Estimate>> {
    let mut rows = rule_albedo_rows(
        backend,
        std::slice::from_ref(params),
        white_furnace,
        rule,
        wo,
    )?;
    Ok(rows.pop().unwrap_or_default())
}

/// Integrand evaluations [`rule_albedo`] spends on `rule` at the view directions `wo`: the nodes
/// of the rule and of its two coarser levels (for the replicated importance rule, its replicates' nodes).
pub fn rule_evaluations(rule: Rule, wo: &[DVec3]) -> u64 {
    let count = |r: Rule| -> u64 {
        if r.depends_on_wo() {
            wo.par_iter().map(|&o| r.node_count(o) as u64).sum()
        } else {
            r.node_count(DVec3::Z) as u64 * wo.len() as u64
        }
    };
    match rule {
        Rule::Importance {
            replicate: None, ..
        } => count(rule),
        _ => count(rule) + count(rule.coarse()) + count(rule.coarse().coarse()),
    }
}

/// The factor K of the f32 rounding bound K ε Σ|w f| / μo that a GPU estimate of a fixed rule
/// carries where the kernel sums ωi + ωo itself (every sum but those of
/// [`GPU_MIRROR_ROUNDING_FACTOR`]).
///
/// The GPU evaluates f in f32 from nodes and a view direction rounded to f32, and sums in f32
/// (16 terms per running sum, then a 64-wide tree on a GPU or four sums added pairwise on a CPU
/// driver, before the host's f64 sum: at most 22 roundings, 22 ε relative, in the worst case,
/// ~√22 ε typically; tests/engine_luts.rs checks the bound on both layouts). The coarse rule
/// shares those roundings, so |fine − coarse| misses them: at E(1) of GGX α = 0.3 under the
/// white furnace the GPU (workgroup tree) is 6.5e-8 from the f64 sum of the same rule while
/// |fine − coarse| is 1.7e-8. The rounding of f grows at grazing view: h = ωi + ωo cancels to
/// length 2μo about the mirror direction, so an absolute rounding of ε in its components is
/// ε/(2μo) in its direction. Over the built-in presets and GGX and Beckmann with
/// α ∈ [0.001, 1], μo ∈ [0.02, 1], the largest |GPU − f64| / (ε Σ|w f|) seen was 0.8 at μo = 1,
/// 53 at μo = 0.1 (GGX α = 0.001: 5.3/μo) and, over the default DFG table, 457 at μo = 1/64
/// (GGX α = 0.0022: 7.1/μo): K = 16 covers it with a margin of 2.2 (tests/engine_luts.rs
/// `gpu_error_estimates_bound_the_f32_rounding` and tests/estimates.rs check it).
pub const GPU_ROUNDING_FACTOR: f64 = 16.0;

/// The factor K′ of the f32 rounding bound K′ ε Σ|w f| of a GPU sum whose nodes are offsets from
/// the mirror direction ([`Model::sums_from_mirror_offsets`](crate::model::Model) and a rule
/// made per ωo): the kernel forms ωi + ωo without the cancellation that costs the other sums
/// their 1/μo, so what is left is the rounding of f's other terms and of the sum. Over GGX and
/// Beckmann with α ∈ [0.001, 1] and μo ∈ [1/64, 1] (65536 nodes, white furnace) and over the
/// default DFG table, the largest |GPU − f64| / (ε Σ|w f|) seen was 1.6, on both reduction
/// layouts (it was 457 before the offsets); K′ = 4 covers it with a margin of 2.5
/// (tests/engine_luts.rs `gpu_error_estimates_bound_the_f32_rounding` checks it).
pub const GPU_MIRROR_ROUNDING_FACTOR: f64 = 4.0;

/// The f32 rounding term of an estimate of `rule` for `model` on `backend` (0 on the CPU, whose
/// sums are f64): for a GPU sum of value v at view ωo, K ε |v| / μo with ε = 2^-23 and
/// K = [`GPU_ROUNDING_FACTOR`], or K′ ε |v| ([`GPU_MIRROR_ROUNDING_FACTOR`]) where the kernel
/// forms ωi + ωo from mirror offsets. |v| = Σ|w f| because every rule's weights are positive and
/// a BRDF is nonnegative.
fn f32_rounding(
    backend: &Evaluator,
    model: crate::model::Model,
    rule: Rule,
) -> impl Fn(DVec3, DVec3) -> DVec3 {
    let on_gpu = matches!(backend.backend(), Backend::Gpu(_));
    let mirror = model.sums_from_mirror_offsets() && rule.depends_on_wo();
    move |v: DVec3, wo: DVec3| {
        if !on_gpu {
            DVec3::ZERO
        } else if mirror {
            v.abs() * (GPU_MIRROR_ROUNDING_FACTOR * f32::EPSILON as f64)
        } else {
            v.abs() * (GPU_ROUNDING_FACTOR * f32::EPSILON as f64 / wo.z.max(f64::MIN_POSITIVE))
        }
    }
}

/// One rule's sums for several parameter sets: `[row][ωo]` of (Σ w f, the number of nodes).
pub type RowSums = Vec<Vec<(DVec3, u64)>>;

/// Σ w f(ωi, ωo) for each ωo: f64 sums on the CPU, the reduction kernel on the GPU.
pub fn sum_rule(
    backend: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<(DVec3, u64)>> {
    let mut sums = sum_rules_rows(
        backend,
        std::slice::from_ref(params),
        white_furnace,
        &[rule],
        wo,
    )?;
    Ok(sums.pop().and_then(|mut r| r.pop()).unwrap_or_default())
}

/// Nodes of ωo-dependent rules in one batch on the GPU: 1M nodes, a node buffer of 16 MiB as
/// f32x4. Small enough that first touching its pages stays a small part of a directional
/// albedo's time (each page of a fresh mapping faults once), large enough for dispatches of
/// ~1000 workgroups.
const GPU_BUFFER_NODES: usize = 1 << 20;

/// Σ w f(ωi, ωo) of each rule of `rules`, for each parameter block of `blocks` (one model) and
/// each ωo, on the GPU: results indexed `[rule][row][ωo]`. Every rule, row and direction of a
/// batch goes out in the same dispatches. Shared node lists go out once, at the front of the
/// node buffer; lists per direction follow, a batch of directions at a time, made straight into
/// the buffer that serves every batch.
fn gpu_sum_rules(
    backend: &Evaluator,
    gpu: &crate::gpu::Gpu,
    model: crate::model::Model,
    blocks: &[Vec<u8>],
    white_furnace: bool,
    rules: &[Rule],
    wo: &[DVec3],
) -> Result<Vec<RowSums>> {
    use crate::gpu::albedo::{span_nodes, AlbedoSum, DISPATCH_NODES};
    let span = span_nodes(gpu.device().cpu_kernels());
    // Lists made per direction go as offsets from its mirror direction where the model's kernel
    // takes ωi + ωo from them (`Model::sums_from_mirror_offsets`).
    let mirror = model.sums_from_mirror_offsets();
    // Workgroup spans in one batch: about one dispatch's worth, which bounds the host's span
    // list and partial sums however many rows and directions a job has, and lets Ctrl-C act
    // between dispatches.
    let batch_spans = DISPATCH_NODES / span;
    let shared: Vec<Option<std::sync::Arc<Vec<Node>>>> =
        rules.iter().map(Rule::shared_nodes).collect();
    // Where each shared list starts in the node buffer.
    let mut front = 0;
    let shared_at: Vec<usize> = shared
        .iter()
        .map(|l| {
            let at = front;
            front += l.as_ref().map_or(0, |l| l.len());
            at
        })
        .collect();
    // Nodes of each rule at each direction (counted in parallel unless every list is shared:
    // then there is nothing worth waking the thread pool for), and what one direction costs:
    // the nodes it adds to the buffer and the spans of all its sums.
    let all_shared = shared.iter().all(Option::is_some);
    let count = |&o: &DVec3| -> Vec<usize> {
        rules
            .iter()
            .zip(&shared)
            .map(|(r, l)| l.as_ref().map_or_else(|| r.node_count(o), |l| l.len()))
            .collect()
    };
    let counts: Vec<Vec<usize>> = if all_shared {
        wo.iter().map(count).collect()
    } else {
        wo.par_iter().map(count).collect()
    };
    let own = |o: usize| -> usize {
        counts[o]
            .iter()
            .zip(&shared)
            .filter(|(_, l)| l.is_none())
            .map(|(c, _)| c)
            .sum()
    };
    let spans = |o: usize| -> usize {
        blocks.len() * counts[o].iter().map(|c| c.div_ceil(span)).sum::<usize>()
    };
    // Batches of consecutive directions, each within both budgets (at least one direction).
    let mut batches: Vec<std::ops::Range<usize>> = Vec::new();
    let (mut start, mut nodes_in, mut spans_in) = (0, 0, 0);
    for o in 0..wo.len() {
        let (n, k) = (own(o), spans(o));
        if o > start && (nodes_in + n > GPU_BUFFER_NODES || spans_in + k > batch_spans) {
            batches.push(start..o);
            (start, nodes_in, spans_in) = (o, 0, 0);
        }
        nodes_in += n;
        spans_in += k;
    }
    if start < wo.len() {
        batches.push(start..wo.len());
    }
    let capacity = front
        + batches
            .iter()
            .map(|b| b.clone().map(own).sum::<usize>())
            .max()
            .unwrap_or(0);
    let mut nodes = gpu.albedo_nodes(capacity)?;
    nodes.fill(front, |d| {
        for (l, &at) in shared.iter().zip(&shared_at) {
            if let Some(l) = l {
                for (d, x) in d[at..at + l.len()].iter_mut().zip(l.iter()) {
                    *d = f4(x.wi, x.weight);
                }
            }
        }
    })?;
    let mut out = vec![vec![Vec::with_capacity(wo.len()); blocks.len()]; rules.len()];
    for batch in batches {
        backend.check_cancelled()?;
        // Where each (direction, rule) list starts: shared lists at the front, the rest of the
        // batch's lists after them, direction by direction.
        let mut at = front;
        let mut starts: Vec<Vec<usize>> = Vec::with_capacity(batch.len());
        for o in batch.clone() {
            starts.push(
                shared_at
                    .iter()
                    .zip(&shared)
                    .zip(&counts[o])
                    .map(|((&s, l), &c)| match l {
                        Some(_) => s,
                        None => {
                            at += c;
                            at - c
                        }
                    })
                    .collect(),
            );
        }
        // The batch's own lists (none where every list is shared: the buffer holds those).
        if at > front {
            nodes.fill(at, |d| {
                // One slot per direction, then filled in parallel.
                let mut slots = Vec::with_capacity(batch.len());
                let mut rest = &mut d[front..];
                for o in batch.clone() {
                    let (slot, tail) = std::mem::take(&mut rest).split_at_mut(own(o));
                    slots.push((o, slot));
                    rest = tail;
                }
                slots.into_par_iter().for_each(|(o, slot)| {
                    let mut k = 0;
                    for ((r, l), &c) in rules.iter().zip(&shared).zip(&counts[o]) {
                        if l.is_none() {
                            fill_nodes(*r, wo[o], mirror, &mut slot[k..k + c]);
                            k += c;
                        }
                    }
                });
            })?;
        }
        let mut sums = Vec::with_capacity(rules.len() * blocks.len() * batch.len());
        for r in 0..rules.len() {
            for param in 0..blocks.len() {
                for (o, s) in batch.clone().zip(&starts) {
                    sums.push(AlbedoSum {
                        wo: f32_wo(wo[o]),
                        param,
                        begin: s[r],
                        len: counts[o][r],
                        mirror: mirror && shared[r].is_none(),
                    });
                }
            }
        }
        let e = gpu.albedo_sums(model, blocks, white_furnace, &nodes, &sums)?;
        let mut e = e.into_iter();
        for (r, rule_out) in out.iter_mut().enumerate() {
            for row in rule_out.iter_mut() {
                for o in batch.clone() {
                    let v = e.next().unwrap_or_default();
                    row.push((DVec3::from_array(v), counts[o][r] as u64));
                }
            }
        }
    }
    Ok(out)
}

/// Σ term(node) over `nodes` in parallel and in a fixed order: sums of 4096-node chunks, then
/// those sums in chunk order. (rayon's own `sum` combines partial sums in an order that depends
/// on which thread stole what, so the same integral could differ in its last bit between runs.)
fn weighted_sum(nodes: &[Node], term: impl Fn(&Node) -> DVec3 + Sync) -> DVec3 {
    let parts: Vec<DVec3> = nodes
        .par_chunks(4096)
        .map(|c| c.iter().map(&term).sum::<DVec3>())
        .collect();
    parts.into_iter().sum()
}

/// f32x4 (xyz, w) of a direction and a weight, as the GPU kernels read them.
fn f4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// ωo as the GPU kernels read it.
fn f32_wo(wo: DVec3) -> [f32; 3] {
    [wo.x as f32, wo.y as f32, wo.z as f32]
}

/// Writes the nodes of `rule` at `wo` into `slot` (as long as their count) as f32x4 (ωi, w), or
/// with `mirror` as offsets from the mirror direction of ωo
/// ([`mirror_node`](crate::gpu::albedo::mirror_node)).
fn fill_nodes(rule: Rule, wo: DVec3, mirror: bool, slot: &mut [[f32; 4]]) {
    let mut k = 0;
    rule.for_each_node(wo, |x| {
        slot[k] = if mirror {
            crate::gpu::albedo::mirror_node(x.wi, x.weight, wo)
        } else {
            f4(x.wi, x.weight)
        };
        k += 1;
    });
    debug_assert_eq!(k, slot.len(), "node_count and for_each_node disagree");
}

/// [`rule_albedo`] for several parameter sets of one model (the rows of a LUT) at the same view
/// directions with the same rule: each direction's nodes are made once and serve every row, and
/// on the GPU every row, the rule and its two coarser levels (or every replicate) go out in the
/// same dispatches. Row r of the result is `rule_albedo(backend, &rows[r], …)`. Rows of
/// different models are taken row by row.
pub fn rule_albedo_rows(
    backend: &Evaluator,
    rows: &[ParamSet],
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Vec<Estimate>>> {
    if !rows.windows(2).all(|w| w[0].model() == w[1].model()) {
        return rows
            .iter()
            .map(|p| rule_albedo(backend, p, white_furnace, rule, wo))
            .collect();
    }
    let Some(first) = rows.first() else {
        return Ok(Vec::new());
    };
    let rounding = f32_rounding(backend, first.model(), rule);
    if let Rule::Importance {
        n,
        mix,
        replicate: None,
    } = rule
    {
        let reps: Vec<Rule> = (0..REPLICATES)
            .map(|k| Rule::Importance {
                n,
                mix,
                replicate: Some(k),
            })
            .collect();
        // [replicate][row][ωo]
        let sums = sum_rules_rows(backend, rows, white_furnace, &reps, wo)?;
        let r = REPLICATES as f64;
        return Ok((0..rows.len())
            .map(|row| {
                (0..wo.len())
                    .map(|o| {
                        let at = |k: u32| sums[k as usize][row][o];
                        let mean = (0..REPLICATES).map(|k| at(k).0).sum::<DVec3>() / r;
                        let var = (0..REPLICATES)
                            .map(|k| (at(k).0 - mean) * (at(k).0 - mean))
                            .sum::<DVec3>()
                            / (r - 1.0);
                        Estimate {
                            value: mean,
                            error: REPLICATE_T * (var / r).powf(0.5) + rounding(mean, wo[o]),
                            evals: (0..REPLICATES).map(|k| at(k).1).sum(),
                        }
                    })
                    .collect()
            })
            .collect());
    }
    let (coarse, p) = (rule.coarse(), rule.level_exponent());
    let levels = [rule, coarse, coarse.coarse()];
    // [level][row][ωo]
    let sums = sum_rules_rows(backend, rows, white_furnace, &levels, wo)?;
    Ok((0..rows.len())
        .map(|row| {
            (0..wo.len())
                .map(|o| {
                    let at = |l: usize| sums[l][row][o];
                    let v = at(0).0;
                    Estimate {
                        value: v,
                        error: three_level_error(v, at(1).0, at(2).0, p) + rounding(v, wo[o]),
                        evals: at(0).1,
                    }
                })
                .collect()
        })
        .collect())
}

/// [`sum_rule`] of each rule of `rules` for every parameter set of `rows` (one model) at each
/// ωo: results indexed `[rule][row][ωo]`. Each direction's nodes are made once for all rows:
/// the CPU runs the directions in parallel, the GPU sends a batch of directions (every rule and
/// row of it) in the same dispatches.
pub fn sum_rules_rows(
    backend: &Evaluator,
    rows: &[ParamSet],
    white_furnace: bool,
    rules: &[Rule],
    wo: &[DVec3],
) -> Result<Vec<RowSums>> {
    let Some(first) = rows.first() else {
        return Ok(vec![Vec::new(); rules.len()]);
    };
    if let Backend::Gpu(gpu) = backend.backend() {
        let blocks: Vec<Vec<u8>> = rows.iter().map(|p| Brdf::new(p).gpu_block()).collect();
        return gpu_sum_rules(
            backend,
            gpu,
            first.model(),
            &blocks,
            white_furnace,
            rules,
            wo,
        );
    }
    first.model().require_reference("the CPU backend")?;
    let refs: Vec<Reference> = rows
        .iter()
        .map(|p| Reference::new(p, white_furnace))
        .collect();
    let name = first.model().name();
    rules
        .iter()
        .map(|&rule| cpu_sum_rule_rows(backend, name, &refs, rule, wo))
        .collect()
}

/// One rule's f64 sums for every reference of `refs` at each ωo: row-major results. The view
/// directions run in parallel, each making its nodes (unless the rule shares one list) and
/// summing them for every row: one list per running thread, made once for all rows.
fn cpu_sum_rule_rows(
    backend: &Evaluator,
    model: &str,
    refs: &[Reference],
    rule: Rule,
    wo: &[DVec3],
) -> Result<RowSums> {
    let shared = rule.shared_nodes();
    let per_wo: Vec<Vec<(DVec3, u64)>> = wo
        .par_iter()
        .map(|&o| {
            // Ctrl-C: one view direction's sums at most run on.
            backend.check_cancelled()?;
            let own;
            let nodes = match &shared {
                Some(n) => n,
                None => {
                    own = rule.nodes(o);
                    &own
                }
            };
            refs.iter()
                .map(|r| {
                    // NaN, ±Inf and negative values are refused (docs/design.md §2.1).
                    let bad = std::sync::atomic::AtomicBool::new(false);
                    let sum = weighted_sum(nodes, |n| {
                        let f = r.eval(n.wi, o);
                        if !finite::is_valid_rgb(f) {
                            bad.store(true, std::sync::atomic::Ordering::Relaxed);
                        }
                        n.weight * f
                    });
                    if bad.into_inner() {
                        let pairs = nodes.iter().map(|n| (n.wi, o));
                        let eval = |wi, wo| r.eval(wi, wo);
                        return Err(finite::refuse_pairs(model, "albedo", pairs, eval).into());
                    }
                    Ok((sum, nodes.len() as u64))
                })
                .collect()
        })
        .collect::<Result<_>>()?;
    Ok((0..refs.len())
        .map(|r| per_wo.iter().map(|sums| sums[r]).collect())
        .collect())
}
