//! `lobe compare` and `lobe::compare`: a model against itself, a closed form, a `.brdf` file and
//! a MERL file against their analytic twins, and bad requests refused before any file appears.

mod common;

use lobe::compare::{self, Bins, Comparison, Options, Side};
use lobe::grid::Grid;
use lobe::integrate::Settings;
use lobe::{ParamSet, Session};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Sums of ~2e5 terms in f64: rounding grows with the square root of the count, far below this.
const SUM_TOLERANCE: f64 = 1e-12;

/// The peak rule's albedo target (docs/design.md §5): 1e-6 relative, here on E ≤ 1.
const ALBEDO_TARGET: f64 = 1e-6;

/// Two f32 kernels of one formula written differently (the `.brdf` file's GLSL and the built-in
/// microfacet's): a few ulps of f32 per operation, a few dozen operations, well under 1e-4.
const TWIN_RELATIVE: f64 = 1e-4;

fn params(spec: &str, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    lobe::resolve_params(spec, None, &sets).unwrap_or_else(|e| panic!("{spec} {sets:?}: {e}"))
}

fn isotropic(n: usize) -> Bins {
    Bins::Grid(Grid::Isotropic {
        n_theta_i: n,
        n_theta_o: n,
        n_dphi: 2 * n,
    })
}

fn options(bins: Bins) -> Options {
    Options {
        bins,
        white_furnace: false,
        mus: vec![0.1, 0.5, 1.0],
        albedo: Some(Settings::default()),
    }
}

fn run(session: &Session, a: &ParamSet, b: &ParamSet, opts: &Options) -> Comparison {
    compare::compare(
        &session.evaluator(),
        &Side::new(a.clone()),
        &Side::new(b.clone()),
        opts,
        &mut |_, _| {},
    )
    .unwrap_or_else(|e| panic!("{} against {}: {e:#}", a.to_text(), b.to_text()))
}

fn assert_all_zero(r: &Comparison, what: &str) {
    let mut values = vec![
        r.relative_rms,
        r.relative_max,
        r.log_error.total,
        r.relative_l2.total,
    ];
    values.extend(r.log_error.channel);
    values.extend(r.relative_l2.channel);
    for p in r.directional.iter().chain(&r.hemispherical) {
        values.extend(p.difference);
    }
    assert_eq!(
        r.directional.is_empty(),
        r.hemispherical.is_none(),
        "{what}"
    );
    assert!(
        values.iter().all(|&v| v == 0.0),
        "{what}: a model against itself must give 0 for every metric: {r:?}"
    );
    assert!(r.largest.is_none(), "{what}: {r:?}");
    assert!(r.used > 0, "{what}: {r:?}");
}

#[test]
fn a_model_against_itself_is_zero_on_both_backends() {
    let cases = [
        (params("phong", &["shininess=200"]), isotropic(12)),
        (params("cook_torrance", &[]), isotropic(12)),
        (
            params("ashikhmin_shirley", &["nu=10", "nv=300"]),
            Bins::Grid(Grid::Full {
                n_theta_i: 6,
                n_phi_i: 12,
                n_theta_o: 6,
                n_phi_o: 12,
            }),
        ),
        (
            params("microfacet", &[]),
            Bins::Grid(Grid::HalfDiff {
                n_theta_h: 20,
                n_theta_d: 20,
                n_phi_d: 20,
            }),
        ),
    ];
    // The albedo of an anisotropic set integrates thousands of view directions: the albedo
    // part runs for the isotropic sets, and on the GPU for the first (the table part for all).
    let opts = |k: usize, bins: Bins, albedo: bool| Options {
        albedo: (albedo && k < 2).then(Settings::default),
        ..options(bins)
    };
    let cpu = Session::cpu();
    for (k, (p, bins)) in cases.iter().enumerate() {
        assert_all_zero(&run(&cpu, p, p, &opts(k, *bins, true)), &p.to_text());
    }
    let Some(gpu) = common::gpu_session("a_model_against_itself_is_zero_on_both_backends") else {
        return;
    };
    for (k, (p, bins)) in cases.iter().enumerate() {
        assert_all_zero(&run(&gpu, p, p, &opts(k, *bins, k == 0)), &p.to_text());
    }
    assert_eq!(gpu.validation_messages(), 0);
}

