//! The sampling test with the draws counted on the device (docs/design.md §14): the counting
//! kernel draws each built-in model's f32 sampler with the CPU's numbers, counts the draws in the
//! test's cells and reduces the draw checks there; the expected counts stay the f64 integrals of
//! the f64 reference's pdf. Every model passes at view angles from the normal to grazing and at
//! its parameters' edges; the device's counts are the CPU's but for draws near a cell's edge; a
//! density of the wrong roughness is rejected; and the draw checks stay quiet on correct samplers.

mod common;

use lobe::backend::Query;
use lobe::chi2::{Counting, Options, Report};
use lobe::model::{Model, ParamSet, Reference};
use lobe::{resolve_params, Session};

/// View angles from the normal to grazing.
const THETAS: [f64; 3] = [0.0, 45.0, 80.0];
/// Draws per direction: 2²² fills the test's 100 × 50 cells (≈ 840 draws a cell of a uniform
/// density) and runs in about a second per direction on lavapipe.
const SAMPLES: u64 = 1 << 22;

/// Share of a direction's draws that may land in another cell on the device than on the CPU
/// (or inside on one side and outside on the other). The f32 sampler's ωi differs from the f64
/// one by up to 2e-4 (tests/sampling_parity.rs, WI_TOL; ~1e-5 on lavapipe), and a draw moves
/// only when it lies that close to an edge of its cell: with 100 steps in φ and 50 in cosθ, bands
/// of ±2e-4 about the edges hold about 2e-4 · 2 · (100/2π + 50) ≈ 0.03 of a uniform density at
/// the bound and 1e-3 at lavapipe's 1e-5. 1e-2 allows for that and still fails any draw-by-draw
/// disagreement (another seed or group moves nearly every draw of a lobe).
const MAX_MOVED_SHARE: f64 = 1e-2;

fn params(model: &str, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params(model, None, &sets).expect("valid test parameters")
}

fn options(thetas: &[f64], samples: u64, seed: u32) -> Options {
    Options {
        directions: thetas.iter().map(|&t| [t, 30.0]).collect(),
        samples,
        seed,
        ..Options::default()
    }
}

/// The failures of a report, one line per rejected direction.
fn rejected(label: &str, r: &Report) -> Vec<String> {
    r.directions
        .iter()
        .filter(|d| !d.passed)
        .map(|d| {
            format!(
                "{label} at theta_o {}: {} (p {:.3e}, outside p {:.3e}, worst cell {:?})",
                d.theta_o_deg,
                d.failures.join("; "),
                d.p_value,
                d.outside_p_value,
                d.worst_cell
            )
        })
        .collect()
}

