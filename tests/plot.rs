//! `lobe plot`: every kind writes a PNG of the requested pixel size or an SVG holding its title,
//! and the data each library function returns (the data it drew) says what the picture shows:
//! glossy lobes peak at the mirror direction, delta lobes are marked with their exact albedo,
//! Lambert's slice is flat and its albedo is its albedo parameter.

mod common;

use lobe::gpu::Gpu;
use lobe::model::{Model, ParamSet};
use lobe::plot::hemisphere::{HemisphereOptions, Projection};
use lobe::plot::polar::PolarOptions;
use lobe::plot::slice::{half_diff_to_pair, SliceOptions};
use lobe::plot::surface3d::Surface3dOptions;
use lobe::plot::{self, albedo_curve::AlbedoOptions, PlotSettings, Plotted, Request, Subject};
use lobe::Evaluator;
use std::path::Path;

/// A polar curve's peak lies within one view-angle step of the mirror angle: the curve is
/// sampled at cell centres 180°/samples apart, and a Phong lobe's maximum is exactly at the
/// mirror direction, so the nearest sample is at most half a step away; one full step allows
/// for f32 evaluation flattening the top of the lobe between two neighbours.
const POLAR_PEAK_TOLERANCE_STEPS: f64 = 1.0;
/// A hemisphere map's brightest cell lies within this many degrees of the mirror direction. A
/// cell of the 128-cell equal-area map spans 2/128 in disc units; dθ/dr = √2/cos(θ/2) ≤ 2, so a
/// cell spans at most 1.8° in θ, and at θ = 30° (r ≈ 0.52) 1.7° in φ. The nearest cell centre is
/// within half a diagonal: 1.3°; 2.5° leaves room for f32 ties.
const HEMISPHERE_PEAK_TOLERANCE_DEG: f64 = 2.5;
/// The 3d wireframe's rings are 89.5°/59 ≈ 1.5° apart and its meridians 3° apart; the largest
/// sample is within half of each from the mirror direction; one full spacing allows for ties.
const SURFACE_RING_TOLERANCE_DEG: f64 = 1.6;
const SURFACE_MERIDIAN_TOLERANCE_DEG: f64 = 3.1;
/// Lambert's f = albedo/π is one multiply on the GPU: a few f32 ulps.
const LAMBERT_RTOL_F32: f64 = 8.0 * f32::EPSILON as f64;
/// The peak albedo rule reaches 1e-6 relative on the smooth built-in models (tests/albedo.rs);
/// Lambert is smooth, so 1e-5 is a margin of 10 (the GPU sums f32 values in f64).
const LAMBERT_ALBEDO_RTOL: f64 = 1e-5;
/// Schlick's F at normal incidence for η = 1.5 is R0 = (0.5/2.5)² = 0.04 exactly; the delta mark
/// is computed in f64 on the host.
const DELTA_ALBEDO_ATOL: f64 = 1e-12;

fn params(model: Model, sets: &[&str]) -> ParamSet {
    let mut p = ParamSet::defaults(model);
    for s in sets {
        p.set_text(s)
            .unwrap_or_else(|e| panic!("{}: {s}: {e}", model.name()));
    }
    p
}

fn glossy_phong() -> Subject {
    Subject::new(
        params(Model::Phong, &["diffuse=0", "specular=1", "shininess=500"]),
        None,
    )
}

/// Width and height from a PNG's IHDR chunk (signature 8 bytes, length 4, "IHDR" 4, then
/// big-endian width and height).
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        bytes.len() > 24 && bytes[..8] == [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A],
        "{} is not a PNG",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR", "{}: first chunk", path.display());
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]))
}

fn run(
    e: &Evaluator,
    subjects: &[Subject],
    common: &PlotSettings,
    r: &Request,
    path: &Path,
) -> Plotted {
    plot::plot(e, subjects, common, r, path).unwrap_or_else(|err| panic!("{err:#}"))
}

/// Runs `f` with the GPU evaluator, or not at all when LOBE_SKIP_GPU=1; without a device it
/// fails, printing lobe::gpu::INSTALL_HINT (the device error carries it).
fn with_gpu(test: &str, f: impl FnOnce(&Evaluator)) {
    let Some(dev) = common::gpu_device(test) else {
        return;
    };
    let gpu = Gpu::new(dev);
    f(&Evaluator::gpu(&gpu));
    common::assert_validation_clean(&gpu, test);
}

