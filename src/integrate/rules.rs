//! The fixed rules over the hemisphere of ωi: the [`Rule`] a [`Method`](super::Method) picks,
//! its coarse twin for the error estimate, and the node generators of the rules that need no
//! model knowledge (midpoint, Gauss–Legendre × trapezoid, cosine-weighted QMC).

use super::cache::RecentCache;
use super::gauss::{gauss_legendre, gauss_on};
use super::importance::{importance_node_count, importance_nodes, Mixture, REPLICATES};
use super::peak::{peak_node_count, peak_nodes, peak_nodes_each};
use super::{Node, PLASTIC};
use crate::backend::NodeRule;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

/// How many ωo-independent node lists [`Rule::shared_nodes`] keeps: a fine rule and its coarse
/// twin for two jobs at once. At the largest `--samples` (2^20 nodes, 32 bytes each) that is
/// 128 MiB at most.
pub const SHARED_RULES: usize = 4;

/// A fixed quadrature rule over the hemisphere of ωi.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    /// Cell midpoints: `n_theta` cells in θi over [0, π/2] × 4 `n_theta` in φi.
    Midpoint {
        /// Cells in θi.
        n_theta: usize,
    },
    /// Gauss–Legendre in μi = cosθi × the trapezoid rule in φi.
    Gauss {
        /// Gauss points in μi; φi takes four times as many.
        n_mu: usize,
    },
    /// Cosine-weighted low-discrepancy points, each of weight π/n.
    Qmc {
        /// Points in all.
        n: usize,
    },
    /// `n` points in all, in [`REPLICATES`] independently shifted replicates; `replicate`
    /// selects one of them (its own estimator, `n / REPLICATES` points) or, with None, all (each
    /// weighted 1/REPLICATES: their mean).
    Importance {
        /// Points in all, over every replicate.
        n: usize,
        /// The sampling density: the cosine and the model's lobes.
        mix: Mixture,
        /// One replicate (0 to `REPLICATES` − 1), or None for their mean.
        replicate: Option<u32>,
    },
    /// Composite Gauss–Legendre in polar coordinates about the mirror direction of ωo, graded
    /// towards the peak and the horizon.
    Peak {
        /// Gauss points per panel and axis.
        order: usize,
        /// Split each μ line's Δφ panels at the V-cavity masking kinks
        /// ([`v_cavity_kinks`](super::v_cavity_kinks)).
        v_cavity: bool,
        /// Grading levels towards the peak beyond the default nine, for lobes narrower than
        /// Phong n = 8192 (see `Method::rule`).
        extra_levels: u32,
    },
}

impl Rule {
    /// Whether the nodes depend on ωo (they then travel to the GPU once per direction). The
    /// importance rule's do only through its lobes about the mirror direction: drawn from the
    /// cosine alone (the diffuse models), its points and weights are the same at every ωo.
    pub fn depends_on_wo(&self) -> bool {
        match self {
            Rule::Peak { .. } => true,
            Rule::Importance { mix, .. } => mix.lobes.iter().any(|&(_, c)| c > 0.0),
            _ => false,
        }
    }

    /// The same rule one level coarser, for the error estimate (`integrate::estimate`): half the
    /// cells per axis for the midpoint rule, ⅔ of the μ nodes for `gauss`, the first half of the
    /// points for `qmc` and `importance` (whose estimate takes its replicates' spread instead), ¾
    /// of the order for `peak`; never below one.
    pub fn coarse(&self) -> Rule {
        match *self {
            Rule::Midpoint { n_theta } => Rule::Midpoint {
                n_theta: (n_theta / 2).max(1),
            },
            Rule::Gauss { n_mu } => Rule::Gauss {
                n_mu: (n_mu * 2 / 3).max(1),
            },
            Rule::Qmc { n } => Rule::Qmc { n: (n / 2).max(1) },
            Rule::Importance { n, mix, replicate } => Rule::Importance {
                n: (n / 2).max(1),
                mix,
                replicate,
            },
            Rule::Peak {
                order,
                v_cavity,
                extra_levels,
            } => Rule::Peak {
                order: (order * 3 / 4).clamp(1, order.saturating_sub(1).max(1)),
                v_cavity,
                extra_levels,
            },
        }
    }

    /// The nodes of a rule that does not depend on ωo, made once per process and shared: an
    /// albedo job sums the same Gauss–Legendre, midpoint, QMC or cosine-only importance list at
    /// every view direction, and repeated jobs (a sweep, a benchmark) ask for the same lists
    /// again. None for rules that depend on ωo. The last `SHARED_RULES` (four) lists are kept.
    pub fn shared_nodes(&self) -> Option<Arc<Vec<Node>>> {
        static KEPT: RecentCache<Rule, Vec<Node>> = RecentCache::new(SHARED_RULES);
        if self.depends_on_wo() {
            return None;
        }
        Some(KEPT.get_or_make(self, || self.nodes(DVec3::Z)))
    }

