//! The page's downloads are the command line's files: the table (`.npy`, EXR) byte for byte what
//! `lobe table` writes, the polar plot's SVG what `lobe plot` draws, for the same models.

use super::server::{manifest, Server};
use serde_json::json;
use std::path::Path;
use std::process::Command;

fn lobe(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .current_dir(manifest())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "lobe {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn assert_same_file(what: &str, got: &[u8], path: &Path) {
    let want = std::fs::read(path).unwrap();
    assert!(
        got == want.as_slice(),
        "{what}: the download ({} bytes) differs from {} ({} bytes)",
        got.len(),
        path.display(),
        want.len()
    );
}

#[test]
fn downloads_equal_the_files_of_the_command_lines() {
    let server = Server::start(&["lambert"]);
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("table-1.exr");
    // The grid the page's "lobe table" line names (catalog "table").
    let catalog = server.get_json("/api/models");
    let (grid, res) = (
        catalog["table"]["grid"].as_str().unwrap().to_string(),
        catalog["table"]["res"].as_str().unwrap().to_string(),
    );
    lobe(&[
        "table",
        "--model",
        "cook_torrance{roughness=0.2}",
        "--material",
        "gold",
        "--grid",
        &grid,
        "--res",
        &res,
        "-o",
        exr.to_str().unwrap(),
    ]);
    for (format, file) in [("npy", exr.with_extension("npy")), ("exr", exr.clone())] {
        let r = server.post(
            "/api/table",
            &json!({"model": "cook_torrance", "material": "gold", "sets": ["roughness=0.2"], "format": format}),
        );
        assert_eq!(r.status, 200, "{}", r.text());
        assert!(r.head.contains("attachment"), "{}", r.head);
        assert_same_file(&format!("table as {format}"), &r.body, &file);
    }

    let svg = dir.path().join("polar.svg");
    lobe(&[
        "plot",
        "--kind",
        "polar",
        "-o",
        svg.to_str().unwrap(),
        "--model",
        "cook_torrance{roughness=0.2}",
        "--model",
        "microfacet",
        "--material",
        "gold",
        "--theta-i-deg",
        "40",
        "--cos",
        "--log",
    ]);
    let r = server.post(
        "/api/plot",
        &json!({"models": [
            {"model": "cook_torrance", "material": "gold", "sets": ["roughness=0.2"]},
            {"model": "microfacet", "material": "gold"}],
            "theta_i_deg": 40, "cos": true, "log": true}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    assert!(r.head.contains("image/svg+xml"), "{}", r.head);
    assert_same_file("polar plot as SVG", &r.body, &svg);
}

#[test]
fn refuses_downloads_it_cannot_make_with_a_sentence() {
    let server = Server::start(&["lambert"]);
    for (path, body, says) in [
        (
            "/api/table",
            json!({"model": "lambert", "format": "pdf"}),
            "format \"pdf\": expected \"npy\" or \"exr\"",
        ),
        (
            "/api/table",
            json!({"model": "no_such_model", "format": "npy"}),
            "model no_such_model",
        ),
        (
            "/api/plot",
            json!({"models": [], "theta_i_deg": 30}),
            "0 models: a plot overlays 1 to",
        ),
        (
            "/api/plot",
            json!({"models": [{"model": "lambert"}], "theta_i_deg": 90}),
            "theta_i_deg 90: expected an incidence angle in [0, 90) degrees",
        ),
    ] {
        let r = server.post(path, &body);
        assert_eq!(r.status, 422, "{path} {body}: {}", r.text());
        assert!(r.text().contains(says), "{path} {body}: {}", r.text());
    }
}
