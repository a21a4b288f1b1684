//! `lobe tradeoff`: what each speed-for-accuracy choice costs and gains, measured on this device.
//!
//! Evaluation variants of one model and parameter set: the f64 CPU reference; the model as given
//! in f32 on the GPU; GLSL's plain `pow` instead of the careful cos^n formulation; and for
//! microfacet models (`cook_torrance` is `microfacet` with Beckmann, V-cavity and Schlick)
//! Schlick's vs the exact Fresnel factor, Walter's rational vs the exact Beckmann G1, and V-cavity
//! vs separable vs height-correlated Smith masking.
//!
//! Error is measured against one truth: the f64 reference of the most exact configuration of the
//! same model (exact Fresnel — a conductor's where the material gives η and κ, else a dielectric's
//! from the IOR —, exact G1, height-correlated Smith: Heitz 2014 argues it is the physically right
//! form). So an approximation's figure includes both its modelling error and its f32 error.
//! Relative errors use a floor of [`REL_FLOOR`] × the largest |f| of the truth, so that the far
//! tail of a lobe (values a renderer cannot see) does not dominate.

use crate::bench;
use crate::eval::Evaluator;
use crate::gpu::Gpu;
use crate::grid::Grid;
use crate::model::microfacet::MicrofacetConfig;
use crate::model::{Model, ParamSet, Reference, Value};
use anyhow::Result;
use serde::Serialize;

/// Relative errors are |g − t| / max(|t|, REL_FLOOR · max|t|).
pub const REL_FLOOR: f64 = 1e-3;

#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub variant: String,
    /// "evaluation" (cost in ns per evaluation) or "integration" (cost in ms per albedo).
    pub kind: String,
    pub backend: String,
    pub cost: f64,
    pub cost_unit: String,
    pub max_rel_error: f64,
    pub rms_rel_error: f64,
    /// Largest absolute error of the directional albedo (integration variants only).
    pub albedo_abs_error: Option<f64>,
    pub pareto: bool,
}

/// One evaluation variant: a parameter set, where it runs, and whether it uses the fast pow.
#[derive(Clone, Debug)]
pub struct EvalVariant {
    pub name: String,
    pub params: ParamSet,
    pub gpu: bool,
    pub fast_pow: bool,
}

/// A microfacet parameter set equal to `p` (cook_torrance is converted), or None for other models.
pub fn as_microfacet(p: &ParamSet) -> Option<ParamSet> {
    match p.model() {
        Model::Microfacet(_) => Some(p.clone()),
        Model::CookTorrance => {
            let mut m = ParamSet::defaults(Model::Microfacet(MicrofacetConfig::DEFAULT));
            for (k, v) in [
                ("distribution", "beckmann"),
                ("masking", "v_cavity"),
                ("beckmann_g1", "exact"),
                ("fresnel", "schlick"),
            ] {
                m.set_text(&format!("{k}={v}")).ok()?;
            }
            m.set("alpha", p.get("roughness")).ok()?;
            m.set("ior", p.get("ior")).ok()?;
            m.set("diffuse", p.get("diffuse")).ok()?;
            m.set("specular", p.get("specular")).ok()?;
            Some(m)
        }
        _ => None,
    }
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
        if matches!(
            params.model(),
            Model::Phong | Model::BlinnPhong | Model::AshikhminShirley
        ) {
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
            let r = Evaluator::Gpu(g).eval_table(&v.params, false, grid, &mut sink);
            g.set_fast_pow(false);
            r?;
        }
        (true, None) => anyhow::bail!("variant '{}' needs the GPU backend", v.name),
        (false, _) => Evaluator::Cpu.eval_table(&v.params, false, grid, &mut sink)?,
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
                let m = bench::measure(&Evaluator::Gpu(g), &v.params, timing_grid, repeats);
                g.set_fast_pow(false);
                let m = m?;
                (1e9 / m.kernel_per_s.unwrap_or(m.wall_per_s), m.backend)
            }
            _ => {
                let m = bench::measure(&Evaluator::Cpu, &v.params, timing_grid, repeats)?;
                (1e9 / m.wall_per_s, m.backend)
            }
        };
        rows.push(Row {
            variant: v.name.clone(),
            kind: "evaluation".into(),
            backend,
            cost,
            cost_unit: "ns/eval".into(),
            max_rel_error,
            rms_rel_error,
            albedo_abs_error: None,
            pareto: false,
        });
    }
    mark_pareto(&mut rows);
    Ok(rows)
}

/// Marks, within each kind, the rows that no other row beats in both cost and max error.
pub fn mark_pareto(rows: &mut [Row]) {
    let snapshot: Vec<(String, f64, f64)> = rows
        .iter()
        .map(|r| {
            (
                r.kind.clone(),
                r.cost,
                r.albedo_abs_error.unwrap_or(r.max_rel_error),
            )
        })
        .collect();
    for (i, r) in rows.iter_mut().enumerate() {
        let (kind, cost, err) = &snapshot[i];
        r.pareto = !snapshot.iter().enumerate().any(|(j, (k, c, e))| {
            j != i && k == kind && c <= cost && e <= err && (c < cost || e < err)
        });
    }
}
