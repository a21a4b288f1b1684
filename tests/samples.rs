//! A model's draws as a user asks for them: `lobe sample`'s `.npy` and sidecar, the library's
//! [`lobe::Session::sample`] and [`lobe::Session::write_samples`] give the same bits for the
//! same request on each backend (docs/design.md §13); `Session::pdf` at a drawn ωi is the
//! draw's own pdf; bad requests are refused before any file is made.

mod common;

use lobe::glam::DVec3;
use lobe::samples::{Samples, COLUMNS};
use lobe::{ParamSet, Query, Session};
use std::path::Path;

/// Draws per request: enough to reach both components of every mixture and the lost draws of
/// a grazing microfacet lobe, a fraction of a second on lavapipe.
const N: usize = 3000;
/// The seed (any; fixed so that a failure reproduces).
const SEED: u32 = 41;

/// A draw's pdf against `Session::pdf` at its ωi, both from the f64 reference: the same formula
/// along two paths (the sampler's and the density's) agrees to ~1e-13; 1e-9 still catches any
/// factor or Jacobian missing on one path.
const CPU_PDF_TOLERANCE: f64 = 1e-9;

/// The GPU draw's f32 pdf against the f64 reference's pdf at the same (f32) ωi: the f32 twin's
/// rounding over its 10–30 operations and GLSL's exp, pow and sqrt (a few ulp each), measured up
/// to 3.8e-4 relative on lavapipe (docs/design.md §13); 2e-3 leaves a conforming GPU's exp2 and
/// log2 room and still catches a missing Jacobian (a factor 4 ωo·h) or a wrong mixture share.
const GPU_PDF_TOLERANCE: f64 = 2e-3;

struct Case {
    model: &'static str,
    sets: &'static [&'static str],
    theta_o_deg: f64,
    phi_o_deg: f64,
}

const CASES: &[Case] = &[
    // Anisotropic GGX at grazing ωo: lost draws (reflected below the horizon).
    Case {
        model: "microfacet",
        sets: &["alpha_x=0.5", "alpha_y=0.2"],
        theta_o_deg: 80.0,
        phi_o_deg: 30.0,
    },
    // A mixture with a delta component: the mirror spike among cosine draws.
    Case {
        model: "smooth_layered",
        sets: &[],
        theta_o_deg: 30.0,
        phi_o_deg: 0.0,
    },
    // A power-cosine lobe mixed with a diffuse part.
    Case {
        model: "phong",
        sets: &["shininess=40"],
        theta_o_deg: 45.0,
        phi_o_deg: 0.0,
    },
];

fn params(c: &Case) -> ParamSet {
    let sets: Vec<String> = c.sets.iter().map(|s| s.to_string()).collect();
    lobe::resolve_params(c.model, None, &sets).expect("a valid parameter set")
}

/// The float64 rows of a `.npy` that `lobe sample` wrote, with its shape, after checking the
/// header says float64 C order.
fn npy_f64(path: &Path) -> (Vec<usize>, Vec<f64>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..6], b"\x93NUMPY", "{}", path.display());
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + len]).expect("an ASCII header");
    assert!(
        header.contains("'descr': '<f8'") && header.contains("'fortran_order': False"),
        "{header}"
    );
    let shape_text = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .expect("a shape");
    let shape: Vec<usize> = shape_text
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().expect("a dimension"))
        .collect();
    let values = bytes[10 + len..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    (shape, values)
}

fn wo_of(c: &Case) -> DVec3 {
    let (t, p) = (c.theta_o_deg.to_radians(), c.phi_o_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Runs `lobe sample` for the case and returns the rows of its `.npy` and its sidecar.
fn cli_draws(backend: &str, c: &Case, dir: &Path, k: usize) -> (Vec<f64>, serde_json::Value) {
    let out = dir.join(format!("{backend}{k}.npy"));
    let mut args = vec![
        "sample".to_string(),
        "--backend".into(),
        backend.into(),
        "--model".into(),
        c.model.into(),
        "--theta-o-deg".into(),
        c.theta_o_deg.to_string(),
        "--phi-o-deg".into(),
        c.phi_o_deg.to_string(),
        "-n".into(),
        N.to_string(),
        "--seed".into(),
        SEED.to_string(),
        "-o".into(),
        out.to_str().expect("a UTF-8 path").into(),
    ];
    for s in c.sets {
        args.extend(["--set".to_string(), s.to_string()]);
    }
    let (code, _, err) = common::lobe_run(&args);
    assert_eq!(code, 0, "{backend} {}: lobe sample: {err}", c.model);
    let (shape, rows) = npy_f64(&out);
    assert_eq!(shape, [N, COLUMNS.len()], "{}", c.model);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.with_extension("json")).unwrap())
            .expect("a JSON sidecar");
    (rows, json)
}

