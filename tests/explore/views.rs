//! The view routes over HTTP: what they refuse as the command line refuses it, the slice at a
//! chosen φd and the torus under the point light, cell by cell against `lobe eval`.

use super::server::Server;
use serde_json::json;
use std::process::Command;

/// The page's assignments are the spec's own, `M{K=V,...}` in its command lines: a key given
/// twice is refused with the sentence `lobe albedo --model 'M{...}'` prints, on every route that
/// reads a model.
#[test]
fn a_repeated_key_is_refused_as_the_command_line_refuses_it() {
    let server = Server::start(&["cook_torrance"]);
    let sets = ["roughness=0.3", "roughness=0.4"];
    let spec = format!("cook_torrance{{{}}}", sets.join(","));
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(["albedo", "--model", &spec])
        .output()
        .unwrap();
    assert!(!out.status.success(), "lobe albedo --model {spec} ran");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let cli = stderr
        .trim()
        .strip_prefix("lobe: error: ")
        .unwrap_or_else(|| panic!("lobe albedo's error: {stderr}"));
    assert!(cli.contains("'roughness' is given twice"), "{cli}");
    for (path, extra) in [
        ("/api/polar", json!({"samples": 9})),
        ("/api/lobe", json!({"samples": 4})),
        ("/api/albedo", json!({"samples": 4})),
        ("/api/table", json!({"format": "npy"})),
    ] {
        let mut body = json!({"model": "cook_torrance", "sets": sets});
        body.as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        let r = server.post(path, &body);
        assert_eq!(r.status, 422, "{path} {body}: {}", r.text());
        assert_eq!(r.text(), cli, "{path} {body}");
    }
    let r = server.post(
        "/api/plot",
        &json!({"models": [{"model": "cook_torrance", "sets": sets}], "theta_i_deg": 30}),
    );
    assert_eq!(r.status, 422, "{}", r.text());
    assert_eq!(r.text(), cli, "/api/plot");
    // Two keys, one given once each (an rgb triple among them), are answered.
    let r = server.post(
        "/api/polar",
        &json!({"model": "phong", "sets": ["shininess=20", "specular=0.9,0.5,0.2"], "samples": 9}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
}
