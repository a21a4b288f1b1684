//! `lobe stability`: every model at the edges of its domain, on both backends.
//!
//! The sweep crosses two kinds of edge:
//! - **parameter edges** ([`cases`]): roughness, σ and α down to 1e-4 and up to their maximum;
//!   shininess 0, 8192 (the lab report's largest), 1e5 and 1e6; smoothness 0 and 1; IOR 1 and 5;
//!   nu, nv at 0 and 1e5, alone and together (strong anisotropy); reflectances 0 and 1;
//! - **direction regions** ([`regions`]): an interior reference set; θ → 90° with cos θ from 1e-7
//!   to 1e-3 on either or both sides; ωi = ωo; ωi the mirror of ωo (h = n) and within 1e-6..1e-2
//!   rad of it; opposite grazing directions, where |ωi + ωo| = 2 cos θ → 0 and h → n.
//!
//! Every input is valid (parameters in range, both directions above the horizon), so any NaN,
//! infinity or negative value on either backend is a bug. Both backends see the same inputs: the
//! GPU receives f32 directions and parameters, and the CPU reference evaluates at exactly those
//! values widened to f64 (as the parity test does). The GPU-vs-CPU error is reported two ways: as
//! a relative error with an absolute floor of [`REL_FLOOR`] (so that values far below anything a
//! renderer resolves do not dominate), and as a fraction of the tolerance the parity test allows
//! ([`crate::tolerance`]): a ratio above 1 is a value the parity test would reject.

use crate::backend::Precision;
use crate::backend::Query;
use crate::eval::Evaluator;
use crate::model::{Model, ParamSet, Reference};
use anyhow::{Context, Result};
use glam::DVec3;
use serde::Serialize;
use std::collections::BTreeMap;

pub use crate::tolerance::{conditioning, parity_tolerance, EPS32};

/// Denominator floor of the relative error, 1/sr: the tolerance model's absolute tolerance.
pub const REL_FLOOR: f64 = crate::tolerance::ATOL;

/// |x| of the exponential exp(x) the model evaluates at (ωi, ωo) (see the tolerance model); the
/// model states it ([`crate::model::ModelInfo::exponent`]).
pub fn exponent_at(params: &ParamSet, wi: DVec3, wo: DVec3) -> f64 {
    params.exponent_at(wi, wo)
}

/// One parameter edge of a model: a label and the (valid) parameter set.
#[derive(Clone, Debug)]
pub struct Case {
    /// `defaults`, or the edge's `key=value` settings separated by spaces.
    pub label: String,
    /// The model's parameters at the edge, every value within its range.
    pub params: ParamSet,
}

fn case(model: Model, sets: &[&str]) -> Result<Case> {
    let mut params = ParamSet::defaults(model);
    for s in sets {
        params
            .set_text(s)
            .with_context(|| format!("stability case {} {s}", model.name()))?;
    }
    let label = if sets.is_empty() {
        "defaults".to_string()
    } else {
        sets.join(" ")
    };
    Ok(Case { label, params })
}

/// The parameter edges swept for `model`: its defaults, the edges the model states
/// ([`crate::model::ModelInfo::stability_edges`]), then the true ends of every scalar range
/// ([`range_ends`]).
pub fn cases(model: Model) -> Result<Vec<Case>> {
    let mut cases: Vec<Case> = std::iter::once(&[][..])
        .chain((model.info().stability_edges)(model))
        .map(|sets| case(model, sets))
        .collect::<Result<_>>()?;
    cases.extend(range_ends(model)?);
    Ok(cases)
}

/// The smallest positive f64, a subnormal: the lowest value a range open or closed at 0 allows.
pub const SMALLEST_SUBNORMAL: f64 = 5e-324;

/// The ends of each scalar parameter's range, each alone on the model's white configuration
/// (colours at 1, a specular lobe alone where there is one, so that the lobe the parameter
/// shapes is what is seen): the maximum, the minimum, and for a range that starts at 0 also
/// 1e-30 and [`SMALLEST_SUBNORMAL`] (a value below a roughness floor is swept too: it must
/// evaluate as the floor does).
pub fn range_ends(model: Model) -> Result<Vec<Case>> {
    let mut white = ParamSet::defaults(model);
    (model.info().white)(&mut white)
        .with_context(|| format!("stability: the white configuration of {}", model.name()))?;
    let mut out = Vec::new();
    for spec in model.params() {
        if spec.kind != crate::model::ParamKind::Scalar {
            continue;
        }
        let mut ends = vec![spec.max];
        if !spec.min_exclusive {
            ends.push(spec.min);
        }
        if spec.min == 0.0 {
            ends.extend([1e-30, SMALLEST_SUBNORMAL]);
        }
        for v in ends {
            let text = format!("{}={}", spec.key, crate::pairs::fmt_value(v));
            let mut params = white.clone();
            params
                .set_text(&text)
                .with_context(|| format!("stability case {} {text}", model.name()))?;
            out.push(Case {
                label: format!("white {text}"),
                params,
            });
        }
    }
    Ok(out)
}

