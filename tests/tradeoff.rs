//! The trade-off table's figures are what they claim: for one variant, recompute the error
//! independently (GPU pairs kernel at the grid's directions against the f64 reference of the
//! truth), and check the Pareto marking against its definition.

mod common;

use lobe::gpu::Gpu;
use lobe::grid::Grid;
use lobe::model::Reference;
use lobe::tradeoff::{eval_variants, mark_pareto, measure_eval, Row, REL_FLOOR};
use lobe::{resolve_params, Evaluator};

/// The table path and the pairs path feed the same f32 directions to the same GLSL function, so
/// the two error figures agree to the rounding of the final sums.
const SAME_FIGURE_RTOL: f64 = 1e-9;

#[test]
fn rational_g1_error_is_recomputed_independently() {
    let Some(dev) = common::gpu_device("tradeoff") else {
        return;
    };
    let gpu = Gpu::new(&dev);
    let params = resolve_params("cook_torrance", Some("glazed_ceramic"), &[]).unwrap();
    let (truth, variants) = eval_variants(&params, None);
    let chosen: Vec<_> = variants
        .into_iter()
        .filter(|v| v.name == "f32 GPU, rational G1")
        .collect();
    assert_eq!(
        chosen.len(),
        1,
        "the variant list has a rational-G1 variant for a Beckmann model"
    );
    let grid = Grid::Isotropic {
        n_theta_i: 12,
        n_theta_o: 12,
        n_dphi: 24,
    };
    let timing = Grid::Isotropic {
        n_theta_i: 8,
        n_theta_o: 8,
        n_dphi: 8,
    };
    let rows = measure_eval(Some(&gpu), &truth, &chosen, &grid, &timing, 1, &mut |_| {}).unwrap();
    let figure = rows[0].max_rel_error;

    // Independently: every (wi, wo) of the grid through the pairs kernel, and the truth in f64.
    let (wi, wo) = (grid.wi_list(), grid.wo_list());
    let pairs: Vec<_> = wi
        .iter()
        .flat_map(|a| wo.iter().map(move |b| (*a, *b)))
        .collect();
    let got = Evaluator::Gpu(&gpu)
        .eval_pairs(&chosen[0].params, false, &pairs)
        .unwrap();
    let r = Reference::new(&truth, false);
    let t: Vec<[f64; 3]> = pairs
        .iter()
        .map(|(a, b)| r.eval(*a, *b).to_array())
        .collect();
    let peak = t.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut max = 0.0f64;
    for (g, t) in got.iter().zip(&t) {
        for ch in 0..3 {
            max = max.max((g[ch] - t[ch]).abs() / t[ch].abs().max(REL_FLOOR * peak));
        }
    }
    assert!(
        (figure - max).abs() <= SAME_FIGURE_RTOL * max,
        "trade-off table says max relative error {figure:e}, independent recomputation gives {max:e}"
    );
    // Walter's rational G1 is within 0.35 % of the exact one (tests/microfacet.rs), and f ∝ G1(ωi)
    // G1(ωo) under separable masking but only ∝ 1/(1 + Λi + Λo) here: the error stays at the
    // percent level, far from zero and far from the O(1) of a different masking model.
    assert!(
        max > 1e-5 && max < 5e-2,
        "rational-G1 error {max:e} outside the expected range"
    );
}

#[test]
fn pareto_front_matches_its_definition() {
    let row = |name: &str, cost: f64, err: f64| Row {
        variant: name.into(),
        kind: "evaluation".into(),
        backend: "x".into(),
        cost,
        cost_unit: "ns/eval".into(),
        max_rel_error: err,
        rms_rel_error: err,
        albedo_abs_error: None,
        pareto: false,
    };
    let mut rows = vec![
        row("a", 1.0, 1e-2),
        row("b", 2.0, 1e-4),
        row("c", 3.0, 1e-3),
        row("d", 1.0, 1e-1),
    ];
    mark_pareto(&mut rows);
    let front: Vec<&str> = rows
        .iter()
        .filter(|r| r.pareto)
        .map(|r| r.variant.as_str())
        .collect();
    assert_eq!(
        front,
        ["a", "b"],
        "c is beaten by b (cheaper and more accurate), d by a"
    );
}
