//! Table files round trip (docs/design.md §4): `lobe table` writes an EXR mosaic, a `.npy` and a
//! JSON sidecar; the crate's readers (`lobe::table::read_exr`, `read_npy`) bring back the same
//! values, the EXR's pixels sit where its documented layout says, the headers and the sidecar
//! describe the table, and every cell equals `lobe eval --pairs` at the same cell-centred angles,
//! on the GPU (the table kernel against the pairs kernel) and on the CPU reference.

use lobe::grid::Grid;
use lobe::table::{read_exr, read_npy, TableData};
use lobe::{resolve_params, ParamSet};
use std::path::{Path, PathBuf};
use std::process::Command;

/// EXR against npy: both hold the same float32 values and the EXR is written with a lossless
/// compression (`Encoding::FAST_LOSSLESS`, float32 channels), so they must be bit-identical: no
/// tolerance at all.
const EXR_VS_NPY_ATOL: f32 = 0.0;

/// GPU table against GPU `eval --pairs`, relative part. Both kernels call the same GLSL model
/// functions in f32, but their f32 directions may differ by ~1 ulp: the table converts the cell's
/// radians to a direction in f64 and rounds it, while eval reads the degrees printed in the CSV,
/// converts them back to radians (one more f64 rounding) and then builds and rounds the direction.
/// One f32 ulp of a unit vector turns it by ~6e-8 rad; f changes by that times |d ln f / dθ|,
/// which for the lobes used here (Lambert, Oren–Nayar, Cook–Torrance with roughness ≥ 0.3, where
/// |d ln D / dθh| ≲ 2 tanθh / m² ≈ 60 over the cells) stays below ~4e-6; the two kernels may also
/// contract or order their f32 arithmetic differently (a few ulp, ~1e-6). 2e-5 leaves a margin of
/// about 5 over that; sharper lobes (Blinn–Phong at N = 8192, mirror-like Phong) would need more
/// and are not used here.
const GPU_PAIRS_RTOL: f64 = 2e-5;
/// GPU table against GPU `eval --pairs`, absolute part, as a fraction of the table's largest
/// value: where f is tiny next to the peak (Cook–Torrance far from the specular direction with
/// diffuse = 0) the relative error of f32 exp/pow is larger, but such values do not matter to
/// anyone reading the table.
const GPU_PAIRS_ATOL_OF_MAX: f64 = 1e-6;
/// CPU table against CPU `eval --pairs`: both evaluate the f64 reference; the table rounds to
/// float32, eval prints the f64. The f64 directions may differ by an ulp (see above), which moves
/// f by ~1e-14 relative and can flip the f32 rounding: one f32 ulp, so 2 f32 epsilons.
const CPU_PAIRS_RTOL: f64 = 2.0 * f32::EPSILON as f64;

/// GPU tests do not hide (project policy): without a Vulkan device they fail with the install
/// hint; only LOBE_SKIP_GPU=1 skips them. Returns false when skipping.
fn gpu_or_skip(test: &str) -> bool {
    if std::env::var("LOBE_SKIP_GPU").is_ok_and(|v| v == "1") {
        eprintln!("{test}: skipped because LOBE_SKIP_GPU=1");
        return false;
    }
    true
}

/// A table to write and check.
struct Case {
    model: &'static str,
    material: Option<&'static str>,
    sets: &'static [&'static str],
    grid: &'static str,
    res: &'static str,
}

impl Case {
    fn model_args(&self, backend: &str) -> Vec<String> {
        let mut v = vec![
            "--backend".to_string(),
            backend.to_string(),
            "--model".to_string(),
            self.model.to_string(),
        ];
        if let Some(m) = self.material {
            v.extend(["--material".to_string(), m.to_string()]);
        }
        for s in self.sets {
            v.extend(["--set".to_string(), s.to_string()]);
        }
        v
    }

    fn params(&self) -> ParamSet {
        let sets: Vec<String> = self.sets.iter().map(|s| s.to_string()).collect();
        resolve_params(self.model, self.material, &sets)
            .unwrap_or_else(|e| panic!("{}: invalid test parameters: {e}", self.label()))
    }

