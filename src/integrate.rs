//! Directional and hemispherical albedo (DESIGN §5), on either backend, with error estimates.
//!
//! Directional albedo E(ωo) = ∫_H f(ωi, ωo) c_i dωi + the delta lobe's albedo (added exactly,
//! [`Reference::delta_albedo`]). Hemispherical albedo Ē = (1/π) ∫_H E(ωo) c_o dωo, and Kulla–Conty's
//! E_avg = 2 ∫₀¹ E(μ) μ dμ (at one φo; equal to Ē for an isotropic model).
//!
//! Every fixed rule is a list of nodes (ωi, w) with E ≈ Σ w f(ωi, ωo): the weight already holds
//! c_i, so the GPU reduction (`glsl/kernels/albedo.comp`) and the CPU sum are the same expression.
//!
//! Rules (each derivation sits above its node generator):
//! - `midpoint`: cells in (θi, φi) with sinθ weights; error O(h²) for a smooth integrand.
//! - `gauss`: Gauss–Legendre in μi = cosθi × uniform φi (trapezoid, spectral for periodic φ).
//! - `qmc`: cosine-weighted low-discrepancy points (Roberts' R2 sequence); error ~ N⁻¹ log N.
//! - `importance`: low-discrepancy points drawn from a mixture of the cosine density and
//!   power-cosine lobes about the mirror direction, tuned from the model's parameters
//!   ([`Mixture::for_model`]), weighted by the balance heuristic.
//! - `peak` (default): composite Gauss–Legendre in polar coordinates (α, β) centred on the mirror
//!   direction of ωo, where every seed lobe peaks, graded towards the peak in α and towards the
//!   horizon's fast turn in β: it resolves lobes of width 1e-3 rad with a few thousand nodes.
//! - `reference` (CPU, f64): nested adaptive Gauss–Kronrod (7/15) in the same coordinates,
//!   converged to [`REFERENCE_RTOL`]; the truth the others are tested against.
//!
//! Error estimates are honest upper-bound style estimates: a fixed rule is run again at a coarser
//! resolution and the difference is reported (divided by 3 for the midpoint rule, whose h² order
//! is known: Richardson); the adaptive reference reports Σ|K15 − G7| over its panels, which bounds
//! the 7-point Gauss result and so, in practice, grossly over-bounds the 15-point Kronrod one.

use crate::eval::{Backend, Evaluator};
use crate::model::{Brdf, ParamSet, Reference};
use anyhow::{bail, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Relative tolerance the reference integrator converges to (DESIGN §5 asks for 1e-9; the
/// nested tolerances are set tighter so that the sum of the inner errors stays under it).
pub const REFERENCE_RTOL: f64 = 1e-10;

/// Refinement stops at this many panels even if the tolerance is not met; the reported error
/// then says so.
const MAX_PANELS: usize = 4000;

/// Levels of geometric grading towards the peak in α: the innermost panel spans 2^-10 of the
/// distance to the horizon (≥ 1.5e-3 rad at normal incidence), finer than the narrowest seed lobe
/// (Phong n = 8192: width 1/√n ≈ 1.1e-2 rad).
const ALPHA_LEVELS: u32 = 10;

/// One quadrature node: E ≈ Σ weight · f(wi, wo). The weight holds c_i.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub wi: DVec3,
    pub weight: f64,
}

/// The integrators `lobe albedo --method` offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Midpoint,
    Gauss,
    Qmc,
    Importance,
    Peak,
    Reference,
}

impl Method {
    pub const ALL: [Method; 6] = [
        Method::Midpoint,
        Method::Gauss,
        Method::Qmc,
        Method::Importance,
        Method::Peak,
        Method::Reference,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::Midpoint => "midpoint",
            Method::Gauss => "gauss",
            Method::Qmc => "qmc",
            Method::Importance => "importance",
            Method::Peak => "peak",
            Method::Reference => "reference",
        }
    }

    pub fn from_name(name: &str) -> Result<Method> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "unknown integration method '{name}'; the methods are: {}",
                    Method::ALL.map(Method::name).join(", ")
                )
            })
    }

    /// Nodes per direction when `--samples` is not given. For `peak` this reaches 1e-6 relative
    /// at every preset of every seed model (tests/albedo.rs checks it against the reference):
    /// Cook–Torrance's V-cavity kinks are put on panel edges ([`v_cavity_kinks`],
    /// [`v_cavity_turns`]), which took its presets from 3e-5–7e-5 to ≤ 1.7e-7. `importance` is a
    /// sampling method: ~1e-4 at 65536 points, with a statistical error estimate.
    pub fn default_samples(self) -> usize {
        match self {
            Method::Midpoint | Method::Gauss => 1 << 16,
            Method::Qmc | Method::Importance => 1 << 16,
            Method::Peak => 1 << 16,
            Method::Reference => 0,
        }
    }

    /// The fixed rule with about `samples` nodes per direction for the model `params` (only
    /// `importance` looks at them), or None for the adaptive reference.
    pub fn rule(self, samples: usize, params: &ParamSet) -> Option<Rule> {
        let samples = samples.max(16);
        // (θ or μ) × φ with four times as many φ as θ cells: square cells at the equator.
        let n = (((samples / 4) as f64).sqrt().round() as usize).max(2);
        match self {
            Method::Midpoint => Some(Rule::Midpoint { n_theta: n }),
            Method::Gauss => Some(Rule::Gauss { n_mu: n }),
            Method::Qmc => Some(Rule::Qmc { n: samples }),
            Method::Importance => Some(Rule::Importance {
                n: samples,
                mix: Mixture::for_model(params),
                replicate: None,
            }),
            // About 30 μ panels × 22 φ panels, q² nodes per panel pair; up to 1.7× that for a
            // grazing view and half of it at the normal (the extra grading levels).
            Method::Peak => Some(Rule::Peak {
                order: (((samples as f64) / (30.0 * 22.0)).sqrt().round() as usize).max(2),
                v_cavity: params.model().has_v_cavity_masking(),
            }),
            Method::Reference => None,
        }
    }
}

/// A fixed quadrature rule over the hemisphere of ωi.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    Midpoint {
        n_theta: usize,
    },
    Gauss {
        n_mu: usize,
    },
    Qmc {
        n: usize,
    },
    /// `n` points in all, in [`REPLICATES`] independently shifted replicates; `replicate`
    /// selects one of them (its own estimator, `n / REPLICATES` points) or, with None, all (each
    /// weighted 1/REPLICATES: their mean).
    Importance {
        n: usize,
        mix: Mixture,
        replicate: Option<u32>,
    },
    Peak {
        order: usize,
        /// Split each μ line's Δφ panels at the V-cavity masking kinks ([`v_cavity_kinks`]).
        v_cavity: bool,
    },
}

