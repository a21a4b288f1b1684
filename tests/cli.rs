//! The `lobe` binary on bad and good input. Every bad input must exit non-zero with a sentence on
//! stderr that names the problem (the parameter, the value, the valid range or list), never panic,
//! and leave no file behind (neither an output nor a `.lobe-*.partial` temporary). The good inputs
//! check the shape of `lobe models`, `lobe eval` (CSV, JSON, --pairs) against the library.
//! Everything here runs on the CPU reference (`--backend cpu`) and needs no Vulkan device.

use lobe::grid::direction_deg;
use lobe::model::{Model, Reference};
use lobe::{material, resolve_params};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Relative tolerance of a value read back from `--format json`. The binary prints the f64 in its
/// shortest round-trip form, but serde_json's default float parser (without the
/// `float_roundtrip` feature) may land one or two ulp away from the correctly rounded value; a few
/// f64 epsilons cover that and nothing else. (The CSV path is compared exactly.)
const JSON_PARSE_RTOL: f64 = 4.0 * f64::EPSILON;

/// Exit status of a Rust panic in `main`; a bad input must never produce it.
const PANIC_EXIT_CODE: i32 = 101;

struct Output {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    args: String,
}

/// Runs the built binary with `args` in the folder `cwd`.
fn lobe_in(cwd: &Path, args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("could not start {}: {e}", env!("CARGO_BIN_EXE_lobe")));
    Output {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        args: args.join(" "),
    }
}

