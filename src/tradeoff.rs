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
//! Gauss–Kronrod in f64, converged to [`REFERENCE_RTOL`]), computed once per μ. The model is
//! integrated as given (no truth swap): the figure is the quadrature's error (and on the GPU its
//! f32 error), not the model's.
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

use crate::bench::{self, median};
use crate::eval::Evaluator;
use crate::gpu::Gpu;
use crate::grid::{theta_cell, Grid};
use crate::input::BadInput;
use crate::integrate::{
    reference_albedo, sum_rule, view_direction, Estimate, Method, Rule, DEFAULT_MUS, REFERENCE_RTOL,
};
use crate::model::microfacet::MicrofacetConfig;
use crate::model::{Model, ParamSet, Reference, Value};
use anyhow::Result;
use glam::DVec3;
use serde::Serialize;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

/// Relative errors are |g − t| / max(|t|, REL_FLOOR · max|t|).
pub const REL_FLOOR: f64 = 1e-3;

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
    /// Integration: quadrature nodes per albedo (mean over the view directions); table
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
}

/// One evaluation variant: a parameter set, where it runs, and whether it uses the fast pow.
#[derive(Clone, Debug)]
pub struct EvalVariant {
    /// The variant's label in the report, e.g. `f32 GPU, exact`.
    pub name: String,
    /// The parameter set evaluated (for microfacet models, with the variant's component choices).
    pub params: ParamSet,
    /// Run in f32 on the GPU; otherwise the f64 reference on the CPU.
    pub gpu: bool,
    /// Evaluate cosⁿ lobes with GLSL's plain `pow` instead of the careful formulation (GPU only).
    pub fast_pow: bool,
}

/// A microfacet parameter set equal to `p` (cook_torrance is converted), or None for other models.
pub fn as_microfacet(p: &ParamSet) -> Option<ParamSet> {
    p.as_microfacet()
}

fn with_choice(p: &ParamSet, key: &str, value: &str) -> ParamSet {
    let mut q = p.clone();
    q.set_text(&format!("{key}={value}"))
        .expect("a valid component choice");
    q
}

/// The truth and the evaluation variants for `params`. `conductor` gives (η, κ) for the exact
/// Fresnel factor of a metal.
pub fn eval_variants(
    params: &ParamSet,
    conductor: Option<(Value, Value)>,
) -> (ParamSet, Vec<EvalVariant>) {
    let v = |name: &str, params: ParamSet, gpu: bool, fast_pow: bool| EvalVariant {
        name: name.to_string(),
        params,
        gpu,
        fast_pow,
    };
    let Some(mf) = as_microfacet(params) else {
        let mut out = vec![
            v("f64 CPU reference", params.clone(), false, false),
            v("f32 GPU", params.clone(), true, false),
        ];
        if params.model().info().pow_lobe {
            out.push(v("f32 GPU, fast pow", params.clone(), true, true));
        }
        return (params.clone(), out);
    };
    let exact_fresnel = |p: &ParamSet| match conductor {
        Some((eta, k)) => {
            let mut q = with_choice(p, "fresnel", "conductor");
            q.set("eta", eta).expect("eta");
            q.set("k", k).expect("k");
            q
        }
        None => with_choice(p, "fresnel", "dielectric"),
    };
    let truth = with_choice(
        &exact_fresnel(&with_choice(&mf, "beckmann_g1", "exact")),
        "masking",
        "smith_correlated",
    );
    let beckmann = mf.get("distribution") == Value::Choice("beckmann");
    let mut out = vec![
        v("f64 CPU, as given", mf.clone(), false, false),
        v("f32 GPU, as given", mf.clone(), true, false),
        v("f64 CPU, exact (truth)", truth.clone(), false, false),
        v("f32 GPU, exact", truth.clone(), true, false),
        v(
            "f32 GPU, Schlick F",
            with_choice(&truth, "fresnel", "schlick"),
            true,
            false,
        ),
        v(
            "f32 GPU, V-cavity G",
            with_choice(&truth, "masking", "v_cavity"),
            true,
            false,
        ),
        v(
            "f32 GPU, separable Smith G",
            with_choice(&truth, "masking", "smith_separable"),
            true,
            false,
        ),
    ];
    if beckmann {
        out.push(v(
            "f32 GPU, rational G1",
            with_choice(&truth, "beckmann_g1", "rational"),
            true,
            false,
        ));
        out.push(v(
            "f32 GPU, separable + rational G1",
            with_choice(
                &with_choice(&truth, "beckmann_g1", "rational"),
                "masking",
                "smith_separable",
            ),
            true,
            false,
        ));
    }
    (truth, out)
}

