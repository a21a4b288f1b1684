//! Directional and hemispherical albedo (docs/design.md §5), on either backend, with error
//! estimates.
//!
//! Directional albedo E(ωo) = ∫_H f(ωi, ωo) c_i dωi + the delta lobe's albedo (added exactly,
//! [`Reference::delta_albedo`](crate::model::Reference::delta_albedo)). Hemispherical albedo
//! Ē = (1/π) ∫_H E(ωo) c_o dωo, and Kulla–Conty's E_avg = 2 ∫₀¹ E(μ) μ dμ (at one φo; equal to
//! Ē for an isotropic model).
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
//!   direction of ωo, where every built-in lobe peaks, graded towards the peak in α and towards the
//!   horizon's fast turn in β: it resolves lobes of width 1e-3 rad with a few thousand nodes.
//! - `uniform`, `cosine`, `sampled`: plain Monte Carlo, N independent draws from the uniform
//!   hemisphere, the cosine density or the model's own sampler, E ≈ the mean of f c_i / p, with
//!   [`SAMPLED_T`] standard errors as the error and the variance per draw reported.
//! - `reference` (CPU, f64): nested adaptive Gauss–Kronrod (7/15) in the same coordinates,
//!   converged to [`REFERENCE_RTOL`]; the truth the others are tested against.
//!
//! Error estimates are upper bounds with a stated safety factor: a fixed rule is run at two
//! coarser levels too, and its error extrapolated from the three (`estimate`: geometric
//! convergence where the levels converge steadily, the last difference where they do not, and a
//! floor for what no level difference shows); the adaptive reference reports Σ|K15 − G7| over
//! its panels, which bounds the 7-point Gauss result and so, in practice, grossly over-bounds the
//! 15-point Kronrod one.
//! On the GPU, whose sums are f32, every estimate of a fixed rule also carries an f32 rounding
//! term, which the differences between levels miss: K′ ε |E| ([`GPU_MIRROR_ROUNDING_FACTOR`])
//! where the kernel forms ωi + ωo from nodes given as offsets from the mirror direction, K ε |E|
//! / μo ([`GPU_ROUNDING_FACTOR`]) elsewhere.

mod albedo;
mod backend;
mod cache;
mod estimate;
mod importance;
mod peak;
mod reference;
mod report;
mod rules;
mod sampled;
mod vcavity;

// The one-dimensional rules live in the core layer; the integrators reach them by this name.
use crate::quadrature as gauss;

pub use crate::quadrature::Node;
pub use albedo::{
    albedo_rows, directional, hemispherical, hemispherical_directions, HemiAlbedo, PointAlbedo,
};
pub use backend::{
    rule_albedo, rule_albedo_rows, rule_evaluations, sum_rule, sum_rules_rows, RowSums,
    GPU_MIRROR_ROUNDING_FACTOR, GPU_ROUNDING_FACTOR,
};
pub use estimate::{level_error, ESTIMATE_SAFETY, NOT_CONVERGING, SHARED_ERROR_FLOOR};
pub use gauss::{gauss_legendre, Estimate};
pub use importance::{Mixture, MAX_LOBES, REPLICATES, REPLICATE_T};
pub use reference::{
    reference_albedo, reference_albedo_mirror_frame, reference_albedo_within, Budget,
    REFERENCE_MAX_EVALS, REFERENCE_RTOL,
};
pub use report::{albedo_report, AlbedoReport};
pub use rules::Rule;
pub use sampled::{sampled_albedo, SampledAlbedo, Sampler, DEFAULT_SEED, SAMPLED_T};
pub use vcavity::{v_cavity_kinks, v_cavity_turns};

use crate::backend::Query;
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;

/// The plastic number ρ (ρ³ = ρ + 1), the generator of Roberts' R2 sequence (Roberts 2018, "The
/// unreasonable effectiveness of quasirandom sequences").
const PLASTIC: f64 = 1.324_717_957_244_746;

/// The view directions μ = cosθo at which albedo is reported when none are asked for: grazing,
/// oblique and normal view (`lobe albedo`, the demo's albedo table, `lobe tradeoff`).
pub const DEFAULT_MUS: [f64; 3] = [0.1, 0.5, 1.0];

/// The integrators an albedo job offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Cell midpoints in (θi, φi), sinθ-weighted.
    Midpoint,
    /// Gauss–Legendre in μi = cosθi × the trapezoid rule in φi.
    Gauss,
    /// Cosine-weighted low-discrepancy points (Roberts' R2 sequence).
    Qmc,
    /// Low-discrepancy points from a cosine and power-cosine mixture fitted to the model.
    Importance,
    /// Composite Gauss–Legendre in polar coordinates about the mirror direction (the default).
    Peak,
    /// Plain Monte Carlo with draws uniform over the hemisphere.
    Uniform,
    /// Plain Monte Carlo with cosine-distributed draws.
    Cosine,
    /// Plain Monte Carlo with the model's own sampler (`Backend::draws`).
    Sampled,
    /// The adaptive f64 Gauss–Kronrod integrator on the CPU, converged to [`REFERENCE_RTOL`].
    Reference,
}

