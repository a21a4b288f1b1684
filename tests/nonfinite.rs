//! Invalid BRDF values (NaN, ±Inf, negative; docs/design.md §2.1) through the CLI: `eval` and
//! `table` keep them and say how many and where the first is, a table's sidecar records them and
//! such a table does not replace an existing one; every other job refuses with the model, the
//! count and the first direction, exits non-zero and writes nothing. The shaders are the small
//! `.brdf` files in testdata/brdf/invalid/ (GPU only); a MERL file of 1e300 is refused when read,
//! on both backends.

mod common;

use lobe::brdf::{self, LoadOptions};
use lobe::glam::DVec3;
use lobe::{AlbedoSettings, Error, ParamSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The three kinds of shader, by file name, and the words the refusal uses for each.
const SHADERS: [(&str, &str); 3] = [("nan", "NaN"), ("inf", "+Inf"), ("negative", "negative")];

/// The phrase every refusal and warning carries.
const INVALID: &str = "invalid BRDF values";

fn shader(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata/brdf/invalid")
        .join(format!("{name}.brdf"))
}

fn lobe(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run lobe")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The files in `dir`, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `lobe args` failed with the refusal of `model`'s values of `kind`, and `dir` is as empty as
/// before.
fn assert_refused(dir: &Path, args: &[&str], model: &str, kind: &str) {
    let before = files(dir);
    let o = lobe(dir, args);
    let err = stderr(&o);
    let shown = args.join(" ");
    assert!(!o.status.success(), "lobe {shown} succeeded: {err}");
    assert!(
        err.contains(INVALID) && err.contains(model) && err.contains(kind),
        "lobe {shown}: the message names neither the model {model} nor {kind}: {err}"
    );
    assert!(
        err.contains("theta_i") && err.contains("theta_o"),
        "lobe {shown}: the message gives no first direction: {err}"
    );
    assert_eq!(files(dir), before, "lobe {shown} wrote files: {err}");
}

#[test]
fn albedo_refuses_each_kind_of_invalid_shader() {
    for (name, kind) in SHADERS {
        let dir = tempfile::tempdir().expect("tempdir");
        let m = shader(name);
        let m = m.to_str().expect("utf-8 path");
        assert_refused(
            dir.path(),
            &["albedo", "--model", m, "--mu", "0.5"],
            name,
            kind,
        );
        assert_refused(dir.path(), &["albedo", "--model", m], name, kind);
    }
}

#[test]
fn a_lut_with_a_max_error_is_refused_not_written_full_of_nan() {
    for (name, kind) in SHADERS {
        let dir = tempfile::tempdir().expect("tempdir");
        let m = shader(name);
        let m = m.to_str().expect("utf-8 path");
        let args = [
            "albedo",
            "--model",
            m,
            "--lut",
            "lut.exr",
            "--lut-param",
            "albedo",
            "--lut-res",
            "4,4",
            "--max-error",
            "0.001",
        ];
        assert_refused(dir.path(), &args, name, kind);
    }
}

#[test]
fn plots_compare_energy_and_preview_refuse_invalid_shaders() {
    for (name, kind) in SHADERS {
        let dir = tempfile::tempdir().expect("tempdir");
        let m = shader(name);
        let m = m.to_str().expect("utf-8 path");
        let p = dir.path();
        // Light at 80 degrees: each shader is invalid there (the nan and negative ones only at
        // grazing light).
        let plot = ["plot", "--model", m, "--theta-i-deg", "80", "-o", "p.png"];
        assert_refused(p, &plot, name, kind);
        let compare = [
            "compare",
            "lambert",
            m,
            "--grid",
            "isotropic",
            "--res",
            "8,8,8",
        ];
        assert_refused(p, &compare, name, kind);
        assert_refused(p, &["energy", "--models", m], name, kind);
        let o = lobe(p, &["energy", "--models", m]);
        assert!(
            !stderr(&o).contains("--backend cpu"),
            "energy {name}: the hint offers the CPU, which refuses a .brdf model: {}",
            stderr(&o)
        );
        // A preview refuses by pixel: the message names the pixel, not directions; a pixel of
        // the Inf shader may be NaN (Inf times a zero light term).
        let o = lobe(p, &["preview", "--model", m, "-o", "v.png", "--cell", "32"]);
        let err = stderr(&o);
        assert!(
            !o.status.success() && err.contains(INVALID),
            "preview {name}: {err}"
        );
        assert!(err.contains("pixel"), "preview {name}: {err}");
        assert!(files(p).is_empty(), "preview {name} wrote files: {err}");
    }
}

#[test]
fn fit_refuses_an_invalid_target() {
    for (name, kind) in SHADERS {
        let dir = tempfile::tempdir().expect("tempdir");
        let m = shader(name);
        let m = m.to_str().expect("utf-8 path");
        let args = [
            "fit",
            "--target",
            m,
            "--model",
            "lambert",
            "--free",
            "albedo",
            "--max-bins",
            "4096",
        ];
        assert_refused(dir.path(), &args, name, kind);
    }
}

#[test]
fn eval_keeps_invalid_values_and_says_where_the_first_is() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, kind) in SHADERS {
        let m = shader(name);
        let m = m.to_str().expect("utf-8 path");
        let o = lobe(
            dir.path(),
            &["eval", "--model", m, "--wi-deg", "80,0", "--wo-deg", "10,0"],
        );
        let err = stderr(&o);
        assert!(o.status.success(), "eval {name}: {err}");
        assert!(
            err.contains(INVALID) && err.contains("1 of 1 values") && err.contains(kind),
            "eval {name}: {err}"
        );
        assert!(err.contains("theta_i 80.000 deg"), "eval {name}: {err}");
    }
}