/// (max, RMS) relative error of `got` (cells × rgb) against `truth`, with the floor above.
pub fn relative_errors(got: &[f32], truth: &[f64]) -> (f64, f64) {
    let peak = truth.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    let floor = (REL_FLOOR * peak).max(f64::MIN_POSITIVE);
    let (mut max, mut sum2) = (0.0f64, 0.0f64);
    for (g, t) in got.iter().zip(truth) {
        let e = (*g as f64 - t).abs() / t.abs().max(floor);
        max = max.max(e);
        sum2 += e * e;
    }
    (max, (sum2 / truth.len().max(1) as f64).sqrt())
}

/// The truth on `grid`, in table order (cells × rgb), in f64.
pub fn truth_table(truth: &ParamSet, grid: &Grid) -> Vec<f64> {
    let r = Reference::new(truth, false);
    let (wi, wo) = (grid.wi_list(), grid.wo_list());
    let mut out = Vec::with_capacity(wi.len() * wo.len() * 3);
    for a in &wi {
        for b in &wo {
            out.extend(r.eval(*a, *b).to_array());
        }
    }
    out
}

/// A variant's table on `grid` (cells × rgb, f32 as the backend produced it, f64 rounded to f32
/// for the CPU).
pub fn variant_table(gpu: Option<&Gpu>, v: &EvalVariant, grid: &Grid) -> Result<Vec<f32>> {
    let mut out = Vec::new();
    let mut sink = |_: u64, values: &[f32]| {
        out.extend_from_slice(values);
        Ok(())
    };
    match (v.gpu, gpu) {
        (true, Some(g)) => {
            g.set_fast_pow(v.fast_pow);
            let r = Evaluator::gpu(g).eval_table(&v.params, false, grid, &mut sink);
            g.set_fast_pow(false);
            r?;
        }
        (true, None) => anyhow::bail!("variant '{}' needs the GPU backend", v.name),
        (false, _) => Evaluator::cpu().eval_table(&v.params, false, grid, &mut sink)?,
    }
    Ok(out)
}