impl Method {
    /// Every method, in the order `lobe albedo --help` lists them.
    pub const ALL: [Method; 9] = [
        Method::Midpoint,
        Method::Gauss,
        Method::Qmc,
        Method::Importance,
        Method::Peak,
        Method::Uniform,
        Method::Cosine,
        Method::Sampled,
        Method::Reference,
    ];

    /// The name `--method` takes.
    pub fn name(self) -> &'static str {
        match self {
            Method::Midpoint => "midpoint",
            Method::Gauss => "gauss",
            Method::Qmc => "qmc",
            Method::Importance => "importance",
            Method::Peak => "peak",
            Method::Uniform => "uniform",
            Method::Cosine => "cosine",
            Method::Sampled => "sampled",
            Method::Reference => "reference",
        }
    }

    /// Looks a method up by [`Method::name`]; the error lists the names.
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
    /// at every preset of every built-in model (tests/albedo.rs checks it against the reference):
    /// Cook–Torrance's V-cavity kinks are put on panel edges ([`v_cavity_kinks`],
    /// [`v_cavity_turns`]), which took its presets from 3e-5–7e-5 to ≤ 1.7e-7. `importance` is a
    /// sampling method: ~1e-4 at 65536 points, with a statistical error estimate.
    pub fn default_samples(self) -> usize {
        match self {
            Method::Midpoint | Method::Gauss => 1 << 16,
            Method::Qmc | Method::Importance => 1 << 16,
            Method::Peak => 1 << 16,
            Method::Uniform | Method::Cosine | Method::Sampled => 1 << 16,
            Method::Reference => 0,
        }
    }

    /// The sampler of a Monte Carlo method ([`sampled_albedo`]), None for the rules and the
    /// reference.
    pub fn sampler(self) -> Option<Sampler> {
        match self {
            Method::Uniform => Some(Sampler::Uniform),
            Method::Cosine => Some(Sampler::Cosine),
            Method::Sampled => Some(Sampler::Brdf),
            _ => None,
        }
    }

    /// The fixed rule with about `samples` nodes per direction for the model `params` (only
    /// `importance` looks at them), or None for the adaptive reference and the Monte Carlo
    /// methods ([`Method::sampler`]).
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
                extra_levels: params
                    .sampling_lobes()
                    .map_or(0, |l| peak::lobe_levels(l.exponents[0].max(l.exponents[1]))),
            }),
            Method::Reference | Method::Uniform | Method::Cosine | Method::Sampled => None,
        }
    }
}

/// The most quadrature nodes per view direction a job may ask for: 2^20, far beyond what any rule
/// needs for 1e-6 relative (the defaults are 2^16), with node buffers of 16 MiB per direction
/// and a peak of about 340 MB for `lobe albedo` at this count.
pub const MAX_SAMPLES: usize = 1 << 20;

/// ωo from μ = cosθo and φo (radians).
pub fn view_direction(mu: f64, phi: f64) -> DVec3 {
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), mu)
}

/// How to integrate: a method, its node count, the Monte Carlo methods' stream, and whether under
/// the white furnace.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// The integrator.
    pub method: Method,
    /// Nodes per view direction for a fixed rule (at least 16 are used); for the reference, the
    /// most integrand evaluations the job may spend, 0 for [`REFERENCE_MAX_EVALS`]
    /// ([`Settings::reference_evals`]).
    pub samples: usize,
    /// The stream the Monte Carlo methods ([`Method::sampler`]) draw from: draw i takes
    /// [`crate::random::draw_numbers`]`(seed, i, 0)`, so one seed gives the same directions and
    /// the same estimate every time, and another seed an independent estimate. The rules and the
    /// reference draw nothing and ignore it. [`DEFAULT_SEED`] by default.
    pub seed: u32,
    /// Evaluate with every specular Fresnel factor at 1 (docs/design.md §3).
    pub white_furnace: bool,
}

impl Settings {
    /// What these settings evaluate of `params`: the parameter set with the white-furnace switch.
    pub fn query<'a>(&self, params: &'a ParamSet) -> Query<'a> {
        Query::one(params).with_white_furnace(self.white_furnace)
    }

    /// The reference's budget of integrand evaluations for one job (every view direction of a
    /// directional job together, or the hemispherical albedo's nest): `samples`, or
    /// [`REFERENCE_MAX_EVALS`] when it is 0.
    pub fn reference_evals(&self) -> u64 {
        if self.samples == 0 {
            REFERENCE_MAX_EVALS
        } else {
            self.samples as u64
        }
    }

    /// [`Settings::query`] of several parameter sets of one model.
    pub fn query_sets<'a>(&self, sets: &'a [ParamSet]) -> Query<'a> {
        Query::sets(sets).with_white_furnace(self.white_furnace)
    }
}

impl Default for Settings {
    /// The peak rule at its default node count (1e-6 relative at every preset), no white furnace.
    fn default() -> Self {
        let method = Method::Peak;
        Settings {
            method,
            samples: method.default_samples(),
            seed: DEFAULT_SEED,
            white_furnace: false,
        }
    }
}