/// Every name in `dir` (hidden ones included, so a `.lobe-*.partial` shows up).
fn listing(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("listing {}: {e}", dir.display()))
        .map(|e| {
            e.expect("directory entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect()
}

/// Runs `lobe args` in `dir` and checks that it failed cleanly: a non-zero exit that is not a
/// panic or a signal, every text of `needles` on stderr (case-insensitive), and no new name in
/// `dir` nor in any folder of `watch`.
fn assert_fails_in(dir: &Path, watch: &[&Path], args: &[&str], needles: &[&str]) -> Output {
    let mut folders: Vec<PathBuf> = vec![dir.to_path_buf()];
    folders.extend(watch.iter().map(|p| p.to_path_buf()));
    let before: Vec<BTreeSet<String>> = folders.iter().map(|f| listing(f)).collect();
    let out = lobe_in(dir, args);
    assert!(
        matches!(out.code, Some(c) if c != 0 && c != PANIC_EXIT_CODE),
        "`lobe {}`: expected a clean failure (exit code not 0, not {PANIC_EXIT_CODE}, not a signal), \
         got exit code {:?}\nstdout:\n{}\nstderr:\n{}",
        out.args,
        out.code,
        out.stdout,
        out.stderr
    );
    assert!(
        !out.stderr.contains("panicked") && !out.stderr.contains("RUST_BACKTRACE"),
        "`lobe {}`: expected an error message, got a panic:\n{}",
        out.args,
        out.stderr
    );
    let lower = out.stderr.to_lowercase();
    for needle in needles {
        assert!(
            lower.contains(&needle.to_lowercase()),
            "`lobe {}`: expected stderr to name '{needle}', got:\n{}",
            out.args,
            out.stderr
        );
    }
    for (folder, old) in folders.iter().zip(&before) {
        let new: Vec<String> = listing(folder).difference(old).cloned().collect();
        assert!(
            new.is_empty(),
            "`lobe {}`: expected no new file in {} after a failure, found {new:?}\nstderr:\n{}",
            out.args,
            folder.display(),
            out.stderr
        );
    }
    out
}

fn assert_fails(args: &[&str], needles: &[&str]) -> Output {
    let dir = tempfile::tempdir().expect("temporary folder");
    assert_fails_in(dir.path(), &[], args, needles)
}

/// Runs `lobe args` in `dir` and requires success.
fn assert_succeeds_in(dir: &Path, args: &[&str]) -> Output {
    let out = lobe_in(dir, args);
    assert_eq!(
        out.code,
        Some(0),
        "`lobe {}`: expected success, got exit code {:?}\nstderr:\n{}",
        out.args,
        out.code,
        out.stderr
    );
    out
}

/// The valid range of a parameter as the library prints it, so that the tests follow the model
/// files instead of repeating their ranges.
fn range_of(model: &str, key: &str) -> String {
    let m = Model::from_name(model).expect("model name");
    m.params()
        .iter()
        .find(|p| p.key == key)
        .unwrap_or_else(|| panic!("{model} has no parameter {key}"))
        .range_text()
}

const EVAL_CT: [&str; 8] = [
    "eval",
    "--backend",
    "cpu",
    "--model",
    "cook_torrance",
    "--wi",
    "30,0",
    "--wo",
];

/// `lobe eval --backend cpu --model cook_torrance <extra> --wi 30,0 --wo 30,180`.
fn eval_ct(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = EVAL_CT[..5].iter().map(|s| s.to_string()).collect();
    v.extend(extra.iter().map(|s| s.to_string()));
    v.extend(EVAL_CT[5..].iter().map(|s| s.to_string()));
    v.push("30,180".into());
    v
}

/// `lobe table --backend cpu --model MODEL <extra> --grid isotropic --res 4,5,6 -o out.exr`.
fn table_args(model: &str, extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = ["table", "--backend", "cpu", "--model", model]
        .iter()
        .map(|s| s.to_string())
        .collect();
    v.extend(extra.iter().map(|s| s.to_string()));
    v.extend(
        ["--grid", "isotropic", "--res", "4,5,6", "-o", "out.exr"]
            .iter()
            .map(|s| s.to_string()),
    );
    v
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// A bad parameter fails the same way in `eval` and in `table` (where it must also leave no file).
fn assert_param_error(model: &str, extra: &[&str], needles: &[&str]) {
    if model == "cook_torrance" {
        assert_fails(&strs(&eval_ct(extra)), needles);
    }
    assert_fails(&strs(&table_args(model, extra)), needles);
}

#[test]
fn negative_roughness_names_parameter_value_and_range() {
    let range = range_of("cook_torrance", "roughness");
    assert_param_error(
        "cook_torrance",
        &["--set", "roughness=-0.1"],
        &["roughness", "-0.1", &range],
    );
}

#[test]
fn nan_value_is_rejected() {
    let range = range_of("cook_torrance", "roughness");
    assert_param_error(
        "cook_torrance",
        &["--set", "roughness=nan"],
        &["roughness", "nan", &range],
    );
    assert_param_error(
        "cook_torrance",
        &["--set", "roughness=inf"],
        &["roughness", "inf", &range],
    );
}

#[test]
fn unknown_model_lists_the_models() {
    let mut needles = vec!["unknown model", "nope"];
    needles.extend(Model::ALL.iter().map(|m| m.name()));
    assert_fails(
        &[
            "eval",
            "--backend",
            "cpu",
            "--model",
            "nope",
            "--wi",
            "30,0",
            "--wo",
            "30,180",
        ],
        &needles,
    );
    assert_param_error("nope", &[], &needles);
}

#[test]
fn unknown_key_lists_the_model_parameters() {
    let mut needles = vec!["nope", "cook_torrance"];
    needles.extend(Model::CookTorrance.params().iter().map(|p| p.key));
    assert_param_error("cook_torrance", &["--set", "nope=1"], &needles);
    // Not KEY=VALUE at all.
    assert_param_error("cook_torrance", &["--set", "roughness"], &["roughness"]);
}

#[test]
fn malformed_rgb_says_one_or_three_numbers() {
    assert_param_error(
        "cook_torrance",
        &["--set", "diffuse=0.1,0.2"],
        &["diffuse", "0.1,0.2", "r,g,b"],
    );
    assert_param_error(
        "cook_torrance",
        &["--set", "diffuse=a,b,c"],
        &["diffuse", "a,b,c", "r,g,b"],
    );
}

#[test]
fn out_of_range_rgb_names_the_channel_value_and_range() {
    let range = range_of("cook_torrance", "diffuse");
    assert_param_error(
        "cook_torrance",
        &["--set", "diffuse=0.1,0.2,1.5"],
        &["diffuse", "1.5", &range],
    );
    assert_param_error(
        "lambert",
        &["--set", "albedo=-0.2"],
        &["albedo", "-0.2", &range_of("lambert", "albedo")],
    );
}

#[test]
fn unknown_material_lists_the_materials() {
    let list = material::names().join(", ");
    assert_param_error(
        "cook_torrance",
        &["--material", "marble"],
        &["unknown material", "marble", &list],
    );
}

#[test]
fn isotropic_grid_on_anisotropic_parameters_is_refused() {
    let dir = tempfile::tempdir().expect("temporary folder");
    assert_fails_in(
        dir.path(),
        &[],
        &[
            "table",
            "--backend",
            "cpu",
            "--model",
            "ashikhmin_shirley",
            "--set",
            "nu=10",
            "--set",
            "nv=100",
            "--grid",
            "isotropic",
            "--res",
            "4,5,6",
            "-o",
            "out.exr",
        ],
        &[
            "--grid isotropic",
            "anisotropic",
            "ashikhmin_shirley",
            "nu=10",
            "nv=100",
            "--grid full",
        ],
    );
}

#[test]
fn bad_res_says_what_it_expects() {
    let cases: [(&str, &str, &[&str]); 7] = [
        ("isotropic", "4,5", &["4,5", "three numbers"]),
        ("full", "4,5,6", &["4,5,6", "four numbers"]),
        ("isotropic", "4,0,6", &["4,0,6", "at least 1"]),
        ("isotropic", "a,b,c", &["a,b,c", "positive integers"]),
        ("isotropic", "-1,2,3", &["-1,2,3", "positive integers"]),
        ("isotropic", "", &["--res", "positive integers"]),
        (
            "isotropic",
            "100000,100000,100000",
            &["100000,100000,100000", "cells", "lower the resolution"],
        ),
    ];
    for (grid, res, needles) in cases {
        // `--res=VALUE`, so that a leading '-' reaches the parser instead of reading as a flag.
        let res_arg = format!("--res={res}");
        assert_fails(
            &[
                "table",
                "--backend",
                "cpu",
                "--model",
                "lambert",
                "--grid",
                grid,
                &res_arg,
                "-o",
                "out.exr",
            ],
            needles,
        );
    }
    assert_fails(
        &[
            "table",
            "--backend",
            "cpu",
            "--model",
            "lambert",
            "--grid",
            "polar",
            "--res",
            "4,5,6",
            "-o",
            "out.exr",
        ],
        &["polar", "full", "isotropic"],
    );
}

#[test]
fn output_in_a_missing_folder_is_refused() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let missing = dir.path().join("nonexistent_dir");
    let target = missing.join("x.exr");
    let target = target.to_str().expect("utf-8 path");
    assert_fails_in(
        dir.path(),
        &[],
        &strs(&table_args_to("lambert", target)),
        &["cannot write", "nonexistent_dir", "does not exist"],
    );
    assert!(
        !missing.exists(),
        "expected {} not to be created",
        missing.display()
    );
    // The literal path from the brief, in case a folder of that name exists nowhere.
    if !Path::new("/nonexistent_dir").exists() {
        assert_fails(
            &strs(&table_args_to("lambert", "/nonexistent_dir/x.exr")),
            &["cannot write", "/nonexistent_dir", "does not exist"],
        );
    }
}

/// `lobe table --backend cpu --model MODEL --grid isotropic --res 4,5,6 -o OUTPUT`.
fn table_args_to(model: &str, output: &str) -> Vec<String> {
    let mut v = table_args(model, &[]);
    *v.last_mut().expect("-o value") = output.to_string();
    v
}

/// Whether a file can be created in `dir` (root can write into a mode-0555 folder).
fn can_create_in(dir: &Path) -> bool {
    let probe = dir.join(".lobe-test-probe");
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            true
        }
        Err(_) => false,
    }
}

