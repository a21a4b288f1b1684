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
