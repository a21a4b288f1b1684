//! `lobe preview`: the images have the requested size, carry the data (a glossy sphere's
//! brightest pixel lies where a light's mirror direction meets the view, computed here
//! analytically), the GPU and CPU renders agree pixel by pixel, and the EXR reads back.

mod common;

use glam::DVec3;
use lobe::gpu::Gpu;
use lobe::model::{Model, ParamSet, Reference};
use lobe::preview::{self, LightKind, Scene, Shape, Sheet, SheetImage};
use lobe::{material, Evaluator};

/// f32 machine epsilon.
const EPS32: f64 = f32::EPSILON as f64;
/// Relative tolerance of a GPU pixel against the f64 render. Per pixel the kernel chains an f32
/// ray–object intersection, a frame built from the f32 normal, one BRDF evaluation per light and a
/// sum of four terms. The BRDF alone is held to 64 ε plus exp's 3 + 2|x| ulp in tests/parity.rs;
/// here its inputs also carry the geometry's error: the normal is off by a few ε of the object's
/// distance (~3), so Δθ ≈ 1e-6 rad, and a lobe's value moves with direction by |d ln f/dθ|. For
/// a cos^n lobe that is n tanθ, which over the range where f is above ATOL (n θ²/2 < ln(peak/ATOL)
/// ≈ 14) stays below √(28 n) ≈ 90 for the sharpest preset (Ashikhmin–Shirley nu = 300); GGX with
/// α = 0.08 gives ~2/α = 25. So ~1e-4 at worst; 5e-4 keeps a margin of 5 over that bound and of
/// ~10 over the largest error measured on lavapipe where values exceed 100 ATOL (5e-5 in 96-pixel
/// cells; the test prints it per model). Next to a silhouette or a terminator, where c_o or c_i
/// comes from cancellation, the relative error grows as ε / c (1.6e-4 was seen in 1032-pixel
/// cells); those pixels are dim, so ATOL covers most, and PERTURBATION below the rest.
const RTOL: f64 = 5e-4;
/// Absolute tolerance in radiance units (a white Lambertian facing the camera reads 1): far below
/// one step of an 8-bit PNG (1/255 before the sRGB curve).
const ATOL: f64 = 1e-5;
/// Input conditioning: where a pixel's ray passes within the GPU's f32 error of a silhouette, a
/// face edge of the icosahedron or a terminator (cos θ = 0), f32 and f64 may legitimately land on
/// different sides. Such a pixel passes if the GPU value lies within the spread of the f64 render
/// over rays turned by this angle (radians; 64 ε ≈ 8e-6, several times the f32 error of the ray
/// direction and of the hit point's angle seen from the camera).
const PERTURBATION: f64 = 64.0 * EPS32;
/// How far (pixels) the brightest pixel may lie from the analytic mirror point: the pixel grid
/// quantises to ±0.5 px per axis, and cos θi / d² tilt the peak of a n = 2000 lobe by far less
/// than a pixel.
const HIGHLIGHT_TOLERANCE_PX: f64 = 2.0;

fn default_materials() -> Vec<String> {
    material::names().into_iter().map(String::from).collect()
}

fn render(e: &Evaluator, sheet: &Sheet, scene: &Scene) -> SheetImage {
    preview::render(e, sheet, scene, &mut |_, _| {}).unwrap_or_else(|err| panic!("{err:#}"))
}

/// One Phong cell: a mirror-like lobe (n = 2000, no diffuse) lit by the lab's light at `light`.
fn glossy_sheet_and_scene(light: [f64; 3], cell: u32) -> (Sheet, Scene) {
    let mut p = ParamSet::defaults(Model::Phong);
    for s in ["diffuse=0", "specular=1", "shininess=2000"] {
        p.set_text(s).unwrap();
    }
    let sheet = Sheet {
        materials: vec!["mirror-like".into()],
        models: vec![Model::Phong],
        columns: vec!["phong".into()],
        params: vec![vec![p]],
    };
    let mut scene = Scene::lab(cell, Shape::Sphere, LightKind::Point, DVec3::ZERO);
    scene
        .lights
        .retain(|l| l.position == DVec3::from_array(light));
    assert_eq!(
        scene.lights.len(),
        1,
        "{light:?} is one of the lab's lights"
    );
    (sheet, scene)
}