#[cfg(unix)]
/// An output whose folder is a file, or lies under a file, is refused naming that file (it was
/// reported as a missing folder), and nothing is written.
#[test]
fn output_under_a_file_names_the_file() {
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::write(dir.path().join("plain"), "x").expect("write a file");
    for (target, says) in [
        ("plain/t.exr", "plain is not a folder"),
        ("plain/sub/t.exr", "plain is a file, not a folder"),
        ("missing/sub/t.exr", "does not exist"),
    ] {
        assert_fails_in(
            dir.path(),
            &[],
            &strs(&table_args_to("lambert", target)),
            &["cannot write", says],
        );
    }
}

#[test]
fn output_in_a_read_only_folder_is_refused() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().expect("temporary folder");
    let ro = dir.path().join("read_only");
    std::fs::create_dir(&ro).expect("create folder");
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).expect("chmod 555");
    let ro_is_read_only = !can_create_in(&ro);
    // Under root (CAP_DAC_OVERRIDE) the mode does not stop writes; sysfs and procfs refuse new
    // files to root as well, so one of them stands in for the read-only folder.
    let folder: PathBuf = if ro_is_read_only {
        ro.clone()
    } else {
        ["/sys", "/proc"]
            .iter()
            .map(PathBuf::from)
            .find(|p| p.is_dir() && !can_create_in(p))
            .unwrap_or_else(|| {
                panic!(
                    "this process can write into a mode-0555 folder and neither /sys nor /proc \
                     refuses a new file: expected some folder that cannot be written to test with"
                )
            })
    };
    let target = folder.join("x.exr");
    let target_text = target.to_str().expect("utf-8 path").to_string();
    let folder_text = folder.to_str().expect("utf-8 path").to_string();
    let result = std::panic::catch_unwind(|| {
        let out = assert_fails_in(
            dir.path(),
            &[&folder],
            &strs(&table_args_to("lambert", &target_text)),
            &["cannot write", &folder_text],
        );
        // Said once: the temporary file's own error had repeated "at path …" per attempt.
        assert_eq!(
            out.stderr.matches(&folder_text).count(),
            2,
            "{}",
            out.stderr
        );
        assert!(!out.stderr.contains("at path"), "{}", out.stderr);
    });
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).expect("chmod 755");
    if let Err(e) = result {
        std::panic::resume_unwind(e);
    }
}

