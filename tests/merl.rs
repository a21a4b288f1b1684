//! MERL `.binary` files (the MERL BRDF database's format): refused when malformed, read with
//! missing bins as 0 and counted, written from any isotropic model at MERL's bin centres and
//! read back, and evaluated on the GPU (the table as the model's data buffer) in step with the
//! f64 twin of the lookup.

mod common;

use common::Rng;
use glam::DVec3;
use lobe::gpu::Gpu;
use lobe::grid::{direction, half_diff_to_pair, pair_to_half_diff};
use lobe::merl::lookup::{merl_coordinates, merl_nearest};
use lobe::merl::{self, bin, bin_centre, BINS, DIMS, FILE_BYTES, SCALE};
use lobe::model::{ParamSet, Reference};
use lobe::{resolve_params, Evaluator, Session};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A value stored as f/scale and read back as stored × scale: two roundings of f64.
const ROUND_TRIP_RTOL: f64 = 2.0 * f64::EPSILON;
/// A GPU-written file is checked at every GPU_STRIDE-th bin (each check costs 13 reference
/// evaluations, the tolerance model's conditioning).
const GPU_STRIDE: usize = 7;
/// Nearest-bin parity is checked only for pairs whose f64 bin coordinates lie at least this far
/// (in bins) from a bin edge: the GPU's f32 coordinates carry an error of about 180 × 4 ε32 ≈
/// 1e-4 bins (angles to a few ulp, 180 the largest axis scale), so such pairs fall in the same bin.
const EDGE_MARGIN: f64 = 1e-3;
/// Trilinear parity: the f32 coordinates' error (≈ 1e-4 bins, see [`EDGE_MARGIN`]) moves each
/// weight by as much, which moves f by at most that times the largest of the eight bins; plus
/// the f32 sum's rounding.
const TRILINEAR_TOL: f64 = 1e-4;

fn dir() -> tempfile::TempDir {
    tempfile::tempdir().expect("a temporary folder")
}

fn params(model: &str, material: Option<&str>, sets: &[&str]) -> ParamSet {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    resolve_params(model, material, &sets).expect("valid parameters")
}

fn gold() -> ParamSet {
    params("cook_torrance", Some("gold"), &[])
}

/// Writes `p` as `dir/stem.binary` on the CPU.
fn write_cpu(p: &ParamSet, dir: &Path, stem: &str) -> PathBuf {
    let path = dir.join(format!("{stem}.binary"));
    Session::cpu()
        .write_merl(p, &path, &mut |_, _| {})
        .expect("a MERL file");
    path
}

fn lookup(model: lobe::Model, how: &str) -> ParamSet {
    let mut p = ParamSet::defaults(model);
    p.set_text(&format!("lookup={how}")).expect("a lookup");
    p
}

fn header(dims: [i32; 3]) -> Vec<u8> {
    dims.iter().flat_map(|d| d.to_le_bytes()).collect()
}

fn refusal(path: &Path) -> String {
    let e = merl::read(path).expect_err("a bad file");
    let text = e.to_string();
    assert!(
        text.starts_with(&path.display().to_string()),
        "the message names the file: {text}"
    );
    text
}

