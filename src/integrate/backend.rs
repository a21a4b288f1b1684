//! Running a fixed rule on a backend: f64 sums on the CPU, the reduction kernel on the GPU, and
//! the error estimate (coarse rule or replicates' spread) on top.

use super::gauss::Estimate;
use super::importance::{REPLICATES, REPLICATE_T};
use super::rules::{Node, Rule};
use crate::eval::{Backend, Evaluator};
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
    if let Rule::Importance {
        n,
        mix,
        replicate: None,
    } = rule
    {
        let reps: Vec<Vec<(DVec3, u64)>> = (0..REPLICATES)
            .map(|k| {
                let one = Rule::Importance {
                    n,
                    mix,
                    replicate: Some(k),
                };
                sum_rule(backend, params, white_furnace, one, wo)
            })
            .collect::<Result<_>>()?;
        let r = REPLICATES as f64;
        let rounding = f32_rounding(backend);
        return Ok((0..wo.len())
            .map(|o| {
                let mean = reps.iter().map(|v| v[o].0).sum::<DVec3>() / r;
                let var = reps
                    .iter()
                    .map(|v| (v[o].0 - mean) * (v[o].0 - mean))
                    .sum::<DVec3>()
                    / (r - 1.0);
                Estimate {
                    value: mean,
                    error: REPLICATE_T * (var / r).powf(0.5) + rounding(mean, wo[o]),
                    evals: reps.iter().map(|v| v[o].1).sum(),
                }
            })
            .collect());
    }
    let (coarse, factor) = rule.coarse();
    let fine_e = sum_rule(backend, params, white_furnace, rule, wo)?;
    let coarse_e = sum_rule(backend, params, white_furnace, coarse, wo)?;
    let rounding = f32_rounding(backend);
    Ok(fine_e
        .into_iter()
        .zip(coarse_e)
        .zip(wo)
        .map(|(((v, n), (c, _)), &o)| Estimate {
            value: v,
            error: factor * (v - c).abs() + rounding(v, o),
            evals: n,
        })
        .collect())
}

/// Integrand evaluations [`rule_albedo`] spends on `rule` at the view directions `wo`: the fine
/// and the coarse rule's nodes (for the replicated importance rule, its replicates' nodes).
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
        _ => count(rule) + count(rule.coarse().0),
    }
}

/// The factor K of the f32 rounding bound K ε Σ|w f| / μo that every GPU estimate of a fixed
/// rule carries.
///
/// The GPU evaluates f in f32 from nodes and a view direction rounded to f32, and sums in f32
/// (16 terms per invocation, then a 64-wide tree: at most 22 roundings, 22 ε relative, in the
/// worst case, ~√22 ε typically). The coarse rule shares those roundings, so |fine − coarse|
/// misses them: at E(1) of GGX α = 0.3 under the white furnace the GPU is 6.5e-8 from the f64
/// sum of the same rule while |fine − coarse| is 1.7e-8. The rounding of f grows at grazing
/// view: h = ωi + ωo cancels to length 2μo about the mirror direction, so an absolute rounding
/// of ε in its components is ε/(2μo) in its direction. Over the built-in presets and GGX and
/// Beckmann with α ∈ [0.001, 1], μo ∈ [0.02, 1], the largest |GPU − f64| / (ε Σ|w f|) seen was
/// 0.8 at μo = 1 and 80 at μo = 0.02 (1.6/μo): K = 4 covers it with a margin of 2.5
/// (tests/engine_luts.rs `gpu_error_estimates_bound_the_f32_rounding` checks it).
pub const GPU_ROUNDING_FACTOR: f64 = 4.0;

/// The f32 rounding term of an estimate on `backend` (0 on the CPU, whose sums are f64): for a
/// GPU sum of value v at view ωo, K ε |v| / μo with ε = 2^-23 and K = [`GPU_ROUNDING_FACTOR`].
/// |v| = Σ|w f| because every rule's weights are positive and a BRDF is nonnegative.
fn f32_rounding(backend: &Evaluator) -> impl Fn(DVec3, DVec3) -> DVec3 {
    let on_gpu = matches!(backend.backend(), Backend::Gpu(_));
    move |v: DVec3, wo: DVec3| {
        if on_gpu {
            v.abs() * (GPU_ROUNDING_FACTOR * f32::EPSILON as f64 / wo.z.max(f64::MIN_POSITIVE))
        } else {
            DVec3::ZERO
        }
    }
}