impl Rule {
    /// Whether the nodes depend on ωo (they then travel to the GPU once per direction).
    pub fn depends_on_wo(&self) -> bool {
        matches!(self, Rule::Peak { .. } | Rule::Importance { .. })
    }

    /// The same rule at about half the nodes (a quarter for the 2D midpoint rule, whose h is then
    /// doubled), and the factor that turns |fine − coarse| into an estimate of the fine rule's
    /// error: 1/(2² − 1) for the midpoint rule's O(h²) (Richardson), 1 otherwise (the coarse
    /// rule's own error: conservative for rules that converge faster than linearly).
    pub fn coarse(&self) -> (Rule, f64) {
        match *self {
            Rule::Midpoint { n_theta } => (
                Rule::Midpoint {
                    n_theta: (n_theta / 2).max(1),
                },
                if n_theta >= 2 { 1.0 / 3.0 } else { 1.0 },
            ),
            Rule::Gauss { n_mu } => (
                Rule::Gauss {
                    n_mu: (n_mu * 2 / 3).max(1),
                },
                1.0,
            ),
            Rule::Qmc { n } => (Rule::Qmc { n: (n / 2).max(1) }, 1.0),
            // Not used for the estimate ([`rule_albedo`] takes the replicates' spread), but a
            // coarse rule exists for every rule.
            Rule::Importance { n, mix, replicate } => (
                Rule::Importance {
                    n: (n / 2).max(1),
                    mix,
                    replicate,
                },
                1.0,
            ),
            Rule::Peak { order, v_cavity } => (
                Rule::Peak {
                    order: (order * 3 / 4).clamp(1, order.saturating_sub(1).max(1)),
                    v_cavity,
                },
                1.0,
            ),
        }
    }

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
            Rule::Peak { order, v_cavity } => peak_nodes(order, v_cavity, wo),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// One-dimensional rules.

/// Gauss–Legendre nodes and weights on [-1, 1]: Newton's iteration on P_n from Tricomi's initial
/// guess cos(π(k + 3/4)/(n + 1/2)), with P_n from the three-term recurrence (Abramowitz & Stegun
/// 25.4.29 for the weights w = 2/((1 − x²) P_n'(x)²)).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let mut x = (PI * (k as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for j in 2..=n {
                let j = j as f64;
                let p2 = ((2.0 * j - 1.0) * x * p1 - (j - 1.0) * p0) / j;
                p0 = p1;
                p1 = p2;
            }
            let (pn, pm) = if n == 0 { (1.0, 0.0) } else { (p1, p0) };
            let pn = if n == 1 { x } else { pn };
            let pm = if n == 1 { 1.0 } else { pm };
            dp = n as f64 * (x * pn - pm) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// Gauss–Legendre with `n` nodes on [a, b], as (x, w).
fn gauss_on(rule: &[(f64, f64)], a: f64, b: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    rule.iter().map(move |&(x, w)| (m + h * x, h * w))
}

/// Kronrod 15-point nodes (positive half, descending) and weights, with the embedded Gauss
/// 7-point weights at the odd-indexed nodes; QUADPACK's qk15 (Piessens et al. 1983).
#[allow(clippy::excessive_precision)] // QUADPACK's published digits, kept as printed
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.0,
];
#[allow(clippy::excessive_precision)] // QUADPACK's published digits, kept as printed
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
#[allow(clippy::excessive_precision)] // QUADPACK's published digits, kept as printed
const WG: [f64; 4] = [
    0.129484966168869693270611432679082,
    0.279705391489276667901467771423780,
    0.381830050505118944950369775488975,
    0.417959183673469387755102040816327,
];

/// An integral with its error estimate (per channel) and the integrand evaluations it took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub value: DVec3,
    pub error: DVec3,
    pub evals: u64,
}

/// The 15 Kronrod abscissae on [a, b], in the order [`gk15_combine`] expects: pairs m ∓ h·x_j
/// for j = 0..7, then the midpoint.
fn gk15_nodes(a: f64, b: f64) -> [f64; 15] {
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut x = [m; 15];
    for j in 0..7 {
        x[2 * j] = m - h * XGK[j];
        x[2 * j + 1] = m + h * XGK[j];
    }
    x
}

/// One Gauss–Kronrod 7/15 panel from the integrand at [`gk15_nodes`]: the Kronrod sum, and as
/// error |K15 − G7| plus the integrand's own errors carried through the Kronrod weights.
fn gk15_combine(a: f64, b: f64, vals: &[Estimate]) -> Estimate {
    let h = 0.5 * (b - a);
    let mut k = DVec3::ZERO;
    let mut g = DVec3::ZERO;
    let mut carried = DVec3::ZERO;
    let mut evals = 0;
    for (i, e) in vals.iter().enumerate() {
        let j = i / 2;
        k += WGK[j] * e.value;
        carried += WGK[j] * e.error;
        evals += e.evals;
        if j % 2 == 1 {
            g += WG[j / 2] * e.value;
        }
    }
    Estimate {
        value: h * k,
        error: (h * (k - g)).abs() + h.abs() * carried,
        evals,
    }
}

/// One Gauss–Kronrod 7/15 panel of an integrand that returns (value, its own error, evals).
fn gk15<F: Fn(f64) -> Estimate>(f: &F, a: f64, b: f64) -> Estimate {
    let vals: Vec<Estimate> = gk15_nodes(a, b).iter().map(|&x| f(x)).collect();
    gk15_combine(a, b, &vals)
}

