//! `lobe fit`: known parameters recovered from targets made by a model (as a model and as its
//! MERL file), the loss of a perfect fit, and refused input.

mod common;

use lobe::fit::{self, FitOptions, Objective, Samples, Space, Target};
use lobe::loss::LossKind;
use lobe::{ParamSet, Session};
use std::process::Command;

/// The goal's bound on a recovered parameter: 1 % of the truth.
const RECOVERY_TOLERANCE: f64 = 0.01;

/// Bins per test fit: enough to pin four numbers, small enough for a test.
const TEST_BINS: usize = 4096;

fn ggx(alpha: f64, specular: [f64; 3]) -> ParamSet {
    ParamSet::for_model("microfacet")
        .and_then(|p| p.with_choice("distribution", "ggx"))
        .and_then(|p| p.with("alpha", alpha))
        .and_then(|p| p.with("specular", specular))
        .unwrap()
}

fn space() -> Space {
    let base = ParamSet::for_model("microfacet")
        .and_then(|p| p.with_choice("distribution", "ggx"))
        .unwrap();
    Space::new(base, &["alpha".into(), "specular".into()], &[]).unwrap()
}

fn opts() -> FitOptions {
    FitOptions {
        max_bins: TEST_BINS,
        ..FitOptions::default()
    }
}

fn assert_recovered(report: &fit::FitReport, alpha: f64, specular: [f64; 3]) {
    let got_alpha = report.params.scalar("alpha");
    let got_spec = report.params.rgb("specular").to_array();
    let rel = |a: f64, b: f64| (a - b).abs() / b;
    assert!(
        rel(got_alpha, alpha) < RECOVERY_TOLERANCE,
        "alpha: truth {alpha}, fitted {got_alpha} (loss {:e})",
        report.loss.total
    );
    for c in 0..3 {
        assert!(
            rel(got_spec[c], specular[c]) < RECOVERY_TOLERANCE,
            "specular[{c}]: truth {}, fitted {} (loss {:e})",
            specular[c],
            got_spec[c],
            report.loss.total
        );
    }
}

#[test]
fn recovers_ggx_alpha_and_specular_from_a_model_target() {
    let (alpha, specular) = (0.25, [0.9, 0.7, 0.4]);
    let session = Session::cpu();
    let target = Target::Model(ggx(alpha, specular));
    let r = fit::fit(&session.evaluator(), &target, &space(), &opts(), &|_| {}).unwrap();
    assert_recovered(&r, alpha, specular);
    assert_eq!(r.samples.used, TEST_BINS);
    assert!(r.evaluations > 0 && r.rounds > 0 && r.iterations > 0);
}

#[test]
fn recovers_ggx_from_its_merl_file_on_the_gpu() {
    let (alpha, specular) = (0.15, [0.95, 0.64, 0.3]);
    let Some(session) = common::gpu_session("recovers_ggx_from_its_merl_file_on_the_gpu") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gold_ggx.binary");
    session
        .write_merl(&ggx(alpha, specular), &path, &mut |_, _| {})
        .unwrap();
    let r = fit::fit(
        &session.evaluator(),
        &Target::Merl(path),
        &space(),
        &opts(),
        &|_| {},
    )
    .unwrap();
    assert_recovered(&r, alpha, specular);
    // Four starts, so a round holds up to four candidates: fewer rounds than evaluations.
    assert!(r.rounds < r.evaluations, "{} {}", r.rounds, r.evaluations);
    assert_eq!(session.validation_messages(), 0);
}

#[test]
fn a_perfect_fit_has_zero_loss() {
    let truth = ggx(0.3, [0.8, 0.5, 0.2]);
    let session = Session::cpu();
    let eval = session.evaluator();
    let samples: Samples =
        fit::target::samples(&Target::Model(truth.clone()), &eval, TEST_BINS).unwrap();
    for kind in [LossKind::CosineLog, LossKind::RelativeL2] {
        let objective = Objective::new(eval, &samples, kind, 1);
        let e = objective
            .losses(std::slice::from_ref(&truth))
            .unwrap()
            .remove(0);
        assert_eq!(e.total, 0.0, "{kind:?}");
        assert_eq!(e.channel, [0.0; 3], "{kind:?}");
        let off = ggx(0.31, [0.8, 0.5, 0.2]);
        assert!(objective.losses(&[off]).unwrap()[0].total > 0.0);
    }
}

