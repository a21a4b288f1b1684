//! BRDF Explorer `.brdf` files as models: the files in testdata/brdf/ (written in that format's
//! old-style GLSL: int literals in float expressions, `max(0, x)`, their own `const float PI`,
//! helpers named like lobe's) evaluate on the GPU to what lobe's built-in models give for the
//! same formulas (the f64 references, under the parity tolerance of docs/design.md §10), or to
//! closed forms; bad files and bad values are refused with the file and line; a shader that never
//! returns is stopped in bounded time; the CPU backend refuses such a model.

mod common;

use glam::DVec3;
use lobe::brdf::{self, BrdfError, LoadOptions};
use lobe::gpu::Gpu;
use lobe::integrate::Method;
use lobe::model::{Model, ParamSet, Reference};
use lobe::{AlbedoSettings, Error, Evaluator, Session};
use std::f64::consts::{FRAC_1_PI, PI};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// The f32 GPU result of ρ/π against f64: one rounding of ρ, one of 1/π, one product (as in
/// tests/runtime_model.rs).
const F32_REL: f64 = 4.0 * f32::EPSILON as f64;

/// Two GPU albedos by the same fixed rule (the same nodes) of two f32 implementations of one
/// formula: each value within ~1e-5 relative of the other (the parity tolerance's size), so the
/// sums agree to that too.
const SAME_RULE_REL: f64 = 2e-5;

fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata/brdf")
        .join(name)
}