    fn grid(&self) -> Grid {
        Grid::parse(self.grid, self.res).unwrap_or_else(|e| panic!("{}: {e}", self.label()))
    }

    fn label(&self) -> String {
        format!(
            "{} (material {}, set {:?}) on the {} grid {}",
            self.model,
            self.material.unwrap_or("none"),
            self.sets,
            self.grid,
            self.res
        )
    }
}

/// Runs the built binary; on failure, panics with its stderr and, for the GPU backend, the policy.
fn lobe(cwd: &Path, args: &[String], gpu: bool) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("could not start {}: {e}", env!("CARGO_BIN_EXE_lobe")));
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        let hint = if gpu {
            format!(
                "\nthis test needs a Vulkan device; {}\n(set LOBE_SKIP_GPU=1 to skip GPU tests)",
                lobe::gpu::INSTALL_HINT
            )
        } else {
            String::new()
        };
        panic!(
            "`lobe {}`: expected success, got {}\nstderr:\n{stderr}{hint}",
            args.join(" "),
            out.status
        );
    }
    String::from_utf8(out.stdout).expect("utf-8 stdout")
}

/// Every multi-index of `shape` in row-major order.
fn indices(shape: &[usize]) -> Vec<Vec<usize>> {
    let mut out = vec![vec![]];
    for &n in shape {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                (0..n).map(move |k| {
                    let mut v = prefix.clone();
                    v.push(k);
                    v
                })
            })
            .collect();
    }
    out
}

