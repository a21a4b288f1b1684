//! Tables on the `halfdiff` grid (Rusinkiewicz's half/difference angles, docs/design.md §4): the
//! cells hold f at the pairs the grid names, on both backends, through the EXR and npy files;
//! models that depend on θh alone are constant along (θd, φd); the three-axis grid is refused for
//! an anisotropic parameter set.

mod common;

use lobe::gpu::Gpu;
use lobe::grid::Grid;
use lobe::model::{ParamSet, Reference};
use lobe::table::{read_exr, read_npy, write_table, TableMeta};
use lobe::{resolve_params, Evaluator};
use std::path::Path;

/// CPU cells are f64 values rounded to f32 once: half an ulp.
const CPU_RTOL: f64 = f32::EPSILON as f64;
/// GPU cells against the f64 reference at the same pair: the parity test's base tolerance
/// (64 ε32 for a smooth formula in f32, tests/parity.rs) plus 1e-6 1/sr absolute; the pairs here
/// are well-conditioned (no cell on the horizon: cell-centred angles).
const GPU_RTOL: f64 = 64.0 * f32::EPSILON as f64;
const ATOL: f64 = 1e-6;

fn params(model: &str, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params(model, None, &sets).expect("valid parameters")
}

/// Writes the table on `e` and returns its npy values, after checking that the EXR holds the
/// same numbers (its layout is the grid's mosaic, so compare the sorted multisets).
fn table(e: &Evaluator, p: &ParamSet, grid: Grid, dir: &Path, name: &str) -> Vec<f32> {
    let path = dir.join(format!("{name}.exr"));
    let meta = TableMeta {
        params: p,
        white_furnace: false,
        grid,
        backend: e.name(),
    };
    write_table(e, &meta, &path, &mut |_, _| {}).expect("table");
    let npy = read_npy(&path.with_extension("npy")).expect("npy");
    let mut expected_shape = grid.shape();
    expected_shape.push(3);
    assert_eq!(npy.shape, expected_shape);
    let exr = read_exr(&path).expect("exr");
    let sorted = |v: &[f32]| {
        let mut v = v.to_vec();
        v.sort_by(f32::total_cmp);
        v
    };
    assert_eq!(
        sorted(&exr.values),
        sorted(&npy.values),
        "{name}: EXR vs npy"
    );
    assert!(exr
        .attributes
        .iter()
        .any(|(k, v)| k == "lobe.grid" && v.contains("halfdiff")));
    npy.values
}

/// Every cell against the f64 reference at the pair `Grid::pair` names.
fn check_cells(values: &[f32], p: &ParamSet, grid: Grid, rtol: f64, what: &str) {
    let r = Reference::new(p, false);
    for cell in 0..grid.cells().unwrap() {
        let (wi, wo) = grid.pair(&grid.index(cell));
        let want = r.eval(wi, wo);
        for c in 0..3 {
            let got = values[cell as usize * 3 + c] as f64;
            let w = want[c];
            assert!(
                (got - w).abs() <= ATOL + rtol * w.abs(),
                "{what}: cell {cell} {:?} channel {c}: {got} vs {w}",
                grid.index(cell)
            );
        }
    }
}

fn backends(test: &str, f: impl Fn(&Evaluator, f64)) {
    f(&Evaluator::cpu(), CPU_RTOL);
    if let Some(dev) = common::gpu_device(test) {
        let gpu = Gpu::new(dev);
        f(&Evaluator::gpu(&gpu), GPU_RTOL);
        common::assert_validation_clean(&gpu, test);
    }
}

#[test]
fn halfdiff_cells_hold_f_at_their_pairs_on_both_backends() {
    let dir = tempfile::tempdir().unwrap();
    backends("halfdiff cells", |e, rtol| {
        let cases = [
            (params("cook_torrance", &[]), "halfdiff", "12,10,16"),
            (
                params("ashikhmin_shirley", &["nu=300", "nv=20"]),
                "halfdiff",
                "8,6,7,10",
            ),
            (
                params("microfacet", &["alpha_x=0.1", "alpha_y=0.4"]),
                "halfdiff",
                "8,6,7,10",
            ),
        ];
        for (k, (p, kind, res)) in cases.iter().enumerate() {
            let grid = Grid::parse(kind, res).unwrap();
            let values = table(e, p, grid, dir.path(), &format!("t{k}"));
            check_cells(
                &values,
                p,
                grid,
                rtol,
                &format!("{} {res} on {}", p.model().name(), e.name()),
            );
        }
    });
}

/// Blinn–Phong is diffuse/π + specular (n + 8)/(8π) cos^n θh: a function of θh alone wherever both
/// directions are above the horizon, and 0 where either is below (docs/design.md §2).
#[test]
fn blinn_phong_depends_on_theta_h_alone() {
    let dir = tempfile::tempdir().unwrap();
    backends("halfdiff blinn_phong", |e, rtol| {
        let p = params(
            "blinn_phong",
            &["smoothness=0.5", "diffuse=0.3", "specular=1"],
        );
        let grid = Grid::parse("halfdiff", "16,12,24").unwrap();
        let values = table(e, &p, grid, dir.path(), "bp");
        let n = 8192f64.powf(0.5);
        for cell in 0..grid.cells().unwrap() {
            let idx = grid.index(cell);
            let (wi, wo) = grid.pair(&idx);
            let theta_h = grid.angles(&idx)[0];
            let above = wi.z > 0.0 && wo.z > 0.0;
            let want = if above {
                0.3 / std::f64::consts::PI
                    + (n + 8.0) / (8.0 * std::f64::consts::PI) * theta_h.cos().powf(n)
            } else {
                0.0
            };
            let got = values[cell as usize * 3] as f64;
            assert!(
                (got - want).abs() <= ATOL + rtol * want,
                "{idx:?} on {}: {got} vs closed form {want} (wi {wi}, wo {wo})",
                e.name()
            );
        }
        // Grazing θd with θh > 0 puts a direction below the horizon: some cells are 0.
        assert!(values.chunks(3).any(|c| c[0] == 0.0));
    });
}

#[test]
fn the_three_axis_grid_needs_an_isotropic_parameter_set() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "table",
            "--backend",
            "cpu",
            "--material",
            "tin",
            "--model",
            "ashikhmin_shirley",
            "--grid",
            "halfdiff",
            "--res",
            "4,4,4",
            "-o",
            "t.exr",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("anisotropic") && stderr.contains("NTHETA_H,NPHI_H,NTHETA_D,NPHI_D"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "table",
            "--backend",
            "cpu",
            "--grid",
            "halfdiff",
            "--res",
            "4,4",
            "-o",
            "t.exr",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&bad.stderr).contains("NTHETA_H,NTHETA_D,NPHI_D"));
    assert_eq!(bad.status.code(), Some(1));
}
