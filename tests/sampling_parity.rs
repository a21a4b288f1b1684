//! The GPU twin of every built-in model's sampler draws what the f64 reference draws: the same
//! seed, group and index give the same numbers (`random::draw_numbers` and its GLSL twin), and
//! the f32 samplers of `glsl/brdf/` turn them into the same ωi, pdf, weight and delta flag
//! within f32 rounding (docs/design.md §13). The draws kernel's own density and f cos θi at the
//! drawn ωi are checked against the reference's at that ωi.

mod common;

use glam::DVec3;
use lobe::backend::{Backend, CpuBackend, DrawRange, DrawRecord, Query};
use lobe::gpu::Gpu;
use lobe::model::microfacet::MicrofacetConfig;
use lobe::model::{Model, ParamSet, Reference};
use lobe::random;

/// Draws per (parameter set, θo): the brief's 4096.
const DRAWS: usize = 4096;
/// The stream's seed (any; fixed so that a failure reproduces).
const SEED: u32 = 0x5eed_0013;
/// Draws `first .. first + count` of the stream (`seed`, `group`).
fn range(seed: u32, group: u32, first: u64, count: usize) -> DrawRange {
    DrawRange {
        seed,
        group,
        first,
        count,
    }
}

/// Polar angles of ωo, degrees: normal, oblique, grazing.
const THETAS: [f64; 3] = [0.0, 45.0, 85.0];
/// Azimuth of ωo, degrees: off both axes, so that anisotropic lobes see both roughnesses.
const PHI: f64 = 30.0;

/// |ωi_gpu − ωi_cpu| per component allowed. An f32 sampler rounds its 10–30 operations at 2⁻²⁴
/// each, and GLSL's sin, cos, atan, exp and log add a few ulp more (the Vulkan spec allows
/// cos and sin 2⁻¹¹ absolute; lavapipe and the GPUs measured here stay near 1e-7), amplified
/// where a direction is steep in its numbers: the Beckmann slopes' inversion near its support's
/// end and a stretched GGX normal at grazing ωo. Measured largest on lavapipe: 1.6e-5
/// (docs/design.md §13); 2e-4 leaves room for a GPU's sin and cos (NVIDIA's measure about
/// 2⁻²¹ absolute) while a wrong formula (a swapped axis, a missing stretch,
/// another index's numbers) moves ωi by 1e-2 or more.
const WI_TOL: f64 = 2e-4;

/// Relative difference allowed in pdf, weight, pdf_at and f cos θi, beyond what the cosine
/// factor's own difference 2 |Δωi.z| / ωi.z explains (a draw just above the horizon). They are
/// f32 evaluations at directions that differ by up to WI_TOL: a lobe cosⁿ moves by n sin α δα,
/// about √n δα where most draws land (sin α ~ 1/√n); f32 rounding of the density's own terms
/// (EON's transformed cosine, |w|⁴ over det²) adds a few 1e-4 (measured: docs/design.md §13).
/// 2e-3 leaves a margin and still catches a missing Jacobian (a factor 4 ωo·h), a wrong
/// mixture weight or a density of the wrong roughness.
const REL_TOL: f64 = 2e-3;

/// Half-width of the band about a mixture's component boundary P where the two sides may choose
/// differently: P is an f32 on the GPU (the host's f64 rounded, 2⁻²⁴ relative, or computed there
/// from f32 terms: a Fresnel factor, the Kulla–Conty table's f32 interpolation, EON's pow(r, 0.1),
/// a few ulp to 1e-6), and a draw whose uc lies within that of P switches components on one
/// side only. 1e-5 covers them with a margin.
const UC_SLACK: f64 = 1e-5;

/// Draws per (set, θo) allowed to choose another component within UC_SLACK of a boundary: uc
/// falls in a band of width 2 UC_SLACK about each boundary with probability 2e-5, so 4096 draws
/// expect 0.08 there (models have one boundary); 3 would happen by chance with probability
/// about 1e-4 per direction.
const MAX_SWITCHED: usize = 3;

/// Draws per (set, θo) allowed to differ in whether they are lost, with |ωi.z| ≤ WI_TOL (the
/// two sides round a direction on the horizon to either side of it): a band of that width holds
/// about WI_TOL of the draws of a lobe that crosses the horizon, 0.8 of 4096.
const MAX_HORIZON: usize = 4;

