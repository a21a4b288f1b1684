//! Sums of hemispherical rules on the GPU: node lists into the node buffer, batches of view
//! directions within the buffer's and a dispatch's budgets, and the albedo kernel's reductions.

use super::albedo_kernel::{mirror_node, span_nodes, AlbedoSum, DISPATCH_NODES};
use super::Gpu;
use crate::backend::{NodeRule, RowSums};
use crate::interrupt::CancelToken;
use crate::model::Model;
use crate::quadrature::Node;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// Nodes of ωo-dependent rules in one batch on the GPU: 1M nodes, a node buffer of 16 MiB as
/// f32x4. Small enough that first touching its pages stays a small part of a directional
/// albedo's time (each page of a fresh mapping faults once), large enough for dispatches of
/// ~1000 workgroups.
const GPU_BUFFER_NODES: usize = 1 << 20;

/// Where a job's node lists go in the node buffer and which view directions share a batch.
struct Plan {
    /// Each rule's one list for every direction, or None where it makes one per direction.
    shared: Vec<Option<Arc<Vec<Node>>>>,
    /// Where each shared list starts in the node buffer.
    shared_at: Vec<usize>,
    /// Nodes of the shared lists, at the front of the buffer.
    front: usize,
    /// Nodes of each rule at each direction.
    counts: Vec<Vec<usize>>,
    /// Consecutive directions sent in the same dispatches.
    batches: Vec<Range<usize>>,
}

impl Plan {
    /// Lists of `rules` at `wo` for `rows` parameter blocks, in batches within the node buffer's
    /// budget and one dispatch's spans of `span` nodes each.
    fn new(rules: &[&dyn NodeRule], wo: &[DVec3], rows: usize, span: usize) -> Plan {
        let shared: Vec<Option<Arc<Vec<Node>>>> = rules.iter().map(|r| r.shared()).collect();
        let mut front = 0;
        let shared_at: Vec<usize> = shared
            .iter()
            .map(|l| {
                let at = front;
                front += l.as_ref().map_or(0, |l| l.len());
                at
            })
            .collect();
        // Counted in parallel unless every list is shared: then there is nothing worth waking
        // the thread pool for.
        let count = |&o: &DVec3| -> Vec<usize> {
            rules
                .iter()
                .zip(&shared)
                .map(|(r, l)| l.as_ref().map_or_else(|| r.count(o), |l| l.len()))
                .collect()
        };
        let counts: Vec<Vec<usize>> = if shared.iter().all(Option::is_some) {
            wo.iter().map(count).collect()
        } else {
            wo.par_iter().map(count).collect()
        };
        let mut plan = Plan {
            shared,
            shared_at,
            front,
            counts,
            batches: Vec::new(),
        };
        plan.batches = plan.batches(rows, span);
        plan
    }

    /// Nodes direction `o` adds to the buffer: its lists that are not shared.
    fn own(&self, o: usize) -> usize {
        self.counts[o]
            .iter()
            .zip(&self.shared)
            .filter(|(_, l)| l.is_none())
            .map(|(c, _)| c)
            .sum()
    }

    /// Batches of consecutive directions, each within both budgets (at least one direction).
    /// Workgroup spans in one batch: about one dispatch's worth, which bounds the host's span
    /// list and partial sums however many rows and directions a job has, and lets Ctrl-C act
    /// between dispatches.
    fn batches(&self, rows: usize, span: usize) -> Vec<Range<usize>> {
        let batch_spans = DISPATCH_NODES / span;
        let spans = |o: usize| -> usize {
            rows * self.counts[o]
                .iter()
                .map(|c| c.div_ceil(span))
                .sum::<usize>()
        };
        let mut batches = Vec::new();
        let (mut start, mut nodes_in, mut spans_in) = (0, 0, 0);
        for o in 0..self.counts.len() {
            let (n, k) = (self.own(o), spans(o));
            if o > start && (nodes_in + n > GPU_BUFFER_NODES || spans_in + k > batch_spans) {
                batches.push(start..o);
                (start, nodes_in, spans_in) = (o, 0, 0);
            }
            nodes_in += n;
            spans_in += k;
        }
        if start < self.counts.len() {
            batches.push(start..self.counts.len());
        }
        batches
    }

