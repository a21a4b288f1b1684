//! The sampling test judged on samplers whose flaws are known: correct ones must pass, each
//! planted flaw must be caught by the check meant for it.

use super::*;
use crate::interrupt::CancelToken;
use std::f64::consts::PI;

/// An orthonormal frame (t, b) about the unit vector n (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited", JCGT 6(1)).
fn frame(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Malley's method: a uniform disc point lifted to the hemisphere, density cosθ/π.
fn cosine_direction(u: DVec2) -> DVec3 {
    let (r, phi) = (u.x.sqrt(), 2.0 * PI * u.y);
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// A Lambertian lobe of albedo `rho`, drawn by Malley's method; the planted flaws scale the
/// claimed pdf (`pdf_claim`: `pdf` returns and the draw reports cosθ/π times this, or 1/π
/// when `flat`), the draw's pdf alone (`drawn_pdf_scale`) or the weight's red channel
/// (`weight_scale`).
#[derive(Clone, Copy)]
struct Cosine {
    rho: f64,
    flat: bool,
    drawn_pdf_scale: f64,
    weight_scale: f64,
}

const COSINE: Cosine = Cosine {
    rho: 0.8,
    flat: false,
    drawn_pdf_scale: 1.0,
    weight_scale: 1.0,
};

impl Sampler for Cosine {
    fn sample(&self, wo: DVec3, _uc: f64, u: DVec2) -> Drawn {
        let wi = cosine_direction(u);
        let pdf = self.pdf(wi, wo);
        let mut weight = self.eval_cos(wi, wo) / pdf;
        weight.x *= self.weight_scale;
        Drawn {
            wi,
            weight,
            pdf: pdf * self.drawn_pdf_scale,
            delta: false,
        }
    }
    fn pdf(&self, wi: DVec3, _wo: DVec3) -> f64 {
        if wi.z <= 0.0 {
            0.0
        } else if self.flat {
            1.0 / PI
        } else {
            wi.z / PI
        }
    }
    fn eval_cos(&self, wi: DVec3, _wo: DVec3) -> DVec3 {
        DVec3::splat(self.rho * wi.z.max(0.0) / PI)
    }
}

/// A power-cosine (Phong) lobe (n + 1)/(2π) cos^n α about the mirror direction of ωo (Lafortune
/// & Willems 1994), drawn exactly: cos α = (1 − u₁)^{1/(n+1)} (1 − u₁ ∈ (0, 1]: u₁ = 0 itself, one
/// draw in 2²⁴, would put cos α = 0 at the lobe's edge, a leak the test finds). Draws below the horizon are returned
/// with pdf 0 and weight 0, so ∫ pdf over the hemisphere is 1 minus their share.
struct PowerCosine {
    n: f64,
}

impl PowerCosine {
    fn axis(wo: DVec3) -> DVec3 {
        DVec3::new(-wo.x, -wo.y, wo.z)
    }
}

impl Sampler for PowerCosine {
    fn sample(&self, wo: DVec3, _uc: f64, u: DVec2) -> Drawn {
        let r = PowerCosine::axis(wo);
        let (t, b) = frame(r);
        let cos_a = (1.0 - u.x).powf(1.0 / (self.n + 1.0));
        let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let wi = (t * phi.cos() * sin_a + b * phi.sin() * sin_a + r * cos_a).normalize();
        let pdf = self.pdf(wi, wo);
        if pdf <= 0.0 {
            return Drawn {
                wi,
                weight: DVec3::ZERO,
                pdf: 0.0,
                delta: false,
            };
        }
        Drawn {
            wi,
            weight: self.eval_cos(wi, wo) / pdf,
            pdf,
            delta: false,
        }
    }
    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        (self.n + 1.0) / (2.0 * PI) * wi.dot(PowerCosine::axis(wo)).max(0.0).powf(self.n)
    }
    fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        DVec3::new(0.9, 0.6, 0.3) * self.pdf(wi, wo)
    }
}

/// Draws φ with density (1 + a cos 2φ)/(2π) and cosθ as Malley does, but claims cosθ/π: a
/// distortion of shape by a relative ±a, with the right total.
struct Distorted {
    a: f64,
}

