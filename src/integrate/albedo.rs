//! The albedo jobs: directional E(ωo) at given view directions and the hemispherical Ē with
//! Kulla–Conty's E_avg, on a rule's table of directions or by the adaptive reference.

use super::backend::{rule_albedo, rule_albedo_rows};
use super::gauss::{adaptive_until, gk15, gk15_combine, gk15_nodes, graded, Estimate};
use super::reference::{reference_albedo_within, Budget, REFERENCE_RTOL};
use super::sampled::sampled_albedo;
use super::{view_direction, Settings, MAX_SAMPLES};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::model::{ParamSet, Reference};
use anyhow::{bail, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::TAU;
use std::sync::atomic::{AtomicBool, Ordering};

/// E at one view direction, with the delta lobe reported apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointAlbedo {
    /// μ = cosθo of the view direction, in (0, 1].
    pub mu: f64,
    /// φo of the view direction, radians.
    pub phi: f64,
    /// The total albedo, delta lobe included.
    pub albedo: DVec3,
    /// The delta lobe's part, exact: F_s(μ) for the layered models (`smooth_layered`,
    /// `coupled`), 0 for the others.
    pub delta: DVec3,
    /// Estimated absolute error of `albedo`, per channel (see the module's notes on estimates).
    pub error: DVec3,
    /// Integrand evaluations (nodes) spent on this direction, the coarse check included.
    pub samples: u64,
    /// The adaptive reference stopped refining before it met its tolerance (its budget spent,
    /// or its panels too many or too narrow): `albedo` is as far as it got, within `error`.
    /// Always false for the fixed rules, which have no tolerance to meet.
    pub stopped_short: bool,
    /// The Monte Carlo methods' variance of one draw's weight per channel
    /// ([`SampledAlbedo::variance`](super::SampledAlbedo)); None for the rules.
    pub variance_per_sample: Option<DVec3>,
}

/// Refuses a Monte Carlo job of more than [`MAX_SAMPLES`] draws per view direction (option
/// `"samples"`): the draws are held in memory, about 100 bytes each.
fn check_draws(n: usize) -> Result<()> {
    if n > MAX_SAMPLES {
        bail!(BadInput::new(
            "samples",
            format!("{n} draws per view direction: expected from 16 to {MAX_SAMPLES} (2^20)"),
        ));
    }
    Ok(())
}

/// E(ωo) at each (μ, φ) on `backend` (the reference runs on the CPU whatever the backend).
pub fn directional(
    backend: &Evaluator,
    params: &ParamSet,
    s: &Settings,
    points: &[(f64, f64)],
) -> Result<Vec<PointAlbedo>> {
    for &(mu, _) in points {
        if !(mu > 0.0 && mu <= 1.0) {
            bail!(
                "mu = {mu} is out of range; directional albedo needs mu = cos(theta_o) in (0, 1]"
            );
        }
    }
    let wo = directions(points);
    let r = Reference::new(params, s.white_furnace);
    if let Some(sampler) = s.method.sampler() {
        check_draws(s.samples)?;
        let mut est = Vec::with_capacity(wo.len());
        let mut var = Vec::with_capacity(wo.len());
        for &o in &wo {
            let a = sampled_albedo(backend, s.query(params), sampler, s.samples, s.seed, o)?;
            est.push((a.estimate, false));
            var.push(a.variance);
        }
        let mut out = point_albedos(&r, points, est);
        for (p, v) in out.iter_mut().zip(var) {
            p.variance_per_sample = Some(v);
        }
        return Ok(out);
    }
    let est: Vec<(Estimate, bool)> = match s.method.rule(s.samples, params) {
        Some(rule) => rule_albedo(backend, s.query(params), rule, &wo)?
            .into_iter()
            .map(|e| (e, false))
            .collect(),
        // The reference is the adaptive f64 integrator: it runs on the CPU whatever the backend.
        None => {
            params
                .model()
                .require_reference("the reference integrator")?;
            // One budget for the job: once spent, every direction left keeps its first panels.
            let budget = Budget::new(s.reference_evals(), backend.cancel_token());
            wo.par_iter()
                .map(|&o| {
                    backend.check_cancelled()?;
                    let (e, converged) = reference_albedo_within(&r, o, REFERENCE_RTOL, &budget);
                    // Stopped by Ctrl-C: no value to report, not a less accurate one.
                    backend.check_cancelled()?;
                    Ok((e, !converged))
                })
                .collect::<Result<_>>()?
        }
    };
    Ok(point_albedos(&r, points, est))
}

