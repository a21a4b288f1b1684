//! A `.brdf` shader's own sampler (`sampleL`, `pdfL`; docs/sampling.md): the kernels draw with
//! it, each draw's weight is BRDF · cos θi / pdfL and its density is pdfL, and the directions are
//! those of the shader's formula written here in f64 from the same numbers
//! (`random::draw_numbers`). One of the two functions without the other is refused with the
//! file and the line; a shader without them keeps the cosine.

mod common;

use glam::{DVec2, DVec3};
use lobe::backend::DrawRange;
use lobe::brdf::{self, LoadOptions};
use lobe::gpu::Gpu;
use lobe::model::ParamSet;
use lobe::Evaluator;
use std::f64::consts::PI;
use std::path::PathBuf;

/// Vulkan's precision of sin and cos is an absolute error of 2^-11 over [-π, π]; pow and the
/// normalisation add a few ulp. Each component of a drawn unit direction is within this of the
/// f64 formula from the same numbers.
const WI_ABS: f64 = 4.0 / 2048.0;

/// pow(x, n) with n = 20 in f32 (spec: 3 + 2 |n log2 x| ulp, here far below 1e-3 relative) on a
/// direction off by [`WI_ABS`]: the density near the lobe's axis changes by n · WI_ABS relative.
const PDF_REL: f64 = 20.0 * 2.0 * WI_ABS;

/// Draws compared with the twin.
const DRAWS: usize = 4096;

const HEAD: &str =
    "analytic\n::begin parameters\nfloat n 1 100 20\n::end parameters\n::begin shader\n";

/// A Phong lobe about the mirror direction R: f = (n+2)/(2π) max(0, R·L)^n, drawn exactly by
/// the power cosine about R (cos α = u1^(1/(n+1)), φ = 2π u2), pdf = (n+1)/(2π) (R·L)^n over
/// the solid angle of L.
const PHONG: &str = "const float PI = 3.14159265358979;
vec3 mirrorOf(vec3 V, vec3 N) { return 2.0 * dot(V, N) * N - V; }
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {
    return vec3((n + 2.0) / (2.0 * PI) * pow(max(0.0, dot(mirrorOf(V, N), L)), n));
}
vec3 sampleL(vec2 u, vec3 V, vec3 N, vec3 X, vec3 Y) {
    vec3 R = mirrorOf(V, N);
    float c = pow(u.x, 1.0 / (n + 1.0));
    float s = sqrt(max(0.0, 1.0 - c * c));
    float phi = 2.0 * PI * u.y;
    vec3 a = normalize(cross(vec3(0.0, 1.0, 0.0), R));
    vec3 b = cross(R, a);
    return normalize(c * R + s * (cos(phi) * a + sin(phi) * b));
}
float pdfL(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {
    return (n + 1.0) / (2.0 * PI) * pow(max(0.0, dot(mirrorOf(V, N), L)), n);
}";

/// [`PHONG`]'s sampleL in f64 (n = 20, N = +z).
fn phong_sample(u: DVec2, wo: DVec3, n: f64) -> DVec3 {
    let r = DVec3::new(-wo.x, -wo.y, wo.z);
    let c = u.x.powf(1.0 / (n + 1.0));
    let s = (1.0 - c * c).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let a = DVec3::Y.cross(r).normalize();
    let b = r.cross(a);
    (c * r + s * (phi.cos() * a + phi.sin() * b)).normalize()
}

/// [`PHONG`]'s pdfL in f64.
fn phong_pdf(wi: DVec3, wo: DVec3, n: f64) -> f64 {
    let r = DVec3::new(-wo.x, -wo.y, wo.z);
    (n + 1.0) / (2.0 * PI) * r.dot(wi).max(0.0).powf(n)
}

fn file_with(name: &str, shader: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, format!("{HEAD}{shader}\n::end shader\n")).unwrap();
    (dir, path)
}

#[test]
fn one_sampler_function_without_the_other_is_refused_with_its_line() {
    // sampleL is on the shader's line 6, the file's line 11 (the shader starts on line 6).
    let without_pdf = PHONG.split("float pdfL").next().unwrap();
    let (_d, path) = file_with("half.brdf", without_pdf);
    let e = brdf::load(&path, &LoadOptions::default())
        .err()
        .expect("a sampleL without pdfL loaded")
        .to_string();
    let at = format!("{}:11:", path.display());
    assert!(e.starts_with(&at), "{e} (expected {at})");
    assert!(e.contains("sampleL but not pdfL"), "{e}");
    let only_pdf = PHONG.replace("vec3 sampleL(", "vec3 drawL(");
    let (_d, path) = file_with("pdf_only.brdf", &only_pdf);
    let e = brdf::load(&path, &LoadOptions::default())
        .err()
        .expect("a pdfL without sampleL loaded")
        .to_string();
    assert!(e.contains("pdfL but not sampleL"), "{e}");
    assert!(e.starts_with(&format!("{}:", path.display())), "{e}");
}

