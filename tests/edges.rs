//! Promises at the edges of what a user can type: directions exactly on the horizon.

mod common;

/// Every built-in model (`lobe models --json`, so a new model is covered).
fn model_names() -> Vec<String> {
    let v = common::lobe_json(&["models", "--json"]);
    let models = v["models"].as_array().expect("a list of models");
    models
        .iter()
        .map(|m| m["name"].as_str().expect("a model's name").to_string())
        .collect()
}

/// θ = 90° is on the horizon, where every BRDF is zero (one-sided rule, design §3): the
/// direction's cos θ must be exactly 0, not the 6.1e-17 of cos(π/2) in floating point, which
/// gave Phong 2.86/sr at grazing light and view on both backends. Light, view and both on the
/// horizon, at azimuths that are multiples of 90° and not.
#[test]
fn a_direction_on_the_horizon_gives_zero_on_both_backends() {
    let models = model_names();
    assert!(models.len() >= 10, "lobe models listed {models:?}");
    let cases = [
        ("90,0", "90,180"),
        ("90,0", "30,180"),
        ("30,0", "90,180"),
        ("90,37", "90,-143"),
        ("90,270", "90,90"),
    ];
    for backend in ["gpu", "cpu"] {
        if backend == "gpu" && common::gpu_device("horizon on the GPU").is_none() {
            continue;
        }
        for model in &models {
            for (wi, wo) in cases {
                let v = common::lobe_json(&[
                    "eval",
                    "--model",
                    model,
                    "--backend",
                    backend,
                    "--wi-deg",
                    wi,
                    "--wo-deg",
                    wo,
                    "--format",
                    "json",
                ]);
                let rgb = &v["values"][0]["rgb"];
                assert_eq!(
                    rgb,
                    &serde_json::json!([0.0, 0.0, 0.0]),
                    "{model} on the {backend}: f(ωi = {wi}°, ωo = {wo}°) = {rgb}"
                );
            }
        }
    }
}

/// Runs lobe and returns (success, stderr).
fn lobe(args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .output()
        .expect("run lobe");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A spec that names one parameter twice is refused (which value wins is a guess), naming the
/// key and both values; an rgb triple's commas are not taken for more keys.
#[test]
fn a_parameter_given_twice_in_one_spec_is_refused() {
    let at = ["--wi-deg", "30,0", "--wo-deg", "30,180", "--backend", "cpu"];
    for spec in [
        "phong{shininess=1,shininess=2}",
        "phong{ shininess=1 , diffuse=0.1,0.2,0.3, shininess =2}",
    ] {
        let (ok, err) = lobe(&[&["eval", "--model", spec], &at[..]].concat());
        assert!(!ok, "{spec} was accepted");
        assert!(
            err.contains("'shininess' is given twice") && err.contains("shininess=1"),
            "{spec}: {err}"
        );
    }
    let (ok, err) = lobe(
        &[
            &["eval", "--model", "phong{diffuse=0.1,0.2,0.3,shininess=5}"],
            &at[..],
        ]
        .concat(),
    );
    assert!(ok, "{err}");
}
