//! `lobe tradeoff`: what each speed-for-accuracy choice costs and gains, measured on this device.
//!
//! Three sections, each with its own Pareto front (error against cost):
//!
//! **Evaluation** variants of one model and parameter set: the f64 CPU reference; the model as
//! given in f32 on the GPU; GLSL's plain `pow` instead of the careful cos^n formulation; and for
//! microfacet models (`cook_torrance` is `microfacet` with Beckmann, V-cavity and Schlick)
//! Schlick's vs the exact Fresnel factor, Walter's rational vs the exact Beckmann G1, and V-cavity
//! vs separable vs height-correlated Smith masking. Cost: ns per evaluation of a lobe table (GPU:
//! kernel time from timestamp queries; CPU: wall clock on all cores). Error: max and RMS relative
//! error of f over a dense grid against one truth, the f64 reference of the most exact
//! configuration of the same model (exact Fresnel — a conductor's where the material gives η and
//! κ, else a dielectric's from the IOR —, exact G1, height-correlated Smith: Heitz 2014 argues it
//! is the physically right form). So an approximation's figure includes both its modelling error
//! and its f32 error. Relative errors use a floor of [`REL_FLOOR`] × the largest |f| of the
//! truth, so that the far tail of a lobe (values a renderer cannot see) does not dominate.
//!
//! **Integration** variants: each fixed albedo rule of [`crate::integrate`] (`Method::ALL` but the
//! adaptive reference) × a ladder of node counts, on the GPU (f32 evaluation, the reduction
//! kernel) and on the CPU (f64). Cost: wall-clock ms per directional albedo E(ωo) from scratch —
//! node generation, evaluation and summation, and on the GPU the upload, dispatch and read-back —
//! the median over repeats of the mean over the view directions; the GPU's kernel time alone
//! (timestamp queries) is reported beside it. The rule's own error estimate (a second, coarser
//! run, which `lobe albedo` adds) is not part of it. Error: the largest absolute error of E(μ)
//! over the view directions and channels against [`crate::integrate::reference_albedo`] (adaptive
//! Gauss–Kronrod in f64, converged to
//! [`REFERENCE_RTOL`](crate::integrate::REFERENCE_RTOL)), computed once per μ. The model is
//! integrated as given (no truth swap): the figure is the quadrature's error (and on the GPU its
//! f32 error), not the model's. Beside the rules, the Monte Carlo methods (uniform, cosine and
//! the model's own sampler, [`crate::integrate::sampled_albedo`]) at the same ladder of draw
//! counts, timed and judged alike, each row with its variance per draw.
//!
//! **Table resolution**: E(μ) from a tabulated isotropic lobe table (θi, θo, Δφ) of N × N × 2N
//! cells (square cells at the equator; the centring of docs/design.md §4), as a user holding
//! such a table would compute it: linear interpolation in θo between the two nearest cell
//! centres (held constant beyond the first and last centre; E is even in θo at the pole, so that
//! costs O(Δθ²) there too), and cell sums in (θi, Δφ) with weights cosθi sinθi ΔθΔφ, doubled for
//! Δφ ∈ [π, 2π] (an isotropic lobe is even in Δφ). Cost: wall-clock ms to generate the table on
//! the backend and integrate it at every view direction. Error as for integration. Delta lobes
//! are not on a grid (docs/design.md §3): both sections compare the non-delta part, whose
//! reference excludes them too.
//!
//! The files: this one holds the sections, the rows and their Pareto fronts, the options, the
//! report and [`run`]; `eval.rs` the evaluation variants and their errors; `albedo.rs` what the
//! two albedo sections share (set-up, reference, error); `integration.rs` and `resolution.rs`
//! those two sections; `output.rs` the report as text tables, CSV and JSON.

mod eval;
mod integration;
mod output;
mod resolution;
mod setup;

pub use eval::{
    as_microfacet, conductor_of, error_grid_for, eval_variants, measure_eval, relative_errors,
    truth_table, variant_table, EvalVariant, REL_FLOOR,
};
pub use integration::{
    integration_variants, measure_integration, rule_albedo_once, IntegrationVariant,
};
pub use resolution::{measure_tables, table_albedo, table_grid};
pub use setup::{albedo_errors, reference_albedos, reference_albedos_within, AlbedoSetup};

use crate::backend::Precision;
use crate::eval::Evaluator;
use crate::grid::Grid;
use crate::integrate::Estimate;
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;
use serde::Serialize;

/// The sections of the trade-off table; each has its own Pareto front.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Section {
    /// Variants of evaluating f itself: precision, Fresnel, G1, masking and pow (ns per
    /// evaluation).
    Evaluation,
    /// Albedo quadrature rules × node counts on each backend (ms per directional albedo).
    Integration,
    /// E(μ) from lobe tables of growing resolution (ms per table).
    TableResolution,
}