/// Globally adaptive Gauss–Kronrod over the panels between `breaks` (QUADPACK's QAG strategy,
/// refined in batches): while the summed error exceeds `tol` (absolute, in the largest
/// channel), every panel whose error is at least half the largest one is bisected. With
/// `parallel`, the panels of a batch are evaluated on rayon's threads.
fn adaptive<F: Fn(f64) -> Estimate + Sync>(
    f: &F,
    breaks: &[f64],
    tol: f64,
    parallel: bool,
) -> Estimate {
    let eval = |(a, b): (f64, f64)| (a, b, gk15(f, a, b));
    let spans: Vec<(f64, f64)> = breaks
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| (w[0], w[1]))
        .collect();
    let mut panels: Vec<(f64, f64, Estimate)> = if parallel {
        spans.into_par_iter().map(eval).collect()
    } else {
        spans.into_iter().map(eval).collect()
    };
    let mut evals: u64 = panels.iter().map(|p| p.2.evals).sum();
    loop {
        let error: DVec3 = panels.iter().map(|p| p.2.error).sum();
        if error.max_element() <= tol || panels.len() >= MAX_PANELS {
            break;
        }
        let worst = panels
            .iter()
            .map(|p| p.2.error.max_element())
            .fold(0.0, f64::max);
        // A panel too narrow to bisect in f64 keeps its error: reported, not hidden.
        let splittable = |p: &(f64, f64, Estimate)| {
            p.2.error.max_element() >= 0.5 * worst
                && 0.5 * (p.0 + p.1) > p.0
                && 0.5 * (p.0 + p.1) < p.1
        };
        let (split, keep): (Vec<_>, Vec<_>) = panels.into_iter().partition(splittable);
        if split.is_empty() {
            panels = keep;
            break;
        }
        let halves: Vec<(f64, f64)> = split
            .iter()
            .flat_map(|&(a, b, _)| {
                let m = 0.5 * (a + b);
                [(a, m), (m, b)]
            })
            .collect();
        let new: Vec<_> = if parallel {
            halves.into_par_iter().map(eval).collect()
        } else {
            halves.into_iter().map(eval).collect()
        };
        evals += new.iter().map(|p| p.2.evals).sum::<u64>();
        panels = keep;
        panels.extend(new);
    }
    Estimate {
        value: panels.iter().map(|p| p.2.value).sum(),
        error: panels.iter().map(|p| p.2.error).sum(),
        evals,
    }
}

/// Breakpoints on [0, 1] graded geometrically towards 0: 0, 2^-levels, …, 1/2, 1.
fn graded(levels: u32) -> Vec<f64> {
    let mut b = vec![0.0];
    b.extend((0..=levels).rev().map(|k| 0.5f64.powi(k as i32)));
    b
}

// ---------------------------------------------------------------------------------------------
// Fixed rules over the hemisphere of ωi.

