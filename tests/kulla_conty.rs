//! The microfacet model's Kulla–Conty multiple-scattering lobe (Kulla & Conty 2017;
//! src/model/kulla_conty.rs): under F = 1 the lobe's directional albedo is 1, for every
//! distribution and masking; the shipped tables are what their script writes; F_avg has its
//! closed form or its quadrature; f stays reciprocal.

mod common;

use glam::DVec3;
use lobe::grid::direction;
use lobe::integrate::{directional, Settings};
use lobe::model::kulla_conty::{self, fresnel_average, TABLES};
use lobe::model::microfacet::{Fresnel, Microfacet, MicrofacetConfig};
use lobe::model::terms::{F_dielectric, F_schlick};
use lobe::model::Model;
use lobe::{resolve_params, Evaluator, ParamSet, Reference};

/// The goal: |E − 1| ≤ 1e-4 under the white furnace for α, μ ∈ [0.05, 1]. What remains is the
/// interpolation error of 1 − E on the 65 × 65 knots (largest found: 1.5e-5, Beckmann α = 0.05,
/// μ = 0.1); the integrator's own estimate is added to the bound.
const FURNACE_TOL: f64 = 1e-4;

/// The tables hold 1 − E to 9 significant digits, kept as f32: a relative 2^-24 of the value,
/// plus the 5e-10 absolute of the printed digits where the loss is tiny.
const TABLE_RTOL: f64 = 6e-8;
const TABLE_ATOL: f64 = 1e-9;

/// Reciprocity in f64: every term is symmetric in (ωi, ωo) up to the order of operations.
const RECIPROCITY_RTOL: f64 = 1e-12;

fn params(sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params("microfacet", None, &sets).expect("valid microfacet parameters")
}