fn direction(theta: f64, phi: f64) -> DVec3 {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// A parameter set of `model` with `assignments` (`key=value`, as `--set` takes them).
fn set(model: &str, assignments: &[&str]) -> ParamSet {
    let mut p = ParamSet::for_model(model).unwrap_or_else(|e| panic!("{model}: {e}"));
    for a in assignments {
        p.set_text(a).unwrap_or_else(|e| panic!("{model} {a}: {e}"));
    }
    p
}

/// (what the failure names, the set, the white furnace) for every built-in model: defaults and
/// rough and smooth sets, the layered models' spikes strong and weak, the anisotropic
/// microfacet lobe, every masking and Fresnel choice and both distributions, with and without
/// the Kulla–Conty lobe, and white-furnace configurations.
fn cases() -> Vec<(String, ParamSet, bool)> {
    let mut out = Vec::new();
    let mut add = |model: &str, sets: &[&[&str]], white: bool| {
        for s in sets {
            out.push((format!("{model} {}", s.join(" ")), set(model, s), white));
        }
    };
    add("lambert", &[&[], &["albedo=0.3"]], false);
    add("oren_nayar", &[&[], &["sigma=1"]], false);
    for ms in ["exact", "approx", "none"] {
        let m = format!("multiscatter={ms}");
        add(
            "eon",
            &[
                &[&m],
                &[&m, "roughness=1", "albedo=1"],
                &[&m, "roughness=0.05"],
            ],
            false,
        );
    }
    add(
        "phong",
        &[
            &[],
            &["shininess=20"],
            &["diffuse=0.1", "specular=0.9", "shininess=1e4"],
            &["diffuse=0", "specular=1", "shininess=2"],
        ],
        false,
    );
    add(
        "blinn_phong",
        &[
            &[],
            &["diffuse=0.1", "specular=0.9", "smoothness=0.05"],
            &["diffuse=0", "specular=1", "smoothness=0.9"],
        ],
        false,
    );
    add(
        "ashikhmin_shirley",
        &[&[], &["nu=10", "nv=1000", "specular=0.5"]],
        false,
    );
    add(
        "ashikhmin_shirley",
        &[&["diffuse=0.2", "nu=1e4", "nv=1e4"]],
        true,
    );
    add(
        "cook_torrance",
        &[&[], &["roughness=0.05"], &["roughness=0.7"]],
        false,
    );
    add("cook_torrance", &[&["roughness=0.3"]], true);
    add(
        "smooth_layered",
        &[&[], &["diffuse=0.1", "ior=3"], &["diffuse=0.9", "ior=1.05"]],
        false,
    );
    add(
        "coupled",
        &[&[], &["matte=1", "ior=3"], &["matte=0.2", "ior=1.2"]],
        false,
    );
    let lobes: &[&[&str]] = &[
        &[],
        &["alpha=0.05"],
        &["alpha=0.8"],
        &["alpha_x=0.6", "alpha_y=0.1"],
    ];
    for distribution in ["ggx", "beckmann"] {
        for masking in ["v_cavity", "smith_separable", "smith_correlated"] {
            for fresnel in ["none", "schlick", "dielectric", "conductor"] {
                let choice = [
                    format!("distribution={distribution}"),
                    format!("masking={masking}"),
                    format!("fresnel={fresnel}"),
                ];
                // Every lobe for Schlick's Fresnel (the default), the anisotropic one for
                // the others: each choice at least once, the roughness range once per masking.
                let sets: Vec<&[&str]> = if fresnel == "schlick" {
                    lobes.to_vec()
                } else {
                    vec![lobes[3]]
                };
                for s in sets {
                    let mut a: Vec<&str> = choice.iter().map(String::as_str).collect();
                    a.extend_from_slice(s);
                    out.push((
                        format!("microfacet {}", a.join(" ")),
                        set("microfacet", &a),
                        false,
                    ));
                }
            }
        }
    }
    for (extra, white) in [
        (
            &[
                "distribution=ggx",
                "multiscatter=kulla_conty",
                "alpha=0.6",
                "diffuse=0.1",
            ][..],
            false,
        ),
        (
            &[
                "distribution=ggx",
                "multiscatter=kulla_conty",
                "alpha=0.6",
                "diffuse=0.1",
            ],
            true,
        ),
        (
            &[
                "distribution=beckmann",
                "multiscatter=kulla_conty",
                "alpha=0.4",
            ],
            false,
        ),
        (
            &[
                "distribution=beckmann",
                "beckmann_g1=rational",
                "alpha_x=0.2",
                "alpha_y=0.5",
            ],
            false,
        ),
        (
            &["distribution=ggx", "fresnel=conductor", "alpha=0.3"],
            true,
        ),
    ] {
        out.push((
            format!(
                "microfacet {}{}",
                extra.join(" "),
                if white { " (white furnace)" } else { "" }
            ),
            set("microfacet", extra),
            white,
        ));
    }
    out
}

/// |a − b| relative to the larger magnitude (0 where both are 0).
fn rel(a: f64, b: f64) -> f64 {
    let m = a.abs().max(b.abs());
    if m == 0.0 {
        0.0
    } else {
        (a - b).abs() / m
    }
}

fn max_rel3(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| rel(a[k], b[k])).fold(0.0, f64::max)
}

