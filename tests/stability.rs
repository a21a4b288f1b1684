//! The stability sweep (`lobe stability`) as a test: every model at the edges of its domain, on
//! the GPU and the CPU reference. No NaN, no infinity, no negative value on any valid input, and
//! every GPU value within the parity test's tolerance (see `lobe::stability::parity_tolerance`).
//!
//! Defects found by the sweep in the model formulas, which this crate's model owners are fixing,
//! are listed in [`KNOWN_DEFECTS`] with the exact inputs; they are reported, kept out of the
//! assertions, and a separate test fails as soon as one no longer reproduces, so that the list
//! cannot outlive the bug.

mod common;

use lobe::gpu::Gpu;
use lobe::stability::{self, Options, Report, Row};

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

/// A defect of a model formula, found by the sweep: (model label prefix, parameter edge, what is
/// wrong). Excluded from the assertions below until fixed.
struct KnownDefect {
    model_prefix: &'static str,
    model_suffix: &'static str,
    case: &'static str,
    what: &'static str,
}

const KNOWN_DEFECTS: &[KnownDefect] = &[
    KnownDefect {
        model_prefix: "cook_torrance",
        model_suffix: "",
        case: "ior=1",
        what:
            "Schlick with R0 = 0: c_d = |wi+wo|/2 rounds above 1 for f32 inputs (|w| = 1 + 5e-9), \
               so (1 - c_d)^5 < 0 and the CPU reference returns ~-1e-36 (e.g. wi = wo = \
               (9.999999747378752e-5, 0, 1)); Schlick needs 1 - min(c, 1)",
    },
    KnownDefect {
        model_prefix: "microfacet[",
        model_suffix: "/schlick]",
        case: "f0=0",
        what: "as cook_torrance ior=1: Schlick's (1 - c_d)^5 with c_d > 1",
    },
    KnownDefect {
        model_prefix: "microfacet[",
        model_suffix: "/schlick]",
        case: "alpha=1e-4 ior=1",
        what: "as cook_torrance ior=1: Schlick's (1 - c_d)^5 with c_d > 1",
    },
    KnownDefect {
        model_prefix: "microfacet[",
        model_suffix: "/conductor]",
        case: "eta=1 k=0",
        what: "F_conductor at eta = 1, k = 0 (an index-matched interface, F = 0) is computed as \
               (t1 - t2)/(t1 + t2) with t1 = t2 = 2c^2: pure cancellation, negative values on both \
               backends and GPU values of 1e15 where the reference is 0 (with alpha = 1e-4)",
    },
];

fn known(row: &Row) -> Option<&'static KnownDefect> {
    KNOWN_DEFECTS.iter().find(|d| {
        row.model.starts_with(d.model_prefix)
            && row.model.ends_with(d.model_suffix)
            && row.region.contains(d.case)
    })
}

fn sweep(test: &str) -> Option<Report> {
    let dev = common::gpu_device(test)?;
    let gpu = Gpu::new(&dev);
    let report = stability::sweep(Options {
        gpu: Some(&gpu),
        models: stability::sweep_models(),
        progress: &mut |_| {},
    })
    .expect("stability sweep");
    common::assert_validation_clean(test);
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
        if let Some(d) = known(row) {
            eprintln!(
                "known defect, not asserted: {} [{}]: {}",
                row.model, row.region, d.what
            );
            continue;
        }
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

/// Relative errors where the reference is well-conditioned, per direction region. Rows that mix
/// in a known defect's parameter edge are skipped (the defect dominates them).
#[test]
fn relative_error_is_small_where_well_conditioned() {
    let Some(report) = sweep("stability relative error") else {
        return;
    };
    let defective_models: Vec<&str> = report
        .rows
        .iter()
        .filter(|r| r.group == "params" && known(r).is_some())
        .map(|r| r.model.as_str())
        .collect();
    let mut failures = Vec::new();
    for row in report.rows.iter().filter(|r| {
        r.group == "directions" && WELL_CONDITIONED_REGIONS.contains(&r.region.as_str())
    }) {
        if defective_models.contains(&row.model.as_str()) {
            continue;
        }
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

/// Each known defect must still reproduce: once a model owner fixes it, this fails and asks for
/// the entry to be removed, so that the exclusion above cannot hide a later regression.
#[test]
fn known_defects_still_reproduce() {
    let Some(report) = sweep("stability known defects") else {
        return;
    };
    for d in KNOWN_DEFECTS {
        let rows: Vec<&Row> = report
            .rows
            .iter()
            .filter(|r| r.group == "params" && known(r).is_some_and(|k| std::ptr::eq(k, d)))
            .collect();
        assert!(
            !rows.is_empty(),
            "known defect matches no sweep row: {} {} {}",
            d.model_prefix,
            d.model_suffix,
            d.case
        );
        let still = rows
            .iter()
            .any(|r| r.stats.bad() > 0 || r.stats.max_tolerance_ratio > MAX_TOLERANCE_RATIO);
        assert!(
            still,
            "fixed: '{}' no longer reproduces ({}{} [{}]); remove it from KNOWN_DEFECTS in tests/stability.rs",
            d.what, d.model_prefix, d.model_suffix, d.case
        );
    }
}

/// The CPU reference alone must be free of NaN and infinities everywhere too (no GPU needed).
#[test]
fn cpu_reference_alone_has_no_nan_or_inf() {
    let report = stability::sweep(Options {
        gpu: None,
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
