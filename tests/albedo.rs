//! Albedo integrators (docs/design.md §5): closed forms, the reference against itself in two
//! coordinate systems, the fixed rules against the reference, their error estimates' honesty,
//! their order of convergence, and GPU against CPU.

mod common;

use glam::DVec3;
use lobe::gpu::Gpu;
use lobe::integrate::{
    directional, hemispherical, reference_albedo, reference_albedo_mirror_frame, rule_albedo,
    view_direction, Estimate, Method, Rule, Settings, ESTIMATE_SAFETY, REFERENCE_RTOL,
};
use lobe::model::terms::{pow5, r0_from_ior};
use lobe::Query;
use lobe::{resolve_params, Evaluator, ParamSet, Reference};

/// Closed forms against the reference: its stated convergence (1e-10 relative, REFERENCE_RTOL)
/// with a margin of 10 for the summation of ~1e6 terms in f64.
const CLOSED_FORM_RTOL: f64 = 1e-9;

/// The default `peak` rule against the reference, for every built-in model at every preset: the
/// accuracy the rule is built for (the models' kinks lie on its panel edges, Cook–Torrance's
/// V-cavity curves included).
const PEAK_RTOL: f64 = 1e-6;

/// GPU (f32) against CPU (f64) for the same rule. Per node, f32 evaluation of a lobe differs by
/// up to ~1e-5 relative (PLATFORM.md: lavapipe f32 vs f64 max 1e-5; exp's 3 + 2|x| ulp bound
/// for cos^n lobes), and the nodes themselves are rounded to f32; the errors of 65536 nodes
/// average out, and the f32 partial sums add ≲ 1.3e-6 (src/gpu/albedo.rs). 2e-5 relative keeps
/// to what a conforming device (not only lavapipe) guarantees, plus 1e-7 absolute for channels
/// that are 0 (glazed ceramic's green).
const GPU_RTOL: f64 = 2e-5;
const GPU_ATOL: f64 = 1e-7;

fn params(model: &str, material: Option<&str>, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params(model, material, &sets).expect("valid test parameters")
}

fn reference(p: &ParamSet, mu: f64) -> Estimate {
    reference_albedo(
        &Reference::new(p, false),
        view_direction(mu, 0.3),
        REFERENCE_RTOL,
    )
}

#[track_caller]
fn assert_rel(what: &str, got: DVec3, want: DVec3, rtol: f64, atol: f64) {
    let diff = (got - want).abs();
    let allowed = DVec3::splat(atol) + rtol * want.abs();
    assert!(
        diff.cmple(allowed).all(),
        "{what}\n  expected {want:?}\n  actual   {got:?}\n  |diff|   {diff:?}\n  allowed  {allowed:?}"
    );
}

const MUS: [f64; 5] = [0.05, 0.1, 0.5, 0.9, 1.0];

#[test]
fn lambert_albedo_is_exactly_rho() {
    let p = params("lambert", None, &["albedo=0.9,0.4,0.1"]);
    for mu in MUS {
        let e = reference(&p, mu);
        assert_rel(
            &format!("lambert E(mu = {mu})"),
            e.value,
            DVec3::new(0.9, 0.4, 0.1),
            CLOSED_FORM_RTOL,
            0.0,
        );
    }
}

#[test]
fn oren_nayar_at_normal_incidence_is_albedo_times_a() {
    // At θo = 0 the B term's sinθi sinθo cosΔφ vanishes: f = albedo·A/π, E = albedo·A.
    for sigma in [0.05, 0.3, 0.6, 1.5] {
        let p = params(
            "oren_nayar",
            None,
            &["albedo=0.8,0.5,0.2", &format!("sigma={sigma}")],
        );
        let s2 = sigma * sigma;
        let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
        assert_rel(
            &format!("oren_nayar sigma = {sigma} E(mu = 1)"),
            reference(&p, 1.0).value,
            a * DVec3::new(0.8, 0.5, 0.2),
            CLOSED_FORM_RTOL,
            0.0,
        );
    }
}

