//! Engine tables (docs/luts.md): the split-sum DFG against independent references (the mirror
//! limit at roughness → 0, R + G = E with F = 1 from the adaptive f64 reference), Kulla–Conty's
//! E and EON's Ê against the directional albedo and its closed form, the C/C++ header compiled
//! and read back, `--max-error` refusing a coarse table with no file left, and GPU error
//! estimates that bound the f32 result's distance to the f64 one.

mod common;

use lobe::gpu::Gpu;
use lobe::integrate::{directional, Method, Settings};
use lobe::lut::engine::{compute_engine, EngineKind, EngineSpec};
use lobe::lut::Mapping;
use lobe::model::eon::{eon_albedo_avg, eon_albedo_ss, EonConfig};
use lobe::{resolve_params, Evaluator};
use std::path::Path;
use std::process::Command;

/// A DFG entry at roughness r ≤ 0.02 (α ≤ 4e-4) and μ ≥ 1/16 against the mirror's
/// (1 − (1 − μ)⁵, (1 − μ)⁵): the lobe's width moves ωi·h off μ by O(α) (≲ 1e-4 in the
/// Fresnel weight's slope 5(1 − μ)⁴ ≤ 5 times α) and masking loses O(α²/μ²) of E.
const MIRROR_LIMIT_TOL: f64 = 2e-3;

/// The adaptive reference converges to 1e-10 relative (REFERENCE_RTOL); its own reported
/// bound is added to every comparison with it, and this absolute floor to the rest.
const REFERENCE_ATOL: f64 = 1e-9;

/// A half float holds 11 significant bits: rounding is at most 2^-11 relative, and 2^-25
/// absolute in the subnormal range below 2^-14.
const HALF_RTOL: f64 = 1.0 / 2048.0;
const HALF_ATOL: f64 = 1.0 / (1u64 << 25) as f64;

fn engine(kind: EngineKind, n_mu: usize, n_p: usize) -> EngineSpec {
    let mut s = EngineSpec::new(kind, &[]).expect("valid engine table");
    s.lut.n_mu = n_mu;
    s.lut.n_p = n_p;
    s
}

#[test]
fn dfg_tends_to_the_mirror_at_zero_roughness() {
    let mut spec = engine(EngineKind::Dfg, 8, 2);
    spec.lut.hi = 0.02;
    let t = compute_engine(&Evaluator::cpu(), &spec, &mut |_, _| {}).expect("dfg");
    assert!(t.ps[0] > 0.0 && (t.ps[0] - 0.005f64.powi(2)).abs() < 1e-15);
    for k in 0..2 {
        for (j, &mu) in t.mus.iter().enumerate() {
            let fc = (1.0 - mu).powi(5);
            let i = (k * 8 + j) * 2;
            for (c, want) in [(0, 1.0 - fc), (1, fc)] {
                let got = t.values[i + c];
                assert!(
                    (got - want).abs() <= MIRROR_LIMIT_TOL,
                    "r = {}, mu = {mu}, channel {c}: {got} vs mirror {want}",
                    t.axis[k]
                );
            }
        }
    }
}

#[test]
fn dfg_channels_add_up_to_the_white_furnace_albedo_of_the_reference() {
    let spec = engine(EngineKind::Dfg, 4, 3);
    let t = compute_engine(&Evaluator::cpu(), &spec, &mut |_, _| {}).expect("dfg");
    let ms = compute_engine(
        &Evaluator::cpu(),
        &engine(EngineKind::DfgMultiscatter, 4, 3),
        &mut |_, _| {},
    )
    .expect("dfg multiscatter");
    let reference = Settings {
        method: Method::Reference,
        samples: 0,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: true,
    };
    let fresnel_part = Settings {
        white_furnace: false,
        ..reference
    };
    for k in 0..3 {
        let p = spec.lut.params_at(t.ps[k]).expect("row parameters");
        let pts: Vec<(f64, f64)> = t.mus.iter().map(|&m| (m, 0.0)).collect();
        let e = directional(&Evaluator::cpu(), &p, &reference, &pts).expect("reference");
        let g = directional(&Evaluator::cpu(), &p, &fresnel_part, &pts).expect("reference");
        for j in 0..4 {
            let i = (k * 4 + j) * 2;
            let (r, gg) = (t.values[i], t.values[i + 1]);
            let tol = t.max_error + e[j].error.x + g[j].error.x + REFERENCE_ATOL;
            assert!(
                (r + gg - e[j].albedo.x).abs() <= tol,
                "r = {}, mu = {}: R + G = {} vs E(F = 1) = {} (tol {tol:.2e})",
                t.axis[k],
                t.mus[j],
                r + gg,
                e[j].albedo.x
            );
            assert!((gg - g[j].albedo.x).abs() <= tol, "G vs the F0 = 0 albedo");
            // The multiscatter layout holds the same integrals: (G, R + G).
            assert_eq!(ms.values[i], gg);
            // (R + G rounds once: R is the difference of the two passes.)
            assert!((ms.values[i + 1] - (r + gg)).abs() <= 4.0 * f64::EPSILON);
        }
    }
    assert!(t.max_error < 1e-5, "largest estimate {}", t.max_error);
}