fn load(name: &str) -> Model {
    brdf::load(&testdata(name), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .model
}

fn with(model: Model, sets: &[&str]) -> ParamSet {
    let mut p = ParamSet::defaults(model);
    for s in sets {
        p.set_text(s).unwrap_or_else(|e| panic!("{s}: {e}"));
    }
    p
}

fn direction(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Pairs over the hemisphere, near the mirror direction and off it, rounded to f32 as the GPU
/// receives them (so that the f64 reference sees the same inputs).
fn pairs() -> Vec<(DVec3, DVec3)> {
    let f32_round = |v: DVec3| DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64);
    let mut out = Vec::new();
    for ti in [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0] {
        for (to, dphi) in [
            (ti, 180.0),
            (ti + 2.0, 178.0),
            (40.0, 90.0),
            (10.0, 0.0),
            (70.0, 135.0),
        ] {
            out.push((direction(ti, 20.0), direction(to, 20.0 + dphi)));
        }
    }
    out.push((DVec3::Z, DVec3::Z));
    out.into_iter()
        .map(|(a, b)| (f32_round(a), f32_round(b)))
        .collect()
}

fn gpu() -> Option<Gpu> {
    common::gpu_device("brdf files").map(Gpu::new)
}

/// The GPU values of `file_params` against the f64 reference of the built-in `builtin` at every
/// pair, within the parity tolerance of the built-in model.
fn assert_matches_builtin(gpu: &Gpu, file_params: &ParamSet, builtin: &ParamSet) {
    let pairs = pairs();
    let g = Evaluator::gpu(gpu)
        .eval_pairs(file_params, &pairs)
        .expect("gpu");
    let r = Reference::new(builtin, false);
    for ((wi, wo), g) in pairs.iter().zip(g) {
        let c = r.eval(*wi, *wo);
        let tol = lobe::tolerance::parity_tolerance(builtin, &r, *wi, *wo, c);
        for k in 0..3 {
            assert!(
                (g[k] - c[k]).abs() <= tol[k],
                "{} vs {}: wi {wi} wo {wo} channel {k}: file {} built-in {} (difference {:e}, allowed {:e})",
                file_params.to_text(),
                builtin.to_text(),
                g[k],
                c[k],
                (g[k] - c[k]).abs(),
                tol[k]
            );
        }
    }
}

fn gauss(samples: usize) -> AlbedoSettings {
    AlbedoSettings {
        method: Method::Gauss,
        samples,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    }
}

#[test]
fn the_lambert_file_is_albedo_over_pi_and_its_albedo_is_the_albedo() {
    let model = load("lambert.brdf");
    assert!(!model.has_reference());
    let p = with(model, &["albedo=0.2,0.4,0.8"]);
    assert!(p.is_isotropic(), "BRDF() never reads X or Y");
    let Some(gpu) = gpu() else { return };
    let f = Evaluator::gpu(&gpu).eval_pairs(&p, &pairs()).expect("gpu");
    common::assert_rho_over_pi(&f, [0.2, 0.4, 0.8], F32_REL);
    // Below the horizon lobe's one-sided rule gives 0, whatever the file's formula.
    let below = Evaluator::gpu(&gpu)
        .eval_pairs(&p, &[(direction(30.0, 0.0), -DVec3::Z)])
        .expect("gpu");
    assert_eq!(below[0], [0.0; 3]);
    // Its albedo by a fixed rule is the albedo: E = ρ for Lambert. Each of the 4096 f32 terms is
    // off by a few ε and they sum in f32: 1e-5 (as tests/runtime_model.rs allows).
    let e = lobe::integrate::directional(&Evaluator::gpu(&gpu), &p, &gauss(4096), &[(0.5, 0.0)])
        .expect("gpu albedo");
    for (c, rho) in [0.2, 0.4, 0.8].into_iter().enumerate() {
        assert!((e[0].albedo[c] - rho).abs() < 1e-5, "{:?}", e[0].albedo);
    }
    common::assert_validation_clean(&gpu, "lambert.brdf");
}

#[test]
fn the_blinn_phong_file_equals_the_built_in_blinn_phong() {
    let model = load("blinn_phong.brdf");
    // The built-in's exponent is 8192^(1 - s) = 2^(13 (1 - s)): s = 7/13 gives n = 64, the
    // file's n, and the same (n + 8)/(8π) normalisation.
    let file = with(model, &["n=64", "kd=0.5,0.25,0.1", "ks=0.04"]);
    let builtin = lobe::resolve_params(
        "blinn_phong",
        None,
        &[
            format!("smoothness={}", 7.0 / 13.0),
            "diffuse=0.5,0.25,0.1".into(),
            "specular=0.04".into(),
        ],
    )
    .unwrap();
    let Some(gpu) = gpu() else { return };
    assert_matches_builtin(&gpu, &file, &builtin);

    // normalized=false drops the factor (n + 8)/(8π) from the lobe: the closed form
    // kd/π + ks (n·h)^n.
    let plain = with(model, &["n=64", "kd=0", "ks=1", "normalized=false"]);
    let pairs = pairs();
    let g = Evaluator::gpu(&gpu)
        .eval_pairs(&plain, &pairs)
        .expect("gpu");
    let r = Reference::new(
        &lobe::resolve_params(
            "blinn_phong",
            None,
            &[
                format!("smoothness={}", 7.0 / 13.0),
                "diffuse=0".into(),
                "specular=1".into(),
            ],
        )
        .unwrap(),
        false,
    );
    for ((wi, wo), g) in pairs.iter().zip(g) {
        let want = r.eval(*wi, *wo).x / (72.0 / (8.0 * PI));
        // pow(c, 64) in f32 with c = n·h off by a few ε: 64 × a few ε relative, and the 1e-6
        // absolute floor of the parity tolerance.
        let tol = 1e-6 + 64.0 * 8.0 * f32::EPSILON as f64 * want;
        assert!(
            (g[0] - want).abs() <= tol,
            "wi {wi} wo {wo}: {} vs {want}",
            g[0]
        );
    }

    // The albedo by the same fixed rule as the built-in's GPU albedo.
    let mus = [(0.3, 0.0), (0.9, 0.0)];
    let e_file = lobe::integrate::directional(&Evaluator::gpu(&gpu), &file, &gauss(65536), &mus)
        .expect("file albedo");
    let e_builtin =
        lobe::integrate::directional(&Evaluator::gpu(&gpu), &builtin, &gauss(65536), &mus)
            .expect("built-in albedo");
    for (a, b) in e_file.iter().zip(&e_builtin) {
        for c in 0..3 {
            let (a, b) = (a.albedo[c], b.albedo[c]);
            assert!((a - b).abs() <= SAME_RULE_REL * b, "{a} vs {b}");
        }
    }
    common::assert_validation_clean(&gpu, "blinn_phong.brdf");
}

#[test]
fn the_ggx_file_equals_the_built_in_microfacet_model() {
    let loaded = brdf::load(&testdata("ggx.brdf"), &LoadOptions::default()).unwrap();
    // A second load gives the model of the first.
    assert_eq!(load("ggx.brdf"), loaded.model);
    let file = with(loaded.model, &["alpha=0.25", "diffuse=0.1,0.2,0.3"]);
    let builtin = lobe::resolve_params(
        "microfacet",
        None,
        &[
            "distribution=ggx".into(),
            "masking=smith_separable".into(),
            "fresnel=schlick".into(),
            "alpha=0.25".into(),
            "f0=1,0.78,0.34".into(),
            "diffuse=0.1,0.2,0.3".into(),
        ],
    )
    .unwrap();
    assert!(file.is_isotropic());
    let Some(gpu) = gpu() else { return };
    assert_matches_builtin(&gpu, &file, &builtin);
    common::assert_validation_clean(&gpu, "ggx.brdf");
}

/// The albedo target of docs/design.md (§5): the peak rule's GPU albedo within 1e-6 of the f64
/// reference.
const ALBEDO_TARGET: f64 = 1e-6;

#[test]
fn the_ggx_files_albedo_meets_the_target_against_the_built_in_reference() {
    let model = load("ggx.brdf");
    let file = with(model, &["alpha=0.25"]);
    let builtin = lobe::resolve_params(
        "microfacet",
        None,
        &[
            "masking=smith_separable".into(),
            "alpha=0.25".into(),
            "f0=1,0.78,0.34".into(),
        ],
    )
    .unwrap();
    let mus = [(0.2, 0.0), (0.6, 0.0), (1.0, 0.0)];
    let reference = AlbedoSettings {
        method: Method::Reference,
        samples: 0,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let want = Session::cpu()
        .directional_albedo(&builtin, &reference, &mus)
        .expect("reference albedo");
    let Some(gpu) = gpu() else { return };
    let peak = AlbedoSettings {
        method: Method::Peak,
        samples: 65536,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let got = lobe::integrate::directional(&Evaluator::gpu(&gpu), &file, &peak, &mus)
        .expect("gpu albedo");
    for (g, w) in got.iter().zip(&want) {
        for c in 0..3 {
            let d = (g.albedo[c] - w.albedo[c]).abs();
            assert!(
                d <= ALBEDO_TARGET,
                "mu {}: {} vs {} (difference {d:e})",
                w.mu,
                g.albedo[c],
                w.albedo[c]
            );
        }
    }
}

/// Relative difference allowed between f(L, V) and f(V, L) from one f32 formula: the same
/// operations in another order, a few dozen roundings (the parity tolerance's base).
const RECIPROCITY_REL: f64 = lobe::tolerance::RTOL_BASE;

#[test]
fn the_shipped_coated_plastic_file_is_reciprocal_and_conserves_energy() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/brdf/coated_plastic.brdf");
    let model = brdf::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .model;
    let Some(gpu) = gpu() else { return };
    let e = Evaluator::gpu(&gpu);
    let pairs = pairs();
    let swapped: Vec<_> = pairs.iter().map(|&(a, b)| (b, a)).collect();
    for sets in [&["roughness=0.35"][..], &["roughness=0.05", "ior=2.5"][..]] {
        let p = with(model, sets);
        let f = e.eval_pairs(&p, &pairs).unwrap();
        let g = e.eval_pairs(&p, &swapped).unwrap();
        for ((a, b), (wi, wo)) in f.iter().zip(&g).zip(&pairs) {
            for c in 0..3 {
                let tol = 1e-6 + RECIPROCITY_REL * a[c].abs();
                assert!(
                    (a[c] - b[c]).abs() <= tol,
                    "{sets:?} wi {wi} wo {wo}: {a:?} vs {b:?}"
                );
            }
        }
    }
    // With the coat off it is Lambert: base/π.
    let f = e
        .eval_pairs(&with(model, &["coat=0", "base=0.5"]), &pairs[..3])
        .unwrap();
    assert!(
        f.iter()
            .all(|v| (v[0] - 0.5 * FRAC_1_PI).abs() <= F32_REL * 0.5 * FRAC_1_PI),
        "{f:?}"
    );
    // A white base under the strongest coat reflects less than it receives, at every μ.
    let p = with(model, &["base=1", "roughness=1", "ior=2.5"]);
    let peak = AlbedoSettings {
        method: Method::Peak,
        samples: 16384,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let albedo =
        lobe::integrate::directional(&e, &p, &peak, &[(0.1, 0.0), (0.5, 0.0), (1.0, 0.0)]).unwrap();
    for a in &albedo {
        assert!(
            a.albedo.x > 0.0 && a.albedo.x < 1.0,
            "mu {}: {:?}",
            a.mu,
            a.albedo
        );
    }
    common::assert_validation_clean(&gpu, "coated_plastic.brdf");
}

#[test]
fn the_anisotropic_file_equals_anisotropic_microfacet_and_is_not_taken_as_isotropic() {
    let model = load("anisotropic.brdf");
    let file = with(model, &["alpha_x=0.1", "alpha_y=0.4"]);
    assert!(!file.is_isotropic(), "BRDF() reads X and Y");
    // An isotropic grid would keep only half the azimuths: refused with the reason.
    let iso = lobe::grid::Grid::Isotropic {
        n_theta_i: 3,
        n_theta_o: 3,
        n_dphi: 3,
    };
    let e = lobe::table::check_grid(&file, &iso).unwrap_err();
    assert!(format!("{e:#}").contains("anisotropic"), "{e:#}");
    let builtin = lobe::resolve_params(
        "microfacet",
        None,
        &[
            "distribution=ggx".into(),
            "masking=smith_separable".into(),
            "fresnel=none".into(),
            "alpha_x=0.1".into(),
            "alpha_y=0.4".into(),
        ],
    )
    .unwrap();
    let Some(gpu) = gpu() else { return };
    assert_matches_builtin(&gpu, &file, &builtin);
    common::assert_validation_clean(&gpu, "anisotropic.brdf");
}

#[test]
fn names_a_shader_shares_with_lobes_kernels_do_not_clash() {
    // names.brdf declares PI, INV_PI, PHI, brdf, store, shade, intersect, Light, parameters named
    // ambient, params and chunk, and macros; f = ambient · chunk / π while `on` is set.
    let model = load("names.brdf");
    let Some(gpu) = gpu() else { return };
    let e = Evaluator::gpu(&gpu);
    let pair = [(direction(30.0, 0.0), direction(50.0, 200.0))];
    let f = e.eval_pairs(&with(model, &["chunk=2"]), &pair).unwrap();
    for (c, a) in [0.25, 0.5, 1.0].into_iter().enumerate() {
        let want = 2.0 * a * FRAC_1_PI;
        assert!((f[0][c] - want).abs() <= F32_REL * want, "{:?}", f[0]);
    }
    let off = e.eval_pairs(&with(model, &["on=false"]), &pair).unwrap();
    assert_eq!(off[0], [0.0; 3]);
    // The table kernel runs too (the albedo and preview kernels: the other tests, the CLI's).
    let grid = lobe::grid::Grid::Isotropic {
        n_theta_i: 2,
        n_theta_o: 2,
        n_dphi: 2,
    };
    let p = with(model, &[]);
    let mut cells = 0;
    e.eval_table(&p, &grid, &mut |_, chunk: &[f32]| {
        cells += chunk.len() / 3;
        Ok(())
    })
    .expect("table");
    assert_eq!(cells, 8);
    common::assert_validation_clean(&gpu, "names.brdf");
}

#[test]
fn a_scene_takes_a_brdf_file_relative_to_itself() {
    let scene_file = testdata("scene.toml");
    let text = "[[materials]]\nname = \"rough\"\nmodel = \"ggx.brdf\"\nparams = { alpha = 0.5, f0 = [1, 1, 1] }\n[[albedos]]\nmaterial = \"rough\"\noutput = \"a.json\"\n";
    let scene = lobe::scene::parse(text, scene_file.to_str().unwrap()).expect("scene");
    let p = &scene.materials[0].params;
    assert_eq!(p.model(), load("ggx.brdf"));
    assert_eq!((p.scalar("alpha"), p.rgb("f0")), (0.5, DVec3::ONE));
    // A file that is not there is named with the scene's line and column.
    let e = lobe::scene::parse(&text.replace("ggx.brdf", "none.brdf"), "s.toml")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("s.toml:3:") && e.contains("none.brdf"), "{e}");
}

fn error_of(text: &[u8]) -> BrdfError {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.brdf");
    std::fs::write(&path, text).unwrap();
    match brdf::load(&path, &LoadOptions::default()) {
        Err(e) => e,
        Ok(l) => panic!(
            "{:?} loaded as {}",
            String::from_utf8_lossy(text),
            l.model.name()
        ),
    }
}

#[test]
fn bad_files_are_refused_with_file_and_line() {
    let cases: &[(&[u8], &str)] = &[
        (b"# nothing but comments\n", "bad.brdf:1: the file has no 'analytic' line"),
        (b"analytic\n::begin parameters\nfloat a 0 1 5\n::end parameters\n", "bad.brdf:3: float 'a': DEFAULT 5 is outside [0, 1]"),
        (b"analytic\n\n::begin shader\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(1); }\n", "bad.brdf:3: the section 'shader' has no '::end shader'"),
        (b"analytic\n::begin parameters\ncolor c 1 1\n::end parameters\n", "bad.brdf:3: expected 'color NAME R G B', found 4 words"),
        (b"analytic\n\xff\n", "bad.brdf:2: not UTF-8"),
    ];
    for (text, want) in cases {
        let e = error_of(text).to_string();
        assert!(e.contains(want), "{:?}: {e}", String::from_utf8_lossy(text));
    }
    // Larger than 1 MiB: refused before parsing, with the limit.
    let mut big = b"analytic\n".to_vec();
    big.resize(brdf::MAX_FILE_BYTES + 1, b'#');
    let e = error_of(&big);
    assert!(
        matches!(e, BrdfError::TooLarge { .. }) && e.to_string().contains("1 MiB"),
        "{e}"
    );
    let e = brdf::load(Path::new("/nonexistent/x.brdf"), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/x.brdf"), "{e}");
}

#[test]
fn compile_errors_point_at_the_files_line() {
    let e = brdf::load(&testdata("bad/typo.brdf"), &LoadOptions::default()).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, BrdfError::Compile { line: 10, .. })
            && text.contains("typo.brdf:10: 'undeclared_name'"),
        "{text}"
    );
    let e = brdf::load(&testdata("bad/no_brdf.brdf"), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains(brdf::SIGNATURE), "{e}");
    // A parameter whose name GLSL keeps for itself fails at its own line.
    let e = error_of(b"analytic\n::begin parameters\nfloat a 0 1 0\nfloat int 0 1 0\n::end parameters\n::begin shader\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(a); }\n::end shader\n");
    assert!(matches!(e, BrdfError::Compile { line: 4, .. }), "{e}");
}

#[test]
fn set_values_are_checked_against_the_files_declarations() {
    let model = load("blinn_phong.brdf");
    let refused = [
        ("n=1001", "[1, 1000]"),
        ("n=0.5", "[1, 1000]"),
        ("normalized=0.5", "0 or 1"),
        ("normalized=yes", "0 or 1"),
        ("kd=0.1,0.2", "r,g,b"),
        ("kd=2", "[0, 1]"),
        ("kd=0.1,0.2,-0.3", "[0, 1]"),
        ("shininess=3", "its parameters are: n, kd, ks, normalized"),
    ];
    for (set, words) in refused {
        let e = ParamSet::defaults(model)
            .set_text(set)
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{set}: {e}");
    }
    let p = with(
        model,
        &["normalized=true", "kd=0.3", "ks=0.1,0.2,0.3", "n=1000"],
    );
    assert_eq!(p.scalar("normalized"), 1.0);
    assert_eq!(p.rgb("kd"), DVec3::splat(0.3));
    // A colour's default comes from the file, channel by channel.
    assert_eq!(
        ParamSet::defaults(model).rgb("kd"),
        DVec3::new(0.5, 0.25, 0.1)
    );
    assert_eq!(with(model, &["normalized=0"]).scalar("normalized"), 0.0);
}

#[test]
fn the_cpu_backend_refuses_a_brdf_model() {
    let model = load("lambert.brdf");
    let e = Session::cpu()
        .eval_pairs(&ParamSet::defaults(model), &pairs())
        .unwrap_err();
    assert!(matches!(e, Error::NoReference(_)), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("lambert.brdf") && text.contains("no f64 twin"),
        "{text}"
    );
    // The stability sweep compares the GPU with the f64 reference: not available either.
    let e = Session::cpu()
        .stability(vec![model], &mut |_| {})
        .unwrap_err();
    assert!(matches!(e, Error::NoReference(_)), "{e}");
}

fn lobe_cli(args: &[&str], env: &[(&str, &str)], limit: Duration) -> (i32, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_lobe"));
    cmd.args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("lobe starts");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("lobe {args:?} still ran after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("output");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `lobe eval` of `model` at normal incidence and view, with `extra` flags.
fn eval_cli(model: &str, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec!["eval", "--model", model, "--wi", "0,0", "--wo", "0,0"];
    args.extend_from_slice(extra);
    lobe_cli(&args, &[], Duration::from_secs(120))
}

#[test]
fn the_command_line_takes_a_brdf_file_as_a_model() {
    if std::env::var("LOBE_SKIP_GPU").is_ok_and(|v| v == "1") {
        return;
    }
    let limit = Duration::from_secs(120);
    // Braces carry parameters; a skipped section is noted on stderr.
    let (rc, out, err) = lobe_cli(
        &[
            "eval",
            "--model",
            "testdata/brdf/ggx.brdf{alpha=0.5}",
            "--set",
            "f0=1",
            "--wi",
            "30,0",
            "--wo",
            "30,180",
            "--white-furnace",
        ],
        &[],
        limit,
    );
    assert_eq!(rc, 0, "{err}");
    assert!(
        err.contains("ggx.brdf:14: section 'isFunc' skipped"),
        "{err}"
    );
    // f at the mirror pair with F = 1 (f0 = 1) and diffuse 0: D(n) G1² / (4 cos²), with
    // D(n) = 1/(π α²) for GGX and G1 = 2/(1 + sqrt(1 + α² tan²θ)), at α = 0.5, θ = 30°.
    let (a, t) = (0.5f64, 30f64.to_radians());
    let g1 = 2.0 / (1.0 + (1.0 + a * a * t.tan().powi(2)).sqrt());
    let want = g1 * g1 / (PI * a * a) / (4.0 * t.cos().powi(2));
    let r: f64 = out
        .lines()
        .nth(1)
        .and_then(|l| l.split(',').nth(4))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    assert!((r - want).abs() <= 1e-5 * want, "{r} vs {want}");

    // A bad --set names the parameter and the file's range.
    let (rc, _, err) = eval_cli("testdata/brdf/ggx.brdf", &["--set", "alpha=2"]);
    assert!(
        rc == 1 && err.contains("'alpha' = 2") && err.contains("[0.001, 1]"),
        "{err}"
    );
    // The CPU backend says there is no f64 twin.
    let (rc, _, err) = eval_cli("testdata/brdf/lambert.brdf", &["--backend", "cpu"]);
    assert!(rc == 1 && err.contains("no f64 twin"), "{err}");
    // The preview kernel: a sheet with the file's model in its own column.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("p.png");
    let (rc, _, err) = lobe_cli(
        &[
            "preview",
            "--model",
            "testdata/brdf/names.brdf,lambert",
            "--cell",
            "16",
            "-o",
            png.to_str().unwrap(),
        ],
        &[],
        limit,
    );
    assert!(rc == 0 && png.exists(), "{err}");
    // A compile error is shown at the file's line.
    let (rc, _, err) = eval_cli("testdata/brdf/bad/typo.brdf", &[]);
    assert!(rc == 1 && err.contains("typo.brdf:10:"), "{err}");
}

#[test]
fn a_shader_that_never_returns_is_stopped_with_a_message() {
    if std::env::var("LOBE_SKIP_GPU").is_ok_and(|v| v == "1") {
        return;
    }
    let start = Instant::now();
    let (rc, _, err) = lobe_cli(
        &["albedo", "--model", "testdata/brdf/bad/endless.brdf"],
        &[("LOBE_BRDF_TIMEOUT", "1")],
        Duration::from_secs(60),
    );
    assert_eq!(rc, 1, "{err}");
    assert!(
        err.contains("did not finish within 1 s")
            && err.contains("may never return")
            && err.contains("LOBE_BRDF_TIMEOUT"),
        "{err}"
    );
    // Start-up and compiling take well under a second here; the limit is 1 s per chunk and the
    // job stops at the first chunk over it.
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{:?}",
        start.elapsed()
    );
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;

    /// Lines a `.brdf` file is made of, good and bad, for the structured fuzzing.
    fn line() -> impl Strategy<Value = String> {
        prop_oneof![
            Just("analytic".to_string()),
            Just("::begin parameters".to_string()),
            Just("::end parameters".to_string()),
            Just("::begin shader".to_string()),
            Just("::end shader".to_string()),
            Just("::begin isFunc".to_string()),
            Just("::end isFunc".to_string()),
            Just("::begin".to_string()),
            Just("# comment".to_string()),
            Just("float a 0 1 0.5".to_string()),
            Just("bool b 1".to_string()),
            Just("color c 0.1 0.2 0.3".to_string()),
            Just(
                "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(a); }".to_string()
            ),
            "(float|bool|color|int) [a-z_]{0,3}( -?[0-9.e]{0,4}){0,5}",
            "[ -~]{0,24}",
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]

        /// Any bytes: the parser answers with a file or an error naming a line of the text.
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..1500)) {
            let text = String::from_utf8_lossy(&bytes);
            if let Err(BrdfError::Parse { line, .. }) = brdf::parse("fuzz.brdf", &text) {
                prop_assert!(line >= 1 && line <= text.split('\n').count().max(1));
            }
        }

        /// Files from the format's own lines in any order: the same, and a parsed file's
        /// parameters are valid names with defaults in their ranges.
        #[test]
        fn random_line_sequences_never_panic(lines in proptest::collection::vec(line(), 0..24)) {
            let text = lines.join("\n");
            match brdf::parse("fuzz.brdf", &text) {
                Ok(f) => {
                    prop_assert!(f.shader_line >= 2 && f.shader_line <= lines.len() + 1);
                    for p in &f.params {
                        if let brdf::ParamType::Float { min, max, default } = p.kind {
                            prop_assert!(min <= default && default <= max);
                        }
                    }
                }
                Err(BrdfError::Parse { line, .. }) => prop_assert!(line >= 1 && line <= lines.len().max(1)),
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
    }

    /// Token soup in the shader section (unbalanced braces, stray preprocessor directives, an
    /// unterminated comment): glslang refuses it with a message, and nothing panics or aborts.
    /// 200 cases; most fail at the first of the four kernels, in well under a second in all.
    #[test]
    fn random_shaders_compile_or_fail_with_a_message() {
        let words = [
            "{",
            "}",
            "(",
            ")",
            ";",
            "vec3",
            "float",
            "BRDF",
            "return",
            "L",
            "V",
            "PI",
            "1",
            "0.5",
            "+",
            "/",
            "=",
            "#define X",
            "#undef PI",
            "#if 0",
            "#endif",
            "/*",
            "*/",
            "//",
            "\n",
            "const",
            "a",
            "lobe_p",
            "#line 1",
            "#version 120",
            "vec3(1)",
            ",",
            "int",
        ];
        let mut rng = common::Rng(0xb4df);
        for case in 0..200 {
            let n = 1 + (rng.next_u64() % 40) as usize;
            let soup: Vec<&str> = (0..n)
                .map(|_| words[(rng.next_u64() % words.len() as u64) as usize])
                .collect();
            let text = format!(
                "analytic\n::begin parameters\nfloat a 0 1 0.5\n::end parameters\n::begin shader\n{}\n::end shader\n",
                soup.join(" ")
            );
            let file = brdf::parse("soup.brdf", &text).unwrap();
            match brdf::build(&file, &format!("soup{case}"), &LoadOptions::default()) {
                Ok(_) => {}
                Err(BrdfError::Compile { line, message, .. }) => {
                    assert!(
                        line >= 1 && !message.is_empty(),
                        "{text}: line {line}: {message:?}"
                    );
                }
                Err(e) => panic!("{text}: {e}"),
            }
        }
    }
}
