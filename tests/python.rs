//! The Python package as a user gets it: `pip install '.[ray]'` into a fresh virtual environment
//! under target/ (maturin builds the extension in release, reusing target/; Ray comes along for
//! lobe.batch's cluster tests), then pytest over tests/python against the installed package, with
//! this build's `lobe` binary to compare with.
//! `LOBE_PYTHON` names the interpreter (default `python3`).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const INSTALL_HINT: &str = "the Python tests need python3 with venv and pip: apt-get install \
     python3-venv python3-pip (scripts/with-vulkan installs them for `cargo test`)";

fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"))
}

fn run(what: &str, cmd: &mut Command) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start {cmd:?}: {e}; {INSTALL_HINT}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{text}",
        out.status
    );
    text
}

#[test]
fn the_python_package_installs_into_a_fresh_venv_and_passes_its_suite() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = target_dir(root);
    let python = std::env::var("LOBE_PYTHON").unwrap_or_else(|_| "python3".to_string());
    let venv = target.join("py-venv");
    if venv.exists() {
        std::fs::remove_dir_all(&venv).expect("removing the old target/py-venv");
    }
    run(
        "creating a virtual environment",
        Command::new(&python).args(["-m", "venv"]).arg(&venv),
    );
    let venv_python = venv.join("bin").join("python");

    let started = Instant::now();
    run(
        "pip install .[ray] pytest",
        Command::new(&venv_python)
            .args(["-m", "pip", "install", "--quiet", ".[ray]", "pytest"])
            .current_dir(root)
            .env("CARGO_TARGET_DIR", &target),
    );
    eprintln!(
        "python: pip install '.[ray]' into a fresh venv took {:.1} s",
        started.elapsed().as_secs_f64()
    );

    // From a folder outside the source tree, so that `import lobe` finds the installed package
    // (conftest.py checks that it comes from the venv).
    let scratch = tempfile::tempdir().expect("a scratch folder");
    let report = run(
        "pytest tests/python",
        Command::new(&venv_python)
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(root.join("tests").join("python"))
            .current_dir(scratch.path())
            .env("LOBE_BIN", env!("CARGO_BIN_EXE_lobe")),
    );
    eprintln!("{report}");
}