/// Writes the table of `case` on `backend` into `dir` and returns the EXR path.
fn write_table(case: &Case, dir: &Path, backend: &str) -> PathBuf {
    let exr = dir.join("table.exr");
    let mut args = vec!["table".to_string()];
    args.extend(case.model_args(backend));
    args.extend(
        [
            "--grid",
            case.grid,
            "--res",
            case.res,
            "-o",
            exr.to_str().expect("utf-8 path"),
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    lobe(dir, &args, backend == "gpu");
    exr
}

/// Both readers agree bit for bit and have the grid's shape; returns the npy data.
fn check_readers(case: &Case, exr_path: &Path) -> TableData {
    let label = case.label();
    let mut shape = case.grid().shape();
    shape.push(3);
    let npy_path = exr_path.with_extension("npy");
    let npy = read_npy(&npy_path).unwrap_or_else(|e| panic!("{label}: read_npy: {e:#}"));
    let exr = read_exr(exr_path).unwrap_or_else(|e| panic!("{label}: read_exr: {e:#}"));
    assert_eq!(
        npy.shape, shape,
        "{label}: expected npy shape {shape:?}, got {:?}",
        npy.shape
    );
    assert_eq!(
        exr.shape, shape,
        "{label}: expected EXR shape {shape:?}, got {:?}",
        exr.shape
    );
    let n: usize = shape.iter().product();
    assert_eq!(
        npy.values.len(),
        n,
        "{label}: expected {n} npy values, got {}",
        npy.values.len()
    );
    assert_eq!(
        exr.values.len(),
        n,
        "{label}: expected {n} EXR values, got {}",
        exr.values.len()
    );
    let mut nonzero = 0;
    for (k, (&a, &b)) in npy.values.iter().zip(&exr.values).enumerate() {
        assert!(
            a.is_finite() && a >= 0.0,
            "{label}: value {k} (cell {}, channel {}) of the npy: expected finite and >= 0, got {a}",
            k / 3,
            k % 3
        );
        assert!(
            (a - b).abs() <= EXR_VS_NPY_ATOL,
            "{label}: value {k} (cell {}, channel {}): expected the EXR to hold the npy's {a:e}, \
             got {b:e} (difference {:e}, allowed {EXR_VS_NPY_ATOL:e})",
            k / 3,
            k % 3,
            (a - b).abs()
        );
        nonzero += usize::from(a > 0.0);
    }
    assert!(
        nonzero > 0,
        "{label}: expected some non-zero values, got an all-zero table"
    );

    // The header names the table.
    let attr = |key: &str| {
        exr.attributes
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| {
                panic!(
                    "{label}: expected the EXR attribute {key}, got {:?}",
                    exr.attributes
                )
            })
    };
    assert_eq!(
        attr("lobe.model"),
        case.model,
        "{label}: expected lobe.model = {}",
        case.model
    );
    assert_eq!(
        attr("lobe.grid"),
        case.grid,
        "{label}: expected lobe.grid = {}",
        case.grid
    );
    let shape_text = case
        .grid()
        .shape()
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(",");
    assert_eq!(
        attr("lobe.shape"),
        shape_text,
        "{label}: expected lobe.shape = {shape_text}"
    );
    for key in ["lobe.parameters", "lobe.layout", "lobe.units"] {
        assert!(!attr(key).is_empty(), "{label}: expected a non-empty {key}");
    }
    check_mosaic(case, exr_path, &npy);
    npy
}

/// Reads the EXR with the exr crate directly (not through `read_exr`, which shares the writer's
/// mosaic function) and checks each pixel against the layout documented in `lobe::table`:
/// full: x = φi·NPHI_O + φo, y = θi·NTHETA_O + θo; isotropic: x = θi·NDPHI + Δφ, y = θo.
fn check_mosaic(case: &Case, exr_path: &Path, npy: &TableData) {
    use exr::prelude::*;
    let label = case.label();
    let image = read_first_flat_layer_from_file(exr_path)
        .unwrap_or_else(|e| panic!("{label}: reading {}: {e}", exr_path.display()));
    let layer = &image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let grid = case.grid();
    let shape = grid.shape();
    for idx in indices(&shape) {
        let (x, y) = match grid {
            Grid::Full {
                n_theta_o, n_phi_o, ..
            } => (idx[1] * n_phi_o + idx[3], idx[0] * n_theta_o + idx[2]),
            Grid::Isotropic { n_dphi, .. } => (idx[0] * n_dphi + idx[2], idx[1]),
            Grid::HalfDiff { n_phi_d, .. } => (idx[0] * n_phi_d + idx[2], idx[1]),
            Grid::HalfDiffFull {
                n_theta_d, n_phi_d, ..
            } => (idx[1] * n_phi_d + idx[3], idx[0] * n_theta_d + idx[2]),
        };
        assert!(
            x < w && y < h,
            "{label}: cell {idx:?} maps to pixel ({x}, {y}) outside the {w}x{h} image"
        );
        let cell = idx.iter().zip(&shape).fold(0, |acc, (&i, &n)| acc * n + i);
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            let ch = layer
                .channel_data
                .list
                .iter()
                .find(|ch| ch.name == **name)
                .unwrap_or_else(|| panic!("{label}: expected an EXR channel {name}"));
            let got = ch.sample_data.value_by_flat_index(y * w + x).to_f32();
            let want = npy.values[cell * 3 + c];
            assert!(
                got == want,
                "{label}: cell {idx:?} channel {name}: expected {want:e} at pixel ({x}, {y}) of \
                 the documented layout, got {got:e}"
            );
        }
    }
}