/// Midpoint rule in (θ, φ): dω = sinθ dθ dφ, so E ≈ Σ f c_i sinθ Δθ Δφ at the cell centres
/// θ_k = (k + ½)Δθ, φ_l = (l + ½)Δφ (DESIGN §4's centring). Error O(Δθ²) (the φ sum of a smooth
/// periodic integrand converges spectrally; kinks in f, e.g. max() terms, limit both to O(h²)).
fn midpoint_nodes(n_theta: usize, n_phi: usize) -> Vec<Node> {
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
fn gauss_nodes(n_mu: usize, n_phi: usize) -> Vec<Node> {
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

/// The plastic number ρ (ρ³ = ρ + 1), the generator of Roberts' R2 sequence (Roberts 2018, "The
/// unreasonable effectiveness of quasirandom sequences").
const PLASTIC: f64 = 1.324_717_957_244_746;

/// Cosine-weighted quasi-Monte Carlo: the R2 points (u, v) = frac(½ + k(1/ρ, 1/ρ²)) mapped by
/// Malley's method, ωi = (√u cos 2πv, √u sin 2πv, √(1 − u)), whose density is c_i/π; so
/// E ≈ (π/N) Σ f. The first N/2 points are the coarse rule's (nested).
fn qmc_nodes(n: usize) -> Vec<Node> {
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

    /// The mixture tuned from the model's parameters. Each peaked model's lobe is matched by a
    /// power cosine (r·ωi)^n of the same width near its peak (small angles α between ωi and r):
    /// - `phong`: n = shininess, exactly its lobe;
    /// - `blinn_phong`: c_h^N with θh ≈ α/2: cos^N(α/2) ≈ e^{−Nα²/8} = cos^{N/4}α, so n = N/4;
    /// - `ashikhmin_shirley`: likewise n = nu/4 and n = nv/4 (two lobes when anisotropic);
    /// - `cook_torrance` (and `microfacet`, per axis): Beckmann's e^{−tan²θh/m²} ≈ e^{−α²/(4m²)}
    ///   = cos^n α with n = 1/(2m²).
    ///
    /// Each width gets two lobes, n (2/3 of its share) and n/8 (1/3; see
    /// [`BROAD_LOBE_DIVISOR`]). The cosine's share is diffuse/(diffuse + specular) of the
    /// parameters' largest channels, clamped to [`COSINE_FRACTION`]. Models without a peaked
    /// lobe (lambert, oren_nayar, and the layered ones, whose spike is added exactly) draw from
    /// c_i/π alone.
    pub fn for_model(params: &ParamSet) -> Mixture {
        let beckmann = |m: f64| 0.5 / (m * m);
        let (diffuse, specular, widths) = match Brdf::new(params) {
            Brdf::Phong(p) => (p.diffuse, p.specular, [p.shininess; 2]),
            Brdf::BlinnPhong(p) => {
                let n = 8192f64.powf(1.0 - p.smoothness) / 4.0;
                (p.diffuse, p.specular, [n; 2])
            }
            Brdf::CookTorrance(p) => (p.diffuse, p.specular, [beckmann(p.roughness); 2]),
            // The coat's Fresnel rises to 1 at grazing whatever R0 (`specular`) is: weigh the
            // lobe as if it reflected everything, the base by what the coat lets through.
            Brdf::AshikhminShirley(p) => (
                p.diffuse * (DVec3::ONE - p.specular),
                DVec3::ONE,
                [p.nu / 4.0, p.nv / 4.0],
            ),
            Brdf::Microfacet(p) => (
                p.diffuse,
                p.specular,
                [beckmann(p.alpha_x), beckmann(p.alpha_y)],
            ),
            _ => return Mixture::cosine_only(),
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

/// The `importance` rule: multi-sample importance sampling with the balance heuristic (Veach
/// 1997, §9.2). Component l of the [`Mixture`] gets N_l = round(c_l N) points, the R2 sequence
/// (each component at its own offset) mapped through its inverse CDF:
/// - cosine: Malley's method, as in [`qmc_nodes`];
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
fn importance_nodes(n: usize, mix: &Mixture, replicate: u32, wo: DVec3) -> Vec<Node> {
    let frame = PeakFrame::new(wo);
    let counts = mix.counts(n);
    let (a1, a2) = (1.0 / PLASTIC, 1.0 / (PLASTIC * PLASTIC));
    let density = |x: DVec3| -> f64 {
        let mut p = counts[0] as f64 * x.z.max(0.0) / PI;
        for (k, &(e, _)) in mix.lobes.iter().enumerate() {
            let c = x.dot(frame.r);
            if counts[k + 1] > 0 && c > 0.0 {
                p += counts[k + 1] as f64 * (e + 1.0) / TAU * c.powf(e);
            }
        }
        p
    };
    let mut out = Vec::with_capacity(counts.iter().sum());
    for (l, &count) in counts.iter().enumerate() {
        // Cranley–Patterson rotation: the replicate's own random shift of the R2 points, one per
        // component, from a seeded generator (deterministic: a run reproduces exactly).
        let mut seed = SplitMix64(((replicate as u64) << 8) | l as u64);
        let (su, sv) = (seed.unit(), seed.unit());
        for k in 0..count {
            let u = (su + a1 * k as f64).fract();
            let v = (sv + a2 * k as f64).fract();
            let (sb, cb) = (TAU * v).sin_cos();
            let x = if l == 0 {
                let r = u.sqrt();
                DVec3::new(r * cb, r * sb, (1.0 - u).sqrt())
            } else {
                let e = mix.lobes[l - 1].0;
                // sin²α = 1 − u^{2/(n+1)} without the cancellation near α = 0.
                let ln_u = u.max(f64::MIN_POSITIVE).ln();
                let sin2 = -(2.0 * ln_u / (e + 1.0)).exp_m1();
                let (sa, ca) = (sin2.sqrt(), (1.0 - sin2).max(0.0).sqrt());
                ca * frame.r + sa * (cb * frame.u + sb * frame.v)
            };
            let p = density(x);
            out.push(if x.z > 0.0 && p > 0.0 {
                Node {
                    wi: x,
                    weight: x.z / p,
                }
            } else {
                Node {
                    wi: DVec3::Z,
                    weight: 0.0,
                }
            });
        }
    }
    out
}

/// Polar coordinates (α, β) about the mirror direction r of ωo, where every seed lobe peaks
/// (Phong's r·ωo = 1; D's maximum at h = n for the half-vector lobes):
/// ωi = cosα r + sinα (cosβ u + sinβ v), u = ∂r/∂θ (in the plane of incidence, pointing
/// down towards the horizon), v = n × r / |n × r|. Then dω = sinα dα dβ and
/// c_i = cosα cosθr − sinα cosβ sinθr, which vanishes at α_max(β) = atan2(cosθr, sinθr cosβ):
/// the horizon. The integral over the hemisphere is exactly
///   E = ∫_{−π/2}^{3π/2} dβ ∫_0^{α_max(β)} f c_i sinα dα,
/// with α = α_max(β)·t, t ∈ [0, 1]. α_max changes fastest near β = ±π/2 (width ~ cosθr), so the
/// β range splits at ±π/2 and 0, π, and each quadrant is graded towards ±π/2.
#[derive(Clone, Copy, Debug)]
struct PeakFrame {
    r: DVec3,
    u: DVec3,
    v: DVec3,
    cos_r: f64,
    sin_r: f64,
}

impl PeakFrame {
    fn new(wo: DVec3) -> PeakFrame {
        let r = DVec3::new(-wo.x, -wo.y, wo.z);
        let sin_r = (r.x * r.x + r.y * r.y).sqrt();
        let cos_r = r.z;
        let (u, v) = if sin_r > 0.0 {
            let (c, s) = (r.x / sin_r, r.y / sin_r);
            (
                DVec3::new(cos_r * c, cos_r * s, -sin_r),
                DVec3::new(-s, c, 0.0),
            )
        } else {
            (DVec3::X, DVec3::Y)
        };
        PeakFrame {
            r,
            u,
            v,
            cos_r,
            sin_r,
        }
    }

    fn alpha_max(&self, beta: f64) -> f64 {
        self.cos_r.atan2(self.sin_r * beta.cos())
    }

    fn dir(&self, alpha: f64, beta: f64) -> DVec3 {
        let (sa, ca) = alpha.sin_cos();
        let (sb, cb) = beta.sin_cos();
        ca * self.r + sa * (cb * self.u + sb * self.v)
    }

    /// β breakpoints over [−π/2, 3π/2]: four quadrants graded towards ±π/2, down to a panel of
    /// about cosθr/2 (the width of α_max's turn).
    fn beta_breaks(&self) -> Vec<f64> {
        let levels = (PI / self.cos_r.max(1e-12)).log2().ceil().clamp(1.0, 40.0) as u32;
        let g = graded(levels);
        let mut b: Vec<f64> = Vec::new();
        for t in &g {
            b.push(-FRAC_PI_2 + FRAC_PI_2 * t); // [−π/2, 0], fine at −π/2
            b.push(FRAC_PI_2 - FRAC_PI_2 * t); // [0, π/2], fine at π/2
            b.push(FRAC_PI_2 + FRAC_PI_2 * t); // [π/2, π], fine at π/2
            b.push(1.5 * PI - FRAC_PI_2 * t); // [π, 3π/2], fine at 3π/2
        }
        b.sort_by(f64::total_cmp);
        b.dedup();
        b
    }
}

/// The `peak` rule: composite Gauss–Legendre of `order` points per panel in (μi, φi) (dω = dμ dφ,
/// E = ∫∫ f μ dμ dφ), on panels aligned with where the seed models are not smooth and graded
/// towards where they peak:
/// - μ splits at μo (the kink of max(c_i, c_o) in Oren–Nayar and Ashikhmin–Shirley; the mirror
///   direction's μ) and is graded towards it from both sides;
/// - φ splits at φo + kπ/2 (Oren–Nayar's max(0, cos Δφ) kinks at Δφ = ±π/2; the mirror direction
///   at Δφ = π) and the two quadrants beside Δφ = π are graded towards it.
///
/// A lobe of width w about the mirror direction is then covered by panels of every size down to
/// 2^-levels of the domain (see [`PEAK_LEVELS`]), so it is integrated like a smooth function.
///
/// With `v_cavity`, each μ line's Δφ panels are also split at the V-cavity's kinks (see
/// [`v_cavity_kinks`]): curves in (μ, Δφ) that no fixed panel grid follows, which would otherwise
/// leave Gauss panels integrating a kinked function at low order (~5e-5 relative at the
/// Cook–Torrance presets). With the kink on a panel edge the inner integral is smooth in every
/// panel, and the outer one in μ is smooth because the kink moves smoothly with μ.
fn peak_nodes(order: usize, v_cavity: bool, wo: DVec3) -> Vec<Node> {
    let phi_o = wo.y.atan2(wo.x);
    let gl = gauss_legendre(order);
    let mut mb = peak_mu_breaks(wo.z);
    if v_cavity {
        mb.extend(v_cavity_turns(wo.z));
        mb.sort_by(f64::total_cmp);
        mb.dedup();
    }
    let pb = peak_phi_breaks(wo.z);
    let line = |breaks: &[f64]| -> Vec<(f64, f64, f64)> {
        let mut phis = Vec::with_capacity(order * breaks.len());
        for w in breaks.windows(2) {
            for (dphi, wp) in gauss_on(&gl, w[0], w[1]) {
                let (sp, cp) = (phi_o + dphi).sin_cos();
                phis.push((sp, cp, wp));
            }
        }
        phis
    };
    let shared = line(&pb);
    let mut out = Vec::with_capacity(order * (mb.len() - 1) * (shared.len() + 2 * order));
    for w in mb.windows(2) {
        for (mu, wm) in gauss_on(&gl, w[0], w[1]) {
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            let own;
            let phis = if v_cavity {
                let mut b = pb.clone();
                b.extend(v_cavity_kinks(mu, wo.z));
                b.sort_by(f64::total_cmp);
                b.dedup();
                own = line(&b);
                &own
            } else {
                &shared
            };
            for &(sp, cp, wp) in phis {
                out.push(Node {
                    wi: DVec3::new(s * cp, s * sp, mu),
                    weight: wm * wp * mu,
                });
            }
        }
    }
    out
}

/// The μi where the V-cavity's kink curve turns (cos Δφ* of [`v_cavity_kinks`] reaches ±1): there
/// the kinks appear or vanish on the μ lines, the inner integral's derivative in μ is singular
/// like a square root, and the outer rule needs a panel edge. Found by bisection on a scan of
/// q(μ) = (2m(μ + μo) − 1 − μμo)² − (1 − μ²)(1 − μo²), whose sign changes they are.
pub fn v_cavity_turns(mu_o: f64) -> Vec<f64> {
    let q = |mu: f64| {
        let m = mu.min(mu_o);
        let a = 2.0 * m * (mu + mu_o) - 1.0 - mu * mu_o;
        a * a - (1.0 - mu * mu) * (1.0 - mu_o * mu_o)
    };
    const SCAN: usize = 256;
    let mut out = Vec::new();
    for k in 0..SCAN {
        let (mut a, mut b) = (k as f64 / SCAN as f64, (k + 1) as f64 / SCAN as f64);
        let (qa, qb) = (q(a), q(b));
        if qa == 0.0 {
            out.push(a);
            continue;
        }
        if qa * qb >= 0.0 {
            continue;
        }
        for _ in 0..60 {
            let mid = 0.5 * (a + b);
            if q(mid) * qa > 0.0 {
                a = mid;
            } else {
                b = mid;
            }
        }
        out.push(0.5 * (a + b));
    }
    out
}

/// The Δφ = φi − φo ∈ (0, 2π) where the V-cavity's G = min(1, 2 c_h m / c_d), m = min(μi, μo),
/// has its kink on the line μi = `mu`, for a view at μo = `mu_o`.
///
/// With s = ωi + ωo: c_h = (μi + μo)/|s| and c_d = |s|/2, so 2 c_h m = c_d ⟺ |s|² = 4m(μi + μo),
/// and |s|² = 2 + 2(μi μo + sinθi sinθo cos Δφ):
/// cos Δφ* = (2m(μi + μo) − 1 − μi μo) / (sinθi sinθo). The other kink, μi = μo where m switches,
/// is already a μ breakpoint of the `peak` rule.
pub fn v_cavity_kinks(mu: f64, mu_o: f64) -> Vec<f64> {
    let m = mu.min(mu_o);
    let ss = ((1.0 - mu * mu) * (1.0 - mu_o * mu_o)).max(0.0).sqrt();
    if ss <= 0.0 {
        return Vec::new();
    }
    let c = (2.0 * m * (mu + mu_o) - 1.0 - mu * mu_o) / ss;
    if !(c > -1.0 && c < 1.0) {
        return Vec::new();
    }
    let d = c.acos();
    vec![d, TAU - d]
}

/// The `peak` rule's μ breakpoints. Below μo: graded towards μo. Above: towards μo and towards
/// the pole, where sinθi = √(1 − μ²) (Oren–Nayar's sinθi sinθo cosΔφ term) has an infinite
/// derivative.
fn peak_mu_breaks(mu_o: f64) -> Vec<f64> {
    let mu_o = mu_o.clamp(0.0, 1.0);
    let g = graded(PEAK_LEVELS);
    // Towards μo, [`pole_levels`] more levels for a view near the normal.
    let gp = graded(PEAK_LEVELS + pole_levels(mu_o));
    let mid = 0.5 * (mu_o + 1.0);
    let mut mb: Vec<f64> = gp.iter().map(|t| mu_o - mu_o * t).collect();
    mb.extend(gp.iter().map(|t| mu_o + (mid - mu_o) * t));
    mb.extend(g.iter().map(|t| 1.0 - (1.0 - mid) * t));
    mb.sort_by(f64::total_cmp);
    mb.dedup();
    mb
}

/// The `peak` rule's breakpoints in Δφ = φi − φo ∈ [0, 2π]: the quadrants, the two beside the
/// mirror azimuth Δφ = π graded towards it, with [`grazing_levels`] more levels for a grazing
/// view.
fn peak_phi_breaks(mu_o: f64) -> Vec<f64> {
    let g = graded(PEAK_LEVELS + grazing_levels(mu_o));
    let mut pb: Vec<f64> = vec![0.0, FRAC_PI_2];
    pb.extend(g.iter().map(|t| PI - FRAC_PI_2 * t));
    pb.extend(g.iter().map(|t| PI + FRAC_PI_2 * t));
    pb.extend([1.5 * PI, TAU]);
    pb.sort_by(f64::total_cmp);
    pb.dedup();
    pb
}

/// Extra levels of Δφ grading for a view at μo: near the horizon a lobe is narrower in Δφ than in
/// angle. With ωi and ωo both near grazing and Δφ near π, |ωi + ωo| ≈ 2μo, so turning ωi by δ in
/// azimuth tilts h by about δ/(2μo): a lobe of width w in h spans only ~2μo·w in Δφ (GGX with
/// α = 0.01 at μo = 1/64: 3e-4 rad, a tenth of the finest panel at 9 levels, which left 6e-4 of
/// E at 65536 nodes). log2(1/μo) more levels keep the finest panel in step; capped at 8.
fn grazing_levels(mu_o: f64) -> u32 {
    (1.0 / mu_o.max(1e-12)).log2().ceil().clamp(0.0, 8.0) as u32
}

/// Extra levels of μ grading for a view at μo near the normal: a lobe of angular width w about
/// the mirror direction spans δμ ≈ sinθo·w + w²/2 in μ, down to w²/2 at μo = 1 (GGX α = 0.01:
/// 2e-4, a fifth of the finest panel at 9 levels, which left 5e-5 of E at 65536 nodes).
/// log2(1/sinθo) more levels, capped at 9 (finest panel 2^-18 in μ, ~3e-3 rad at the pole).
fn pole_levels(mu_o: f64) -> u32 {
    let sin_o = (1.0 - mu_o * mu_o).max(0.0).sqrt();
    (1.0 / sin_o.max(1e-12)).log2().ceil().clamp(0.0, 9.0) as u32
}

/// Levels of grading of the `peak` rule's panels towards the mirror direction: the finest panel
/// is 2^-9 of its side's extent, finer than the narrowest seed lobe (Phong n = 8192 has width
/// 1/√n ≈ 1.1e-2 rad; Cook–Torrance m = 0.01 about 2e-2 rad in ωi).
const PEAK_LEVELS: u32 = 9;

// ---------------------------------------------------------------------------------------------
// The reference.

/// Directional albedo (delta lobe excluded), the reference: nested adaptive Gauss–Kronrod in
/// (μi, Δφ) from the `peak` rule's aligned, graded breakpoints: outer over μ ∈ [0, 1], inner
/// over Δφ ∈ [0, 2π], E = ∫∫ f μ dΔφ dμ. The seed models' kinks lie on breakpoints (μ = μo,
/// Δφ = ±π/2) or are found by bisection (the V-cavity's min); tolerances as in
/// [`reference_albedo_mirror_frame`].
pub fn reference_albedo(r: &Reference, wo: DVec3, rtol: f64) -> Estimate {
    if wo.z <= 0.0 {
        return Estimate::default();
    }
    let first: DVec3 = peak_nodes(6, false, wo)
        .iter()
        .map(|n| n.weight * r.eval(n.wi, wo))
        .sum();
    let tol = (rtol * first.abs().max_element()).max(f64::MIN_POSITIVE);
    let tol_inner = tol / 100.0;
    let phi_o = wo.y.atan2(wo.x);
    let pb = peak_phi_breaks(wo.z);
    let inner = |mu: f64| {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let g = |dphi: f64| {
            let (sp, cp) = (phi_o + dphi).sin_cos();
            Estimate {
                value: r.eval(DVec3::new(s * cp, s * sp, mu), wo) * mu,
                error: DVec3::ZERO,
                evals: 1,
            }
        };
        adaptive(&g, &pb, tol_inner, false)
    };
    adaptive(&inner, &peak_mu_breaks(wo.z), tol, true)
}

/// Directional albedo (delta lobe excluded) by nested adaptive Gauss–Kronrod in the peak frame:
/// inner over α ∈ [0, α_max(β)] from the graded breakpoints, outer over β from the graded
/// quadrants. The absolute tolerance is `rtol` × the largest channel of a first estimate (the
/// `peak` rule of order 6); the inner integrals get 1/(100·2π) of it each so that their carried
/// errors (weighted by at most 2π) stay a small part of the total.
pub fn reference_albedo_mirror_frame(r: &Reference, wo: DVec3, rtol: f64) -> Estimate {
    if wo.z <= 0.0 {
        return Estimate::default();
    }
    let frame = PeakFrame::new(wo);
    let first: DVec3 = peak_nodes(6, false, wo)
        .iter()
        .map(|n| n.weight * r.eval(n.wi, wo))
        .sum();
    let scale = first.abs().max_element();
    // A black material: the estimate is exact (every node gives 0) and nothing needs refining.
    let tol = (rtol * scale).max(f64::MIN_POSITIVE);
    let tol_inner = tol / (100.0 * TAU);
    let tb = graded(ALPHA_LEVELS);
    let inner = |beta: f64| {
        let am = frame.alpha_max(beta);
        let breaks: Vec<f64> = tb.iter().map(|t| am * t).collect();
        let g = |alpha: f64| {
            let wi = frame.dir(alpha, beta);
            Estimate {
                value: r.eval(wi, wo) * (wi.z.max(0.0) * alpha.sin()),
                error: DVec3::ZERO,
                evals: 1,
            }
        };
        adaptive(&g, &breaks, tol_inner, false)
    };
    adaptive(&inner, &frame.beta_breaks(), tol, true)
}

// ---------------------------------------------------------------------------------------------
// Running rules on a backend.

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
                    error: REPLICATE_T * (var / r).powf(0.5),
                    evals: reps.iter().map(|v| v[o].1).sum(),
                }
            })
            .collect());
    }
    let (coarse, factor) = rule.coarse();
    let fine_e = sum_rule(backend, params, white_furnace, rule, wo)?;
    let coarse_e = sum_rule(backend, params, white_furnace, coarse, wo)?;
    Ok(fine_e
        .into_iter()
        .zip(coarse_e)
        .map(|((v, n), (c, _))| Estimate {
            value: v,
            error: factor * (v - c).abs(),
            evals: n,
        })
        .collect())
}