/// Every door, one backend: the same bits from the CLI, `Session::sample` and
/// `Session::write_samples`; the sidecar says what was drawn; each draw's pdf is `Session::pdf`
/// at its ωi; lost draws are below the horizon with weight and pdf 0.
fn check_doors(backend: &str, session: &Session, pdf_tolerance: f64) {
    let dir = tempfile::tempdir().unwrap();
    for (k, c) in CASES.iter().enumerate() {
        let what = format!(
            "{backend}: {} {:?} at θo {}",
            c.model, c.sets, c.theta_o_deg
        );
        let p = params(c);
        let (rows, json) = cli_draws(backend, c, dir.path(), k);
        // The CLI's ωo from its angles, as wo_of makes it, and the sidecar's to the bit (the
        // sidecar is read back and written again when the set commits).
        let wo = wo_of(c).to_array();
        let side: [f64; 3] = serde_json::from_value(json["wo"].clone()).expect("wo");
        assert_eq!(side, wo, "{what}: the sidecar's ωo");
        let s: Samples = session
            .sample(&p, DVec3::from_array(wo), N, SEED)
            .unwrap_or_else(|e| panic!("{what}: Session::sample: {e}"));
        let written = dir.path().join(format!("lib-{backend}{k}.npy"));
        let w = session
            .write_samples(&p, DVec3::from_array(wo), N, SEED, &written, &mut |_, _| {})
            .unwrap_or_else(|e| panic!("{what}: Session::write_samples: {e}"));
        assert_eq!(w, s, "{what}: write_samples returns what sample draws");
        let (_, from_writer) = npy_f64(&written);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&rows),
            bits(&s.rows()),
            "{what}: lobe sample vs Session::sample"
        );
        assert_eq!(
            bits(&rows),
            bits(&from_writer),
            "{what}: lobe sample vs write_samples"
        );

        assert_eq!(json["model"], c.model, "{what}");
        assert_eq!(json["backend"], s.backend.as_str(), "{what}");
        assert_eq!(json["seed"], SEED, "{what}");
        assert_eq!(json["draws"], N, "{what}");
        assert_eq!(json["lost"], s.lost(), "{what}");
        assert_eq!(json["delta"], s.deltas(), "{what}");
        assert_eq!(json["set"]["kind"], "samples", "{what}");
        let columns: Vec<String> = serde_json::from_value(json["columns"].clone()).unwrap();
        assert_eq!(columns, COLUMNS, "{what}");

        // Each non-delta draw's pdf is the density at its ωi.
        let pairs: Vec<(DVec3, DVec3)> = (s.wi.iter())
            .map(|wi| (DVec3::from_array(*wi), DVec3::from_array(wo)))
            .collect();
        let density = session
            .pdf(&p, &pairs)
            .unwrap_or_else(|e| panic!("{what}: Session::pdf: {e}"));
        let mut worst = (0.0f64, 0usize);
        for i in 0..N {
            if s.delta[i] {
                continue;
            }
            let (a, b) = (s.pdf[i], density[i]);
            let e = if a == b {
                0.0
            } else {
                (a - b).abs() / a.abs().max(b.abs())
            };
            if e > worst.0 {
                worst = (e, i);
            }
        }
        assert!(
            worst.0 <= pdf_tolerance,
            "{what}: draw {}'s pdf {} against pdf(ωi) {} at ωi {:?}: relative {:.3e}, allowed {pdf_tolerance:e}",
            worst.1,
            s.pdf[worst.1],
            density[worst.1],
            s.wi[worst.1],
            worst.0
        );
        eprintln!(
            "{what}: {} lost, {} delta; largest relative pdf difference {:.2e}",
            s.lost(),
            s.deltas(),
            worst.0
        );
        for i in 0..N {
            if !s.delta[i] && s.pdf[i] == 0.0 {
                assert!(s.wi[i][2] <= 0.0, "{what}: lost draw {i} above the horizon");
                assert_eq!(s.weight[i], [0.0; 3], "{what}: lost draw {i} has a weight");
            }
        }
        match c.model {
            "microfacet" => assert!(s.lost() > 0, "{what}: grazing GGX loses some draws"),
            "smooth_layered" => {
                assert!(s.deltas() > 0, "{what}: the spike is drawn");
                let mirror = [-wo[0], -wo[1], wo[2]];
                for i in (0..N).filter(|&i| s.delta[i]) {
                    for a in 0..3 {
                        assert!(
                            (s.wi[i][a] - mirror[a]).abs() < 1e-6,
                            "{what}: delta draw {i} at {:?}, the mirror direction is {mirror:?}",
                            s.wi[i]
                        );
                    }
                    assert!(
                        s.pdf[i] > 0.0 && s.pdf[i] < 1.0,
                        "{what}: the spike's probability"
                    );
                }
            }
            _ => {}
        }
    }
}

#[test]
fn draws_hold_the_same_bits_through_every_door_on_the_cpu() {
    check_doors("cpu", &Session::cpu(), CPU_PDF_TOLERANCE);
}

#[test]
fn draws_hold_the_same_bits_through_every_door_on_the_gpu() {
    let Some(session) = common::gpu_session("sample doors on the GPU") else {
        return;
    };
    check_doors("gpu", &session, GPU_PDF_TOLERANCE);
}