impl Section {
    /// Every section, in the order reports list them.
    pub const ALL: [Section; 3] = [
        Section::Evaluation,
        Section::Integration,
        Section::TableResolution,
    ];

    /// The section's name on the command line and in the reports: `evaluation`, `integration` or
    /// `table-resolution`.
    pub fn name(self) -> &'static str {
        match self {
            Section::Evaluation => "evaluation",
            Section::Integration => "integration",
            Section::TableResolution => "table-resolution",
        }
    }

    /// The section called `name`; an unknown name is an error that lists the sections.
    pub fn from_name(name: &str) -> Result<Section> {
        Section::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "unknown section '{name}'; the sections are: {}",
                    Section::ALL.map(Section::name).join(", ")
                )
            })
    }

    /// The unit of [`Row::cost`] in this section: `ns/eval`, `ms/albedo` or `ms/table`.
    pub fn cost_unit(self) -> &'static str {
        match self {
            Section::Evaluation => "ns/eval",
            Section::Integration => "ms/albedo",
            Section::TableResolution => "ms/table",
        }
    }

    /// What [`Row::max_error`] measures in this section.
    pub fn error_kind(self) -> &'static str {
        match self {
            Section::Evaluation => "relative error of f",
            Section::Integration | Section::TableResolution => "absolute error of E(mu)",
        }
    }
}

/// One measured variant of a section: its cost, its error and whether it is on the Pareto front.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// The section the variant belongs to.
    pub section: Section,
    /// What was measured, e.g. `f32 GPU, Schlick F` or `table 16x16x32, f64 CPU`.
    pub variant: String,
    /// The evaluator that ran it: `gpu (device)` or `cpu (f64 reference)`.
    pub backend: String,
    /// Integration: quadrature nodes (or Monte Carlo draws) per albedo (mean over the view directions); table
    /// resolution: table cells; evaluation: none.
    pub samples: Option<u64>,
    /// Median over repeats, in `cost_unit` (see the module notes for what each section times).
    pub cost: f64,
    /// [`Section::cost_unit`] of the row's section.
    pub cost_unit: String,
    /// Integration on the GPU: kernel time alone (timestamp queries), in `cost_unit`.
    pub kernel_cost: Option<f64>,
    /// The error the Pareto front uses: max relative error of f (evaluation) or max absolute
    /// error of E(μ) over view directions and channels (integration, table resolution).
    pub max_error: f64,
    /// RMS of the same errors.
    pub rms_error: f64,
    /// [`Section::error_kind`] of the row's section.
    pub error_kind: String,
    /// On its section's Pareto front: no other row of the section beats it ([`mark_pareto`]).
    pub pareto: bool,
    /// Integration by Monte Carlo draws (uniform, cosine or the model's own sampler): the
    /// variance of one draw's weight, the largest over the view directions and channels, what
    /// a sampler is judged by; None for the rules and the other sections.
    pub variance_per_sample: Option<f64>,
}

/// Errors within this relative margin of each other count as equal when the Pareto front is
/// marked. The f32 and f64 runs of one rule differ by rounding (~1e-7 of E) and would otherwise
/// both sit on the front, the slower one for an "improvement" nobody can use; a user chooses
/// between errors that differ by factors, and 1 % is far below those and far above rounding.
pub const ERROR_TIE_RTOL: f64 = 0.01;

/// Marks, within each section, the rows that no other row beats. Row j beats row i when it costs
/// no more and errs no more (errors within [`ERROR_TIE_RTOL`] count as equal), and is strictly
/// cheaper or clearly more accurate. The cheapest row (the most accurate of equally cheap ones)
/// is always on the front, and along the front, cost rises as error falls by more than the margin.
pub fn mark_pareto(rows: &mut [Row]) {
    let snapshot: Vec<(Section, f64, f64)> = rows
        .iter()
        .map(|r| (r.section, r.cost, r.max_error))
        .collect();
    let beats = |j: (f64, f64), i: (f64, f64)| {
        let ((cj, ej), (ci, ei)) = (j, i);
        let no_worse = cj <= ci && ej <= ei * (1.0 + ERROR_TIE_RTOL);
        let clearly_more_accurate = ej * (1.0 + ERROR_TIE_RTOL) < ei;
        no_worse && (cj < ci || clearly_more_accurate)
    };
    for (i, r) in rows.iter_mut().enumerate() {
        let (section, cost, err) = snapshot[i];
        r.pareto = !snapshot
            .iter()
            .enumerate()
            .any(|(j, &(s, c, e))| j != i && s == section && beats((c, e), (cost, err)));
    }
}