/// The sidecar describes the table.
fn check_sidecar(case: &Case, exr_path: &Path, backend_prefix: &str) {
    let label = case.label();
    let path = exr_path.with_extension("json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{label}: reading {}: {e}", path.display()));
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap_or_else(|e| {
        panic!(
            "{label}: expected JSON in {} ({e}), got:\n{text}",
            path.display()
        )
    });
    assert_eq!(
        doc["model"], case.model,
        "{label}: expected sidecar model {}, got {}",
        case.model, doc["model"]
    );
    // The parameters are short decimals (material presets and --set values), which serde_json
    // parses exactly, so the comparison is exact.
    let params = case.params().to_json();
    assert_eq!(
        doc["parameters"], params,
        "{label}: expected sidecar parameters {params}, got {}",
        doc["parameters"]
    );
    assert_eq!(
        doc["grid"], case.grid,
        "{label}: expected sidecar grid {}, got {}",
        case.grid, doc["grid"]
    );
    let mut shape = case.grid().shape();
    shape.push(3);
    assert_eq!(
        doc["shape"],
        serde_json::json!(shape),
        "{label}: expected sidecar shape {shape:?}, got {}",
        doc["shape"]
    );
    let axes = doc["axes"].as_array().unwrap_or_else(|| {
        panic!(
            "{label}: expected a sidecar axes array, got {}",
            doc["axes"]
        )
    });
    let sizes: Vec<u64> = axes.iter().filter_map(|a| a["size"].as_u64()).collect();
    let want_sizes: Vec<u64> = shape.iter().map(|&n| n as u64).collect();
    assert_eq!(
        sizes, want_sizes,
        "{label}: expected axis sizes {want_sizes:?}, got {sizes:?} in {}",
        doc["axes"]
    );
    let names: Vec<&str> = axes.iter().filter_map(|a| a["name"].as_str()).collect();
    let want_names: &[&str] = match case.grid {
        "full" => &["theta_i", "phi_i", "theta_o", "phi_o", "rgb"],
        _ => &["theta_i", "theta_o", "delta_phi", "rgb"],
    };
    assert_eq!(
        names, want_names,
        "{label}: expected axis names {want_names:?}, got {names:?}"
    );
    assert_eq!(
        doc["white_furnace"], false,
        "{label}: expected white_furnace false, got {}",
        doc["white_furnace"]
    );
    assert_eq!(
        doc["exr"],
        exr_path
            .file_name()
            .and_then(|n| n.to_str())
            .expect("file name"),
        "{label}: expected the sidecar to name the EXR, got {}",
        doc["exr"]
    );
    let backend = doc["backend"].as_str().unwrap_or("");
    assert!(
        backend.starts_with(backend_prefix),
        "{label}: expected the sidecar backend to start with '{backend_prefix}', got '{backend}'"
    );
}

/// Every cell's angles in degrees, in npy order, written as a --pairs CSV; evaluates it with
/// `lobe eval --pairs` and returns the rgb rows.
fn eval_cells(case: &Case, dir: &Path, backend: &str) -> Vec<[f64; 3]> {
    let grid = case.grid();
    let mut csv = String::from("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n");
    for idx in indices(&grid.shape()) {
        // Rust prints f64 in its shortest round-trip form: the CSV carries the exact degrees.
        let [ti, pi, to, po] = grid.angles(&idx).map(f64::to_degrees);
        csv += &format!("{ti},{pi},{to},{po}\n");
    }
    let pairs = dir.join("cells.csv");
    std::fs::write(&pairs, csv).expect("write cells.csv");
    let mut args = vec!["eval".to_string()];
    args.extend(case.model_args(backend));
    args.extend([
        "--pairs".to_string(),
        pairs.to_str().expect("utf-8 path").to_string(),
    ]);
    let out = lobe(dir, &args, backend == "gpu");
    let mut lines = out.lines();
    assert_eq!(
        lines.next(),
        Some("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,r,g,b"),
        "{}: expected the CSV header from eval",
        case.label()
    );
    lines
        .map(|line| {
            let f: Vec<f64> = line
                .split(',')
                .map(|s| {
                    s.parse()
                        .unwrap_or_else(|e| panic!("eval row '{line}': {e}"))
                })
                .collect();
            assert_eq!(f.len(), 7, "expected 7 fields, got '{line}'");
            [f[4], f[5], f[6]]
        })
        .collect()
}