fn check_polar_peaks(e: &Evaluator, dir: &Path, name: &str) {
    let path = dir.join(name);
    let common = PlotSettings {
        size: (900, 600),
        ..PlotSettings::default()
    };
    let opts = PolarOptions {
        theta_i_deg: vec![0.0, 30.0, 60.0, 75.0],
        ..PolarOptions::default()
    };
    let Plotted::Polar(data) = run(
        e,
        &[glossy_phong()],
        &common,
        &Request::Polar(opts.clone()),
        &path,
    ) else {
        panic!("a polar request returned another kind")
    };
    assert_eq!(png_size(&path), (900, 600));
    assert_eq!(data.series.len(), 4);
    let step = 180.0 / opts.samples as f64;
    for s in &data.series {
        let peak = s.peak_deg();
        assert!(
            (peak - s.theta_i_deg).abs() <= POLAR_PEAK_TOLERANCE_STEPS * step,
            "phong n=500 on {}: θi = {}°: the curve peaks at {peak}°, expected the mirror angle \
             {}° within {} steps of {step}°",
            e.name(),
            s.theta_i_deg,
            s.theta_i_deg,
            POLAR_PEAK_TOLERANCE_STEPS
        );
    }
    assert!(data.deltas.is_empty(), "phong has no delta lobe");
}

#[test]
fn polar_png_has_its_size_and_peaks_at_the_mirror_angle_gpu() {
    with_gpu("polar_png_gpu", |e| {
        let dir = tempfile::tempdir().unwrap();
        check_polar_peaks(e, dir.path(), "polar.png");
    });
}

#[test]
fn polar_png_has_its_size_and_peaks_at_the_mirror_angle_cpu() {
    let dir = tempfile::tempdir().unwrap();
    check_polar_peaks(&Evaluator::cpu(), dir.path(), "polar.png");
}

#[test]
fn polar_overlay_marks_delta_lobes_with_their_albedo_and_svg_holds_the_title() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("overlay.svg");
    let subjects = [
        Subject::new(params(Model::SmoothLayered, &["ior=1.5"]), None),
        Subject::new(params(Model::CookTorrance, &[]), None),
        Subject::new(
            lobe::resolve_params("cook_torrance", Some("gold"), &[]).unwrap(),
            Some("gold"),
        ),
    ];
    let common = PlotSettings {
        log: true,
        ..PlotSettings::default()
    };
    let opts = PolarOptions {
        theta_i_deg: vec![0.0, 60.0],
        samples: 360,
        ..PolarOptions::default()
    };
    let Plotted::Polar(data) = run(
        &Evaluator::cpu(),
        &subjects,
        &common,
        &Request::Polar(opts),
        &path,
    ) else {
        panic!("a polar request returned another kind")
    };
    // Two curves per model; delta marks only for the smooth-layered model, one per θi.
    assert_eq!(data.series.len(), 6);
    assert_eq!(data.deltas.len(), 2);
    let normal = &data.deltas[0];
    assert_eq!((normal.subject, normal.mirror_deg), (0, 0.0));
    for c in normal.albedo {
        assert!(
            (c - 0.04).abs() <= DELTA_ALBEDO_ATOL,
            "smooth_layered ior=1.5 at θi = 0: delta albedo {c}, expected R0 = 0.04"
        );
    }
    // Grazing incidence reflects more: Schlick grows towards 1.
    assert!(data.deltas[1].albedo[0] > 0.04);
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(
        svg.trim_start().starts_with("<svg") || svg.contains("<svg "),
        "not SVG"
    );
    assert!(svg.trim_end().ends_with("</svg>"), "the SVG is not closed");
    for text in [
        "in the plane of incidence",
        "smooth_layered",
        "gold cook_torrance",
        "ior=1.5",
        "δ ρ=0.04",
    ] {
        assert!(svg.contains(text), "the SVG lacks the text '{text}'");
    }
}