impl Sampler for Distorted {
    fn sample(&self, wo: DVec3, _uc: f64, u: DVec2) -> Drawn {
        // Invert F(φ) = (φ + (a/2) sin 2φ)/(2π) by Newton's method; F' ≥ (1 − a)/(2π) > 0.
        let target = 2.0 * PI * u.y;
        let mut phi = target;
        for _ in 0..20 {
            let (sin, cos) = (2.0 * phi).sin_cos();
            let step = (phi + 0.5 * self.a * sin - target) / (1.0 + self.a * cos);
            phi -= step;
            if step.abs() < 1e-15 {
                break;
            }
        }
        let r = u.x.sqrt();
        let wi = DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt());
        let pdf = self.pdf(wi, wo);
        Drawn {
            wi,
            weight: self.eval_cos(wi, wo) / pdf,
            pdf,
            delta: false,
        }
    }
    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        COSINE.pdf(wi, wo)
    }
    fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        COSINE.eval_cos(wi, wo)
    }
}

/// A Lambertian lobe with a mirror: uc < `mirror` picks the delta lobe, otherwise Malley's
/// method; the pdf of the continuous part is (1 − mirror) cosθ/π. `lost` is a share of draws
/// that the sampler throws away (pdf 0) without its pdf saying so.
struct WithMirror {
    mirror: f64,
    lost: f64,
}

impl Sampler for WithMirror {
    fn sample(&self, wo: DVec3, uc: f64, u: DVec2) -> Drawn {
        if uc < self.mirror {
            return Drawn {
                wi: DVec3::new(-wo.x, -wo.y, wo.z),
                weight: DVec3::ONE,
                pdf: self.mirror,
                delta: true,
            };
        }
        let wi = cosine_direction(u);
        if uc < self.mirror + self.lost {
            return Drawn {
                wi,
                weight: DVec3::ZERO,
                pdf: 0.0,
                delta: false,
            };
        }
        let pdf = self.pdf(wi, wo);
        Drawn {
            wi,
            weight: self.eval_cos(wi, wo) / pdf,
            pdf,
            delta: false,
        }
    }
    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        (1.0 - self.mirror) * COSINE.pdf(wi, wo)
    }
    fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        COSINE.eval_cos(wi, wo)
    }
}

/// Uniform draws over the hemisphere, each reported with the uniform density, whose pdf
/// function claims nothing in the quadrant φ ∈ [0, π/2) (and 4/3 of uniform elsewhere).
struct Blind;

impl Sampler for Blind {
    fn sample(&self, wo: DVec3, _uc: f64, u: DVec2) -> Drawn {
        let (z, phi) = (u.x, 2.0 * PI * u.y);
        let s = (1.0 - z * z).max(0.0).sqrt();
        let wi = DVec3::new(s * phi.cos(), s * phi.sin(), z);
        let _ = wo;
        Drawn {
            wi,
            weight: DVec3::ONE,
            pdf: 1.0 / (2.0 * PI),
            delta: false,
        }
    }
    fn pdf(&self, wi: DVec3, _wo: DVec3) -> f64 {
        if wi.z > 0.0 && !(wi.x > 0.0 && wi.y >= 0.0) {
            4.0 / 3.0 / (2.0 * PI)
        } else {
            0.0
        }
    }
    fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        DVec3::splat(self.pdf(wi, wo))
    }
}

fn options(samples: u64, directions: &[[f64; 2]]) -> Options {
    Options {
        directions: directions.to_vec(),
        samples,
        ..Options::default()
    }
}

fn test<S: Sampler>(s: &S, samples: u64, directions: &[[f64; 2]]) -> Report {
    run(s, &options(samples, directions), None, |_, _| {}).expect("the test runs")
}

/// Prints what a failing assertion needs: per direction, the verdicts and the numbers behind them.
fn describe(r: &Report) -> String {
    let mut out = format!(
        "{} draws, α per test {:.3e}\n",
        r.options.samples, r.corrected_significance
    );
    for d in &r.directions {
        out += &format!(
            "  θo {}° φo {}°: chi-square {:.1} / {} dof, p {:.3e}; outside {} + {} draws vs missing {:.3e}, p {:.3e}; accuracy {:.2e}; worst {:?}; draws {:?}; failures {:?}\n",
            d.theta_o_deg, d.phi_o_deg, d.statistic.value, d.statistic.dof, d.p_value, d.leaked,
            d.delta, d.missing_mass, d.outside_p_value, d.expected_accuracy, d.worst_cell, d.draws, d.failures
        );
    }
    out
}