#[test]
fn kulla_conty_table_is_the_white_furnace_albedo_of_microfacet() {
    let mut spec = EngineSpec::new(EngineKind::KullaConty, &["distribution=beckmann".into()])
        .expect("beckmann");
    (spec.lut.n_mu, spec.lut.n_p) = (3, 2);
    let t = compute_engine(&Evaluator::cpu(), &spec, &mut |_, _| {}).expect("kc");
    assert_eq!(spec.lut.mapping, Mapping::Perceptual);
    let s = Settings {
        method: Method::Reference,
        samples: 0,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: true,
    };
    for k in 0..2 {
        let p = spec.lut.params_at(t.ps[k]).expect("row");
        let pts: Vec<(f64, f64)> = t.mus.iter().map(|&m| (m, 0.0)).collect();
        let e = directional(&Evaluator::cpu(), &p, &s, &pts).expect("reference");
        for j in 0..3 {
            let got = t.values[k * 3 + j];
            let tol = t.max_error + e[j].error.x + REFERENCE_ATOL;
            assert!(
                (got - e[j].albedo.x).abs() <= tol,
                "E {got} vs {}",
                e[j].albedo.x
            );
        }
        assert!(t.avg[k] > 0.0 && t.avg[k] < 1.0 + t.max_error);
    }
}

#[test]
fn eon_table_is_its_closed_form_albedo() {
    let spec = engine(EngineKind::Eon, 5, 4);
    let t = compute_engine(&Evaluator::cpu(), &spec, &mut |_, _| {}).expect("eon");
    let exact = EonConfig::DEFAULT;
    for k in 0..4 {
        let r = t.ps[k];
        assert_eq!(r, (k as f64 + 0.5) / 4.0, "linear cell-centred r");
        for j in 0..5 {
            let want = eon_albedo_ss(t.mus[j], r, exact);
            let got = t.values[k * 5 + j];
            assert!(
                (got - want).abs() <= t.max_error + REFERENCE_ATOL,
                "r = {r}, mu = {}: {got} vs closed form {want}",
                t.mus[j]
            );
        }
        let want = eon_albedo_avg(r);
        assert!(
            (t.avg[k] - want).abs() <= t.max_error + REFERENCE_ATOL,
            "E_avg at r = {r}: {} vs {want}",
            t.avg[k]
        );
    }
}

fn lobe(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .output()
        .expect("run lobe")
}

/// binary16 bits to f64 (IEEE 754: 1 sign, 5 exponent, 10 fraction bits).
fn half_to_f64(h: u16) -> f64 {
    let (s, e, f) = ((h >> 15) as i32, ((h >> 10) & 31) as i32, (h & 1023) as f64);
    let m = if e == 0 {
        f * 2f64.powi(-24)
    } else {
        (1.0 + f / 1024.0) * 2f64.powi(e - 15)
    };
    if s == 1 {
        -m
    } else {
        m
    }
}