fn max_abs3(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max)
}

fn lost(d: &DrawRecord) -> bool {
    !d.delta && d.pdf == 0.0
}

/// The largest differences seen over every case, for the report.
#[derive(Default)]
struct Largest {
    wi: (f64, String),
    pdf: (f64, String),
    weight: (f64, String),
    pdf_at: (f64, String),
    eval_cos: (f64, String),
    switched: usize,
    horizon: usize,
}

fn keep(slot: &mut (f64, String), value: f64, what: impl FnOnce() -> String) {
    if value > slot.0 {
        *slot = (value, what());
    }
}

/// Whether the CPU draws `gpu`'s direction with uc moved by ±UC_SLACK (the draw sits at a
/// component boundary that the two sides place a rounding apart).
fn switched_at_boundary(r: &Reference, wo: DVec3, i: u64, group: u32, gpu: &DrawRecord) -> bool {
    let (uc, u) = random::draw_numbers(SEED, i, group);
    [uc - UC_SLACK, uc + UC_SLACK].into_iter().any(|c| {
        let s = r.sample(wo, c.clamp(0.0, 1.0 - random::RESOLUTION), u);
        s.delta == gpu.delta && max_abs3(s.wi.to_array(), gpu.wi) <= WI_TOL
    })
}

/// Compares the GPU's draws with the CPU's for one case at one θo; failures are sentences.
#[allow(clippy::too_many_arguments)]
fn compare(
    name: &str,
    p: &ParamSet,
    white: bool,
    theta: f64,
    group: u32,
    cpu: &[DrawRecord],
    gpu: &[DrawRecord],
    largest: &mut Largest,
    failures: &mut Vec<String>,
) {
    let wo = direction(theta, PHI);
    let r = Reference::new(p, white);
    let at = |i: usize| format!("{name} θo={theta}° draw {i}");
    let (mut switched, mut horizon) = (0usize, 0usize);
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        let d_wi = max_abs3(c.wi, g.wi);
        if d_wi > WI_TOL || c.delta != g.delta {
            if switched_at_boundary(&r, wo, i as u64, group, g) {
                switched += 1;
                continue;
            }
            failures.push(format!(
                "{}: ωi cpu {:?} gpu {:?} (|Δ| {d_wi:.3e} > {WI_TOL:e}), delta cpu {} gpu {}",
                at(i),
                c.wi,
                g.wi,
                c.delta,
                g.delta
            ));
            continue;
        }
        keep(&mut largest.wi, d_wi, || at(i));
        if lost(c) != lost(g) {
            if c.wi[2].abs() <= WI_TOL {
                horizon += 1;
                continue;
            }
            failures.push(format!(
                "{}: lost on one side only (cpu pdf {}, gpu pdf {}), ωi {:?}",
                at(i),
                c.pdf,
                g.pdf,
                c.wi
            ));
            continue;
        }
        // The factor cos θi of weight (and of a cosine lobe's pdf) carries the two sides'
        // difference in ωi.z relative to ωi.z: a few percent for a draw 1e-5 above the horizon.
        let z = c.wi[2].abs().min(g.wi[2].abs());
        let cosine = if z > 0.0 {
            2.0 * (c.wi[2] - g.wi[2]).abs() / z
        } else {
            0.0
        };
        let checks = [
            ("pdf", rel(c.pdf, g.pdf), &mut largest.pdf),
            ("weight", max_rel3(c.weight, g.weight), &mut largest.weight),
        ];
        for (what, e, slot) in checks {
            let e = (e - cosine).max(0.0);
            keep(slot, e, || at(i));
            if e > REL_TOL {
                failures.push(format!(
                    "{}: {what} cpu {:?} gpu {:?}: relative {e:.3e} > {REL_TOL:e} (ωi {:?})",
                    at(i),
                    (c.pdf, c.weight),
                    (g.pdf, g.weight),
                    g.wi
                ));
            }
        }
        // The kernel's own density and f cos θi at its ωi, against the reference's at that ωi.
        let wi = DVec3::from_array(g.wi).normalize();
        let pdf_at = r.pdf(wi, wo);
        let eval_cos = (r.eval(wi, wo) * wi.z.max(0.0)).to_array();
        let e_pdf = rel(pdf_at, g.pdf_at);
        let e_eval = max_rel3(eval_cos, g.eval_cos);
        keep(&mut largest.pdf_at, e_pdf, || at(i));
        keep(&mut largest.eval_cos, e_eval, || at(i));
        if e_pdf > REL_TOL || e_eval > REL_TOL {
            failures.push(format!(
                "{}: at the GPU's ωi {:?}, pdf cpu {pdf_at} gpu {} ({e_pdf:.3e}), f cos cpu \
                 {eval_cos:?} gpu {:?} ({e_eval:.3e}); allowed {REL_TOL:e}",
                at(i),
                g.wi,
                g.pdf_at,
                g.eval_cos
            ));
        }
        // The kernel's sample agrees with its own density and f: pdf = pdf_at and
        // weight = f cos / pdf, for the non-delta draws it keeps.
        if !g.delta && g.pdf > 0.0 {
            let w = g.eval_cos.map(|f| f / g.pdf);
            let e = rel(g.pdf, g.pdf_at).max(max_rel3(w, g.weight));
            if e > REL_TOL {
                failures.push(format!(
                    "{}: the GPU's sample disagrees with its own pdf_at / eval_cos: pdf {} vs \
                     {}, weight {:?} vs {w:?}",
                    at(i),
                    g.pdf,
                    g.pdf_at,
                    g.weight
                ));
            }
        }
    }
    largest.switched = largest.switched.max(switched);
    largest.horizon = largest.horizon.max(horizon);
    if switched > MAX_SWITCHED {
        failures.push(format!(
            "{name} θo={theta}°: {switched} draws chose another component within {UC_SLACK:e} \
             of a boundary; at most {MAX_SWITCHED} expected"
        ));
    }
    if horizon > MAX_HORIZON {
        failures.push(format!(
            "{name} θo={theta}°: {horizon} draws lost on one side only at the horizon; at most \
             {MAX_HORIZON} expected"
        ));
    }
}

