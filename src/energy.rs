//! Energy report (`lobe energy`): for every model at each material preset and over a
//! sweep of its main parameter, the largest directional albedo E(μ) and where it occurs, whether
//! the model gains energy, and how much it loses on average (1 − E_avg).
//!
//! What is measured. The numbers should be about the model, not about a colour someone chose,
//! so every case is evaluated in its *white configuration*: the preset's (or the sweep's) shape
//! parameters (roughness, exponents, σ, IOR) with the colours set so that the model, read as its
//! authors intended, should reflect all light at normal incidence:
//! - `lambert`, `oren_nayar`: albedo = 1;
//! - `phong`, `blinn_phong`, `cook_torrance`, `ashikhmin_shirley`, `microfacet`: the specular
//!   lobe alone (diffuse = 0, specular = 1) under the white furnace (Fresnel = 1,
//!   docs/design.md §3): the lobe's own normalization and masking (the diffuse part is Lambert, reported apart);
//! - `smooth_layered`: diffuse = 1 − R0, the largest base for which E(μ = 1) = 1, so that what
//!   it gains towards grazing (F_s(μ) → 1 while the base stays) is the model's, not the colour's;
//! - `coupled`: matte = 1 (its (1 − R0)·(1 − (1 − c)^5) factors are meant to make this lossless).
//!
//! Definitions. Gain: some E(μ) exceeds 1 by more than [`GAIN_MARGIN`] plus its error estimate:
//! a passive surface in the white configuration should never return more than it receives.
//! Loss: 1 − E_avg, E_avg = 2∫₀¹ E(μ) μ dμ (Kulla–Conty's average; the hemispherical albedo for
//! an isotropic model): the energy the model drops (masking without multiple scattering, the
//! horizon cutting a lobe, an under-normalized lobe). A negative loss is an average gain.

use crate::backend::Query;
use crate::eval::Evaluator;
use crate::integrate::{
    albedo_rows, directional, hemispherical, HemiAlbedo, PointAlbedo, Settings,
};
use crate::lut::{default_axis, LutSpec};
use crate::material;
use crate::model::{Model, ParamError, ParamKind, ParamSet};
use anyhow::Result;
use glam::DVec3;
use serde::Serialize;

/// E must exceed 1 by this much (beyond its error estimate) to count as a gain: far above the
/// integrators' errors (1e-6 relative for the default rule), far below the gains that matter
/// (Blinn–Phong's approximate normalization: percents; the layered model: tens of percents).
pub const GAIN_MARGIN: f64 = 1e-4;

/// Nodes per view direction of the report's default integrator (the peak rule): half of
/// [`Method::default_samples`](crate::integrate::Method::default_samples)'s 65536, which halves
/// the time of a report of ~100 cases and keeps the sharpest presets' error estimates near
/// 1e-4 or below, the scale of [`GAIN_MARGIN`].
pub const DEFAULT_PEAK_SAMPLES: usize = 1 << 15;

/// View cosines where E is looked at: grazing ones, then 32 cell centres, then normal incidence.
pub fn mu_grid() -> Vec<f64> {
    let mut v = vec![0.001, 0.003, 0.01, 0.03];
    v.extend((0..32).map(|j| (j as f64 + 0.5) / 32.0));
    v.push(1.0);
    v
}

/// One line of the report.
#[derive(Clone, Debug, Serialize)]
pub struct EnergyRow {
    /// The model's name.
    pub model: String,
    /// `preset NAME` or `sweep KEY=VALUE`.
    pub case: String,
    /// The white configuration evaluated (all parameters).
    pub parameters: String,
    /// Whether the white configuration runs under the white furnace.
    pub white_furnace: bool,
    /// The largest E over [`mu_grid`] (largest channel).
    pub e_max: f64,
    /// The μ where `e_max` occurs.
    pub mu_at_max: f64,
    /// E at normal incidence.
    pub e_normal: f64,
    /// E_avg = 2∫₀¹ E(μ) μ dμ (largest channel).
    pub e_avg: f64,
    /// 1 − E_avg.
    pub loss: f64,
    /// Whether `e_max` exceeds 1 by more than [`GAIN_MARGIN`] plus its error estimate.
    pub gain: bool,
    /// The largest error estimate among the E values and E_avg.
    pub error: f64,
}

/// The white configuration of `params` (see the module's documentation) and whether it runs
/// under the white furnace; the model states it ([`crate::model::ModelInfo::white`]).
pub fn white_configuration(params: &ParamSet) -> Result<(ParamSet, bool), ParamError> {
    params.white_configuration()
}

/// The report's line for one case (`params` already in its white configuration).
pub fn evaluate(
    eval: &Evaluator,
    model: &str,
    case: &str,
    query: Query,
    method: crate::integrate::Method,
    samples: usize,
) -> Result<EnergyRow> {
    let params = query.params();
    let s = Settings {
        method,
        samples,
        seed: crate::integrate::DEFAULT_SEED,
        white_furnace: query.white_furnace,
    };
    let pts = mu_points();
    let dir = directional(eval, params, &s, &pts)?;
    let h = hemispherical(eval, params, &s, 0.0)?;
    Ok(summarise(model, case, query, &dir, &h))
}