fn read_npy_f32(path: &Path) -> (Vec<usize>, Vec<f32>) {
    lobe::table::npy::read(path).expect("npy")
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Runs the compiler `cc` (CI installs build-essential) and requires success.
fn compiles(cc: &str, args: &[&str]) {
    let out = Command::new(cc)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{cc}: {e} (install build-essential)"));
    assert!(
        out.status.success(),
        "{cc}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_c_header_compiles_and_holds_the_npy_values() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (kind, stem) in [("dfg", "dfg-table"), ("kulla-conty", "kc")] {
        let exr = dir.path().join(format!("{stem}.exr"));
        let out = lobe(&[
            "albedo",
            "--backend",
            "cpu",
            "--lut",
            exr.to_str().expect("utf-8"),
            "--engine",
            kind,
            "--lut-res",
            "5,3",
            "--samples",
            "4096",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let header = exr.with_extension("h");
        let text = std::fs::read_to_string(&header).expect("header");
        for needle in [
            "cell-centred",
            "mu_j = (j + 0.5)/width",
            "Source: microfacet",
        ] {
            assert!(text.contains(needle), "{needle} missing from the header");
        }
        let name = format!("lobe_{}", stem.replace('-', "_"));
        let upper = name.to_uppercase();
        let program = format!(
            "#include <stdio.h>\n#include \"{}\"\nint main(void) {{\n  int n = {upper}_WIDTH * {upper}_HEIGHT * {upper}_CHANNELS;\n  printf(\"%d %d %d\\n\", {upper}_WIDTH, {upper}_HEIGHT, {upper}_CHANNELS);\n  for (int i = 0; i < n; i++) printf(\"%.9e %u\\n\", (double){name}_f32[i], (unsigned){name}_f16[i]);\n  return 0;\n}}\n",
            header.display()
        );
        let src = dir.path().join(format!("{stem}.c"));
        std::fs::write(&src, program).expect("write C");
        let bin = dir.path().join(stem);
        compiles(
            "cc",
            &["-std=c99", "-Wall", "-Werror", "-o", path(&bin), path(&src)],
        );
        compiles(
            "c++",
            &["-x", "c++", "-fsyntax-only", "-Wall", "-Werror", path(&src)],
        );
        let run = Command::new(&bin).output().expect("run the C program");
        let printed = String::from_utf8_lossy(&run.stdout);
        let mut lines = printed.lines();
        let dims: Vec<usize> = lines
            .next()
            .expect("dims")
            .split(' ')
            .map(|x| x.parse().expect("int"))
            .collect();
        let (shape, npy) = read_npy_f32(&exr.with_extension("npy"));
        let channels = if kind == "dfg" { 2 } else { 1 };
        assert_eq!(dims, [5, 3, channels]);
        assert_eq!(shape[..2], [3, 5]);
        let mut n = 0;
        for (line, &want) in lines.zip(&npy) {
            let mut it = line.split(' ');
            let f: f32 = it.next().expect("f32").parse().expect("f32");
            let h: u16 = it.next().expect("f16").parse().expect("f16");
            assert_eq!(f, want, "{kind}: the float array is the npy value");
            let hv = half_to_f64(h);
            assert!(
                (hv - want as f64).abs() <= HALF_RTOL * (want as f64).abs() + HALF_ATOL,
                "{kind}: half {hv} vs {want}"
            );
            n += 1;
        }
        assert_eq!(n, npy.len());
    }
}

#[test]
fn max_error_refuses_a_coarse_table_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let exr = dir.path().join("coarse.exr");
    let args = [
        "albedo",
        "--backend",
        "cpu",
        "--lut",
        exr.to_str().expect("utf-8"),
        "--engine",
        "dfg",
        "--lut-res",
        "4,4",
        "--samples",
        "16",
    ];
    let mut strict = args.to_vec();
    strict.extend(["--max-error", "1e-6"]);
    let out = lobe(&strict);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a coarse table was accepted");
    assert!(
        err.contains("--max-error") && err.contains("exceeds"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).expect("list").count(), 0);
    // Without the limit it is written, with a warning.
    let out = lobe(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("warning: the largest error estimate"), "{err}");
    // Plain albedo obeys it too.
    let out = lobe(&[
        "albedo",
        "--backend",
        "cpu",
        "--model",
        "microfacet",
        "--samples",
        "16",
        "--max-error",
        "1e-6",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("exceeds"));
}

/// |GPU − f64| ≤ the GPU's error estimate, whose f32 rounding term is K ε Σ|w f| / μo
/// (`GPU_ROUNDING_FACTOR`), or K′ ε Σ|w f| (`GPU_MIRROR_ROUNDING_FACTOR`) for a model whose
/// kernel takes ωi + ωo from mirror offsets, over the cases that set K′: GGX and Beckmann from
/// α = 0.001 to 1, at μo from 1 down to 1/64; and two presets.
fn estimates_bound_the_f32_rounding(gpu: &Gpu) {
    let s = Settings {
        method: Method::Peak,
        samples: 1 << 14,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: true,
    };
    let pts: Vec<(f64, f64)> = [1.0, 0.5, 0.1, 0.05, 0.02, 1.0 / 64.0]
        .iter()
        .map(|&m| (m, 0.0))
        .collect();
    let mut cases: Vec<(String, Vec<String>)> = Vec::new();
    for a in ["0.001", "0.003", "0.01", "0.3", "1"] {
        for d in ["ggx", "beckmann"] {
            cases.push((
                "microfacet".into(),
                vec![format!("alpha={a}"), format!("distribution={d}")],
            ));
        }
    }
    cases.push(("blinn_phong".into(), vec!["smoothness=0.1".into()]));
    cases.push(("lambert".into(), vec![]));
    for (model, sets) in cases {
        // The GPU sees f32 parameters: the f64 side gets the same.
        let p = resolve_params(&model, None, &sets)
            .expect("params")
            .rounded_to_f32();
        let g = directional(&Evaluator::gpu(gpu), &p, &s, &pts).expect("gpu");
        let c = directional(&Evaluator::cpu(), &p, &s, &pts).expect("cpu");
        for (g, c) in g.iter().zip(&c) {
            for ch in 0..3 {
                let diff = (g.albedo[ch] - c.albedo[ch]).abs();
                assert!(
                    diff <= g.error[ch],
                    "{model} {sets:?} mu = {}: |GPU - f64| = {diff:.3e} above the GPU estimate {:.3e}",
                    g.mu,
                    g.error[ch]
                );
            }
        }
    }
}

#[test]
fn gpu_error_estimates_bound_the_f32_rounding() {
    common::on_gpu(
        "gpu_error_estimates_bound_the_f32_rounding",
        false,
        estimates_bound_the_f32_rounding,
    );
}

/// The same with a GPU's albedo reduction (16 nodes per invocation and a workgroup tree) on
/// any device: on a CPU driver each invocation writes its own partial instead.
#[test]
fn with_the_workgroup_tree_error_estimates_bound_the_f32_rounding() {
    common::on_gpu(
        "with_the_workgroup_tree_error_estimates_bound_the_f32_rounding",
        true,
        estimates_bound_the_f32_rounding,
    );
}

/// The goal for a GGX white-furnace table on the GPU: its largest error estimate at most 1e-5,
/// a twentieth of the half-float step below 1 (2^-11), so that f32 kernels serve tables stored as
/// halves. It holds where the kernel forms ωi + ωo from mirror offsets: the f32 rounding term
/// is then K′ ε E without the 1/μo that made it 2.4e-4 at μo = 1/128.
const GGX_TABLE_MAX_ESTIMATE: f64 = 1e-5;

/// Kulla–Conty's E(μ, α) table (GGX, white furnace) with 64 μ columns, the first at μ = 1/128,
/// and 8 rows (α from 3.9e-3 to 0.88): every estimate at most [`GGX_TABLE_MAX_ESTIMATE`].
fn ggx_table_estimates(gpu: &Gpu) {
    let t = compute_engine(
        &Evaluator::gpu(gpu),
        &engine(EngineKind::KullaConty, 64, 8),
        &mut |_, _| {},
    )
    .expect("kulla-conty table");
    let at = t.largest_error().expect("a table");
    assert!(
        t.max_error <= GGX_TABLE_MAX_ESTIMATE,
        "largest estimate {:.3e} at {} above {GGX_TABLE_MAX_ESTIMATE:.0e}",
        t.max_error,
        at.describe("alpha")
    );
}

#[test]
fn gpu_ggx_table_estimates_stay_below_1e_5_at_grazing_view() {
    common::on_gpu(
        "gpu_ggx_table_estimates_stay_below_1e_5_at_grazing_view",
        false,
        ggx_table_estimates,
    );
}