#[test]
fn ashikhmin_shirley_diffuse_term_has_its_closed_form() {
    // f is linear in `diffuse`, so E(diffuse = d) − E(diffuse = 0) is the ρd term's albedo:
    // 28 d (1 − s)/(23π) (1 − (1 − μ/2)^5) ∫ (1 − (1 − c_i/2)^5) c_i dω, and
    // ∫ = 2π (1/2 − ∫₀¹ (1 − x/2)^5 x dx) = 2π (1/2 − 5/56) = 23π/28 (substitute u = 1 − x/2),
    // so E_d = d (1 − s)(1 − (1 − μ/2)^5) in closed form.
    let d = DVec3::new(0.7, 0.4, 0.2);
    let s = DVec3::new(0.05, 0.3, 0.6);
    for (nu, nv) in [(100.0, 100.0), (300.0, 50.0), (5.0, 5.0)] {
        let with = params(
            "ashikhmin_shirley",
            None,
            &[
                "diffuse=0.7,0.4,0.2",
                "specular=0.05,0.3,0.6",
                &format!("nu={nu}"),
                &format!("nv={nv}"),
            ],
        );
        let mut without = with.clone();
        without.set_text("diffuse=0").expect("valid");
        for mu in MUS {
            let e = reference(&with, mu).value - reference(&without, mu).value;
            let want = d * (DVec3::ONE - s) * (1.0 - (1.0 - 0.5 * mu).powi(5));
            // The difference of two integrals of size ~1 carries both tolerances.
            assert_rel(
                &format!("ashikhmin_shirley nu={nu} nv={nv} diffuse part of E(mu = {mu})"),
                e,
                want,
                CLOSED_FORM_RTOL,
                2.0 * CLOSED_FORM_RTOL,
            );
        }
    }
}

#[test]
fn coupled_albedo_is_the_spike_plus_the_matte_closed_form() {
    // E = F_s(μ) + (21/(20π))(1 − R0) m (1 − (1 − μ)^5) ∫ (1 − (1 − c_i)^5) c_i dω, and
    // ∫ = 2π (1/2 − ∫₀¹ (1 − x)^5 x dx) = 2π (1/2 − 1/42) = 20π/21: E = F_s(μ) + (1 − R0) m (1 − (1 − μ)^5).
    let m = DVec3::new(0.9, 0.5, 0.1);
    for ior in [1.3, 1.5, 4.0] {
        let p = params(
            "coupled",
            None,
            &["matte=0.9,0.5,0.1", &format!("ior={ior}")],
        );
        let r0 = r0_from_ior(ior);
        let s = Settings {
            method: Method::Reference,
            samples: 0,
            seed: lobe::integrate::DEFAULT_SEED,
            white_furnace: false,
        };
        let pts: Vec<(f64, f64)> = MUS.iter().map(|&mu| (mu, 0.3)).collect();
        for e in directional(&Evaluator::cpu(), &p, &s, &pts).expect("cpu") {
            let f = r0 + (1.0 - r0) * pow5(1.0 - e.mu);
            assert_rel(
                &format!("coupled ior = {ior} delta(mu = {})", e.mu),
                e.delta,
                DVec3::splat(f),
                1e-15,
                0.0,
            );
            assert_rel(
                &format!("coupled ior = {ior} E(mu = {})", e.mu),
                e.albedo,
                DVec3::splat(f) + (1.0 - r0) * m * (1.0 - pow5(1.0 - e.mu)),
                CLOSED_FORM_RTOL,
                0.0,
            );
        }
    }
}