#[test]
fn output_must_end_in_exr() {
    for name in ["x.png", "x", "x.exr.npy"] {
        assert_fails(
            &strs(&table_args_to("lambert", name)),
            &["-o", name, "must end in .exr"],
        );
    }
}

#[test]
fn a_folder_in_the_way_leaves_no_file_of_the_set() {
    // The .exr name is taken by a folder: the table must fail before writing the .npy or .json.
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::create_dir(dir.path().join("out.exr")).expect("create folder");
    assert_fails_in(
        dir.path(),
        &[],
        &strs(&table_args("lambert", &[])),
        &["cannot write", "out.exr", "folder"],
    );
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::create_dir(dir.path().join("out.json")).expect("create folder");
    assert_fails_in(
        dir.path(),
        &[],
        &strs(&table_args("lambert", &[])),
        &["cannot write", "out.json", "folder"],
    );
}

const PAIRS_HEADER: &str = "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg";

/// Writes `text` to `name` in a new folder and runs `lobe eval --backend cpu --pairs name` there,
/// expecting a failure that names `needles`.
fn assert_pairs_fail(text: &str, needles: &[&str]) {
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::write(dir.path().join("pairs.csv"), text).expect("write csv");
    assert_fails_in(
        dir.path(),
        &[],
        &["eval", "--backend", "cpu", "--pairs", "pairs.csv"],
        needles,
    );
}

#[test]
fn malformed_pairs_csv_is_refused() {
    assert_pairs_fail(
        "a,b,c,d\n10,0,20,180\n",
        &["pairs.csv", "header", PAIRS_HEADER],
    );
    assert_pairs_fail("", &["pairs.csv", "header", PAIRS_HEADER]);
    assert_pairs_fail(
        &format!("{PAIRS_HEADER}\n10,0,20,180\n1,2,3\n"),
        &["pairs.csv line 3", "four numbers", "found 3"],
    );
    assert_pairs_fail(
        &format!("{PAIRS_HEADER}\n1,2,3,4,5\n"),
        &["pairs.csv line 2", "four numbers", "found 5"],
    );
    assert_pairs_fail(
        &format!("{PAIRS_HEADER}\n1,2,x,4\n"),
        &["pairs.csv line 2", "1,2,x,4", "four numbers"],
    );
    assert_pairs_fail(
        &format!("{PAIRS_HEADER}\n10,0,300,4\n"),
        &["pairs.csv line 2", "theta", "300", "[0, 180]"],
    );
    let dir = tempfile::tempdir().expect("temporary folder");
    assert_fails_in(
        dir.path(),
        &[],
        &["eval", "--backend", "cpu", "--pairs", "missing.csv"],
        &["missing.csv", "no such file"],
    );
}