#[test]
fn gpu_draws_equal_cpu_draws_for_every_model() {
    common::on_gpu("sampling parity", false, |gpu: &Gpu| {
        let mut failures = Vec::new();
        let mut largest = Largest::default();
        let cases = cases();
        for (name, p, white) in &cases {
            let query = Query::one(p).with_white_furnace(*white);
            for (k, &theta) in THETAS.iter().enumerate() {
                let wo = direction(theta, PHI);
                // One group per θo, and draws from an index past 2³² for the last, so that
                // the index's high word is exercised.
                let group = k as u32;
                let first = if k == 2 { (1u64 << 32) - 1000 } else { 0 };
                let cpu = CpuBackend
                    .draws(query, wo, range(SEED, group, first, DRAWS), None)
                    .unwrap_or_else(|e| panic!("{name}: cpu draws: {e}"));
                let gpu_draws = gpu
                    .draws(query, wo, range(SEED, group, first, DRAWS), None)
                    .unwrap_or_else(|e| panic!("{name}: gpu draws: {e:#}"));
                assert_eq!(gpu_draws.len(), DRAWS, "{name}");
                let before = failures.len();
                compare(
                    name,
                    p,
                    *white,
                    theta,
                    group,
                    &cpu,
                    &gpu_draws,
                    &mut largest,
                    &mut failures,
                );
                failures.truncate(before + 5); // the first few of each case tell the story
            }
        }
        eprintln!(
            "sampling parity on {} over {} cases × {} θo × {DRAWS} draws:\n  \
             ωi {:.3e} ({})\n  pdf {:.3e} ({})\n  weight {:.3e} ({})\n  pdf_at {:.3e} ({})\n  \
             eval_cos {:.3e} ({})\n  most boundary switches in one direction {}, most horizon \
             draws {}",
            gpu.device().name(),
            cases.len(),
            THETAS.len(),
            largest.wi.0,
            largest.wi.1,
            largest.pdf.0,
            largest.pdf.1,
            largest.weight.0,
            largest.weight.1,
            largest.pdf_at.0,
            largest.pdf_at.1,
            largest.eval_cos.0,
            largest.eval_cos.1,
            largest.switched,
            largest.horizon
        );
        assert!(
            failures.is_empty(),
            "{} failures:\n{}",
            failures.len(),
            failures.join("\n")
        );
    });
}

