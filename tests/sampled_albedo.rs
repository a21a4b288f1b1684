//! The Monte Carlo albedo methods (`uniform`, `cosine`, `sampled`): their estimates against the
//! adaptive reference within their own error bounds, over several seeds, on both backends; the
//! model's own sampler against the cosine on a peaked lobe; bad draw counts refused; the seed of
//! a request through the CLI, a scene file and the library, and bad seeds refused.

mod common;

use glam::DVec3;
use lobe::gpu::Gpu;
use lobe::integrate::{
    directional, reference_albedo, sampled_albedo, view_direction, Method, Sampler, Settings,
    DEFAULT_SEED, MAX_SAMPLES, REFERENCE_RTOL,
};
use lobe::{resolve_params, Evaluator, ParamSet, Query, Reference, Session};

/// Draws per estimate: 2^14 keeps the test binary quick while the standard error stays well
/// above the reference's 1e-9-relative error.
const DRAWS: usize = 1 << 14;

/// Seeds over which every bound is checked (the bound is statistical: SAMPLED_T = 4 standard
/// errors, exceeded by a normal error with probability 6e-5, so a failure here is a wrong bound
/// or a wrong sampler, not bad luck).
const SEEDS: [u32; 4] = [0, 1, 2, 3];

fn params(model: &str, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params(model, None, &sets).expect("valid test parameters")
}

/// The cases: smooth (lambert, oren_nayar), peaked (GGX α = 0.05 at grazing and normal view)
/// and one with a delta lobe (coupled: its spike's weight comes back in delta draws).
fn cases() -> Vec<(String, ParamSet, f64)> {
    vec![
        ("lambert".into(), params("lambert", &[]), 0.5),
        ("oren_nayar".into(), params("oren_nayar", &[]), 0.3),
        (
            "ggx 0.05 normal".into(),
            params("microfacet", &["distribution=ggx", "alpha=0.05"]),
            1.0,
        ),
        (
            "ggx 0.05 grazing".into(),
            params("microfacet", &["distribution=ggx", "alpha=0.05"]),
            0.1,
        ),
        ("coupled".into(), params("coupled", &[]), 0.6),
    ]
}

/// The total albedo (delta included) by the adaptive reference: the truth.
fn truth(p: &ParamSet, mu: f64) -> DVec3 {
    let r = Reference::new(p, false);
    reference_albedo(&r, view_direction(mu, 0.0), REFERENCE_RTOL).value + r.delta_albedo(mu)
}

fn check_bounds(backend: &Evaluator, tag: &str) {
    for (name, p, mu) in cases() {
        let want = truth(&p, mu);
        let delta = Reference::new(&p, false).delta_albedo(mu);
        for seed in SEEDS {
            let a = sampled_albedo(
                backend,
                Query::one(&p),
                Sampler::Brdf,
                DRAWS,
                seed,
                view_direction(mu, 0.0),
            )
            .expect("sampled albedo");
            let got = a.estimate.value + delta;
            let err = (got - want).abs();
            assert!(
                err.cmple(a.estimate.error).all() && a.estimate.error.max_element() > 0.0,
                "{tag} {name} seed {seed}: |{got} - {want}| = {err} above the bound {}",
                a.estimate.error
            );
        }
    }
}

#[test]
fn sampled_albedo_is_within_its_bound_of_the_reference_on_the_cpu() {
    check_bounds(&Evaluator::cpu(), "cpu");
}

#[test]
fn sampled_albedo_is_within_its_bound_of_the_reference_on_the_gpu() {
    let Some(dev) = common::gpu_device("sampled_albedo_gpu") else {
        return;
    };
    let gpu = Gpu::new(dev);
    check_bounds(&Evaluator::gpu(&gpu), "gpu");
}