#[test]
fn normalized_phong_keeps_its_specular_albedo_while_the_lobe_is_whole() {
    // ∫ (n+2)/(2π) (r·ωi)^n c_i dωi over the sphere = c_r · 2π/(n+2) · (n+2)/(2π) = μ (write
    // c_i = (r·ωi) c_r + tangential terms whose integral vanishes): E = specular·μ while the lobe
    // stays above the horizon. At μ = 1 the lobe is centred on n and the hemisphere holds all of
    // it: E(1) = specular exactly for every n. At μ = 0.5 with n = 8192 the horizon is 0.52 rad
    // from the peak, exp(−n·0.52²/2) ≈ 0 away: also exact in f64. This resolves the sharpest peak
    // of the lab report (width 1/√8192 ≈ 0.011 rad).
    for n in [0.0, 5.0, 400.0, 8192.0] {
        let p = params(
            "phong",
            None,
            &[
                "diffuse=0",
                "specular=0.9,0.6,0.3",
                &format!("shininess={n}"),
            ],
        );
        assert_rel(
            &format!("phong n = {n} E(mu = 1)"),
            reference(&p, 1.0).value,
            DVec3::new(0.9, 0.6, 0.3),
            CLOSED_FORM_RTOL,
            0.0,
        );
    }
    let p = params(
        "phong",
        None,
        &["diffuse=0", "specular=0.9,0.6,0.3", "shininess=8192"],
    );
    assert_rel(
        "phong n = 8192 E(mu = 0.5)",
        reference(&p, 0.5).value,
        0.5 * DVec3::new(0.9, 0.6, 0.3),
        CLOSED_FORM_RTOL,
        0.0,
    );
}

#[test]
fn cook_torrance_m_001_under_the_white_furnace_reflects_everything_at_normal_incidence() {
    // At ωo = n: E = ∫ D G c_d/c_o dωh (dωi = 4 c_d dωh) = ∫ D c_h dωh = 1 (Beckmann's D is
    // normalized over the hemisphere of h), as long as G = 1 and ωi stays above the horizon,
    // both true wherever D is not negligible for m = 0.01 (θh < 0.1 rad: D ~ e^-100 beyond).
    let p = params(
        "cook_torrance",
        None,
        &["diffuse=0", "specular=1", "roughness=0.01"],
    );
    let e = reference_albedo(
        &Reference::new(&p, true),
        view_direction(1.0, 0.0),
        REFERENCE_RTOL,
    );
    assert_rel(
        "cook_torrance m = 0.01 white furnace E(mu = 1)",
        e.value,
        DVec3::ONE,
        CLOSED_FORM_RTOL,
        0.0,
    );
}

#[test]
fn schlick_hemispherical_average_and_the_smooth_layered_spike() {
    // 2∫₀¹ F_s(μ) μ dμ = f0 + (1 − f0)·2∫₀¹ (1 − μ)^5 μ dμ = f0 + (1 − f0)·2·B(2, 6) = f0 + (1 − f0)/21.
    for ior in [1.0, 1.5, 2.5, 5.0] {
        let p = params(
            "smooth_layered",
            None,
            &["diffuse=0", &format!("ior={ior}")],
        );
        let f0 = r0_from_ior(ior);
        let want = DVec3::splat(f0 + (1.0 - f0) / 21.0);
        for method in [Method::Reference, Method::Peak] {
            let s = Settings {
                method,
                samples: method.default_samples(),
                seed: lobe::integrate::DEFAULT_SEED,
                white_furnace: false,
            };
            let h = hemispherical(&Evaluator::cpu(), &p, &s, 0.0).expect("cpu");
            assert_rel(
                &format!(
                    "smooth_layered ior = {ior} hemispherical ({})",
                    method.name()
                ),
                h.albedo,
                want,
                1e-14,
                1e-15,
            );
            assert_rel("its delta part", h.delta, want, 1e-14, 1e-15);
            for e in directional(&Evaluator::cpu(), &p, &s, &[(0.2, 0.0), (0.7, 1.0)]).expect("cpu")
            {
                let f = f0 + (1.0 - f0) * pow5(1.0 - e.mu);
                assert_rel("delta = F_s(mu)", e.delta, DVec3::splat(f), 1e-15, 0.0);
            }
        }
    }
}