    /// The nodes for the view direction `wo` (ignored by rules that do not depend on it).
    pub fn nodes(&self, wo: DVec3) -> Vec<Node> {
        match *self {
            Rule::Midpoint { n_theta } => midpoint_nodes(n_theta, 4 * n_theta),
            Rule::Gauss { n_mu } => gauss_nodes(n_mu, 4 * n_mu),
            Rule::Qmc { n } => qmc_nodes(n),
            Rule::Importance { n, mix, replicate } => {
                let per = (n / REPLICATES as usize).max(1);
                match replicate {
                    Some(k) => importance_nodes(per, &mix, k, wo),
                    None => (0..REPLICATES)
                        .flat_map(|k| importance_nodes(per, &mix, k, wo))
                        .map(|x| Node {
                            wi: x.wi,
                            weight: x.weight / REPLICATES as f64,
                        })
                        .collect(),
                }
            }
            Rule::Peak {
                order,
                v_cavity,
                extra_levels,
            } => peak_nodes(order, v_cavity, extra_levels, wo),
        }
    }

    /// How many nodes [`Rule::nodes`] makes at `wo`, without making them (for the `peak` rule
    /// from its breakpoints, for `importance` from its mixture's counts).
    pub fn node_count(&self, wo: DVec3) -> usize {
        match *self {
            Rule::Midpoint { n_theta } => n_theta * 4 * n_theta,
            Rule::Gauss { n_mu } => n_mu * 4 * n_mu,
            Rule::Qmc { n } => n,
            Rule::Importance { n, mix, replicate } => {
                let per = importance_node_count((n / REPLICATES as usize).max(1), &mix);
                if replicate.is_some() {
                    per
                } else {
                    per * REPLICATES as usize
                }
            }
            Rule::Peak {
                order,
                v_cavity,
                extra_levels,
            } => peak_node_count(order, v_cavity, extra_levels, wo),
        }
    }

    /// [`Rule::nodes`] at `wo`, each node handed to `emit` in order; the `peak` rule makes them
    /// one by one without a list.
    pub fn for_each_node(&self, wo: DVec3, mut emit: impl FnMut(Node)) {
        match *self {
            Rule::Peak {
                order,
                v_cavity,
                extra_levels,
            } => peak_nodes_each(order, v_cavity, extra_levels, wo, emit),
            _ => self.nodes(wo).into_iter().for_each(&mut emit),
        }
    }
}

/// Midpoint rule in (θ, φ): dω = sinθ dθ dφ, so E ≈ Σ f c_i sinθ Δθ Δφ at the cell centres
/// θ_k = (k + ½)Δθ, φ_l = (l + ½)Δφ (docs/design.md §4's centring). Error O(Δθ²) (the φ sum of a
/// smooth periodic integrand converges spectrally; kinks in f, e.g. max() terms, limit both to
/// O(h²)).
pub(super) fn midpoint_nodes(n_theta: usize, n_phi: usize) -> Vec<Node> {
    let (dt, dp) = (FRAC_PI_2 / n_theta as f64, TAU / n_phi as f64);
    let mut out = Vec::with_capacity(n_theta * n_phi);
    for k in 0..n_theta {
        let theta = (k as f64 + 0.5) * dt;
        let (s, c) = theta.sin_cos();
        for l in 0..n_phi {
            let (sp, cp) = ((l as f64 + 0.5) * dp).sin_cos();
            out.push(Node {
                wi: DVec3::new(s * cp, s * sp, c),
                weight: c * s * dt * dp,
            });
        }
    }
    out
}

/// Gauss–Legendre in μ = cosθ ∈ (0, 1) × trapezoid in φ: dω = dμ dφ, so E ≈ Σ w_μ (2π/Nφ) f μ.
/// Spectral in φ for a smooth periodic integrand; order 2Nμ polynomial exactness in μ.
pub(super) fn gauss_nodes(n_mu: usize, n_phi: usize) -> Vec<Node> {
    let gl = gauss_legendre(n_mu);
    let dp = TAU / n_phi as f64;
    let mut out = Vec::with_capacity(n_mu * n_phi);
    for (mu, w) in gauss_on(&gl, 0.0, 1.0) {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        for l in 0..n_phi {
            let (sp, cp) = ((l as f64 + 0.5) * dp).sin_cos();
            out.push(Node {
                wi: DVec3::new(s * cp, s * sp, mu),
                weight: w * dp * mu,
            });
        }
    }
    out
}