/// Densities below this are not compared: their f32 evaluation nears the end of f32's exponent
/// range (1.2e-38) in its intermediate products (a Beckmann exp(−tan²θ/α²) far in its tail),
/// where relative precision is lost; no cell of the sampling test at 2⁴⁰ draws expects a draw
/// of a density this small over a cell's solid angle (1e-30 · 2⁴⁰ · 1.3e-3 ≈ 1e-21).
const TINY_PDF: f64 = 1e-30;

/// The kernels' density (`Backend::pdf`, the pairs kernel's `pdf_at`) equals the f64
/// reference's at the same directions, for every model: over a grid of the hemisphere and at
/// the reference's own draws (where the density is largest and steepest). This is the density
/// the sampling test integrates for a `.brdf` file's sampler; here it is checked against the
/// reference for the models that have one.
#[test]
fn gpu_density_equals_cpu_density_for_every_model() {
    common::on_gpu("density parity", false, |gpu: &Gpu| {
        let grid: Vec<DVec3> = (0..12)
            .flat_map(|i| (0..24).map(move |j| (i, j)))
            .map(|(i, j)| {
                let mu = (i as f64 + 0.5) / 12.0;
                let phi = (j as f64 + 0.5) / 24.0 * 2.0 * std::f64::consts::PI;
                let s = (1.0 - mu * mu).sqrt();
                DVec3::new(s * phi.cos(), s * phi.sin(), mu)
            })
            .collect();
        let (mut failures, mut largest, mut compared) = (Vec::new(), (0.0f64, String::new()), 0);
        for (name, p, white) in &cases() {
            let query = Query::one(p).with_white_furnace(*white);
            for &theta in &THETAS {
                let wo = direction(theta, PHI);
                let draws = CpuBackend
                    .draws(query, wo, range(SEED, 0, 0, 512), None)
                    .unwrap_or_else(|e| panic!("{name}: cpu draws: {e}"));
                let wi: Vec<DVec3> = grid
                    .iter()
                    .copied()
                    .chain(draws.iter().filter(|d| !d.delta).map(|d| DVec3::from(d.wi)))
                    // A direction within f32 rounding of the horizon may land on either side.
                    .filter(|w| w.z.abs() > WI_TOL)
                    .collect();
                let pairs: Vec<(DVec3, DVec3)> = wi.iter().map(|&w| (w, wo)).collect();
                let cpu = CpuBackend.pdf(query, &pairs).unwrap();
                let gpu_pdf = gpu
                    .pdf(query, &pairs)
                    .unwrap_or_else(|e| panic!("{name}: gpu pdf: {e:#}"));
                assert_eq!(gpu_pdf.len(), wi.len(), "{name}");
                for ((w, c), g) in wi.iter().zip(&cpu).zip(&gpu_pdf) {
                    if c.abs().max(g.abs()) < TINY_PDF {
                        continue;
                    }
                    compared += 1;
                    let e = rel(*c, *g);
                    let at = || format!("{name}, θo {theta}, ωi {w:?}: cpu {c:e}, gpu {g:e}");
                    if e > largest.0 {
                        largest = (e, at());
                    }
                    if !(e <= REL_TOL) && failures.len() < 10 {
                        failures.push(format!("{} ({e:.2e})", at()));
                    }
                }
            }
        }
        eprintln!(
            "density parity on {}: {compared} densities, largest relative difference {:.3e} ({})",
            gpu.device().name(),
            largest.0,
            largest.1
        );
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    });
}