/// Runs `lobe fit ARGS` on the CPU backend: (exit success, stderr).
fn lobe_fit(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .arg("fit")
        .args(args)
        .args(["--backend", "cpu", "--max-bins", "256", "--max-iters", "5"])
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_input_is_refused_with_a_sentence() {
    let cases: [(&[&str], &[&str]); 4] = [
        (
            &[
                "--target",
                "lambert",
                "--model",
                "phong",
                "--free",
                "roughness",
            ],
            &["--free", "roughness", "shininess"],
        ),
        (
            &[
                "--target",
                "lambert",
                "--model",
                "microfacet",
                "--free",
                "distribution",
            ],
            &["distribution", "choice", "not a number"],
        ),
        (
            &[
                "--target",
                "lambert",
                "--model",
                "phong",
                "--set",
                "shininess=10",
                "--free",
                "shininess",
            ],
            &["shininess", "fixed or fitted"],
        ),
        (
            &[
                "--target",
                "lambert",
                "--model",
                "phong{shininess=10}",
                "--free",
                "shininess,diffuse",
            ],
            &["shininess", "fixed or fitted"],
        ),
    ];
    for (args, words) in cases {
        let (ok, err) = lobe_fit(args);
        assert!(!ok, "{args:?} was accepted");
        for w in words {
            assert!(err.contains(w), "{args:?}: '{w}' not in: {err}");
        }
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn a_target_without_valid_bins_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.binary");
    // Every stored value negative: MERL's mark of a missing measurement.
    std::fs::write(&path, lobe::merl::encode(&vec![-1.0; 3 * lobe::merl::BINS])).unwrap();
    let (ok, err) = lobe_fit(&[
        "--target",
        path.to_str().unwrap(),
        "--model",
        "lambert",
        "--free",
        "albedo",
    ]);
    assert!(!ok);
    assert!(
        err.contains("--target") && err.contains("none of its"),
        "{err}"
    );
    assert!(err.contains("1458000 missing"), "{err}");
}

#[test]
fn output_prefix_draws_target_and_fit_and_a_table_target_is_refused_for_it() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("fit");
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(["fit", "--target", "phong{shininess=40}", "--model", "phong"])
        .args([
            "--free",
            "shininess",
            "--backend",
            "cpu",
            "--max-bins",
            "256",
        ])
        .args(["--max-iters", "20", "-o", prefix.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for name in ["fit_polar.png", "fit_difference.png"] {
        let len = std::fs::metadata(dir.path().join(name)).unwrap().len();
        assert!(len > 1000, "{name}: {len} bytes");
    }
    // A table target: no model to draw, refused before any work, nothing written.
    let table = dir.path().join("t.exr");
    let made = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "table",
            "--model",
            "lambert",
            "--grid",
            "isotropic",
            "--res",
            "4,4,4",
        ])
        .args(["--backend", "cpu", "-o", table.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(made.status.success());
    let prefix2 = dir.path().join("t_fit");
    let (ok, err) = lobe_fit(&[
        "--target",
        dir.path().join("t.npy").to_str().unwrap(),
        "--model",
        "lambert",
        "--free",
        "albedo",
        "-o",
        prefix2.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("-o") && err.contains("table"), "{err}");
    assert!(!dir.path().join("t_fit_polar.png").exists());
}

#[test]
fn a_table_target_is_read_through_its_sidecar() {
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("t.exr");
    let made = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "table",
            "--model",
            "lambert",
            "--set",
            "albedo=0.25,0.5,0.75",
        ])
        .args(["--grid", "isotropic", "--res", "8,8,8", "--backend", "cpu"])
        .args(["-o", table.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(made.status.success());
    let base = ParamSet::for_model("lambert").unwrap();
    let space = Space::new(base, &["albedo".into()], &[]).unwrap();
    let session = Session::cpu();
    let r = fit::fit(
        &session.evaluator(),
        &Target::Table(dir.path().join("t.npy")),
        &space,
        &FitOptions::default(),
        &|_| {},
    )
    .unwrap();
    assert_eq!(r.samples.used, 8 * 8 * 8);
    let got = r.params.rgb("albedo").to_array();
    for (c, truth) in [0.25, 0.5, 0.75].into_iter().enumerate() {
        // The table is f32: its values carry 6e-8 relative rounding, far inside 1 %.
        assert!(
            (got[c] - truth).abs() / truth < RECOVERY_TOLERANCE,
            "{c}: {got:?}"
        );
    }
    assert!(r.albedo.iter().all(|a| a.target.is_none()));
}