/// Cosine-weighted quasi-Monte Carlo: the R2 points (u, v) = frac(½ + k(1/ρ, 1/ρ²)) mapped by
/// Malley's method, ωi = (√u cos 2πv, √u sin 2πv, √(1 − u)), whose density is c_i/π; so
/// E ≈ (π/N) Σ f. The first N/2 points are the coarse rule's (nested).
pub(super) fn qmc_nodes(n: usize) -> Vec<Node> {
    let (a1, a2) = (1.0 / PLASTIC, 1.0 / (PLASTIC * PLASTIC));
    (0..n)
        .map(|k| {
            let u = (0.5 + a1 * k as f64).fract();
            let v = (0.5 + a2 * k as f64).fract();
            let r = u.sqrt();
            let (sp, cp) = (TAU * v).sin_cos();
            Node {
                wi: DVec3::new(r * cp, r * sp, (1.0 - u).sqrt()),
                weight: PI / n as f64,
            }
        })
        .collect()
}

/// A rule's node lists as the backends read them.
impl NodeRule for Rule {
    fn shared(&self) -> Option<Arc<Vec<Node>>> {
        self.shared_nodes()
    }

    fn count(&self, wo: DVec3) -> usize {
        self.node_count(wo)
    }

    fn visit(&self, wo: DVec3, emit: &mut dyn FnMut(Node)) {
        self.for_each_node(wo, emit)
    }

    fn list(&self, wo: DVec3) -> Vec<Node> {
        self.nodes(wo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::view_direction;

    #[test]
    fn shared_nodes_are_the_rules_own_nodes() {
        for rule in [
            Rule::Gauss { n_mu: 37 },
            Rule::Midpoint { n_theta: 11 },
            Rule::Qmc { n: 999 },
        ] {
            let first = rule
                .shared_nodes()
                .expect("an ωo-independent rule is shared");
            assert_eq!(*first, rule.nodes(DVec3::Z), "{rule:?}");
            // A second call reads the kept list (or makes it again if other jobs evicted it).
            assert_eq!(*rule.shared_nodes().unwrap(), *first, "{rule:?}");
        }
        let peak = Rule::Peak {
            order: 8,
            v_cavity: false,
            extra_levels: 0,
        };
        assert!(peak.shared_nodes().is_none(), "the peak rule depends on ωo");
    }

    #[test]
    fn the_importance_rule_depends_on_wo_only_through_its_lobes() {
        let (a, b) = (view_direction(0.9, 0.2), view_direction(0.05, 2.0));
        let cosine = Rule::Importance {
            n: 4096,
            mix: Mixture::cosine_only(),
            replicate: Some(3),
        };
        assert!(!cosine.depends_on_wo());
        assert_eq!(cosine.nodes(a), cosine.nodes(b));
        assert_eq!(*cosine.shared_nodes().unwrap(), cosine.nodes(a));
        let lobed = Rule::Importance {
            n: 4096,
            mix: Mixture::with_lobes(0.5, &[(100.0, 0.5)]),
            replicate: Some(3),
        };
        assert!(lobed.depends_on_wo());
        assert_ne!(lobed.nodes(a), lobed.nodes(b));
    }

    #[test]
    fn rules_integrate_the_cosine_to_one() {
        // ∫ c_i dω = π, so Σ w = π for every rule (Lambert with albedo 1 gives E = 1).
        let wo = view_direction(0.3, 0.7);
        for rule in [
            Rule::Midpoint { n_theta: 200 },
            Rule::Gauss { n_mu: 8 },
            Rule::Peak {
                order: 6,
                v_cavity: false,
                extra_levels: 0,
            },
        ] {
            let s: f64 = rule.nodes(wo).iter().map(|n| n.weight).sum();
            // The midpoint rule's O(h²): about (π/400)²/6 ≈ 1e-5 relative at nθ = 200.
            let tol = if let Rule::Midpoint { .. } = rule {
                5e-5
            } else {
                1e-13
            };
            assert!((s / PI - 1.0).abs() < tol, "{rule:?}: {}", s / PI);
        }
    }

    #[test]
    fn node_counts_match_the_node_lists() {
        // Every rule's count without the list equals the list's length, and `for_each_node`
        // hands out the list's nodes in order.
        let lobed = Mixture::with_lobes(0.3, &[(50.0, 0.45), (6.25, 0.25)]);
        for mu in [1.0, 0.9, 0.5, 0.1, 0.02] {
            let wo = view_direction(mu, 0.4);
            for rule in [
                Rule::Midpoint { n_theta: 7 },
                Rule::Gauss { n_mu: 5 },
                Rule::Qmc { n: 33 },
                Rule::Peak {
                    order: 6,
                    v_cavity: false,
                    extra_levels: 2,
                },
                Rule::Peak {
                    order: 5,
                    v_cavity: true,
                    extra_levels: 0,
                },
                Rule::Importance {
                    n: 1000,
                    mix: lobed,
                    replicate: Some(5),
                },
                Rule::Importance {
                    n: 1003,
                    mix: lobed,
                    replicate: None,
                },
            ] {
                let list = rule.nodes(wo);
                assert_eq!(rule.node_count(wo), list.len(), "{rule:?} at mu {mu}");
                let mut each = Vec::new();
                rule.for_each_node(wo, |n| each.push(n));
                assert_eq!(each, list, "{rule:?} at mu {mu}");
            }
        }
    }
}
