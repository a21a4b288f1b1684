//! The integration section: each fixed albedo rule of [`crate::integrate`] × a ladder of node
//! counts on each backend, timed from scratch per directional albedo and judged against the
//! adaptive reference (see the notes of [`crate::tradeoff`]).

use super::setup::{albedo_errors, backend_tag, AlbedoSetup};
use super::{mark_pareto, Row, Section};
use crate::backend::Query;
use crate::bench::median;
use crate::eval::Evaluator;
use crate::integrate::{
    sampled_albedo, sum_rule, view_direction, Method, Rule, DEFAULT_SEED, MAX_SAMPLES,
};
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;
use std::time::Instant;

/// One integration variant: a method and the rule it gives for a node count.
#[derive(Clone, Debug)]
pub struct IntegrationVariant {
    /// The albedo rule.
    pub method: Method,
    /// The node count asked for.
    pub asked: usize,
    /// The rule that node count gives: its nodes and weights.
    pub rule: Rule,
}

/// Every fixed rule × the ladder, rules that come out equal listed once.
pub fn integration_variants(params: &ParamSet, ladder: &[usize]) -> Vec<IntegrationVariant> {
    let mut out: Vec<IntegrationVariant> = Vec::new();
    for method in Method::ALL {
        for &n in ladder {
            let Some(rule) = method.rule(n, params) else {
                continue;
            };
            if !out.iter().any(|v| v.rule == rule) {
                out.push(IntegrationVariant {
                    method,
                    asked: n,
                    rule,
                });
            }
        }
    }
    out
}

/// E(ωo) (delta excluded) by `rule` on `backend`, from scratch: the nodes, then Σ w f (f64 sums
/// of f64 values on the CPU; the reduction kernel on the GPU). Returns E and the node count.
pub fn rule_albedo_once(
    backend: &Evaluator,
    params: &ParamSet,
    rule: &Rule,
    wo: DVec3,
) -> Result<(DVec3, usize)> {
    let (value, n) = sum_rule(backend, params, *rule, &[wo])?
        .pop()
        .expect("one sum per direction");
    Ok((value, n as usize))
}

/// Measures every integration variant on each backend (GPU first; the two never overlap: on
/// lavapipe they would share the same cores). `truth` holds the reference E at `setup.mus`.
pub fn measure_integration(
    backends: &[Evaluator],
    params: &ParamSet,
    setup: &AlbedoSetup,
    truth: &[DVec3],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    let wo: Vec<DVec3> = setup
        .mus
        .iter()
        .map(|&mu| view_direction(mu, 0.0))
        .collect();
    let variants = integration_variants(params, &setup.samples);
    let mut rows = Vec::new();
    for backend in backends {
        for v in &variants {
            backend.check_cancelled()?;
            let label = format!("{} {}", v.method.name(), backend_tag(backend));
            progress(&label);
            // The untimed run: builds the pipeline, and its values are the ones judged.
            let mut values = Vec::with_capacity(wo.len());
            let mut nodes = 0usize;
            for &o in &wo {
                let (e, n) = rule_albedo_once(backend, params, &v.rule, o)?;
                values.push(e);
                nodes += n;
            }
            let (max_error, rms_error) = albedo_errors(&values, truth);
            let (mut walls, mut kernels) = (Vec::new(), Vec::new());
            for _ in 0..setup.repeats {
                backend.take_device_time();
                let t = Instant::now();
                for &o in &wo {
                    std::hint::black_box(rule_albedo_once(backend, params, &v.rule, o)?);
                }
                walls.push(t.elapsed().as_secs_f64() * 1e3 / wo.len() as f64);
                if let Some(k) = backend.take_device_time() {
                    kernels.push(k.as_secs_f64() * 1e3 / wo.len() as f64);
                }
            }
            let mean_nodes = (nodes as f64 / wo.len() as f64).round() as u64;
            rows.push(Row {
                section: Section::Integration,
                variant: format!(
                    "{} {} nodes, {}",
                    v.method.name(),
                    mean_nodes,
                    backend_tag(backend)
                ),
                backend: backend.name(),
                samples: Some(mean_nodes),
                cost: median(walls),
                cost_unit: Section::Integration.cost_unit().into(),
                kernel_cost: (!kernels.is_empty()).then(|| median(kernels)),
                max_error,
                rms_error,
                error_kind: Section::Integration.error_kind().into(),
                pareto: false,
                variance_per_sample: None,
            });
        }
        rows.extend(measure_monte_carlo(
            backend, params, setup, truth, &wo, progress,
        )?);
    }
    mark_pareto(&mut rows);
    Ok(rows)
}

/// The Monte Carlo methods (uniform, cosine and the model's own sampler, [`sampled_albedo`])
/// at each count of the ladder (at most [`MAX_SAMPLES`] draws) on `backend`, timed as the
/// rules are, each row with the largest variance per draw over the view directions.
fn measure_monte_carlo(
    backend: &Evaluator,
    params: &ParamSet,
    setup: &AlbedoSetup,
    truth: &[DVec3],
    wo: &[DVec3],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    let query = Query::one(params);
    let mut counts: Vec<usize> = setup.samples.iter().map(|&n| n.min(MAX_SAMPLES)).collect();
    counts.dedup();
    let mut rows = Vec::new();
    for method in Method::ALL {
        let Some(sampler) = method.sampler() else {
            continue;
        };
        for &n in &counts {
            backend.check_cancelled()?;
            let label = format!("{} {}", method.name(), backend_tag(backend));
            progress(&label);
            // The untimed run: its values are the ones judged.
            let mut values = Vec::with_capacity(wo.len());
            let mut variance = 0.0f64;
            for &o in wo {
                let a = sampled_albedo(backend, query, sampler, n, DEFAULT_SEED, o)?;
                values.push(a.estimate.value);
                variance = variance.max(a.variance.max_element());
            }
            let (max_error, rms_error) = albedo_errors(&values, truth);
            let mut walls = Vec::new();
            for _ in 0..setup.repeats {
                let t = Instant::now();
                for &o in wo {
                    std::hint::black_box(sampled_albedo(
                        backend,
                        query,
                        sampler,
                        n,
                        DEFAULT_SEED,
                        o,
                    )?);
                }
                walls.push(t.elapsed().as_secs_f64() * 1e3 / wo.len() as f64);
            }
            rows.push(Row {
                section: Section::Integration,
                variant: format!("{} {} draws, {}", method.name(), n, backend_tag(backend)),
                backend: backend.name(),
                samples: Some(n as u64),
                cost: median(walls),
                cost_unit: Section::Integration.cost_unit().into(),
                kernel_cost: None,
                max_error,
                rms_error,
                error_kind: Section::Integration.error_kind().into(),
                pareto: false,
                variance_per_sample: Some(variance),
            });
        }
    }
    Ok(rows)
}
