//! Output as transactions, through the real command line: a set of files comes whole from one
//! run or not at all, the old set stays when a run fails or is interrupted, and nothing temporary
//! (`.lobe-*`) is left behind. Every run here is on the CPU reference: no Vulkan needed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn lobe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
}

/// Exit status of a command stopped by a signal it handled (128 + SIGINT, as shells report it).
const INTERRUPTED_STATUS: i32 = 130;

/// `lobe table` on the CPU: cook_torrance at `roughness`, isotropic grid `res`, into `out`.
fn table(dir: &Path, roughness: f64, res: &str, out: &str) -> Command {
    let mut c = lobe();
    c.current_dir(dir).args([
        "table",
        "--backend",
        "cpu",
        "--grid",
        "isotropic",
        "--res",
        res,
        "--set",
        &format!("roughness={roughness}"),
        "-o",
        out,
    ]);
    c
}

fn run(mut c: Command) -> Output {
    c.output().expect("running lobe")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every file under `dir` (relative path → bytes), hidden ones included.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("listing").flatten() {
            let p = e.path();
            let rel = p.strip_prefix(dir).expect("inside").to_path_buf();
            if p.is_dir() {
                out.insert(rel.join(""), Vec::new());
                stack.push(p);
            } else {
                out.insert(rel, std::fs::read(&p).unwrap_or_default());
            }
        }
    }
    out
}

fn temporaries(dir: &Path) -> Vec<PathBuf> {
    snapshot(dir)
        .into_keys()
        .filter(|p| {
            p.components()
                .any(|c| c.as_os_str().to_string_lossy().starts_with(".lobe-"))
        })
        .collect()
}

fn roughness_in_sidecar(json: &[u8]) -> f64 {
    let v: serde_json::Value = serde_json::from_slice(json).expect("the sidecar is JSON");
    v["parameters"]["roughness"]
        .as_f64()
        .unwrap_or_else(|| panic!("no parameters.roughness in {v}"))
}

/// Two processes writing one table set at once, 50 times: afterwards the set is always one run's
/// (the roughness in its JSON matches its .npy and its .exr byte for byte), never a mix.
#[test]
fn concurrent_writers_leave_one_runs_set() {
    const TRIES: usize = 50;
    const RES: &str = "8,8,8";
    let roughness = [0.1, 0.9];
    // The reference set of each run, written alone; EXR output is byte-stable, so the .exr can be
    // compared as bytes too.
    let refs: Vec<(Vec<u8>, Vec<u8>)> = roughness
        .iter()
        .map(|&r| {
            let d = tempfile::tempdir().expect("temporary folder");
            let o = run(table(d.path(), r, RES, "t.exr"));
            assert!(o.status.success(), "{}", stderr(&o));
            let read = |n: &str| std::fs::read(d.path().join(n)).expect("reading");
            (read("t.npy"), read("t.exr"))
        })
        .collect();
    assert_ne!(
        refs[0].0, refs[1].0,
        "the two runs must write different tables"
    );
    let dir = tempfile::tempdir().expect("temporary folder");
    let mut winners = [0usize; 2];
    for attempt in 0..TRIES {
        let children: Vec<Child> = roughness
            .iter()
            .map(|&r| {
                table(dir.path(), r, RES, "t.exr")
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped())
                    .spawn()
                    .expect("spawning lobe")
            })
            .collect();
        for c in children {
            let o = c.wait_with_output().expect("waiting for lobe");
            assert!(o.status.success(), "try {attempt}: {}", stderr(&o));
        }
        let read = |n: &str| std::fs::read(dir.path().join(n)).expect("reading");
        let r = roughness_in_sidecar(&read("t.json"));
        let k = roughness
            .iter()
            .position(|&x| x == r)
            .unwrap_or_else(|| panic!("try {attempt}: roughness {r} in the JSON"));
        assert!(
            read("t.npy") == refs[k].0,
            "try {attempt}: t.json says roughness {r}, but t.npy is not that run's"
        );
        assert!(
            read("t.exr") == refs[k].1,
            "try {attempt}: t.json says roughness {r}, but t.exr is not that run's"
        );
        assert!(temporaries(dir.path()).is_empty(), "try {attempt}");
        winners[k] += 1;
    }
    eprintln!(
        "last writer: roughness 0.1 {} times, 0.9 {} times",
        winners[0], winners[1]
    );
}

