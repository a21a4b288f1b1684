//! One request, one path: a table asked for through the command line (`lobe table`'s `.npy`),
//! the library in memory ([`lobe::Session::table`]) and the library's writer
//! ([`lobe::Session::write_table`], which the explorer's downloads and Python's `write_table`
//! call) holds the same bits, on both backends. The cases take each way a table is made: every
//! cell evaluated, a reciprocal model's upper triangle with its mirror cells copied, the quarter
//! of a mirror-symmetric full table, and the half/difference grid's mirrored φd rows.

mod common;

use lobe::grid::Grid;
use std::path::Path;

struct Case {
    model: &'static str,
    sets: &'static [&'static str],
    grid: &'static str,
    res: &'static str,
}

const CASES: &[Case] = &[
    // NTHETA_I = NTHETA_O and a reciprocal isotropic model: the upper triangle (§4.5).
    Case {
        model: "microfacet",
        sets: &[
            "distribution=ggx",
            "masking=smith_correlated",
            "fresnel=schlick",
            "f0=0.04",
            "alpha=0.3",
        ],
        grid: "isotropic",
        res: "8,8,16",
    },
    // NTHETA_I ≠ NTHETA_O: every cell evaluated.
    Case {
        model: "cook_torrance",
        sets: &["roughness=0.2"],
        grid: "isotropic",
        res: "6,5,4",
    },
    // NPHI_I a multiple of 4, NPHI_O even: the first quadrant of light directions (§4.6).
    Case {
        model: "ashikhmin_shirley",
        sets: &["nu=10", "nv=200"],
        grid: "full",
        res: "3,8,4,6",
    },
    // The three-axis half/difference grid: each φd row's mirrored half (§4.5).
    Case {
        model: "microfacet",
        sets: &["alpha=0.2"],
        grid: "halfdiff",
        res: "5,4,6",
    },
];

/// The f32 values of a `.npy` file lobe wrote (a little-endian float32 array, header skipped).
fn npy_values(path: &Path) -> Vec<f32> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header = 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    bytes[header..]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

/// The first cell where two tables' bits differ, and how many do.
fn differences(a: &[f32], b: &[f32]) -> (usize, Option<usize>) {
    assert_eq!(a.len(), b.len(), "the tables have different sizes");
    let differ: Vec<usize> = (0..a.len())
        .filter(|&k| a[k].to_bits() != b[k].to_bits())
        .collect();
    (differ.len(), differ.first().copied())
}

fn check_doors(backend: &str, session: &lobe::Session) {
    let dir = tempfile::tempdir().unwrap();
    for (k, case) in CASES.iter().enumerate() {
        let what = format!(
            "{backend}: {} {:?} on {} {}",
            case.model, case.sets, case.grid, case.res
        );
        let sets: Vec<String> = case.sets.iter().map(|s| s.to_string()).collect();
        let params = lobe::resolve_params(case.model, None, &sets).unwrap();
        let grid = Grid::parse(case.grid, case.res).unwrap();

        let cli = dir.path().join(format!("cli{k}.exr"));
        let mut args = vec![
            "table".to_string(),
            "--backend".into(),
            backend.into(),
            "--model".into(),
            case.model.into(),
            "--grid".into(),
            case.grid.into(),
            "--res".into(),
            case.res.into(),
            "-o".into(),
            cli.to_str().unwrap().into(),
        ];
        for s in case.sets {
            args.extend(["--set".to_string(), s.to_string()]);
        }
        let (code, _, err) = common::lobe_run(&args);
        assert_eq!(code, 0, "{what}: lobe table: {err}");
        let from_cli = npy_values(&cli.with_extension("npy"));

        let written = dir.path().join(format!("lib{k}.exr"));
        session
            .write_table(&params, grid, &written, false, &mut |_, _| {})
            .unwrap_or_else(|e| panic!("{what}: write_table: {e}"));
        let from_writer = npy_values(&written.with_extension("npy"));

        let in_memory = session
            .table(&params, &grid, 1 << 20)
            .unwrap_or_else(|e| panic!("{what}: table: {e}"));

        for (name, other) in [
            ("Session::write_table", &from_writer),
            ("Session::table", &in_memory.data().to_vec()),
        ] {
            let (n, first) = differences(&from_cli, other);
            assert_eq!(
                n,
                0,
                "{what}: {name} differs from lobe table's .npy in {n} of {} values, first at \
                 value {first:?}",
                from_cli.len()
            );
        }
    }
}

#[test]
fn a_table_holds_the_same_bits_through_every_door_on_the_cpu() {
    check_doors("cpu", &lobe::Session::cpu());
}

#[test]
fn a_table_holds_the_same_bits_through_every_door_on_the_gpu() {
    let Some(session) = common::gpu_session("table doors on the GPU") else {
        return;
    };
    check_doors("gpu", &session);
}
