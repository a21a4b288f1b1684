//! Throughput of each model on this machine: evaluations per second of a lobe table and of an
//! albedo integration, draws per second of the sampling test and texel terms per second of the
//! lit sphere's exact sum (and, for a table, cells written per second, which exceeds evaluations
//! per second where a reciprocal table copies mirror cells, docs/design.md §4.5), on the GPU (kernel time from timestamp queries, and wall time including
//! upload and read-back) and on the CPU reference (wall time, all cores). The two backends never
//! run at the same time: on lavapipe both would compete for the same cores.

use crate::backend::Query;
use crate::eval::Evaluator;
use crate::grid::Grid;
use crate::integrate::Method;
use crate::lut::LutSpec;
use crate::model::ParamSet;
use anyhow::Result;
use std::time::Instant;

/// One measurement: the median over repeats.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Throughput {
    /// The model's name.
    pub model: String,
    /// What was timed: "table" (a lobe table, output discarded), "albedo" (directional albedo
    /// by a fixed quadrature: the reduction kernel on the GPU, f64 sums on the CPU), "lut" (an
    /// albedo look-up table E(μ, p) and E_avg(p), [`measure_lut`]), "chi2" (the sampling test,
    /// `Session::bench_chi2`) or "light" (the lit sphere's exact sum, `Session::bench_light`).
    pub task: &'static str,
    /// The backend timed, as [`Evaluator::name`] says.
    pub backend: String,
    /// The GPU's driver and its version ([`Evaluator::driver`]); None on the CPU.
    pub driver: Option<String>,
    /// BRDF (integrand) evaluations in one run, as the backend reports them; for "chi2" the
    /// draws, for "light" the texel terms (pixels × texels, before the horizon skips).
    pub evaluations: u64,
    /// Evaluations per second by wall clock, read-back included.
    pub wall_per_s: f64,
    /// Evaluations per second of kernel time (GPU timestamp queries), where available.
    pub kernel_per_s: Option<f64>,
    /// Table cells handed on in one run (the table task only): evaluated cells and copied
    /// mirror cells.
    pub cells: Option<u64>,
    /// Cells per second by wall clock (the table task only).
    pub cells_wall_per_s: Option<f64>,
}

/// The median of `v` (the upper one of an even count); `v` must not be empty.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Times `repeats` runs of `work`, which returns the integrand evaluations it made, after one
/// warm-up run, which also builds the pipeline; wall time always, kernel time from the GPU's
/// timestamp queries when `eval` is the GPU.
pub fn time_task(
    eval: &Evaluator,
    params: &ParamSet,
    task: &'static str,
    repeats: usize,
    work: impl Fn() -> Result<u64>,
) -> Result<Throughput> {
    let run = || -> Result<(u64, f64, Option<f64>)> {
        eval.check_cancelled()?;
        eval.take_device_time();
        let t = Instant::now();
        let evaluations = work()?;
        let wall = t.elapsed().as_secs_f64();
        let kernel = eval.take_device_time().map(|d| d.as_secs_f64());
        Ok((evaluations, wall, kernel))
    };
    let mut evaluations = run()?.0;
    let mut walls = Vec::new();
    let mut kernels = Vec::new();
    for _ in 0..repeats.max(1) {
        let (e, w, k) = run()?;
        evaluations = e;
        walls.push(evaluations as f64 / w);
        if let Some(k) = k.filter(|k| *k > 0.0) {
            kernels.push(evaluations as f64 / k);
        }
    }
    Ok(Throughput {
        model: params.model().name().to_string(),
        task,
        backend: eval.name(),
        driver: eval.driver(),
        evaluations,
        wall_per_s: median(walls),
        kernel_per_s: (!kernels.is_empty()).then(|| median(kernels)),
        cells: None,
        cells_wall_per_s: None,
    })
}

/// Throughput of a lobe table on `grid` (output discarded), the median of `repeats` runs.
pub fn measure(
    eval: &Evaluator,
    params: &ParamSet,
    grid: &Grid,
    repeats: usize,
) -> Result<Throughput> {
    measure_table(eval, params, grid, repeats)
}

/// [`measure`], optionally under the white furnace (docs/design.md §3). The table is made as
/// `lobe table` makes it ([`Evaluator::eval_table_runs`]: a reciprocal model's isotropic table
/// with equal θ axes evaluates about half its cells), so evaluations and cells are counted
/// apart.
pub fn measure_table<'q>(
    eval: &Evaluator,
    query: impl Into<Query<'q>>,
    grid: &Grid,
    repeats: usize,
) -> Result<Throughput> {
    let query = query.into();
    let params = query.params();
    let cells = grid.cells().unwrap_or(0);
    let mut t = time_task(eval, params, "table", repeats, || {
        eval.eval_table_runs(query, grid, &mut |_, v| {
            std::hint::black_box(v);
            Ok(())
        })
    })?;
    t.cells = Some(cells);
    // Both rates come from the same runs' times.
    t.cells_wall_per_s = Some(t.wall_per_s * cells as f64 / t.evaluations.max(1) as f64);
    Ok(t)
}