/// The GPU draws the f64 reference's directions within f32 rounding, through the session.
#[test]
fn the_gpu_and_the_cpu_draw_the_same_directions() {
    let Some(gpu) = common::gpu_session("sample on both backends") else {
        return;
    };
    let c = &CASES[0];
    let (p, wo) = (params(c), wo_of(c));
    let g = gpu.sample(&p, wo, N, SEED).expect("GPU draws");
    let r = Session::cpu().sample(&p, wo, N, SEED).expect("CPU draws");
    // tests/sampling_parity.rs's WI_TOL, with its reasons: f32 samplers round at 2⁻²⁴ per
    // operation and GLSL's sin, cos, atan, exp and log add a few ulp, amplified at grazing ωo.
    const WI_TOL: f64 = 2e-4;
    for i in 0..N {
        for a in 0..3 {
            assert!(
                (g.wi[i][a] - r.wi[i][a]).abs() <= WI_TOL,
                "draw {i}: gpu {:?}, cpu {:?}",
                g.wi[i],
                r.wi[i]
            );
        }
    }
}

/// Bad requests: a sentence naming the flag and the valid range, a non-zero exit, and no file.
#[test]
fn lobe_sample_refuses_bad_requests_before_any_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.npy");
    let o = out.to_str().unwrap();
    let txt = dir.path().join("s.txt");
    for (args, says) in [
        (vec!["-n", "0", "-o", o], "-n"),
        (vec!["-n", "2^23", "-o", o], "2^22"),
        (vec!["-n", "5000000", "-o", o], "2^22"),
        (vec!["-n", "ten", "-o", o], "-n"),
        (
            vec!["--theta-o-deg", "90", "-n", "8", "-o", o],
            "--theta-o-deg 90",
        ),
        (vec!["--theta-o-deg", "-1", "-n", "8", "-o", o], "[0, 90)"),
        (
            vec!["--theta-o-deg", "nan", "-n", "8", "-o", o],
            "--theta-o-deg NaN",
        ),
        (
            vec!["--phi-o-deg", "inf", "-n", "8", "-o", o],
            "--phi-o-deg inf",
        ),
        (vec!["-n", "8", "-o", txt.to_str().unwrap()], ".npy"),
        (vec!["--model", "nonesuch", "-n", "8", "-o", o], "nonesuch"),
        (
            vec![
                "--set",
                "shininess=-3",
                "--model",
                "phong",
                "-n",
                "8",
                "-o",
                o,
            ],
            "shininess",
        ),
    ] {
        let mut all = vec!["sample", "--backend", "cpu"];
        if !args.contains(&"--theta-o-deg") {
            all.extend(["--theta-o-deg", "30"]);
        }
        all.extend(&args);
        let (code, out_text, err) = common::lobe_run(&all);
        assert_ne!(code, 0, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(out_text.is_empty(), "{args:?}: {out_text}");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{args:?}: a file was left"
        );
    }
    // The library names its inputs as Python's keywords do.
    let lambert = ParamSet::for_model("lambert").unwrap();
    let session = Session::cpu();
    for (wo, n, option) in [
        (DVec3::Z, 0, "n"),
        (DVec3::Z, lobe::samples::MAX_DRAWS + 1, "n"),
        (DVec3::new(0.0, 0.6, -0.8), 8, "wo"),
        (DVec3::new(0.0, 0.0, 2.0), 8, "wo"),
        (DVec3::new(f64::NAN, 0.0, 1.0), 8, "wo"),
    ] {
        match session.sample(Query::one(&lambert), wo, n, 0) {
            Err(lobe::Error::Input { input, .. }) => assert_eq!(input.option, option),
            other => panic!("ωo {wo}, n {n}: expected a refusal of {option}, got {other:?}"),
        }
    }
    match session.pdf(&lambert, &[(DVec3::new(0.0, 0.0, 0.5), DVec3::Z)]) {
        Err(lobe::Error::Input { input, .. }) => assert_eq!(input.option, "wi"),
        other => panic!("a short ωi: expected a refusal of wi, got {other:?}"),
    }
}

/// A failed run replaces nothing: an existing set of draws stays as it was when a later run is
/// refused.
#[test]
fn a_refused_run_keeps_the_earlier_draws() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.npy");
    let o = out.to_str().unwrap();
    let base = [
        "sample",
        "--backend",
        "cpu",
        "--model",
        "lambert",
        "--theta-o-deg",
        "10",
    ];
    let mut first = base.to_vec();
    first.extend(["-n", "16", "-o", o]);
    let (code, _, err) = common::lobe_run(&first);
    assert_eq!(code, 0, "{err}");
    let before = (
        std::fs::read(&out).unwrap(),
        std::fs::read(out.with_extension("json")).unwrap(),
    );
    let mut bad = base.to_vec();
    bad.extend(["--set", "albedo=7", "-n", "16", "-o", o]);
    let (code, _, err) = common::lobe_run(&bad);
    assert_ne!(code, 0, "{err}");
    let after = (
        std::fs::read(&out).unwrap(),
        std::fs::read(out.with_extension("json")).unwrap(),
    );
    assert!(before == after, "the earlier draws were replaced");
}