#[test]
fn gpu_and_cpu_sampled_estimates_agree_within_their_bounds() {
    let Some(dev) = common::gpu_device("sampled_gpu_cpu") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let (g, c) = (Evaluator::gpu(&gpu), Evaluator::cpu());
    for (name, p, mu) in cases() {
        let wo = view_direction(mu, 0.0);
        let ag = sampled_albedo(&g, Query::one(&p), Sampler::Brdf, DRAWS, 7, wo).expect("gpu");
        let ac = sampled_albedo(&c, Query::one(&p), Sampler::Brdf, DRAWS, 7, wo).expect("cpu");
        let d = (ag.estimate.value - ac.estimate.value).abs();
        assert!(
            d.cmple(ag.estimate.error + ac.estimate.error).all(),
            "{name}: gpu {} vs cpu {}",
            ag.estimate.value,
            ac.estimate.value
        );
    }
}

#[test]
fn uniform_and_cosine_are_within_their_bounds_on_smooth_lobes() {
    let cpu = Evaluator::cpu();
    for (name, p, mu) in cases().into_iter().take(2) {
        let want = truth(&p, mu);
        for sampler in [Sampler::Uniform, Sampler::Cosine] {
            for seed in SEEDS {
                let a = sampled_albedo(
                    &cpu,
                    Query::one(&p),
                    sampler,
                    DRAWS,
                    seed,
                    view_direction(mu, 0.0),
                )
                .expect("albedo");
                let err = (a.estimate.value - want).abs();
                assert!(
                    err.cmple(a.estimate.error).all(),
                    "{name} {sampler:?} seed {seed}: error {err} above {}",
                    a.estimate.error
                );
            }
        }
    }
}

#[test]
fn the_brdf_sampler_has_less_variance_than_the_cosine_on_a_peaked_lobe() {
    // Measured, not assumed: GGX α = 0.05 at μ = 0.5 puts nearly all of f cos θi in a small
    // solid angle, where cosine draws seldom fall and weigh much when they do.
    let cpu = Evaluator::cpu();
    let p = params("microfacet", &["distribution=ggx", "alpha=0.05"]);
    let wo = view_direction(0.5, 0.0);
    let v = |s| {
        sampled_albedo(&cpu, Query::one(&p), s, DRAWS, 0, wo)
            .expect("albedo")
            .variance
            .max_element()
    };
    let (brdf, cosine) = (v(Sampler::Brdf), v(Sampler::Cosine));
    assert!(
        brdf < cosine,
        "variance per draw: brdf {brdf} vs cosine {cosine}"
    );
}