    /// The node buffer's length: the shared lists and the largest batch's own lists.
    fn capacity(&self) -> usize {
        self.front
            + self
                .batches
                .iter()
                .map(|b| b.clone().map(|o| self.own(o)).sum::<usize>())
                .max()
                .unwrap_or(0)
    }

    /// Where each (direction, rule) list of `batch` starts: shared lists at the front, the rest
    /// of the batch's lists after them, direction by direction; and where the batch's own lists end.
    fn starts(&self, batch: Range<usize>) -> (Vec<Vec<usize>>, usize) {
        let mut at = self.front;
        let starts = batch
            .map(|o| {
                self.shared_at
                    .iter()
                    .zip(&self.shared)
                    .zip(&self.counts[o])
                    .map(|((&s, l), &c)| match l {
                        Some(_) => s,
                        None => {
                            at += c;
                            at - c
                        }
                    })
                    .collect()
            })
            .collect();
        (starts, at)
    }

    /// Writes the shared lists into the front of `d`.
    fn fill_shared(&self, d: &mut [[f32; 4]]) {
        for (l, &at) in self.shared.iter().zip(&self.shared_at) {
            if let Some(l) = l {
                for (d, x) in d[at..at + l.len()].iter_mut().zip(l.iter()) {
                    *d = f4(x.wi, x.weight);
                }
            }
        }
    }

    /// Writes the own lists of `batch` after the front of `d`: one slot per direction, filled in
    /// parallel.
    fn fill_batch(
        &self,
        d: &mut [[f32; 4]],
        batch: Range<usize>,
        rules: &[&dyn NodeRule],
        wo: &[DVec3],
        mirror: bool,
    ) {
        let mut slots = Vec::with_capacity(batch.len());
        let mut rest = &mut d[self.front..];
        for o in batch {
            let (slot, tail) = std::mem::take(&mut rest).split_at_mut(self.own(o));
            slots.push((o, slot));
            rest = tail;
        }
        slots.into_par_iter().for_each(|(o, slot)| {
            let mut k = 0;
            for ((r, l), &c) in rules.iter().zip(&self.shared).zip(&self.counts[o]) {
                if l.is_none() {
                    fill_nodes(*r, wo[o], mirror, &mut slot[k..k + c]);
                    k += c;
                }
            }
        });
    }
}

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
    let plan = Plan::new(
        rules,
        wo,
        blocks.len(),
        span_nodes(gpu.device().cpu_kernels()),
    );
    // Lists made per direction go as offsets from its mirror direction where the model's kernel
    // takes ωi + ωo from them (`Model::sums_from_mirror_offsets`).
    let mirror = model.sums_from_mirror_offsets();
    let mut nodes = gpu.albedo_nodes(plan.capacity())?;
    nodes.fill(plan.front, |d| plan.fill_shared(d))?;
    let mut out = vec![vec![Vec::with_capacity(wo.len()); blocks.len()]; rules.len()];
    for batch in &plan.batches {
        if let Some(c) = cancel {
            c.check()?;
        }
        let (starts, end) = plan.starts(batch.clone());
        // The batch's own lists (none where every list is shared: the buffer holds those).
        if end > plan.front {
            nodes.fill(end, |d| {
                plan.fill_batch(d, batch.clone(), rules, wo, mirror)
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
                        len: plan.counts[o][r],
                        mirror: mirror && plan.shared[r].is_none(),
                    });
                }
            }
        }
        let mut e = gpu
            .albedo_sums(model, blocks, white_furnace, &nodes, &sums)?
            .into_iter();
        for (r, rule_out) in out.iter_mut().enumerate() {
            for row in rule_out.iter_mut() {
                for o in batch.clone() {
                    let v = e.next().unwrap_or_default();
                    row.push((DVec3::from_array(v), plan.counts[o][r] as u64));
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