fn check_hemisphere(e: &Evaluator, dir: &Path, reverse: bool, projection: Projection) {
    let path = dir.join(format!("hemi-{reverse}-{}.png", projection.name()));
    let common = PlotSettings {
        log: true,
        size: (1000, 420),
        ..PlotSettings::default()
    };
    let opts = HemisphereOptions {
        theta_deg: vec![30.0, 60.0],
        phi_deg: 20.0,
        reverse,
        projection,
        res: 128,
    };
    let Plotted::Hemisphere(data) = run(
        e,
        &[glossy_phong()],
        &common,
        &Request::Hemisphere(opts),
        &path,
    ) else {
        panic!("a hemisphere request returned another kind")
    };
    assert_eq!(png_size(&path), (1000, 420));
    assert_eq!(data.panels.len(), 2);
    for p in &data.panels {
        assert_eq!(p.values.len(), 128 * 128);
        // The disc covers π/4 of the square; cells on its edge count as in or out.
        let inside = p.values.iter().filter(|v| v.is_finite()).count() as f64;
        let expected = std::f64::consts::FRAC_PI_4 * 128.0 * 128.0;
        assert!(
            (inside - expected).abs() < 4.0 * 128.0,
            "{inside} cells inside the disc, expected about {expected}"
        );
        let (t, ph) = p.peak_deg;
        let (mt, mph) = p.mirror_deg;
        let dphi = ((ph - mph + 540.0).rem_euclid(360.0) - 180.0).abs();
        // Compare as great-circle distance so φ differences count by their true size.
        let a = lobe::grid::direction(t.to_radians(), ph.to_radians());
        let b = lobe::grid::direction(mt.to_radians(), mph.to_radians());
        let angle = a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
        assert!(
            angle <= HEMISPHERE_PEAK_TOLERANCE_DEG,
            "phong n=500 on {}, reverse={reverse}, {}: fixed direction ({}°, {}°): the map \
             peaks at ({t}°, {ph}°), the mirror is ({mt}°, {mph}°): {angle}° apart (Δφ {dphi}°)",
            e.name(),
            projection.name(),
            p.theta_deg,
            p.phi_deg
        );
    }
}

#[test]
fn hemisphere_maps_peak_at_the_mirror_direction_gpu() {
    with_gpu("hemisphere_gpu", |e| {
        let dir = tempfile::tempdir().unwrap();
        check_hemisphere(e, dir.path(), false, Projection::EqualArea);
        check_hemisphere(e, dir.path(), true, Projection::Nusselt);
    });
}

#[test]
fn hemisphere_maps_peak_at_the_mirror_direction_cpu() {
    let dir = tempfile::tempdir().unwrap();
    check_hemisphere(&Evaluator::cpu(), dir.path(), false, Projection::Nusselt);
    check_hemisphere(&Evaluator::cpu(), dir.path(), true, Projection::EqualArea);
}

#[test]
fn projections_invert_and_keep_the_horizon_on_the_unit_circle() {
    for p in [Projection::EqualArea, Projection::Nusselt] {
        assert!((p.radius(std::f64::consts::FRAC_PI_2) - 1.0).abs() < 1e-15);
        for k in 0..=90 {
            let t = (k as f64).to_radians();
            assert!(
                (p.theta(p.radius(t)) - t).abs() < 1e-7,
                "{} at {k}°",
                p.name()
            );
        }
    }
}

#[test]
fn rusinkiewicz_coordinates_give_the_half_and_difference_angles() {
    for (th, ph, td, pd) in [
        (0.3, 0.0, 0.5, 1.5),
        (1.2, 0.7, 0.2, 0.4),
        (0.0, 0.0, 1.0, 3.0),
    ] {
        let (wi, wo) = half_diff_to_pair(th, ph, td, pd);
        let h = (wi + wo).normalize();
        assert!((h.z.acos() - th).abs() < 1e-12, "θh");
        assert!((wi.dot(h).acos() - td).abs() < 1e-12, "θd");
        assert!((wi.length() - 1.0).abs() < 1e-12 && (wo.length() - 1.0).abs() < 1e-12);
    }
}

