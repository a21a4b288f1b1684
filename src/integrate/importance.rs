//! The `importance` rule: a mixture of the cosine density and power-cosine lobes about the
//! mirror direction, sampled by low-discrepancy points in independently shifted replicates.

use super::cache::RecentCache;
use super::peak::PeakFrame;
use super::{Node, PLASTIC};
use crate::model::sampling::SamplingLobes;
use crate::model::ParamSet;
use glam::DVec3;
use std::f64::consts::{PI, TAU};
use std::sync::Arc;

/// Power-cosine lobes a [`Mixture`] holds besides the cosine density.
pub const MAX_LOBES: usize = 4;

/// The density the `importance` rule draws ωi from, for one model and its parameters:
///   p(ωi) = c₀ c_i/π + Σ_k c_k (n_k + 1)/(2π) max(0, r·ωi)^{n_k},   Σ c = 1,
/// where r is the mirror direction of ωo (each lobe lives on the hemisphere about r; directions
/// below the surface carry no weight, and the cosine term keeps p > 0 wherever f c_i may be).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mixture {
    /// c₀: the fraction of points drawn from c_i/π (Malley's method).
    pub cosine: f64,
    /// (n_k, c_k): power-cosine lobes about r; unused slots have c_k = 0.
    pub lobes: [(f64, f64); MAX_LOBES],
}

/// Bounds of the cosine fraction c₀: at least 10 % of the points cover the whole hemisphere
/// (the lobes' horizon-cut tails and a diffuse term too small to matter still get points), and
/// at least 10 % go to the lobes however dull they are.
const COSINE_FRACTION: (f64, f64) = (0.1, 0.9);

/// How much broader the second lobe of each width is, in exponent: n/8 is √8 ≈ 2.8 times as
/// wide. It covers what a single Phong-like lobe about r misses: the off-specular shift and
/// horizon stretch of half-vector lobes at grazing view, and GGX's long tails.
const BROAD_LOBE_DIVISOR: f64 = 8.0;

impl Mixture {
    /// c_i/π alone: the right density for the diffuse models (and qmc's).
    pub fn cosine_only() -> Mixture {
        Mixture {
            cosine: 1.0,
            lobes: [(0.0, 0.0); MAX_LOBES],
        }
    }

    /// The mixture tuned from the model's parameters: the model describes its peaked lobes as
    /// power cosines about r ([`ParamSet::sampling_lobes`]), and each width gets two lobes, n
    /// (2/3 of its share) and n/8 (1/3; see `BROAD_LOBE_DIVISOR`). The cosine's share is
    /// diffuse/(diffuse + specular) of the largest channels, clamped to `COSINE_FRACTION`.
    /// Models without a peaked lobe draw from c_i/π alone.
    pub fn for_model(params: &ParamSet) -> Mixture {
        let Some(SamplingLobes {
            diffuse,
            specular,
            exponents: widths,
        }) = params.sampling_lobes()
        else {
            return Mixture::cosine_only();
        };
        let (d, s) = (diffuse.max_element(), specular.max_element());
        let cosine =
            if d + s > 0.0 { d / (d + s) } else { 0.5 }.clamp(COSINE_FRACTION.0, COSINE_FRACTION.1);
        let share = if widths[0] == widths[1] { 1.0 } else { 0.5 };
        let mut lobes = [(0.0, 0.0); MAX_LOBES];
        for (k, &n) in widths
            .iter()
            .enumerate()
            .take(if share == 1.0 { 1 } else { 2 })
        {
            let c = (1.0 - cosine) * share;
            lobes[2 * k] = (n, c * 2.0 / 3.0);
            lobes[2 * k + 1] = (n / BROAD_LOBE_DIVISOR, c / 3.0);
        }
        Mixture { cosine, lobes }
    }

    /// A mixture with the cosine's share `cosine` and the lobes (exponent, share) `lobes`, the
    /// rest unused: for tests that need a peaked density without a model.
    #[cfg(test)]
    pub(super) fn with_lobes(cosine: f64, lobes: &[(f64, f64)]) -> Mixture {
        let mut mix = Mixture::cosine_only();
        mix.cosine = cosine;
        mix.lobes[..lobes.len()].copy_from_slice(lobes);
        mix
    }

    /// Points per component for `n` in all: round(c n), the cosine's at least 1 so that the
    /// density stays positive over the hemisphere.
    fn counts(&self, n: usize) -> [usize; MAX_LOBES + 1] {
        let mut out = [0; MAX_LOBES + 1];
        out[0] = ((self.cosine * n as f64).round() as usize).max(1);
        for (k, &(_, c)) in self.lobes.iter().enumerate() {
            out[k + 1] = (c * n as f64).round() as usize;
        }
        out
    }
}