#[test]
fn theta_out_of_range_is_refused() {
    let run = |wi: &str, wo: &str, needles: &[&str]| {
        let wi_arg = format!("--wi={wi}");
        let wo_arg = format!("--wo={wo}");
        assert_fails(&["eval", "--backend", "cpu", &wi_arg, &wo_arg], needles);
    };
    run("200,0", "30,180", &["--wi", "theta", "200", "[0, 180]"]);
    run("-10,0", "30,180", &["--wi", "theta", "-10", "[0, 180]"]);
    run("30,0", "181,180", &["--wo", "theta", "181", "[0, 180]"]);
    run("nan,0", "30,180", &["--wi", "theta", "nan", "[0, 180]"]);
    run("30,nan", "30,180", &["--wi", "phi", "nan", "finite"]);
    run("30", "30,180", &["--wi", "30", "THETA,PHI"]);
}

#[test]
fn models_lists_every_model() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let out = assert_succeeds_in(dir.path(), &["models"]);
    let listed: BTreeSet<&str> = out
        .stdout
        .lines()
        .filter(|l| !l.starts_with(' ') && !l.is_empty())
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    // The eight named models of docs/design.md §3 (all but `microfacet`), by name, and whatever the
    // library adds beyond them.
    let named = [
        "lambert",
        "phong",
        "blinn_phong",
        "oren_nayar",
        "cook_torrance",
        "smooth_layered",
        "coupled",
        "ashikhmin_shirley",
    ];
    for name in named
        .iter()
        .copied()
        .chain(Model::ALL.iter().map(|m| m.name()))
    {
        assert!(
            listed.contains(name),
            "`lobe models`: expected model {name} in the list, got {listed:?}\n{}",
            out.stdout
        );
        for p in Model::from_name(name).expect("model").params() {
            assert!(
                out.stdout.contains(p.key),
                "`lobe models`: expected parameter {} of {name}, got:\n{}",
                p.key,
                out.stdout
            );
        }
    }
    // `--format json`, as every command that prints a report takes it; `--json` the same.
    let json = assert_succeeds_in(dir.path(), &["models", "--format", "json"]);
    let alias = assert_succeeds_in(dir.path(), &["models", "--json"]);
    assert_eq!(
        json.stdout, alias.stdout,
        "`lobe models --json` is `--format json`"
    );
    let doc: serde_json::Value = serde_json::from_str(&json.stdout).unwrap_or_else(|e| {
        panic!(
            "`lobe models --format json`: expected JSON ({e}), got:\n{}",
            json.stdout
        )
    });
    let names: Vec<&str> = doc["models"]
        .as_array()
        .unwrap_or_else(|| {
            panic!("`lobe models --format json`: expected a models array, got {doc}")
        })
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    let expected: Vec<&str> = Model::ALL.iter().map(|m| m.name()).collect();
    assert_eq!(
        names, expected,
        "`lobe models --format json`: expected the models {expected:?}, got {names:?}"
    );
}

/// f of cook_torrance (roughness 0.3) from the library's CPU reference at angles in degrees, as
/// the CLI computes it.
fn reference_ct(angles: [f64; 4]) -> [f64; 3] {
    let params = resolve_params("cook_torrance", None, &["roughness=0.3".to_string()])
        .expect("valid parameters");
    let [ti, pi, to, po] = angles;
    Reference::new(&params, false)
        .eval(direction_deg(ti, pi), direction_deg(to, po))
        .to_array()
}

fn parse_row(line: &str) -> Vec<f64> {
    line.split(',')
        .map(|s| {
            s.parse::<f64>()
                .unwrap_or_else(|e| panic!("CSV field '{s}' in '{line}': {e}"))
        })
        .collect()
}

