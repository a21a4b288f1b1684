//! Promises at the edges of what a user can type: directions exactly on the horizon.

mod common;

use std::path::Path;

/// Every built-in model (`lobe models --format json`, so a new model is covered).
fn model_names() -> Vec<String> {
    let v = common::lobe_json(&["models", "--format", "json"]);
    let models = v["models"].as_array().expect("a list of models");
    models
        .iter()
        .map(|m| m["name"].as_str().expect("a model's name").to_string())
        .collect()
}

/// θ = 90° is on the horizon, where every BRDF is zero (one-sided rule, design §3): the
/// direction's cos θ must be exactly 0, not the 6.1e-17 of cos(π/2) in floating point, which
/// gave Phong 2.86/sr at grazing light and view on both backends. Light, view and both on the
/// horizon, at azimuths that are multiples of 90° and not.
#[test]
fn a_direction_on_the_horizon_gives_zero_on_both_backends() {
    let models = model_names();
    assert!(models.len() >= 10, "lobe models listed {models:?}");
    let cases = [
        ("90,0", "90,180"),
        ("90,0", "30,180"),
        ("30,0", "90,180"),
        ("90,37", "90,-143"),
        ("90,270", "90,90"),
    ];
    for backend in ["gpu", "cpu"] {
        if backend == "gpu" && common::gpu_device("horizon on the GPU").is_none() {
            continue;
        }
        for model in &models {
            for (wi, wo) in cases {
                let v = common::lobe_json(&[
                    "eval",
                    "--model",
                    model,
                    "--backend",
                    backend,
                    "--wi-deg",
                    wi,
                    "--wo-deg",
                    wo,
                    "--format",
                    "json",
                ]);
                let rgb = &v["values"][0]["rgb"];
                assert_eq!(
                    rgb,
                    &serde_json::json!([0.0, 0.0, 0.0]),
                    "{model} on the {backend}: f(ωi = {wi}°, ωo = {wo}°) = {rgb}"
                );
            }
        }
    }
}

/// A table of a few cells on the CPU, short of its `-o`.
const TINY_TABLE: &[&str] = &[
    "table",
    "--model",
    "lambert",
    "--backend",
    "cpu",
    "--grid",
    "isotropic",
    "--res",
    "4,4,4",
];