#[test]
fn bad_files_are_refused_with_their_name_and_the_problem() {
    let d = dir();
    let good_header = header([90, 90, 180]);
    let write = |name: &str, bytes: &[u8]| {
        let p = d.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let mut truncated = good_header.clone();
    truncated.resize(FILE_BYTES - 8, 0);
    let t = refusal(&write("truncated.binary", &truncated));
    assert!(t.contains("truncated") && t.contains("34992012"), "{t}");
    let t = refusal(&write("short.binary", &[1, 2, 3, 4, 5]));
    assert!(t.contains("truncated") && t.contains("header"), "{t}");
    let mut oversized = good_header.clone();
    oversized.resize(FILE_BYTES + 8, 0);
    let t = refusal(&write("oversized.binary", &oversized));
    assert!(t.contains("oversized") && t.contains("8 more"), "{t}");
    let mut dims = header([90, 90, 181]);
    dims.resize(FILE_BYTES, 0);
    let t = refusal(&write("dims.binary", &dims));
    assert!(t.contains("90 x 90 x 181") && t.contains("1458000"), "{t}");
    // Only the product is checked, as MERL's reader checks it.
    let mut reordered = header([180, 90, 90]);
    reordered.resize(FILE_BYTES, 0);
    assert!(merl::read(&write("reordered.binary", &reordered)).is_ok());
    let mut nan = good_header.clone();
    nan.resize(FILE_BYTES, 0);
    let at = 12 + 8 * (BINS + bin(3, 4, 5));
    nan[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    let t = refusal(&write("nan.binary", &nan));
    assert!(
        t.contains("NaN") && t.contains("green bin") && t.contains("theta_h 3"),
        "{t}"
    );
    let t = refusal(&d.path().join("absent.binary"));
    assert!(t.contains("cannot read"), "{t}");
    let t = refusal(d.path());
    assert!(t.contains("not a file"), "{t}");
}

/// Random bytes never panic the parser: short buffers, a valid header with a random length, and
/// random headers; only a whole file of finite values is accepted.
#[test]
fn random_bytes_never_panic_the_parser() {
    let mut rng = Rng(13);
    for round in 0..3000 {
        let len = (rng.next_u64() % 64) as usize;
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
        if round % 3 == 1 {
            bytes.splice(0..bytes.len().min(12), header([90, 90, 180]));
        }
        let header_ok = merl::parse_header(&bytes).is_ok();
        assert!(merl::parse(&bytes).is_err(), "{len} bytes accepted");
        if header_ok {
            assert!(bytes.len() >= 12);
        }
    }
    // Random dimensions: refused unless their product is MERL's.
    for _ in 0..3000 {
        let dims = [0, 1, 2].map(|_| rng.next_u64() as i32);
        let product: i64 = dims.iter().map(|&d| d as i64).product();
        assert_eq!(
            merl::parse_header(&header(dims)).is_ok(),
            product == BINS as i64
        );
    }
    // A whole file of random bit patterns: some are NaN, and the parser says where.
    let mut bytes = header([90, 90, 180]);
    bytes.extend((0..3 * BINS).flat_map(|_| rng.next_u64().to_le_bytes()));
    let e = merl::parse(&bytes).expect_err("random doubles include NaNs");
    assert!(e.contains("finite"), "{e}");
}

/// Negative stored values are missing data: counted, read as 0, and 0 on both backends.
#[test]
fn missing_bins_read_as_zero_and_are_counted() {
    let d = dir();
    let f = 0.25;
    let mut bytes = merl::encode(&vec![f; 3 * BINS]);
    let holes = [
        (bin(10, 20, 30), 0),
        (bin(10, 20, 30), 2),
        (bin(50, 5, 170), 1),
    ];
    for &(k, c) in &holes {
        let at = 12 + 8 * (c * BINS + k);
        bytes[at..at + 8].copy_from_slice(&(-1.0f64).to_le_bytes());
    }
    let path = d.path().join("holes.binary");
    std::fs::write(&path, &bytes).unwrap();
    let table = merl::read(&path).expect("a MERL file");
    assert_eq!(table.missing, holes.len());
    assert_eq!(table.values[bin(10, 20, 30)], 0.0);
    assert!((table.values[BINS + bin(10, 20, 30)] - f).abs() <= ROUND_TRIP_RTOL * f);
    let loaded = merl::model::load(&path).expect("a model");
    assert!(loaded.first && loaded.missing == 3);
    assert!(loaded.model.description().contains("3 of 4374000"));
    assert_eq!(loaded.model.name(), "holes");
    let again = merl::model::load(&path).expect("the same model");
    assert!(!again.first && again.model == loaded.model);

    let pairs: Vec<(DVec3, DVec3)> = [(10, 20, 30), (50, 5, 170), (11, 20, 30)]
        .iter()
        .map(|&(h, dd, p)| {
            let [th, td, pd] = bin_centre(h, dd, p);
            half_diff_to_pair(th, 0.0, td, pd)
        })
        .collect();
    let p = ParamSet::defaults(loaded.model);
    let cpu = Evaluator::cpu().eval_pairs(&p, &pairs).expect("cpu");
    let expect = [[0.0, f, 0.0], [f, 0.0, f], [f, f, f]];
    for (got, want) in cpu.iter().zip(expect) {
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() <= ROUND_TRIP_RTOL * f, "{got:?}");
        }
    }
    let Some(dev) = common::gpu_device("missing MERL bins on the GPU") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let g = Evaluator::gpu(&gpu).eval_pairs(&p, &pairs).expect("gpu");
    for (got, want) in g.iter().zip(expect) {
        assert_eq!(got.map(|v| v as f32), want.map(|v| v as f32), "{got:?}");
    }
    common::assert_validation_clean(&gpu, "missing MERL bins on the GPU");
}