/// Σ w f(ωi, ωo) for each ωo: f64 sums on the CPU, the reduction kernel on the GPU.
/// Nodes of ωo-dependent rules gathered for one GPU call: 4M nodes, 64 MiB as f32x4 (and 128 MiB
/// as f64 while they are made).
const GPU_NODE_BATCH: usize = 1 << 22;

pub fn sum_rule(
    backend: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<(DVec3, u64)>> {
    match backend.backend() {
        Backend::Cpu => {
            let r = Reference::new(params, white_furnace);
            let shared = (!rule.depends_on_wo()).then(|| rule.nodes(DVec3::Z));
            Ok(wo
                .par_iter()
                .map(|&o| {
                    let own;
                    let nodes = match &shared {
                        Some(n) => n,
                        None => {
                            own = rule.nodes(o);
                            &own
                        }
                    };
                    let sum = nodes
                        .par_chunks(4096)
                        .map(|c| c.iter().map(|n| n.weight * r.eval(n.wi, o)).sum::<DVec3>())
                        .sum::<DVec3>();
                    (sum, nodes.len() as u64)
                })
                .collect())
        }
        Backend::Gpu(gpu) => {
            // Nodes per direction travel to the GPU: a batch of directions at a time keeps host
            // memory bounded (an anisotropic hemispherical albedo asks for thousands of
            // directions of ~1e5 nodes each: gigabytes at once).
            let batch = match (rule.depends_on_wo(), wo.first()) {
                (true, Some(&o)) => (GPU_NODE_BATCH / rule.nodes(o).len().max(1)).max(1),
                _ => wo.len().max(1),
            };
            let mut out = Vec::with_capacity(wo.len());
            for part in wo.chunks(batch) {
                out.extend(gpu_sum(gpu, params, white_furnace, rule, part)?);
            }
            Ok(out)
        }
    }
}

/// Σ w f(ωi, ωo) for each ωo of `wo` by the GPU reduction kernel, in one call.
fn gpu_sum(
    gpu: &crate::gpu::Gpu,
    params: &ParamSet,
    white_furnace: bool,
    rule: Rule,
    wo: &[DVec3],
) -> Result<Vec<(DVec3, u64)>> {
    let block = Brdf::new(params).gpu_block();
    let f4 = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
    let wo4: Vec<[f32; 4]> = wo.iter().map(|&o| f4(o, 0.0)).collect();
    let (nodes, n_nodes, per_wo, counts) = if rule.depends_on_wo() {
        let lists: Vec<Vec<Node>> = wo.par_iter().map(|&o| rule.nodes(o)).collect();
        let n = lists.iter().map(Vec::len).max().unwrap_or(0);
        let mut flat = Vec::with_capacity(n * lists.len());
        for l in &lists {
            flat.extend(l.iter().map(|x| f4(x.wi, x.weight)));
            // Padding nodes weigh nothing.
            flat.resize(flat.len() + n - l.len(), [0.0, 0.0, 1.0, 0.0]);
        }
        let counts = lists.iter().map(|l| l.len() as u64).collect();
        (flat, n, true, counts)
    } else {
        let l = rule.nodes(DVec3::Z);
        let n = l.len();
        let flat = l.iter().map(|x| f4(x.wi, x.weight)).collect();
        (flat, n, false, vec![n as u64; wo.len()])
    };
    let sums = gpu.albedo(
        params.model(),
        &block,
        white_furnace,
        &wo4,
        &nodes,
        n_nodes,
        per_wo,
    )?;
    Ok(sums
        .into_iter()
        .zip(counts)
        .map(|(s, n)| (DVec3::from_array(s), n))
        .collect())
}

/// E at one view direction, with the delta lobe reported apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointAlbedo {
    pub mu: f64,
    pub phi: f64,
    /// The total albedo, delta lobe included.
    pub albedo: DVec3,
    /// The delta lobe's part, exact: F_s(μ) for the seed's layered models.
    pub delta: DVec3,
    pub error: DVec3,
    /// Integrand evaluations (nodes) spent on this direction, the coarse check included.
    pub samples: u64,
}