/// Runs each case on the device and fails listing every rejected one; the draw checks must find
/// nothing at all on these correct samplers (no invalid, non-unit or leaking draw, errors within
/// the f32 tolerance). Prints the largest weight and pdf errors seen.
fn assert_all_pass_on_device(
    session: &Session,
    cases: &[(String, ParamSet)],
    thetas: &[f64],
    samples: u64,
) {
    let mut failures = Vec::new();
    let (mut weight, mut pdf) = ((0.0f64, String::new()), (0.0f64, String::new()));
    for (label, p) in cases {
        let r = session
            .chi2(p, false, &options(thetas, samples, 11), &mut |_, _| {})
            .unwrap_or_else(|e| panic!("{label}: {e}"));
        assert!(
            r.backend.starts_with("gpu"),
            "{label}: drawn on {}",
            r.backend
        );
        failures.extend(rejected(label, &r));
        for d in &r.directions {
            let c = &d.draws;
            assert_eq!(
                (c.invalid, c.non_unit, c.zero_pdf, c.non_finite_weight),
                (0, 0, 0, 0),
                "{label} at theta_o {}: {c:?}",
                d.theta_o_deg
            );
            assert_eq!(
                (c.nonzero_weight_outside, c.nonzero_pdf_below),
                (0, 0),
                "{label} at theta_o {}: {c:?}",
                d.theta_o_deg
            );
            if c.max_weight_error > weight.0 {
                weight = (c.max_weight_error, format!("{label} θo {}", d.theta_o_deg));
            }
            if c.max_pdf_error > pdf.0 {
                pdf = (c.max_pdf_error, format!("{label} θo {}", d.theta_o_deg));
            }
        }
    }
    eprintln!(
        "largest f32 weight error {:.3e} ({}), pdf error {:.3e} ({})",
        weight.0, weight.1, pdf.0, pdf.1
    );
    assert!(
        failures.is_empty(),
        "{} rejected:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Every built-in model at its defaults, drawn and counted on the device at θo = 0°, 45°, 80°.
#[test]
fn every_model_passes_with_its_draws_counted_on_the_device() {
    let Some(session) = common::gpu_session("chi2 on the device") else {
        return;
    };
    let cases: Vec<(String, ParamSet)> = Model::ALL
        .iter()
        .map(|&m| (m.label(), ParamSet::defaults(m)))
        .collect();
    assert_all_pass_on_device(&session, &cases, &THETAS, SAMPLES);
}

/// The edges of the parameter ranges on the device, with a grazing view (89°) beside the others:
/// the sharpest and roughest lobes, strong anisotropy, Phong's largest exponent.
#[test]
fn samplers_pass_at_their_parameter_edges_on_the_device() {
    let Some(session) = common::gpu_session("chi2 edges on the device") else {
        return;
    };
    let cases: Vec<(String, ParamSet)> = [
        ("microfacet", vec!["alpha=0.01"]),
        ("microfacet", vec!["alpha=1"]),
        ("microfacet", vec!["alpha_x=0.05", "alpha_y=0.5"]),
        // Seen at 89°, this lobe is 0.09° wide in φ, a fortieth of a cell: the expected counts
        // find it only once the cells holding it are refined (chi2::REFINE_SIGMA).
        ("microfacet", vec!["distribution=beckmann", "alpha=0.01"]),
        ("microfacet", vec!["distribution=beckmann", "alpha=1"]),
        ("cook_torrance", vec!["roughness=0.02"]),
        ("phong", vec!["shininess=8192"]),
        ("blinn_phong", vec!["smoothness=1"]),
        ("ashikhmin_shirley", vec!["nu=1000", "nv=10"]),
        ("eon", vec!["roughness=1"]),
        ("smooth_layered", vec!["ior=3"]),
    ]
    .iter()
    .map(|(m, s)| (format!("{m} {}", s.join(" ")), params(m, s)))
    .collect();
    assert_all_pass_on_device(&session, &cases, &[0.0, 45.0, 80.0, 89.0], 1 << 20);
}

/// The device's counts are the CPU's for the same seed but for draws near a cell's edge, where
/// f32 and f64 directions may fall on either side: at most MAX_MOVED_SHARE of the draws move.
#[test]
fn device_counts_equal_cpu_counts_but_at_cell_edges() {
    let Some(gpu) = common::gpu_session("chi2 counts, device against CPU") else {
        return;
    };
    let cpu = Session::cpu();
    let cases = [
        params("lambert", &[]),
        params("microfacet", &["alpha=0.3"]),
        params("microfacet", &["alpha=0.01"]),
        params("phong", &["shininess=500"]),
        params("eon", &[]),
    ];
    let mut worst = (0.0f64, String::new());
    for p in &cases {
        let o = options(&THETAS, 1 << 20, 5);
        let a = gpu.chi2(p, false, &o, &mut |_, _| {}).expect("device test");
        let b = cpu.chi2(p, false, &o, &mut |_, _| {}).expect("cpu test");
        for (dg, dc) in a.directions.iter().zip(&b.directions) {
            let moved: u64 = dg
                .observed
                .iter()
                .zip(&dc.observed)
                .map(|(x, y)| x.abs_diff(*y))
                .sum::<u64>()
                + (dg.leaked + dg.delta).abs_diff(dc.leaked + dc.delta);
            // Each moved draw leaves one count and joins another.
            let share = moved as f64 / 2.0 / o.samples as f64;
            let label = format!("{} θo {}", p.to_text(), dg.theta_o_deg);
            assert!(
                share <= MAX_MOVED_SHARE,
                "{label}: {share:.3e} of the draws counted elsewhere on the device"
            );
            if share > worst.0 {
                worst = (share, label);
            }
        }
    }
    eprintln!(
        "largest share of draws counted elsewhere: {:.3e} ({})",
        worst.0, worst.1
    );
    // Another seed moves nearly every draw of a sharp lobe out of its cell: the comparison can
    // fail.
    let p = params("microfacet", &["alpha=0.3"]);
    let a = gpu
        .chi2(&p, false, &options(&[45.0], 1 << 20, 5), &mut |_, _| {})
        .unwrap();
    let b = cpu
        .chi2(&p, false, &options(&[45.0], 1 << 20, 6), &mut |_, _| {})
        .unwrap();
    let moved: u64 = a.directions[0]
        .observed
        .iter()
        .zip(&b.directions[0].observed)
        .map(|(x, y)| x.abs_diff(*y))
        .sum();
    assert!(moved as f64 / 2.0 / (1u64 << 20) as f64 > MAX_MOVED_SHARE);
}

/// Draws of α = 0.3 counted on the device, judged against the pdf of α = 0.31: a 3 % error in
/// roughness must be rejected at 2²² draws (while α = 0.3 against itself passes).
#[test]
fn a_wrong_expectation_is_rejected() {
    let Some(session) = common::gpu_session("chi2 wrong expectation") else {
        return;
    };
    let drawn = params("microfacet", &["alpha=0.3"]);
    let evaluator = session.evaluator();
    let counting = Counting::on(evaluator.backend(), Query::one(&drawn));
    let o = options(&[45.0], SAMPLES, 3);
    for (alpha, should_pass) in [("alpha=0.3", true), ("alpha=0.31", false)] {
        let expected = Reference::new(&params("microfacet", &[alpha]), false);
        let r = lobe::chi2::run_counted(&expected, counting, &o, None, |_, _| {})
            .expect("the test runs");
        assert!(r.backend.starts_with("gpu"), "{}", r.backend);
        assert_eq!(
            r.passed, should_pass,
            "draws of alpha 0.3 against the pdf of {alpha}: p {:.3e}, {:?}",
            r.directions[0].p_value, r.directions[0].failures
        );
    }
}

/// `lobe chi2 --backend gpu` gives the library's numbers on the device and names it.
#[test]
fn lobe_chi2_on_the_device_matches_the_library() {
    let Some(session) = common::gpu_session("lobe chi2 --backend gpu") else {
        return;
    };
    let j = common::lobe_json(&[
        "chi2",
        "--backend",
        "gpu",
        "--model",
        "phong{shininess=50}",
        "--theta-o-deg",
        "0,40",
        "--phi-o-deg",
        "30",
        "--samples",
        "2^16",
        "--seed",
        "5",
        "--format",
        "json",
    ]);
    let lib = session
        .chi2(
            &params("phong", &["shininess=50"]),
            false,
            &options(&[0.0, 40.0], 1 << 16, 5),
            &mut |_, _| {},
        )
        .expect("the test runs");
    assert!(j["backend"].as_str().is_some_and(|b| b.starts_with("gpu")));
    assert_eq!(j["passed"], lib.passed);
    for (k, d) in lib.directions.iter().enumerate() {
        let observed: Vec<u64> = j["directions"][k]["observed"]
            .as_array()
            .expect("observed counts")
            .iter()
            .map(|v| v.as_u64().expect("a count"))
            .collect();
        assert_eq!(observed, d.observed, "direction {k}");
    }
}

/// The progress callback hears the device's batches up to every draw, and a session whose token
/// is set stops at the next batch with the cancellation error.
#[test]
fn device_counting_reports_progress_and_stops_once_cancelled() {
    let Some(session) = common::gpu_session("chi2 progress and cancel on the device") else {
        return;
    };
    let p = params("lambert", &[]);
    // Two batches per direction, the second a partial one.
    let o = options(&[0.0, 45.0], (1 << 24) + 12345, 1);
    let total = 2 * o.samples;
    let mut heard = Vec::new();
    let r = session
        .chi2(&p, false, &o, &mut |done, all| heard.push((done, all)))
        .expect("the test runs");
    assert!(r.passed, "{:?}", r.directions[0].failures);
    assert_eq!(heard.len(), 4, "{heard:?}");
    assert!(heard.windows(2).all(|w| w[0].0 < w[1].0), "{heard:?}");
    assert_eq!(heard.last(), Some(&(total, total)));

    let token = lobe::CancelToken::new();
    let stoppable = session.with_cancel(token.clone());
    let mut calls = 0;
    let stopped = stoppable.chi2(&p, false, &o, &mut |_, _| {
        calls += 1;
        token.cancel();
    });
    assert!(
        matches!(stopped, Err(lobe::Error::Cancelled(_))),
        "{:?}",
        stopped.map(|r| r.passed)
    );
    assert_eq!(calls, 1, "one batch heard before the stop");
}

/// A MERL file's tabulated sampler drawn and counted on the device (its kernels read the
/// sampler's tables after the bins): Cook–Torrance's gold written as a MERL file.
#[test]
fn a_merl_files_sampler_passes_on_the_device() {
    let Some(session) = common::gpu_session("chi2 of a MERL file on the device") else {
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("chi2_gpu_gold.binary");
    let gold = lobe::resolve_params("cook_torrance", Some("gold"), &[]).expect("gold");
    Session::cpu()
        .write_merl(&gold, &path, &mut |_, _| {})
        .expect("a MERL file");
    let model = lobe::merl::model::load(&path).expect("the MERL file").model;
    let cases = [("merl gold".to_string(), ParamSet::defaults(model))];
    assert_all_pass_on_device(&session, &cases, &THETAS, 1 << 20);
}

/// The counting kernel's two ways of counting a draw in its cell, an atomic add on the device
/// (a GPU's) and its cell's index counted on the host (a CPU driver's), give the same counts
/// and tallies, draw for draw; and a chunk whose weights are not checked counts the same cells.
#[test]
fn host_and_device_cell_counting_agree() {
    use lobe::gpu::{CellCounting, Gpu, GpuDrawRequest, COUNT_HEADER, COUNT_WEIGHT_ERROR};
    use lobe::model::Brdf;
    let Some(dev) = common::gpu_device("host and device cell counting") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let p = params("microfacet", &["alpha=0.2", "diffuse=0.3"]);
    let block = Brdf::new(&p).gpu_block();
    let t = 40f32.to_radians();
    let request = GpuDrawRequest {
        wo: [t.sin(), 0.0, t.cos()],
        seed: 3,
        group: 1,
        first_lo: 0,
        first_hi: 0,
        pad: 0,
    };
    let (n_phi, n_cos) = (60u32, 30u32);
    // Not a whole number of invocations, and the checked draws end inside it.
    let count = (1u64 << 20) + 12345;
    let counts = |checked: u64, way: CellCounting| {
        let mut words = vec![0u64; COUNT_HEADER + (n_phi * n_cos) as usize];
        gpu.chi2_counts(
            p.model(),
            &block,
            request,
            [count, checked],
            [n_phi, n_cos],
            (false, way),
            None,
            &mut words,
        )
        .expect("the counting kernel runs");
        words
    };
    let checked = 1000;
    let device = counts(checked, CellCounting::Device);
    let host = counts(checked, CellCounting::Host);
    assert_eq!(device, host);
    let in_cells: u64 = host[COUNT_HEADER..].iter().sum();
    assert!(in_cells > count / 2, "{in_cells} of {count} draws in cells");
    assert!(
        host[COUNT_WEIGHT_ERROR] > 0,
        "the checked draws' weights were compared"
    );
    let unchecked = counts(0, CellCounting::Host);
    assert_eq!(unchecked[COUNT_HEADER..], host[COUNT_HEADER..]);
    assert_eq!(unchecked[COUNT_WEIGHT_ERROR], 0);
}