/// Lambert ρ against Lambert 1.1ρ: f_B = 1.1 f_A everywhere, so relative L2 = 0.1 exactly, the
/// floored relative difference is 0.1ρ/(1.1ρ) = 1/11 in every bin (RMS and max alike, as ρ/π is
/// far above the floor), and E_A − E_B = ρ − 1.1ρ = −0.1ρ at every μ (Lambert's albedo is ρ).
#[test]
fn lambert_against_a_brighter_lambert_has_closed_form_distances() {
    let rho = [0.8, 0.5, 0.2];
    let a = params("lambert", &["albedo=0.8,0.5,0.2"]);
    let b = params("lambert", &["albedo=0.88,0.55,0.22"]);
    let r = run(&Session::cpu(), &a, &b, &options(isotropic(20)));
    let near = |x: f64, want: f64, tol: f64, what: &str| {
        assert!(
            (x - want).abs() <= tol,
            "{what}: expected {want}, got {x} (|error| {:e} > {tol:e})",
            (x - want).abs()
        )
    };
    for x in r
        .relative_l2
        .channel
        .into_iter()
        .chain([r.relative_l2.total])
    {
        near(x, 0.1, SUM_TOLERANCE, "relative L2");
    }
    near(r.relative_max, 0.1 / 1.1, SUM_TOLERANCE, "max relative");
    near(r.relative_rms, 0.1 / 1.1, SUM_TOLERANCE, "RMS relative");
    assert_eq!(r.directional.len(), 3);
    for p in r.directional.iter().chain(&r.hemispherical) {
        for c in 0..3 {
            near(p.difference[c], -0.1 * rho[c], ALBEDO_TARGET, "E_A - E_B");
        }
    }
    assert!(r.log_error.total > 0.0);
}

fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata/brdf")
        .join(name)
}

