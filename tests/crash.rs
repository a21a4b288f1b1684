//! A commit stopped at any of its steps, as `kill -9` would stop it: the next run that writes
//! into the folder finds the old set or the new set, never a mix, and no temporary file. The
//! test hook `LOBE_CRASH_AT=N` aborts the process at the N-th step of its commits.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The members of the table set `t` the runs write.
const MEMBERS: [&str; 3] = ["t.exr", "t.json", "t.npy"];

/// A commit of three files has at least 1 (data flushed) + 1 (record written) + 3 (old files
/// kept) + 3 (renames) + 1 (folders flushed) + 1 (backups removed) steps.
const MIN_STEPS: usize = 10;

/// Bounds the loop should the hook never end a run.
const MAX_STEPS: usize = 64;

/// `lobe table` on the CPU: cook_torrance at `roughness` on a small isotropic grid, into `out` in
/// `dir`, aborting at commit step `crash_at` when given.
fn table(dir: &Path, roughness: f64, out: &str, crash_at: Option<usize>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lobe"));
    c.current_dir(dir).args([
        "table",
        "--backend",
        "cpu",
        "--grid",
        "isotropic",
        "--res",
        "6,6,12",
        "--set",
        &format!("roughness={roughness}"),
        "-o",
        out,
    ]);
    c.env_remove("LOBE_CRASH_AT");
    if let Some(n) = crash_at {
        c.env("LOBE_CRASH_AT", n.to_string());
    }
    c.output().expect("running lobe")
}

/// Every file in `dir` (name → bytes), hidden ones included.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .expect("listing")
        .flatten()
        .map(|e| {
            let bytes = std::fs::read(e.path()).unwrap_or_default();
            (e.file_name().to_string_lossy().into_owned(), bytes)
        })
        .collect()
}

/// The set `t` as it is in `dir`: each member's bytes, `None` for a missing one.
fn set_in(dir: &Path) -> Vec<Option<Vec<u8>>> {
    MEMBERS
        .iter()
        .map(|m| std::fs::read(dir.join(m)).ok())
        .collect()
}

/// A folder holding the set `t` written whole at `roughness`, and its path.
fn written(roughness: f64) -> (tempfile::TempDir, PathBuf) {
    let d = tempfile::tempdir().expect("a temporary folder");
    let o = table(d.path(), roughness, "t.exr", None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let p = d.path().to_path_buf();
    (d, p)
}

/// Every step of a table's commit in turn: before the record is written the old set stays, after
/// it the new set is completed; either way the temporary files and kept old files go.
#[cfg(unix)]
#[test]
fn a_commit_stopped_at_any_step_is_finished_or_undone_by_the_next_run() {
    use std::os::unix::process::ExitStatusExt;
    const SIGABRT: i32 = 6;
    let (_old_dir, old_path) = written(0.5);
    let (_new_dir, new_path) = written(0.2);
    let (old, new) = (set_in(&old_path), set_in(&new_path));
    assert_ne!(old, new, "the two runs must write different sets");
    let (mut saw_old, mut saw_new) = (false, false);
    let mut steps = 0;
    for n in 1..=MAX_STEPS {
        let dir = tempfile::tempdir().expect("a temporary folder");
        for m in MEMBERS {
            std::fs::copy(old_path.join(m), dir.path().join(m)).expect("copying the old set");
        }
        let o = table(dir.path(), 0.2, "t.exr", Some(n));
        if o.status.success() {
            assert_eq!(set_in(dir.path()), new, "the run past every step");
            steps = n - 1;
            break;
        }
        assert_eq!(
            o.status.signal(),
            Some(SIGABRT),
            "step {n}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        // The next run writing into the folder: another table beside it.
        let next = table(dir.path(), 0.3, "u.exr", None);
        assert!(
            next.status.success(),
            "step {n}: {}",
            String::from_utf8_lossy(&next.stderr)
        );
        let found = set_in(dir.path());
        saw_old |= found == old;
        saw_new |= found == new;
        assert!(
            found == old || found == new,
            "step {n}: t.* is neither the old nor the new set"
        );
        let left: Vec<String> = snapshot(dir.path())
            .into_keys()
            .filter(|k| k.starts_with(".lobe-"))
            .collect();
        assert!(left.is_empty(), "step {n}: left behind {left:?}");
    }
    assert!(steps >= MIN_STEPS, "the commit had {steps} steps");
    assert!(
        saw_old && saw_new,
        "old kept: {saw_old}, new completed: {saw_new}"
    );
}
