//! Sums of hemispherical rules on the GPU: node lists into the node buffer, batches of view
//! directions within the buffer's and a dispatch's budgets, and the albedo kernel's reductions.

use super::albedo::{mirror_node, span_nodes, AlbedoSum, DISPATCH_NODES};
use super::Gpu;
use crate::backend::{NodeRule, RowSums};
use crate::interrupt::CancelToken;
use crate::model::Model;
use crate::quadrature::Node;
use glam::DVec3;
use rayon::prelude::*;

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
pub(super) fn sum_rules(
    gpu: &Gpu,
    model: Model,
    blocks: &[Vec<u8>],
    white_furnace: bool,
    rules: &[&dyn NodeRule],
    wo: &[DVec3],
    cancel: Option<&CancelToken>,
) -> anyhow::Result<Vec<RowSums>> {
    let span = span_nodes(gpu.device().cpu_kernels());
    // Lists made per direction go as offsets from its mirror direction where the model's kernel
    // takes ωi + ωo from them (`Model::sums_from_mirror_offsets`).
    let mirror = model.sums_from_mirror_offsets();
    // Workgroup spans in one batch: about one dispatch's worth, which bounds the host's span
    // list and partial sums however many rows and directions a job has, and lets Ctrl-C act
    // between dispatches.
    let batch_spans = DISPATCH_NODES / span;
    let shared: Vec<Option<std::sync::Arc<Vec<Node>>>> = rules.iter().map(|r| r.shared()).collect();
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
            .map(|(r, l)| l.as_ref().map_or_else(|| r.count(o), |l| l.len()))
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
        if let Some(c) = cancel {
            c.check()?;
        }
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
/// ([`mirror_node`]).
fn fill_nodes(rule: &dyn NodeRule, wo: DVec3, mirror: bool, slot: &mut [[f32; 4]]) {
    let mut k = 0;
    rule.visit(wo, &mut |x| {
        slot[k] = if mirror {
            mirror_node(x.wi, x.weight, wo)
        } else {
            f4(x.wi, x.weight)
        };
        k += 1;
    });
    debug_assert_eq!(k, slot.len(), "a rule's count and its nodes disagree");
}
