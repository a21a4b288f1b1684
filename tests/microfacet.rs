//! Closed forms and limits of the microfacet terms (CPU, f64), and the identity between
//! `cook_torrance` and one configuration of `microfacet`.

mod common;

use glam::DVec3;
use lobe::grid::direction;
use lobe::model::microfacet::{Microfacet, MicrofacetConfig};
use lobe::model::terms::*;
use lobe::model::{Model, ParamSet, Reference};
use lobe::resolve_params;
use std::f64::consts::{FRAC_PI_2, PI};

/// ∫ D(h) c_h dω_h = 1 over the hemisphere (Walter et al. 2007 eq. 4) for a normalized D. The
/// midpoint rule in (θ, φ) below has relative error ≈ Δθ²/(24 σ²) for a peak of width σ ≈ α/√2:
/// with 30 000 cells in θ that is 1e-7 at the narrowest peak tested (α = 0.05). In φ the integrand
/// is smooth and periodic, where the midpoint rule converges geometrically: 8 cells are exact for
/// an isotropic D, and 1024 resolve the azimuthal peaks of α = (0.1, 0.5).
const NORMALIZATION_TOL: f64 = 1e-6;

fn integrate_projected(np: usize, d: impl Fn(DVec3) -> f64) -> f64 {
    let nt = 30_000;
    let (dt, dp) = (FRAC_PI_2 / nt as f64, 2.0 * PI / np as f64);
    let mut sum = 0.0;
    for i in 0..nt {
        let t = (i as f64 + 0.5) * dt;
        let mut ring = 0.0;
        for j in 0..np {
            ring += d(direction(t, (j as f64 + 0.5) * dp));
        }
        sum += ring * t.cos() * t.sin() * dt * dp;
    }
    sum
}

#[test]
fn both_distributions_are_normalized() {
    for (ax, ay) in [
        (0.05, 0.05),
        (0.2, 0.2),
        (0.6, 0.6),
        (1.0, 1.0),
        (0.1, 0.5),
        (0.8, 0.15),
    ] {
        let np = if ax == ay { 8 } else { 1024 };
        let b = integrate_projected(np, |h| D_beckmann(h, ax, ay));
        let g = integrate_projected(np, |h| D_ggx(h, ax, ay));
        // GGX's tail falls as θ^-4 near the horizon: the part beyond the last cell is O(α²Δθ).
        assert!(
            (b - 1.0).abs() < NORMALIZATION_TOL,
            "Beckmann α=({ax},{ay}): ∫D c_h dω = {b}"
        );
        assert!(
            (g - 1.0).abs() < NORMALIZATION_TOL,
            "GGX α=({ax},{ay}): ∫D c_h dω = {g}"
        );
    }
}

fn g1(lambda: f64) -> f64 {
    1.0 / (1.0 + lambda)
}

#[test]
fn smith_g1_limits_and_closed_forms() {
    for alpha in [0.05, 0.3, 1.0] {
        // G1 = 1 at normal incidence, for every distribution and variant.
        let t2 = alpha_tan2(DVec3::Z, alpha, alpha);
        assert_eq!(t2, 0.0);
        assert_eq!(g1(lambda_ggx(t2)), 1.0);
        assert_eq!(g1(lambda_beckmann(t2)), 1.0);
        assert_eq!(G1_beckmann_rational(t2), 1.0);
        // G1 → 0 at grazing.
        let graze = alpha_tan2(direction(FRAC_PI_2 - 1e-6, 0.3), alpha, alpha);
        assert!(g1(lambda_ggx(graze)) < 1e-4 * (1.0 + alpha));
        assert!(g1(lambda_beckmann(graze)) < 1e-4 * (1.0 + alpha));
        // Monotone in θ and within [0, 1].
        let mut last = 1.0;
        for k in 0..=90 {
            let w = direction((k as f64).to_radians().min(FRAC_PI_2 - 1e-9), 0.7);
            let g = g1(lambda_ggx(alpha_tan2(w, alpha, alpha)));
            assert!(
                (0.0..=1.0).contains(&g) && g <= last + 1e-15,
                "GGX G1 not monotone at {k}°"
            );
            last = g;
            // Walter et al. 2007 eq. 34: GGX G1 = 2 / (1 + sqrt(1 + α² tan²θ)).
            let t2 = alpha_tan2(w, alpha, alpha);
            assert!((g - 2.0 / (1.0 + (1.0 + t2).sqrt())).abs() < 1e-13);
            // The rational fit tracks the exact Beckmann G1; Walter et al. 2007 give its error as
            // under 0.35 % (section 5.1). Assert that bound on the absolute difference (G1 ≤ 1).
            let exact = g1(lambda_beckmann(t2));
            let rational = G1_beckmann_rational(t2);
            assert!(
                (exact - rational).abs() < 3.5e-3,
                "α={alpha} θ={k}°: exact {exact} rational {rational}"
            );
        }
    }
}