#[test]
fn lambert_hemispherical_albedo_is_rho_and_equals_e_avg() {
    let p = params("lambert", None, &["albedo=0.6,0.3,0.9"]);
    for method in [Method::Reference, Method::Peak, Method::Gauss] {
        let s = Settings {
            method,
            samples: method.default_samples(),
            seed: lobe::integrate::DEFAULT_SEED,
            white_furnace: false,
        };
        let h = hemispherical(&Evaluator::cpu(), &p, &s, 0.0).expect("cpu");
        assert_rel(
            &format!("lambert hemispherical ({})", method.name()),
            h.albedo,
            DVec3::new(0.6, 0.3, 0.9),
            CLOSED_FORM_RTOL,
            0.0,
        );
        assert_eq!(
            h.albedo, h.e_avg,
            "isotropic: the hemispherical albedo is E_avg"
        );
    }
}

#[test]
fn the_reference_agrees_with_itself_in_the_mirror_frame() {
    // Two nested adaptive integrations in different coordinates (μ, Δφ about the normal; α, β
    // about the mirror direction) on the lab report's sharpest lobes. The mirror frame's panels
    // are not aligned with max(c_i, c_o) kinks, which it must find by bisection; the bound is
    // 1e-9.
    let cases = [
        (
            "phong",
            vec!["diffuse=0.1", "specular=0.9", "shininess=8192"],
        ),
        (
            "cook_torrance",
            vec!["diffuse=0", "specular=1", "roughness=0.01"],
        ),
        (
            "blinn_phong",
            vec!["diffuse=0.1", "specular=0.9", "smoothness=0"],
        ),
        (
            "ashikhmin_shirley",
            vec!["diffuse=0.2", "specular=0.5", "nu=2000", "nv=100"],
        ),
    ];
    for (model, sets) in cases {
        let p = params(model, None, &sets);
        let r = Reference::new(&p, false);
        for mu in [0.1, 0.5, 1.0] {
            let wo = view_direction(mu, 0.3);
            let a = reference_albedo(&r, wo, REFERENCE_RTOL);
            let b = reference_albedo_mirror_frame(&r, wo, REFERENCE_RTOL);
            assert_rel(
                &format!("{model} {sets:?} E(mu = {mu}): normal frame vs mirror frame"),
                b.value,
                a.value,
                1e-9,
                1e-12,
            );
        }
    }
}

fn presets() -> Vec<(&'static str, &'static str)> {
    let models = [
        "lambert",
        "phong",
        "blinn_phong",
        "oren_nayar",
        "cook_torrance",
        "smooth_layered",
        "coupled",
        "ashikhmin_shirley",
        "eon",
    ];
    let mut out = Vec::new();
    for m in models {
        for mat in ["tin", "gold", "glazed_ceramic", "granite"] {
            out.push((m, mat));
        }
    }
    out
}

#[test]
fn default_rule_meets_its_target_and_its_error_estimate_is_honest() {
    let mus = [0.02, 0.1, 0.5, 1.0];
    let wo: Vec<DVec3> = mus.iter().map(|&mu| view_direction(mu, 0.3)).collect();
    for (model, mat) in presets() {
        let p = params(model, Some(mat), &[]);
        let rule = Method::Peak
            .rule(Method::Peak.default_samples(), &p)
            .expect("fixed rule");
        let got = rule_albedo(&Evaluator::cpu(), &p, rule, &wo).expect("cpu");
        for (mu, e) in mus.iter().zip(got) {
            let want = reference(&p, *mu);
            let scale = want.value.abs().max_element();
            let err = (e.value - want.value).abs();
            let what = format!("{model} @ {mat}, mu = {mu}: peak {:?} vs reference {:?}, error {err:?}, estimate {:?}", e.value, want.value, e.error);
            // Honest: the estimate covers the actual error (plus the reference's own).
            assert!(
                // f64 round-off of ~1e5 terms may exceed an estimate that is itself round-off.
                err.cmple(e.error + want.error + 1e-13 * scale).all(),
                "error estimate too small: {what}"
            );
            assert!(
                err.max_element() <= PEAK_RTOL * scale,
                "over the 1e-6 target: {what}"
            );
        }
    }
}