/// A folder holding a small table set `t.exr`, `t.npy`, `t.json` (roughness 0.5), and its
/// snapshot: the old set a failing or interrupted run must keep.
fn folder_with_old_set() -> (tempfile::TempDir, BTreeMap<PathBuf, Vec<u8>>) {
    let dir = tempfile::tempdir().expect("temporary folder");
    let o = run(table(dir.path(), 0.5, "4,4,4", "t.exr"));
    assert!(o.status.success(), "{}", stderr(&o));
    let old = snapshot(dir.path());
    (dir, old)
}

/// Starts `c` with its standard error captured.
fn spawn(mut c: Command) -> Child {
    c.stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawning lobe")
}

/// The run `child` ended by a signal as it should: status 130, `message` on standard error, and
/// `dir` exactly as `old` (the old set, no temporary file).
fn assert_interrupted(
    child: Child,
    what: &str,
    message: &str,
    dir: &Path,
    old: &BTreeMap<PathBuf, Vec<u8>>,
) {
    let o = child.wait_with_output().expect("waiting for lobe");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(INTERRUPTED_STATUS), "{what}: {err}");
    assert!(err.contains(message), "{what}: {err}");
    assert!(
        temporaries(dir).is_empty(),
        "{what}: left {:?}\n{err}",
        temporaries(dir)
    );
    assert!(snapshot(dir) == *old, "{what}: the old set changed\n{err}");
}