fn check_slice(e: &Evaluator, dir: &Path) {
    let path = dir.join("slice.png");
    let subjects = [
        Subject::new(
            params(
                Model::BlinnPhong,
                &["diffuse=0", "specular=1", "smoothness=0.5"],
            ),
            None,
        ),
        Subject::new(params(Model::Lambert, &["albedo=0.5"]), None),
    ];
    let common = PlotSettings {
        size: (1100, 600),
        ..PlotSettings::default()
    };
    let Plotted::Slice(data) = run(
        e,
        &subjects,
        &common,
        &Request::Slice(SliceOptions::default()),
        &path,
    ) else {
        panic!("a slice request returned another kind")
    };
    assert_eq!(png_size(&path), (1100, 600));
    let n = data.res;
    // Blinn-Phong depends on θh alone (c_h^N): every θd row peaks in the first θh column.
    let bp = &data.panels[0].values;
    for row in 0..n {
        let r = &bp[row * n..(row + 1) * n];
        let best = (0..n).max_by(|&a, &b| r[a].total_cmp(&r[b])).unwrap();
        assert_eq!(
            best,
            0,
            "blinn_phong on {}: θd row {row} peaks at θh cell {best}",
            e.name()
        );
    }
    // Lambert is flat: albedo/π everywhere (φd = 90° keeps both directions above the horizon).
    let expected = 0.5 / std::f64::consts::PI;
    for &v in &data.panels[1].values {
        assert!(
            (v - expected).abs() <= LAMBERT_RTOL_F32 * expected,
            "lambert on {}: slice value {v}, expected {expected}",
            e.name()
        );
    }
}

#[test]
fn slice_of_blinn_phong_peaks_at_theta_h_zero_and_lambert_is_flat_gpu() {
    with_gpu("slice_gpu", |e| {
        check_slice(e, tempfile::tempdir().unwrap().path())
    });
}

#[test]
fn slice_of_blinn_phong_peaks_at_theta_h_zero_and_lambert_is_flat_cpu() {
    check_slice(&Evaluator::cpu(), tempfile::tempdir().unwrap().path());
}

#[test]
fn surface3d_lobe_points_along_the_mirror_direction_gpu() {
    with_gpu("surface3d_gpu", |e| {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lobe.svg");
        let opts = Surface3dOptions {
            theta_i_deg: vec![40.0],
            phi_i_deg: 30.0,
            ..Surface3dOptions::default()
        };
        let Plotted::Surface3d(data) = run(
            e,
            &[glossy_phong()],
            &PlotSettings::default(),
            &Request::Surface3d(opts),
            &path,
        ) else {
            panic!("a 3d request returned another kind")
        };
        let (t, p) = data.panels[0].peak_deg;
        assert!(
            (t - 40.0).abs() <= SURFACE_RING_TOLERANCE_DEG
                && (p - 210.0).abs() <= SURFACE_MERIDIAN_TOLERANCE_DEG,
            "phong n=500, ωi = (40°, 30°): the lobe's longest radius is at ({t}°, {p}°), \
             expected the mirror direction (40°, 210°)"
        );
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("<svg") && svg.contains("The lobe r(ωo)"));
    });
}

#[test]
fn albedo_curves_show_lambert_exactly_and_the_smooth_layered_gain() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("albedo.png");
    let subjects = [
        Subject::new(params(Model::Lambert, &["albedo=0.5"]), None),
        Subject::new(params(Model::SmoothLayered, &["diffuse=0.9"]), None),
    ];
    let opts = AlbedoOptions {
        n_mu: 16,
        ..AlbedoOptions::default()
    };
    let Plotted::Albedo(data) = run(
        &Evaluator::cpu(),
        &subjects,
        &PlotSettings::default(),
        &Request::Albedo(opts),
        &path,
    ) else {
        panic!("an albedo request returned another kind")
    };
    assert_eq!(png_size(&path), (1200, 800));
    for (mu, e) in data.curves[0].mu.iter().zip(&data.curves[0].albedo) {
        assert!(
            (e - 0.5).abs() <= LAMBERT_ALBEDO_RTOL * 0.5,
            "lambert albedo=0.5: E({mu}) = {e}"
        );
    }
    // docs/design.md §3: `smooth_layered` gains energy at grazing angles; the plot must
    // show a curve above E = 1 there.
    let grazing = data.curves[1].albedo[0];
    assert!(
        grazing > 1.0,
        "smooth_layered diffuse=0.9: E(μ = {}) = {grazing}",
        data.curves[1].mu[0]
    );
    assert!(data.y_max > grazing);
}

#[test]
fn a_bad_extension_or_angle_fails_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("plot.jpg");
    let err = plot::plot(
        &Evaluator::cpu(),
        &[glossy_phong()],
        &PlotSettings::default(),
        &Request::Polar(PolarOptions::default()),
        &bad,
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains(".png, .svg or .pdf"), "{err:#}");
    let out = dir.path().join("plot.png");
    let err = plot::plot(
        &Evaluator::cpu(),
        &[glossy_phong()],
        &PlotSettings::default(),
        &Request::Polar(PolarOptions {
            theta_i_deg: vec![95.0],
            ..PolarOptions::default()
        }),
        &out,
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("theta_i = 95"), "{err:#}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "a file was left behind"
    );
}

