//! Roughness at the bottom of its documented range (0, 1]: values down to the smallest subnormal
//! give finite, non-negative albedos whose error estimates still bound the error.
//!
//! Reference: a specular lobe alone under the white furnace (Fresnel = 1) with α → 0 tends to a
//! mirror, whose directional albedo is 1 for every view (a closed form); below the roughness floor
//! (`lobe::model::SLOPE_FLOOR`) every value is evaluated as the floor.

use serde_json::Value;

mod common;

/// Roughness values from the floor down to the smallest positive subnormal.
const TINY: [&str; 4] = ["1e-5", "1e-6", "1e-30", "5e-324"];

/// The albedo JSON of `model` with `key` set to `value`, specular lobe alone, white furnace.
fn albedo(model: &str, key: &str, value: &str, extra: &[&str]) -> Value {
    let set = format!("{key}={value}");
    let mut args = vec![
        "albedo",
        "--model",
        model,
        "--white-furnace",
        "--backend",
        "cpu",
        "--set",
        &set,
    ];
    args.extend_from_slice(extra);
    args.extend(["--theta-o-deg", "0,1,30,80", "--format", "json"]);
    common::lobe_json(&args)
}

fn channel(v: &Value, key: &str) -> f64 {
    v[key][0].as_f64().unwrap_or(f64::NAN)
}

/// Every direction's albedo is finite and non-negative, and within its own error estimate of the
/// mirror's albedo 1: a wrong answer with a small estimate would be silent.
fn check(model: &str, key: &str, extra: &[&str]) {
    for value in TINY {
        let report = albedo(model, key, value, extra);
        let points = report["points"].as_array().expect("points");
        for p in points {
            let (e, err) = (channel(p, "albedo"), channel(p, "error_estimate"));
            let theta = p["theta_deg"].as_f64().unwrap_or(f64::NAN);
            assert!(
                e.is_finite() && e >= 0.0,
                "{model} {key}={value} θo={theta}: E = {e}"
            );
            assert!(
                (e - 1.0).abs() <= err.max(1e-6),
                "{model} {key}={value} θo={theta}: E = {e}, |E − 1| beyond its estimate {err}"
            );
        }
        let h = &report["hemispherical"];
        let (e, err) = (channel(h, "albedo"), channel(h, "error_estimate"));
        assert!(
            e.is_finite() && (e - 1.0).abs() <= err.max(1e-6),
            "{model} {key}={value}: hemispherical {e} ± {err}"
        );
    }
}

#[test]
fn microfacet_alpha_down_to_subnormals() {
    check(
        "microfacet",
        "alpha",
        &["--set", "diffuse=0", "--set", "specular=1"],
    );
}

#[test]
fn cook_torrance_roughness_down_to_subnormals() {
    check("cook_torrance", "roughness", &[]);
}
