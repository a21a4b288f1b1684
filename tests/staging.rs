//! The staging path of discrete GPUs (src/gpu/buffer/): kernels bind device-local buffers,
//! inputs reach them through an upload copy and outputs come back through a copy to host-cached
//! memory. `DeviceOptions::force_staging` takes that path on any device; on lavapipe, which maps
//! its one memory type directly, it is the only way to run it. Copies move bytes, so every value
//! must be bit-identical to the direct path: tables, pairs, albedo and previews.

mod common;

use glam::DVec3;
use lobe::gpu::{Device, DeviceOptions, Gpu, GpuPair};
use lobe::grid::Grid;
use lobe::integrate::{directional, hemispherical, Method, Settings};
use lobe::model::{Brdf, Model};
use lobe::preview::{self, LightKind, Scene, Shape, Sheet};
use lobe::Evaluator;

/// The direct path (as the test environment asks, see tests/common) and the forced staging
/// path, otherwise with the same options.
fn both_paths(test: &str) -> Option<(Gpu, Gpu)> {
    let direct = common::gpu_device(test)?;
    let staged = Device::open(&DeviceOptions {
        force_staging: true,
        ..common::device_options()
    })
    .unwrap_or_else(|e| panic!("{test} needs a Vulkan device: {e}"));
    Some((Gpu::new(direct), Gpu::new(staged)))
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn table(gpu: &Gpu, grid: &Grid) -> Vec<u32> {
    let params = lobe::resolve_params(
        "microfacet",
        Some("gold"),
        &["distribution=beckmann".into(), "fresnel=conductor".into()],
    )
    .unwrap();
    let mut out = Vec::new();
    Evaluator::gpu(gpu)
        .eval_table(&params, grid, &mut |first, v| {
            assert_eq!(first as usize * 3, out.len(), "chunks arrive in order");
            out.extend(bits(v));
            Ok(())
        })
        .expect("table");
    out
}

fn pairs(gpu: &Gpu) -> Vec<u32> {
    let params = lobe::resolve_params("cook_torrance", Some("tin"), &[]).unwrap();
    let mut rng = common::Rng(7);
    let mut dir = || {
        let (mu, phi) = (rng.range(0.01, 1.0), rng.range(0.0, std::f64::consts::TAU));
        let s = (1.0 - mu * mu).sqrt();
        [(s * phi.cos()) as f32, (s * phi.sin()) as f32, mu as f32]
    };
    let list: Vec<GpuPair> = (0..5000)
        .map(|_| GpuPair {
            wi: dir(),
            param_index: 0,
            wo: dir(),
            pad: 0,
        })
        .collect();
    let f = gpu
        .eval_pairs(
            params.model(),
            &[Brdf::new(&params).gpu_block()],
            &list,
            false,
        )
        .expect("pairs");
    f.iter().flatten().map(|x| x.to_bits()).collect()
}

fn albedo(gpu: &Gpu) -> Vec<u64> {
    let params = lobe::resolve_params("microfacet", None, &["alpha=0.2".into()]).unwrap();
    let eval = Evaluator::gpu(gpu);
    let s = Settings {
        method: Method::Peak,
        samples: 4096,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: true,
    };
    let dir = directional(&eval, &params, &s, &[(0.2, 0.0), (0.7, 0.0), (1.0, 0.0)]).unwrap();
    let hemi = hemispherical(&eval, &params, &s, 0.0).unwrap();
    dir.iter()
        .map(|p| p.albedo)
        .chain([hemi.e_avg])
        .flat_map(|v: DVec3| v.to_array())
        .map(f64::to_bits)
        .collect()
}

fn preview_pixels(gpu: &Gpu) -> Vec<u32> {
    let sheet = Sheet::new(&["gold".into(), "granite".into()], &[Model::CookTorrance]).unwrap();
    let scene = Scene::lab(
        48,
        Shape::Sphere,
        LightKind::Point,
        DVec3::new(0.1, 0.1, 0.1),
    );
    let image = preview::render(&Evaluator::gpu(gpu), &sheet, &scene, &mut |_, _| {})
        .unwrap_or_else(|e| panic!("{e:#}"));
    let mut out = Vec::new();
    for y in 0..image.height() {
        for x in 0..image.width() {
            out.extend(bits(&image.pixel(x, y)));
        }
    }
    out
}

#[test]
fn the_staging_path_gives_the_direct_paths_bits() {
    let test = "the_staging_path_gives_the_direct_paths_bits";
    let Some((direct, staged)) = both_paths(test) else {
        return;
    };
    // 1.1e6 cells: several chunks on either device kind, so both output buffers take turns.
    let grid = Grid::parse("isotropic", "67,63,263").unwrap();
    let t = table(&direct, &grid);
    assert_eq!(t.len(), 67 * 63 * 263 * 3);
    assert!(t == table(&staged, &grid), "tables differ");
    assert!(pairs(&direct) == pairs(&staged), "pairs differ");
    assert_eq!(albedo(&direct), albedo(&staged), "albedo differs");
    assert!(
        preview_pixels(&direct) == preview_pixels(&staged),
        "previews differ"
    );
    // The forced path did copy; the direct path copies only where the device needs it (never
    // on lavapipe, whose one memory type is mapped directly).
    assert!(staged.device().staging_copies() > 0);
    if direct.device().is_cpu() && std::env::var("LOBE_STAGING").is_err() {
        assert_eq!(direct.device().staging_copies(), 0);
    }
    common::assert_validation_clean(&direct, test);
    common::assert_validation_clean(&staged, test);
}
