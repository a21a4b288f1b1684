//! The energy report (`lobe energy`) on facts known in closed form or from the literature.

use lobe::energy::{cases, evaluate, white_configuration, EnergyRow};
use lobe::integrate::Method;
use lobe::model::terms::r0_from_ior;
use lobe::Query;
use lobe::{resolve_params, Evaluator, Model};

mod common;

/// Closed forms against the default `peak` rule: it integrates these smooth integrands to
/// round-off (tests/albedo.rs); 1e-9 leaves room for the sums of ~1e5 f64 terms.
const EXACT_TOL: f64 = 1e-9;

fn row(model: &str, sets: &[&str]) -> EnergyRow {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let p = resolve_params(model, None, &sets).expect("valid parameters");
    let (white, wf) = white_configuration(&p).expect("white configuration");
    evaluate(
        &Evaluator::cpu(),
        model,
        "test",
        Query::one(&white).with_white_furnace(wf),
        Method::Peak,
        Method::Peak.default_samples(),
    )
    .expect("cpu")
}

#[test]
fn lambert_at_albedo_one_neither_gains_nor_loses() {
    let r = row("lambert", &["albedo=0.3"]);
    assert!(r.parameters.contains("albedo=1"), "{r:?}");
    assert!((r.e_max - 1.0).abs() < EXACT_TOL, "{r:?}");
    assert!(r.loss.abs() < EXACT_TOL, "{r:?}");
    assert!(!r.gain, "{r:?}");
}

#[test]
fn coupled_at_matte_one_reflects_exactly_everything() {
    // E = F_s(μ) + (1 − R0)(1 − (1 − μ)^5) (tests/albedo.rs's closed form at m = 1)
    //   = R0 + (1 − R0)(1 − μ)^5 + (1 − R0) − (1 − R0)(1 − μ)^5 = 1 for every μ.
    for ior in ["1.2", "1.5", "4"] {
        let r = row("coupled", &[&format!("ior={ior}")]);
        assert!((r.e_max - 1.0).abs() < EXACT_TOL, "ior {ior}: {r:?}");
        assert!(r.loss.abs() < EXACT_TOL, "ior {ior}: {r:?}");
        assert!(!r.gain, "ior {ior}: {r:?}");
    }
}

#[test]
fn smooth_layered_gains_near_grazing() {
    // White configuration: diffuse = 1 − R0, so E(μ) = F_s(μ) + 1 − R0 = 1 + (1 − R0)(1 − μ)^5:
    // exactly 1 at normal incidence, largest at the most grazing μ looked at (docs/design.md §3:
    // the model gains energy at grazing angles).
    let r = row("smooth_layered", &["ior=1.5"]);
    let r0 = r0_from_ior(1.5);
    assert!(r.gain, "{r:?}");
    assert!((r.e_normal - 1.0).abs() < EXACT_TOL, "{r:?}");
    assert_eq!(r.mu_at_max, lobe::energy::mu_grid()[0], "{r:?}");
    let want = 1.0 + (1.0 - r0) * (1.0 - r.mu_at_max).powi(5);
    assert!((r.e_max - want).abs() < EXACT_TOL, "{r:?} vs {want}");
    // E_avg = 1 + (1 − R0)·2∫(1 − μ)^5 μ dμ = 1 + (1 − R0)/21: a loss of −(1 − R0)/21.
    assert!((r.loss + (1.0 - r0) / 21.0).abs() < EXACT_TOL, "{r:?}");
}

#[test]
fn cook_torrance_loses_more_energy_at_high_roughness() {
    // White furnace, lobe alone: the V-cavity G discards light that would scatter again
    // (Heitz 2014: masking without multiple scattering), more the rougher the surface.
    let losses: Vec<f64> = ["0.05", "0.2", "0.5", "0.9"]
        .iter()
        .map(|m| row("cook_torrance", &[&format!("roughness={m}")]).loss)
        .collect();
    for w in losses.windows(2) {
        assert!(w[1] > w[0], "loss should grow with roughness: {losses:?}");
    }
    assert!(losses[0] >= 0.0 && losses[3] > 0.1, "{losses:?}");
}