#[test]
fn chi2_accepts_the_cosine_sampler() {
    for samples in [1u64 << 20, 1 << 24] {
        let r = test(&COSINE, samples, &[[0.0, 0.0], [60.0, 0.0]]);
        assert!(r.passed, "{}", describe(&r));
        for d in &r.directions {
            assert_eq!(d.observed.iter().sum::<u64>(), samples);
            assert!(d.expected_accuracy < 1e-6, "{}", describe(&r));
            assert!(d.draws.max_weight_error < 1e-12 && d.draws.max_pdf_error == 0.0);
            assert_eq!((d.leaked, d.delta), (0, 0));
        }
    }
}

#[test]
fn chi2_accepts_power_cosine_lobes_broad_and_peaked() {
    for n in [20.0, 1e4] {
        let r = test(&PowerCosine { n }, 1 << 20, &[[0.0, 0.0], [60.0, 30.0]]);
        assert!(r.passed, "n = {n}: {}", describe(&r));
        for d in &r.directions {
            assert!(d.expected_accuracy < 1e-3, "n = {n}: {}", describe(&r));
            assert_eq!(d.unconverged_cells, 0);
        }
    }
}

#[test]
fn chi2_sees_a_two_percent_distortion_only_with_many_draws() {
    // The distortion adds about N E[δ²] = N a²/2 = N · 2e-4 to the statistic, against a spread of
    // sqrt(2 dof): 13 against ~44 at 2¹⁶ draws (968 cells), 3400 against ~100 at 2²⁴.
    let s = Distorted { a: 0.02 };
    let few = test(&s, 1 << 16, &[[0.0, 0.0]]);
    assert!(few.passed, "{}", describe(&few));
    let many = test(&s, 1 << 24, &[[0.0, 0.0]]);
    let d = &many.directions[0];
    assert!(
        !d.histogram_passed && d.p_value < 1e-30,
        "{}",
        describe(&many)
    );
    // The draws themselves are consistent with what the sampler claims: only the histogram fails.
    assert!(
        d.outside_passed && d.draws.consistent(),
        "{}",
        describe(&many)
    );
    // Where observed and expected part most: near φ = 0, 90, 180 or 270°, where cos 2φ = ±1.
    let w = d.worst_cell.as_ref().unwrap();
    let centre = 0.5 * (w.phi_deg[0] + w.phi_deg[1]);
    let off = (centre % 90.0).min(90.0 - centre % 90.0);
    assert!(w.sigma.abs() > 4.0 && off < 20.0, "worst cell {w:?}");
}

#[test]
fn chi2_rejects_a_pdf_missing_its_cosine() {
    // Cosine draws, pdf claimed 1/π (weights consistent with the claim): ∫ pdf = 2.
    let s = Cosine {
        flat: true,
        ..COSINE
    };
    let r = test(&s, 1 << 16, &[[30.0, 0.0]]);
    let d = &r.directions[0];
    assert!(
        !r.passed && !d.histogram_passed && !d.outside_passed,
        "{}",
        describe(&r)
    );
    assert!((d.integral - 2.0).abs() < 1e-12 && (d.missing_mass + 1.0).abs() < 1e-12);
    assert!(d.draws.consistent(), "{}", describe(&r));
}

#[test]
fn chi2_leak_equals_one_minus_the_integral() {
    // A broad lobe about the mirror direction at θo = 80°: a sizeable share is drawn below the
    // horizon.
    let r = test(&PowerCosine { n: 4.0 }, 1 << 20, &[[80.0, 0.0]]);
    let d = &r.directions[0];
    assert!(r.passed, "{}", describe(&r));
    let n = r.options.samples as f64;
    let sigma = (d.missing_mass * (1.0 - d.missing_mass) / n).sqrt();
    assert!(d.missing_mass > 0.1, "missing {}", d.missing_mass);
    assert!(
        (d.leak_share - d.missing_mass).abs() < 5.0 * sigma,
        "leak {} vs 1 − ∫pdf {} (σ {sigma:e})",
        d.leak_share,
        d.missing_mass
    );
    assert_eq!(d.draws.nonzero_weight_outside, 0);
    // The same draws reported below the horizon with a pdf (the contract asks for 0).
    struct PdfBelow(PowerCosine);
    impl Sampler for PdfBelow {
        fn sample(&self, wo: DVec3, uc: f64, u: DVec2) -> Drawn {
            let d = self.0.sample(wo, uc, u);
            let pdf = if d.wi.z <= 0.0 { 0.5 } else { d.pdf };
            Drawn { pdf, ..d }
        }
        fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
            self.0.pdf(wi, wo)
        }
        fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3 {
            self.0.eval_cos(wi, wo)
        }
    }
    let r = test(&PdfBelow(PowerCosine { n: 4.0 }), 1 << 20, &[[80.0, 0.0]]);
    let e = &r.directions[0];
    assert!(
        e.histogram_passed && e.outside_passed && !e.passed,
        "{}",
        describe(&r)
    );
    assert_eq!((e.draws.nonzero_pdf_below, e.leaked), (d.leaked, d.leaked));
}