/// The microfacet lobe alone with the Kulla–Conty lobe, for table `t`.
fn white_lobe(t: usize, extra: &[&str]) -> ParamSet {
    let (d, m, g1) = TABLES[t];
    let mut sets = vec![
        format!("distribution={d}"),
        format!("masking={m}"),
        format!("beckmann_g1={g1}"),
        "fresnel=none".to_string(),
        "multiscatter=kulla_conty".to_string(),
        "specular=1".to_string(),
        "diffuse=0".to_string(),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    params(&sets)
}

fn white_settings() -> Settings {
    Settings {
        white_furnace: true,
        ..Settings::default()
    }
}

#[test]
fn white_furnace_albedo_is_one_for_every_distribution_and_masking() {
    let mus = [0.05, 0.1, 0.3, 0.6, 1.0];
    let points: Vec<(f64, f64)> = mus.iter().map(|&mu| (mu, 0.0)).collect();
    let mut worst = (0.0f64, String::new());
    for t in 0..TABLES.len() {
        for alpha in ["0.05", "0.2", "0.5", "1"] {
            let p = white_lobe(t, &[&format!("alpha={alpha}")]);
            let got =
                directional(&Evaluator::cpu(), &p, &white_settings(), &points).expect("albedo");
            for (a, mu) in got.iter().zip(mus) {
                let d = (a.albedo.x - 1.0).abs();
                let what = format!("{:?} alpha={alpha} mu={mu}: E = {}", TABLES[t], a.albedo.x);
                assert!(
                    d <= FURNACE_TOL + a.error.x,
                    "{what} (estimate {:e})",
                    a.error.x
                );
                if d > worst.0 {
                    worst = (d, what);
                }
            }
        }
    }
    // Anisotropic: the tables are read at sqrt(alpha_x alpha_y), which only approximates the
    // lobe's loss (at alpha_x = 0.3, alpha_y = 0.6, phi_o = 0: E = 0.944 at mu = 0.05); the
    // lobe must still return energy without creating any.
    let p = white_lobe(7, &["alpha_x=0.3", "alpha_y=0.6"]);
    let got = directional(&Evaluator::cpu(), &p, &white_settings(), &points).expect("albedo");
    for a in &got {
        let e = a.albedo.x;
        assert!(
            (0.9..=1.0 + FURNACE_TOL).contains(&e),
            "anisotropic GGX: E = {e}"
        );
    }
    eprintln!(
        "largest |E - 1| under the white furnace: {:e} at {}",
        worst.0, worst.1
    );
}

#[test]
fn without_the_lobe_energy_is_lost() {
    // The same point with multiscatter = none loses what the lobe returns (GGX at alpha = 1
    // keeps only 0.307 at mu = 1).
    let p = white_lobe(7, &["alpha=1", "multiscatter=none"]);
    let got = directional(&Evaluator::cpu(), &p, &white_settings(), &[(1.0, 0.0)]).unwrap();
    assert!(got[0].albedo.x < 0.35, "E = {}", got[0].albedo.x);
}

/// A few rows of each kind recomputed as scripts/kulla-conty-tables computes them (the f64
/// reference with the default peak rule, white furnace, specular 1, diffuse 0).
#[test]
fn shipped_tables_are_the_scripts_output() {
    let tables = kulla_conty::tables();
    let n = kulla_conty::KNOTS - 1;
    let points: Vec<(f64, f64)> = (1..=n)
        .map(|j| ((j as f64 / n as f64).powi(2), 0.0))
        .collect();
    for (t, k) in [(0, 64), (4, 20), (7, 33)] {
        let (d, m, g1) = TABLES[t];
        let alpha = (k as f64 / n as f64).powi(2);
        let p = params(&[
            &format!("distribution={d}"),
            &format!("masking={m}"),
            &format!("beckmann_g1={g1}"),
            "fresnel=none",
            "specular=1",
            "diffuse=0",
            &format!("alpha={alpha}"),
        ]);
        let got = directional(&Evaluator::cpu(), &p, &white_settings(), &points).unwrap();
        for (j, a) in got.iter().enumerate() {
            let want = 1.0 - a.albedo.x;
            let have = tables[t].loss[k * kulla_conty::KNOTS + j + 1] as f64;
            assert!(
                (have - want).abs() <= TABLE_RTOL * want.abs() + TABLE_ATOL,
                "{:?} k={k} j={}: table {have:e}, recomputed {want:e}",
                TABLES[t],
                j + 1
            );
        }
    }
    // Row 0 is a mirror's loss, 0; the first column is the cubic extrapolation of its row.
    for table in tables {
        assert!(table.loss[..kulla_conty::KNOTS].iter().all(|&v| v == 0.0));
        assert!(table.largest_error < 1e-4);
    }
}

/// The piecewise cubic reproduces cubics exactly, and the row averages are its integral.
#[test]
fn interpolation_reproduces_cubics_and_averages_integrate_it() {
    for u in [0.0, 0.3, 1.0, 17.25, 62.9, 64.0] {
        let (i0, w) = kulla_conty::lagrange(u);
        let cubic = |x: f64| 0.5 - 0.1 * x + 0.003 * x * x - 2e-5 * x * x * x;
        let got: f64 = (0..4).map(|q| w[q] * cubic((i0 + q) as f64)).sum();
        assert!(
            (got - cubic(u)).abs() < 1e-12,
            "u = {u}: {got} vs {}",
            cubic(u)
        );
    }
    // avg_at at a knot is 4∫ L̃ s³ ds of that row, checked by a fine midpoint rule.
    let table = &kulla_conty::tables()[7];
    for k in [8usize, 40, 64] {
        let alpha = (k as f64 / 64.0).powi(2);
        let cells = 200_000;
        let mut sum = 0.0;
        for c in 0..cells {
            let s = (c as f64 + 0.5) / cells as f64;
            sum += table.loss_at(s * s, alpha) * s * s * s;
        }
        let want = 4.0 * sum / cells as f64;
        assert!((table.avg_at(alpha) - want).abs() < 1e-8, "k = {k}");
    }
}

#[test]
fn fresnel_averages() {
    // Schlick: 2∫(F0 + (1 − F0)(1 − μ)⁵)μ dμ = F0 + (1 − F0)/21, against the quadrature of F.
    for f0 in [0.0, 0.04, 0.5, 1.0] {
        let p = Microfacet::new(&params(&[&format!("f0={f0}")]));
        let quad = fresnel_average(|c| F_schlick(c, DVec3::splat(f0)).x);
        assert!((p.f_avg.x - (f0 + (1.0 - f0) / 21.0)).abs() < 1e-15);
        assert!(
            (p.f_avg.x - quad).abs() < 1e-13,
            "f0 = {f0}: {} vs {quad}",
            p.f_avg.x
        );
    }
    // Dielectric: against an independent midpoint rule of 10⁶ cells; η = 1 reflects nothing.
    for ior in [1.0, 1.5, 2.4] {
        let p = Microfacet::new(&params(&["fresnel=dielectric", &format!("ior={ior}")]));
        let cells = 1_000_000;
        let mid: f64 = (0..cells)
            .map(|c| {
                let mu = (c as f64 + 0.5) / cells as f64;
                2.0 * F_dielectric(mu, ior) * mu
            })
            .sum::<f64>()
            / cells as f64;
        assert!(
            (p.f_avg.x - mid).abs() < 1e-9,
            "ior = {ior}: {} vs {mid}",
            p.f_avg.x
        );
    }
    // No Fresnel factor: 1.
    assert_eq!(
        Microfacet::new(&params(&["fresnel=none"])).f_avg,
        DVec3::ONE
    );
}

#[test]
fn reciprocal_and_finite() {
    let mut rng = common::Rng(0x6b63_0012);
    for fresnel in Fresnel::NAMES {
        for alpha in [
            ["alpha=1e-4", "alpha=1e-4"],
            ["alpha_x=0.05", "alpha_y=1"],
            ["alpha=1", "alpha=1"],
        ] {
            let p = params(&[
                "multiscatter=kulla_conty",
                &format!("fresnel={fresnel}"),
                "diffuse=0.1",
                alpha[0],
                alpha[1],
            ]);
            let r = Reference::new(&p, false);
            for _ in 0..200 {
                let wi = direction(rng.range(0.0, 1.5707), rng.range(0.0, 6.28));
                let wo = direction(rng.range(0.0, 1.5707), rng.range(0.0, 6.28));
                let (a, b) = (r.eval(wi, wo), r.eval(wo, wi));
                assert!(a.is_finite() && a.min_element() >= 0.0, "{p:?}: f = {a}");
                assert!(
                    (a - b).abs().max_element() <= RECIPROCITY_RTOL * a.max_element(),
                    "{fresnel} {alpha:?}: f(wi, wo) = {a}, f(wo, wi) = {b}"
                );
            }
        }
    }
}

#[test]
fn the_choice_is_the_pipeline() {
    let p = params(&["multiscatter=kulla_conty"]);
    let Model::Microfacet(c) = p.model() else {
        panic!("microfacet")
    };
    assert!(c.kulla_conty() && !MicrofacetConfig::DEFAULT.kulla_conty());
    assert_eq!(c.spec_constants()[4], 1);
    assert!(p.model().label().contains("+kulla_conty"));
    assert!(MicrofacetConfig::all().iter().any(|c| c.kulla_conty()));
    // Each configuration binds its own table.
    assert_eq!(
        p.model().data().map(<[u8]>::len),
        Some(4 * (kulla_conty::KNOTS * kulla_conty::KNOTS + kulla_conty::KNOTS))
    );
}