/// The sharpest lobe an albedo LUT asks for (GGX α = 0.01, the default microfacet axis's low
/// end, lobe alone) from grazing to normal view: the default rule within the 1e-6 target. Here
/// the lobe spans ~2μo·α in Δφ near the horizon and ~α²/2 in μ at the pole, narrower than the
/// rule's 9 levels of grading; the extra levels of `grazing_levels` and `pole_levels` take
/// these from 6e-4 and 5e-5 to ≤ 1.1e-7.
#[test]
fn default_rule_resolves_the_sharpest_ggx_lobe_at_every_view() {
    let p = params(
        "microfacet",
        None,
        &["distribution=ggx", "alpha=0.01", "fresnel=none"],
    );
    let mus = [1.0 / 64.0, 0.1, 0.5, 0.9, 0.99, 1.0];
    let wo: Vec<DVec3> = mus.iter().map(|&mu| view_direction(mu, 0.3)).collect();
    let rule = Method::Peak
        .rule(Method::Peak.default_samples(), &p)
        .expect("fixed rule");
    let got = rule_albedo(&Evaluator::cpu(), &p, rule, &wo).expect("cpu");
    for (mu, e) in mus.iter().zip(got) {
        let want = reference(&p, *mu);
        let err = (e.value - want.value).abs().max_element();
        let scale = want.value.abs().max_element();
        assert!(
            err <= PEAK_RTOL * scale,
            "GGX alpha 0.01 at mu = {mu}: {:?} vs reference {:?}",
            e.value,
            want.value
        );
        assert!(
            err <= e.error.max_element() + want.error.max_element() + 1e-13 * scale,
            "estimate too small at mu = {mu}"
        );
    }
}