mod regions;

pub use regions::{regions, Region, GRAZING_COS, MIRROR_OFFSETS};

/// The models the sweep covers: every model with each of its component choices.
pub fn sweep_models() -> Vec<Model> {
    // Configurations that differ only in a component their formula does not use (Beckmann's G1
    // under V-cavity masking, for instance) evaluate the same function: sweep one of each.
    let mut labels = std::collections::BTreeSet::new();
    Model::ALL
        .into_iter()
        .flat_map(Model::variants)
        .filter(|m| labels.insert(m.label()))
        .collect()
}

/// The models named (as `lobe models` lists them); `microfacet` stands for every component
/// choice. An empty list means [`sweep_models`].
pub fn models_named(names: &[String]) -> Result<Vec<Model>> {
    if names.is_empty() {
        return Ok(sweep_models());
    }
    let all = sweep_models();
    let mut out = Vec::new();
    for name in names {
        let model = Model::from_name(name.trim())?;
        let swept: Vec<Model> = all
            .iter()
            .copied()
            .filter(|m| m.name() == model.name())
            .collect();
        // A model the default sweep does not hold (one defined at run time) is swept as named.
        out.extend(if swept.is_empty() {
            model.variants()
        } else {
            swept
        });
    }
    out.dedup();
    Ok(out)
}

/// A model's name with its components ([`Model::label`]).
pub fn model_label(model: Model) -> String {
    model.label()
}

/// Counts and worst errors of one group of evaluations.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Stats {
    /// Channel values evaluated per backend.
    pub values: usize,
    /// Channel values that are NaN on the GPU.
    pub gpu_nan: usize,
    /// Channel values that are infinite on the GPU.
    pub gpu_inf: usize,
    /// Channel values below 0 on the GPU.
    pub gpu_negative: usize,
    /// Channel values that are NaN in the f64 reference.
    pub cpu_nan: usize,
    /// Channel values that are infinite in the f64 reference.
    pub cpu_inf: usize,
    /// Channel values below 0 in the f64 reference.
    pub cpu_negative: usize,
    /// Largest |g − c| / max(|c|, REL_FLOOR) over values finite on both sides.
    pub max_rel_error: f64,
    /// Largest |g − c| / (the parity test's tolerance).
    pub max_tolerance_ratio: f64,
    /// GPU values outside the parity tolerance.
    pub over_tolerance: usize,
    /// Where the largest tolerance ratio occurred.
    pub worst: Option<Sample>,
    /// The first non-finite or negative value met, if any.
    pub first_bad: Option<Sample>,
}

/// One evaluation, described well enough to reproduce it.
#[derive(Clone, Debug, Serialize)]
pub struct Sample {
    /// The model's label, with its components ([`model_label`]).
    pub model: String,
    /// The parameter edge's label ([`Case::label`]).
    pub case: String,
    /// The direction region's name ([`Region::name`]).
    pub region: String,
    /// Whether the Fresnel factors of specular lobes were set to 1.
    pub white_furnace: bool,
    /// ωi toward the light, as both backends received it.
    pub wi: [f64; 3],
    /// ωo toward the viewer, as both backends received it.
    pub wo: [f64; 3],
    /// The RGB channel: 0 red, 1 green, 2 blue.
    pub channel: usize,
    /// The GPU's value in 1/sr; `None` when the sweep ran on the CPU alone.
    pub gpu: Option<f64>,
    /// The f64 reference's value in 1/sr.
    pub cpu: f64,
    /// The parity tolerance at this value in 1/sr; `None` where no GPU value was compared.
    pub tolerance: Option<f64>,
}