fn directions(points: &[(f64, f64)]) -> Vec<DVec3> {
    points
        .iter()
        .map(|&(mu, phi)| view_direction(mu, phi))
        .collect()
}

/// Each point's estimate with its delta lobe added.
fn point_albedos(
    r: &Reference,
    points: &[(f64, f64)],
    est: Vec<(Estimate, bool)>,
) -> Vec<PointAlbedo> {
    points
        .iter()
        .zip(est)
        .map(|(&(mu, phi), (e, stopped_short))| {
            let delta = r.delta_albedo(mu);
            PointAlbedo {
                mu,
                phi,
                albedo: e.value + delta,
                delta,
                error: e.error,
                samples: e.evals,
                stopped_short,
                variance_per_sample: None,
            }
        })
        .collect()
}

/// Hemispherical albedo and Kulla–Conty's E_avg.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HemiAlbedo {
    /// Ē = (1/π) ∫ E(ωo) c_o dωo, delta lobe included.
    pub albedo: DVec3,
    /// The delta lobe's part of Ē.
    pub delta: DVec3,
    /// Estimated absolute error of `albedo`, per channel.
    pub error: DVec3,
    /// E_avg = 2 ∫₀¹ E(μ, φo) μ dμ at the φo asked for (= Ē for an isotropic model).
    pub e_avg: DVec3,
    /// Estimated absolute error of `e_avg`, per channel.
    pub e_avg_error: DVec3,
    /// View directions integrated.
    pub directions: usize,
    /// Integrand evaluations in all.
    pub samples: u64,
    /// The adaptive reference stopped refining before it met its tolerance somewhere (see
    /// [`PointAlbedo::stopped_short`]); false for the fixed rules.
    pub stopped_short: bool,
}

/// Levels of grading towards μ = 0 of the outer μ integral's panels: E(μ) changes fastest at
/// grazing view, where a lobe meets the horizon.
const MU_LEVELS: u32 = 5;

/// Levels of grading towards μ = 1: E(μ) of Oren–Nayar carries sinθo = √(1 − μ²), whose
/// derivative is infinite at the pole.
const MU_POLE_LEVELS: u32 = 3;

/// The outer μ rule's panels: [0, 2^-5, …, ½] graded towards 0, [½, …, 1 − 2^-4, 1] towards 1.
fn mu_breaks() -> Vec<f64> {
    let mut b: Vec<f64> = graded(MU_LEVELS).iter().map(|t| 0.5 * t).collect();
    b.extend(graded(MU_POLE_LEVELS).iter().map(|t| 1.0 - 0.5 * t));
    b.sort_by(f64::total_cmp);
    b.dedup();
    b
}

/// View azimuths of the outer φo trapezoid for an anisotropic model (the coarse check uses every
/// other one).
const PHI_O_NODES: usize = 16;

/// The μ nodes of the fixed outer rule, in the order gk15 visits them.
fn outer_mus(breaks: &[f64]) -> Vec<f64> {
    breaks
        .windows(2)
        .flat_map(|w| gk15_nodes(w[0], w[1]))
        .collect()
}

/// The view azimuths of the outer rule: `phi` alone for an isotropic model.
fn outer_phis(params: &ParamSet, phi: f64) -> Vec<f64> {
    let mut v = vec![phi];
    if !params.is_isotropic() {
        v.extend((1..PHI_O_NODES).map(|l| phi + TAU * l as f64 / PHI_O_NODES as f64));
    }
    v
}

/// The view directions at which [`hemispherical`] evaluates E with a fixed rule, azimuth by
/// azimuth, μ by μ.
pub fn hemispherical_directions(params: &ParamSet, phi: f64) -> Vec<DVec3> {
    let mus = outer_mus(&mu_breaks());
    outer_phis(params, phi)
        .iter()
        .flat_map(|&p| mus.iter().map(move |&mu| view_direction(mu, p)))
        .collect()
}