/// testdata/brdf/ggx.brdf is GGX with separable Smith masking and Schlick's Fresnel over a
/// Lambertian base: the built-in microfacet model in that configuration.
#[test]
fn the_ggx_brdf_file_is_close_to_its_built_in_twin() {
    let Some(gpu) = common::gpu_session("the_ggx_brdf_file_is_close_to_its_built_in_twin") else {
        return;
    };
    let loaded =
        lobe::brdf::load(&testdata("ggx.brdf"), &lobe::brdf::LoadOptions::default()).unwrap();
    let mut file = ParamSet::defaults(loaded.model);
    for s in ["alpha=0.3", "diffuse=0.1,0.2,0.3"] {
        file.set_text(s).unwrap();
    }
    let twin = params(
        "microfacet",
        &[
            "distribution=ggx",
            "masking=smith_separable",
            "fresnel=schlick",
            "alpha=0.3",
            "f0=1,0.78,0.34",
            "diffuse=0.1,0.2,0.3",
        ],
    );
    let r = run(&gpu, &file, &twin, &options(isotropic(16)));
    assert!(r.relative_max < TWIN_RELATIVE, "{r:?}");
    assert!(r.relative_l2.total < TWIN_RELATIVE, "{r:?}");
    assert!(r.log_error.total < TWIN_RELATIVE, "{r:?}");
    for p in r.directional.iter().chain(&r.hemispherical) {
        assert!(
            p.difference.iter().all(|d| d.abs() < 10.0 * ALBEDO_TARGET),
            "{p:?}"
        );
    }
    // On the CPU there is no f64 twin of a .brdf shader: the refusal says so.
    let e = compare::compare(
        &Session::cpu().evaluator(),
        &Side::new(file.clone()),
        &Side::new(twin),
        &options(isotropic(4)),
        &mut |_, _| {},
    )
    .unwrap_err();
    assert!(format!("{e:#}").contains("ggx"), "{e:#}");
    assert_eq!(gpu.validation_messages(), 0);
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lobe-compare-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A MERL file written from cook_torrance on the CPU holds f at each bin's centre (to the
/// rounding of f/scale·scale), so on MERL's own bins, with nearest lookup, it equals its source.
#[test]
fn a_merl_file_equals_its_analytic_source_on_its_own_bins() {
    let d = temp_dir("merl");
    let path = d.join("ct_source.binary");
    let source = params("cook_torrance", &["roughness=0.3"]);
    let cpu = Session::cpu();
    cpu.write_merl(&source, &path, &mut |_, _| {}).unwrap();
    let loaded = lobe::merl::model::load(&path).unwrap();
    let file = ParamSet::defaults(loaded.model);
    let opts = Options {
        albedo: None,
        mus: Vec::new(),
        ..options(Bins::Merl)
    };
    let r = run(&cpu, &file, &source, &opts);
    assert_eq!(r.used + r.below_horizon, lobe::merl::BINS as u64);
    assert_eq!(r.missing, 0);
    // Two roundings of a division and a product by the scale: a few ulps.
    assert!(r.relative_max < SUM_TOLERANCE, "{r:?}");
    assert!(r.relative_l2.total < SUM_TOLERANCE, "{r:?}");
    // The missing-data mask: none in a file written from a model.
    assert!(compare::missing_bins(&path).unwrap().is_none());
    let _ = std::fs::remove_dir_all(&d);
}

fn lobe(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .env(
            "VK_ICD_FILENAMES",
            "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json",
        )
        .output()
        .expect("running lobe")
}

fn files_in(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn the_command_line_reports_json_and_writes_both_plots() {
    let d = temp_dir("cli");
    let prefix = d.join("cmp");
    let out = lobe(&[
        "compare",
        "lambert",
        "lambert{albedo=0.88}",
        "--grid",
        "isotropic",
        "--res",
        "10,10,20",
        "--format",
        "json",
        "--mu",
        "0.5",
        "--backend",
        "cpu",
        "-o",
        prefix.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let l2 = v["relative_l2"]["total"].as_f64().unwrap();
    assert!((l2 - 0.1).abs() < SUM_TOLERANCE, "{v}");
    let e = v["directional_albedo"][0]["a_minus_b"][0].as_f64().unwrap();
    assert!((e + 0.08).abs() < ALBEDO_TARGET, "{v}");
    assert_eq!(v["bins_compared"], 2000);
    assert_eq!(
        files_in(&d),
        [
            "cmp_difference.csv",
            "cmp_difference.json",
            "cmp_difference.png",
            "cmp_polar.csv",
            "cmp_polar.json",
            "cmp_polar.png"
        ]
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Each refusal: non-zero exit, a message naming the input, and no file written.
#[test]
fn bad_requests_are_refused_naming_the_input() {
    let d = temp_dir("bad");
    let prefix = d.join("cmp");
    let p = prefix.to_str().unwrap();
    let ggx = testdata("ggx.brdf");
    let ggx = ggx.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec!["lambert", "phong", "--set-a", "shininess=5"],
            &["--set-a shininess=5", "model A = lambert", "shininess"],
        ),
        (
            vec!["lambert", "phong", "--set-b", "shininess=-1"],
            &["--set-b shininess=-1", "model B = phong"],
        ),
        (
            vec![
                "lambert",
                "ashikhmin_shirley{nu=10,nv=100}",
                "--grid",
                "isotropic",
            ],
            &["--grid", "B:", "anisotropic"],
        ),
        (
            vec!["lambert", "phong", "--grid", "full", "--res", "4,4,4"],
            &["--res", "four numbers"],
        ),
        (
            vec![ggx, "microfacet", "--backend", "cpu"],
            &["--backend cpu", "model A", "no f64 CPU twin"],
        ),
        (vec!["lambert", "phong", "--mu", "0"], &["--mu 0"]),
        (vec!["lambert", "nosuchmodel"], &["nosuchmodel"]),
        (
            vec!["lambert", "phong", "--set", "lambert.shininess=3"],
            &["--set lambert.shininess=3"],
        ),
    ];
    for (args, words) in cases {
        let mut all = vec!["compare"];
        all.extend(&args);
        all.extend(["-o", p]);
        let out = lobe(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was accepted: {err}");
        for w in words {
            assert!(err.contains(w), "{args:?}: expected '{w}' in: {err}");
        }
        assert!(files_in(&d).is_empty(), "{args:?} left {:?}", files_in(&d));
    }
    // A folder that does not exist: refused before any work.
    let missing = d.join("no/such/folder/cmp");
    let out = lobe(&[
        "compare",
        "lambert",
        "phong",
        "-o",
        missing.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("-o"));
    assert!(files_in(&d).is_empty());
    let _ = std::fs::remove_dir_all(&d);
}