impl Sample {
    /// One line naming the model, edge, white-furnace switch, directions, channel and both values.
    pub fn text(&self) -> String {
        let g = self.gpu.map(|g| format!("gpu={g:e} ")).unwrap_or_default();
        format!(
            "{} [{}] wf={} wi={:?} wo={:?} ch{}: {g}cpu={:e}",
            self.model, self.case, self.white_furnace, self.wi, self.wo, self.channel, self.cpu
        )
    }
}

impl Stats {
    /// Non-finite or negative channel values, the GPU's and the reference's counted together.
    pub fn bad(&self) -> usize {
        self.gpu_nan
            + self.gpu_inf
            + self.gpu_negative
            + self.cpu_nan
            + self.cpu_inf
            + self.cpu_negative
    }

    fn merge(&mut self, o: &Stats) {
        self.values += o.values;
        self.gpu_nan += o.gpu_nan;
        self.gpu_inf += o.gpu_inf;
        self.gpu_negative += o.gpu_negative;
        self.cpu_nan += o.cpu_nan;
        self.cpu_inf += o.cpu_inf;
        self.cpu_negative += o.cpu_negative;
        self.over_tolerance += o.over_tolerance;
        self.max_rel_error = self.max_rel_error.max(o.max_rel_error);
        if o.max_tolerance_ratio > self.max_tolerance_ratio || self.worst.is_none() {
            self.max_tolerance_ratio = self.max_tolerance_ratio.max(o.max_tolerance_ratio);
            if o.worst.is_some() {
                self.worst = o.worst.clone();
            }
        }
        if self.first_bad.is_none() {
            self.first_bad = o.first_bad.clone();
        }
    }
}

/// Classifies one value: (nan, inf, negative).
fn classify(v: f64) -> (bool, bool, bool) {
    (v.is_nan(), v.is_infinite(), v < 0.0)
}

/// One row of the report: a model with a parameter edge, or a model with a direction region.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// The model's label, with its components ([`model_label`]).
    pub model: String,
    /// "params" (grouped by parameter edge, over all regions) or "directions".
    pub group: &'static str,
    /// The parameter edge's label (group `params`) or the direction region's name (group
    /// `directions`).
    pub region: String,
    /// Counts and worst errors over the row's evaluations.
    #[serde(flatten)]
    pub stats: Stats,
}

/// The sweep's result.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// What was compared: `gpu (device) vs cpu (f64 reference)`, or `cpu (f64 reference) only`.
    pub backend: String,
    /// Whether GPU values were compared with the reference.
    pub gpu: bool,
    /// The relative error's denominator floor, [`REL_FLOOR`], in 1/sr.
    pub rel_floor: f64,
    /// Per model, the parameter edges in the order of [`cases`], then the direction regions in the
    /// order of [`regions`].
    pub rows: Vec<Row>,
    /// Every evaluation of the sweep, each counted once.
    pub total: Stats,
}

impl Report {
    /// NaN, infinities and negatives on either backend: all inputs are valid, so each is a bug.
    pub fn bad_values(&self) -> usize {
        self.total.bad()
    }
}

/// Options of a sweep.
pub struct Options<'a> {
    /// Where to sweep: a GPU evaluator is compared with the f64 reference value by value; the
    /// CPU evaluator sweeps the reference alone. Its cancellation token stops the sweep.
    pub backend: Evaluator<'a>,
    /// Models to sweep (default: [`sweep_models`]).
    pub models: Vec<Model>,
    /// Called with a model's label before it is swept.
    pub progress: &'a mut dyn FnMut(&str),
}