/// ωo from μ = cosθo and φo (radians).
pub fn view_direction(mu: f64, phi: f64) -> DVec3 {
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), mu)
}

/// How to integrate: a method, its node count, and (reference only) its tolerance.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub method: Method,
    pub samples: usize,
    pub white_furnace: bool,
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
    let wo: Vec<DVec3> = points
        .iter()
        .map(|&(mu, phi)| view_direction(mu, phi))
        .collect();
    let r = Reference::new(params, s.white_furnace);
    let est: Vec<Estimate> = match s.method.rule(s.samples, params) {
        Some(rule) => rule_albedo(backend, params, s.white_furnace, rule, &wo)?,
        None => {
            if backend.is_gpu() {
                bail!("--method reference is the adaptive f64 CPU integrator; use it with --backend cpu");
            }
            wo.par_iter()
                .map(|&o| reference_albedo(&r, o, REFERENCE_RTOL))
                .collect()
        }
    };
    Ok(points
        .iter()
        .zip(est)
        .map(|(&(mu, phi), e)| {
            let delta = r.delta_albedo(mu);
            PointAlbedo {
                mu,
                phi,
                albedo: e.value + delta,
                delta,
                error: e.error,
                samples: e.evals,
            }
        })
        .collect())
}

/// Hemispherical albedo and Kulla–Conty's E_avg.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HemiAlbedo {
    /// Ē = (1/π) ∫ E(ωo) c_o dωo, delta lobe included.
    pub albedo: DVec3,
    /// The delta lobe's part of Ē.
    pub delta: DVec3,
    pub error: DVec3,
    /// E_avg = 2 ∫₀¹ E(μ, φo) μ dμ at the φo asked for (= Ē for an isotropic model).
    pub e_avg: DVec3,
    pub e_avg_error: DVec3,
    /// View directions integrated.
    pub directions: usize,
    /// Integrand evaluations in all.
    pub samples: u64,
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