/// The draws are counter-based on the GPU too: a range drawn in two requests equals the same
/// range drawn in one, and the chunking of a request does not show.
#[test]
fn gpu_draws_do_not_depend_on_the_request_split() {
    common::on_gpu("sampling split", false, |gpu: &Gpu| {
        let p = set("microfacet", &["alpha_x=0.3", "alpha_y=0.1"]);
        let wo = direction(40.0, PHI);
        let q = Query::one(&p);
        let whole = gpu.draws(q, wo, range(7, 3, 100, 3000), None).unwrap();
        let a = gpu.draws(q, wo, range(7, 3, 100, 1234), None).unwrap();
        let b = gpu.draws(q, wo, range(7, 3, 1334, 1766), None).unwrap();
        assert_eq!(whole, [a, b].concat());
    });
}

/// Every built-in model has the draws kernel (no model is left to the CPU).
#[test]
fn every_built_in_model_has_a_draws_kernel() {
    for model in Model::ALL {
        for m in model.variants() {
            assert!(
                m.spirv("sample").is_some(),
                "{} has no sample kernel",
                m.label()
            );
        }
    }
    for c in MicrofacetConfig::all() {
        assert!(Model::Microfacet(c).spirv("sample").is_some());
    }
}

/// A measured BRDF (a MERL file, here Cook–Torrance's gold written on the CPU) is drawn by its
/// tabulated sampler on both sides (the same f32 tables, so the same cells), with the same checks
/// as a built-in model, under both lookups (the same draws, other weights).
#[test]
fn gpu_draws_equal_cpu_draws_for_a_merl_file() {
    common::on_gpu("sampling parity, MERL", false, |gpu: &Gpu| {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("sampled_gold.binary");
        let gold = lobe::resolve_params("cook_torrance", Some("gold"), &[]).expect("gold");
        lobe::Session::cpu()
            .write_merl(&gold, &path, &mut |_, _| {})
            .expect("a MERL file");
        let model = lobe::merl::model::load(&path).expect("the MERL file").model;
        let nearest = ParamSet::defaults(model);
        let trilinear = nearest.clone().with_choice("lookup", "trilinear").unwrap();
        let (mut failures, mut largest) = (Vec::new(), Largest::default());
        for (p, (k, &theta)) in [&nearest, &trilinear]
            .into_iter()
            .flat_map(|p| THETAS.iter().enumerate().map(move |t| (p, t)))
        {
            let wo = direction(theta, PHI);
            let q = Query::one(p);
            let cpu = CpuBackend
                .draws(q, wo, range(SEED, k as u32, 0, DRAWS), None)
                .unwrap();
            let g = gpu
                .draws(q, wo, range(SEED, k as u32, 0, DRAWS), None)
                .unwrap();
            compare(
                "merl gold",
                p,
                false,
                theta,
                k as u32,
                &cpu,
                &g,
                &mut largest,
                &mut failures,
            );
        }
        eprintln!(
            "MERL draws: ωi {:.3e}, pdf {:.3e}, weight {:.3e}, eval_cos {:.3e}",
            largest.wi.0, largest.pdf.0, largest.weight.0, largest.eval_cos.0
        );
        failures.truncate(10);
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    });
}

/// A `.brdf` file's shader has no f64 twin, so the CPU backend cannot draw it; its GPU draws
/// are the cosine's (the draws kernel's fallback sampler) and must equal the reference's
/// cosine draws in ωi and pdf, and agree with the kernel's own f cos θi.
#[test]
fn a_brdf_file_is_drawn_by_the_cosine_on_the_gpu() {
    common::on_gpu("sampling parity, .brdf", false, |gpu: &Gpu| {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("sampled_lobe.brdf");
        let text = "analytic\n::begin parameters\nfloat a 0 1 0.5\n::end parameters\n\
                    ::begin shader\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {\n\
                    vec3 r = reflect(-L, N);\n\
                    return vec3(0.1) + vec3(a) * pow(max(dot(r, V), 0.0), 10.0);\n}\n\
                    ::end shader\n";
        std::fs::write(&path, text).unwrap();
        let model = lobe::brdf::load(&path, &lobe::brdf::LoadOptions::default())
            .unwrap_or_else(|e| panic!("{e}"))
            .model;
        let p = ParamSet::defaults(model);
        let r = Reference::new(&p, false);
        let mut worst = 0.0f64;
        for (k, &theta) in THETAS.iter().enumerate() {
            let wo = direction(theta, PHI);
            let g = gpu
                .draws(Query::one(&p), wo, range(SEED, k as u32, 0, DRAWS), None)
                .unwrap();
            for (i, d) in g.iter().enumerate() {
                let (uc, u) = random::draw_numbers(SEED, i as u64, k as u32);
                let s = r.sample(wo, uc, u);
                let e = max_abs3(s.wi.to_array(), d.wi);
                worst = worst.max(e);
                assert!(
                    e <= WI_TOL,
                    "θo={theta}° draw {i}: ωi {:?} vs {:?}",
                    s.wi,
                    d.wi
                );
                assert!(
                    rel(s.pdf, d.pdf) <= REL_TOL,
                    "θo={theta}° draw {i}: pdf {} vs {}",
                    s.pdf,
                    d.pdf
                );
                assert!(!d.delta && rel(d.pdf, d.pdf_at) <= REL_TOL);
                let w = d.eval_cos.map(|f| f / d.pdf);
                assert!(
                    max_rel3(w, d.weight) <= REL_TOL,
                    "draw {i}: weight {:?} vs {w:?}",
                    d.weight
                );
            }
        }
        eprintln!(".brdf draws: ωi {worst:.3e}");
    });
}

