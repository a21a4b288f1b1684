//! Output sets no run can break: a set knows its kind and members, and a run refuses, before
//! any work, to replace a member of another set; the demo refuses a folder it cannot write.

mod common;

use std::path::Path;

/// Names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A folder without write permission is refused before the session opens or any step runs, as
/// lobe refuses read-only files (even for root, who could write there anyway); nothing is
/// created in it or beside it.
#[cfg(unix)]
#[test]
fn the_demo_refuses_a_read_only_folder_before_any_work() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().expect("a temporary folder");
    let out = dir.path().join("demo");
    std::fs::create_dir(&out).expect("the output folder");
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o555)).expect("chmod");
    let (code, _, err) = common::lobe_run(&[
        "demo",
        "--quick",
        "--backend",
        "cpu",
        "-o",
        out.to_str().expect("a UTF-8 path"),
    ]);
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o755)).expect("chmod back");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("read-only") && err.contains("-o"), "{err}");
    assert!(!err.contains("lobe demo:"), "the demo started: {err}");
    assert!(names(&out).is_empty(), "{:?}", names(&out));
    assert_eq!(names(dir.path()), ["demo"]);
}

/// `lobe` with `args` in `dir` on the CPU reference: (success, stderr).
fn lobe_in(dir: &Path, args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run lobe");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A small table set `stem.exr`, `.npy`, `.json` at `roughness`.
fn table_args(stem: &str, roughness: &str) -> Vec<String> {
    let out = format!("{stem}.exr");
    let set = format!("roughness={roughness}");
    [
        "table",
        "--backend",
        "cpu",
        "--model",
        "cook_torrance",
        "--grid",
        "isotropic",
        "--res",
        "4,4,8",
        "--set",
        &set,
        "-o",
        &out,
    ]
    .map(String::from)
    .to_vec()
}

fn table_in(dir: &Path, stem: &str, roughness: &str, extra: &[&str]) -> (bool, String) {
    let mut args = table_args(stem, roughness);
    args.extend(extra.iter().map(|s| s.to_string()));
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    lobe_in(dir, &refs)
}

/// An albedo LUT `stem.exr` with its `.npy`, `_avg.npy` and `.json`.
fn lut_in(dir: &Path, stem: &str) -> (bool, String) {
    let out = format!("{stem}.exr");
    lobe_in(
        dir,
        &[
            "albedo",
            "--backend",
            "cpu",
            "--model",
            "lambert",
            "--lut",
            &out,
            "--lut-res",
            "4,4",
        ],
    )
}

/// Every file in `dir` (name → bytes).
fn contents(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    names(dir)
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap_or_default();
            (n, bytes)
        })
        .collect()
}

/// The run was refused with a message naming both sets, and `dir` is exactly as `before`.
fn assert_refused(
    run: (bool, String),
    dir: &Path,
    before: &std::collections::BTreeMap<String, Vec<u8>>,
    names_: &[&str],
) {
    let (ok, err) = run;
    assert!(!ok, "the run was not refused");
    for n in names_ {
        assert!(err.contains(n), "{n} not named in: {err}");
    }
    assert!(err.contains("--replace"), "{err}");
    assert_eq!(&contents(dir), before, "{err}");
}

/// The sidecar of a table records its set: kind and members.
#[test]
fn a_tables_sidecar_names_its_set() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let (ok, err) = table_in(dir.path(), "t", "0.3", &[]);
    assert!(ok, "{err}");
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("t.json")).expect("t.json"))
            .expect("JSON");
    assert_eq!(v["set"]["kind"], "table");
    assert_eq!(
        v["set"]["members"],
        serde_json::json!(["t.npy", "t.exr", "t.json"])
    );
}

/// A plot or a preview over a table's files is refused before any work (the plot replaced the
/// table's `t.json`, after which `lobe fit --target t.npy` failed; the preview replaced its
/// `t.exr` with a radiance image); the table is untouched and nothing else is written.
#[test]
fn a_plot_or_preview_does_not_replace_a_tables_files() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let (ok, err) = table_in(dir.path(), "t", "0.3", &[]);
    assert!(ok, "{err}");
    let before = contents(dir.path());
    let plot = lobe_in(
        dir.path(),
        &[
            "plot",
            "--backend",
            "cpu",
            "--model",
            "lambert",
            "-o",
            "t.png",
        ],
    );
    assert_refused(plot, dir.path(), &before, &["t.json", "table"]);
    let preview = lobe_in(
        dir.path(),
        &["preview", "--backend", "cpu", "--cell", "16", "-o", "t.png"],
    );
    assert_refused(preview, dir.path(), &before, &["t.exr", "table"]);
}

