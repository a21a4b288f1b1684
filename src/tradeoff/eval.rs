//! The evaluation section: variants of evaluating f itself (precision, Fresnel factor, masking,
//! Beckmann G1, pow), each measured for its relative error of f against one f64 truth and for
//! its cost per evaluation (see the notes of [`crate::tradeoff`]).

use super::{mark_pareto, Row, Section};
use crate::backend::Precision;
use crate::bench;
use crate::eval::Evaluator;
use crate::grid::Grid;
use crate::model::microfacet::MicrofacetConfig;
use crate::model::{Model, ParamSet, Reference, Value};
use anyhow::Result;

/// Relative errors are |g − t| / max(|t|, REL_FLOOR · max|t|).
pub const REL_FLOOR: f64 = 1e-3;

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
pub fn variant_table(gpu: Option<&Evaluator>, v: &EvalVariant, grid: &Grid) -> Result<Vec<f32>> {
    let mut out = Vec::new();
    let mut sink = |_: u64, values: &[f32]| {
        out.extend_from_slice(values);
        Ok(())
    };
    match (v.gpu, gpu) {
        (true, Some(g)) => g
            .with_fast_pow(v.fast_pow)
            .eval_table(&v.params, grid, &mut sink)?,
        (true, None) => anyhow::bail!("variant '{}' needs the GPU backend", v.name),
        (false, _) => Evaluator::cpu().eval_table(&v.params, grid, &mut sink)?,
    }
    Ok(out)
}

/// Measures every evaluation variant: error on `error_grid`, cost on `timing_grid`; the GPU
/// variants run where `backend` is the GPU, and its cancellation token stops the section
/// between variants.
pub fn measure_eval(
    backend: &Evaluator,
    truth: &ParamSet,
    variants: &[EvalVariant],
    error_grid: &Grid,
    timing_grid: &Grid,
    repeats: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>> {
    truth.model().require_reference("the trade-off's truth")?;
    // The f32 backend where there is one; its variants are left out without it.
    let gpu = (backend.precision() == Precision::F32).then_some(backend);
    let t = truth_table(truth, error_grid);
    let mut rows = Vec::new();
    for v in variants {
        if v.gpu && gpu.is_none() {
            continue;
        }
        backend.check_cancelled()?;
        progress(&v.name);
        let got = variant_table(gpu, v, error_grid)?;
        let (max_rel_error, rms_rel_error) = relative_errors(&got, &t);
        let (cost, backend) = match (v.gpu, gpu) {
            (true, Some(g)) => {
                let ev = g.with_fast_pow(v.fast_pow);
                let m = bench::measure(&ev, &v.params, timing_grid, repeats)?;
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
            variance_per_sample: None,
        });
    }
    mark_pareto(&mut rows);
    Ok(rows)
}

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