#[test]
fn chi2_counts_delta_draws_apart_and_catches_lost_draws() {
    let r = test(
        &WithMirror {
            mirror: 0.3,
            lost: 0.0,
        },
        1 << 20,
        &[[45.0, 0.0]],
    );
    let d = &r.directions[0];
    assert!(r.passed, "{}", describe(&r));
    assert!((d.delta_share - 0.3).abs() < 5.0 * (0.21f64 / (1u64 << 20) as f64).sqrt());
    assert!((d.missing_mass - 0.3).abs() < 1e-12);
    // One draw in 100 thrown away without the pdf saying so: the outside share is off by
    // 10⁴ draws against a spread of ~470.
    let r = test(
        &WithMirror {
            mirror: 0.3,
            lost: 0.01,
        },
        1 << 20,
        &[[45.0, 0.0]],
    );
    let d = &r.directions[0];
    assert!(!d.outside_passed && !r.passed, "{}", describe(&r));
    assert_eq!(d.draws.zero_pdf, d.leaked);
}

#[test]
fn chi2_rejects_draws_where_the_pdf_is_zero() {
    let r = test(&Blind, 1 << 16, &[[0.0, 0.0]]);
    let d = &r.directions[0];
    assert!(
        d.statistic.draws_where_none_expected.is_some(),
        "{}",
        describe(&r)
    );
    assert!(!d.histogram_passed && d.p_value == 0.0);
    assert!(d.worst_cell.as_ref().unwrap().sigma.is_infinite());
    assert!(
        d.failures[0].contains("integrates to 0"),
        "{:?}",
        d.failures
    );
}

#[test]
fn chi2_reports_weight_and_pdf_mismatches() {
    let r = test(
        &Cosine {
            weight_scale: 1.01,
            ..COSINE
        },
        1 << 16,
        &[[0.0, 0.0]],
    );
    let d = &r.directions[0];
    assert!(d.histogram_passed && !d.passed, "{}", describe(&r));
    assert!(
        (d.draws.max_weight_error - 0.01 / 1.01).abs() < 1e-12,
        "{:?}",
        d.draws
    );
    assert!(d.draws.worst_weight_draw.is_some() && d.draws.max_pdf_error == 0.0);
    // A drawn pdf 0.1 % off the pdf function (an unmatched Jacobian would be far more).
    let r = test(
        &Cosine {
            drawn_pdf_scale: 1.001,
            ..COSINE
        },
        1 << 16,
        &[[0.0, 0.0]],
    );
    let d = &r.directions[0];
    assert!(!d.passed, "{}", describe(&r));
    assert!(
        (d.draws.max_pdf_error - 0.001 / 1.001).abs() < 1e-12,
        "{:?}",
        d.draws
    );
}

/// Only the first `checked_draws` draws have their weight and pdf checked; the histogram and the
/// other checks keep every draw.
#[test]
fn chi2_checks_weights_on_the_first_checked_draws() {
    let bad = Cosine {
        weight_scale: 1.01,
        ..COSINE
    };
    let with = |checked: Option<u64>| {
        let o = Options {
            checked_draws: checked,
            ..options(1 << 16, &[[0.0, 0.0]])
        };
        run(&bad, &o, None, |_, _| {}).expect("the test runs")
    };
    let some = with(Some(1000));
    let d = &some.directions[0];
    assert_eq!(d.draws.checked_draws, 1000);
    assert!(d.draws.worst_weight_draw.is_some_and(|i| i < 1000));
    assert!(!d.passed, "{}", describe(&some));
    let all = with(None);
    assert_eq!(all.directions[0].draws.checked_draws, 1 << 16);
    assert_eq!(all.directions[0].observed, d.observed);
    // None checked: the weight goes unseen, and the histogram is the same.
    let none = with(Some(0));
    let d0 = &none.directions[0];
    assert!(
        d0.passed && d0.draws.max_weight_error == 0.0,
        "{}",
        describe(&none)
    );
    assert_eq!(d0.draws.checked_draws, 0);
    assert_eq!(d0.observed, d.observed);
    // More than the draws: every draw.
    assert_eq!(
        with(Some(1 << 20)).directions[0].draws.checked_draws,
        1 << 16
    );
}