#[test]
fn a_table_with_invalid_values_records_them_and_never_replaces_a_good_one() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path();
    let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/brdf/lambert.brdf");
    let table = |model: &Path, extra: &[&str]| {
        let mut args = vec![
            "table",
            "--model",
            model.to_str().expect("utf-8"),
            "--grid",
            "isotropic",
            "--res",
            "4,4,4",
            "-o",
            "t.exr",
        ];
        args.extend_from_slice(extra);
        lobe(p, &args)
    };
    let o = table(&good, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let sidecar = |p: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p.join("t.json")).expect("sidecar")).expect("JSON")
    };
    assert_eq!(sidecar(p)["invalid_values"]["invalid"], 0);
    let kept = std::fs::read(p.join("t.npy")).expect("npy");
    for (name, kind) in SHADERS {
        let o = table(&shader(name), &[]);
        let err = stderr(&o);
        assert!(
            !o.status.success(),
            "table {name} replaced a good table: {err}"
        );
        assert!(
            err.contains("does not replace")
                && err.contains(kind)
                && err.contains("--allow-invalid"),
            "table {name}: {err}"
        );
        assert_eq!(
            std::fs::read(p.join("t.npy")).expect("npy"),
            kept,
            "table {name} touched t.npy"
        );
    }
    // The negative shader is below 0 for theta_i > acos(0.3) = 72.5 deg: of the four cell-centred
    // theta_i (11.25, 33.75, 56.25, 78.75 deg), the last, so 16 of 64 cells.
    let o = table(&shader("negative"), &["--allow-invalid"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(INVALID) && err.contains("16 of 64 values"),
        "{err}"
    );
    let rec = &sidecar(p)["invalid_values"];
    assert_eq!(
        (
            rec["evaluated"].as_u64(),
            rec["invalid"].as_u64(),
            rec["negative"].as_u64()
        ),
        (Some(64), Some(16), Some(16)),
        "{rec}"
    );
    assert_eq!(rec["first"]["index"], 48, "{rec}");
    assert_eq!(rec["first"]["angles"]["theta_i_deg"], 78.75, "{rec}");
    // Declared reciprocal, the table is its theta_i <= theta_o half with the mirror images
    // (docs/design.md §4.5): of the last theta_i row only the diagonal cells (theta_o = 78.75 deg,
    // 4 dphi) are evaluated there, the other 12 are copies of cells at theta_i < 72.5 deg. The
    // counts still speak of the table's 64 cells (40 evaluated), the first being cell (3, 3, 0).
    let o = table(&shader("negative"), &["--allow-invalid", "--reciprocal"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rec = &sidecar(p)["invalid_values"];
    assert_eq!(
        (
            rec["evaluated"].as_u64(),
            rec["negative"].as_u64(),
            rec["first"]["index"].as_u64()
        ),
        (Some(64), Some(4), Some(3 * 16 + 3 * 4)),
        "{rec}"
    );
    assert_eq!(rec["first"]["angles"]["theta_o_deg"], 78.75, "{rec}");
    // Without an existing set, such a table is written, with the warning.
    for (name, _) in SHADERS {
        let sub = tempfile::tempdir().expect("tempdir");
        let m = shader(name);
        let o = lobe(
            sub.path(),
            &[
                "table",
                "--model",
                m.to_str().expect("utf-8"),
                "--grid",
                "isotropic",
                "--res",
                "4,4,4",
                "-o",
                "t.exr",
            ],
        );
        assert!(
            o.status.success() && stderr(&o).contains(INVALID),
            "{name}: {}",
            stderr(&o)
        );
        assert!(sidecar(sub.path())["invalid_values"]["invalid"].as_u64() > Some(0));
    }
}

/// A MERL file whose every stored value is 1e300: finite in f64, f = 1e300/1500 far above the
/// largest f32.
fn huge_merl(dir: &Path) -> PathBuf {
    let path = dir.join("huge.binary");
    let mut bytes = Vec::with_capacity(lobe::merl::FILE_BYTES);
    for d in lobe::merl::DIMS {
        bytes.extend_from_slice(&(d as i32).to_le_bytes());
    }
    for _ in 0..3 * lobe::merl::BINS {
        bytes.extend_from_slice(&1e300f64.to_le_bytes());
    }
    std::fs::write(&path, bytes).expect("write MERL");
    path
}

#[test]
fn a_merl_file_beyond_f32_is_refused_when_read_on_both_backends() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path();
    huge_merl(p);
    for backend in ["cpu", "gpu"] {
        for args in [
            &[
                "eval",
                "--model",
                "huge.binary",
                "--wi-deg",
                "10,0",
                "--wo-deg",
                "10,180",
            ][..],
            &[
                "table",
                "--model",
                "huge.binary",
                "--grid",
                "isotropic",
                "--res",
                "4,4,4",
                "-o",
                "t.exr",
            ],
            &[
                "albedo",
                "--model",
                "huge.binary",
                "--mu",
                "0.5",
                "--format",
                "json",
            ],
        ] {
            let mut a = args.to_vec();
            a.extend(["--backend", backend]);
            let o = lobe(p, &a);
            let err = stderr(&o);
            assert!(!o.status.success(), "{a:?} succeeded: {err}");
            assert!(
                err.contains("huge.binary") && err.contains("red bin 0") && err.contains("1e300"),
                "{a:?}: {err}"
            );
            assert_eq!(files(p), ["huge.binary"], "{a:?} wrote files");
        }
    }
}

#[test]
fn a_nan_error_estimate_fails_the_max_error_check() {
    assert!(lobe::lut::check_max_error(f64::NAN, Some(1e-3)).is_err());
    assert!(lobe::lut::check_max_error(1e-4, Some(1e-3)).is_ok());
    assert!(lobe::finite::max_or_nan(0.0, f64::NAN).is_nan());
}

#[test]
fn the_library_refuses_with_the_count_and_counts_when_asked() {
    let Some(session) = common::gpu_session("nonfinite library") else {
        return;
    };
    let model = brdf::load(&shader("nan"), &LoadOptions::default())
        .expect("load nan.brdf")
        .model;
    let params = ParamSet::defaults(model);
    let dir = |theta_deg: f64| {
        let t = theta_deg.to_radians();
        DVec3::new(t.sin(), 0.0, t.cos())
    };
    // sqrt(cos(theta_i) - 0.2) is NaN beyond 78.5 deg: the second pair of three.
    let pairs = [
        (dir(10.0), dir(10.0)),
        (dir(80.0), dir(10.0)),
        (dir(30.0), dir(40.0)),
    ];
    match session.eval_pairs(&params, &pairs) {
        Err(Error::InvalidValues(v)) => {
            assert_eq!(
                (v.count.evaluated, v.count.invalid, v.count.nan),
                (3, 1, 1),
                "{v}"
            );
            assert_eq!(v.count.first.as_ref().map(|f| f.index), Some(1), "{v}");
        }
        other => panic!("eval_pairs: expected InvalidValues, got {other:?}"),
    }
    let (f, count) = session
        .eval_pairs_counting(&params, &pairs)
        .expect("counting keeps the values");
    assert!(f[1][0].is_nan() && f[0][0].is_finite());
    assert_eq!((count.invalid, count.nan), (1, 1));
    // Both layouts of the albedo kernel count: a CPU driver's partial per invocation, and a
    // GPU's workgroup tree (forced on any device).
    common::on_gpu("nonfinite albedo tree", true, |gpu| {
        let e = lobe::Evaluator::gpu(gpu);
        let r =
            lobe::integrate::directional(&e, &params, &AlbedoSettings::default(), &[(0.5, 0.0)]);
        let err = format!("{:#}", r.map(|_| ()).expect_err("the NaN shader's albedo"));
        assert!(err.contains(INVALID) && err.contains("NaN"), "{err}");
    });
    match session.directional_albedo(&params, &AlbedoSettings::default(), &[(0.5, 0.0)]) {
        Err(Error::InvalidValues(v)) => {
            assert!(v.count.invalid > 0 && v.count.first.is_some(), "{v}")
        }
        other => panic!(
            "directional_albedo: expected InvalidValues, got {:?}",
            other.map(|_| ())
        ),
    }
}

/// A lobe table has no missing-data mark, so a table target's invalid cells are refused as
/// every job refuses them (they were counted as "missing" bins and the fit went on).
#[test]
fn fit_refuses_a_table_target_with_invalid_cells() {
    for (name, kind) in SHADERS {
        let dir = tempfile::tempdir().expect("tempdir");
        let m = shader(name);
        let made = lobe(
            dir.path(),
            &[
                "table",
                "--model",
                m.to_str().expect("utf-8 path"),
                "--grid",
                "isotropic",
                "--res",
                "8,8,8",
                "-o",
                "t.exr",
            ],
        );
        assert!(made.status.success(), "{}", stderr(&made));
        let args = [
            "fit",
            "--target",
            "t.npy",
            "--model",
            "lambert",
            "--free",
            "albedo",
            "--backend",
            "cpu",
        ];
        assert_refused(dir.path(), &args, "t.npy", kind);
    }
}