/// Runs the sweep: for each model, one GPU dispatch per white-furnace setting holding every
/// parameter edge × every direction pair, compared value by value with the f64 reference.
pub fn sweep(opts: Options<'_>) -> Result<Report> {
    let regions = regions();
    let mut by_key: BTreeMap<(usize, &'static str, String), Stats> = BTreeMap::new();
    let mut model_order: Vec<String> = Vec::new();
    // Values of an f32 backend are compared with the reference; the reference alone is checked
    // for invalid values.
    let compared = opts.backend.precision() == Precision::F32;
    for (mi, &model) in opts.models.iter().enumerate() {
        opts.backend.check_cancelled()?;
        model.require_reference("the stability sweep")?;
        let label = model_label(model);
        (opts.progress)(&label);
        model_order.push(label.clone());
        let cases = cases(model)?;
        for white_furnace in [false, true] {
            if white_furnace && !model.has_specular_fresnel() {
                continue;
            }
            // Every case at every region's pairs, in one job of the backend.
            let mut pairs = Vec::new();
            let mut region_of = Vec::new();
            for (ri, region) in regions.iter().enumerate() {
                pairs.extend_from_slice(&region.pairs);
                region_of.extend(std::iter::repeat_n(ri, region.pairs.len()));
            }
            let sets: Vec<ParamSet> = cases.iter().map(|c| c.params.rounded_to_f32()).collect();
            // A preset may choose components of another pipeline; the sweep keeps each case on
            // its model's pipeline (cases only set numbers).
            debug_assert!(sets.iter().all(|p| p.model() == model));
            let gpu_values = match compared {
                true => Some(
                    opts.backend
                        .eval_sets_unchecked(
                            Query::sets(&sets).with_white_furnace(white_furnace),
                            &pairs,
                        )
                        .with_context(|| format!("evaluating {label} on the GPU"))?,
                ),
                false => None,
            };
            let meta: Vec<(usize, usize, DVec3, DVec3)> = (0..sets.len())
                .flat_map(|k| {
                    let region_of = &region_of;
                    pairs
                        .iter()
                        .enumerate()
                        .map(move |(j, &(wi, wo))| (k, region_of[j], wi, wo))
                })
                .collect();
            let refs: Vec<(ParamSet, Reference)> = cases
                .iter()
                .map(|c| {
                    let p32 = c.params.rounded_to_f32();
                    let r = Reference::new(&p32, white_furnace);
                    (p32, r)
                })
                .collect();
            for (n, &(k, ri, wi, wo)) in meta.iter().enumerate() {
                let (p32, r) = &refs[k];
                let c = r.eval(wi, wo);
                let g = gpu_values.as_ref().map(|v| v[k][n % pairs.len()]);
                let tol = g.map(|_| parity_tolerance(p32, r, wi, wo, c));
                let at = At {
                    model: &label,
                    case: &cases[k].label,
                    region: regions[ri].name,
                    white_furnace,
                    wi,
                    wo,
                };
                let s = pair_stats(&at, c, g, tol);
                by_key
                    .entry((mi, "params", cases[k].label.clone()))
                    .or_default()
                    .merge(&s);
                by_key
                    .entry((mi, "directions", regions[ri].name.to_string()))
                    .or_default()
                    .merge(&s);
            }
        }
    }
    let (rows, total) = report_rows(&opts.models, &regions, &model_order, by_key)?;
    Ok(Report {
        backend: match compared {
            true => format!("{} vs cpu (f64 reference)", opts.backend.name()),
            false => "cpu (f64 reference) only".to_string(),
        },
        gpu: compared,
        rel_floor: REL_FLOOR,
        rows,
        total,
    })
}

/// Where a pair's samples come from.
struct At<'a> {
    model: &'a str,
    case: &'a str,
    region: &'static str,
    white_furnace: bool,
    wi: DVec3,
    wo: DVec3,
}

/// One pair's three channels: invalid values on either side, and the f32 backend's error `g`
/// against the reference `c` within the parity tolerance `tol`.
fn pair_stats(at: &At, c: DVec3, g: Option<[f64; 3]>, tol: Option<DVec3>) -> Stats {
    let mut s = Stats::default();
    for ch in 0..3 {
        s.values += 1;
        let cv = c[ch];
        let gv = g.map(|g| g[ch]);
        let sample = |tolerance: Option<f64>| Sample {
            model: at.model.to_string(),
            case: at.case.to_string(),
            region: at.region.to_string(),
            white_furnace: at.white_furnace,
            wi: at.wi.to_array(),
            wo: at.wo.to_array(),
            channel: ch,
            gpu: gv,
            cpu: cv,
            tolerance,
        };
        let (nan, inf, neg) = classify(cv);
        s.cpu_nan += nan as usize;
        s.cpu_inf += inf as usize;
        s.cpu_negative += neg as usize;
        let mut bad = nan || inf || neg;
        if let Some(gv) = gv {
            let (nan, inf, neg) = classify(gv);
            s.gpu_nan += nan as usize;
            s.gpu_inf += inf as usize;
            s.gpu_negative += neg as usize;
            bad |= nan || inf || neg;
        }
        if bad {
            if s.first_bad.is_none() {
                s.first_bad = Some(sample(None));
            }
            continue;
        }
        if let (Some(gv), Some(tol)) = (gv, tol) {
            let diff = (gv - cv).abs();
            let rel = diff / cv.abs().max(REL_FLOOR);
            let ratio = diff / tol[ch];
            s.max_rel_error = s.max_rel_error.max(rel);
            if ratio > 1.0 {
                s.over_tolerance += 1;
            }
            if ratio > s.max_tolerance_ratio || s.worst.is_none() {
                s.max_tolerance_ratio = ratio;
                s.worst = Some(sample(Some(tol[ch])));
            }
        }
    }
    s
}