/// Nodes of ωo-dependent rules gathered for one batch of directions: 4M nodes, 64 MiB as f32x4 in
/// the GPU's node buffer (made straight into it), 128 MiB as f64 lists on the CPU.
const GPU_NODE_BATCH: usize = 1 << 22;

/// Σ w f(ωi, ωo) for each ωo: f64 sums on the CPU, the reduction kernel on the GPU.
pub fn sum_rule(
    backend: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<(DVec3, u64)>> {
    match backend.backend() {
        Backend::Cpu => {
            params.model().require_reference("the CPU backend")?;
            let r = Reference::new(params, white_furnace);
            let shared = rule.shared_nodes();
            wo.par_iter()
                .map(|&o| {
                    // Ctrl-C: one view direction's sum at most runs on.
                    backend.check_cancelled()?;
                    let own;
                    let nodes = match &shared {
                        Some(n) => n,
                        None => {
                            own = rule.nodes(o);
                            &own
                        }
                    };
                    let sum = weighted_sum(nodes, |n| n.weight * r.eval(n.wi, o));
                    Ok((sum, nodes.len() as u64))
                })
                .collect()
        }
        Backend::Gpu(gpu) => {
            let blocks = [Brdf::new(params).gpu_block()];
            let mut rows = gpu_sum_rows(
                backend,
                gpu,
                params.model(),
                &blocks,
                white_furnace,
                rule,
                wo,
            )?;
            Ok(rows.pop().unwrap_or_default())
        }
    }
}

/// Nodes of ωo-dependent rules in one batch on the GPU: 1M nodes, a node buffer of 16 MiB as
/// f32x4. Small enough that first touching its pages stays a small part of a directional
/// albedo's time (each page of a fresh mapping faults once), large enough for dispatches of
/// ~1000 workgroups.
const GPU_BUFFER_NODES: usize = 1 << 20;

/// Σ w f(ωi, ωo) for each parameter block of `blocks` (one model) and each ωo on the GPU:
/// row-major results. A shared node list goes out once; lists per direction go out a batch of
/// directions at a time, made straight into one node buffer that serves every batch.
fn gpu_sum_rows(
    backend: &Evaluator,
    gpu: &crate::gpu::Gpu,
    model: crate::model::Model,
    blocks: &[Vec<u8>],
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Vec<(DVec3, u64)>>> {
    let wo4: Vec<[f32; 4]> = wo.iter().map(|&o| f4(o, 0.0)).collect();
    let mut out: Vec<Vec<(DVec3, u64)>> = vec![Vec::with_capacity(wo.len()); blocks.len()];
    let mut add = |sums: Vec<Vec<[f64; 3]>>, counts: &[usize]| {
        for (row, sums) in out.iter_mut().zip(sums) {
            row.extend(
                sums.into_iter()
                    .zip(counts)
                    .map(|(s, &k)| (DVec3::from_array(s), k as u64)),
            );
        }
    };
    if let Some(l) = rule.shared_nodes() {
        let mut nodes = gpu.albedo_nodes(l.len())?;
        nodes.fill(l.len(), |d| {
            for (d, x) in d.iter_mut().zip(l.iter()) {
                *d = f4(x.wi, x.weight);
            }
        })?;
        let sums =
            gpu.albedo_rows_in(model, blocks, white_furnace, &wo4, &nodes, l.len(), false)?;
        add(sums, &vec![l.len(); wo.len()]);
        return Ok(out);
    }
    // Nodes per direction travel to the GPU: a batch of directions at a time keeps host memory
    // bounded (an anisotropic hemispherical albedo asks for thousands of directions of ~1e5
    // nodes each: gigabytes at once). Each batch's lists are padded to its longest; the buffer
    // is sized once for the largest batch.
    let counts: Vec<usize> = wo.par_iter().map(|&o| rule.node_count(o)).collect();
    let batch = (GPU_BUFFER_NODES / counts.first().copied().unwrap_or(1).max(1)).max(1);
    let stride = |c: &[usize]| c.iter().copied().max().unwrap_or(0);
    let capacity = counts
        .chunks(batch)
        .map(|c| stride(c) * c.len())
        .max()
        .unwrap_or(0);
    let mut nodes = gpu.albedo_nodes(capacity)?;
    for ((part, part4), c) in wo
        .chunks(batch)
        .zip(wo4.chunks(batch))
        .zip(counts.chunks(batch))
    {
        backend.check_cancelled()?;
        let n = stride(c);
        nodes.fill(n * part.len(), |d| {
            if n > 0 {
                d.par_chunks_mut(n)
                    .zip(part.par_iter())
                    .for_each(|(slot, &o)| fill_nodes(rule, o, slot));
            }
        })?;
        let sums = gpu.albedo_rows_in(model, blocks, white_furnace, part4, &nodes, n, true)?;
        add(sums, c);
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

/// Writes the nodes of `rule` at `wo` into `slot` as f32x4 (ωi, w), then pads the rest of the
/// slot with nodes that weigh nothing.
fn fill_nodes(rule: Rule, wo: DVec3, slot: &mut [[f32; 4]]) {
    let mut k = 0;
    rule.for_each_node(wo, |x| {
        slot[k] = f4(x.wi, x.weight);
        k += 1;
    });
    slot[k..].fill([0.0, 0.0, 1.0, 0.0]);
}

/// [`rule_albedo`] for several parameter sets of one model (the rows of a LUT) at the same view
/// directions with the same rule: each direction's nodes are made once and serve every row, and
/// on the GPU every row goes out in the same dispatches. Row r of the result is
/// `rule_albedo(backend, &rows[r], …)`. A rule that depends on the parameters (`importance`)
/// or rows of different models are taken row by row.
pub fn rule_albedo_rows(
    backend: &Evaluator,
    rows: &[ParamSet],
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Vec<Estimate>>> {
    let one_model = rows.windows(2).all(|w| w[0].model() == w[1].model());
    if matches!(rule, Rule::Importance { .. }) || !one_model {
        return rows
            .iter()
            .map(|p| rule_albedo(backend, p, white_furnace, rule, wo))
            .collect();
    }
    let (coarse, factor) = rule.coarse();
    let fine_e = sum_rule_rows(backend, rows, white_furnace, rule, wo)?;
    let coarse_e = sum_rule_rows(backend, rows, white_furnace, coarse, wo)?;
    let rounding = f32_rounding(backend);
    Ok(fine_e
        .into_iter()
        .zip(coarse_e)
        .map(|(fine, coarse)| {
            fine.into_iter()
                .zip(coarse)
                .zip(wo)
                .map(|(((v, n), (c, _)), &o)| Estimate {
                    value: v,
                    error: factor * (v - c).abs() + rounding(v, o),
                    evals: n,
                })
                .collect()
        })
        .collect())
}

/// [`sum_rule`] for every parameter set of `rows` (one model) at each ωo: row-major results.
/// The nodes of a batch of directions are made once (in parallel) for all rows; the CPU then
/// sums every (row, ωo) in parallel, the GPU in one reduction call per batch.
pub fn sum_rule_rows(
    backend: &Evaluator,
    rows: &[ParamSet],
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Vec<(DVec3, u64)>>> {
    let Some(first) = rows.first() else {
        return Ok(Vec::new());
    };
    if let Backend::Gpu(gpu) = backend.backend() {
        let blocks: Vec<Vec<u8>> = rows.iter().map(|p| Brdf::new(p).gpu_block()).collect();
        return gpu_sum_rows(
            backend,
            gpu,
            first.model(),
            &blocks,
            white_furnace,
            rule,
            wo,
        );
    }
    let depends = rule.depends_on_wo();
    let batch = match (depends, wo.first()) {
        (true, Some(&o)) => (GPU_NODE_BATCH / rule.node_count(o).max(1)).max(1),
        _ => wo.len().max(1),
    };
    let mut out: Vec<Vec<(DVec3, u64)>> = vec![Vec::with_capacity(wo.len()); rows.len()];
    let shared = rule.shared_nodes();
    first.model().require_reference("the CPU backend")?;
    let refs: Vec<Reference> = rows
        .iter()
        .map(|p| Reference::new(p, white_furnace))
        .collect();
    for part in wo.chunks(batch) {
        backend.check_cancelled()?;
        let lists: Vec<Vec<Node>> = match &shared {
            Some(_) => Vec::new(),
            None => part.par_iter().map(|&o| rule.nodes(o)).collect(),
        };
        let list = |d: usize| -> &[Node] {
            match &shared {
                Some(n) => n,
                None => &lists[d],
            }
        };
        let sums: Vec<(DVec3, u64)> = (0..rows.len() * part.len())
            .into_par_iter()
            .map(|e| {
                let (r, d) = (e / part.len(), e % part.len());
                let (nodes, o, reference) = (list(d), part[d], &refs[r]);
                let sum = weighted_sum(nodes, |n| n.weight * reference.eval(n.wi, o));
                (sum, nodes.len() as u64)
            })
            .collect();
        for (r, row) in sums.chunks(part.len()).enumerate() {
            out[r].extend_from_slice(row);
        }
    }
    Ok(out)
}