/// Measures every evaluation variant: error on `error_grid`, cost on `timing_grid`.
pub fn measure_eval(
    gpu: Option<&Gpu>,
    truth: &ParamSet,
    variants: &[EvalVariant],
    error_grid: &Grid,
    timing_grid: &Grid,
    repeats: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    let t = truth_table(truth, error_grid);
    let mut rows = Vec::new();
    for v in variants {
        if v.gpu && gpu.is_none() {
            continue;
        }
        progress(&v.name);
        let got = variant_table(gpu, v, error_grid)?;
        let (max_rel_error, rms_rel_error) = relative_errors(&got, &t);
        let (cost, backend) = match (v.gpu, gpu) {
            (true, Some(g)) => {
                g.set_fast_pow(v.fast_pow);
                let m = bench::measure(&Evaluator::gpu(g), &v.params, timing_grid, repeats);
                g.set_fast_pow(false);
                let m = m?;
                (1e9 / m.kernel_per_s.unwrap_or(m.wall_per_s), m.backend)
            }
            _ => {
                let m = bench::measure(&Evaluator::cpu(), &v.params, timing_grid, repeats)?;
                (1e9 / m.wall_per_s, m.backend)
            }
        };
        rows.push(Row {
            section: Section::Evaluation,
            variant: v.name.clone(),
            backend,
            samples: None,
            cost,
            cost_unit: Section::Evaluation.cost_unit().into(),
            kernel_cost: None,
            max_error: max_rel_error,
            rms_error: rms_rel_error,
            error_kind: Section::Evaluation.error_kind().into(),
            pareto: false,
        });
    }
    mark_pareto(&mut rows);
    Ok(rows)
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

// ---------------------------------------------------------------------------------------------
// Integration and table-resolution variants.

/// What the integration and table-resolution sections measure.
#[derive(Clone, Debug, Serialize)]
pub struct AlbedoSetup {
    /// View directions μ = cosθo (φo = 0), each in (0, 1].
    pub mus: Vec<f64>,
    /// The ladder of node counts asked of each rule (a rule may round them: see
    /// [`Method::rule`]; rules that come out equal are measured once).
    pub samples: Vec<usize>,
    /// Table resolutions N: N × N × 2N cells in (θi, θo, Δφ).
    pub table_res: Vec<usize>,
    /// Timed runs per variant (the median is reported), after one untimed run that builds the
    /// pipeline and gives the value whose error is reported.
    pub repeats: usize,
}

impl AlbedoSetup {
    /// What `lobe tradeoff` measures by default: grazing, oblique and normal view; 2^8 … 2^16
    /// nodes in steps of 4; tables of 8 … 128 cells per θ axis.
    pub fn standard() -> AlbedoSetup {
        AlbedoSetup {
            mus: DEFAULT_MUS.to_vec(),
            samples: vec![1 << 8, 1 << 10, 1 << 12, 1 << 14, 1 << 16],
            table_res: vec![8, 16, 32, 64, 128],
            repeats: 5,
        }
    }

    /// `--quick`: the same shape at a fraction of the time (tests, a first look).
    pub fn quick() -> AlbedoSetup {
        AlbedoSetup {
            mus: DEFAULT_MUS.to_vec(),
            samples: vec![1 << 8, 1 << 10, 1 << 12],
            table_res: vec![8, 16, 32],
            repeats: 2,
        }
    }

    /// Checks every μ (in (0, 1]), node count (in [16, 4194304]), table resolution (in [2, 512])
    /// and that `repeats` is at least 1.
    pub fn check(&self) -> Result<()> {
        if self.mus.is_empty() {
            return Err(BadInput::new("mus", "give at least one view direction mu").into());
        }
        for &mu in &self.mus {
            if !(mu > 0.0 && mu <= 1.0) {
                return Err(BadInput::new(
                    "mus",
                    format!("view direction mu = {mu}: expected mu = cos(theta_o) in (0, 1]"),
                )
                .into());
            }
        }
        for &n in &self.samples {
            if !(16..=1 << 22).contains(&n) {
                return Err(BadInput::new(
                    "samples",
                    format!("{n} nodes per albedo: node counts lie in [16, 4194304]"),
                )
                .into());
            }
        }
        for &n in &self.table_res {
            if !(2..=512).contains(&n) {
                return Err(BadInput::new(
                    "table_res",
                    format!(
                        "table resolution {n}: resolutions lie in [2, 512] cells per theta axis"
                    ),
                )
                .into());
            }
        }
        if self.repeats == 0 {
            return Err(BadInput::new("repeats", "0 timed runs: time at least one run").into());
        }
        Ok(())
    }
}

/// The reference E(μ) (delta lobe excluded) at each view direction of `setup`, φo = 0.
pub fn reference_albedos(params: &ParamSet, mus: &[f64]) -> Vec<Estimate> {
    let r = Reference::new(params, false);
    mus.iter()
        .map(|&mu| reference_albedo(&r, view_direction(mu, 0.0), REFERENCE_RTOL))
        .collect()
}

/// (max, RMS) absolute error of `got` against `truth` over directions and channels.
pub fn albedo_errors(got: &[DVec3], truth: &[DVec3]) -> (f64, f64) {
    let (mut max, mut sum2, mut n) = (0.0f64, 0.0f64, 0usize);
    for (g, t) in got.iter().zip(truth) {
        for e in (*g - *t).abs().to_array() {
            max = max.max(e);
            sum2 += e * e;
            n += 1;
        }
    }
    (max, (sum2 / n.max(1) as f64).sqrt())
}

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
    let (value, n) = sum_rule(backend, params, false, *rule, &[wo])?
        .pop()
        .expect("one sum per direction");
    Ok((value, n as usize))
}