/// The report's rows and the total over the parameter rows: per model, parameter rows in the
/// order the cases were made, then direction rows in region order.
fn report_rows(
    models: &[Model],
    regions: &[Region],
    model_order: &[String],
    mut by_key: BTreeMap<(usize, &'static str, String), Stats>,
) -> Result<(Vec<Row>, Stats)> {
    let mut rows: Vec<Row> = Vec::new();
    let mut total = Stats::default();
    for (mi, &model) in models.iter().enumerate() {
        let case_labels: Vec<String> = cases(model)?.into_iter().map(|c| c.label).collect();
        for (group, names) in [
            ("params", case_labels),
            (
                "directions",
                regions.iter().map(|r| r.name.to_string()).collect(),
            ),
        ] {
            for name in names {
                if let Some(stats) = by_key.remove(&(mi, group, name.clone())) {
                    if group == "params" {
                        total.merge(&stats);
                    }
                    rows.push(Row {
                        model: model_order[mi].clone(),
                        group,
                        region: name,
                        stats,
                    });
                }
            }
        }
    }
    Ok((rows, total))
}

/// The report as a text table: one line per (model, parameter edge) and per (model, direction
/// region), then the worst case and any bad value.
pub fn format_table(r: &Report, all_rows: bool) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "lobe stability: {}; relative error = |gpu - cpu| / max(|cpu|, {:e}); tol = the parity test's tolerance\n",
        r.backend, r.rel_floor
    ));
    out.push_str(&format!(
        "{:<52} {:<10} {:<42} {:>6} {:>7} {:>7} {:>9} {:>9} {:>9} {:>5}\n",
        "model",
        "group",
        "edge / region",
        "values",
        "NaN g/c",
        "Inf g/c",
        "neg g/c",
        "max rel",
        "max/tol",
        ">tol"
    ));
    for row in &r.rows {
        let s = &row.stats;
        if !all_rows && row.group == "params" && s.bad() == 0 && s.max_tolerance_ratio <= 1.0 {
            // Compact view: parameter rows only where something is off; the direction rows
            // still cover every value.
            continue;
        }
        let (rel, ratio) = if r.gpu {
            (
                format!("{:.2e}", s.max_rel_error),
                if s.max_tolerance_ratio < 1e4 {
                    format!("{:.3}", s.max_tolerance_ratio)
                } else {
                    format!("{:.2e}", s.max_tolerance_ratio)
                },
            )
        } else {
            ("-".into(), "-".into())
        };
        out.push_str(&format!(
            "{:<52} {:<10} {:<42} {:>6} {:>7} {:>7} {:>9} {:>9} {:>9} {:>5}\n",
            row.model,
            row.group,
            row.region,
            s.values,
            format!("{}/{}", s.gpu_nan, s.cpu_nan),
            format!("{}/{}", s.gpu_inf, s.cpu_inf),
            format!("{}/{}", s.gpu_negative, s.cpu_negative),
            rel,
            ratio,
            s.over_tolerance
        ));
    }
    let t = &r.total;
    out.push_str(&format!(
        "total: {} values per backend; NaN {}/{}, Inf {}/{}, negative {}/{} (gpu/cpu); max relative error {:.2e}; max error/tolerance {:.3e}; {} over tolerance\n",
        t.values, t.gpu_nan, t.cpu_nan, t.gpu_inf, t.cpu_inf, t.gpu_negative, t.cpu_negative,
        t.max_rel_error, t.max_tolerance_ratio, t.over_tolerance
    ));
    if let Some(w) = &t.worst {
        if r.gpu {
            out.push_str(&format!(
                "closest to the tolerance: {} (allowed {:e})\n",
                w.text(),
                w.tolerance.unwrap_or(f64::NAN)
            ));
        }
    }
    for row in r.rows.iter().filter(|row| row.group == "params") {
        if let Some(b) = &row.stats.first_bad {
            out.push_str(&format!("bad value: {}\n", b.text()));
        }
    }
    out
}

#[cfg(test)]
mod tests;