#[test]
fn cli_plot_writes_each_kind_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, file, extra) in [
        ("polar", "p.svg", vec!["--material", "gold,tin", "--log"]),
        (
            "hemisphere",
            "h.png",
            vec!["--theta-i-deg", "45", "--res", "48"],
        ),
        ("slice", "s.png", vec!["--res", "32"]),
        ("3d", "t.png", vec!["--res", "16"]),
        (
            "albedo",
            "a.svg",
            vec![
                "--model",
                "lambert,coupled",
                "--res",
                "8",
                "--samples",
                "4096",
            ],
        ),
    ] {
        let path = dir.path().join(file);
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
            .args(["plot", "--kind", kind, "--backend", "cpu", "-o"])
            .arg(&path)
            .args(&extra)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "lobe plot --kind {kind}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            std::fs::metadata(&path).unwrap().len() > 1000,
            "{kind}: tiny file"
        );
    }
}

/// The RGB pixels of a PNG.
fn png_pixels(path: &Path) -> Vec<[u8; 3]> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
    buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// A pixel that is `c` laid over white with a coverage strictly between 0 and 1 (each channel
/// within one unit of rounding of the same mix).
fn is_partial_cover(p: [u8; 3], c: [u8; 3]) -> bool {
    let a = (255.0 - p[0] as f64) / (255.0 - c[0] as f64);
    a > 0.05
        && a < 0.95
        && (0..3).all(|k| {
            let want = 255.0 - a * (255.0 - c[k] as f64);
            (p[k] as f64 - want).abs() <= 2.0
        })
}

#[test]
fn pngs_are_anti_aliased_and_byte_stable_and_svg_keeps_sub_pixel_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let common = PlotSettings {
        log: true,
        size: (600, 400),
        ..PlotSettings::default()
    };
    let request = Request::Polar(PolarOptions {
        theta_i_deg: vec![30.0],
        samples: 360,
        ..PolarOptions::default()
    });
    let e = Evaluator::cpu();
    let (a, b, svg) = (
        dir.path().join("a.png"),
        dir.path().join("b.png"),
        dir.path().join("c.svg"),
    );
    let subjects = [glossy_phong()];
    run(&e, &subjects, &common, &request, &a);
    run(&e, &subjects, &common, &request, &b);
    run(&e, &subjects, &common, &request, &svg);
    assert_eq!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "the same plot twice gave different bytes"
    );
    // One θi on one model: the curve is palette(0); an aliased renderer draws it in that colour
    // or not at all, an anti-aliased one also mixes it with the white around it.
    let c = plot::palette(0);
    let c = [c.0, c.1, c.2];
    let pixels = png_pixels(&a);
    let full = pixels.iter().filter(|p| **p == c).count();
    let partial = pixels.iter().filter(|p| is_partial_cover(**p, c)).count();
    assert!(full > 100, "{full} pixels of the curve's colour");
    assert!(
        partial > full / 4,
        "{partial} partly covered pixels beside {full} full ones: not anti-aliased"
    );
    // The curve's points keep fractions of a pixel.
    let text = std::fs::read_to_string(&svg).unwrap();
    let curve = text
        .lines()
        .find(|l| l.starts_with("<polyline") && l.contains("stroke-width=\"2\""))
        .expect("no curve in the SVG");
    let points = &curve[curve.find("points=\"").unwrap() + 8..];
    let fractional = points.split([' ', ',']).filter(|v| v.contains('.')).count();
    assert!(fractional > 20, "only {fractional} sub-pixel coordinates");
    assert_eq!(
        text.matches("<svg").count(),
        1,
        "one SVG document, its ink inside it"
    );
}

#[test]
fn twelve_series_stay_distinct_and_a_model_keeps_its_style() {
    let styles: Vec<plot::SeriesStyle> = (0..12).map(plot::series_style).collect();
    for i in 0..12 {
        for j in 0..i {
            assert_ne!(styles[i], styles[j], "series {i} and {j} look the same");
        }
    }
    let subject = |m: Model| Subject::new(ParamSet::defaults(m), None);
    let a = plot::subject_styles(&[subject(Model::Phong), subject(Model::Lambert)]);
    let b = plot::subject_styles(&[
        subject(Model::Lambert),
        subject(Model::CookTorrance),
        subject(Model::Phong),
    ]);
    assert_eq!(a[0], b[2], "phong changed style between plots");
    assert_eq!(a[1], b[0], "lambert changed style between plots");
    // Every built-in model has a style of its own.
    let all: Vec<Subject> = Model::ALL.iter().map(|&m| subject(m)).collect();
    let styles = plot::subject_styles(&all);
    for i in 0..styles.len() {
        for j in 0..i {
            assert_ne!(styles[i], styles[j], "models {i} and {j}");
        }
    }
}