/// "f32 GPU" or "f64 CPU": the precision and place of a backend, for variant names.
fn backend_tag(backend: &Evaluator) -> &'static str {
    if backend.is_gpu() {
        "f32 GPU"
    } else {
        "f64 CPU"
    }
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
                if let Some(g) = backend.as_gpu() {
                    g.take_gpu_time();
                }
                let t = Instant::now();
                for &o in &wo {
                    std::hint::black_box(rule_albedo_once(backend, params, &v.rule, o)?);
                }
                walls.push(t.elapsed().as_secs_f64() * 1e3 / wo.len() as f64);
                if let Some(g) = backend.as_gpu() {
                    if let Some(k) = g.take_gpu_time() {
                        kernels.push(k.as_secs_f64() * 1e3 / wo.len() as f64);
                    }
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
            });
        }
    }
    mark_pareto(&mut rows);
    Ok(rows)
}

/// The isotropic grid of table resolution `n`: n × n × 2n cells in (θi, θo, Δφ).
pub fn table_grid(n: usize) -> Grid {
    Grid::Isotropic {
        n_theta_i: n,
        n_theta_o: n,
        n_dphi: 2 * n,
    }
}

/// E(μ) (delta excluded) from an isotropic lobe table in table order (θi, θo, Δφ, rgb): linear
/// interpolation in θo between the two nearest cell centres (held constant beyond the first and
/// the last), midpoint cell sums in θi and Δφ with dω = sinθi dθi dΔφ and the cosine cosθi, the
/// Δφ ∈ [0, π] half doubled for the even other half.
pub fn table_albedo(
    table: &[f32],
    n_theta_i: usize,
    n_theta_o: usize,
    n_dphi: usize,
    mu: f64,
) -> DVec3 {
    debug_assert_eq!(table.len(), n_theta_i * n_theta_o * n_dphi * 3);
    let d_theta_o = FRAC_PI_2 / n_theta_o as f64;
    // Position of θo in units of cells, from the first centre.
    let x = (mu.clamp(0.0, 1.0).acos() / d_theta_o - 0.5).clamp(0.0, (n_theta_o - 1) as f64);
    let k0 = x.floor() as usize;
    let k1 = (k0 + 1).min(n_theta_o - 1);
    let t = x - k0 as f64;
    let w_dphi = 2.0 * PI / n_dphi as f64;
    let d_theta_i = FRAC_PI_2 / n_theta_i as f64;
    let mut sum = DVec3::ZERO;
    for i in 0..n_theta_i {
        let theta_i = theta_cell(i, n_theta_i);
        let w = theta_i.cos() * theta_i.sin() * d_theta_i * w_dphi;
        let row = |k: usize| {
            let base = ((i * n_theta_o + k) * n_dphi) * 3;
            let mut s = DVec3::ZERO;
            for c in table[base..base + n_dphi * 3].chunks_exact(3) {
                s += DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
            }
            s
        };
        sum += w * ((1.0 - t) * row(k0) + t * row(k1));
    }
    sum
}

/// Measures E(μ) from tables at each resolution of `setup` on each backend.
pub fn measure_tables(
    backends: &[Evaluator],
    params: &ParamSet,
    setup: &AlbedoSetup,
    truth: &[DVec3],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    if !params.is_isotropic() {
        return Err(BadInput::new(
            "sections",
            "the table-resolution section needs an isotropic parameter set (the isotropic table \
             (theta_i, theta_o, dphi) cannot hold this one); leave that section out",
        )
        .into());
    }
    let mut rows = Vec::new();
    for backend in backends {
        for &n in &setup.table_res {
            let grid = table_grid(n);
            let cells = grid.cells().unwrap_or(0);
            progress(&format!("table {n} {}", backend_tag(backend)));
            let run = || -> Result<Vec<DVec3>> {
                let mut table = Vec::with_capacity(cells as usize * 3);
                backend.eval_table(params, false, &grid, &mut |_, v| {
                    table.extend_from_slice(v);
                    Ok(())
                })?;
                Ok(setup
                    .mus
                    .iter()
                    .map(|&mu| table_albedo(&table, n, n, 2 * n, mu))
                    .collect())
            };
            let values = run()?;
            let (max_error, rms_error) = albedo_errors(&values, truth);
            let mut walls = Vec::new();
            for _ in 0..setup.repeats {
                let t = Instant::now();
                std::hint::black_box(run()?);
                walls.push(t.elapsed().as_secs_f64() * 1e3);
            }
            rows.push(Row {
                section: Section::TableResolution,
                variant: format!("table {n}x{n}x{}, {}", 2 * n, backend_tag(backend)),
                backend: backend.name(),
                samples: Some(cells),
                cost: median(walls),
                cost_unit: Section::TableResolution.cost_unit().into(),
                kernel_cost: None,
                max_error,
                rms_error,
                error_kind: Section::TableResolution.error_kind().into(),
                pareto: false,
            });
        }
    }
    mark_pareto(&mut rows);
    Ok(rows)
}

