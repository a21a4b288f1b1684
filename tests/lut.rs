//! Albedo look-up tables (docs/design.md §5.7): the table's entries are `lobe albedo` at the same
//! (μ, p), Lambert's table is its albedo, the files round-trip, bad input is refused before any
//! file appears, and the GPU table agrees with the CPU one.

mod common;

use glam::DVec3;
use lobe::gpu::Gpu;
use lobe::integrate::{directional, hemispherical, Method, Settings};
use lobe::lut::{self, LutSpec, Mapping};
use lobe::{resolve_params, Evaluator, ParamSet};
use std::path::Path;
use std::process::Command;

/// Files hold f32: an entry read back differs from the f64 value by at most half an f32 ulp
/// (2^-24 relative), and JSON prints f64 in full.
const F32_RTOL: f64 = 6e-8;

/// GPU (f32 sums) against CPU (f64) for the same rule: the bound tests/albedo.rs justifies.
const GPU_RTOL: f64 = 2e-5;
const GPU_ATOL: f64 = 1e-7;

fn params(model: &str, material: Option<&str>, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params(model, material, &sets).expect("valid test parameters")
}

fn small_spec(p: ParamSet) -> LutSpec {
    let mut s = LutSpec::new(p);
    s.n_mu = 5;
    s.n_p = 3;
    // Fewer nodes keep the test quick; the comparison is with the same rule.
    s.samples = 1 << 12;
    s
}

#[track_caller]
fn close(what: &str, got: f64, want: f64, rtol: f64, atol: f64) {
    let diff = (got - want).abs();
    assert!(
        diff <= atol + rtol * want.abs(),
        "{what}: expected {want}, got {got}, |diff| {diff:.3e}, allowed {:.3e}",
        atol + rtol * want.abs()
    );
}

#[test]
fn lut_entries_are_the_directional_albedo_at_the_same_mu_and_p() {
    for (model, mat) in [("cook_torrance", "gold"), ("smooth_layered", "tin")] {
        let spec = small_spec(params(model, Some(mat), &[]));
        let lut = lut::compute(&Evaluator::cpu(), &spec, &mut |_, _| {}).expect("lut");
        assert_eq!(lut.mus, vec![0.1, 0.3, 0.5, 0.7, 0.9], "cell-centred mu");
        let settings = Settings {
            method: spec.method,
            samples: spec.samples,
            seed: lobe::integrate::DEFAULT_SEED,
            white_furnace: false,
        };
        for (k, &p) in lut.ps.iter().enumerate() {
            let at = spec.params_at(p).expect("in range");
            let pts: Vec<(f64, f64)> = lut.mus.iter().map(|&m| (m, 0.0)).collect();
            let direct = directional(&Evaluator::cpu(), &at, &settings, &pts).expect("cpu");
            for (j, d) in direct.iter().enumerate() {
                assert_eq!(
                    lut.e[k * spec.n_mu + j],
                    d.albedo,
                    "{model} {:?} = {p}, mu = {}",
                    spec.keys,
                    d.mu
                );
            }
            let h = hemispherical(&Evaluator::cpu(), &at, &settings, 0.0).expect("cpu");
            assert_eq!(lut.e_avg[k], h.e_avg, "{model} E_avg at p = {p}");
        }
    }
}

#[test]
fn parameter_axes_are_cell_centred_in_the_mapping() {
    let mut spec = small_spec(params("phong", None, &[]));
    spec.n_p = 4;
    // Default: shininess 1 .. 8192, log: p_k = 8192^((k + 1/2)/4).
    let want: Vec<f64> = (0..4)
        .map(|k| 8192f64.powf((k as f64 + 0.5) / 4.0))
        .collect();
    for (g, w) in spec.ps().iter().zip(&want) {
        close("log axis", *g, *w, 1e-14, 0.0);
    }
    spec.mapping = Mapping::Square;
    spec.lo = 0.0;
    spec.hi = 2.0;
    assert_eq!(
        spec.ps(),
        vec![2.0 / 64.0, 18.0 / 64.0, 50.0 / 64.0, 98.0 / 64.0]
    );
}

#[test]
fn lambert_lut_is_its_albedo_and_the_files_round_trip() {
    // Lambert: E(μ) = albedo for every μ (docs/design.md §5), and E_avg = albedo. The axis is the
    // albedo itself (grey), so E(μ_j, p_k) = p_k.
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("lambert.exr");
    let mut spec = small_spec(params("lambert", None, &[]));
    spec.n_p = 4;
    let lut = lut::write(&Evaluator::cpu(), &spec, &path, &mut |_, _| {}).expect("write");
    assert_eq!(lut.files.len(), 4);
    for (k, &p) in lut.ps.iter().enumerate() {
        for j in 0..spec.n_mu {
            let e = lut.e[k * spec.n_mu + j];
            for c in 0..3 {
                // The peak rule integrates the cosine to round-off (tests/albedo.rs).
                close("lambert E", e[c], p, 1e-13, 1e-15);
            }
        }
        close("lambert E_avg", lut.e_avg[k].x, p, 1e-13, 1e-15);
    }
    let from_npy = lut::read_npy(&path).expect("npy");
    let from_exr = lut::read_exr(&path).expect("exr");
    assert_eq!(from_npy, from_exr, "npy and EXR hold the same table");
    assert_eq!((from_npy.n_mu, from_npy.n_p), (spec.n_mu, spec.n_p));
    let f32s = |v: &DVec3| [v.x as f32, v.y as f32, v.z as f32];
    assert_eq!(from_npy.e, lut.e.iter().map(f32s).collect::<Vec<_>>());
    assert_eq!(
        from_npy.e_avg,
        lut.e_avg.iter().map(f32s).collect::<Vec<_>>()
    );
    let side: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(path.with_extension("json")).expect("sidecar"),
    )
    .expect("JSON");
    assert_eq!(side["model"], "lambert");
    assert_eq!(side["parameter_axis"]["keys"][0], "albedo");
    assert_eq!(side["parameter_axis"]["mapping"], "linear");
    assert!(side["mu_axis"]["centring"]
        .as_str()
        .is_some_and(|s| s.contains("(j + 0.5)")));
    assert_eq!(side["method"], "peak");
    assert!(
        side["parameters"].get("albedo").is_none(),
        "the axis key is not a fixed parameter: {side}"
    );
    // Nothing else in the folder: the temporary files were renamed, not left behind.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
}

