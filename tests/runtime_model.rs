//! Models defined at run time join the built-in set: registered with a parameter table and
//! SPIR-V kernels, they evaluate on the GPU through the same pipelines; without an f64
//! reference every job that needs one refuses with a sentence; with one, the CPU backend and the
//! integrators use it. The kernels here are the built-in `lambert` kernels, so the expected
//! values are exact: f = albedo/π (a closed form) and E = albedo (Lambert's albedo).

mod common;

use glam::DVec3;
use lobe::gpu::Gpu;
use lobe::model::kernels;
use lobe::model::runtime::RuntimeModel;
use lobe::model::{Model, ParamSet, ParamSpec};
use lobe::{AlbedoSettings, Error, Evaluator, Session};
use std::f64::consts::FRAC_1_PI;
use std::sync::Arc;

/// The f32 GPU result of ρ/π against f64: one rounding of ρ, one of 1/π, one product.
const F32_REL: f64 = 4.0 * f32::EPSILON as f64;

/// A copy of `lambert` under another name, with lambert's kernels and, optionally, a reference.
/// Its one parameter is what lambert's kernels read from their block, albedo / π (lambert's host
/// side divides once per parameter set), so f is the parameter itself.
fn lambert_twin(name: &str, with_reference: bool) -> Model {
    let params = vec![ParamSpec::rgb("albedo_over_pi", 0.1, "albedo / π")];
    let mut m = RuntimeModel::new(name, "Lambert, defined at run time", params, true)
        .expect("a valid run-time model");
    for kernel in ["pairs", "table", "albedo", "preview"] {
        let spirv = kernels::spirv(kernel, "lambert").expect("lambert's kernel");
        m = m.with_kernel(kernel, spirv);
    }
    if with_reference {
        m = m.with_reference(Arc::new(|v: &[f64], _wi: DVec3, _wo: DVec3| {
            DVec3::new(v[0], v[1], v[2])
        }));
    }
    m.register().expect("a new name")
}

fn pairs() -> Vec<(DVec3, DVec3)> {
    let d = |t: f64, p: f64| DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    vec![
        (d(0.3, 0.0), d(1.2, 2.0)),
        (d(1.5, 1.0), d(0.1, 4.0)),
        (DVec3::Z, DVec3::Z),
    ]
}

/// The built-in lambert with albedo ρ (the same value in every channel where one is given).
fn lambert(albedo: &str) -> ParamSet {
    let mut p = ParamSet::defaults(Model::Lambert);
    p.set_text(&format!("albedo={albedo}")).expect("albedo");
    p
}

/// The twin of lambert with albedo `rho`: its parameter is ρ/π, formed in f64 as lambert's host
/// side forms it.
fn twin(model: Model, rho: &[f64]) -> ParamSet {
    let text: Vec<String> = rho.iter().map(|r| format!("{}", r * FRAC_1_PI)).collect();
    let mut p = ParamSet::defaults(model);
    p.set_text(&format!("albedo_over_pi={}", text.join(",")))
        .expect("albedo_over_pi");
    p
}

