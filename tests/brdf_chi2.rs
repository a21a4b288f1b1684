//! The sampling test of a `.brdf` file's own sampler (`sampleL`, `pdfL`; docs/sampling.md) at
//! 2³⁰ draws: drawn and counted on the device, the expected counts integrated in f64 from the
//! kernels' `pdfL` (the pairs kernel's density). A correct sampler passes at that count, and
//! samplers with the bugs renderers ship are rejected at the same count: a density without the
//! half-vector Jacobian, a density of another lobe than the one drawn, a density whose shape is
//! 2 % off. A hostile sampler's NaN and unnormalised directions are counted and named.

mod common;

use lobe::brdf::{self, LoadOptions};
use lobe::chi2::{Options, Report};
use lobe::model::ParamSet;
use std::path::PathBuf;

/// The count at which the sampling test is meant to stay valid (`lobe chi2`'s guarantee).
const SAMPLES: u64 = 1 << 30;

/// One oblique view direction, (θo, φo) in degrees: a mirror lobe at 45° reaches the horizon
/// (8e-5 of its mass below it), so the outside-share test has draws to count too.
const VIEW: [f64; 2] = [45.0, 20.0];

const HEAD: &str =
    "analytic\n::begin parameters\nfloat m 1 100 20\n::end parameters\n::begin shader\n";

/// A normalised Blinn–Phong lobe drawn through its half vector, with its correct density
/// (`testdata/brdf/half_vector_sampler.brdf`, which the Python tests read too): `shader` makes
/// the variants by replacing the half vector's density (`H_DRAWN`) and pdfL's (`CORRECT`).
const SAMPLER_FILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/testdata/brdf/half_vector_sampler.brdf"
);

/// The half vector's density as drawn.
const H_DRAWN: &str = "(m + 1.0) / (2.0 * PI) * pow(c, m)";

/// The correct density of ωi: the half vector's over 4 (ωo·h).
const CORRECT: &str = "h_density(c) / (4.0 * dot(V, H))";

/// The file's shader with the half vector's density `h_pdf` and pdfL's return value `density`.
fn shader(h_pdf: &str, density: &str) -> String {
    let text = std::fs::read_to_string(SAMPLER_FILE).unwrap();
    let body = text
        .split_once("::begin shader\n")
        .and_then(|(_, rest)| rest.split_once("::end shader"))
        .map(|(body, _)| body.trim_end())
        .unwrap_or_else(|| panic!("{SAMPLER_FILE} has no shader section"));
    for part in [H_DRAWN, CORRECT] {
        assert!(
            body.contains(&format!("return {part};")),
            "{SAMPLER_FILE} returns no {part}"
        );
    }
    body.replace(&format!("return {H_DRAWN};"), &format!("return {h_pdf};"))
        .replace(&format!("return {CORRECT};"), &format!("return {density};"))
}

/// The sampling test of `shader` at `samples` draws per view direction, on the device.
fn chi2(name: &str, shader: &str, samples: u64) -> Option<Report> {
    let session = common::gpu_session(name)?;
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join(format!("{name}.brdf"));
    std::fs::write(&path, format!("{HEAD}{shader}\n::end shader\n")).unwrap();
    let model = brdf::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .model;
    let options = Options {
        directions: vec![VIEW],
        samples,
        ..Options::default()
    };
    let report = session
        .chi2(&ParamSet::defaults(model), false, &options, &mut |_, _| {})
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    Some(report)
}

fn describe(r: &Report) -> String {
    let d = &r.directions[0];
    format!(
        "chi2 {:.1} over {} dof, p = {:e}, outside p = {:e}, accuracy {:.1e}, density from {}, failures {:?}, worst cell {:?}",
        d.statistic.value,
        d.statistic.dof,
        d.p_value,
        d.outside_p_value,
        d.expected_accuracy,
        r.density,
        d.failures,
        d.worst_cell
    )
}

#[test]
fn brdf_chi2_passes_a_correct_half_vector_sampler_at_2_30_draws() {
    let Some(r) = chi2("correct", &shader(H_DRAWN, CORRECT), SAMPLES) else {
        return;
    };
    eprintln!("correct: {}", describe(&r));
    let d = &r.directions[0];
    assert!(r.passed, "{}", describe(&r));
    assert!(r.density.ends_with("(f32)"), "{}", r.density);
    // The expected counts are far more accurate than the noise at this count.
    assert!(d.expected_accuracy < 0.05, "{}", describe(&r));
    // Some of the lobe lies below the horizon at 45°: the leak is measured, not zero.
    assert!(d.leaked > 0 && d.missing_mass > 0.0, "{}", describe(&r));
}