/// Ē and E_avg by Gauss–Kronrod 7/15 on the μ panels of [`mu_breaks`] (for `reference`: adaptive
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
    let r = Reference::new(params, s.white_furnace);
    let breaks = mu_breaks();
    // The μ nodes of the fixed outer rule, in the order gk15 visits them.
    let mus: Vec<f64> = breaks
        .windows(2)
        .flat_map(|w| gk15_nodes(w[0], w[1]))
        .collect();
    let phis: Vec<f64> = if params.is_isotropic() {
        vec![phi]
    } else {
        let mut v = vec![phi];
        v.extend((1..PHI_O_NODES).map(|l| phi + TAU * l as f64 / PHI_O_NODES as f64));
        v
    };
    let table: Vec<Estimate> = match s.method.rule(s.samples, params) {
        Some(rule) => {
            let wo: Vec<DVec3> = phis
                .iter()
                .flat_map(|&p| mus.iter().map(move |&mu| view_direction(mu, p)))
                .collect();
            rule_albedo(backend, params, s.white_furnace, rule, &wo)?
        }
        None => {
            if backend.is_gpu() {
                bail!("--method reference is the adaptive f64 CPU integrator; use it with --backend cpu");
            }
            Vec::new()
        }
    };
    // 2∫ E(μ, φo) μ dμ at azimuth index k.
    let e_avg_at = |k: usize| -> Estimate {
        let p = phis[k];
        if table.is_empty() {
            let g = |mu: f64| {
                let e = reference_albedo(&r, view_direction(mu, p), REFERENCE_RTOL);
                Estimate {
                    value: 2.0 * mu * (e.value + r.delta_albedo(mu)),
                    error: 2.0 * mu * e.error,
                    evals: e.evals,
                }
            };
            // The outer tolerance relative to the Lambert-like scale of the directional ones.
            let first = gk15(&g, 0.0, 1.0);
            let tol = (REFERENCE_RTOL * first.value.abs().max_element()).max(f64::MIN_POSITIVE);
            adaptive(&g, &breaks, 10.0 * tol, true)
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
    if phis.len() == 1 {
        return Ok(HemiAlbedo {
            albedo: e_avg.value,
            delta: delta_avg,
            error: e_avg.error,
            e_avg: e_avg.value,
            e_avg_error: e_avg.error,
            directions: if table.is_empty() { 0 } else { mus.len() },
            samples: e_avg.evals,
        });
    }
    let rows: Vec<Estimate> = if table.is_empty() {
        (0..phis.len()).into_par_iter().map(e_avg_at).collect()
    } else {
        (0..phis.len()).map(e_avg_at).collect()
    };
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
    })
}