/// A model written as a MERL file and read back holds f at every bin centre, and the nearest
/// lookup at a bin centre gives that bin's value. A GPU-written file agrees with the CPU's.
#[test]
fn written_files_read_back_at_their_bin_centres() {
    let d = dir();
    let p = gold();
    let path = write_cpu(&p, d.path(), "gold_round_trip");
    assert_eq!(std::fs::metadata(&path).unwrap().len(), FILE_BYTES as u64);
    let table = merl::read(&path).expect("its own file");
    assert_eq!(table.missing, 0);
    let r = Reference::new(&p, false);
    let mut rng = Rng(7);
    let mut pairs = Vec::new();
    let mut want = Vec::new();
    for _ in 0..4000 {
        let (h, dd, pp) = (
            (rng.next_u64() % 90) as usize,
            (rng.next_u64() % 90) as usize,
            (rng.next_u64() % 180) as usize,
        );
        let [th, td, pd] = bin_centre(h, dd, pp);
        let (wi, wo) = half_diff_to_pair(th, 0.0, td, pd);
        let f = r.eval(wi, wo);
        for c in 0..3 {
            let got = table.values[c * BINS + bin(h, dd, pp)];
            assert!(
                (got - f[c]).abs() <= ROUND_TRIP_RTOL * f[c].abs(),
                "bin {h} {dd} {pp} channel {c}: read {got}, wrote {}",
                f[c]
            );
        }
        pairs.push((wi, wo));
        want.push(f);
    }
    let model = merl::model::load(&path).expect("a model").model;
    let f = Evaluator::cpu()
        .eval_pairs(&lookup(model, "nearest"), &pairs)
        .expect("cpu");
    for (got, w) in f.iter().zip(&want) {
        for c in 0..3 {
            assert!((got[c] - w[c]).abs() <= ROUND_TRIP_RTOL * w[c].abs());
        }
    }

    let Some(dev) = common::gpu_device("MERL file written on the GPU") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let gpu_path = d.path().join("gold_gpu.binary");
    merl::write::write(
        &Evaluator::gpu(&gpu),
        (&p).into(),
        &gpu_path,
        &mut |_, _| {},
    )
    .expect("a GPU-written file");
    let g = merl::read(&gpu_path).expect("its own file");
    // The GPU's f at each bin centre against the f64 reference, under the parity tests'
    // tolerance model (docs/design.md §10).
    let p32 = p.rounded_to_f32();
    let r32 = Reference::new(&p32, false);
    for h in 0..DIMS[0] {
        for k in (bin(h, 0, 0)..bin(h + 1, 0, 0)).step_by(GPU_STRIDE) {
            let (dd, pp) = (k / DIMS[2] % DIMS[1], k % DIMS[2]);
            let [th, td, pd] = bin_centre(h, dd, pp);
            let (wi, wo) = half_diff_to_pair(th, 0.0, td, pd);
            let c = r32.eval(wi, wo);
            let allowed = lobe::tolerance::parity_tolerance(&p32, &r32, wi, wo, c);
            for ch in 0..3 {
                let a = g.values[ch * BINS + k];
                assert!(
                    (a - c[ch]).abs() <= allowed[ch],
                    "bin {h} {dd} {pp} channel {ch}: GPU {a}, CPU {}, allowed {}",
                    c[ch],
                    allowed[ch]
                );
            }
        }
    }
    common::assert_validation_clean(&gpu, "MERL file written on the GPU");
}

/// Random pairs over the hemisphere, keeping those whose f64 bin coordinates lie at least
/// [`EDGE_MARGIN`] from every bin edge.
fn pairs_off_the_edges(n: usize, seed: u64) -> Vec<(DVec3, DVec3)> {
    let mut rng = Rng(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let wi = direction(rng.range(0.0, 1.55), rng.range(0.0, 6.28));
        let wo = direction(rng.range(0.0, 1.55), rng.range(0.0, 6.28));
        let [th, _, td, pd] = pair_to_half_diff(wi, wo);
        let u = merl_coordinates(th, td, pd);
        if u.iter().all(|x| (x - x.round()).abs() >= EDGE_MARGIN) {
            out.push((wi, wo));
        }
    }
    out
}

