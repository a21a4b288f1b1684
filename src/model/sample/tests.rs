use super::checks::*;
use super::*;

#[test]
fn frame_is_orthonormal() {
    for n in [
        DVec3::Z,
        -DVec3::Z,
        direction(40.0, 30.0),
        direction(120.0, 200.0),
        DVec3::X,
    ] {
        let (t, b) = frame(n);
        for (x, y) in [(t, b), (t, n), (b, n)] {
            assert!(x.dot(y).abs() < 1e-15, "{n}: {x} · {y}");
        }
        assert!((t.cross(b) - n).length() < 1e-15, "{n}: right-handed");
    }
}

#[test]
fn beckmann_visible_slope_inverts_its_distribution() {
    // C(x(u)) = u, to the rounding of C: the solver's own stopping rule.
    const TOL: f64 = 1e-13;
    for tan_t in [0.0, 0.1, 1.0, 20.0] {
        for u in [1e-9, 0.01, 0.3, 0.5, 0.9, 0.999_999] {
            let x = beckmann_visible_slope(tan_t, u);
            let k = tan_t / (2.0 * PI.sqrt());
            let f = |x: f64| 0.5 * libm::erfc(-x) + k * (-x * x).exp();
            let hi = if tan_t > 0.0 {
                (1.0 / tan_t).min(SLOPE_RANGE)
            } else {
                SLOPE_RANGE
            };
            let c = f(x) / f(hi);
            assert!((c - u).abs() < TOL, "tan θ {tan_t}, u {u}: x {x}, C(x) {c}");
        }
    }
}

/// The visible-normal samplers alone (no model around them): GGX in both forms and
/// Beckmann, isotropic and anisotropic, against [`pdf_vndf`].
#[test]
fn visible_normal_samplers_match_their_density() {
    let f = |_: DVec3, _: DVec3| DVec3::ONE;
    let none = |_: f64| DVec3::ZERO;
    for (dist, form) in [
        (Distribution::Ggx, "cap"),
        (Distribution::Ggx, "hemisphere"),
        (Distribution::Beckmann, "slopes"),
    ] {
        for (ax, ay) in [(0.05, 0.05), (0.8, 0.8), (0.1, 0.5)] {
            let sample = |wo: DVec3, _uc: f64, u: DVec2| {
                let h = match form {
                    "hemisphere" => sample_ggx_vndf_hemisphere(wo, ax, ay, u),
                    _ => sample_vndf(dist, wo, ax, ay, u),
                };
                let wi = reflect(wo, h);
                Sample::from_draw(wi, pdf_vndf(dist, wi, wo, ax, ay), |_| DVec3::ONE)
            };
            let pdf = |wi: DVec3, wo: DVec3| pdf_vndf(dist, wi, wo, ax, ay);
            check(&Sampler {
                name: format!("{dist:?} VNDF ({form}) αx {ax} αy {ay}"),
                sample: &sample,
                pdf: &pdf,
                f: &f,
                delta_albedo: &none,
                width: 2.0 * ax.min(ay),
            });
        }
    }
}

/// Every built-in model and component choice, with and without the white furnace, through
/// [`crate::model::Reference`]: check 2 at every angle, and nothing for ωo below the
/// horizon (weight 0, pdf 0) or density for ωi below it.
#[test]
fn every_model_samples_consistently_through_the_reference() {
    use crate::model::{Model, ParamSet, Reference};
    for model in Model::ALL.iter().flat_map(|m| m.variants()) {
        for white_furnace in [false, true] {
            let r = Reference::new(&ParamSet::defaults(model), white_furnace);
            let sample = |wo: DVec3, uc: f64, u: DVec2| r.sample(wo, uc, u);
            let pdf = |wi: DVec3, wo: DVec3| r.pdf(wi, wo);
            let f = |wi: DVec3, wo: DVec3| r.eval(wi, wo);
            let delta_albedo = |c_o: f64| r.delta_albedo(c_o);
            let s = Sampler {
                name: model.label(),
                sample: &sample,
                pdf: &pdf,
                f: &f,
                delta_albedo: &delta_albedo,
                width: 0.5,
            };
            for theta in ANGLES {
                let wo = direction(theta, 30.0);
                if let Err(e) = consistency_ok(&s, wo) {
                    panic!(
                        "{} (white furnace {white_furnace}) at θo = {theta}°: {e}",
                        s.name
                    );
                }
                let below = DVec3::new(wo.x, wo.y, -wo.z);
                assert_eq!(r.pdf(below, wo), 0.0, "{}: ωi below the horizon", s.name);
                let d = r.sample(below, 0.3, DVec2::new(0.4, 0.6));
                assert!(
                    d.pdf == 0.0 && d.weight == DVec3::ZERO && d.wi.z <= 0.0,
                    "{}: ωo below the horizon gave {d:?}",
                    s.name
                );
            }
        }
    }
}