/// Ē and E_avg by Gauss–Kronrod 7/15 on the μ panels of `mu_breaks` (for `reference`: adaptive
/// from those panels), the integrand 2μE(μ); anisotropic models add a trapezoid over φo
/// (spectral for the smooth periodic E(μ, ·)), checked against its every-other-node half.
/// Errors: the μ rule's |K − G| plus the directional errors carried through its weights, plus
/// the φo check.
pub fn hemispherical(
    backend: &Evaluator,
    params: &ParamSet,
    s: &Settings,
    phi: f64,
) -> Result<HemiAlbedo> {
    if let Some(sampler) = s.method.sampler() {
        check_draws(s.samples)?;
        let table = hemispherical_directions(params, phi)
            .into_iter()
            .map(|o| {
                Ok(
                    sampled_albedo(backend, s.query(params), sampler, s.samples, s.seed, o)?
                        .estimate,
                )
            })
            .collect::<Result<Vec<_>>>()?;
        return hemispherical_from(backend, params, s, phi, table);
    }
    let table: Vec<Estimate> = match s.method.rule(s.samples, params) {
        Some(rule) => {
            let wo = hemispherical_directions(params, phi);
            rule_albedo(backend, s.query(params), rule, &wo)?
        }
        None => {
            params
                .model()
                .require_reference("the reference integrator")?;
            Vec::new()
        }
    };
    hemispherical_from(backend, params, s, phi, table)
}

/// [`directional`] at `points` and, when `phi` is given, [`hemispherical`] at it for every
/// parameter set of `rows` (one model: the rows of a LUT), the same values row by row. With a fixed rule every
/// row's directions go to [`rule_albedo_rows`] at once: each direction's nodes are made once
/// for all rows, and the GPU sums all rows in the same dispatches.
pub fn albedo_rows(
    backend: &Evaluator,
    rows: &[ParamSet],
    s: &Settings,
    points: &[(f64, f64)],
    phi: Option<f64>,
) -> Result<Vec<(Vec<PointAlbedo>, Option<HemiAlbedo>)>> {
    let rules: Vec<_> = rows.iter().map(|p| s.method.rule(s.samples, p)).collect();
    let same = rows
        .windows(2)
        .all(|w| w[0].model() == w[1].model() && w[0].is_isotropic() == w[1].is_isotropic())
        && rules.windows(2).all(|w| w[0] == w[1]);
    let (Some(Some(rule)), true) = (rules.first(), same) else {
        return rows
            .iter()
            .map(|p| {
                backend.check_cancelled()?;
                Ok((
                    directional(backend, p, s, points)?,
                    phi.map(|phi| hemispherical(backend, p, s, phi))
                        .transpose()?,
                ))
            })
            .collect();
    };
    for &(mu, _) in points {
        if !(mu > 0.0 && mu <= 1.0) {
            bail!(
                "mu = {mu} is out of range; directional albedo needs mu = cos(theta_o) in (0, 1]"
            );
        }
    }
    let mut wo = directions(points);
    if let Some(phi) = phi {
        wo.extend(hemispherical_directions(&rows[0], phi));
    }
    let est = rule_albedo_rows(backend, s.query_sets(rows), *rule, &wo)?;
    rows.iter()
        .zip(est)
        .map(|(p, mut e)| {
            let hemi = e.split_off(points.len());
            let r = Reference::new(p, s.white_furnace);
            Ok((
                point_albedos(&r, points, e.into_iter().map(|e| (e, false)).collect()),
                phi.map(|phi| hemispherical_from(backend, p, s, phi, hemi))
                    .transpose()?,
            ))
        })
        .collect()
}