/// The GPU lookup against its f64 twin on one table: nearest gives the f64 value rounded to f32
/// (the GPU table holds exactly that), trilinear agrees within [`TRILINEAR_TOL`] of the largest
/// of the eight bins it reads.
#[test]
fn the_gpu_lookup_matches_the_f64_twin() {
    let d = dir();
    let path = write_cpu(&gold(), d.path(), "gold_parity");
    let table = merl::read(&path).expect("a MERL file");
    let model = merl::model::load(&path).expect("a model").model;
    let Some(dev) = common::gpu_device("MERL lookup parity") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let pairs = pairs_off_the_edges(20_000, 11);
    let near = lookup(model, "nearest");
    let cpu = Evaluator::cpu().eval_pairs(&near, &pairs).unwrap();
    let g = Evaluator::gpu(&gpu).eval_pairs(&near, &pairs).unwrap();
    for (k, (a, b)) in g.iter().zip(&cpu).enumerate() {
        assert_eq!(
            a.map(|v| v as f32),
            b.map(|v| v as f32),
            "nearest at pair {k} {:?}",
            pairs[k]
        );
    }
    let tri = lookup(model, "trilinear");
    let cpu = Evaluator::cpu().eval_pairs(&tri, &pairs).unwrap();
    let g = Evaluator::gpu(&gpu).eval_pairs(&tri, &pairs).unwrap();
    let mut worst: f64 = 0.0;
    for (k, (a, b)) in g.iter().zip(&cpu).enumerate() {
        let (wi, wo) = pairs[k];
        let [th, _, td, pd] = pair_to_half_diff(wi, wo);
        let u = merl_coordinates(th, td, pd);
        // The eight bins the trilinear lookup reads, for the scale of its error.
        let mut scale: f64 = 0.0;
        for corner in 0..8 {
            let step = |bit: usize| if corner >> bit & 1 == 1 { 0.5 } else { -0.5 };
            let v = [
                u[0] + step(0),
                u[1] + step(1),
                (u[2] + step(2)).rem_euclid(DIMS[2] as f64),
            ];
            scale = scale.max(merl_nearest(&table.values, v).max_element());
        }
        for c in 0..3 {
            let err = (a[c] - b[c]).abs();
            worst = worst.max(err / scale.max(f64::MIN_POSITIVE));
            assert!(
                err <= TRILINEAR_TOL * scale,
                "trilinear at pair {k} {:?} channel {c}: GPU {}, CPU {}, bins up to {scale}",
                pairs[k],
                a[c],
                b[c]
            );
        }
    }
    eprintln!("trilinear: worst GPU-CPU difference {worst:.2e} of the largest bin read");
    common::assert_validation_clean(&gpu, "MERL lookup parity");
}

/// A file holding ρ/π in every bin (Lambert's f, also in the bins whose centre lies below the
/// horizon, which a file written from Lambert holds as 0) has directional albedo ρ by a fixed
/// rule on both backends: the data buffer reaches the albedo kernel.
#[test]
fn a_constant_file_gives_its_albedo_on_both_backends() {
    let d = dir();
    let rho = [0.2, 0.5, 0.8];
    let values: Vec<f64> = (0..3 * BINS)
        .map(|k| rho[k / BINS] * std::f64::consts::FRAC_1_PI)
        .collect();
    let path = d.path().join("constant_albedo.binary");
    std::fs::write(&path, merl::encode(&values)).unwrap();
    let model = merl::model::load(&path).expect("a model").model;
    let s = lobe::AlbedoSettings {
        method: lobe::integrate::Method::Gauss,
        samples: 4096,
        seed: lobe::integrate::DEFAULT_SEED,
        white_furnace: false,
    };
    for how in ["nearest", "trilinear"] {
        let m = lookup(model, how);
        let e = lobe::integrate::directional(&Evaluator::cpu(), &m, &s, &[(0.6, 0.0)]).unwrap();
        for c in 0..3 {
            // The Gauss rule integrates a constant f·cos exactly, to rounding.
            assert!(
                (e[0].albedo[c] - rho[c]).abs() < 1e-12,
                "{how}: {:?}",
                e[0].albedo
            );
        }
    }
    let Some(dev) = common::gpu_device("MERL albedo on the GPU") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let e = lobe::integrate::directional(
        &Evaluator::gpu(&gpu),
        &lookup(model, "trilinear"),
        &s,
        &[(0.6, 0.0)],
    )
    .expect("gpu albedo");
    for c in 0..3 {
        // f32 nodes and sums: the albedo kernel's f32 partial sums, as tests/runtime_model.rs.
        assert!((e[0].albedo[c] - rho[c]).abs() < 1e-5, "{:?}", e[0].albedo);
    }
    common::assert_validation_clean(&gpu, "MERL albedo on the GPU");
}