/// Sends `signal` (INT, TERM, HUP) to `child`.
fn kill(child: &Child, signal: &str) -> bool {
    Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Waits until `ready` holds for the temporary files in `dir` (with their sizes), or 30 s.
fn wait_for(dir: &Path, ready: impl Fn(&[u64]) -> bool) -> bool {
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(30) {
        let sizes: Vec<u64> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
            .filter_map(|e| e.metadata().ok().map(|m| m.len()))
            .collect();
        if ready(&sizes) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    false
}

/// The big table of the signal tests: 160³ cells, 49 MB of npy and as much EXR; a fraction of a
/// second to encode, so a signal sent once encoding starts lands in it.
const BIG: &str = "160,160,160";
/// Its npy's size: a 128-byte header and 160³ cells of three float32.
const BIG_NPY_BYTES: u64 = 128 + 160 * 160 * 160 * 12;

/// Ctrl-C, SIGTERM and SIGHUP during the EXR encoding of a big table: the run stops (status 130,
/// "interrupted"), the old set is untouched and no temporary file is left.
#[cfg(unix)]
#[test]
fn a_signal_during_encoding_keeps_the_old_set() {
    let (dir, old) = folder_with_old_set();
    for signal in ["INT", "TERM", "HUP"] {
        let child = spawn(table(dir.path(), 0.2, BIG, "t.exr"));
        // Encoding has begun once the npy is complete and a second temporary file has data.
        let encoding = wait_for(dir.path(), |s| {
            s.contains(&BIG_NPY_BYTES) && s.iter().filter(|&&n| n > 0).count() >= 2
        });
        assert!(encoding, "SIG{signal}: the EXR encoding never started");
        assert!(
            kill(&child, signal),
            "SIG{signal}: the run ended before the signal"
        );
        assert_interrupted(
            child,
            &format!("SIG{signal}"),
            "interrupted",
            dir.path(),
            &old,
        );
    }
}

/// A writer waits for the folder's lock (held here, as another lobe writing into the folder would
/// hold it) with its set staged. One signal then: no commit starts once the lock is free (status
/// 130, the old set kept). Two signals: the second removes every temporary file at once and exits
/// 130 while the first is still waiting.
#[cfg(unix)]
#[test]
fn signals_while_waiting_for_the_lock_keep_the_old_set() {
    let (dir, old) = folder_with_old_set();
    for signals in [1, 2] {
        let lock = std::fs::File::open(dir.path()).expect("opening the folder");
        lock.lock().expect("locking the folder");
        let mut child = spawn(table(dir.path(), 0.9, "4,4,4", "t.exr"));
        // Staged: three temporary files, all written (the sidecar last).
        let staged = wait_for(dir.path(), |s| s.len() == 3 && s.iter().all(|&n| n > 0));
        assert!(staged, "{signals} signals: the set was never staged");
        std::thread::sleep(Duration::from_millis(200));
        assert!(
            child.try_wait().expect("polling lobe").is_none(),
            "{signals} signals: lobe did not wait for the folder's lock"
        );
        for _ in 0..signals {
            assert!(kill(&child, "INT"));
            std::thread::sleep(Duration::from_millis(200));
        }
        if signals == 1 {
            drop(lock);
        }
        let expected = if signals == 1 {
            "interrupted"
        } else {
            "interrupted again"
        };
        assert_interrupted(
            child,
            &format!("{signals} signals"),
            expected,
            dir.path(),
            &old,
        );
    }
}

/// A sidecar name one byte too long for the file system (255 bytes): refused before any work,
/// and the old .exr and .npy of that name stay as they were.
#[test]
fn a_name_too_long_for_the_sidecar_only_changes_nothing() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let stem = "n".repeat(251);
    for ext in ["exr", "npy"] {
        std::fs::write(dir.path().join(format!("{stem}.{ext}")), "old").expect("writing");
    }
    let old = snapshot(dir.path());
    let o = run(table(dir.path(), 0.5, "4,4,4", &format!("{stem}.exr")));
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(err.contains("too long"), "{err}");
    assert!(snapshot(dir.path()) == old, "{err}");
}

/// A folder in the way of the last file of the set (the sidecar): the old .exr and .npy stay.
#[test]
fn a_folder_in_the_way_of_the_last_file_changes_nothing() {
    let (dir, _) = folder_with_old_set();
    std::fs::remove_file(dir.path().join("t.json")).expect("removing");
    std::fs::create_dir(dir.path().join("t.json")).expect("a folder in the way");
    let old = snapshot(dir.path());
    let o = run(table(dir.path(), 0.9, "4,4,4", "t.exr"));
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(err.contains("in the way"), "{err}");
    assert!(snapshot(dir.path()) == old, "{err}");
}

/// A read-only old sidecar: the run is refused with a sentence and the whole old set stays.
#[cfg(unix)]
#[test]
fn a_read_only_old_file_is_refused() {
    use std::os::unix::fs::PermissionsExt;
    let (dir, _) = folder_with_old_set();
    let json = dir.path().join("t.json");
    std::fs::set_permissions(&json, std::fs::Permissions::from_mode(0o444)).expect("chmod");
    let old = snapshot(dir.path());
    let o = run(table(dir.path(), 0.9, "4,4,4", "t.exr"));
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(err.contains("read-only") && err.contains("t.json"), "{err}");
    assert!(snapshot(dir.path()) == old, "{err}");
}

/// An immutable old sidecar (`chattr +i`): refused before the first rename, the old set stays.
#[cfg(target_os = "linux")]
#[test]
#[ignore = "needs root (CAP_LINUX_IMMUTABLE) and a file system with chattr +i"]
fn an_immutable_old_file_changes_nothing() {
    let (dir, _) = folder_with_old_set();
    let json = dir.path().join("t.json");
    let chattr = |flag: &str| {
        Command::new("chattr")
            .args([flag, json.to_str().expect("utf-8")])
            .status()
            .is_ok_and(|s| s.success())
    };
    assert!(chattr("+i"), "chattr +i failed");
    let old = snapshot(dir.path());
    let o = run(table(dir.path(), 0.9, "4,4,4", "t.exr"));
    let same = snapshot(dir.path()) == old;
    assert!(chattr("-i"), "chattr -i failed");
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("cannot replace") && err.contains("t.json"),
        "{err}"
    );
    assert!(same, "{err}");
}

/// New files and folders honour the umask: 077 gives 0600 files and 0700 folders.
#[cfg(unix)]
#[test]
fn outputs_honour_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().expect("temporary folder");
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        "[[materials]]\nname = \"m\"\nmodel = \"lambert\"\n\n[[tables]]\nmaterial = \"m\"\nn_theta = 4\nn_phi = 8\noutput = \"sub/t.exr\"\n",
    )
    .expect("writing the scene");
    for (umask, file, folder) in [("077", 0o600, 0o700), ("022", 0o644, 0o755)] {
        let out = dir.path().join(format!("out{umask}"));
        let lobe = env!("CARGO_BIN_EXE_lobe");
        let script = format!(
            "umask {umask} && exec '{lobe}' run --backend cpu --output-dir '{}' '{}'",
            out.display(),
            scene.display()
        );
        let o = run({
            let mut c = Command::new("sh");
            c.args(["-c", &script]);
            c
        });
        assert!(o.status.success(), "{}", stderr(&o));
        let mode = |p: PathBuf| std::fs::metadata(&p).expect("stat").permissions().mode() & 0o777;
        for f in ["sub/t.exr", "sub/t.npy", "sub/t.json"] {
            assert_eq!(mode(out.join(f)), file, "umask {umask}: {f}");
        }
        assert_eq!(mode(out.join("sub")), folder, "umask {umask}: sub/");
        assert_eq!(
            mode(out.clone()),
            folder,
            "umask {umask}: the output folder"
        );
    }
}