#[test]
fn smith_g_is_symmetric_in_the_two_directions() {
    let mut rng = common::Rng(3);
    for config in MicrofacetConfig::all() {
        let mut p = ParamSet::defaults(Model::Microfacet(config));
        p.set_text("alpha_x=0.2").unwrap();
        p.set_text("alpha_y=0.6").unwrap();
        let r = Reference::new(&p, true);
        for _ in 0..200 {
            let wi = direction(rng.range(0.0, 1.5), rng.range(0.0, 2.0 * PI));
            let wo = direction(rng.range(0.0, 1.5), rng.range(0.0, 2.0 * PI));
            let (a, b) = (r.eval(wi, wo), r.eval(wo, wi));
            assert!(
                (a - b).abs().max_element() <= 1e-12 * a.abs().max_element(),
                "{}: {a} vs {b}",
                config.label()
            );
        }
    }
}

#[test]
fn exact_fresnel_limits() {
    for eta in [1.0, 1.33, 1.5, 2.4, 5.0] {
        let r0 = r0_from_ior(eta);
        // Normal incidence: R0 = ((η−1)/(η+1))² (Born & Wolf); grazing: 1.
        assert!((F_dielectric(1.0, eta) - r0).abs() < 1e-15, "η={eta}");
        if eta > 1.0 {
            assert!(
                (F_dielectric(0.0, eta) - 1.0).abs() < 1e-15,
                "η={eta} at grazing"
            );
        }
        // A conductor with k = 0 is the dielectric, at every angle.
        for k in 0..=100 {
            let c = k as f64 / 100.0;
            let cond = F_conductor(c, DVec3::splat(eta), DVec3::ZERO);
            assert!(
                (cond - DVec3::splat(F_dielectric(c, eta)))
                    .abs()
                    .max_element()
                    < 1e-13,
                "η={eta} c={c}"
            );
        }
    }
    // A conductor at normal incidence: R0 = ((n−1)² + k²)/((n+1)² + k²).
    let (n, k) = (0.2, 3.0);
    let expected = ((n - 1.0) * (n - 1.0) + k * k) / ((n + 1.0) * (n + 1.0) + k * k);
    assert!((F_conductor(1.0, DVec3::splat(n), DVec3::splat(k)).x - expected).abs() < 1e-14);
}

/// `cook_torrance` is `microfacet` with Beckmann D, V-cavity G and Schlick's F from the IOR.
#[test]
fn cook_torrance_is_a_microfacet_configuration() {
    let mut rng = common::Rng(5);
    for _ in 0..100 {
        let m = rng.log_range(0.01, 1.0);
        let eta = rng.range(1.0, 5.0);
        let (kd, ks) = (rng.uniform(), rng.uniform());
        let ct = resolve_params(
            "cook_torrance",
            None,
            &[
                format!("roughness={m}"),
                format!("ior={eta}"),
                format!("diffuse={kd}"),
                format!("specular={ks}"),
            ],
        )
        .unwrap();
        let mf = resolve_params(
            "microfacet",
            None,
            &[
                "distribution=beckmann".into(),
                "masking=v_cavity".into(),
                "fresnel=schlick".into(),
                format!("alpha={m}"),
                format!("ior={eta}"),
                format!("diffuse={kd}"),
                format!("specular={ks}"),
            ],
        )
        .unwrap();
        for wf in [false, true] {
            let (a, b) = (Reference::new(&ct, wf), Reference::new(&mf, wf));
            for _ in 0..50 {
                let wi = direction(rng.range(0.0, 1.55), rng.range(0.0, 2.0 * PI));
                let wo = direction(rng.range(0.0, 1.55), rng.range(0.0, 2.0 * PI));
                let (x, y) = (a.eval(wi, wo), b.eval(wi, wo));
                // Same terms, same order of operations: equal to the last bit.
                assert_eq!(x, y, "m={m} η={eta} wi={wi:?} wo={wo:?}");
            }
        }
    }
}

#[test]
fn anisotropy_follows_alpha_x_and_alpha_y() {
    let iso = resolve_params("microfacet", None, &["alpha=0.3".into()]).unwrap();
    assert!(iso.is_isotropic());
    let aniso = resolve_params(
        "microfacet",
        None,
        &["alpha_x=0.1".into(), "alpha_y=0.4".into()],
    )
    .unwrap();
    assert!(!aniso.is_isotropic());
    let m = Microfacet::new(&aniso);
    assert_eq!((m.alpha_x, m.alpha_y), (0.1, 0.4));
    // f is then not invariant under a rotation of both directions about n.
    let r = Reference::new(&aniso, false);
    let f0 = r.eval(direction(0.5, 0.0), direction(0.5, PI + 0.2));
    let f1 = r.eval(
        direction(0.5, FRAC_PI_2),
        direction(0.5, FRAC_PI_2 + PI + 0.2),
    );
    assert!((f0 - f1).abs().max_element() > 1e-3 * f0.max_element());
}