#[test]
fn blinn_phong_gains_through_its_approximate_normalization() {
    // (N + 8)/(8π) approximates the normalization of c_h^N c_i (Akenine-Möller et al., RTR):
    // at normal incidence the broad lobes of the lab report's mapping (s = 0.9: N ≈ 2.5) reflect
    // more than they receive.
    let r = row("blinn_phong", &["smoothness=0.9"]);
    assert!(r.gain && r.e_normal > 1.01, "{r:?}");
}

#[test]
fn every_model_has_cases_and_lambert_has_no_colour_sweep() {
    for m in Model::ALL {
        let c = cases(m, 3).expect("cases");
        assert!(!c.is_empty(), "{}", m.name());
        let sweeps = c.iter().filter(|(n, _)| n.starts_with("sweep")).count();
        // A colour axis (Lambert's albedo) is not swept: the white configuration sets it to 1.
        let colour_axis = m.info().lut_axis.keys.iter().any(|k| {
            m.params()
                .iter()
                .any(|s| s.key == *k && s.kind == lobe::model::ParamKind::Rgb)
        });
        assert_eq!(sweeps, if colour_axis { 0 } else { 3 }, "{}", m.name());
        if m == Model::Lambert {
            assert_eq!(sweeps, 0, "lambert has no colour sweep");
        }
    }
}

#[test]
fn cli_energy_formats_and_bad_input() {
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
            .args(args)
            .output()
            .expect("run lobe")
    };
    let base = [
        "energy",
        "--models",
        "lambert,coupled",
        "--backend",
        "cpu",
        "--samples",
        "4096",
        "--sweep",
        "2",
    ];
    let csv = run(&[&base[..], &["--format", "csv"]].concat());
    assert!(
        csv.status.success(),
        "{}",
        String::from_utf8_lossy(&csv.stderr)
    );
    let text = String::from_utf8_lossy(&csv.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("model,case,white_furnace,e_max"));
    let presets = lobe::material::names()
        .iter()
        .filter(|n| lobe::material::preset(n, Model::Coupled).is_ok())
        .count();
    let lambert = lobe::material::names()
        .iter()
        .filter(|n| lobe::material::preset(n, Model::Lambert).is_ok())
        .count();
    assert_eq!(lines.len(), 1 + lambert + presets + 2, "{text}");
    let json = run(&[&base[..], &["--format", "json"]].concat());
    let doc: serde_json::Value = serde_json::from_slice(&json.stdout).expect("JSON");
    assert_eq!(doc["rows"].as_array().map(Vec::len), Some(lines.len() - 1));
    let bad = run(&["energy", "--models", "lamberd", "--backend", "cpu"]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && err.contains("lamberd") && !err.contains("panicked"),
        "{err}"
    );
}

/// Per-series parameters: a spec with its own keys and `--set MODEL.KEY=V` are series of their
/// own, labelled as written, reported as given (no presets) and swept from there. GGX at α = 1
/// loses 59 % of E_avg under the white furnace (tests/kulla_conty.rs); with the Kulla–Conty
/// lobe it loses nothing (to the 1e-4 of the lobe's tables).
#[test]
fn cli_energy_per_series_parameters() {
    let doc = common::lobe_json(&[
        "energy",
        "--models",
        "microfacet,microfacet{multiscatter=kulla_conty},eon",
        "--set",
        "microfacet.alpha=1",
        "--set",
        "eon.multiscatter=none",
        "--backend",
        "cpu",
        "--samples",
        "4096",
        "--sweep",
        "0",
        "--format",
        "json",
    ]);
    let rows = doc["rows"].as_array().expect("rows");
    let find = |model: &str| {
        rows.iter()
            .find(|r| r["model"] == model)
            .unwrap_or_else(|| panic!("no row for {model}: {doc}"))
    };
    assert_eq!(rows.len(), 3, "{doc}");
    let loss = |model: &str| find(model)["loss"].as_f64().expect("loss");
    assert!(loss("microfacet") > 0.5);
    // 4096 nodes per direction: the report's own error estimate bounds the rest.
    let kc = find("microfacet{multiscatter=kulla_conty}");
    let error = kc["error"].as_f64().expect("error estimate");
    assert!(kc["loss"].as_f64().unwrap().abs() <= 1e-4 + error, "{kc}");
    assert!(loss("eon") > 0.0);
    assert_eq!(find("eon")["case"], "as given");
}