/// The same input writes the same EXR bytes: the header's attributes in one order and the tiles
/// in increasing order, for tables, previews and albedo LUTs.
#[test]
fn exr_output_is_byte_stable() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let command = |kind: &str, out: &str| {
        if kind == "table" {
            return table(dir.path(), 0.5, "16,16,16", out);
        }
        let mut c = lobe();
        c.current_dir(dir.path()).args([kind, "--backend", "cpu"]);
        if kind == "preview" {
            c.args(["--cell", "16", "-o", out]);
        } else {
            c.args(["--lut-res", "8,4", "--samples", "64", "--lut", out]);
        }
        c
    };
    for kind in ["table", "preview", "albedo"] {
        for k in 0..2 {
            // A preview is named by its PNG; its EXR goes beside it.
            let ext = if kind == "preview" { "png" } else { "exr" };
            let o = run(command(kind, &format!("{kind}{k}.{ext}")));
            assert!(o.status.success(), "{kind}: {}", stderr(&o));
        }
        let read =
            |k: usize| std::fs::read(dir.path().join(format!("{kind}{k}.exr"))).expect("reading");
        assert!(
            read(0) == read(1),
            "{kind}: two runs wrote different EXR bytes"
        );
    }
}

fn scene_with(tables_and_more: &str) -> String {
    format!("[[materials]]\nname = \"m\"\nmodel = \"lambert\"\n\n{tables_and_more}")
}

/// Scene outputs stay inside --output-dir: absolute paths and `..` are refused with a sentence;
/// a clash is found on the resolved path, sidecars included (`./t.json` beside a table `t.exr`),
/// and through a symbolic link. Nothing is written in any case.
#[test]
fn scene_outputs_stay_inside_the_output_folder() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let outside = dir.path().join("outside");
    let out = dir.path().join("out");
    std::fs::create_dir_all(&outside).expect("folder");
    std::fs::create_dir_all(&out).expect("folder");
    #[cfg(unix)]
    std::os::unix::fs::symlink(&outside, out.join("link")).expect("symlink");
    let abs = outside.join("t.exr");
    let table = |o: &str| {
        format!("[[tables]]\nmaterial = \"m\"\nn_theta = 4\nn_phi = 8\noutput = \"{o}\"\n")
    };
    let albedo = |o: &str| format!("[[albedos]]\nmaterial = \"m\"\noutput = \"{o}\"\n");
    let mut cases = vec![
        (
            "absolute",
            table(abs.to_str().expect("utf-8")),
            "is an absolute path",
        ),
        ("dot-dot", table("../outside/t.exr"), "'..'"),
        ("deep dot-dot", table("a/../../outside/t.exr"), "'..'"),
        (
            "sidecar clash",
            table("t.exr") + "\n" + &albedo("./t.json"),
            "clashes with the output on line",
        ),
    ];
    #[cfg(unix)]
    cases.push((
        "symbolic link",
        table("link/t.exr"),
        "outside the output folder",
    ));
    for (what, body, expected) in cases {
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, scene_with(&body)).expect("writing the scene");
        let before = (snapshot(&out), snapshot(&outside));
        let o = run({
            let mut c = lobe();
            c.args(["run", "--backend", "cpu", "--output-dir"])
                .arg(&out)
                .arg(&scene);
            c
        });
        let err = stderr(&o);
        assert!(!o.status.success(), "{what}: accepted");
        assert!(err.contains(expected), "{what}: {err}");
        assert!(
            (snapshot(&out), snapshot(&outside)) == before,
            "{what}: files changed"
        );
    }
}