/// [`hemispherical`] from E at [`hemispherical_directions`] (`table`, empty for the adaptive
/// reference, which then integrates here).
fn hemispherical_from(
    backend: &Evaluator,
    params: &ParamSet,
    s: &Settings,
    phi: f64,
    table: Vec<Estimate>,
) -> Result<HemiAlbedo> {
    let r = Reference::new(params, s.white_furnace);
    let breaks = mu_breaks();
    let mus = outer_mus(&breaks);
    let phis = outer_phis(params, phi);
    // The reference's budget, for every view direction of the outer integrals together.
    let budget = Budget::new(s.reference_evals(), backend.cancel_token());
    // Whether an integral of the reference stopped before meeting its tolerance.
    let short = AtomicBool::new(false);
    // 2∫ E(μ, φo) μ dμ at azimuth index k.
    let e_avg_at = |k: usize| -> Estimate {
        let p = phis[k];
        if table.is_empty() {
            let g = |mu: f64| {
                // Cancelled: the value is thrown away (see `reference_albedo_within`).
                if budget.cancelled() {
                    return Estimate::default();
                }
                let (e, _) =
                    reference_albedo_within(&r, view_direction(mu, p), REFERENCE_RTOL, &budget);
                Estimate {
                    value: 2.0 * mu * (e.value + r.delta_albedo(mu)),
                    error: 2.0 * mu * e.error,
                    evals: e.evals,
                }
            };
            // The outer tolerance relative to the Lambert-like scale of the directional ones.
            let first = gk15(&g, 0.0, 1.0);
            let tol = (REFERENCE_RTOL * first.value.abs().max_element()).max(f64::MIN_POSITIVE);
            // The directional integrals' shortfalls are carried in their errors, which the
            // outer tolerance counts: the outer integral's answer is the job's.
            let (e, converged) = adaptive_until(&g, &breaks, 10.0 * tol, true, &|| budget.stop());
            if !converged {
                short.store(true, Ordering::Relaxed);
            }
            e
        } else {
            let row = &table[k * mus.len()..(k + 1) * mus.len()];
            let mut total = Estimate::default();
            for (w, part) in breaks.windows(2).zip(row.chunks(15)) {
                let mu = gk15_nodes(w[0], w[1]);
                let vals: Vec<Estimate> = part
                    .iter()
                    .zip(mu)
                    .map(|(e, mu)| Estimate {
                        value: 2.0 * mu * (e.value + r.delta_albedo(mu)),
                        error: 2.0 * mu * e.error,
                        evals: e.evals,
                    })
                    .collect();
                let panel = gk15_combine(w[0], w[1], &vals);
                total.value += panel.value;
                total.error += panel.error;
                total.evals += panel.evals;
            }
            total
        }
    };
    let delta_avg = {
        let g = |mu: f64| Estimate {
            value: 2.0 * mu * r.delta_albedo(mu),
            error: DVec3::ZERO,
            evals: 0,
        };
        breaks
            .windows(2)
            .map(|w| gk15(&g, w[0], w[1]).value)
            .sum::<DVec3>()
    };
    let e_avg = e_avg_at(0);
    // Stopped by Ctrl-C: no value to report, not a less accurate one.
    backend.check_cancelled()?;
    if phis.len() == 1 {
        return Ok(HemiAlbedo {
            albedo: e_avg.value,
            delta: delta_avg,
            error: e_avg.error,
            e_avg: e_avg.value,
            e_avg_error: e_avg.error,
            directions: if table.is_empty() { 0 } else { mus.len() },
            samples: e_avg.evals,
            stopped_short: short.load(Ordering::Relaxed),
        });
    }
    backend.check_cancelled()?;
    let rows: Vec<Estimate> = if table.is_empty() {
        (0..phis.len()).into_par_iter().map(e_avg_at).collect()
    } else {
        (0..phis.len()).map(e_avg_at).collect()
    };
    backend.check_cancelled()?;
    let n = rows.len() as f64;
    let fine: DVec3 = rows.iter().map(|e| e.value).sum::<DVec3>() / n;
    let coarse: DVec3 = rows.iter().step_by(2).map(|e| e.value).sum::<DVec3>() / (n / 2.0);
    let carried: DVec3 = rows.iter().map(|e| e.error).sum::<DVec3>() / n;
    Ok(HemiAlbedo {
        albedo: fine,
        delta: delta_avg,
        error: carried + (fine - coarse).abs(),
        e_avg: e_avg.value,
        e_avg_error: e_avg.error,
        directions: phis.len() * mus.len(),
        samples: rows.iter().map(|e| e.evals).sum(),
        stopped_short: short.load(Ordering::Relaxed),
    })
}
