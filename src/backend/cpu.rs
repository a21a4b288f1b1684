//! The f64 CPU reference as a backend: each model's f64 twin, rayon over every core. Tables
//! evaluate every cell, reciprocal ones too ([`Backend::makes_upper_triangle`] is false): the
//! reference makes each cell from its own directions.

use super::light::{SpherePixel, WeightedTexels};
use super::scene::Scene;
use super::shade::render_cells_cpu;
use super::{Backend, DrawRange, DrawRecord, NodeRule, Precision, Query, RowSums, TableSink};
use crate::finite;
use crate::interrupt::CancelToken;
use crate::model::{Model, Reference};
use crate::quadrature::Node;
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Cells per CPU chunk of a table: bounded memory, enough work for every thread.
const CPU_CHUNK_CELLS: u64 = 1 << 22;

/// The f64 reference: [`Reference`] of each parameter set.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuBackend;

impl CpuBackend {
    /// The references of the query's sets, once the model is known to have its f64 twin.
    fn references(&self, query: &Query) -> Result<Vec<Reference>> {
        if let Some(m) = query.model() {
            self.supports(m)?;
        }
        Ok(query
            .sets
            .iter()
            .map(|p| Reference::new(p, query.white_furnace))
            .collect())
    }

    /// The reference of the query's first set (None for a query without sets).
    fn first_reference(&self, query: &Query) -> Result<Option<Reference>> {
        let refs = self.references(&Query {
            sets: &query.sets[..query.sets.len().min(1)],
            ..*query
        })?;
        Ok(refs.into_iter().next())
    }
}

fn check(cancel: Option<&CancelToken>) -> Result<()> {
    Ok(cancel.map_or(Ok(()), CancelToken::check)?)
}

impl Backend for CpuBackend {
    fn name(&self) -> String {
        "cpu (f64 reference)".to_string()
    }

    fn precision(&self) -> Precision {
        Precision::F64
    }

    fn supports(&self, model: Model) -> Result<()> {
        Ok(model.require_reference("the CPU backend")?)
    }

    fn pdf(&self, query: Query, pairs: &[(DVec3, DVec3)]) -> Result<Vec<f64>> {
        let Some(r) = self.first_reference(&query)? else {
            return Ok(Vec::new());
        };
        Ok(pairs.par_iter().map(|&(wi, wo)| r.pdf(wi, wo)).collect())
    }

    fn draws(
        &self,
        query: Query,
        wo: DVec3,
        range: DrawRange,
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<DrawRecord>> {
        let DrawRange {
            seed,
            group,
            first,
            count,
        } = range;
        let Some(r) = self.first_reference(&query)? else {
            return Ok(Vec::new());
        };
        let mut out = Vec::with_capacity(count);
        // Chunks of CPU_CHUNK_CELLS draws, with a look at `cancel` between them.
        let mut done = 0u64;
        while (done as usize) < count {
            check(cancel)?;
            let n = CPU_CHUNK_CELLS.min(count as u64 - done);
            let start = first + done;
            out.par_extend((start..start + n).into_par_iter().map(|i| {
                let (uc, u) = crate::random::draw_numbers(seed, i, group);
                let s = r.sample(wo, uc, u);
                DrawRecord {
                    wi: s.wi.to_array(),
                    pdf: s.pdf,
                    weight: s.weight.to_array(),
                    delta: s.delta,
                    pdf_at: r.pdf(s.wi, wo),
                    eval_cos: (r.eval(s.wi, wo) * s.wi.z.max(0.0)).to_array(),
                }
            }));
            done += n;
        }
        Ok(out)
    }

    fn pairs(&self, query: Query, pairs: &[(DVec3, DVec3)]) -> Result<Vec<Vec<[f64; 3]>>> {
        Ok(self
            .references(&query)?
            .iter()
            .map(|r| {
                pairs
                    .par_iter()
                    .map(|(wi, wo)| r.eval(*wi, *wo).to_array())
                    .collect()
            })
            .collect())
    }

    fn table(
        &self,
        query: Query,
        wi: &[DVec3],
        wo: &[DVec3],
        _fast_pow: bool,
        cancel: Option<&CancelToken>,
        sink: &mut TableSink<'_>,
    ) -> Result<()> {
        let refs = self.references(&Query {
            sets: &query.sets[..1],
            ..query
        })?;
        let r = &refs[0];
        let cells = wi.len() as u64 * wo.len() as u64;
        let n_wo = wo.len() as u64;
        let mut first = 0u64;
        let mut buf = Vec::new();
        while first < cells {
            check(cancel)?;
            let count = CPU_CHUNK_CELLS.min(cells - first);
            buf.resize(count as usize * 3, 0.0f32);
            buf.par_chunks_mut(3).enumerate().for_each(|(k, out)| {
                let cell = first + k as u64;
                let f = r.eval(wi[(cell / n_wo) as usize], wo[(cell % n_wo) as usize]);
                out.copy_from_slice(&[f.x as f32, f.y as f32, f.z as f32]);
            });
            sink(first, &buf)?;
            first += count;
        }
        Ok(())
    }

    fn rule_sums(
        &self,
        query: Query,
        rules: &[&dyn NodeRule],
        wo: &[DVec3],
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<RowSums>> {
        let Some(model) = query.model() else {
            return Ok(vec![Vec::new(); rules.len()]);
        };
        let refs = self.references(&query)?;
        rules
            .iter()
            .map(|&rule| sum_rule_rows(model.name(), &refs, rule, wo, cancel))
            .collect()
    }

    fn light(
        &self,
        query: Query,
        texels: &WeightedTexels,
        pixels: &[SpherePixel],
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<[f64; 3]>> {
        let Some(r) = self.first_reference(&query)? else {
            return Ok(Vec::new());
        };
        // Ctrl-C: one pixel's sum at most runs on past the token.
        pixels
            .par_iter()
            .map(|p| {
                check(cancel)?;
                Ok(texels.light_pixel(p, |wi, wo| r.eval(wi, wo)).to_array())
            })
            .collect()
    }

    fn preview(&self, query: Query, scene: &Scene) -> Result<Vec<[f32; 3]>> {
        Ok(render_cells_cpu(&self.references(&query)?, scene))
    }
}

/// One rule's f64 sums for every reference of `refs` at each ωo: row-major results. The view
/// directions run in parallel, each making its nodes (unless the rule shares one list) and
/// summing them for every row: one list per running thread, made once for all rows. NaN, ±Inf
/// and negative values are refused (docs/design.md §2.1), naming the first such pair.
fn sum_rule_rows(
    model: &str,
    refs: &[Reference],
    rule: &dyn NodeRule,
    wo: &[DVec3],
    cancel: Option<&CancelToken>,
) -> Result<RowSums> {
    let shared = rule.shared();
    let per_wo: Vec<Vec<(DVec3, u64)>> = wo
        .par_iter()
        .map(|&o| {
            // Ctrl-C: one view direction's sums at most run on.
            check(cancel)?;
            let own;
            let nodes = match &shared {
                Some(n) => n,
                None => {
                    own = rule.list(o);
                    &own
                }
            };
            refs.iter()
                .map(|r| {
                    let bad = AtomicBool::new(false);
                    let sum = weighted_sum(nodes, |n| {
                        let f = r.eval(n.wi, o);
                        if !finite::is_valid_rgb(f) {
                            bad.store(true, Ordering::Relaxed);
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