/// log-log slope of errors against sizes (least squares).
fn slope(sizes: &[f64], errors: &[f64]) -> f64 {
    let xs: Vec<f64> = sizes.iter().map(|s| s.ln()).collect();
    let ys: Vec<f64> = errors.iter().map(|e| e.ln()).collect();
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

#[test]
fn each_rule_converges_at_its_theoretical_rate() {
    // A smooth integrand: granite Phong (diffuse + a broad n = 5 lobe) at μ = 0.5.
    let p = params("phong", Some("granite"), &[]);
    let wo = view_direction(0.5, 0.3);
    let truth = reference(&p, 0.5).value;
    let err_of = |rule: Rule| {
        let e = rule_albedo(&Evaluator::cpu(), &p, rule, &[wo]).expect("cpu")[0];
        ((e.value - truth).abs().max_element(), e.error.max_element())
    };
    // Midpoint: O(h²) with N = 4 nθ² nodes, i.e. slope −1 against N.
    let ns = [8usize, 16, 32, 64, 128];
    let (errs, ests): (Vec<f64>, Vec<f64>) = ns
        .iter()
        .map(|&n| err_of(Rule::Midpoint { n_theta: n }))
        .unzip();
    let sizes: Vec<f64> = ns.iter().map(|&n| (4 * n * n) as f64).collect();
    let k = slope(&sizes, &errs);
    assert!(
        (-1.1..=-0.9).contains(&k),
        "midpoint: error ~ N^{k:.3}, theory N^-1 (h²); errors {errs:?}"
    );
    // The estimate is ESTIMATE_SAFETY × Richardson's (three levels at h, 2h, 4h: r = ¼ gives
    // d₁/3), which tracks the actual error within a factor 2 once asymptotic: it bounds the error
    // and is at most 2 × ESTIMATE_SAFETY above it.
    for (e, s) in errs.iter().zip(&ests).skip(2) {
        assert!(
            (1.0..=2.0 * ESTIMATE_SAFETY).contains(&(s / e)),
            "midpoint estimate {s} vs error {e}"
        );
    }
    // QMC (R2, cosine-weighted): ~N^-1 up to log factors; accept a slope in [−1.3, −0.7].
    let qs = [1usize << 10, 1 << 12, 1 << 14, 1 << 16, 1 << 18];
    let errs: Vec<f64> = qs.iter().map(|&n| err_of(Rule::Qmc { n }).0).collect();
    let sizes: Vec<f64> = qs.iter().map(|&n| n as f64).collect();
    let k = slope(&sizes, &errs);
    assert!(
        (-1.3..=-0.7).contains(&k),
        "qmc: error ~ N^{k:.3}, theory ~N^-1; errors {errs:?}"
    );
    // Gauss–Legendre × trapezoid: spectral for an analytic integrand (granite Blinn–Phong:
    // c_h^N with N ≈ 6 has no kink, unlike Phong's max(0, r·ωo)^n), so the log-log slope keeps
    // steepening: by nμ = 8 → 16 it is far steeper than any low algebraic order.
    let p = params("blinn_phong", Some("granite"), &[]);
    let truth = reference(&p, 0.5).value;
    let gs = [2usize, 4, 8, 16];
    let errs: Vec<f64> = gs
        .iter()
        .map(|&n| {
            let e =
                rule_albedo(&Evaluator::cpu(), &p, Rule::Gauss { n_mu: n }, &[wo]).expect("cpu")[0];
            (e.value - truth).abs().max_element().max(1e-16)
        })
        .collect();
    let last = slope(&[8.0, 16.0], &errs[2..]);
    assert!(
        last < -8.0 && errs[3] < 1e-12,
        "gauss: errors {errs:?} at n_mu {gs:?}; last log-log slope {last:.1} should be < -8"
    );
}

#[test]
fn gpu_and_cpu_agree_on_every_preset() {
    let Some(dev) = common::gpu_device("gpu_and_cpu_agree_on_every_preset") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let wo: Vec<DVec3> = [0.1, 0.5, 1.0]
        .iter()
        .map(|&mu| view_direction(mu, 0.3))
        .collect();
    for method in [Method::Peak, Method::Importance] {
        for (model, mat) in presets() {
            let p = params(model, Some(mat), &[]);
            let rule = method
                .rule(method.default_samples(), &p)
                .expect("fixed rule");
            // The GPU gets the parameters rounded to f32: compare with the CPU on the same values.
            let cpu = rule_albedo(&Evaluator::cpu(), &p.rounded_to_f32(), rule, &wo).expect("cpu");
            let g = rule_albedo(&Evaluator::gpu(&gpu), &p, rule, &wo).expect("gpu");
            for ((c, g), o) in cpu.iter().zip(&g).zip(&wo) {
                assert_rel(
                    &format!(
                        "{model} @ {mat}, mu = {}: GPU vs CPU ({})",
                        o.z,
                        method.name()
                    ),
                    g.value,
                    c.value,
                    GPU_RTOL,
                    GPU_ATOL,
                );
            }
        }
    }
    // One shared node list (midpoint) and a white furnace pipeline take the other paths.
    let p = params("cook_torrance", Some("gold"), &[]);
    let rule = Rule::Midpoint { n_theta: 64 };
    let cpu = rule_albedo(
        &Evaluator::cpu(),
        Query::one(&p.rounded_to_f32()).with_white_furnace(true),
        rule,
        &wo,
    )
    .expect("cpu");
    let g = rule_albedo(
        &Evaluator::gpu(&gpu),
        Query::one(&p).with_white_furnace(true),
        rule,
        &wo,
    )
    .expect("gpu");
    for (c, g) in cpu.iter().zip(&g) {
        assert_rel(
            "cook_torrance gold white furnace midpoint: GPU vs CPU",
            g.value,
            c.value,
            GPU_RTOL,
            GPU_ATOL,
        );
    }
    common::assert_validation_clean(&gpu, "gpu_and_cpu_agree_on_every_preset");
}

/// The reference is the f64 CPU integrator: asked of a GPU evaluator, it runs on the CPU and
/// gives the CPU's answer bit for bit (Lambert: E = rho exactly, up to the quadrature's rounding).
#[test]
fn the_reference_runs_on_the_cpu_whatever_the_backend() {
    let Some(dev) = common::gpu_device("the_reference_runs_on_the_cpu_whatever_the_backend") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let p = params("lambert", None, &[]);
    let s = Settings {
        method: Method::Reference,
        samples: 0,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    let on_gpu = directional(&Evaluator::gpu(&gpu), &p, &s, &[(0.5, 0.0)]).expect("gpu");
    let on_cpu = directional(&Evaluator::cpu(), &p, &s, &[(0.5, 0.0)]).expect("cpu");
    assert_eq!(on_gpu[0].albedo, on_cpu[0].albedo);
    assert!(
        (on_cpu[0].albedo.x - p.scalar("albedo")).abs() < 1e-12,
        "{:?}",
        on_cpu[0].albedo
    );
}

#[test]
fn cli_albedo_json_has_the_documented_fields() {
    let doc = common::lobe_json(&[
        "albedo",
        "--model",
        "smooth_layered",
        "--material",
        "tin",
        "--mu",
        "0.1,1",
        "--backend",
        "cpu",
        "--format",
        "json",
    ]);
    for key in [
        "model",
        "parameters",
        "method",
        "samples",
        "points",
        "hemispherical",
        "seconds",
    ] {
        assert!(doc.get(key).is_some(), "missing '{key}' in {doc}");
    }
    let pts = doc["points"].as_array().expect("points");
    assert_eq!(pts.len(), 2);
    for p in pts {
        for key in ["mu", "phi_deg", "albedo", "delta", "error_estimate"] {
            assert!(p.get(key).is_some(), "missing '{key}' in {p}");
        }
    }
    // The spike at mu = 0.1 is F_s(0.1) with R0 = (1/3)^2; the total holds it plus the diffuse 0.2481.
    let r0 = 1.0 / 9.0;
    let f = r0 + (1.0 - r0) * 0.9f64.powi(5);
    let delta = pts[0]["delta"][0].as_f64().expect("number");
    let total = pts[0]["albedo"][0].as_f64().expect("number");
    assert!((delta - f).abs() < 1e-12, "delta {delta} vs F_s = {f}");
    assert!(
        (total - f - 0.2481).abs() < 1e-9,
        "total {total} vs {}",
        f + 0.2481
    );
    // Bad input is a sentence, not a panic.
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(["albedo", "--mu", "1.5", "--backend", "cpu"])
        .output()
        .expect("run lobe");
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("--mu 1.5") && !err.contains("panicked"),
        "{err}"
    );
}

/// The `importance` rule's estimate is REPLICATE_T = 3.5 standard errors of its replicates'
/// mean: the actual error may exceed it in a few percent of directions (t with 7 degrees of
/// freedom beyond 3.5: 1.3 %; the replicates' errors are not exactly normal), never by much.
const IMPORTANCE_MISS_FRACTION: f64 = 0.05;
const IMPORTANCE_MISS_FACTOR: f64 = 2.0;

#[test]
fn importance_sampling_error_estimate_is_honest_on_every_preset() {
    let mus = [0.02, 0.1, 0.5, 1.0];
    let wo: Vec<DVec3> = mus.iter().map(|&mu| view_direction(mu, 0.3)).collect();
    let (mut cases, mut misses) = (0, 0);
    let mut models: Vec<_> = presets();
    for mat in ["tin", "gold", "glazed_ceramic", "granite"] {
        models.push(("microfacet", mat));
    }
    for (model, mat) in models {
        let p = params(model, Some(mat), &[]);
        let rule = Method::Importance
            .rule(Method::Importance.default_samples(), &p)
            .expect("fixed rule");
        let got = rule_albedo(&Evaluator::cpu(), &p, rule, &wo).expect("cpu");
        for (mu, e) in mus.iter().zip(got) {
            let want = reference(&p, *mu);
            let scale = want.value.abs().max_element();
            let err = (e.value - want.value).abs().max_element();
            // Exact integrands (lambert's f c_i/p is constant) leave only f64 round-off of ~1e5
            // terms, which no spread of the replicates can show.
            let allowed = e.error.max_element() + want.error.max_element() + 1e-12 * scale;
            let what = format!(
                "{model} @ {mat}, mu = {mu}: importance {:?} vs reference {:?}, error {err:.2e}, estimate {:.2e}",
                e.value, want.value, e.error.max_element()
            );
            assert!(
                err <= IMPORTANCE_MISS_FACTOR * allowed,
                "estimate far too small: {what}"
            );
            cases += 1;
            if err > allowed {
                misses += 1;
                eprintln!("estimate exceeded: {what}");
            }
            // A sanity bound on the method itself: 1e-2 relative at 65536 points for every preset.
            assert!(err <= 1e-2 * scale, "importance sampling far off: {what}");
        }
    }
    assert!(
        misses as f64 <= IMPORTANCE_MISS_FRACTION * cases as f64,
        "the importance estimate fell short in {misses} of {cases} directions"
    );
}

#[test]
fn importance_sampling_converges_at_least_at_the_monte_carlo_rate() {
    // RMS error over 8 view directions (the replicates' random shifts make each error a random
    // variable; the RMS steadies the log-log fit). Plain Monte Carlo gives N^-1/2; the
    // randomised low-discrepancy points do better, up to N^-1 for a smooth f c_i/p, less where
    // the horizon cuts the lobes. Accept a slope in [−1.25, −0.5].
    let wo: Vec<DVec3> = (0..8)
        .map(|k| view_direction(0.2 + 0.1 * k as f64, 0.3 * k as f64))
        .collect();
    for (model, mat) in [("phong", "gold"), ("cook_torrance", "gold")] {
        let p = params(model, Some(mat), &[]);
        let truth: Vec<DVec3> = wo
            .iter()
            .map(|o| reference_albedo(&Reference::new(&p, false), *o, REFERENCE_RTOL).value)
            .collect();
        let ns = [1usize << 10, 1 << 12, 1 << 14, 1 << 16, 1 << 18];
        let errs: Vec<f64> = ns
            .iter()
            .map(|&n| {
                let rule = Method::Importance.rule(n, &p).expect("fixed rule");
                let got = rule_albedo(&Evaluator::cpu(), &p, rule, &wo).expect("cpu");
                let ss: f64 = got
                    .iter()
                    .zip(&truth)
                    .map(|(e, t)| (e.value - *t).abs().max_element().powi(2))
                    .sum();
                (ss / wo.len() as f64).sqrt()
            })
            .collect();
        let sizes: Vec<f64> = ns.iter().map(|&n| n as f64).collect();
        let k = slope(&sizes, &errs);
        assert!(
            (-1.25..=-0.5).contains(&k),
            "{model} @ {mat} importance: RMS error ~ N^{k:.3}, theory N^-1/2 (MC) to N^-1 (QMC); errors {errs:?} at {ns:?}"
        );
    }
}

#[test]
fn importance_sampling_beats_cosine_qmc_on_a_sharp_lobe() {
    // Phong n = 8192 (lobe width 0.011 rad): cosine-weighted points almost never land in the
    // lobe, the mixture puts 2/3 of its lobe share there. At equal N the error must be at least
    // 100 times smaller (measured: ~1e-5 against ~1e-2 to 1e-1).
    let p = params(
        "phong",
        None,
        &["diffuse=0", "specular=1", "shininess=8192"],
    );
    for mu in [0.1, 0.5, 1.0] {
        let wo = [view_direction(mu, 0.3)];
        let truth = reference(&p, mu).value;
        let err = |m: Method| {
            let rule = m.rule(1 << 16, &p).expect("fixed rule");
            let e = rule_albedo(&Evaluator::cpu(), &p, rule, &wo).expect("cpu")[0];
            (e.value - truth).abs().max_element()
        };
        let (imp, qmc) = (err(Method::Importance), err(Method::Qmc));
        assert!(
            imp * 100.0 <= qmc,
            "phong n = 8192, mu = {mu}: importance error {imp:.2e}, qmc error {qmc:.2e}"
        );
    }
}