/// View directions of the timed albedo integration: μ evenly spread over (0, 1].
pub const ALBEDO_DIRECTIONS: usize = 32;

/// The timed albedo rule: Gauss–Legendre in μ × uniform φ, 64 × 256 nodes per direction (its
/// coarse check rule, which `rule_albedo` also runs, is counted too).
pub const ALBEDO_RULE: crate::integrate::Rule = crate::integrate::Rule::Gauss { n_mu: 64 };

/// Throughput of directional-albedo integration at [`ALBEDO_DIRECTIONS`] view directions with
/// [`ALBEDO_RULE`], the median of `repeats` runs; evaluations = integrand evaluations.
pub fn measure_albedo<'q>(
    eval: &Evaluator,
    query: impl Into<Query<'q>>,
    repeats: usize,
) -> Result<Throughput> {
    let query = query.into();
    let params = query.params();
    use crate::integrate::{rule_albedo, view_direction};
    let wo: Vec<glam::DVec3> = (0..ALBEDO_DIRECTIONS)
        .map(|k| view_direction((k as f64 + 1.0) / ALBEDO_DIRECTIONS as f64, 0.0))
        .collect();
    let per_direction: usize = ALBEDO_RULE
        .levels(false)
        .iter()
        .map(|r| r.nodes(glam::DVec3::Z).len())
        .sum();
    let evaluations = (per_direction * wo.len()) as u64;
    time_task(eval, params, "albedo", repeats, || {
        std::hint::black_box(rule_albedo(eval, query, ALBEDO_RULE, &wo)?);
        Ok(evaluations)
    })
}

/// Nodes per view direction of the timed LUT: the peak rule at 32768 nodes.
pub const LUT_SAMPLES: usize = 1 << 15;

/// Cells of the timed LUT along μ and along the parameter axis: Kulla–Conty's 32 × 32.
pub const LUT_RES: usize = 32;

/// The LUT [`measure_lut`] times for `params`: the model's default axis at [`LUT_RES`] ×
/// [`LUT_RES`] cells, the peak rule at [`LUT_SAMPLES`] nodes per direction.
pub fn lut_spec(query: Query) -> LutSpec {
    let mut spec = LutSpec::new(query.params().clone());
    spec.white_furnace = query.white_furnace;
    spec.n_mu = LUT_RES;
    spec.n_p = LUT_RES;
    spec.method = Method::Peak;
    spec.samples = LUT_SAMPLES;
    spec
}

/// Throughput of an albedo look-up table ([`lut_spec`], computed as `lobe albedo --lut` does,
/// no file written), the median of `repeats` runs; evaluations = integrand evaluations of every
/// entry, the coarse checks included.
pub fn measure_lut<'q>(
    eval: &Evaluator,
    query: impl Into<Query<'q>>,
    repeats: usize,
) -> Result<Throughput> {
    let query = query.into();
    let params = query.params();
    let spec = lut_spec(query);
    let evaluations = lut_evaluations(&spec)?;
    time_task(eval, params, "lut", repeats, || {
        std::hint::black_box(crate::lut::compute(eval, &spec, &mut |_, _| {})?);
        Ok(evaluations)
    })
}

/// Integrand evaluations of `spec`'s LUT: every row's directional view directions and its
/// hemispherical ones, each with its fine and coarse rule.
pub fn lut_evaluations(spec: &LutSpec) -> Result<u64> {
    use crate::integrate::{hemispherical_directions, rule_evaluations, view_direction};
    spec.validate()?;
    let mut total = 0;
    for p in spec.ps() {
        let params = spec.params_at(p)?;
        let rule = spec.method.rule(spec.samples, &params);
        if rule.is_none() && spec.method.sampler().is_none() {
            continue;
        }
        let mut wo: Vec<glam::DVec3> = spec
            .mus()
            .into_iter()
            .map(|mu| view_direction(mu, spec.phi))
            .collect();
        wo.extend(hemispherical_directions(&params, spec.phi));
        total += match rule {
            Some(rule) => rule_evaluations(rule, params.model().is_tabulated(), &wo),
            None => spec.samples.max(2) as u64 * wo.len() as u64,
        };
    }
    Ok(total)
}

/// Draws per run of the timed sampling test, at θo = [`CHI2_THETA_O_DEG`].
pub const CHI2_SAMPLES: u64 = 1 << 22;

/// The timed sampling test's view direction, in degrees from the normal.
pub const CHI2_THETA_O_DEG: f64 = 45.0;

/// Pixels per side of the timed lit sphere.
pub const LIGHT_SIZE: u32 = 64;