/// Table cells against eval rows: |table − eval| ≤ atol + rtol·|eval| per channel.
fn compare_to_eval(
    case: &Case,
    table: &TableData,
    evals: &[[f64; 3]],
    rtol: f64,
    atol_of_max: f64,
) {
    let label = case.label();
    let grid = case.grid();
    let cells = indices(&grid.shape());
    assert_eq!(
        evals.len(),
        cells.len(),
        "{label}: expected {} eval rows, got {}",
        cells.len(),
        evals.len()
    );
    let max = table.values.iter().fold(0.0f64, |m, &v| m.max(v as f64));
    let atol = atol_of_max * max;
    let mut worst = 0.0f64;
    for (cell, (idx, e)) in cells.iter().zip(evals).enumerate() {
        for (c, &want) in e.iter().enumerate() {
            let t = table.values[cell * 3 + c] as f64;
            let diff = (t - want).abs();
            let allowed = atol + rtol * want.abs();
            let [ti, pi, to, po] = grid.angles(idx).map(f64::to_degrees);
            assert!(
                diff <= allowed,
                "{label}: cell {idx:?} (theta_i {ti} deg, phi_i {pi} deg, theta_o {to} deg, \
                 phi_o {po} deg) channel {c}: expected eval's {want:e}, the table holds {t:e}; \
                 difference {diff:e} (relative {:e}), allowed {allowed:e} (rtol {rtol:e}, atol {atol:e})",
                diff / want.abs().max(f64::MIN_POSITIVE)
            );
            if want.abs() > atol {
                worst = worst.max(diff / want.abs());
            }
        }
    }
    eprintln!("{label}: largest relative difference table vs eval {worst:e} (allowed {rtol:e})");
}

fn gpu_round_trip(test: &str, case: &Case) {
    if !gpu_or_skip(test) {
        return;
    }
    let dir = tempfile::tempdir().expect("temporary folder");
    let exr = write_table(case, dir.path(), "gpu");
    let table = check_readers(case, &exr);
    check_sidecar(case, &exr, "gpu");
    let evals = eval_cells(case, dir.path(), "gpu");
    compare_to_eval(case, &table, &evals, GPU_PAIRS_RTOL, GPU_PAIRS_ATOL_OF_MAX);
}

#[test]
fn gpu_lambert_gold_full_grid() {
    gpu_round_trip(
        "gpu_lambert_gold_full_grid",
        &Case {
            model: "lambert",
            material: Some("gold"),
            sets: &[],
            grid: "full",
            res: "4,3,5,6",
        },
    );
}

#[test]
fn gpu_cook_torrance_full_grid() {
    gpu_round_trip(
        "gpu_cook_torrance_full_grid",
        &Case {
            model: "cook_torrance",
            material: None,
            sets: &["roughness=0.3", "diffuse=0.1,0.2,0.3"],
            grid: "full",
            res: "4,3,5,6",
        },
    );
}

#[test]
fn gpu_oren_nayar_granite_isotropic_grid() {
    gpu_round_trip(
        "gpu_oren_nayar_granite_isotropic_grid",
        &Case {
            model: "oren_nayar",
            material: Some("granite"),
            sets: &[],
            grid: "isotropic",
            res: "4,5,6",
        },
    );
}

#[test]
fn gpu_cook_torrance_tin_isotropic_grid() {
    gpu_round_trip(
        "gpu_cook_torrance_tin_isotropic_grid",
        &Case {
            model: "cook_torrance",
            material: Some("tin"),
            sets: &["roughness=0.3"],
            grid: "isotropic",
            res: "4,5,6",
        },
    );
}

/// The same round trip on the CPU reference: needs no Vulkan device, so the file formats stay
/// checked where LOBE_SKIP_GPU=1.
#[test]
fn cpu_round_trip_both_grids() {
    for case in [
        Case {
            model: "cook_torrance",
            material: None,
            sets: &["roughness=0.3"],
            grid: "full",
            res: "4,3,5,6",
        },
        Case {
            model: "oren_nayar",
            material: Some("granite"),
            sets: &[],
            grid: "isotropic",
            res: "4,5,6",
        },
    ] {
        let dir = tempfile::tempdir().expect("temporary folder");
        let exr = write_table(&case, dir.path(), "cpu");
        let table = check_readers(&case, &exr);
        check_sidecar(&case, &exr, "cpu");
        let evals = eval_cells(&case, dir.path(), "cpu");
        compare_to_eval(&case, &table, &evals, CPU_PAIRS_RTOL, 0.0);
    }
}