/// A model defined at run time is drawn by the cosine: with a Phong-like reference (a lobe
/// the cosine does not follow), the checks hold and the weight is f cos θi / pdf of the
/// caller's f.
#[test]
fn a_run_time_model_samples_by_the_cosine() {
    use crate::model::params::ParamSpec;
    use crate::model::runtime::RuntimeModel;
    use crate::model::Model;
    let table = vec![ParamSpec::scalar("n", 0.0, 100.0, 10.0, "exponent")];
    let m = RuntimeModel::new("sample_runtime_twin", "a run-time lobe", table, true)
        .expect("a valid run-time model")
        .with_reference(std::sync::Arc::new(|v: &[f64], wi: DVec3, wo: DVec3| {
            DVec3::splat(pdf_power_cosine(mirror(wo), v[0], wi))
        }));
    let model = Model::Runtime(Box::leak(Box::new(m)));
    check_reference(&params(model, &["n=10"]), false, 0.8);
}

/// The test of the tests: a density without the reflection Jacobian 1/(4 ωo·h) (the
/// density of h taken for that of ωi), and a density of the wrong distribution for the
/// draws, must each fail check 1 or check 3.
#[test]
fn broken_densities_are_caught() {
    let (ax, ay) = (0.3, 0.3);
    let sample = |wo: DVec3, _uc: f64, u: DVec2| {
        let wi = reflect(wo, sample_ggx_vndf(wo, ax, ay, u));
        Sample::from_draw(wi, pdf_vndf(Distribution::Ggx, wi, wo, ax, ay), |_| {
            DVec3::ONE
        })
    };
    let no_jacobian = |wi: DVec3, wo: DVec3| {
        let h = (wi + wo).normalize();
        pdf_vndf(Distribution::Ggx, wi, wo, ax, ay) * 4.0 * wo.dot(h)
    };
    let wrong_distribution =
        |wi: DVec3, wo: DVec3| pdf_vndf(Distribution::Beckmann, wi, wo, ax, ay);
    let f = |_: DVec3, _: DVec3| DVec3::ONE;
    let none = |_: f64| DVec3::ZERO;
    for (what, pdf) in [
        ("no Jacobian", &no_jacobian as &dyn Fn(DVec3, DVec3) -> f64),
        ("Beckmann density for GGX draws", &wrong_distribution),
    ] {
        let s = Sampler {
            name: what.to_string(),
            sample: &sample,
            pdf,
            f: &f,
            delta_albedo: &none,
            width: 2.0 * ax,
        };
        for theta in ANGLES {
            let m = measure(&s, direction(theta, 30.0));
            assert!(
                integral_ok(&m).is_err() || histogram_ok(&m).is_err(),
                "{what} at θo = {theta}° passed: {m:?}"
            );
        }
    }
}

/// The test of the tests in a mixture: Blinn–Phong's density with the half-vector lobe's
/// density taken for that of ωi (no 1/(4 ωo·h)) must fail check 1 or check 3 at every angle,
/// although the cosine half of the mixture is right.
#[test]
fn a_mixture_without_its_jacobian_is_caught() {
    use crate::model::blinn_phong::{
        blinn_phong, blinn_phong_exponent, blinn_phong_lobe_probability, sample_blinn_phong,
    };
    use crate::model::{Model, ParamSet};
    let p = crate::model::blinn_phong::BlinnPhong::new(&ParamSet::defaults(Model::BlinnPhong));
    let sample = |wo: DVec3, uc: f64, u: DVec2| sample_blinn_phong(&p, wo, uc, u);
    let broken = |wi: DVec3, wo: DVec3| {
        if wi.z <= 0.0 {
            return 0.0;
        }
        let lobe = blinn_phong_lobe_probability(&p);
        let h = (wi + wo).normalize();
        let n = blinn_phong_exponent(p.smoothness);
        (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_power_cosine(DVec3::Z, n, h)
    };
    let f = |wi: DVec3, wo: DVec3| blinn_phong(&p, wi, wo);
    let none = |_: f64| DVec3::ZERO;
    let s = Sampler {
        name: "Blinn–Phong without its Jacobian".to_string(),
        sample: &sample,
        pdf: &broken,
        f: &f,
        delta_albedo: &none,
        width: 0.2,
    };
    for theta in ANGLES {
        let m = measure(&s, direction(theta, 30.0));
        assert!(
            integral_ok(&m).is_err() || histogram_ok(&m).is_err(),
            "{} at θo = {theta}° passed: {m:?}",
            s.name
        );
    }
}