/// Each bug leaves the draws consistent with what the sampler claims (the weights are
/// BRDF cos θi / pdfL by construction), so only the histogram or the outside share can see it.
fn assert_rejected(name: &str, h_pdf: &str, density: &str) {
    let Some(r) = chi2(name, &shader(h_pdf, density), SAMPLES) else {
        return;
    };
    eprintln!("{name}: {}", describe(&r));
    let d = &r.directions[0];
    assert!(!r.passed && !d.histogram_passed, "{name}: {}", describe(&r));
    assert!(d.draws.consistent(), "{name}: {:?}", d.draws);
    let w = d.worst_cell.as_ref().expect("a worst cell");
    assert!(w.sigma.abs() > 5.0, "{name}: {w:?}");
}

#[test]
fn brdf_chi2_rejects_a_density_without_its_jacobian_at_2_30_draws() {
    // The half vector's density returned as the direction's: off by 4 (ωo·h), 2.8 at 45°.
    assert_rejected("no_jacobian", H_DRAWN, "h_density(c)");
}

#[test]
fn brdf_chi2_rejects_the_density_of_another_lobe_at_2_30_draws() {
    // h drawn from (n·h)^m but the density claimed is D(h) (n·h) with D normalised for
    // exponent m: the normalised (m + 2)/(2π) (n·h)^(m+1), the density of a sampler that draws
    // D cos θh. It integrates to 1, so only the shape can tell.
    assert_rejected(
        "other_lobe",
        "(m + 2.0) / (2.0 * PI) * pow(c, m + 1.0)",
        CORRECT,
    );
}

#[test]
fn brdf_chi2_rejects_a_density_two_percent_off_in_shape_at_2_30_draws() {
    // The density times 1 + 0.02 cos 2φh: it integrates to what the drawn one does (the
    // ripple's mean over φh is 0), and no value is off by more than 2 %.
    assert_rejected(
        "two_percent",
        H_DRAWN,
        "h_density(c) * (1.0 + 0.02 * cos(2.0 * ph)) / (4.0 * dot(V, H))",
    );
}

#[test]
fn brdf_chi2_counts_and_names_a_hostile_samplers_bad_draws() {
    // 1 % of the draws are NaN, another 1 % come back twice unit length.
    let hostile = shader(H_DRAWN, CORRECT).replace(
        "    return normalize(2.0 * dot(V, H) * H - V);",
        "    vec3 L = normalize(2.0 * dot(V, H) * H - V);
    if (u.y < 0.01) return vec3(uintBitsToFloat(0x7fc00000u));
    if (u.y > 0.99) return 2.0 * L;
    return L;",
    );
    let Some(r) = chi2("hostile", &hostile, 1 << 20) else {
        return;
    };
    let d = &r.directions[0];
    let n = (1u64 << 20) as f64;
    let share = |k: u64| k as f64 / n;
    assert!(!r.passed, "{}", describe(&r));
    // 1 % ± 5σ of a binomial count of 2²⁰ draws (σ = 1e-4 as a share).
    assert!(
        (share(d.draws.invalid) - 0.01).abs() < 5e-4,
        "{:?}",
        d.draws
    );
    assert!(
        (share(d.draws.non_unit) - 0.01).abs() < 5e-4,
        "{:?}",
        d.draws
    );
    let text = d.failures.join("\n");
    assert!(
        text.contains(&format!("{} invalid", d.draws.invalid))
            && text.contains(&format!("{} not of unit length", d.draws.non_unit)),
        "{text}"
    );
}

#[test]
fn brdf_chi2_refuses_the_cpu_backend_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cpu.brdf");
    std::fs::write(
        &path,
        format!("{HEAD}{}\n::end shader\n", shader(H_DRAWN, CORRECT)),
    )
    .unwrap();
    let (code, _out, err) = common::lobe_run(&[
        "chi2",
        "--backend",
        "cpu",
        "--model",
        path.to_str().unwrap(),
        "--samples",
        "2^16",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("cpu.brdf") && err.contains("sampling test"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn brdf_chi2_gives_the_same_numbers_through_the_cli_and_the_library() {
    let text = shader(H_DRAWN, CORRECT);
    let Some(lib) = chi2("doors", &text, 1 << 20) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("doors.brdf");
    std::fs::write(&path, format!("{HEAD}{text}\n::end shader\n")).unwrap();
    let cli = common::lobe_json(&[
        "chi2",
        "--model",
        path.to_str().unwrap(),
        "--theta-o-deg",
        &VIEW[0].to_string(),
        "--phi-o-deg",
        &VIEW[1].to_string(),
        "--samples",
        "2^20",
        "--format",
        "json",
    ]);
    let (d, c) = (&lib.directions[0], &cli["directions"][0]);
    assert_eq!(c["observed"], serde_json::json!(d.observed));
    assert_eq!(c["statistic"]["value"].as_f64(), Some(d.statistic.value));
    assert_eq!(c["p_value"].as_f64(), Some(d.p_value));
    assert_eq!(cli["density"].as_str(), Some(lib.density.as_str()));
}