#[test]
fn eval_csv_has_the_header_and_the_reference_value() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let out = assert_succeeds_in(dir.path(), &strs(&eval_ct(&["--set", "roughness=0.3"])));
    let lines: Vec<&str> = out.stdout.lines().collect();
    assert_eq!(
        lines.len(),
        2,
        "expected a header and one row, got:\n{}",
        out.stdout
    );
    assert_eq!(
        lines[0], "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,r,g,b",
        "expected the CSV header, got '{}'",
        lines[0]
    );
    let row = parse_row(lines[1]);
    assert_eq!(row.len(), 7, "expected 7 fields, got '{}'", lines[1]);
    assert_eq!(
        &row[..4],
        &[30.0, 0.0, 30.0, 180.0],
        "expected the angles back, got '{}'",
        lines[1]
    );
    // The CLI prints f64 in Rust's shortest round-trip form, so the CPU value comes back exactly.
    let want = reference_ct([30.0, 0.0, 30.0, 180.0]);
    assert_eq!(
        &row[4..],
        &want,
        "expected the CPU reference value {want:?}, got '{}'",
        lines[1]
    );
    assert!(
        want[0] > 0.0,
        "expected a positive f in the specular plane, got {want:?}"
    );
}

#[test]
fn eval_json_parses_and_matches_csv() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let out = assert_succeeds_in(
        dir.path(),
        &strs(&eval_ct(&["--set", "roughness=0.3", "--format", "json"])),
    );
    let doc: serde_json::Value = serde_json::from_str(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "expected JSON from --format json ({e}), got:\n{}",
            out.stdout
        )
    });
    assert_eq!(
        doc["model"], "cook_torrance",
        "expected model cook_torrance, got {}",
        doc["model"]
    );
    assert_eq!(
        doc["parameters"]["roughness"], 0.3,
        "expected parameters.roughness = 0.3, got {}",
        doc["parameters"]
    );
    let values = doc["values"]
        .as_array()
        .unwrap_or_else(|| panic!("expected a values array, got {doc}"));
    assert_eq!(values.len(), 1, "expected one value, got {values:?}");
    let rgb: Vec<f64> = values[0]["rgb"]
        .as_array()
        .unwrap_or_else(|| panic!("expected an rgb array, got {}", values[0]))
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect();
    let want = reference_ct([30.0, 0.0, 30.0, 180.0]);
    for (got, want) in rgb.iter().zip(want) {
        let diff = (got - want).abs();
        assert!(
            diff <= JSON_PARSE_RTOL * want.abs(),
            "expected rgb = the CPU reference {want} within {JSON_PARSE_RTOL:e} relative, got {got} \
             (difference {diff:e})"
        );
    }
    for (key, v) in [
        ("theta_i_deg", 30.0),
        ("phi_i_deg", 0.0),
        ("theta_o_deg", 30.0),
        ("phi_o_deg", 180.0),
    ] {
        assert_eq!(
            values[0][key], v,
            "expected {key} = {v}, got {}",
            values[0][key]
        );
    }
}

#[test]
fn eval_pairs_file_gives_one_row_per_pair_in_order() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let pairs = [
        [30.0, 0.0, 30.0, 180.0],
        [10.0, 45.0, 60.0, 200.0],
        [85.0, 0.0, 5.0, 90.0],
        // Below the horizon: f = 0 (one-sided, docs/design.md §2).
        [95.0, 0.0, 30.0, 180.0],
    ];
    let mut csv = format!("{PAIRS_HEADER}\n");
    for p in &pairs {
        csv += &format!("{},{},{},{}\n", p[0], p[1], p[2], p[3]);
    }
    std::fs::write(dir.path().join("pairs.csv"), csv).expect("write csv");
    let out = assert_succeeds_in(
        dir.path(),
        &[
            "eval",
            "--backend",
            "cpu",
            "--model",
            "cook_torrance",
            "--set",
            "roughness=0.3",
            "--pairs",
            "pairs.csv",
        ],
    );
    let lines: Vec<&str> = out.stdout.lines().collect();
    assert_eq!(
        lines.len(),
        pairs.len() + 1,
        "expected a header and {} rows, got:\n{}",
        pairs.len(),
        out.stdout
    );
    for (p, line) in pairs.iter().zip(&lines[1..]) {
        let row = parse_row(line);
        assert_eq!(&row[..4], p, "expected the angles {p:?} back, got '{line}'");
        let want = reference_ct(*p);
        assert_eq!(
            &row[4..],
            &want,
            "at {p:?}: expected the CPU reference {want:?}, got '{line}'"
        );
    }
    assert_eq!(
        parse_row(lines[4])[4..],
        [0.0; 3],
        "expected f = 0 below the horizon, got '{}'",
        lines[4]
    );
}