/// The point of the sphere where the light at `l` is mirrored toward the camera at the origin:
/// there the normal bisects the directions to the light and to the camera. The camera, the
/// sphere's centre and the light span a plane; bisect on the angle α of the normal in it.
fn mirror_point(scene: &Scene, l: DVec3) -> DVec3 {
    let c = scene.centre;
    let e1 = (-c).normalize(); // from the centre toward the camera
    let off = l - c - e1 * (l - c).dot(e1);
    let e2 = if off.length() > 0.0 {
        off.normalize()
    } else {
        DVec3::X
    };
    let normal = |a: f64| e1 * a.cos() + e2 * a.sin();
    // g > 0 while the bisector lies further toward the light than the normal.
    let g = |a: f64| {
        let p = c + scene.radius * normal(a);
        let h = (l - p).normalize() + (-p).normalize();
        h.dot(e2) * normal(a).dot(e1) - h.dot(e1) * normal(a).dot(e2)
    };
    let (mut lo, mut hi) = (0.0, std::f64::consts::FRAC_PI_2);
    assert!(g(lo) >= 0.0 && g(hi) < 0.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if g(mid) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    c + scene.radius * normal(lo)
}

fn argmax(image: &SheetImage) -> (usize, usize) {
    let mut best = (0, 0, f32::MIN);
    for y in 0..image.height() {
        for x in 0..image.width() {
            let [r, g, b] = image.pixel(x, y);
            if r + g + b > best.2 {
                best = (x, y, r + g + b);
            }
        }
    }
    (best.0, best.1)
}

fn check_highlight(e: &Evaluator) {
    for light in [[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [-1.0, 0.0, 1.0]] {
        let (sheet, scene) = glossy_sheet_and_scene(light, 129);
        let image = render(e, &sheet, &scene);
        let p = mirror_point(&scene, DVec3::from_array(light));
        let (px, py) = scene.project(p);
        let (ax, ay) = argmax(&image);
        let dist = ((ax as f64 - px).powi(2) + (ay as f64 - py).powi(2)).sqrt();
        assert!(
            dist <= HIGHLIGHT_TOLERANCE_PX,
            "{}: light at {light:?}: the mirror point {p} projects to pixel ({px:.2}, {py:.2}), \
but the brightest pixel is ({ax}, {ay}), {dist:.2} px away (allowed {HIGHLIGHT_TOLERANCE_PX})",
            e.name()
        );
    }
}

#[test]
fn cpu_highlight_lies_at_the_mirror_point() {
    check_highlight(&Evaluator::cpu());
}

#[test]
fn gpu_highlight_lies_at_the_mirror_point() {
    let Some(dev) = common::gpu_device("gpu_highlight_lies_at_the_mirror_point") else {
        return;
    };
    let gpu = Gpu::new(dev);
    check_highlight(&Evaluator::gpu(&gpu));
    common::assert_validation_clean(&gpu, "gpu_highlight_lies_at_the_mirror_point");
}

#[test]
fn lab_lights_are_mirror_symmetric_about_the_vertical() {
    // The lights at (1,0,1) and (-1,0,1) mirror each other, (0,0,1) and (0,1,1) lie in x = 0:
    // an isotropic material's image is symmetric left to right.
    let sheet = Sheet::new(&["granite".into()], &[Model::OrenNayar]).unwrap();
    let scene = Scene::lab(64, Shape::Sphere, LightKind::Point, DVec3::ZERO);
    let image = render(&Evaluator::cpu(), &sheet, &scene);
    for y in 0..64 {
        for x in 0..32 {
            let (a, b) = (image.pixel(x, y), image.pixel(63 - x, y));
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-6 * a[c].abs().max(1.0),
                    "({x}, {y}) {a:?} vs ({}, {y}) {b:?}",
                    63 - x
                );
            }
        }
    }
}

