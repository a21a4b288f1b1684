//! Albedo by plain Monte Carlo: N independent draws ωi from a sampler, E(ωo) ≈ the mean of
//! their weights f cos θi / p, with an error bound from their standard error.
//!
//! Three samplers: the uniform hemisphere (p = 1/2π), the cosine density (p = cos θi / π,
//! Malley's method) and the model's own sampler (`Backend::draws`: the GPU kernel's draws on
//! the GPU, `Reference::sample` on the CPU), whose delta draws carry the spike's weight and whose
//! lost draws weigh 0. Draw i takes its numbers from
//! [`crate::random::draw_numbers`]`(seed, i, 0)`, so a result depends on (seed, ωo, N) alone.

use super::gauss::Estimate;
use super::GPU_ROUNDING_FACTOR;
use crate::backend::{DrawRange, Precision, Query};
use crate::eval::Evaluator;
use crate::model::Reference;
use anyhow::{bail, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};

/// Where the draws of a Monte Carlo albedo come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampler {
    /// Uniform over the hemisphere: weight 2π f cos θi.
    Uniform,
    /// The cosine density: weight π f.
    Cosine,
    /// The model's own sampler: weight f cos θi / pdf as the sampler returns it.
    Brdf,
}

/// The seed the `uniform`, `cosine` and `sampled` methods draw with when a job names none.
pub const DEFAULT_SEED: u32 = 0;

/// Standard errors a Monte Carlo albedo reports as its error. The N draws are independent, so
/// the mean's error is close to normal with the standard error s/√N (s from all N draws, so
/// known to about 1/√(2N) relative); beyond 4 standard errors a normal error lies with
/// probability 6e-5. The margin over the importance rule's 3.5 covers the skew of the mean of
/// heavy-tailed weights (uniform or cosine draws on a narrow lobe), whose error is less normal
/// at a given N. A lobe the draws never hit leaves no trace in s: no statistical bound can see
/// it, so N must be large enough for the lobe's solid angle.
pub const SAMPLED_T: f64 = 4.0;

/// A Monte Carlo estimate of E(ωo) with what the draws say of their spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledAlbedo {
    /// E(ωo) with the delta lobe's exact part taken out (as every rule's estimate), its error
    /// ([`SAMPLED_T`] standard errors, plus f32 rounding on the GPU) and the draws.
    pub estimate: Estimate,
    /// The variance of one draw's weight per channel (unbiased, over the N draws): the mean's
    /// variance times N, what a sampler is judged by.
    pub variance: DVec3,
}

/// Each draw's weight f cos θi / p (the total albedo's estimator: a delta draw carries the
/// spike's weight).
fn weights(
    backend: &Evaluator,
    query: Query,
    sampler: Sampler,
    n: usize,
    seed: u32,
    wo: DVec3,
) -> Result<Vec<DVec3>> {
    let model = query.params().model().name();
    let w: Vec<DVec3> = match sampler {
        Sampler::Brdf => backend
            .draws(query, wo, DrawRange::new(seed, n))?
            .iter()
            .map(|d| {
                if d.delta || d.pdf > 0.0 {
                    DVec3::from_array(d.weight)
                } else {
                    DVec3::ZERO
                }
            })
            .collect(),
        Sampler::Uniform | Sampler::Cosine => {
            let pairs: Vec<(DVec3, DVec3)> = (0..n as u64)
                .into_par_iter()
                .map(|i| {
                    let (_, u) = crate::random::draw_numbers(seed, i, 0);
                    let (sin_b, cos_b) = (TAU * u.y).sin_cos();
                    let z = if sampler == Sampler::Uniform {
                        u.x
                    } else {
                        (1.0 - u.x).sqrt()
                    };
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    (DVec3::new(r * cos_b, r * sin_b, z), wo)
                })
                .collect();
            let f = backend.eval_pairs(query, &pairs)?;
            pairs
                .iter()
                .zip(f)
                .map(|((wi, _), f)| {
                    let scale = if sampler == Sampler::Uniform {
                        TAU * wi.z
                    } else {
                        PI
                    };
                    DVec3::from_array(f) * scale
                })
                .collect()
        }
    };
    let bad = w.iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        bail!(
            "{model}: {bad} of {n} draws at ωo = ({}, {}, {}) have a NaN or infinite weight; no \
             albedo is made from them",
            wo.x,
            wo.y,
            wo.z
        );
    }
    Ok(w)
}

/// E(ωo) of the query's first set from `n` draws of `sampler` in the stream `seed` on
/// `backend`, the delta lobe's exact part taken out (the caller adds it back, as for the
/// rules), with its error bound and the variance per draw.
pub fn sampled_albedo(
    backend: &Evaluator,
    query: Query,
    sampler: Sampler,
    n: usize,
    seed: u32,
    wo: DVec3,
) -> Result<SampledAlbedo> {
    backend.check_cancelled()?;
    let n = n.max(2);
    let w = weights(backend, query, sampler, n, seed, wo)?;
    let count = w.len() as f64;
    let mean = w.iter().copied().sum::<DVec3>() / count;
    let variance = w.iter().map(|&v| (v - mean) * (v - mean)).sum::<DVec3>() / (count - 1.0);
    let delta = if sampler == Sampler::Brdf {
        Reference::new(query.params(), query.white_furnace).delta_albedo(wo.z)
    } else {
        DVec3::ZERO
    };
    // The f64 sum of N terms: at most N ε |E| (the whole error where every weight is the same,
    // as for Lambert's cosine draws); on the GPU also the rules' f32 rounding bound. Both are far
    // below the statistical error wherever the weights vary.
    let mut rounding = mean.abs() * (count * f64::EPSILON);
    if backend.precision() == Precision::F32 {
        rounding +=
            mean.abs() * (GPU_ROUNDING_FACTOR * f32::EPSILON as f64 / wo.z.max(f64::MIN_POSITIVE));
    }
    Ok(SampledAlbedo {
        estimate: Estimate {
            value: mean - delta,
            error: SAMPLED_T * (variance / count).powf(0.5) + rounding,
            evals: n as u64,
        },
        variance,
    })
}