fn mu_points() -> Vec<(f64, f64)> {
    mu_grid().into_iter().map(|m| (m, 0.0)).collect()
}

/// The report's line from E at [`mu_grid`] and the hemispherical albedo.
fn summarise(
    model: &str,
    case: &str,
    query: Query,
    dir: &[PointAlbedo],
    h: &HemiAlbedo,
) -> EnergyRow {
    let params = query.params();
    let (mut e_max, mut mu_at_max, mut err_at_max) = (f64::NEG_INFINITY, 1.0, 0.0);
    let mut error: f64 = h.e_avg_error.max_element();
    for d in dir {
        error = error.max(d.error.max_element());
        let e = d.albedo.max_element();
        if e > e_max {
            (e_max, mu_at_max, err_at_max) = (e, d.mu, d.error.max_element());
        }
    }
    let e_avg = h.e_avg.max_element();
    let last: DVec3 = dir.last().map(|d| d.albedo).unwrap_or_default();
    EnergyRow {
        model: model.to_string(),
        case: case.to_string(),
        parameters: params.to_text(),
        white_furnace: query.white_furnace,
        e_max,
        mu_at_max,
        e_normal: last.max_element(),
        e_avg,
        loss: 1.0 - e_avg,
        gain: e_max - err_at_max > 1.0 + GAIN_MARGIN,
        error,
    }
}

