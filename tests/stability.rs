//! The stability sweep (`lobe stability`) as a test: every model at the edges of its domain, on
//! the GPU and the CPU reference. No NaN, no infinity, no negative value on any valid input, and
//! every GPU value within the parity test's tolerance (see `lobe::stability::parity_tolerance`).
//!
//! The sweep first found three defects, since fixed in both languages (glsl/brdf/terms.glsl):
//! Schlick's (1 − c_d)⁵ with c_d rounding above 1 (negative F for R0 = 0), the conductor
//! Fresnel's cancelling (t1 − t2) at an index-matched interface (η = 1, κ = 0: negative values
//! and 1e15 on the GPU where F = 0), and 1 − (1 − c)⁵ losing every digit at grazing angles.

mod common;

use lobe::gpu::Gpu;
use lobe::stability::{self, Options, Report};

/// GPU values may use at most this fraction of the parity test's tolerance: 1 is that test's own
/// bound, so the extremes are held to the same standard as the interior.
const MAX_TOLERANCE_RATIO: f64 = 1.0;

/// Relative error bound (floor 1e-6 1/sr) where the reference is well-conditioned: the interior
/// directions and the exact mirror configuration at every parameter edge. 64 ε (the parity
/// test's base relative tolerance, 7.6e-6) with a margin for exp(x) with |x| up to ~20 at the
/// swept edges (3 + 2|x| ulp): 1e-4. The grazing, near-mirror, ωi = ωo and opposite-grazing
/// regions hold configurations where moving the f32 inputs by a few ulp moves f by more than
/// that (a cosine of 1e-7 known to ±1e-7, a lobe of width 1e-4 rad); they are bounded by
/// MAX_TOLERANCE_RATIO instead, whose tolerance includes that conditioning.
const MAX_REL_ERROR_WELL_CONDITIONED: f64 = 1e-4;
const WELL_CONDITIONED_REGIONS: &[&str] = &["interior", "mirror"];

fn sweep(test: &str) -> Option<Report> {
    let dev = common::gpu_device(test)?;
    let gpu = Gpu::new(dev);
    let report = stability::sweep(Options {
        backend: lobe::Evaluator::gpu(&gpu),
        models: stability::sweep_models(),
        progress: &mut |_| {},
    })
    .expect("stability sweep");
    common::assert_validation_clean(&gpu, test);
    Some(report)
}

#[test]
fn no_nan_inf_or_negative_and_bounded_errors_at_the_edges() {
    let Some(report) = sweep("stability sweep") else {
        return;
    };
    let mut failures = Vec::new();
    for row in report.rows.iter().filter(|r| r.group == "params") {
        let s = &row.stats;
        if s.bad() > 0 {
            failures.push(format!(
                "{} [{}]: NaN {}/{}, Inf {}/{}, negative {}/{} (gpu/cpu); first: {}",
                row.model,
                row.region,
                s.gpu_nan,
                s.cpu_nan,
                s.gpu_inf,
                s.cpu_inf,
                s.gpu_negative,
                s.cpu_negative,
                s.first_bad.as_ref().map(|b| b.text()).unwrap_or_default()
            ));
        }
        if s.max_tolerance_ratio > MAX_TOLERANCE_RATIO {
            let w = s.worst.as_ref().expect("worst sample");
            failures.push(format!(
                "{} [{}]: error {:.3} x the parity tolerance (allowed {MAX_TOLERANCE_RATIO}) at {} (tolerance {:e})",
                row.model,
                row.region,
                s.max_tolerance_ratio,
                w.text(),
                w.tolerance.unwrap_or(f64::NAN)
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} stability failures:\n{}\n\nfull table:\n{}",
        failures.len(),
        failures.join("\n"),
        stability::format_table(&report, false)
    );
}

/// Relative errors where the reference is well-conditioned, per direction region.
#[test]
fn relative_error_is_small_where_well_conditioned() {
    let Some(report) = sweep("stability relative error") else {
        return;
    };
    let mut failures = Vec::new();
    for row in report.rows.iter().filter(|r| {
        r.group == "directions" && WELL_CONDITIONED_REGIONS.contains(&r.region.as_str())
    }) {
        if row.stats.max_rel_error > MAX_REL_ERROR_WELL_CONDITIONED {
            failures.push(format!(
                "{} [{}]: max relative error {:.2e} > {MAX_REL_ERROR_WELL_CONDITIONED:e} at {}",
                row.model,
                row.region,
                row.stats.max_rel_error,
                row.stats
                    .worst
                    .as_ref()
                    .map(|w| w.text())
                    .unwrap_or_default()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The CPU reference alone must be free of NaN and infinities everywhere too (no GPU needed).
#[test]
fn cpu_reference_alone_has_no_nan_or_inf() {
    let report = stability::sweep(Options {
        backend: lobe::Evaluator::cpu(),
        models: stability::sweep_models(),
        progress: &mut |_| {},
    })
    .expect("stability sweep");
    assert_eq!(
        report.total.cpu_nan,
        0,
        "{}",
        stability::format_table(&report, false)
    );
    assert_eq!(
        report.total.cpu_inf,
        0,
        "{}",
        stability::format_table(&report, false)
    );
    assert_eq!(report.total.gpu_nan + report.total.gpu_inf, 0);
}