#[test]
fn a_shaders_sampler_draws_as_its_f64_twin() {
    let (_d, path) = file_with("phong.brdf", PHONG);
    let model = brdf::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .model;
    let Some(dev) = common::gpu_device("brdf sampler") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let p = ParamSet::defaults(model);
    let n = 20.0;
    let (t, ph) = (35f64.to_radians(), 20f64.to_radians());
    let wo = DVec3::new(t.sin() * ph.cos(), t.sin() * ph.sin(), t.cos());
    let wo = DVec3::new(wo.x as f32 as f64, wo.y as f32 as f64, wo.z as f32 as f64);
    const SEED: u32 = 11;
    let draws = Evaluator::gpu(&gpu)
        .draws(&p, wo, DrawRange::new(SEED, DRAWS))
        .expect("draws");
    let mut kept = 0;
    for (i, d) in draws.iter().enumerate() {
        let (_, u) = lobe::random::draw_numbers(SEED, i as u64, 0);
        let want = phong_sample(u, wo, n);
        let wi = DVec3::from_array(d.wi);
        assert!(
            (wi - want).abs().max_element() <= WI_ABS,
            "draw {i}: wi {wi} vs the formula's {want}"
        );
        if want.z <= 0.01 {
            continue; // near or below the horizon: lost on one side, kept on the other
        }
        kept += 1;
        let pdf = phong_pdf(wi, wo, n);
        assert!(
            (d.pdf - pdf).abs() <= PDF_REL * pdf,
            "draw {i}: pdf {} vs pdfL's formula {pdf}",
            d.pdf
        );
        assert!(
            (d.pdf_at - d.pdf).abs() <= 1e-6 * d.pdf,
            "draw {i}: the density at wi {} vs the draw's {}",
            d.pdf_at,
            d.pdf
        );
        // f cos θi / pdf = (n+2)/(n+1) cos θi for this lobe.
        let weight = (n + 2.0) / (n + 1.0) * wi.z;
        assert!(
            (d.weight[0] - weight).abs() <= PDF_REL * weight,
            "draw {i}: weight {} vs f cos/pdf {weight}",
            d.weight[0]
        );
    }
    assert!(kept > DRAWS / 2, "only {kept} draws above the horizon");
    common::assert_validation_clean(&gpu, "brdf sampler");
}

#[test]
fn a_shader_without_a_sampler_is_drawn_by_the_cosine() {
    let bsdf = PHONG.split("vec3 sampleL").next().unwrap();
    let (_d, path) = file_with("cosine.brdf", bsdf);
    let model = brdf::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .model;
    let Some(dev) = common::gpu_device("brdf cosine") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let p = ParamSet::defaults(model);
    let draws = Evaluator::gpu(&gpu)
        .draws(&p, DVec3::Z, DrawRange::new(3, 256))
        .expect("draws");
    for d in draws.iter().filter(|d| d.pdf > 0.0) {
        // Cosine sampling: pdf = cos θi / π (f32).
        let want = d.wi[2] / PI;
        assert!(
            (d.pdf - want).abs() <= 1e-5 * want.max(1e-3),
            "pdf {} vs cos/π {want}",
            d.pdf
        );
    }
}

/// `Session::pdf` of a shader's model is its `pdfL` as the kernels evaluate it: at each drawn
/// ωi it equals the draw's own density (the same f32 function of the same f32 directions, in
/// another kernel), and it matches the f64 formula within [`PDF_REL`]; a CPU session, which has
/// no twin of the shader, refuses it naming the file.
#[test]
fn session_pdf_of_a_shader_is_its_pdfl() {
    let (_d, path) = file_with("phong.brdf", PHONG);
    let model = brdf::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .model;
    let p = ParamSet::defaults(model);
    let refused = lobe::Session::cpu()
        .pdf(&p, &[(DVec3::Z, DVec3::Z)])
        .expect_err("a CPU session evaluated a shader's pdfL")
        .to_string();
    assert!(refused.contains("phong.brdf"), "{refused}");
    let Some(session) = common::gpu_session("brdf pdf") else {
        return;
    };
    let (t, ph) = (35f64.to_radians(), 20f64.to_radians());
    let wo = DVec3::new(t.sin() * ph.cos(), t.sin() * ph.sin(), t.cos());
    let wo = DVec3::new(wo.x as f32 as f64, wo.y as f32 as f64, wo.z as f32 as f64);
    let draws = session.sample(&p, wo, DRAWS, 3).expect("draws");
    let pairs: Vec<(DVec3, DVec3)> = (0..draws.len())
        .filter(|&k| draws.pdf[k] > 0.0)
        .map(|k| (DVec3::from_array(draws.wi[k]).normalize(), wo))
        .collect();
    let pdf = session.pdf(&p, &pairs).expect("pdf");
    let kept: Vec<f64> = draws.pdf.iter().copied().filter(|&v| v > 0.0).collect();
    assert_eq!(pdf.len(), kept.len());
    for (k, ((wi, _), (got, drawn))) in pairs.iter().zip(pdf.iter().zip(&kept)).enumerate() {
        let want = phong_pdf(*wi, wo, 20.0);
        assert!(
            (got - drawn).abs() <= PDF_REL * drawn && (got - want).abs() <= PDF_REL * want,
            "pair {k}: Session::pdf {got}, the draw's {drawn}, the formula's {want}"
        );
    }
}