/// Everything `lobe albedo` prints: directional albedo at each point and the hemispherical one.
#[derive(Clone, Debug)]
pub struct AlbedoReport {
    pub method: Method,
    /// Nodes per direction asked for (0 for the adaptive reference).
    pub samples: usize,
    pub points: Vec<PointAlbedo>,
    pub hemispherical: HemiAlbedo,
    pub seconds: f64,
}

/// Directional albedo at `points` (μ, φ radians) and the hemispherical albedo (E_avg at `phi`).
pub fn albedo_report(
    backend: &Evaluator,
    params: &ParamSet,
    s: &Settings,
    points: &[(f64, f64)],
    phi: f64,
) -> Result<AlbedoReport> {
    let start = std::time::Instant::now();
    let pts = directional(backend, params, s, points)?;
    let hemi = hemispherical(backend, params, s, phi)?;
    Ok(AlbedoReport {
        method: s.method,
        samples: s.samples,
        points: pts,
        hemispherical: hemi,
        seconds: start.elapsed().as_secs_f64(),
    })
}

impl AlbedoReport {
    pub fn to_json(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        backend: &str,
    ) -> serde_json::Value {
        let a = |v: DVec3| serde_json::json!(v.to_array());
        let points: Vec<_> = self
            .points
            .iter()
            .map(|p| {
                serde_json::json!({
                    "mu": p.mu,
                    "theta_deg": p.mu.acos().to_degrees(),
                    "phi_deg": p.phi.to_degrees(),
                    "albedo": a(p.albedo),
                    "delta": a(p.delta),
                    "error_estimate": a(p.error),
                    "samples": p.samples,
                })
            })
            .collect();
        let h = &self.hemispherical;
        serde_json::json!({
            "model": params.model().name(),
            "parameters": params.to_json(),
            "white_furnace": white_furnace,
            "backend": backend,
            "method": self.method.name(),
            "samples": self.samples,
            "units": "albedo (dimensionless), linear RGB; albedo includes the delta lobe, delta is its part",
            "points": points,
            "hemispherical": {
                "albedo": a(h.albedo),
                "delta": a(h.delta),
                "error_estimate": a(h.error),
                "e_avg": a(h.e_avg),
                "e_avg_error_estimate": a(h.e_avg_error),
                "directions": h.directions,
                "samples": h.samples,
            },
            "seconds": self.seconds,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..40 {
            let rule = gauss_legendre(n);
            // ∫_{-1}^{1} x^k dx = 2/(k+1) for even k, exact up to degree 2n − 1.
            for k in (0..2 * n).step_by(2) {
                let s: f64 = rule.iter().map(|&(x, w)| w * x.powi(k as i32)).sum();
                let exact = 2.0 / (k as f64 + 1.0);
                assert!(
                    (s - exact).abs() < 1e-13 * exact.max(1.0) * (k as f64 + 1.0),
                    "n = {n}, k = {k}: {s} vs {exact}"
                );
            }
        }
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

    /// The V-cavity's kinks from the closed forms against a brute-force scan of where
    /// 2 c_h min(μi, μo)/c_d crosses 1, computed from the vectors.
    #[test]
    fn v_cavity_kinks_and_turns_are_where_the_masking_term_crosses_one() {
        let g = |mu: f64, mu_o: f64, dphi: f64| {
            let wi = view_direction(mu, dphi);
            let wo = view_direction(mu_o, 0.0);
            let s = wi + wo;
            2.0 * (s.z / s.length()) * mu.min(mu_o) / (0.5 * s.length()) - 1.0
        };
        const N: usize = 20_000;
        for mu_o in [0.05, 0.3, 0.5, 0.9] {
            let mut lines_with_kinks = Vec::new();
            for k in 1..200 {
                let mu = k as f64 / 200.0;
                let scan: Vec<f64> = (1..N)
                    .filter(|&j| {
                        let (a, b) = ((j - 1) as f64 * TAU / N as f64, j as f64 * TAU / N as f64);
                        g(mu, mu_o, a) * g(mu, mu_o, b) < 0.0
                    })
                    .map(|j| (j as f64 - 0.5) * TAU / N as f64)
                    .collect();
                let kinks = v_cavity_kinks(mu, mu_o);
                assert_eq!(
                    kinks.len(),
                    scan.len(),
                    "mu_o {mu_o} mu {mu}: {kinks:?} vs {scan:?}"
                );
                for (a, b) in kinks.iter().zip(&scan) {
                    assert!(
                        (a - b).abs() < TAU / N as f64,
                        "mu_o {mu_o} mu {mu}: {a} vs {b}"
                    );
                }
                lines_with_kinks.push(!kinks.is_empty());
            }
            // Each change between lines with and without kinks has a turn between them.
            let turns = v_cavity_turns(mu_o);
            for k in 1..lines_with_kinks.len() {
                if lines_with_kinks[k] != lines_with_kinks[k - 1] {
                    let (lo, hi) = (k as f64 / 200.0, (k + 1) as f64 / 200.0);
                    assert!(
                        turns.iter().any(|&t| lo <= t && t <= hi),
                        "mu_o {mu_o}: no turn in [{lo}, {hi}]: {turns:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn peak_frame_reaches_the_horizon_exactly() {
        for mu in [1.0, 0.5, 0.1, 1e-3] {
            let f = PeakFrame::new(view_direction(mu, 1.1));
            for k in 0..16 {
                let beta = -FRAC_PI_2 + TAU * k as f64 / 16.0;
                let z = f.dir(f.alpha_max(beta), beta).z;
                assert!(z.abs() < 1e-14, "mu {mu} beta {beta}: z = {z}");
            }
            assert!((f.dir(0.0, 0.3) - f.r).length() < 1e-15);
        }
    }
}