#[test]
fn chi2_draws_do_not_depend_on_the_thread_count() {
    let opts = options(1 << 18, &[[20.0, 10.0]]);
    let run_in = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&PowerCosine { n: 50.0 }, &opts, None, |_, _| {}).unwrap())
    };
    let (one, two) = (run_in(1), run_in(3));
    let (a, b) = (&one.directions[0], &two.directions[0]);
    assert_eq!(a.observed, b.observed);
    assert_eq!(a.expected, b.expected);
    assert_eq!(a.draws, b.draws);
}

#[test]
fn chi2_stops_when_cancelled_and_reports_progress() {
    let token = CancelToken::new();
    token.cancel();
    let r = run(
        &COSINE,
        &options(1 << 20, &[[0.0, 0.0]]),
        Some(&token),
        |_, _| {},
    );
    assert!(matches!(r, Err(Error::Cancelled(_))), "{r:?}");
    let mut calls = Vec::new();
    let samples = (1 << 22) + 5;
    run(
        &COSINE,
        &options(samples, &[[0.0, 0.0], [10.0, 0.0]]),
        None,
        |d, t| calls.push((d, t)),
    )
    .unwrap();
    assert!(calls.windows(2).all(|w| w[0].0 < w[1].0), "{calls:?}");
    assert_eq!(calls.last(), Some(&(2 * samples, 2 * samples)));
}

#[test]
fn chi2_refuses_bad_options() {
    for bad in [
        options(0, &[[0.0, 0.0]]),
        options(10, &[]),
        options(10, &[[90.0, 0.0]]),
        options(10, &[[f64::NAN, 0.0]]),
        Options {
            significance: 0.0,
            ..options(10, &[[0.0, 0.0]])
        },
        Options {
            cells: Some(Cells { n_phi: 0, n_cos: 4 }),
            ..options(10, &[[0.0, 0.0]])
        },
    ] {
        let r = run(&COSINE, &bad, None, |_, _| {});
        assert!(matches!(r, Err(Error::Invalid(_))), "{bad:?}: {r:?}");
    }
}

#[test]
fn chi2_report_serialises() {
    let r = test(&COSINE, 1 << 12, &[[0.0, 0.0]]);
    let j = r.to_json();
    assert_eq!(
        j["directions"][0]["observed"].as_array().unwrap().len(),
        r.directions[0].cells.len()
    );
    assert_eq!(j["passed"], serde_json::json!(r.passed));
    assert!(j["directions"][0]["statistic"]["dof"].is_u64());
}

#[test]
fn chi2_p_values_of_a_correct_sampler_are_uniform() {
    // 100 independent runs (seeds) of a correct sampler with a non-trivial pdf, small enough that
    // pooling matters (242 cells, the lobe's tails below 5 draws): their p-values must look
    // uniform, by Kolmogorov–Smirnov at the 0.1 % level (D < 1.95/sqrt(100)). A statistic off
    // in its pooling, degrees of freedom or expected counts skews them.
    let runs = 100;
    let mut p: Vec<f64> = (0..runs)
        .map(|seed| {
            let opts = Options {
                seed,
                ..options(1 << 14, &[[45.0, 0.0]])
            };
            run(&PowerCosine { n: 20.0 }, &opts, None, |_, _| {})
                .unwrap()
                .directions[0]
                .p_value
        })
        .collect();
    p.sort_by(f64::total_cmp);
    let d = p
        .iter()
        .enumerate()
        .map(|(i, &x)| (x - i as f64 / runs as f64).max((i + 1) as f64 / runs as f64 - x))
        .fold(0.0, f64::max);
    assert!(
        d < 1.95 / (runs as f64).sqrt(),
        "KS distance {d}, p-values {p:?}"
    );
}