// ---------------------------------------------------------------------------------------------
// The whole measurement and its report.

/// The exact Fresnel factor of a material whose microfacet preset is a conductor: its (η, κ).
pub fn conductor_of(material: Option<&str>) -> Option<(Value, Value)> {
    let p =
        crate::material::preset(material?, Model::Microfacet(MicrofacetConfig::DEFAULT)).ok()?;
    (p.get("fresnel") == Value::Choice("conductor")).then(|| (p.get("eta"), p.get("k")))
}

/// The grid errors are measured on: `grid` (isotropic) as given for an isotropic parameter set,
/// else the full grid of the same angular density.
pub fn error_grid_for(params: &ParamSet, grid: Grid) -> Grid {
    match grid {
        Grid::Isotropic {
            n_theta_i,
            n_theta_o,
            n_dphi,
        } if !params.is_isotropic() => Grid::Full {
            n_theta_i,
            n_phi_i: 2 * n_dphi,
            n_theta_o,
            n_phi_o: 2 * n_dphi,
        },
        g => g,
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

/// Runs the sections of `opts` for `params`: on the GPU and the CPU where `gpu` is given, on the
/// CPU alone otherwise. `progress` hears (step, steps, what) before each variant.
pub fn run(
    gpu: Option<&Gpu>,
    params: &ParamSet,
    material: Option<&str>,
    opts: &Options,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Report> {
    opts.albedo.check()?;
    let (truth, variants) = eval_variants(params, conductor_of(material));
    let backends: Vec<Evaluator> = match gpu {
        Some(g) => vec![Evaluator::gpu(g), Evaluator::cpu()],
        None => vec![Evaluator::cpu()],
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
            gpu,
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
        reference = reference_albedos(params, &opts.albedo.mus);
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
        device: gpu.map(|g| g.device().name().to_string()),
        options: opts.clone(),
        reference,
        rows,
        notes,
    })
}

/// A CSV field, quoted where it holds a comma or a quote (variant names do).
fn csv_field(s: &str) -> String {
    if s.contains(',') || s.contains('"') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
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

    /// A line per section: what its cost and error mean.
    pub fn section_note(&self, section: Section) -> String {
        let o = &self.options;
        match section {
            Section::Evaluation => format!(
                "cost: ns per evaluation of a {}-cell lobe table, median of {} runs (GPU: kernel \
                 time from timestamp queries; CPU: wall clock, all cores); error: relative error of f \
                 over {} cells ({} grid), floor {} x max|f|, against f64 {} {}",
                o.timing_grid.cells().unwrap_or(0),
                o.eval_repeats,
                o.error_grid.cells().unwrap_or(0),
                o.error_grid.name(),
                REL_FLOOR,
                self.truth.model().name(),
                self.truth.to_text()
            ),
            Section::Integration => format!(
                "cost: wall-clock ms per directional albedo from scratch (nodes, evaluation, sum; \
                 GPU: upload, dispatch, read-back too; kernel ms: timestamp queries), median of {} \
                 runs; error: max |E - E_ref| over mu = {} and channels",
                o.albedo.repeats,
                self.mu_list()
            ),
            Section::TableResolution => format!(
                "cost: wall-clock ms to generate an N x N x 2N isotropic table (theta_i, theta_o, \
                 dphi) and integrate it at every mu (linear in theta_o, cell sums in theta_i and \
                 dphi), median of {} runs; error: max |E - E_ref| over mu = {} and channels",
                o.albedo.repeats,
                self.mu_list()
            ),
        }
    }

    fn mu_list(&self) -> String {
        self.options
            .albedo
            .mus
            .iter()
            .map(|m| format!("{m}"))
            .collect::<Vec<_>>()
            .join(",")
    }

    /// The reference line of the albedo sections.
    pub fn reference_note(&self) -> Option<String> {
        if self.reference.is_empty() {
            return None;
        }
        let values: Vec<String> = self
            .options
            .albedo
            .mus
            .iter()
            .zip(&self.reference)
            .map(|(mu, e)| {
                let v = e.value;
                format!("E({mu}) = {:.9},{:.9},{:.9}", v.x, v.y, v.z)
            })
            .collect();
        let est = self
            .reference
            .iter()
            .map(|e| e.error.max_element())
            .fold(0.0, f64::max);
        Some(format!(
            "reference (adaptive Gauss-Kronrod, f64, rtol {REFERENCE_RTOL:e}, delta lobes excluded): {}; its error estimate <= {est:.1e}",
            values.join("; ")
        ))
    }

    /// The whole report as JSON: subject, parameters, truth, grids, albedo set-up and reference,
    /// sections with their notes, Pareto fronts and rows.
    pub fn to_json(&self) -> serde_json::Value {
        let o = &self.options;
        let reference: Vec<_> = o
            .albedo
            .mus
            .iter()
            .zip(&self.reference)
            .map(|(mu, e)| {
                serde_json::json!({
                    "mu": mu,
                    "albedo": e.value.to_array(),
                    "error_estimate": e.error.to_array(),
                })
            })
            .collect();
        let fronts: serde_json::Map<String, serde_json::Value> = self
            .sections()
            .into_iter()
            .map(|s| {
                let names: Vec<&str> = self
                    .rows_of(s)
                    .filter(|r| r.pareto)
                    .map(|r| r.variant.as_str())
                    .collect();
                (s.name().to_string(), serde_json::json!(names))
            })
            .collect();
        serde_json::json!({
            "model": self.params.model().name(),
            "subject": self.subject,
            "parameters": self.params.to_json(),
            "device": self.device,
            "truth": {"model": self.truth.model().name(), "parameters": self.truth.to_json()},
            "error_grid": o.error_grid.shape(),
            "timing_grid": o.timing_grid.shape(),
            "relative_error_floor": REL_FLOOR,
            "albedo": {
                "mu": o.albedo.mus,
                "samples": o.albedo.samples,
                "table_res": o.albedo.table_res,
                "repeats": o.albedo.repeats,
                "reference_rtol": REFERENCE_RTOL,
                "reference": reference,
            },
            "sections": self.sections().into_iter().map(|s| serde_json::json!({
                "name": s.name(),
                "cost_unit": s.cost_unit(),
                "error_kind": s.error_kind(),
                "note": self.section_note(s),
            })).collect::<Vec<_>>(),
            "pareto_fronts": fronts,
            "notes": self.notes,
            "rows": self.rows,
        })
    }

    /// The rows as CSV with a header line, one row per variant; empty fields where a value does not
    /// apply.
    pub fn write_csv(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(
            out,
            "section,variant,backend,samples,cost,cost_unit,kernel_cost,max_error,rms_error,error_kind,pareto"
        )?;
        for r in &self.rows {
            writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{},{}",
                r.section.name(),
                csv_field(&r.variant),
                csv_field(&r.backend),
                r.samples.map(|n| n.to_string()).unwrap_or_default(),
                r.cost,
                r.cost_unit,
                r.kernel_cost.map(|k| k.to_string()).unwrap_or_default(),
                r.max_error,
                r.rms_error,
                r.error_kind,
                r.pareto
            )?;
        }
        Ok(())
    }

    /// The report as aligned text tables, one per section, with its note and the front marked `*`.
    pub fn write_table(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(out, "{}: {}", self.subject, self.params.to_text())?;
        if let Some(d) = &self.device {
            writeln!(out, "device: {d}")?;
        }
        for s in self.sections() {
            writeln!(out)?;
            writeln!(out, "== {} ==", s.name())?;
            writeln!(out, "{}", self.section_note(s))?;
            if s != Section::Evaluation {
                if let Some(r) = self.reference_note() {
                    writeln!(out, "{r}")?;
                }
            }
            match s {
                Section::Evaluation => {
                    writeln!(
                        out,
                        "{:<36} {:>12} {:>14} {:>14}  pareto",
                        "variant", "ns/eval", "max rel err", "rms rel err"
                    )?;
                    for r in self.rows_of(s) {
                        writeln!(
                            out,
                            "{:<36} {:>12.3} {:>14.3e} {:>14.3e}  {}",
                            r.variant,
                            r.cost,
                            r.max_error,
                            r.rms_error,
                            if r.pareto { "*" } else { "" }
                        )?;
                    }
                }
                Section::Integration | Section::TableResolution => {
                    let (n, c) = if s == Section::Integration {
                        ("nodes", "ms/albedo")
                    } else {
                        ("cells", "ms/table")
                    };
                    writeln!(
                        out,
                        "{:<36} {:>9} {:>11} {:>11} {:>12} {:>12}  pareto",
                        "variant", n, c, "kernel ms", "max |dE|", "rms |dE|"
                    )?;
                    for r in self.rows_of(s) {
                        writeln!(
                            out,
                            "{:<36} {:>9} {:>11.4} {:>11} {:>12.3e} {:>12.3e}  {}",
                            r.variant,
                            r.samples.unwrap_or(0),
                            r.cost,
                            r.kernel_cost
                                .map(|k| format!("{k:.4}"))
                                .unwrap_or_else(|| "-".into()),
                            r.max_error,
                            r.rms_error,
                            if r.pareto { "*" } else { "" }
                        )?;
                    }
                }
            }
        }
        writeln!(out)?;
        writeln!(out, "Pareto fronts (cheapest first):")?;
        for s in self.sections() {
            let mut front: Vec<&Row> = self.rows_of(s).filter(|r| r.pareto).collect();
            front.sort_by(|a, b| a.cost.total_cmp(&b.cost));
            let names: Vec<&str> = front.iter().map(|r| r.variant.as_str()).collect();
            writeln!(out, "  {}: {}", s.name(), names.join(" | "))?;
        }
        for n in &self.notes {
            writeln!(out, "note: {n}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_table_integrates_to_its_albedo_within_the_midpoint_error() {
        // f = ρ/π: E = ρ exactly; the midpoint rule in θi of cosθ sinθ = sin(2θ)/2 errs by
        // about h²/6 relative (h = Δθi), interpolation in θo and the Δφ sum not at all.
        let (n, rho) = (16usize, 0.7f64);
        let table = vec![(rho / PI) as f32; n * n * 2 * n * 3];
        let h = FRAC_PI_2 / n as f64;
        for mu in [0.05, 0.5, 1.0] {
            let e = table_albedo(&table, n, n, 2 * n, mu);
            for c in e.to_array() {
                assert!(
                    (c / rho - 1.0).abs() < h * h / 6.0 * 1.1,
                    "mu {mu}: {c} vs {rho} (h²/6 = {:e})",
                    h * h / 6.0
                );
            }
        }
    }

    #[test]
    fn interpolation_in_theta_o_is_linear_between_centres() {
        // A table whose value is the θo cell index k: at θo halfway between centres 2 and 3 the
        // interpolated f is 2.5 everywhere, so E = 2.5 × Σ weights.
        let n = 8usize;
        let mut table = vec![0f32; n * n * 2 * n * 3];
        for i in 0..n {
            for k in 0..n {
                for d in 0..2 * n {
                    for c in 0..3 {
                        table[((i * n + k) * 2 * n + d) * 3 + c] = k as f32;
                    }
                }
            }
        }
        let ones = vec![1f32; table.len()];
        let theta = 0.5 * (theta_cell(2, n) + theta_cell(3, n));
        let e = table_albedo(&table, n, n, 2 * n, theta.cos());
        let w = table_albedo(&ones, n, n, 2 * n, theta.cos());
        assert!((e.x / w.x - 2.5).abs() < 1e-12, "{} vs 2.5", e.x / w.x);
    }
}