/// `lobe demo -o d` into a folder with a folder in the way of one of its files: refused, and
/// nothing in the folder changes (the old files of the demo's names stay, no new file appears).
#[test]
fn demo_into_a_folder_with_something_in_the_way_changes_nothing() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let d = dir.path().join("d");
    std::fs::create_dir_all(d.join("preview/contact_sheet.png")).expect("a folder in the way");
    std::fs::write(d.join("index.html"), "old page").expect("writing");
    std::fs::write(d.join("preview/contact_sheet.exr"), "old exr").expect("writing");
    std::fs::write(d.join("mine.txt"), "not the demo's").expect("writing");
    let old = snapshot(&d);
    let o = run({
        let mut c = lobe();
        c.args(["demo", "--backend", "cpu", "--quick", "-o"])
            .arg(&d);
        c
    });
    let err = stderr(&o);
    assert!(!o.status.success(), "the demo succeeded");
    assert!(err.contains("in the way"), "{err}");
    assert!(snapshot(&d) == old, "the folder changed: {err}");
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
}

/// SIGTERM stops the other commands that write files too (an albedo LUT while it integrates, a
/// large preview while it renders or encodes): status 130, and the folder as it was.
#[cfg(unix)]
#[test]
fn a_signal_stops_lut_and_preview_runs() {
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::write(dir.path().join("keep.txt"), "mine").expect("writing");
    let old = snapshot(dir.path());
    let runs: [&[&str]; 2] = [
        &["albedo", "--backend", "cpu", "--lut", "l.exr"],
        &[
            "preview",
            "--backend",
            "cpu",
            "--cell",
            "300",
            "-o",
            "p.png",
        ],
    ];
    for args in runs {
        let mut c = lobe();
        c.current_dir(dir.path()).args(args);
        let child = spawn(c);
        // Under way once its temporary files exist.
        assert!(
            wait_for(dir.path(), |s| !s.is_empty()),
            "{args:?} never started"
        );
        std::thread::sleep(Duration::from_millis(100));
        assert!(
            kill(&child, "TERM"),
            "{args:?}: the run ended before the signal"
        );
        assert_interrupted(child, args[0], "interrupted", dir.path(), &old);
    }
}

/// The adaptive reference on measured data (a MERL table split at θd = 45°: a jump on every
/// view direction's circle ωi·ωo = 0) refines for seconds; Ctrl-C and SIGTERM stop it within
/// the time of one batch of panels, with status 130 and no report. Before the reference checked
/// the token between its batches it ran on for minutes after SIGINT.
#[cfg(unix)]
#[test]
fn a_signal_stops_the_reference_on_measured_data() {
    use lobe::merl::{self, BINS, DIMS};
    let dir = tempfile::tempdir().unwrap();
    let mut values = vec![0.0; 3 * BINS];
    for h in 0..DIMS[0] {
        for d in 0..DIMS[1] {
            for p in 0..DIMS[2] {
                for ch in 0..3 {
                    let c = if d < 45 { 0.8 } else { 0.2 };
                    values[ch * BINS + merl::bin(h, d, p)] = c / std::f64::consts::PI;
                }
            }
        }
    }
    let path = dir.path().join("split.binary");
    std::fs::write(&path, merl::encode(&values)).unwrap();
    // How long a signal may take to be obeyed: one batch of the outer integral's panels (each
    // a few inner integrals), well under a second here; 5 s leaves room for a loaded machine.
    const OBEYED_WITHIN: Duration = Duration::from_secs(5);
    for signal in ["INT", "TERM"] {
        let mut c = Command::new(env!("CARGO_BIN_EXE_lobe"));
        c.args([
            "albedo",
            "--backend",
            "cpu",
            "--method",
            "reference",
            "--mu",
            "0.3",
        ])
        .arg("--model")
        .arg(&path);
        let child = spawn(c);
        std::thread::sleep(Duration::from_millis(1500));
        assert!(
            kill(&child, signal),
            "SIG{signal}: the reference ended before the signal"
        );
        let sent = Instant::now();
        let o = child.wait_with_output().expect("waiting for lobe");
        let err = stderr(&o);
        assert!(
            sent.elapsed() < OBEYED_WITHIN,
            "SIG{signal}: lobe took {:?} to stop",
            sent.elapsed()
        );
        assert_eq!(
            o.status.code(),
            Some(INTERRUPTED_STATUS),
            "SIG{signal}: {err}"
        );
        assert!(err.contains("interrupted"), "SIG{signal}: {err}");
    }
}