/// What `lobe tradeoff` measures.
#[derive(Clone, Debug)]
pub struct Options {
    /// The sections to measure, in the order they are reported.
    pub sections: Vec<Section>,
    /// Evaluation errors are measured on this grid ([`error_grid_for`] applied).
    pub error_grid: Grid,
    /// Evaluation costs are timed on this grid.
    pub timing_grid: Grid,
    /// Timed runs per evaluation variant.
    pub eval_repeats: usize,
    /// The view directions, node counts and table resolutions of the integration and
    /// table-resolution sections.
    pub albedo: AlbedoSetup,
}

/// Everything measured, ready to print or plot.
#[derive(Clone, Debug)]
pub struct Report {
    /// `gold cook_torrance` or the model's name.
    pub subject: String,
    /// The parameter set measured, as given.
    pub params: ParamSet,
    /// The evaluation section's truth.
    pub truth: ParamSet,
    /// The Vulkan device, where the GPU was measured.
    pub device: Option<String>,
    /// The options the report was measured with.
    pub options: Options,
    /// The reference E(μ) (delta excluded) at `options.albedo.mus`, if an albedo section ran.
    pub reference: Vec<Estimate>,
    /// Every measured variant, section by section.
    pub rows: Vec<Row>,
    /// Sections left out and why.
    pub notes: Vec<String>,
}

/// Runs the sections of `opts` for `params` on `backend`: where it is the GPU, the GPU variants
/// run there and the CPU variants on the CPU (stopped by the same cancellation token); on the CPU
/// alone otherwise. `progress` hears (step, steps, what) before each variant.
pub fn run(
    backend: &Evaluator,
    params: &ParamSet,
    material: Option<&str>,
    opts: &Options,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Report> {
    opts.albedo.check()?;
    params
        .model()
        .require_reference("lobe tradeoff (its errors are against the f64 reference)")?;
    let (truth, variants) = eval_variants(params, conductor_of(material));
    // The f32 backend where there is one; its variants are left out without it.
    let gpu = (backend.precision() == Precision::F32).then_some(*backend);
    let backends: Vec<Evaluator> = match (gpu, backend.cancel_token()) {
        (None, _) => vec![*backend],
        (Some(_), Some(cancel)) => vec![*backend, Evaluator::cpu().with_cancel(cancel)],
        (Some(_), None) => vec![*backend, Evaluator::cpu()],
    };
    let mut notes = Vec::new();
    let has = |s: Section| opts.sections.contains(&s);
    let tables = has(Section::TableResolution) && params.is_isotropic();
    if has(Section::TableResolution) && !tables {
        notes.push(
            "table-resolution: left out, the parameter set is anisotropic and an isotropic table \
             (theta_i, theta_o, dphi) cannot hold it"
                .to_string(),
        );
    }
    let steps = if has(Section::Evaluation) {
        variants.iter().filter(|v| !v.gpu || gpu.is_some()).count()
    } else {
        0
    } + if has(Section::Integration) {
        backends.len() * integration_variants(params, &opts.albedo.samples).len()
    } else {
        0
    } + if tables {
        backends.len() * opts.albedo.table_res.len()
    } else {
        0
    } + usize::from(has(Section::Integration) || tables);
    let mut step = 0usize;
    let mut tick = |what: &str| {
        progress(step, steps, what);
        step += 1;
    };
    let mut rows = Vec::new();
    if has(Section::Evaluation) {
        rows.extend(measure_eval(
            backend,
            &truth,
            &variants,
            &opts.error_grid,
            &opts.timing_grid,
            opts.eval_repeats,
            &mut tick,
        )?);
    }
    let mut reference = Vec::new();
    if has(Section::Integration) || tables {
        tick("reference albedo");
        reference = reference_albedos_within(params, &opts.albedo.mus, backend.cancel_token())?;
        let values: Vec<DVec3> = reference.iter().map(|e| e.value).collect();
        if has(Section::Integration) {
            rows.extend(measure_integration(
                &backends,
                params,
                &opts.albedo,
                &values,
                &mut tick,
            )?);
        }
        if tables {
            rows.extend(measure_tables(
                &backends,
                params,
                &opts.albedo,
                &values,
                &mut tick,
            )?);
        }
    }
    Ok(Report {
        subject: match material {
            Some(m) => format!("{m} {}", params.model().name()),
            None => params.model().name().to_string(),
        },
        params: params.clone(),
        truth,
        device: gpu.and_then(|g| g.device()),
        options: opts.clone(),
        reference,
        rows,
        notes,
    })
}

impl Report {
    /// The rows of one section, in the order they were measured.
    pub fn rows_of(&self, section: Section) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(move |r| r.section == section)
    }

    /// The sections that have rows, in order.
    pub fn sections(&self) -> Vec<Section> {
        Section::ALL
            .into_iter()
            .filter(|&s| self.rows_of(s).next().is_some())
            .collect()
    }
}