#[test]
fn titles_name_shared_parameters_once_and_only_active_ones() {
    let conductor = Subject::new(
        params(
            Model::Microfacet(lobe::model::microfacet::MicrofacetConfig::DEFAULT),
            &["fresnel=conductor"],
        ),
        None,
    );
    let line = conductor.describe();
    assert!(line.contains("eta=") && line.contains("k="), "{line}");
    assert!(
        !line.contains("ior="),
        "ior is unused by a conductor: {line}"
    );
    let schlick = Subject::new(
        params(
            Model::Microfacet(lobe::model::microfacet::MicrofacetConfig::DEFAULT),
            &[],
        ),
        None,
    );
    let line = schlick.describe();
    assert!(line.contains("ior=") && !line.contains("eta="), "{line}");
    // Two Phong lobes that differ in shininess: the rest once, the shininess per series.
    let mut a = Subject::new(params(Model::Phong, &["shininess=50"]), None);
    let mut b = Subject::new(params(Model::Phong, &["shininess=500"]), None);
    a.label = "narrow".into();
    b.label = "wide".into();
    let lines = plot::describe_subjects(&[a, b]);
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert!(lines[0].starts_with("all: ") && lines[0].contains("diffuse="));
    assert!(!lines[0].contains("shininess"), "{lines:?}");
    assert_eq!(lines[1], "narrow: shininess=50 · wide: shininess=500");
}

#[test]
fn contours_of_a_linear_field_are_where_it_crosses_the_level() {
    // v = x + y on a 5 × 4 grid: the level 1.5 crosses the line x + y = 1.5 exactly (linear
    // interpolation is exact for a linear field).
    let xs = [0.0, 0.5, 1.0, 1.5, 2.0];
    let ys = [0.0, 0.4, 0.8, 1.2];
    let values: Vec<f64> = ys
        .iter()
        .flat_map(|y| xs.iter().map(move |x| x + y))
        .collect();
    let segments = plot::contour_segments(&values, &xs, &ys, 1.5);
    assert!(segments.len() >= 3, "{segments:?}");
    for (a, b) in segments {
        for p in [a, b] {
            assert!((p.0 + p.1 - 1.5).abs() < 1e-12, "{p:?}");
        }
    }
}

fn lobe_plot(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(["plot", "--backend", "cpu", "--res", "64"])
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn set_applies_per_model_and_a_model_spec_carries_its_own_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.svg");
    let out = lobe_plot(&[
        "-o",
        path.to_str().unwrap(),
        "--model",
        "phong,blinn_phong,microfacet{fresnel=conductor,eta=0.2,0.4,1.4}",
        "--set",
        "shininess=50",
        "--set",
        "blinn_phong.smoothness=0.5",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path.with_extension("json")).unwrap())
            .unwrap();
    let series = json["series"].as_array().unwrap();
    assert_eq!(series.len(), 3);
    assert_eq!(series[0]["params"]["shininess"], 50.0);
    assert_eq!(series[1]["params"]["smoothness"], 0.5);
    assert_eq!(series[2]["params"]["fresnel"], "conductor");
    assert_eq!(
        series[2]["params"]["eta"],
        serde_json::json!([0.2, 0.4, 1.4])
    );
    // A key no listed model has, or a model not listed, fails and writes nothing.
    for bad in [
        vec!["--model", "phong,lambert", "--set", "smoothness=1"],
        vec!["--model", "phong", "--set", "lambert.albedo=0.5"],
        vec!["--model", "phong{shininess=50"],
    ] {
        let path = dir.path().join("bad.png");
        let mut args = vec!["-o", path.to_str().unwrap()];
        args.extend(bad.iter().copied());
        let out = lobe_plot(&args);
        assert!(!out.status.success(), "{bad:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("smoothness") || err.contains("lambert") || err.contains('}'),
            "{bad:?}: {err}"
        );
        assert!(!path.exists(), "{bad:?} left a file");
    }
}