#[test]
fn files_have_the_requested_size_and_the_exr_reads_back() {
    let models = [Model::Lambert, Model::CookTorrance, Model::AshikhminShirley];
    let sheet = Sheet::new(&default_materials()[..2], &models).unwrap();
    let mut scene = Scene::lab(40, Shape::Icosahedron, LightKind::Point, DVec3::ZERO);
    scene.cell_height = 24; // not square: the aspect ratio must follow
    let image = render(&Evaluator::cpu(), &sheet, &scene);
    assert_eq!((image.width(), image.height()), (3 * 40, 2 * 24));
    assert_eq!(image.rgb.len(), 120 * 48);
    assert!(image.rgb.iter().any(|p| p[0] > 0.0), "the image is black");

    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("sheet.exr");
    let png_path = dir.path().join("sheet.png");
    preview::write_exr(&image, &sheet, &scene, "cpu", &exr).unwrap();
    let (w, h, rgb) = preview::read_exr(&exr).unwrap();
    assert_eq!((w, h), (120, 48));
    assert!(
        rgb == image.rgb,
        "the EXR does not read back bit for bit (float32, lossless)"
    );

    let (pw, ph) = preview::write_png(&image, &sheet, 0.0, "caption", &png_path).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ));
    let reader = decoder.read_info().unwrap();
    let info = reader.info();
    assert_eq!((info.width as usize, info.height as usize), (pw, ph));
    // The cells plus label margins: a column of names on the left, a row above, a caption below.
    assert!(
        pw > 120 && pw < 120 + 200 && ph > 48 && ph < 48 + 100,
        "{pw}x{ph}"
    );
    // Nothing else is left in the folder (the temporary files were renamed into place).
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["sheet.exr", "sheet.png"]);
}