/// The test of the boundary rule: a draw whose uc lies within UC_SLACK of Phong's component
/// boundary P, drawn on the other side of P, is recognised as a boundary switch; the same draw
/// against another draw's numbers is not.
#[test]
fn a_switch_at_a_component_boundary_is_recognised() {
    use lobe::model::phong::{phong_lobe_probability, Phong};
    let p = set("phong", &["shininess=20"]);
    let prob = phong_lobe_probability(&Phong::new(&p));
    let r = Reference::new(&p, false);
    let wo = direction(45.0, PHI);
    // uc is uniform on multiples of 2⁻²⁴: one draw in 1e5 falls within UC_SLACK/2 of P.
    let i = (0..10_000_000u64)
        .find(|&i| (random::draw_numbers(SEED, i, 0).0 - prob).abs() < 0.5 * UC_SLACK)
        .expect("a draw next to the boundary");
    let (uc, u) = random::draw_numbers(SEED, i, 0);
    // The other side of P, as a GPU whose P rounds past uc would draw it.
    let other = if uc < prob {
        prob + 0.25 * UC_SLACK
    } else {
        prob - 0.25 * UC_SLACK
    };
    let s = r.sample(wo, other, u);
    let record = DrawRecord {
        wi: s.wi.to_array(),
        pdf: s.pdf,
        weight: s.weight.to_array(),
        delta: s.delta,
        pdf_at: s.pdf,
        eval_cos: [0.0; 3],
    };
    let own = r.sample(wo, uc, u);
    assert!(
        max_abs3(own.wi.to_array(), record.wi) > WI_TOL,
        "the two components drew the same direction"
    );
    assert!(switched_at_boundary(&r, wo, i, 0, &record));
    assert!(!switched_at_boundary(&r, wo, i + 1, 0, &record));
}

/// Through the `Evaluator`, a set cancellation token stops the draws on either backend before
/// the first chunk, and an unset one lets them through unchanged.
#[test]
fn draws_stop_once_cancelled() {
    common::on_gpu("sampling cancel", false, |gpu: &Gpu| {
        let p = set("phong", &[]);
        let wo = direction(30.0, PHI);
        let token = lobe::interrupt::CancelToken::new();
        let gpu_eval = lobe::Evaluator::gpu(gpu).with_cancel(&token);
        let cpu_eval = lobe::Evaluator::cpu().with_cancel(&token);
        let plain = gpu
            .draws(Query::one(&p), wo, range(1, 0, 0, 100), None)
            .unwrap();
        assert_eq!(gpu_eval.draws(&p, wo, range(1, 0, 0, 100)).unwrap(), plain);
        assert_eq!(
            cpu_eval.draws(&p, wo, range(1, 0, 0, 100)).unwrap().len(),
            100
        );
        token.cancel();
        for (name, e) in [("gpu", gpu_eval), ("cpu", cpu_eval)] {
            let err = e.draws(&p, wo, range(1, 0, 0, 100)).expect_err("cancelled");
            assert!(
                err.downcast_ref::<lobe::interrupt::Interrupted>().is_some(),
                "{name}: {err:#}"
            );
        }
    });
}