#[test]
fn too_many_draws_are_refused_naming_samples() {
    let p = params("lambert", &[]);
    let s = Settings {
        method: Method::Sampled,
        samples: MAX_SAMPLES + 1,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let e = directional(&Evaluator::cpu(), &p, &s, &[(0.5, 0.0)]).unwrap_err();
    let text = format!("{e:#}");
    assert!(text.contains("draws per view direction"), "{text}");
}

#[test]
fn the_directional_job_reports_the_variance_per_draw() {
    let p = params("lambert", &[]);
    let s = Settings {
        method: Method::Sampled,
        samples: DRAWS,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let e = directional(&Evaluator::cpu(), &p, &s, &[(0.5, 0.0)]).expect("albedo");
    // Lambert's cosine sampler has weight = albedo for every draw: zero variance, exact E.
    let v = e[0].variance_per_sample.expect("a variance");
    assert!(v.max_element() < 1e-20, "{v}");
}

/// `lobe albedo --format csv` gives a Monte Carlo method's variance per draw in its last three
/// columns, and leaves them empty for a rule. Closed forms for a Lambert lobe of albedo ρ: drawn
/// by the cosine every weight is ρ (variance 0, to rounding); drawn uniformly over the
/// hemisphere the weight is 2ρμ with μ uniform on [0, 1], variance ρ² (4/3 − 1) = ρ²/3.
#[test]
fn albedo_csv_carries_the_variance_per_draw() {
    let rho = 0.5;
    let csv = |method: &str| {
        let (code, out, err) = common::lobe_run(&[
            "albedo",
            "--backend",
            "cpu",
            "--model",
            "lambert",
            "--set",
            "albedo=0.5",
            "--method",
            method,
            "--samples",
            "65536",
            "--mu",
            "0.5",
            "--format",
            "csv",
        ]);
        assert_eq!(code, 0, "{err}");
        let rows: Vec<Vec<String>> = out
            .lines()
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        assert_eq!(rows[0][14..], ["variance_r", "variance_g", "variance_b"]);
        assert!(rows.iter().all(|r| r.len() == 17), "{out}");
        rows
    };
    let cosine = csv("cosine");
    let v: f64 = cosine[1][14].parse().unwrap();
    assert!(v.abs() < 1e-20, "cosine-drawn Lambert: variance {v}");
    let uniform = csv("uniform");
    let v: f64 = uniform[1][14].parse().unwrap();
    // The sample variance of 2¹⁶ draws of 2ρμ: its standard error is sqrt((μ4 − σ⁴)/N) with
    // μ4 = (2ρ)⁴ E[(μ − 1/2)⁴] = (2ρ)⁴/80, σ² = ρ²/3: 3.2e-4 at ρ = 0.5; 5 of them allowed.
    let want = rho * rho / 3.0;
    let se = (((2.0 * rho) as f64).powi(4) / 80.0 - want * want) / 65536.0;
    assert!((v - want).abs() < 5.0 * se.sqrt(), "{v} vs {want}");
    // The hemispherical row and a rule's rows leave the columns empty.
    assert!(uniform.last().unwrap()[14..].iter().all(String::is_empty));
    let gauss = csv("gauss");
    assert!(gauss[1][14..].iter().all(String::is_empty));
}

/// Draws per direction of the requests sent through every door: few, so that the hemispherical
/// albedo each `lobe albedo` run also makes stays quick on the CPU.
const DOOR_DRAWS: usize = 4096;

/// A seed far from the default, so that a door which dropped it would show.
const DOOR_SEED: u32 = 4_000_000_123;

/// An RGB triple of a JSON report, as the f64s it was printed from (serde_json prints the
/// shortest text that reads back to the same f64).
fn rgb(v: &serde_json::Value) -> [f64; 3] {
    let c: Vec<f64> = v
        .as_array()
        .expect("an RGB array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect();
    [c[0], c[1], c[2]]
}

fn door_settings(method: Method, seed: u32) -> Settings {
    Settings {
        method,
        samples: DOOR_DRAWS,
        seed,
        white_furnace: false,
    }
}

/// One request (Oren–Nayar, whose weights vary from draw to draw, so that every stream gives
/// another estimate) through `lobe albedo`, a scene's `[[albedos]]` section and
/// `Session::albedo_report`: the same seed gives the same f64s bit for bit, and the JSON names
/// the seed.
#[test]
fn one_seed_gives_the_same_numbers_through_the_cli_a_scene_and_the_library() {
    let p = params("oren_nayar", &[]);
    let session = Session::cpu();
    for method in [Method::Uniform, Method::Sampled] {
        let seed_text = DOOR_SEED.to_string();
        let draws = DOOR_DRAWS.to_string();
        let cli = common::lobe_json(&[
            "albedo",
            "--backend",
            "cpu",
            "--model",
            "oren_nayar",
            "--method",
            method.name(),
            "--samples",
            &draws,
            "--seed",
            &seed_text,
            "--mu",
            "0.3,0.8",
            "--format",
            "json",
        ]);
        assert_eq!(cli["seed"].as_u64(), Some(DOOR_SEED as u64), "{cli}");
        let lib = session
            .albedo_report(
                &p,
                &door_settings(method, DOOR_SEED),
                &[(0.3, 0.0), (0.8, 0.0)],
                0.0,
            )
            .expect("library albedo");
        assert_eq!(lib.seed, Some(DOOR_SEED));
        for (k, point) in lib.points.iter().enumerate() {
            assert_eq!(rgb(&cli["points"][k]["albedo"]), point.albedo.to_array());
            assert_eq!(
                rgb(&cli["points"][k]["error_estimate"]),
                point.error.to_array()
            );
        }
        assert_eq!(
            rgb(&cli["hemispherical"]["albedo"]),
            lib.hemispherical.albedo.to_array()
        );

        // A scene's albedo section with the same request, at the scene's view directions.
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.toml");
        std::fs::write(
            &scene,
            format!(
                "[[materials]]\nname = \"m\"\nmodel = \"oren_nayar\"\n[[albedos]]\nmaterial = \"m\"\nmethod = \"{}\"\nsamples = {DOOR_DRAWS}\nseed = {DOOR_SEED}\noutput = \"a.json\"\n",
                method.name()
            ),
        )
        .unwrap();
        let (scene, out_dir) = (
            scene.display().to_string(),
            dir.path().display().to_string(),
        );
        let (code, _, err) =
            common::lobe_run(&["run", &scene, "--output-dir", &out_dir, "--backend", "cpu"]);
        assert_eq!(code, 0, "{err}");
        let text = std::fs::read_to_string(dir.path().join("a.json")).expect("the scene's report");
        let from_scene: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(from_scene["seed"].as_u64(), Some(DOOR_SEED as u64));
        let points: Vec<(f64, f64)> = lobe::scene::ALBEDO_MU.iter().map(|&m| (m, 0.0)).collect();
        let lib = session
            .albedo_report(&p, &door_settings(method, DOOR_SEED), &points, 0.0)
            .expect("library albedo");
        for (k, point) in lib.points.iter().enumerate() {
            assert_eq!(
                rgb(&from_scene["points"][k]["albedo"]),
                point.albedo.to_array()
            );
        }
    }
}

/// Without --seed the Monte Carlo methods draw from DEFAULT_SEED, and the report says so; a rule
/// reports no seed.
#[test]
fn the_default_seed_is_reported_and_a_rule_reports_none() {
    let run = |method: &str, seed: Option<&str>| {
        let mut args = vec![
            "albedo",
            "--backend",
            "cpu",
            "--model",
            "oren_nayar",
            "--method",
            method,
            "--samples",
            "1024",
            "--mu",
            "0.5",
            "--format",
            "json",
        ];
        if let Some(s) = seed {
            args.extend(["--seed", s]);
        }
        common::lobe_json(&args)
    };
    let default = run("cosine", None);
    assert_eq!(default["seed"].as_u64(), Some(DEFAULT_SEED as u64));
    let explicit = run("cosine", Some(&DEFAULT_SEED.to_string()));
    assert_eq!(
        rgb(&default["points"][0]["albedo"]),
        rgb(&explicit["points"][0]["albedo"])
    );
    let other = run("cosine", Some("1"));
    assert_ne!(
        rgb(&default["points"][0]["albedo"]),
        rgb(&other["points"][0]["albedo"])
    );
    assert!(run("gauss", None)["seed"].is_null());
}

/// Two seeds are two independent estimates: different numbers, each within its own bound of the
/// adaptive reference (the bound as in `check_bounds`: a failure is a wrong bound or a seed that
/// did not reach the draws, not bad luck). The directional job's draws are `sampled_albedo`'s for
/// the same seed, bit for bit.
#[test]
fn different_seeds_give_different_estimates_each_within_its_bound() {
    let cpu = Evaluator::cpu();
    let jobs = [
        ("oren_nayar", Method::Uniform),
        ("oren_nayar", Method::Cosine),
        ("oren_nayar", Method::Sampled),
        ("ggx 0.05 grazing", Method::Sampled),
        ("coupled", Method::Sampled),
    ];
    for (name, method) in jobs {
        let (_, p, mu) = cases().into_iter().find(|c| c.0 == name).unwrap();
        let want = truth(&p, mu);
        let delta = Reference::new(&p, false).delta_albedo(mu);
        let estimate = |seed: u32| {
            let s = Settings {
                method,
                samples: DRAWS,
                seed,
                white_furnace: false,
            };
            let e = directional(&cpu, &p, &s, &[(mu, 0.0)]).expect("albedo")[0];
            let direct = sampled_albedo(
                &cpu,
                Query::one(&p),
                method.sampler().unwrap(),
                DRAWS,
                seed,
                view_direction(mu, 0.0),
            )
            .expect("sampled albedo");
            assert_eq!(
                e.albedo.to_array(),
                (direct.estimate.value + delta).to_array(),
                "{name} {method:?} seed {seed}"
            );
            let err = (e.albedo - want).abs();
            assert!(
                err.cmple(e.error).all(),
                "{name} {method:?} seed {seed}: |{} - {want}| = {err} above the bound {}",
                e.albedo,
                e.error
            );
            e.albedo
        };
        let (a, b) = (estimate(DEFAULT_SEED), estimate(DOOR_SEED));
        assert_ne!(
            a.to_array(),
            b.to_array(),
            "{name} {method:?}: one estimate for two seeds"
        );
    }
}

/// `--seed` takes a u32: a negative value, one above 2^32 − 1 or not an integer is a usage error
/// (exit 2) naming --seed, with nothing on standard output. A method that draws nothing refuses
/// it, naming --seed and --method (exit 1, as a `--samples` that does not fit the method).
#[test]
fn bad_seeds_are_refused_naming_seed() {
    for bad in ["-1", "4294967296", "seven", "1.5", ""] {
        let (code, out, err) = common::lobe_run(&[
            "albedo",
            "--backend",
            "cpu",
            "--model",
            "lambert",
            "--method",
            "uniform",
            "--seed",
            bad,
        ]);
        assert_eq!(code, 2, "--seed {bad:?}: {err}");
        assert!(err.contains("--seed"), "--seed {bad:?}: {err}");
        assert!(out.is_empty(), "--seed {bad:?}: {out}");
    }
    for method in ["peak", "gauss", "reference"] {
        let (code, out, err) = common::lobe_run(&[
            "albedo",
            "--backend",
            "cpu",
            "--model",
            "lambert",
            "--method",
            method,
            "--seed",
            "3",
        ]);
        assert_eq!(code, 1, "{method}: {err}");
        assert!(
            err.contains("--seed 3") && err.contains(&format!("--method {method}")),
            "{method}: {err}"
        );
        assert!(out.is_empty(), "{method}: {out}");
    }
}

/// An albedo LUT by a Monte Carlo method draws every entry from the spec's seed: each entry is
/// the directional albedo of its row's parameters with the same seed, and another seed changes
/// the table.
#[test]
fn a_lut_draws_its_entries_from_its_seed() {
    let cpu = Evaluator::cpu();
    let table = |seed: u32| {
        let mut spec = lobe::lut::LutSpec::new(params("oren_nayar", &[]));
        (spec.n_mu, spec.n_p, spec.with_avg) = (3, 2, false);
        (spec.method, spec.samples, spec.seed) = (Method::Uniform, DOOR_DRAWS, seed);
        let lut = lobe::lut::compute(&cpu, &spec, &mut |_, _| {}).expect("lut");
        (spec, lut)
    };
    let (spec, lut) = table(DOOR_SEED);
    let points: Vec<(f64, f64)> = lut.mus.iter().map(|&m| (m, 0.0)).collect();
    for (k, &p) in lut.ps.iter().enumerate() {
        let at = spec.params_at(p).expect("in range");
        let direct = directional(
            &cpu,
            &at,
            &door_settings(Method::Uniform, DOOR_SEED),
            &points,
        )
        .expect("albedo");
        for (j, d) in direct.iter().enumerate() {
            assert_eq!(lut.e[k * spec.n_mu + j], d.albedo, "p = {p}, mu = {}", d.mu);
        }
    }
    assert_ne!(table(DEFAULT_SEED).1.e, lut.e);
}