fn lobe(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .output()
        .expect("run lobe")
}

#[test]
fn cli_lut_matches_cli_albedo() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("ct.exr");
    let p = path.to_str().expect("utf-8 path");
    let out = lobe(&[
        "albedo",
        "--model",
        "cook_torrance",
        "--material",
        "tin",
        "--backend",
        "cpu",
        "--samples",
        "4096",
        "--lut",
        p,
        "--lut-res",
        "4,2",
        "--lut-range",
        "0.05,0.5",
        "--lut-map",
        "linear",
    ]);
    assert!(
        out.status.success(),
        "lobe albedo --lut failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = lut::read_npy(&path).expect("npy");
    // Roughness cells: 0.05 + 0.45 (k + 1/2)/2 = 0.1625, 0.3875; mu = 0.125, 0.375, 0.625, 0.875.
    for (k, rough) in [0.1625, 0.3875].iter().enumerate() {
        let out = lobe(&[
            "albedo",
            "--model",
            "cook_torrance",
            "--material",
            "tin",
            "--backend",
            "cpu",
            "--samples",
            "4096",
            "--set",
            &format!("roughness={rough}"),
            "--mu",
            "0.125,0.375,0.625,0.875",
            "--format",
            "json",
        ]);
        assert!(out.status.success());
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
        for (j, pt) in doc["points"].as_array().expect("points").iter().enumerate() {
            for c in 0..3 {
                let want = pt["albedo"][c].as_f64().expect("number");
                let got = table.e[k * 4 + j][c] as f64;
                close(
                    &format!("roughness {rough} mu {} channel {c}", pt["mu"]),
                    got,
                    want,
                    F32_RTOL,
                    1e-30,
                );
            }
        }
        let want = doc["hemispherical"]["e_avg"][0].as_f64().expect("number");
        close("E_avg", table.e_avg[k][0] as f64, want, F32_RTOL, 1e-30);
    }
}

#[test]
fn bad_lut_input_is_refused_with_a_sentence_and_no_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("bad.exr");
    let p = path.to_str().expect("utf-8 path");
    let cases: [(&[&str], &str); 5] = [
        (&["--lut-param", "shine"], "--lut-param shine"),
        (
            &["--lut-param", "roughness", "--lut-range=-0.1,1"],
            "(0, 1]",
        ),
        (&["--lut-range", "0.5,0.1"], "LO < HI"),
        (&["--lut-res", "0,8"], "NMU = 0"),
        (
            &[
                "--lut-param",
                "diffuse",
                "--lut-range",
                "0,1",
                "--lut-map",
                "log",
            ],
            "LO must be > 0",
        ),
    ];
    for (extra, needle) in cases {
        let mut args = vec![
            "albedo",
            "--model",
            "cook_torrance",
            "--backend",
            "cpu",
            "--lut",
            p,
        ];
        args.extend_from_slice(extra);
        let out = lobe(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?} was accepted");
        assert!(
            err.contains(needle) && !err.contains("panicked"),
            "{extra:?}: expected '{needle}' in: {err}"
        );
    }
    let out = lobe(&[
        "albedo",
        "--backend",
        "cpu",
        "--lut",
        "/tmp/x.png",
        "--lut-res",
        "2,2",
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains(".exr"));
    assert_eq!(
        std::fs::read_dir(dir.path()).expect("list").count(),
        0,
        "a refused LUT leaves no file"
    );
    // A folder where the sidecar would go: refused before anything is computed or renamed.
    std::fs::create_dir(path.with_extension("json")).expect("mkdir");
    let e = lut::write(
        &Evaluator::cpu(),
        &small_spec(params("lambert", None, &[])),
        &path,
        &mut |_, _| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("folder"), "{e}");
    assert!(!Path::new(&path).exists() && !path.with_extension("npy").exists());
}

#[test]
fn gpu_lut_agrees_with_the_cpu_lut() {
    let Some(dev) = common::gpu_device("gpu_lut_agrees_with_the_cpu_lut") else {
        return;
    };
    let gpu = Gpu::new(dev);
    for method in [Method::Peak, Method::Importance] {
        let mut spec = small_spec(params("cook_torrance", Some("gold"), &[]));
        spec.method = method;
        let g = lut::compute(&Evaluator::gpu(&gpu), &spec, &mut |_, _| {}).expect("gpu");
        // The GPU receives f32 parameters; the CPU gets the same rounded values (the axis value
        // itself is rounded too on the GPU: a 6e-8 relative change of m, far inside GPU_RTOL).
        spec.params = spec.params.rounded_to_f32();
        let c = lut::compute(&Evaluator::cpu(), &spec, &mut |_, _| {}).expect("cpu");
        for (i, (g, c)) in g.e.iter().zip(&c.e).enumerate() {
            for ch in 0..3 {
                close(
                    &format!("{} E entry {i} channel {ch}", method.name()),
                    g[ch],
                    c[ch],
                    GPU_RTOL,
                    GPU_ATOL,
                );
            }
        }
    }
    common::assert_validation_clean(&gpu, "gpu_lut_agrees_with_the_cpu_lut");
}