/// The parameter block the host writes has the layout merl.glsl declares.
#[test]
fn the_parameter_block_matches_the_glsl() {
    let words = lobe::model::kernels::spirv("pairs", "merl").expect("the MERL pairs kernel");
    let glsl = lobe::gpu::spirv::struct_layout(words, "MerlParams").expect("struct MerlParams");
    assert_eq!(glsl.members, vec![("lookup".to_string(), 0)]);
    let (layout, size) = lobe::model::runtime::std430_layout(&[merl::model::LOOKUP_PARAM]);
    assert_eq!(layout, vec![("lookup", 0)]);
    assert_eq!(glsl.array_stride, Some(size as u32));
    assert_eq!(SCALE, [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0]);
}

fn lobe() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lobe"));
    c.env(
        "VK_ICD_FILENAMES",
        "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json",
    );
    c
}

/// The command line: `lobe table --format merl` writes a file, `--model PATH.binary` reads it
/// (with a note of its missing values), and bad requests are refused before any file appears.
#[test]
fn the_command_line_writes_and_reads_merl_files() {
    let d = dir();
    // Arguments split at spaces (the temporary folder's path has none).
    let run = |line: String| {
        lobe()
            .args(line.split_whitespace())
            .output()
            .expect("lobe runs")
    };
    let out = d.path().join("lambert_cli.binary");
    let out = out.display();
    let write = "table --grid halfdiff --format merl --backend cpu";
    let o = run(format!("{write} --model lambert --set albedo=0.3 -o {out}"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(format!(
        "eval --model {out} --backend cpu --wi 31.3,0 --wo 47.1,97 --format json"
    ));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("as model 'lambert_cli' (0 of 4374000 values missing"),
        "{err}"
    );
    let text = String::from_utf8_lossy(&o.stdout);
    let want = format!("{}", 0.3 * std::f64::consts::FRAC_1_PI);
    assert!(text.contains(&want[..12]), "{text} lacks {want}");

    let bad = d.path().join("refused.binary");
    let bad = bad.display();
    for (args, says) in [
        ("--grid isotropic --format merl", "give --grid halfdiff"),
        ("--grid halfdiff --format merl --res 90,90,90", "90,90,180"),
        (
            "--grid halfdiff --format merl --model ashikhmin_shirley --set nu=10",
            "anisotropic",
        ),
    ] {
        let o = run(format!("table --backend cpu -o {bad} {args}"));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(says), "{args}: {err}");
        // No grid of a MERL file holds an anisotropic BRDF: none is suggested.
        assert!(!err.contains("NTHETA_H,NPHI_H"), "{args}: {err}");
        assert!(
            !d.path().join("refused.binary").exists(),
            "{args} left a file"
        );
    }
    let o = run(format!("{write} -o {}", d.path().join("t.exr").display()));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("must end in .binary"),
        "{err}"
    );
    let short = d.path().join("bad.binary");
    std::fs::write(&short, header([90, 90, 180])).unwrap();
    let o = run(format!(
        "eval --model {} --wi 10,0 --wo 20,0",
        short.display()
    ));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("bad.binary: truncated"),
        "{err}"
    );
}

/// A scene names a MERL file as a material's model, relative to the scene's folder, and sets its
/// lookup like any parameter.
#[test]
fn a_scene_takes_a_merl_file_as_a_model() {
    let d = dir();
    let values = vec![0.1; 3 * BINS];
    std::fs::write(d.path().join("scene_flat.binary"), merl::encode(&values)).unwrap();
    let scene = d.path().join("s.toml");
    let text = "name = \"s\"\n[[materials]]\nname = \"m\"\nmodel = \"scene_flat.binary\"\nparams = { lookup = \"trilinear\" }\n[[albedos]]\nmaterial = \"m\"\noutput = \"m.json\"\n";
    std::fs::write(&scene, text).unwrap();
    let s = lobe::scene::load(&scene).unwrap_or_else(|e| panic!("{e:#}"));
    let p = &s.materials[0].params;
    assert_eq!(p.model().name(), "scene_flat");
    assert_eq!(p.get("lookup").to_string(), "trilinear");
    std::fs::write(&scene, text.replace("scene_flat", "absent")).unwrap();
    let e = format!("{:#}", lobe::scene::load(&scene).unwrap_err());
    assert!(
        e.contains("absent.binary: cannot read it") && e.contains(":4:"),
        "{e}"
    );
}