/// Independent randomly shifted replicates of the `importance` rule's points. The estimate is
/// their mean, its error [`REPLICATE_T`] standard errors of that mean.
pub const REPLICATES: u32 = 8;

/// Standard errors the `importance` rule reports as its error: Student's t with
/// REPLICATES − 1 = 7 degrees of freedom exceeds 3.5 with probability 1.3 % (two-sided), so the
/// true error of the mean exceeds the estimate about once in 80 directions.
pub const REPLICATE_T: f64 = 3.5;

/// SplitMix64 (Steele, Lea & Flood 2014), for the replicates' shifts.
struct SplitMix64(u64);

impl SplitMix64 {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How many nodes [`importance_nodes`] makes for `n` points of `mix` (at any ωo).
pub(super) fn importance_node_count(n: usize, mix: &Mixture) -> usize {
    mix.counts(n).iter().sum()
}

/// The `importance` rule: multi-sample importance sampling with the balance heuristic (Veach
/// 1997, §9.2). Component l of the [`Mixture`] gets N_l = round(c_l N) points, the R2 sequence
/// (each component at its own offset) mapped through its inverse CDF:
/// - cosine: Malley's method, as in [`qmc_nodes`](super::rules::qmc_nodes);
/// - lobe n about r: cosα = u^{1/(n+1)}, β = 2πv in the mirror frame ([`PeakFrame`]), whose
///   density is (n+1)/(2π) cos^n α.
///
/// Every point x then weighs c_i(x) / Σ_l N_l p_l(x) (the weight already holds c_i), so
/// E ≈ Σ w f is unbiased, and the error falls like a QMC rule's for a smooth f c_i/p: faster
/// than Monte Carlo's N^-1/2, slower than N^-1 because the horizon (where c_i and the lobes are
/// cut) is a discontinuity the points do not align with. Points below the surface become
/// zero-weight nodes at the pole (f there is 0; the GPU pads with the same node).
///
/// Randomised QMC (Owen 2013, "Monte Carlo theory, methods and examples", §17): each replicate
/// shifts the points by its own uniform random vector mod 1, so the replicates are independent
/// unbiased estimates and their spread gives an honest standard error, which deterministic QMC
/// points (whose N-vs-N/2 difference can be far below the actual error) do not.
pub(super) fn importance_nodes(n: usize, mix: &Mixture, replicate: u32, wo: DVec3) -> Vec<Node> {
    let frame = PeakFrame::new(wo);
    let counts = mix.counts(n);
    let cosine = counts[0] as f64 / PI;
    unit_points(n, mix, replicate)
        .iter()
        .map(|pt| {
            let (x, lobe_density) = match *pt {
                UnitPoint::Cosine(x) => (x, lobe_density(mix, &counts, x.dot(frame.r))),
                UnitPoint::Lobe {
                    cos_a,
                    sin_a,
                    cos_b,
                    sin_b,
                    lobe_density,
                } => (
                    cos_a * frame.r + sin_a * (cos_b * frame.u + sin_b * frame.v),
                    lobe_density,
                ),
            };
            let p = cosine * x.z.max(0.0) + lobe_density;
            if x.z > 0.0 && p > 0.0 {
                Node {
                    wi: x,
                    weight: x.z / p,
                }
            } else {
                Node {
                    wi: DVec3::Z,
                    weight: 0.0,
                }
            }
        })
        .collect()
}

/// The lobes' part of the mixture's density, Σ_k N_k (n_k + 1)/(2π) c^{n_k}, at c = r·x.
fn lobe_density(mix: &Mixture, counts: &[usize; MAX_LOBES + 1], c: f64) -> f64 {
    let mut p = 0.0;
    for (k, &(e, _)) in mix.lobes.iter().enumerate() {
        if counts[k + 1] > 0 && c > 0.0 {
            p += counts[k + 1] as f64 * (e + 1.0) / TAU * c.powf(e);
        }
    }
    p
}

/// One point of the importance rule before it meets a view direction.
#[derive(Clone, Copy, Debug)]
enum UnitPoint {
    /// Drawn from the cosine: the direction itself (z up), the same at every ωo.
    Cosine(DVec3),
    /// Drawn from a lobe: its angles in the mirror frame (α from r, β about it), and the lobes'
    /// part of the density there, which depends on cos α = r·x alone.
    Lobe {
        cos_a: f64,
        sin_a: f64,
        cos_b: f64,
        sin_b: f64,
        lobe_density: f64,
    },
}

/// Point sets [`unit_points`] keeps: two jobs' eight replicates, at most
/// `MAX_SAMPLES / REPLICATES` = 2^17 points of 48 bytes each (6 MiB; 96 MiB in all).
const KEPT_POINT_SETS: usize = 16;

/// The points of `replicate` for `n` points of `mix`, in [`importance_nodes`]' order, with all
/// that does not depend on ωo worked out once (the R2 sequence, its shift, the inverse CDFs'
/// sines, cosines and powers) and kept for the other view directions.
fn unit_points(n: usize, mix: &Mixture, replicate: u32) -> Arc<Vec<UnitPoint>> {
    static KEPT: RecentCache<(usize, Mixture, u32), Vec<UnitPoint>> =
        RecentCache::new(KEPT_POINT_SETS);
    KEPT.get_or_make(&(n, *mix, replicate), || {
        make_unit_points(n, mix, replicate)
    })
}

fn make_unit_points(n: usize, mix: &Mixture, replicate: u32) -> Vec<UnitPoint> {
    let counts = mix.counts(n);
    let (a1, a2) = (1.0 / PLASTIC, 1.0 / (PLASTIC * PLASTIC));
    let mut out = Vec::with_capacity(counts.iter().sum());
    for (l, &count) in counts.iter().enumerate() {
        // Cranley–Patterson rotation: the replicate's own random shift of the R2 points, one per
        // component, from a generator started from the replicate and component indices
        // (deterministic: a run reproduces exactly).
        let mut seed = SplitMix64(((replicate as u64) << 8) | l as u64);
        let (su, sv) = (seed.unit(), seed.unit());
        for k in 0..count {
            let u = (su + a1 * k as f64).fract();
            let v = (sv + a2 * k as f64).fract();
            let (sin_b, cos_b) = (TAU * v).sin_cos();
            out.push(if l == 0 {
                let r = u.sqrt();
                UnitPoint::Cosine(DVec3::new(r * cos_b, r * sin_b, (1.0 - u).sqrt()))
            } else {
                let e = mix.lobes[l - 1].0;
                // sin²α = 1 − u^{2/(n+1)} without the cancellation near α = 0.
                let ln_u = u.max(f64::MIN_POSITIVE).ln();
                let sin2 = -(2.0 * ln_u / (e + 1.0)).exp_m1();
                let (sin_a, cos_a) = (sin2.sqrt(), (1.0 - sin2).max(0.0).sqrt());
                UnitPoint::Lobe {
                    cos_a,
                    sin_a,
                    cos_b,
                    sin_b,
                    lobe_density: lobe_density(mix, &counts, cos_a),
                }
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::view_direction;

    /// A lobe point's density uses cos α from its angles, the direct one r·x of the rotated
    /// vector: a few ε apart, which c^n (n = 200 here) turns into ~200 × a few ε ≈ 2e-13.
    const DENSITY_TOLERANCE: f64 = 1e-12;

    /// The density the rule's weights divide by, evaluated directly at x from the mixture's
    /// definition (the cached points only precompute parts of it).
    fn density(mix: &Mixture, n: usize, wo: DVec3, x: DVec3) -> f64 {
        let counts = mix.counts(n);
        let r = PeakFrame::new(wo).r;
        counts[0] as f64 * x.z.max(0.0) / PI + lobe_density(mix, &counts, x.dot(r))
    }

    #[test]
    fn a_kept_point_is_48_bytes() {
        // KEPT_POINT_SETS' memory bound counts on it.
        assert_eq!(std::mem::size_of::<UnitPoint>(), 48);
    }

    #[test]
    fn weights_are_the_cosine_over_the_mixtures_density_at_every_view() {
        let mix = Mixture::with_lobes(0.4, &[(200.0, 0.4), (25.0, 0.2)]);
        let n = 3000;
        for (mu, phi) in [(1.0, 0.0), (0.6, 1.0), (0.05, 4.0)] {
            let wo = view_direction(mu, phi);
            // Twice: made, then read back from the kept point sets.
            let nodes = importance_nodes(n, &mix, 2, wo);
            assert_eq!(nodes, importance_nodes(n, &mix, 2, wo));
            assert_eq!(nodes.len(), importance_node_count(n, &mix));
            for node in nodes.iter().filter(|n| n.weight > 0.0) {
                assert!((node.wi.length() - 1.0).abs() < 1e-14, "{node:?}");
                let w = node.wi.z / density(&mix, n, wo, node.wi);
                assert!(
                    (node.weight - w).abs() <= DENSITY_TOLERANCE * w,
                    "mu {mu}: weight {} vs {w}",
                    node.weight
                );
            }
        }
    }
}