/// Runs lobe and returns (success, stderr).
fn lobe(args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .output()
        .expect("run lobe");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A spec that names one parameter twice is refused (which value wins is a guess), naming the
/// key and both values; an rgb triple's commas are not taken for more keys.
#[test]
fn a_parameter_given_twice_in_one_spec_is_refused() {
    let at = ["--wi-deg", "30,0", "--wo-deg", "30,180", "--backend", "cpu"];
    for spec in [
        "phong{shininess=1,shininess=2}",
        "phong{ shininess=1 , diffuse=0.1,0.2,0.3, shininess =2}",
    ] {
        let (ok, err) = lobe(&[&["eval", "--model", spec], &at[..]].concat());
        assert!(!ok, "{spec} was accepted");
        assert!(
            err.contains("'shininess' is given twice") && err.contains("shininess=1"),
            "{spec}: {err}"
        );
    }
    let (ok, err) = lobe(
        &[
            &["eval", "--model", "phong{diffuse=0.1,0.2,0.3,shininess=5}"],
            &at[..],
        ]
        .concat(),
    );
    assert!(ok, "{err}");
}

/// Runs lobe, killing it if it has not finished within `limit`: (finished, success, stderr).
fn lobe_within(args: &[&std::ffi::OsStr], limit: std::time::Duration) -> (bool, bool, String) {
    use std::io::Read;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run lobe");
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for lobe") {
            break Some(s);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let mut err = String::new();
    let _ = child.stderr.take().map(|mut e| e.read_to_string(&mut err));
    (status.is_some(), status.is_some_and(|s| s.success()), err)
}

/// Makes a named pipe at `path`.
fn mkfifo(path: &std::path::Path) {
    let made = std::process::Command::new("mkfifo").arg(path).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo {}", path.display());
}

/// Every input path is read only when it is a regular file (links followed), within a bound:
/// a table target whose .npy or sidecar links to /dev/zero grew the process to 20 GB, and a FIFO
/// as a table target, its sidecar, a scene or a pairs file blocked forever. Each is refused at
/// once, naming the file and what it is.
#[test]
fn devices_and_pipes_are_refused_as_inputs() {
    // Long enough for a refusal on a loaded machine; a read of /dev/zero or a blocked FIFO never
    // finishes.
    const LIMIT: std::time::Duration = std::time::Duration::from_secs(60);
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("t.exr");
    let (ok, err) = lobe(&[TINY_TABLE, &["-o", table.to_str().unwrap()]].concat());
    assert!(ok, "{err}");
    let fit = |target: &std::path::Path| {
        let args = [
            "fit",
            "--target",
            target.to_str().unwrap(),
            "--model",
            "lambert",
            "--free",
            "albedo",
            "--backend",
            "cpu",
        ];
        let args: Vec<_> = args.iter().map(std::ffi::OsStr::new).collect();
        lobe_within(&args, LIMIT)
    };
    let npy = dir.path().join("t.npy");
    let json = dir.path().join("t.json");
    let (good_npy, good_json) = (dir.path().join("good.npy"), dir.path().join("good.json"));
    std::fs::rename(&npy, &good_npy).unwrap();
    std::fs::rename(&json, &good_json).unwrap();
    for broken in [&npy, &json] {
        std::fs::copy(&good_npy, &npy).unwrap();
        std::fs::copy(&good_json, &json).unwrap();
        std::fs::remove_file(broken).unwrap();
        std::os::unix::fs::symlink("/dev/zero", broken).unwrap();
        let name = broken.file_name().unwrap().to_str().unwrap();
        let (finished, ok, err) = fit(&npy);
        assert!(
            finished && !ok,
            "{name} -> /dev/zero: finished {finished}, {err}"
        );
        assert!(err.contains("a device") && err.contains(name), "{err}");
        std::fs::remove_file(broken).unwrap();
        mkfifo(broken);
        let (finished, ok, err) = fit(&npy);
        assert!(finished && !ok, "{name} a FIFO: finished {finished}, {err}");
        assert!(err.contains("FIFO") && err.contains(name), "{err}");
        std::fs::remove_file(broken).unwrap();
    }
    std::fs::copy(&good_npy, &npy).unwrap();
    std::fs::copy(&good_json, &json).unwrap();
    let (finished, ok, err) = fit(&npy);
    assert!(finished && ok, "the table itself: {err}");
    let fifo = dir.path().join("in.fifo");
    let brdf_fifo = dir.path().join("in.brdf");
    mkfifo(&fifo);
    mkfifo(&brdf_fifo);
    let out = dir.path().join("out");
    for (args, name) in [
        (
            vec![
                "run".as_ref(),
                fifo.as_os_str(),
                "--output-dir".as_ref(),
                out.as_os_str(),
            ],
            "in.fifo",
        ),
        (
            vec![
                "eval".as_ref(),
                "--pairs".as_ref(),
                fifo.as_os_str(),
                "--backend".as_ref(),
                "cpu".as_ref(),
            ],
            "in.fifo",
        ),
        (
            vec!["eval".as_ref(), "--model".as_ref(), brdf_fifo.as_os_str()],
            "in.brdf",
        ),
    ] {
        let (finished, ok, err) = lobe_within(&args, LIMIT);
        assert!(finished && !ok, "{args:?}: finished {finished}, {err}");
        assert!(
            err.contains("FIFO") && err.contains(name),
            "{args:?}: {err}"
        );
    }
}

/// With standard output closed (`>&-`), a report would be lost without a word (status 0):
/// every command refuses, saying so on stderr. A caller's /dev/null is honoured however it was
/// opened: write-only as a shell's `> /dev/null` opens it, and read-write as `1<> /dev/null`,
/// Python's `subprocess.DEVNULL` and many job runners open it (which is also what Rust's runtime
/// puts on a closed descriptor, so lobe must look before the runtime does).
#[test]
fn a_closed_standard_output_is_refused_and_dev_null_is_honoured() {
    let lobe = env!("CARGO_BIN_EXE_lobe");
    for args in [
        "models",
        "eval --backend cpu --wi-deg 30,0 --wo-deg 30,180",
        "albedo --backend cpu --model lambert",
    ] {
        let run = |redirect: &str| {
            std::process::Command::new("sh")
                .arg("-c")
                .arg(format!("exec \"$0\" {args} {redirect}"))
                .arg(lobe)
                .output()
                .expect("run sh")
        };
        let closed = run(">&-");
        let err = String::from_utf8_lossy(&closed.stderr);
        assert!(!closed.status.success(), "lobe {args} >&-: {err}");
        assert!(
            err.contains("standard output is closed"),
            "lobe {args} >&-: {err}"
        );
        for null in ["> /dev/null", "1<> /dev/null"] {
            let done = run(null);
            assert!(
                done.status.success(),
                "lobe {args} {null}: {}",
                String::from_utf8_lossy(&done.stderr)
            );
        }
    }
}

/// A folder that can be written but not listed (mode 733) cannot be opened for its lock, and
/// lobe went on without it: two runs could each commit part of one set. Such a folder is refused
/// before any work, naming it, and nothing is left in it. Run as an unprivileged user (root can
/// open any folder): under root through `setpriv` as `nobody`, with a copy of lobe that user can
/// run.
#[test]
fn a_folder_that_cannot_be_locked_is_refused() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let lobe = dir.path().join("lobe");
    std::fs::copy(env!("CARGO_BIN_EXE_lobe"), &lobe).unwrap();
    let unlisted = dir.path().join("unlisted");
    std::fs::create_dir(&unlisted).unwrap();
    std::fs::set_permissions(&unlisted, std::fs::Permissions::from_mode(0o733)).unwrap();
    // SAFETY: geteuid only reads the process's effective user id.
    let root = unsafe { libc::geteuid() } == 0;
    let mut cmd = if root {
        let mut c = std::process::Command::new("setpriv");
        c.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
            .arg(&lobe);
        c
    } else {
        std::process::Command::new(&lobe)
    };
    let out = cmd
        .args(TINY_TABLE)
        .arg("-o")
        .arg(unlisted.join("t.exr"))
        .output()
        .expect("run lobe");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("cannot lock the output folder") && err.contains("unlisted"),
        "{err}"
    );
    std::fs::set_permissions(&unlisted, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert_eq!(
        std::fs::read_dir(&unlisted).unwrap().count(),
        0,
        "files were left behind"
    );
}

