//! Running a fixed rule on a backend: f64 sums on the CPU, the reduction kernel on the GPU, and
//! the error estimate (the rule's coarser levels, or the replicates' spread) on top.

use super::estimate::level_error;
use super::gauss::Estimate;
use super::importance::{REPLICATES, REPLICATE_T};
use super::rules::Rule;
use crate::backend::{NodeRule, Precision, Query};
use crate::eval::Evaluator;
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;

/// E (delta excluded) of a fixed rule at each ωo on `backend`, with the rule's error estimate.
pub fn rule_albedo<'q>(
    backend: &Evaluator,
    query: impl Into<Query<'q>>,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Estimate>> {
    let mut rows = rule_albedo_rows(backend, query.into(), rule, wo)?;
    Ok(rows.pop().unwrap_or_default())
}

/// Integrand evaluations [`rule_albedo`] spends on `rule` at the view directions `wo`: the nodes
/// of the rule and of its coarser levels ([`Rule::levels`]; for the replicated importance rule,
/// its replicates' nodes).
pub fn rule_evaluations(rule: Rule, tabulated: bool, wo: &[DVec3]) -> u64 {
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
        _ => rule.levels(tabulated).into_iter().map(count).sum(),
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
    let on_gpu = backend.precision() == Precision::F32;
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

pub use crate::backend::RowSums;

/// Σ w f(ωi, ωo) for each ωo: f64 sums on the CPU, the reduction kernel on the GPU.
pub fn sum_rule<'q>(
    backend: &Evaluator,
    query: impl Into<Query<'q>>,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<(DVec3, u64)>> {
    let mut sums = sum_rules_rows(backend, query.into(), &[rule], wo)?;
    Ok(sums.pop().and_then(|mut r| r.pop()).unwrap_or_default())
}

/// [`rule_albedo`] for each parameter set of `query` (the rows of a LUT) at the same view
/// directions with the same rule: each direction's nodes are made once and serve every row, and
/// on the GPU every row, the rule and its coarser levels (or every replicate) go out in the
/// same dispatches. Row r of the result is `rule_albedo(backend, query.for_set(&rows[r]), …)`.
/// Rows of different models are taken row by row.
pub fn rule_albedo_rows(
    backend: &Evaluator,
    query: Query,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<Vec<Estimate>>> {
    let rows = query.sets;
    if !query.one_model() {
        return rows
            .iter()
            .map(|p| rule_albedo(backend, query.for_set(p), rule, wo))
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
        let sums = sum_rules_rows(backend, query, &reps, wo)?;
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
    let tabulated = first.model().is_tabulated();
    let (levels, p) = (rule.levels(tabulated), rule.level_exponent());
    // [level][row][ωo]
    let sums = sum_rules_rows(backend, query, &levels, wo)?;
    Ok((0..rows.len())
        .map(|row| {
            (0..wo.len())
                .map(|o| {
                    let at = |l: usize| sums[l][row][o];
                    let v = at(0).0;
                    let values: Vec<DVec3> = (0..levels.len()).map(|l| at(l).0).collect();
                    Estimate {
                        value: v,
                        error: level_error(&values, p) + rounding(v, wo[o]),
                        evals: at(0).1,
                    }
                })
                .collect()
        })
        .collect())
}

/// [`sum_rule`] of each rule of `rules` for every parameter set of `query` (one model) at each
/// ωo: results indexed `[rule][row][ωo]`. Each direction's nodes are made once for all rows:
/// the CPU runs the directions in parallel, the GPU sends a batch of directions (every rule and
/// row of it) in the same dispatches.
pub fn sum_rules_rows(
    backend: &Evaluator,
    query: Query,
    rules: &[Rule],
    wo: &[DVec3],
) -> Result<Vec<RowSums>> {
    let rules: Vec<&dyn NodeRule> = rules.iter().map(|r| r as &dyn NodeRule).collect();
    backend
        .backend()
        .rule_sums(query, &rules, wo, backend.cancel_token())
}