/// `lobe compare -o P` writes `P_polar.png` and its `P_polar.json`: refused where `P_polar.json`
/// is a table's sidecar.
#[test]
fn compare_does_not_replace_a_tables_sidecar() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let (ok, err) = table_in(dir.path(), "P_polar", "0.3", &[]);
    assert!(ok, "{err}");
    let before = contents(dir.path());
    let compare = lobe_in(
        dir.path(),
        &[
            "compare",
            "lambert",
            "oren_nayar",
            "--backend",
            "cpu",
            "-o",
            "P",
        ],
    );
    assert_refused(compare, dir.path(), &before, &["P_polar.json", "table"]);
}

/// A table named after a LUT's member (`L_avg.exr` writes `L_avg.npy`) or over a LUT (`L.exr`)
/// is refused, naming the LUT; with `--replace` the LUT goes whole: no stale `L_avg.npy` stays
/// beside the table.
#[test]
fn a_table_replaces_a_lut_only_whole_and_when_told() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let (ok, err) = lut_in(dir.path(), "L");
    assert!(ok, "{err}");
    assert_eq!(names(dir.path()), ["L.exr", "L.json", "L.npy", "L_avg.npy"]);
    let before = contents(dir.path());
    let over_member = table_in(dir.path(), "L_avg", "0.3", &[]);
    assert_refused(
        over_member,
        dir.path(),
        &before,
        &["L_avg.npy", "lut", "L.json"],
    );
    let over_set = table_in(dir.path(), "L", "0.3", &[]);
    assert_refused(over_set, dir.path(), &before, &["L.exr", "lut"]);
    let (ok, err) = table_in(dir.path(), "L", "0.3", &["--replace"]);
    assert!(ok, "{err}");
    assert_eq!(names(dir.path()), ["L.exr", "L.json", "L.npy"]);
    let (ok, err) = table_in(dir.path(), "L_avg", "0.3", &[]);
    assert!(ok, "{err}");
}

/// Files no lobe set owns (here a table's three files written by hand) are not replaced by a
/// table, unless told; a table over its own earlier set of the same kind and name is replaced
/// as before.
#[test]
fn a_table_replaces_its_own_set_but_not_foreign_files() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    for n in ["f.exr", "f.npy", "f.json"] {
        std::fs::write(dir.path().join(n), "someone else's").expect("writing");
    }
    let before = contents(dir.path());
    let foreign = table_in(dir.path(), "f", "0.3", &[]);
    assert_refused(foreign, dir.path(), &before, &["f.exr", "no lobe set"]);
    let (ok, err) = table_in(dir.path(), "f", "0.3", &["--replace"]);
    assert!(ok, "{err}");
    let (ok, err) = table_in(dir.path(), "f", "0.7", &[]);
    assert!(ok, "{err}");
    assert_eq!(names(dir.path()), ["f.exr", "f.json", "f.npy"]);
}

/// A table and a preview started together on `X.*`: whichever commits second finds the other's
/// set in place (at its start or at its commit) and is refused: the folder holds one run's set,
/// never `X.exr` from one and `X.npy`/`X.json` from the other.
#[test]
fn a_table_and_a_preview_at_once_never_mix() {
    const ROUNDS: usize = 4;
    for round in 0..ROUNDS {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let spawn = |args: Vec<String>| {
            std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
                .current_dir(dir.path())
                .args(args)
                .stderr(std::process::Stdio::piped())
                .spawn()
                .expect("run lobe")
        };
        let preview = spawn(
            ["preview", "--backend", "cpu", "--cell", "24", "-o", "X.png"]
                .map(String::from)
                .to_vec(),
        );
        let table = spawn(table_args("X", "0.3"));
        let (p, t) = (
            preview.wait_with_output().expect("preview"),
            table.wait_with_output().expect("table"),
        );
        let n = names(dir.path());
        let errs = format!(
            "{}\n{}",
            String::from_utf8_lossy(&p.stderr),
            String::from_utf8_lossy(&t.stderr)
        );
        match (t.status.success(), p.status.success()) {
            (true, false) => assert_eq!(n, ["X.exr", "X.json", "X.npy"], "round {round}"),
            (false, true) => assert_eq!(n, ["X.exr", "X.png"], "round {round}"),
            both => panic!("round {round}: table, preview succeeded: {both:?}; {n:?}; {errs}"),
        }
    }
}