/// The cases of one model: every preset that defines it, then `sweep` values of its main
/// parameter ([`default_axis`], cell-centred in its mapping) from the model's defaults. Models
/// whose main parameter is a colour (lambert) have no sweep: the white configuration fixes it.
pub fn cases(model: Model, sweep: usize) -> Result<Vec<(String, ParamSet)>> {
    let mut out = Vec::new();
    for name in material::names() {
        match material::preset(name, model) {
            Ok(p) => out.push((format!("preset {name}"), p)),
            Err(ParamError::NoPreset { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    push_sweep(&mut out, &ParamSet::defaults(model), sweep)?;
    Ok(out)
}

/// Appends `sweep` values of the model's main parameter (its LUT axis) from `base`, unless that
/// axis is a colour.
fn push_sweep(out: &mut Vec<(String, ParamSet)>, base: &ParamSet, sweep: usize) -> Result<()> {
    let (keys, ..) = default_axis(base.model());
    let colour = base
        .model()
        .params()
        .iter()
        .any(|s| keys.contains(&s.key) && s.kind == ParamKind::Rgb);
    if sweep > 0 && !colour {
        let mut spec = LutSpec::new(base.clone());
        spec.n_p = sweep;
        for p in spec.ps() {
            let set = spec.params_at(p)?;
            out.push((format!("sweep {}={}", keys.join(","), fmt_value(p)), set));
        }
    }
    Ok(())
}

/// The cases of a series with its own parameters (`NAME{KEY=V}`, `--set MODEL.KEY=V`): the set
/// as given, then `sweep` values of the model's main parameter from it (no presets: they would
/// overwrite what the series sets).
pub fn cases_from(base: &ParamSet, sweep: usize) -> Result<Vec<(String, ParamSet)>> {
    let mut out = vec![("as given".to_string(), base.clone())];
    push_sweep(&mut out, base, sweep)?;
    Ok(out)
}

/// One series of a report: a model with its presets and default sweep, or a labelled parameter
/// set ([`cases_from`]).
#[derive(Clone, Debug)]
pub enum Series {
    /// The model's presets, then its sweep from the defaults ([`cases`]).
    Model(Model),
    /// A label (the spec as given, `microfacet{multiscatter=kulla_conty}`) and its parameters.
    Params(String, ParamSet),
}

impl Series {
    /// The name its rows carry in the `model` column.
    pub fn label(&self) -> String {
        match self {
            Series::Model(m) => m.name().to_string(),
            Series::Params(label, _) => label.clone(),
        }
    }

    fn cases(&self, sweep: usize) -> Result<Vec<(String, ParamSet)>> {
        match self {
            Series::Model(m) => cases(*m, sweep),
            Series::Params(_, p) => cases_from(p, sweep),
        }
    }
}

fn fmt_value(p: f64) -> String {
    if p >= 100.0 {
        format!("{p:.0}")
    } else {
        format!("{p:.4}")
    }
}

/// The whole report for `models`; `progress` receives (cases done, cases).
pub fn report(
    eval: &Evaluator,
    models: &[Model],
    sweep: usize,
    method: crate::integrate::Method,
    samples: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Vec<EnergyRow>> {
    report_each(
        eval,
        models,
        sweep,
        method,
        samples,
        &mut |_, done, total| {
            progress(done, total);
            Ok(())
        },
    )
}

/// [`report`], handing each line to `on_row` as soon as it is known, with (cases done, cases).
/// The cases of one model under one white-furnace setting are integrated together
/// ([`albedo_rows`]: each view direction's nodes are made once for all of them, and the GPU
/// sums them in the same dispatches), so lines arrive model by model.
pub fn report_each(
    eval: &Evaluator,
    models: &[Model],
    sweep: usize,
    method: crate::integrate::Method,
    samples: usize,
    on_row: &mut dyn FnMut(&EnergyRow, u64, u64) -> Result<()>,
) -> Result<Vec<EnergyRow>> {
    let series: Vec<Series> = models.iter().map(|&m| Series::Model(m)).collect();
    report_series_each(eval, &series, sweep, method, samples, on_row)
}

/// [`report_each`] over series, each labelled in the rows by its spec (`microfacet{…}`) or its
/// model's name.
pub fn report_series_each(
    eval: &Evaluator,
    series: &[Series],
    sweep: usize,
    method: crate::integrate::Method,
    samples: usize,
    on_row: &mut dyn FnMut(&EnergyRow, u64, u64) -> Result<()>,
) -> Result<Vec<EnergyRow>> {
    // (series index, label, case, white configuration, white furnace), in report order.
    let mut all = Vec::new();
    for (k, s) in series.iter().enumerate() {
        for (case, p) in s.cases(sweep)? {
            let (white, wf) = white_configuration(&p)?;
            all.push((k, s.label(), case, white, wf));
        }
    }
    let total = all.len() as u64;
    let mut rows = Vec::with_capacity(all.len());
    let pts = mu_points();
    let mut start = 0;
    while start < all.len() {
        eval.check_cancelled()?;
        let (m, wf) = (all[start].0, all[start].4);
        let end = start
            + all[start..]
                .iter()
                .take_while(|c| c.0 == m && c.4 == wf)
                .count();
        let group = &all[start..end];
        let s = Settings {
            method,
            samples,
            seed: crate::integrate::DEFAULT_SEED,
            white_furnace: wf,
        };
        let params: Vec<ParamSet> = group.iter().map(|c| c.3.clone()).collect();
        for ((_, label, case, white, wf), (dir, h)) in
            group
                .iter()
                .zip(albedo_rows(eval, &params, &s, &pts, Some(0.0))?)
        {
            let h = h.expect("asked for the hemispherical albedo");
            let row = summarise(
                label,
                case,
                Query::one(white).with_white_furnace(*wf),
                &dir,
                &h,
            );
            rows.push(row);
            on_row(rows.last().unwrap(), rows.len() as u64, total)?;
        }
        start = end;
    }
    Ok(rows)
}

/// A fixed-width table, one line per case.
pub fn format_table(rows: &[EnergyRow]) -> String {
    let width = model_width(rows.iter().map(|r| r.model.as_str()));
    let mut s = table_header(width);
    for r in rows {
        s += &table_line(r, width);
    }
    s
}

/// The width of the `model` column that holds every one of `labels` (at least 18).
pub fn model_width<'a>(labels: impl IntoIterator<Item = &'a str>) -> usize {
    labels
        .into_iter()
        .map(|l| l.chars().count())
        .max()
        .unwrap_or(0)
        .max(18)
}

/// The header line of [`format_table`] with a `model` column `width` characters wide
/// ([`model_width`]), newline included.
pub fn table_header(width: usize) -> String {
    format!(
        "{:<width$} {:<28} {:>10} {:>8} {:>10} {:>10} {:>10} {:>5} {:>9}\n",
        "model", "case", "E max", "at mu", "E(mu=1)", "E_avg", "loss", "gain", "error"
    )
}

/// One line of [`format_table`], newline included.
pub fn table_line(r: &EnergyRow, width: usize) -> String {
    format!(
        "{:<width$} {:<28} {:>10.6} {:>8.4} {:>10.6} {:>10.6} {:>10.6} {:>5} {:>9.1e}\n",
        r.model,
        r.case,
        r.e_max,
        r.mu_at_max,
        r.e_normal,
        r.e_avg,
        r.loss,
        if r.gain { "GAIN" } else { "-" },
        r.error
    )
}

/// CSV with a header line.
pub fn format_csv(rows: &[EnergyRow]) -> String {
    let mut s = String::from(CSV_HEADER);
    for r in rows {
        s += &csv_line(r);
    }
    s
}

/// The header line of [`format_csv`], newline included.
pub const CSV_HEADER: &str =
    "model,case,white_furnace,e_max,mu_at_max,e_mu1,e_avg,loss,gain,error_estimate,parameters\n";

/// One line of [`format_csv`], newline included.
pub fn csv_line(r: &EnergyRow) -> String {
    format!(
        "{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
        r.model,
        r.case,
        r.white_furnace,
        r.e_max,
        r.mu_at_max,
        r.e_normal,
        r.e_avg,
        r.loss,
        r.gain,
        r.error,
        r.parameters
    )
}