#[test]
fn a_model_without_reference_runs_on_the_gpu_and_refuses_the_cpu() {
    let model = lambert_twin("lambert_gpu_only", false);
    assert_eq!(Model::from_name("lambert_gpu_only").unwrap(), model);
    assert!(!model.has_reference());
    let p = twin(model, &[0.2, 0.4, 0.8]);

    let cpu = Session::cpu();
    let e = cpu.eval_pairs(&p, &pairs()).unwrap_err();
    assert!(matches!(e, Error::NoReference(_)), "{e}");
    assert!(
        e.to_string().contains("lambert_gpu_only") && e.to_string().contains("no f64"),
        "{e}"
    );
    let e = cpu
        .stability(vec![model], &mut |_| {})
        .expect_err("the sweep needs the reference");
    assert!(matches!(e, Error::NoReference(_)), "{e}");

    let Some(dev) = common::gpu_device("run-time model on the GPU") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let f = Evaluator::gpu(&gpu).eval_pairs(&p, &pairs()).expect("gpu");
    common::assert_rho_over_pi(&f, [0.2, 0.4, 0.8], F32_REL);
    // Its GPU albedo by a fixed rule works (no reference needed) and gives E = albedo.
    let s = AlbedoSettings {
        method: lobe::integrate::Method::Gauss,
        samples: 4096,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let e = lobe::integrate::directional(&Evaluator::gpu(&gpu), &p, &s, &[(0.5, 0.0)])
        .expect("gpu albedo");
    assert!((e[0].albedo.z - 0.8).abs() < 1e-5, "{:?}", e[0].albedo);
    let e = lobe::integrate::directional(
        &Evaluator::gpu(&gpu),
        &p,
        &AlbedoSettings {
            method: lobe::integrate::Method::Reference,
            ..s
        },
        &[(0.5, 0.0)],
    )
    .expect_err("the reference integrator needs the f64 reference");
    assert!(format!("{e:#}").contains("no f64 CPU reference"), "{e:#}");
    common::assert_validation_clean(&gpu, "run-time model on the GPU");
}

#[test]
fn a_model_with_reference_runs_on_both_backends() {
    let model = lambert_twin("lambert_with_reference", true);
    let p = twin(model, &[0.6]);
    let cpu = Session::cpu();
    let f = cpu.eval_pairs(&p, &pairs()).expect("cpu");
    assert!(f.iter().all(|v| v[1] == 0.6 * FRAC_1_PI), "{f:?}");
    // The adaptive reference integrates the run-time reference: E = albedo.
    let s = AlbedoSettings {
        method: lobe::integrate::Method::Reference,
        samples: 0,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let e = cpu
        .directional_albedo(&p, &s, &[(0.3, 0.0)])
        .expect("albedo");
    assert!((e[0].albedo.x - 0.6).abs() < 1e-9, "{:?}", e[0].albedo);
    // Tables from the built-in lambert and its run-time twin agree value for value.
    let grid = lobe::grid::Grid::Isotropic {
        n_theta_i: 3,
        n_theta_o: 4,
        n_dphi: 5,
    };
    let twin = cpu.table(&p, &grid, 1 << 10).expect("twin table");
    let builtin = cpu
        .table(&lambert("0.6"), &grid, 1 << 10)
        .expect("lambert table");
    assert_eq!(twin, builtin);
}

#[test]
fn bad_run_time_models_are_refused_with_a_sentence() {
    let e = RuntimeModel::new("lambert", "a clash", vec![], true)
        .unwrap()
        .register()
        .unwrap_err();
    assert!(e.to_string().contains("a name no other model has"), "{e}");
    let e = RuntimeModel::new("has space", "", vec![], true).unwrap_err();
    assert!(e.to_string().contains("letters, digits"), "{e}");
}

/// A named choice of a run-time model reaches the kernels as its option's index, a `uint` in
/// the std430 block after the numbers before it.
#[test]
fn a_choice_is_its_index_in_the_parameter_block() {
    let params = vec![
        ParamSpec::scalar("gain", 0.0, 2.0, 1.0, "a number"),
        ParamSpec::choice("kind", &["a", "b", "c"], 0, "a choice"),
    ];
    let model = RuntimeModel::new("with_choice", "", params, true)
        .unwrap()
        .register()
        .expect("a new name");
    let mut p = ParamSet::defaults(model);
    p.set_text("kind=c").expect("an option");
    let block = lobe::model::Brdf::new(&p).gpu_block();
    assert_eq!(block.len(), 8);
    assert_eq!(&block[0..4], &1.0f32.to_le_bytes());
    assert_eq!(&block[4..8], &2u32.to_le_bytes());
    let e = p.set_text("kind=d").unwrap_err();
    assert!(e.to_string().contains("one of: a, b, c"), "{e}");
}