/// The largest change of the f64 render when the pixel's ray turns by PERTURBATION about each
/// axis: returns the range [lo, hi] of the values seen, per channel.
fn conditioned_range(r: &Reference, scene: &Scene, d: DVec3) -> (DVec3, DVec3) {
    let centre = preview::radiance_along(r, scene, d);
    let (mut lo, mut hi) = (centre, centre);
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        for sign in [-1.0, 1.0] {
            let v = preview::radiance_along(r, scene, (d + sign * PERTURBATION * axis).normalize());
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (lo, hi)
}

/// Compares a GPU and a CPU render of `sheet` pixel by pixel: |g − c| ≤ ATOL + RTOL|c| per
/// channel, or within the f64 render's spread over rays turned by PERTURBATION. Panics with the
/// first failures; returns a one-line summary.
fn assert_agree(
    sheet: &Sheet,
    scene: &Scene,
    g: &SheetImage,
    c: &SheetImage,
    what: &str,
) -> String {
    assert_eq!(g.rgb.len(), c.rgb.len());
    let mut worst_rel = vec![(0.0f64, String::new()); g.cols];
    let (mut worst_abs, mut conditioned) = (0.0f64, 0usize);
    let mut failures = Vec::new();
    for (col, worst) in worst_rel.iter_mut().enumerate() {
        for row in 0..g.rows {
            let r = Reference::new(&sheet.params[col][row], false);
            for y in 0..g.cell_height {
                for x in 0..g.cell_width {
                    let gp = DVec3::from_array(g.cell_pixel(row, col, x, y).map(f64::from));
                    let cp = DVec3::from_array(c.cell_pixel(row, col, x, y).map(f64::from));
                    let err = (gp - cp).abs();
                    let allowed = DVec3::splat(ATOL) + RTOL * cp.abs();
                    if err.cmple(allowed).all() {
                        worst_abs = worst_abs.max(err.max_element());
                        // Relative error where it means something: channels above 100 ATOL.
                        for k in 0..3 {
                            if cp[k].abs() > 100.0 * ATOL {
                                let rel = err[k] / cp[k].abs();
                                if rel > worst.0 {
                                    *worst = (rel, format!("{} ({x}, {y})", sheet.materials[row]));
                                }
                            }
                        }
                        continue;
                    }
                    let d = scene.camera_ray(x as u32, y as u32);
                    let (lo, hi) = conditioned_range(&r, scene, d);
                    let slack = DVec3::splat(ATOL) + RTOL * hi.abs().max(lo.abs());
                    if gp.cmpge(lo - slack).all() && gp.cmple(hi + slack).all() {
                        conditioned += 1;
                        continue;
                    }
                    failures.push(format!(
                        "{} / {} pixel ({x}, {y}): gpu {gp}, cpu {cp}, |diff| {err}, allowed {allowed}; \
f64 over rays turned by {PERTURBATION:.1e} rad spans [{lo}, {hi}]",
                        sheet.models[col].name(),
                        sheet.materials[row],
                    ));
                }
            }
        }
    }
    let per_model: Vec<String> = worst_rel
        .iter()
        .zip(&sheet.models)
        .map(|((rel, at), m)| format!("{} {rel:.1e} at {at}", m.name()))
        .collect();
    let line = format!(
        "{what}: {} pixels; worst absolute error {worst_abs:.2e}; {conditioned} pixels at \
silhouettes/edges/terminators accepted by conditioning; worst relative error per model: {}",
        g.rgb.len(),
        per_model.join(", ")
    );
    eprintln!("{line}");
    assert!(
        failures.is_empty(),
        "{what}: {} of {} pixels differ beyond |g - c| <= {ATOL:e} + {RTOL:e}|c| (model / material / pixel):\n{}",
        failures.len(),
        g.rgb.len(),
        failures[..failures.len().min(20)].join("\n")
    );
    line
}

#[test]
fn gpu_and_cpu_previews_agree_pixel_by_pixel() {
    let Some(dev) = common::gpu_device("gpu_and_cpu_previews_agree_pixel_by_pixel") else {
        return;
    };
    let gpu = Gpu::new(dev);
    // Both sides see the same inputs: the parameters rounded to f32 as the GPU receives them, and
    // a scene whose numbers are f32 values already (Scene::lab).
    let sheet = Sheet::new(&default_materials(), &Model::ALL)
        .unwrap()
        .rounded_to_f32();
    for (shape, ambient) in [
        (Shape::Sphere, DVec3::ZERO),
        (Shape::Icosahedron, DVec3::ZERO),
        (Shape::Sphere, DVec3::new(0.1, 0.2, 0.3)),
    ] {
        let scene = Scene::lab(96, shape, LightKind::Point, ambient);
        let g = render(&Evaluator::gpu(&gpu), &sheet, &scene);
        let c = render(&Evaluator::cpu(), &sheet, &scene);
        assert_agree(
            &sheet,
            &scene,
            &g,
            &c,
            &format!("{} ambient {ambient}", shape.name()),
        );
    }
    common::assert_validation_clean(&gpu, "gpu_and_cpu_previews_agree_pixel_by_pixel");
}

#[test]
fn gpu_preview_larger_than_one_chunk_matches_the_cpu() {
    let Some(dev) = common::gpu_device("gpu_preview_larger_than_one_chunk_matches_the_cpu") else {
        return;
    };
    let gpu = Gpu::new(dev);
    // One column of four cells with more pixels than one chunk's output buffer holds
    // (CHUNK_OUTPUT_BYTES of f32 RGB), so the kernel runs at least twice with first > 0.
    let chunk_pixels = lobe::gpu::CHUNK_OUTPUT_BYTES / 12;
    let cell = ((chunk_pixels as f64 / 4.0).sqrt().ceil() as u32) + 8;
    let sheet = Sheet::new(&default_materials(), &[Model::Lambert])
        .unwrap()
        .rounded_to_f32();
    let scene = Scene::lab(cell, Shape::Sphere, LightKind::Point, DVec3::ZERO);
    let g = render(&Evaluator::gpu(&gpu), &sheet, &scene);
    let c = render(&Evaluator::cpu(), &sheet, &scene);
    assert!(g.rgb.len() as u64 > chunk_pixels);
    assert_agree(&sheet, &scene, &g, &c, &format!("{cell} px cells, chunked"));
    common::assert_validation_clean(&gpu, "gpu_preview_larger_than_one_chunk_matches_the_cpu");
}