/// Refusals name what the user gave: an azimuth beyond ±1e6° is refused by `albedo` and `plot`
/// as by `eval` (it was accepted and printed as a 300-digit angle); a choice as a LUT axis is
/// named as such (the message blamed a `--lut-range 0,0` never given); a model without numeric
/// parameters names `--lut` (the message read "--lut-param :").
#[test]
fn refusals_name_the_flags_the_user_gave() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let merl = path("diffuse_white.binary");
    let (ok, err) = lobe(&[
        "table",
        "--backend",
        "cpu",
        "--model",
        "lambert",
        "--format",
        "merl",
        "--grid",
        "halfdiff",
        "-o",
        &merl,
    ]);
    assert!(ok, "{err}");
    let (lut, png) = (path("lut.exr"), path("h.png"));
    for (args, says, never) in [
        (
            vec![
                "albedo",
                "--backend",
                "cpu",
                "--model",
                "lambert",
                "--phi-o-deg",
                "1e300",
            ],
            "--phi-o-deg: phi = 1e300 deg is out of range",
            "",
        ),
        (
            vec![
                "plot",
                "--backend",
                "cpu",
                "--kind",
                "hemisphere",
                "--phi-i-deg",
                "1e300",
                "-o",
                &png,
            ],
            "--phi-i-deg: phi = 1e300 deg is out of range",
            "",
        ),
        (
            vec![
                "albedo",
                "--backend",
                "cpu",
                "--model",
                "microfacet",
                "--lut",
                &lut,
                "--lut-param",
                "distribution",
            ],
            "--lut-param distribution: LUT axis key 'distribution' is a choice",
            "--lut-range",
        ),
        (
            vec![
                "albedo",
                "--backend",
                "cpu",
                "--model",
                &merl,
                "--lut",
                &lut,
            ],
            "--lut: the model diffuse_white has no numeric parameter",
            "--lut-param",
        ),
    ] {
        let (ok, err) = lobe(&args);
        assert!(!ok && err.contains(says), "{args:?}: {err}");
        assert!(never.is_empty() || !err.contains(never), "{args:?}: {err}");
    }
    assert!(!Path::new(&lut).exists() && !Path::new(&png).exists());
}
