//! `lobe explore`: the real server on an ephemeral port, spoken to over real HTTP (a plain
//! socket, so that the tests can send what a browser would not: no token, a foreign Host), and
//! the page in headless Chromium over the DevTools protocol.

#[path = "explore/busy.rs"]
mod busy;
#[path = "explore/cdp.rs"]
mod cdp;
#[path = "explore/downloads.rs"]
mod downloads;
#[path = "explore/merl.rs"]
mod merl;
#[path = "explore/optional.rs"]
mod optional;
#[path = "explore/page.rs"]
mod page;
#[path = "explore/restore.rs"]
mod restore;
#[path = "explore/server.rs"]
mod server;
#[path = "explore/stale.rs"]
mod stale;
#[path = "explore/views.rs"]
mod views;

use serde_json::{json, Value};
use server::{floats, http, http_chunked, http_claiming, manifest, Server};
use std::io::Read;
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

/// The f32 values the server sends and `lobe eval` prints come from the same kernel on the same
/// device; the directions differ in their last bits (the server builds them from radians as the
/// polar plot does, `lobe eval` from degrees), which moves a Phong lobe of exponent ≤ 1000 by far
/// less than this relative amount.
const SAME_BACKEND_REL: f64 = 1e-4;

/// The page's albedo and `lobe albedo` run the same rule with the same nodes on the same device;
/// only the order of the GPU's partial sums may differ between two runs (f32 sums of ~10⁶ terms
/// round at ~1e-6 relative).
const SAME_RULE_REL: f64 = 1e-5;

/// The page shows 5 significant digits: half a unit in the 5th place, relative.
const SHOWN_REL: f64 = 5e-5;

/// How long a page may take to load and draw its first frame on a shared 2-core machine.
const PAGE_TIMEOUT: Duration = Duration::from_secs(90);

/// `lobe eval` (same backend as the server: the default GPU) at `pairs` of degrees
/// (θi, φi, θo, φo).
fn lobe_eval(model: &str, pairs: &[[f64; 4]]) -> Vec<[f64; 3]> {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("pairs.csv");
    let mut csv = String::from("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n");
    for p in pairs {
        csv += &format!("{},{},{},{}\n", p[0], p[1], p[2], p[3]);
    }
    std::fs::write(&file, csv).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(["eval", "--model", model, "--pairs"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[4], v[5], v[6]]
        })
        .collect()
}

/// `lobe albedo --format json`'s hemispherical albedo of `model`.
fn common_albedo(model: &str) -> Vec<f64> {
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(["albedo", "--model", model, "--format", "json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    serde_json::from_value(v["hemispherical"]["albedo"].clone()).unwrap()
}

/// The `lobe eval` angles of polar view angle `s` (degrees) for a light at (θi, 180°): the page's
/// geometry (docs/architecture.md, the explorer).
fn polar_pair(theta_i: f64, s: f64) -> [f64; 4] {
    [theta_i, 180.0, s.abs(), if s >= 0.0 { 0.0 } else { 180.0 }]
}

fn assert_close(what: &str, got: f64, want: f64, rel: f64) {
    let err = (got - want).abs();
    assert!(
        err <= rel * want.abs().max(1e-30),
        "{what}: got {got}, lobe eval {want}, error {err:e}, allowed {:e}",
        rel * want.abs()
    );
}

#[test]
fn refuses_requests_without_the_token() {
    let server = Server::start(&["lambert"]);
    let body = json!({"model": "lambert", "samples": 3}).to_string();
    for (method, target) in [
        ("GET", "/"),
        ("GET", "/app.js"),
        ("GET", "/views.js"),
        ("GET", "/lobe3d.js"),
        ("GET", "/files.js"),
        ("GET", "/style.css"),
        ("GET", "/api/models"),
    ] {
        let r = http(&server.addr, method, target, &[], b"");
        assert_eq!(r.status, 403, "{method} {target}: {}", r.text());
        assert!(r.text().contains("token"), "{}", r.text());
    }
    let r = http(&server.addr, "POST", "/api/polar", &[], body.as_bytes());
    assert_eq!(r.status, 403, "{}", r.text());
    let wrong = "0".repeat(server.token.len());
    let r = http(&server.addr, "GET", &format!("/?token={wrong}"), &[], b"");
    assert_eq!(r.status, 403, "{}", r.text());
    let r = http(
        &server.addr,
        "POST",
        "/api/polar",
        &[("x-lobe-token", &wrong)],
        body.as_bytes(),
    );
    assert_eq!(r.status, 403, "{}", r.text());
    // With the token the same requests are answered.
    let r = http(
        &server.addr,
        "GET",
        &format!("/?token={}", server.token),
        &[],
        b"",
    );
    assert_eq!(r.status, 200, "{}", r.text());
    assert!(r.text().contains(&format!("app.js?token={}", server.token)));
    // Every script and style the page names is served.
    for (asset, kind) in [
        ("app.js", "text/javascript"),
        ("views.js", "text/javascript"),
        ("lobe3d.js", "text/javascript"),
        ("files.js", "text/javascript"),
        ("style.css", "text/css"),
    ] {
        assert!(
            r.text()
                .contains(&format!("{asset}?token={}", server.token)),
            "the page does not load {asset}"
        );
        let a = http(
            &server.addr,
            "GET",
            &format!("/{asset}?token={}", server.token),
            &[],
            b"",
        );
        assert_eq!(a.status, 200, "{asset}: {}", a.text());
        assert!(
            a.head
                .to_ascii_lowercase()
                .contains(&format!("content-type: {kind}")),
            "{asset}: {}",
            a.head
        );
    }
    assert!(
        !r.head.to_ascii_lowercase().contains("access-control-allow"),
        "{}",
        r.head
    );
}

#[test]
fn refuses_a_foreign_host_or_origin() {
    let server = Server::start(&["lambert"]);
    let target = format!("/?token={}", server.token);
    let port = server.addr.rsplit(':').next().unwrap().to_string();
    for host in [
        format!("evil.example:{port}"),
        "127.0.0.1:1".to_string(),
        String::new(),
    ] {
        let r = http(&server.addr, "GET", &target, &[("Host", &host)], b"");
        assert_eq!(r.status, 403, "Host {host}: {}", r.text());
        assert!(r.text().contains("Host"), "{}", r.text());
    }
    let local = format!("localhost:{port}");
    assert_eq!(
        http(&server.addr, "GET", &target, &[("Host", &local)], b"").status,
        200
    );
    let r = http(
        &server.addr,
        "GET",
        &target,
        &[("Origin", "http://evil.example")],
        b"",
    );
    assert_eq!(r.status, 403, "{}", r.text());
}

#[test]
fn refuses_oversized_requests_with_a_sentence() {
    let server = Server::start(&["lambert"]);
    let token = [("x-lobe-token", server.token.as_str())];
    let big = lobe::explore::MAX_BODY_BYTES + 1;
    let r = http_claiming(&server.addr, "POST", "/api/polar", &token, big, b"");
    assert_eq!(r.status, 413, "{}", r.text());
    assert!(
        r.text()
            .contains(&lobe::explore::MAX_BODY_BYTES.to_string()),
        "{}",
        r.text()
    );
    let long = format!(
        "/api/models?token={}&x={}",
        server.token,
        "a".repeat(lobe::explore::MAX_URI_BYTES)
    );
    assert_eq!(http(&server.addr, "GET", &long, &[], b"").status, 414);
    // A body sent chunked declares no length: it is refused at the bound as it arrives.
    let padded = format!(
        "{{\"model\": \"lambert\"{}}}",
        " ".repeat(lobe::explore::MAX_BODY_BYTES)
    );
    let r = http_chunked(
        &server.addr,
        "POST",
        "/api/polar",
        &token,
        padded.as_bytes(),
    );
    assert_eq!(r.status, 413, "{}", r.text());
    assert!(
        r.text()
            .contains(&lobe::explore::MAX_BODY_BYTES.to_string()),
        "{}",
        r.text()
    );
    let brdf = lobe::explore::MAX_BRDF_BYTES + 1;
    let r = http_claiming(
        &server.addr,
        "POST",
        "/api/brdf?name=big.brdf",
        &token,
        brdf,
        b"",
    );
    assert_eq!(r.status, 413, "{}", r.text());
    let cases = [
        (
            "/api/polar",
            json!({"model": "lambert", "samples": lobe::explore::MAX_POLAR_SAMPLES + 1}),
            "view angles from 1 to",
        ),
        (
            "/api/hemisphere",
            json!({"model": "lambert", "samples": lobe::explore::MAX_IMAGE_RES + 1}),
            "cells across from 1 to",
        ),
        (
            "/api/albedo",
            json!({"model": "lambert", "samples": 0}),
            "view directions from 1 to",
        ),
        (
            "/api/polar",
            json!({"model": "lambert", "samples": 3, "theta_i_deg": 95}),
            "theta_i_deg 95",
        ),
        (
            "/api/polar",
            json!({"model": "phong", "samples": 3, "sets": ["shininess=-1"]}),
            "shininess",
        ),
        (
            "/api/polar",
            json!({"model": "nonesuch", "samples": 3}),
            "nonesuch",
        ),
    ];
    for (path, body, says) in cases {
        let r = server.post(path, &body);
        assert_eq!(r.status, 422, "{path} {body}: {}", r.text());
        assert!(r.text().contains(says), "{path} {body}: {}", r.text());
    }
}

#[test]
fn a_file_that_does_not_load_is_not_kept() {
    let server = Server::start(&["lambert"]);
    let token = [("x-lobe-token", server.token.as_str())];
    let text = std::fs::read(manifest().join("testdata/brdf/bad/typo.brdf")).unwrap();
    for _ in 0..3 {
        let r = http(
            &server.addr,
            "POST",
            "/api/brdf?name=typo.brdf",
            &token,
            &text,
        );
        assert_eq!(r.status, 422, "{}", r.text());
        assert!(r.text().contains("typo.brdf"), "{}", r.text());
    }
    // The server's one folder holds no file of the three.
    let kept: Vec<PathBuf> = std::fs::read_dir(server.tmp.path())
        .unwrap()
        .flat_map(|e| std::fs::read_dir(e.unwrap().path()).unwrap())
        .map(|e| e.unwrap().path())
        .collect();
    assert!(kept.is_empty(), "kept: {kept:?}");
}

#[test]
fn polar_values_equal_lobe_eval() {
    let server = Server::start(&["phong{shininess=50}"]);
    let spec = "phong{shininess=50,specular=0.9,0.5,0.2}";
    let n = 9;
    let r = server.post(
        "/api/polar",
        &json!({"model": "phong", "sets": ["shininess=50", "specular=0.9,0.5,0.2"], "theta_i_deg": 30, "samples": n}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let got = floats(&r.body);
    assert_eq!(got.len(), 3 * n);
    let angles: Vec<f64> = (0..n)
        .map(|k| -90.0 + (k as f64 + 0.5) * 180.0 / n as f64)
        .collect();
    let want = lobe_eval(
        spec,
        &angles
            .iter()
            .map(|&s| polar_pair(30.0, s))
            .collect::<Vec<_>>(),
    );
    for (k, w) in want.iter().enumerate() {
        for c in 0..3 {
            assert_close(
                &format!("{spec} at s = {}°, channel {c}", angles[k]),
                got[3 * k + c] as f64,
                w[c],
                SAME_BACKEND_REL,
            );
        }
    }
    // The mirror direction (s = +30°) holds the peak, and colour reaches the values.
    assert!(got[3 * 6] > got[3 * 6 + 2], "{got:?}");
}

/// The θh × θd slice (φh = 0, φd = 90°), the sphere under the point light and the 3D lobe's mesh,
/// cell by cell,
/// against `lobe eval` at the same directions.
#[test]
fn slice_sphere_and_3d_lobe_equal_lobe_eval() {
    let server = Server::start(&["lambert"]);
    let spec = "cook_torrance{roughness=0.2}";
    let ask = |path: &str, res: usize| {
        let r = server.post(
            path,
            &json!({"model": "cook_torrance", "sets": ["roughness=0.2"], "theta_i_deg": 40, "samples": res}),
        );
        assert_eq!(r.status, 200, "{path}: {}", r.text());
        floats(&r.body)
    };
    let res = 4;
    let slice = ask("/api/slice", res);
    let step = 90.0 / res as f64;
    let mut pairs = Vec::new();
    for row in 0..res {
        for col in 0..res {
            let (th, td) = ((col as f64 + 0.5) * step, (row as f64 + 0.5) * step);
            let (wi, wo) = lobe::grid::half_diff_to_pair(
                th.to_radians(),
                0.0,
                td.to_radians(),
                90f64.to_radians(),
            );
            let ((ti, pi), (to, po)) = (lobe::grid::angles_deg(wi), lobe::grid::angles_deg(wo));
            pairs.push([ti, pi, to, po]);
        }
    }
    for (k, w) in lobe_eval(spec, &pairs).iter().enumerate() {
        assert_close(
            &format!("{spec} slice cell {k} {:?}", pairs[k]),
            slice[3 * k] as f64,
            w[0],
            SAME_BACKEND_REL,
        );
    }
    // An odd sphere's middle cell faces the viewer: f(θi = 40°, θo = 0) cos 40°; the corners
    // are outside the disc.
    let sphere = ask("/api/sphere", 5);
    let want = lobe_eval(spec, &[[40.0, 180.0, 0.0, 0.0]])[0][1] * 40f64.to_radians().cos();
    assert_close(
        &format!("{spec} sphere centre"),
        sphere[3 * 12 + 1] as f64,
        want,
        SAME_BACKEND_REL,
    );
    assert!(sphere[0].is_nan(), "{sphere:?}");
    // The 3D lobe's mesh: row r at θo = (r + ½)·90°/res, column c at φo = c·360°/res.
    let mesh = ask("/api/lobe", res);
    let mut pairs = Vec::new();
    for row in 0..res {
        for col in 0..res {
            pairs.push([
                40.0,
                180.0,
                (row as f64 + 0.5) * 90.0 / res as f64,
                col as f64 * 360.0 / res as f64,
            ]);
        }
    }
    for (k, w) in lobe_eval(spec, &pairs).iter().enumerate() {
        assert_close(
            &format!("{spec} 3D lobe cell {k} {:?}", pairs[k]),
            mesh[3 * k] as f64,
            w[0],
            SAME_BACKEND_REL,
        );
    }
}

/// A JSON number read back: serde_json parses a shortest round-trip decimal to within one unit
/// in the last place of the f64 written, so a unit vector's components agree to this.
const JSON_READ_ABS: f64 = 1e-15;

/// The rows of a `lobe sample` .npy (version 1 header, little-endian f64, n × 8).
fn npy_rows(path: &std::path::Path) -> Vec<[f64; 8]> {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    bytes[10 + header..]
        .chunks_exact(64)
        .map(|row| {
            let mut r = [0.0; 8];
            for (k, v) in row.chunks_exact(8).enumerate() {
                r[k] = f64::from_le_bytes(v.try_into().unwrap());
            }
            r
        })
        .collect()
}

/// The samples view's draws are `lobe sample`'s for the same model, ωo and seed, and its pdf
/// grid is `Session::pdf` at the hemisphere view's cell centres; bad settings are refused with
/// a sentence naming them.
#[test]
fn samples_view_equals_lobe_sample_and_session_pdf() {
    let server = Server::start(&["phong{shininess=50}"]);
    let (n, seed, res) = (256, 5u32, 16);
    let r = server.post(
        "/api/samples",
        &json!({"model": "phong", "sets": ["shininess=50"], "theta_o_deg": 30,
                "phi_o_deg": 20, "draws": n, "seed": seed, "res": res}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let v: Value = serde_json::from_slice(&r.body).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("s.npy");
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "sample",
            "--model",
            "phong{shininess=50}",
            "--theta-o-deg",
            "30",
        ])
        .args([
            "--phi-o-deg",
            "20",
            "-n",
            &n.to_string(),
            "--seed",
            &seed.to_string(),
        ])
        .arg("-o")
        .arg(&npy)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = npy_rows(&npy);
    assert_eq!(rows.len(), n);
    let wi = v["wi"].as_array().unwrap();
    assert_eq!(wi.len(), n);
    for (k, row) in rows.iter().enumerate() {
        for c in 0..3 {
            let got = wi[k][c].as_f64().unwrap();
            assert!(
                (got - row[c]).abs() <= JSON_READ_ABS,
                "draw {k} component {c}: page {got}, lobe sample {}",
                row[c]
            );
        }
        let got = v["pdf"][k].as_f64().unwrap();
        assert!(
            (got - row[6]).abs() <= JSON_READ_ABS * row[6].max(1.0),
            "pdf {k}: {got} vs {}",
            row[6]
        );
    }
    assert_eq!(v["delta_count"], 0, "Phong has no mirror spike");
    // The grid: cell centres of the equal-area disc, pdf(ωi = cell, ωo) from the library.
    let t = 30f64.to_radians();
    let p = 20f64.to_radians();
    let wo = lobe::glam::DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    let grid = v["pdf_grid"].as_array().unwrap();
    assert_eq!(grid.len(), res * res);
    let phong = lobe::resolve_spec(
        "phong{shininess=50}",
        None,
        &[],
        &Default::default(),
        &mut |_| {},
    )
    .unwrap();
    let session = lobe::Session::cpu();
    let mut inside = 0;
    for k in 0..res * res {
        let (x, y) = lobe::plot::hemisphere::cell_point(res, k / res, k % res);
        match lobe::plot::hemisphere::cell_direction(
            lobe::plot::hemisphere::Projection::EqualArea,
            x,
            y,
        ) {
            Some(d) => {
                inside += 1;
                let want = session.pdf(&phong, &[(d, wo)]).unwrap()[0];
                let got = grid[k].as_f64().unwrap();
                assert!(
                    (got - want).abs() <= JSON_READ_ABS * want.max(1.0),
                    "cell {k}: {got} vs {want}"
                );
            }
            None => assert!(grid[k].is_null(), "cell {k} outside the disc: {}", grid[k]),
        }
    }
    assert!(inside > res * res / 2, "{inside} cells inside the disc");
    for (body, names) in [
        (
            json!({"model": "phong", "theta_o_deg": 30, "draws": 0, "res": 8}),
            "draws 0",
        ),
        (
            json!({"model": "phong", "theta_o_deg": 30, "draws": 1_000_000, "res": 8}),
            "draws 1000000",
        ),
        (
            json!({"model": "phong", "theta_o_deg": 90, "draws": 8, "res": 8}),
            "theta_o_deg 90",
        ),
        (
            json!({"model": "phong", "theta_o_deg": 30, "draws": 8, "res": 0}),
            "res 0",
        ),
        (
            json!({"model": "phong", "theta_o_deg": 30, "draws": 8, "res": 8, "n": 3}),
            "unknown field",
        ),
    ] {
        let r = server.post("/api/samples", &body);
        assert_eq!(r.status, 422, "{body}: {}", r.text());
        assert!(r.text().contains(names), "{body}: {}", r.text());
    }
}

/// The page's samples view has a row per model, in the page's order: moving θo asks again for
/// each, and each row's draws and pdf are what the route answers for that model's request (the
/// test's own, so the page asked for the model, ωo, draws and seed it should); a model the server
/// refuses shows the refusal in its own row, and the other row keeps its draws.
#[test]
fn samples_view_in_chromium_shows_draws_and_pdf_of_every_model() {
    /// The page's draws (app.js SAMPLE_DRAWS).
    const DRAWS: u64 = 2048;
    /// The page's random stream (app.js SAMPLE_SEED).
    const SEED: u64 = 0;
    /// The page's pdf cells across (app.js IMAGE_RES).
    const RES: u64 = 64;
    let entries = [
        ("lambert", json!([])),
        ("cook_torrance", json!(["roughness=0.1"])),
    ];
    let server = Server::start(&["lambert", "cook_torrance{roughness=0.1}"]);
    let mut b = cdp::Browser::launch(1400, 1400);
    b.navigate(&server.url);
    let shown = "!!(window.lobeExplore && window.lobeExplore.ready && window.lobeExplore.samples && window.lobeExplore.samples.length === 2 && document.querySelectorAll('#samples canvas.draws').length === 2)";
    b.wait_for(shown, PAGE_TIMEOUT);
    assert!(
        b.errors().is_empty(),
        "console errors on load: {:?}",
        b.errors()
    );
    b.eval("(() => { const s = document.getElementById('theta-o'); s.value = 60; s.dispatchEvent(new Event('input')); })()");
    b.wait_for(
        "window.lobeExplore.samplesRequest.every((r) => r.theta_o_deg === 60)",
        PAGE_TIMEOUT,
    );
    let asked = b.eval("window.lobeExplore.samplesRequest");
    let drawn = b.eval("window.lobeExplore.samples");
    let counts = b.eval("window.lobeExplore.samplesShown");
    let rows = b.eval("[...document.querySelectorAll('#samples > .images')].map((r) => ({ title: r.querySelector('.title').textContent, text: r.textContent, draws: r.querySelectorAll('canvas.draws').length, pdf: r.querySelectorAll('canvas.pdf').length }))");
    assert_eq!(rows.as_array().unwrap().len(), 2, "{rows}");
    // Both went through JSON (the route's, then the page's): each read within a unit in the last
    // place.
    let flat = |v: &Value| -> Vec<Option<f64>> {
        fn walk(v: &Value, out: &mut Vec<Option<f64>>) {
            match v {
                Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
                x => out.push(x.as_f64()),
            }
        }
        let mut out = Vec::new();
        walk(v, &mut out);
        out
    };
    let mut firsts = Vec::new();
    for (i, (model, sets)) in entries.iter().enumerate() {
        let request = json!({"model": model, "material": null, "sets": sets, "white_furnace": false,
            "theta_o_deg": 60, "phi_o_deg": 0, "draws": DRAWS, "seed": SEED, "res": RES});
        assert_eq!(asked[i], request, "row {i}'s request");
        let r = server.post("/api/samples", &request);
        assert_eq!(r.status, 200, "{}", r.text());
        let want: Value = serde_json::from_slice(&r.body).unwrap();
        for key in ["wi", "pdf", "pdf_grid"] {
            let (got, want) = (flat(&drawn[i][key]), flat(&want[key]));
            assert_eq!(got.len(), want.len(), "row {i} {key}");
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                match (g, w) {
                    (Some(g), Some(w)) => assert!(
                        (g - w).abs() <= JSON_READ_ABS * w.abs().max(1.0),
                        "row {i} {key}[{k}]: page {g}, route {w}"
                    ),
                    _ => assert_eq!(g, w, "row {i} {key}[{k}]"),
                }
            }
        }
        firsts.push(want["wi"][0].clone());
        let lost = want["lost"].as_u64().unwrap();
        let delta = want["delta_count"].as_u64().unwrap();
        assert_eq!(counts[i].as_u64().unwrap(), DRAWS - lost - delta, "row {i}");
        let row = &rows[i];
        let label = match sets.as_array().unwrap().as_slice() {
            [] => model.to_string(),
            s => format!("{model}{{{}}}", s[0].as_str().unwrap()),
        };
        assert_eq!(row["title"], json!(label), "row {i}");
        assert_eq!(
            (row["draws"].as_u64(), row["pdf"].as_u64()),
            (Some(1), Some(1)),
            "row {i}"
        );
        let text = row["text"].as_str().unwrap();
        assert!(
            text.contains(&format!("{DRAWS} draws (seed {SEED})")),
            "row {i}: {text}"
        );
    }
    assert_ne!(
        firsts[0], firsts[1],
        "the two rows drew the same directions"
    );

    // The second model refused (a roughness below its range): its row says why, the first keeps
    // its draws.
    b.eval("(() => { const s = document.querySelectorAll('#models .card')[1].querySelector('input[type=range][data-key=roughness]'); const box = s.nextElementSibling; box.value = '-1'; box.dispatchEvent(new Event('change')); })()");
    b.wait_for(
        "window.lobeExplore.samplesRequest[1].sets.includes('roughness=-1')",
        PAGE_TIMEOUT,
    );
    let refused = server.post(
        "/api/samples",
        &b.eval("window.lobeExplore.samplesRequest[1]"),
    );
    assert_eq!(refused.status, 422, "{}", refused.text());
    let errors = b.eval("window.lobeExplore.samplesErrors");
    assert!(errors[0].is_null(), "{errors}");
    let error = errors[1].as_str().unwrap();
    assert!(
        error.contains(&refused.text()),
        "{error} vs {}",
        refused.text()
    );
    assert!(
        b.eval("window.lobeExplore.samples[0] !== null && window.lobeExplore.samples[1] === null")
            == json!(true)
    );
    let rows = b.eval("[...document.querySelectorAll('#samples > .images')].map((r) => ({ text: r.textContent, draws: r.querySelectorAll('canvas.draws').length }))");
    assert_eq!(rows.as_array().unwrap().len(), 2, "{rows}");
    assert_eq!(rows[0]["draws"], json!(1), "{rows}");
    assert_eq!(rows[1]["draws"], json!(0), "{rows}");
    assert!(
        rows[1]["text"].as_str().unwrap().contains(&refused.text()),
        "{rows}"
    );
}

/// The lit view in the page: GGX under the sky drawn exact, split sum and their difference; a
/// pixel of the exact canvas is the route's value through the page's tone map (clamped, sRGB,
/// at the default exposure); the exposure slider changes it without a new request; a model
/// without a split sum shows the route's note.
#[test]
fn lit_view_in_chromium_shows_exact_split_and_difference() {
    /// A canvas byte may differ by one from the test's own tone map of the route's value: both
    /// round the same sRGB value, computed in f64 along slightly different paths.
    const BYTE_SLACK: f64 = 1.0;
    /// The page's full size (app.js LIGHT_FULL).
    const FULL: u64 = 96;
    let srgb = |c: f64| {
        if c <= 0.0031308 {
            12.92 * c
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        }
    };
    let byte = |v: f64, ev: f64| (255.0 * srgb((v * 2f64.powf(ev)).clamp(0.0, 1.0))).round();
    let server = Server::start(&["microfacet{distribution=ggx}"]);
    let mut b = cdp::Browser::launch(1400, 1400);
    b.navigate(&server.url);
    b.wait_for(
        &format!("!!(window.lobeExplore && window.lobeExplore.lightShown === {FULL} && document.querySelectorAll('#light canvas').length === 3)"),
        PAGE_TIMEOUT,
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
    let light = b.eval("window.lobeExplore.light");
    let asked = b.eval("window.lobeExplore.lightRequest");
    let r = server.post("/api/light", &asked);
    assert_eq!(r.status, 200, "{}", r.text());
    let want: Value = serde_json::from_slice(&r.body).unwrap();
    let numbers = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (exact, route) = (numbers(&light["exact"]), numbers(&want["exact"]));
    assert_eq!(exact.len(), route.len());
    // Both went through JSON (the route's, then the page's): each read within a unit in the last
    // place.
    let off = exact
        .iter()
        .zip(&route)
        .position(|(g, w)| (g - w).abs() > JSON_READ_ABS * w.abs().max(1.0));
    assert!(
        off.is_none(),
        "the page drew other values than the route's at {off:?}"
    );
    let n = FULL as usize;
    // A pixel on the sphere neither black nor clipped at 0 EV or at +1 EV.
    let k = (0..n * n)
        .find(|&k| {
            let (row, col) = (k / n, k % n);
            let (x, y) = (
                -1.0 + (col as f64 + 0.5) * 2.0 / n as f64,
                1.0 - (row as f64 + 0.5) * 2.0 / n as f64,
            );
            x * x + y * y < 0.8 && (0..3).all(|c| (0.05..0.45).contains(&exact[3 * k + c]))
        })
        .expect("a mid-grey pixel on the sphere");
    let (row, col) = (k / n, k % n);
    let pixel = |b: &mut cdp::Browser| -> Vec<f64> {
        let v = b.eval(&format!("Array.from(document.querySelectorAll('#light canvas')[0].getContext('2d').getImageData({col}, {row}, 1, 1).data)"));
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let at0 = pixel(&mut b);
    for c in 0..3 {
        let want = byte(exact[3 * k + c], 0.0);
        assert!(
            (at0[c] - want).abs() <= BYTE_SLACK,
            "pixel ({row}, {col}) channel {c}: {} against {want}",
            at0[c]
        );
    }
    let diff = b.eval("window.lobeExplore.lightDifference");
    assert!(
        diff["rms"].as_f64().unwrap() > 0.0,
        "the split sum differs under a sun: {diff}"
    );
    let requests = b.eval("window.lobeExplore.lightRequests");
    b.eval("(() => { const s = document.getElementById('exposure'); s.value = 1; s.dispatchEvent(new Event('input')); })()");
    std::thread::sleep(Duration::from_millis(1500));
    let at1 = pixel(&mut b);
    for c in 0..3 {
        let want = byte(exact[3 * k + c], 1.0);
        assert!(
            (at1[c] - want).abs() <= BYTE_SLACK,
            "+1 EV, channel {c}: {} against {want}",
            at1[c]
        );
        assert!(at1[c] > at0[c], "+1 EV brightens channel {c}");
    }
    assert_eq!(
        b.eval("window.lobeExplore.lightRequests"),
        requests,
        "the exposure asks nothing of the server"
    );

    let server = Server::start(&["phong"]);
    let mut b = cdp::Browser::launch(1400, 1400);
    b.navigate(&server.url);
    b.wait_for(
        &format!("!!(window.lobeExplore && window.lobeExplore.lightShown === {FULL})"),
        PAGE_TIMEOUT,
    );
    let text = b.eval("document.querySelector('#light').textContent");
    assert!(text.as_str().unwrap().contains("no split sum"), "{text}");
    assert_eq!(
        b.eval("document.querySelectorAll('#light canvas').length"),
        json!(1)
    );
}

/// The lit view's route: GGX (microfacet) under the built-in sky, exact and split sum, equal to
/// `Session::light` and `Session::light_split_sum` on the same device at every pixel; a model
/// without a split sum says so; bad settings are refused with a sentence.
#[test]
fn light_route_equals_session_light() {
    let server = Server::start(&["microfacet"]);
    let size = 16u32;
    let r = server.post(
        "/api/light",
        &json!({"model": "microfacet", "sets": ["distribution=ggx"], "env": "sky", "size": size}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let v: Value = serde_json::from_slice(&r.body).unwrap();
    let params = lobe::resolve_spec(
        "microfacet{distribution=ggx}",
        None,
        &[],
        &Default::default(),
        &mut |_| {},
    )
    .unwrap();
    let session = lobe::Session::open(Default::default()).unwrap();
    let map = lobe::light::maps::Builtin::Sky.map();
    let exact = session.light(&params, &map, size, &mut |_, _| {}).unwrap();
    let split = session
        .light_split_sum(&params, &map, size, &mut |_, _| {})
        .unwrap();
    for (key, want) in [("exact", &exact), ("split", &split)] {
        let got = v[key].as_array().unwrap();
        assert_eq!(got.len(), 3 * want.pixels.len(), "{key}");
        for (k, w) in want.pixels.iter().flatten().enumerate() {
            let g = got[k].as_f64().unwrap();
            // The reply's f32 rounding (2^-24 relative) on the same device's sums.
            assert!(
                (g - w).abs() <= SAME_RULE_REL * w.abs() + 1e-30,
                "{key}[{k}]: route {g}, Session {w}"
            );
        }
    }
    let r = server.post(
        "/api/light",
        &json!({"model": "phong", "env": "sky", "size": 8}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let v: Value = serde_json::from_slice(&r.body).unwrap();
    assert!(v["split"].is_null() && v["split_note"].is_string(), "{v}");
    for (body, names) in [
        (json!({"model": "phong", "env": "sky", "size": 0}), "size 0"),
        (
            json!({"model": "phong", "env": "sky", "size": 1000}),
            "size 1000",
        ),
        (
            json!({"model": "phong", "env": "moon", "size": 8}),
            "env 'moon'",
        ),
    ] {
        let r = server.post("/api/light", &body);
        assert_eq!(r.status, 422, "{body}: {}", r.text());
        assert!(r.text().contains(names), "{body}: {}", r.text());
    }
}

/// A map opened through the page's file input lights the sphere: the menu chooses it, the page
/// asks for it and draws the route's numbers; a file that is not a map shows the reason beside the
/// menu and the map stays chosen.
#[test]
fn a_map_opened_in_chromium_lights_the_sphere() {
    const FULL: u64 = 96;
    let server = Server::start(&["microfacet"]);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("room.exr");
    let map = lobe::light::maps::procedural_map(32, 16, |d| {
        lobe::glam::DVec3::new(1.0 + d.x, 1.5 + d.y, 2.0 + 0.5 * d.z)
    })
    .unwrap();
    lobe::light::maps::write_map(&map, "room", &file).unwrap();
    let bad = dir.path().join("bad.exr");
    std::fs::write(&bad, b"not a map").unwrap();
    let mut b = cdp::Browser::launch(1400, 1400);
    b.navigate(&server.url);
    b.wait_for(
        &format!("!!(window.lobeExplore && window.lobeExplore.lightShown === {FULL})"),
        PAGE_TIMEOUT,
    );
    b.set_file("#open-env", &file);
    b.wait_for(
        &format!("document.querySelector('#light-env').value === 'room.exr' && window.lobeExplore.lightRequest.env === 'room.exr' && window.lobeExplore.lightShown === {FULL}"),
        PAGE_TIMEOUT,
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
    let light = b.eval("window.lobeExplore.light");
    let asked = b.eval("window.lobeExplore.lightRequest");
    let r = server.post("/api/light", &asked);
    assert_eq!(r.status, 200, "{}", r.text());
    let want: Value = serde_json::from_slice(&r.body).unwrap();
    assert_eq!(want["env"], "room.exr");
    let numbers = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (got, want) = (numbers(&light["exact"]), numbers(&want["exact"]));
    assert_eq!(got.len(), want.len());
    // Both went through JSON (the route's, then the page's): each read within a unit in the last
    // place.
    let off = got
        .iter()
        .zip(&want)
        .position(|(g, w)| (g - w).abs() > JSON_READ_ABS * w.abs().max(1.0));
    assert!(
        off.is_none(),
        "the page drew other values than the route's at {off:?}"
    );

    b.set_file("#open-env", &bad);
    b.wait_for(
        "document.querySelector('#light-env-error').textContent.includes('bad.exr')",
        PAGE_TIMEOUT,
    );
    let text = b.eval("document.querySelector('#light-env-error').textContent");
    assert!(
        text.as_str().unwrap().contains("not an environment map"),
        "{text}"
    );
    assert_eq!(
        b.eval("document.querySelector('#light-env').value"),
        json!("room.exr")
    );
}

/// A map opened from the page (`POST /api/env`): read by `lobe light --env`'s reader, kept under
/// its file's name, and the lit view under it equals `Session::light` with the map read from the
/// same file; a file that is not a map and a body over the bound are refused with a sentence, and
/// the opened map stays; a map wider than the lit view's bound is box-averaged down to it.
#[test]
fn an_opened_map_lights_the_route_as_session_light() {
    let server = Server::start(&["microfacet"]);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("room.exr");
    // Radiance varying with direction, so that a wrong texel order or orientation shows.
    let map = lobe::light::maps::procedural_map(32, 16, |d| {
        lobe::glam::DVec3::new(1.0 + d.x, 1.5 + d.y, 2.0 + 0.5 * d.z)
    })
    .unwrap();
    lobe::light::maps::write_map(&map, "room", &file).unwrap();
    let headers = [("x-lobe-token", server.token.as_str())];
    let bytes = std::fs::read(&file).unwrap();
    let r = http(
        &server.addr,
        "POST",
        "/api/env?name=room.exr",
        &headers,
        &bytes,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let opened: Value = serde_json::from_slice(&r.body).unwrap();
    assert_eq!(opened["name"], "room.exr");
    assert_eq!(opened["downsampled"], false);
    let size = 12u32;
    let light = || {
        server.post(
            "/api/light",
            &json!({"model": "microfacet", "env": "room.exr", "size": size}),
        )
    };
    let r = light();
    assert_eq!(r.status, 200, "{}", r.text());
    let v: Value = serde_json::from_slice(&r.body).unwrap();
    let params =
        lobe::resolve_spec("microfacet", None, &[], &Default::default(), &mut |_| {}).unwrap();
    let session = lobe::Session::open(Default::default()).unwrap();
    let read = lobe::light::maps::read_map(&file).unwrap();
    let exact = session.light(&params, &read, size, &mut |_, _| {}).unwrap();
    let got = v["exact"].as_array().unwrap();
    assert_eq!(got.len(), 3 * exact.pixels.len());
    for (k, w) in exact.pixels.iter().flatten().enumerate() {
        let g = got[k].as_f64().unwrap();
        // The reply's f32 rounding (2^-24 relative) on the same device's sums.
        assert!(
            (g - w).abs() <= SAME_RULE_REL * w.abs() + 1e-30,
            "exact[{k}]: route {g}, Session {w}"
        );
    }

    let r = http(
        &server.addr,
        "POST",
        "/api/env?name=notes.txt",
        &headers,
        b"not a map",
    );
    assert_eq!(r.status, 422, "{}", r.text());
    assert!(
        r.text().contains("notes.txt is not an environment map"),
        "{}",
        r.text()
    );
    assert!(
        !r.text().contains(&*server.tmp.path().to_string_lossy()),
        "{}",
        r.text()
    );
    // A map with a NaN texel is refused as `lobe light --env` refuses it, naming the texel.
    let nan = dir.path().join("nan.exr");
    exr::prelude::write_rgb_file(&nan, 8, 4, |x, y| {
        if (x, y) == (6, 2) {
            (0.0, f32::NAN, 0.0)
        } else {
            (1.0, 1.0, 1.0)
        }
    })
    .unwrap();
    let r = http(
        &server.addr,
        "POST",
        "/api/env?name=nan.exr",
        &headers,
        &std::fs::read(&nan).unwrap(),
    );
    assert_eq!(r.status, 422, "{}", r.text());
    assert!(
        r.text().contains("row 2, column 6") && r.text().contains("finite"),
        "{}",
        r.text()
    );
    // A declared length over the bound is refused before the body is read.
    let r = http_claiming(
        &server.addr,
        "POST",
        "/api/env?name=big.exr",
        &headers,
        64 * 1024 * 1024 + 1,
        b"",
    );
    assert_eq!(r.status, 413, "{}", r.text());
    assert!(r.text().contains("bytes"), "{}", r.text());
    // The map opened first still lights the sphere.
    assert_eq!(light().status, 200);

    let wide = dir.path().join("wide.hdr");
    let constant =
        lobe::light::maps::procedural_map(1024, 512, |_| lobe::glam::DVec3::ONE).unwrap();
    std::fs::write(&wide, lobe::light::maps::encode_hdr(&constant)).unwrap();
    let r = http(
        &server.addr,
        "POST",
        "/api/env?name=wide.hdr",
        &headers,
        &std::fs::read(&wide).unwrap(),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let opened: Value = serde_json::from_slice(&r.body).unwrap();
    assert_eq!(
        (
            opened["file_width"].clone(),
            opened["width"].clone(),
            opened["height"].clone()
        ),
        (json!(1024), json!(256), json!(128))
    );
    assert_eq!(opened["downsampled"], true);
}

/// The page may open at most `MAX_UPLOADS` maps in one server's life (each stays loaded): the
/// next is refused with a sentence naming the bound, and the maps opened before it still light
/// the sphere.
#[test]
fn the_page_opens_a_bounded_number_of_maps() {
    let server = Server::start(&["lambert"]);
    let headers = [("x-lobe-token", server.token.as_str())];
    let map = lobe::light::maps::procedural_map(8, 4, |_| lobe::glam::DVec3::ONE).unwrap();
    let bytes = lobe::light::maps::encode_hdr(&map);
    let open = |k: usize| {
        http(
            &server.addr,
            "POST",
            &format!("/api/env?name=m{k}.hdr"),
            &headers,
            &bytes,
        )
    };
    for k in 0..lobe::explore::MAX_UPLOADS {
        let r = open(k);
        assert_eq!(r.status, 200, "map {k}: {}", r.text());
    }
    let r = open(lobe::explore::MAX_UPLOADS);
    assert_eq!(r.status, 422, "{}", r.text());
    assert!(
        r.text()
            .contains(&format!("at most {}", lobe::explore::MAX_UPLOADS)),
        "{}",
        r.text()
    );
    for name in [
        "m0.hdr",
        &format!("m{}.hdr", lobe::explore::MAX_UPLOADS - 1),
    ] {
        let r = server.post(
            "/api/light",
            &json!({"model": "lambert", "env": name, "size": 8}),
        );
        assert_eq!(r.status, 200, "{name}: {}", r.text());
    }
}

#[test]
fn exits_on_sigterm_leaving_nothing() {
    let mut server = Server::start(&["lambert"]);
    // An opened .brdf file is kept in the server's temporary folder until it ends.
    let text = std::fs::read(manifest().join("testdata/brdf/ggx.brdf")).unwrap();
    let r = http(
        &server.addr,
        "POST",
        "/api/brdf?name=ggx.brdf",
        &[("x-lobe-token", &server.token)],
        &text,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    assert!(
        !r.text().contains(&*server.tmp.path().to_string_lossy()),
        "the page is shown the server's folder: {}",
        r.text()
    );
    assert!(r.text().contains("ggx.brdf"), "{}", r.text());
    assert_eq!(std::fs::read_dir(server.tmp.path()).unwrap().count(), 1);
    // SAFETY: kill only sends a signal to the child this test started.
    assert_eq!(
        unsafe { libc::kill(server.child.id() as i32, libc::SIGTERM) },
        0
    );
    let start = Instant::now();
    let status = loop {
        if let Some(s) = server.child.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "lobe explore still running 30 s after SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    server
        .child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(status.success(), "{status}: {err}");
    assert!(err.contains("stopped"), "{err}");
    let left: Vec<PathBuf> = std::fs::read_dir(server.tmp.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    assert!(
        TcpStream::connect(&server.addr).is_err(),
        "{} still accepts connections",
        server.addr
    );
}

/// Moves the slider `key` of model card `card` to `value` (as a user's drag would: an input
/// event) and waits until the page has drawn the state it set.
fn move_slider(b: &mut cdp::Browser, card: usize, key: &str, t: u32) {
    let frames = b.eval("window.lobeExplore.frames");
    b.eval(&format!(
        "(() => {{ const s = document.querySelectorAll('#models .card')[{card}].querySelector('input[type=range][data-key={key}]'); s.value = {t}; s.dispatchEvent(new Event('input')); }})()"
    ));
    b.wait_for(&format!("window.lobeExplore.frames > {frames} && window.lobeExplore.request[{card}].sets.some(s => s.startsWith('{key}='))"), PAGE_TIMEOUT);
}

#[test]
fn page_in_chromium_shows_lobe_eval_values() {
    let server = Server::start(&["phong{shininess=20}", "lambert"]);
    let mut b = cdp::Browser::launch(1400, 1000);
    b.navigate(&server.url);
    b.wait_for("!!(window.lobeExplore && window.lobeExplore.ready && window.lobeExplore.albedo.length === 2)", PAGE_TIMEOUT);
    assert!(
        b.errors().is_empty(),
        "console errors on load: {:?}",
        b.errors()
    );
    let readout = "document.querySelector('#readout tbody tr td:nth-child(2)').textContent";
    let before = b.eval(readout);
    move_slider(&mut b, 0, "shininess", 700);
    let after = b.eval(readout);
    assert_ne!(before, after, "the polar plot's numbers did not change");
    // What the page drew and shows, against `lobe eval` with the parameters the page sent.
    let req = b.eval("window.lobeExplore.request[0]");
    let sets: Vec<String> = req["sets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect();
    let spec = format!("phong{{{}}}", sets.join(","));
    let ti = b
        .eval("window.lobeExplore.request[0].theta_i_deg")
        .as_f64()
        .unwrap();
    let drawn: Vec<f64> =
        serde_json::from_value(b.eval("Array.from(window.lobeExplore.polar[0])")).unwrap();
    let angles: Vec<f64> = serde_json::from_value(b.eval("window.lobeExplore.angles")).unwrap();
    let mirror = b.eval("window.lobeExplore.mirrorIndex").as_u64().unwrap() as usize;
    let picks: Vec<usize> = (0..angles.len()).step_by(40).chain([mirror]).collect();
    let want = lobe_eval(
        &spec,
        &picks
            .iter()
            .map(|&k| polar_pair(ti, angles[k]))
            .collect::<Vec<_>>(),
    );
    for (&k, w) in picks.iter().zip(&want) {
        assert_close(
            &format!("{spec} drawn at s = {}°", angles[k]),
            drawn[3 * k],
            w[0],
            SAME_BACKEND_REL,
        );
    }
    let shown: Vec<f64> = after
        .as_str()
        .unwrap()
        .split(", ")
        .map(|x| x.parse().unwrap())
        .collect();
    for c in 0..3 {
        assert_close(
            &format!("{spec} shown at the mirror, channel {c}"),
            shown[c],
            want[want.len() - 1][c],
            SHOWN_REL + SAME_BACKEND_REL,
        );
    }
    // The hemispherical albedo shown, against `lobe albedo` (same rule, same backend).
    b.wait_for(&format!("!!(window.lobeExplore.albedoRequest && window.lobeExplore.albedoRequest[0].sets.includes('{}'))", sets.iter().find(|s| s.starts_with("shininess=")).unwrap()), PAGE_TIMEOUT);
    let albedo: Vec<f64> =
        serde_json::from_value(b.eval("window.lobeExplore.albedo[0].hemispherical")).unwrap();
    let cli = common_albedo(&spec);
    for c in 0..3 {
        assert_close(
            &format!("{spec} hemispherical albedo, channel {c}"),
            albedo[c],
            cli[c],
            SAME_RULE_REL,
        );
    }
    // The URL carries the state: a reload restores the slider's value.
    let shininess = sets
        .iter()
        .find(|s| s.starts_with("shininess="))
        .unwrap()
        .clone();
    b.call("Page.reload", json!({}));
    b.wait_for(
        "!!(window.lobeExplore && window.lobeExplore.ready)",
        PAGE_TIMEOUT,
    );
    let restored = b.eval("window.lobeExplore.request[0].sets");
    assert!(
        restored.as_array().unwrap().contains(&json!(shininess)),
        "{restored} after reload, expected {shininess}"
    );
    // A .brdf file opened from the page appears as a model with its sliders and colour pickers.
    b.set_file("#open-brdf", &manifest().join("testdata/brdf/ggx.brdf"));
    b.wait_for("window.lobeExplore.request && window.lobeExplore.request.length === 3 && window.lobeExplore.polar.length === 3", PAGE_TIMEOUT);
    let card = "document.querySelectorAll('#models .card')[2]";
    let model = b.eval(&format!("{card}.querySelector('select.model').value"));
    assert!(model.as_str().unwrap().contains("ggx"), "{model}");
    assert_eq!(
        b.eval(&format!(
            "!!{card}.querySelector('input[type=range][data-key=alpha]')"
        )),
        json!(true)
    );
    assert_eq!(
        b.eval(&format!(
            "{card}.querySelectorAll('input[type=color]').length"
        )),
        json!(2)
    );
    move_slider(&mut b, 2, "alpha", 500);
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}

/// Latency of a slider drag, input event to the frame drawn with the new values, measured in the
/// browser over 50 moves of a built-in model's slider. A benchmark, not a test: run it alone with
/// `cargo test --release --test explore -- --ignored --nocapture explore_latency`.
#[test]
#[ignore]
fn explore_latency() {
    let server = Server::start(&["cook_torrance"]);
    let mut b = cdp::Browser::launch(1400, 1000);
    b.navigate(&server.url);
    b.wait_for(
        "!!(window.lobeExplore && window.lobeExplore.ready)",
        PAGE_TIMEOUT,
    );
    let moves = 50;
    let script = format!(
        "(async () => {{ const p = window.lobeExplore; const s = document.querySelector('#models .card input[type=range]');
           const out = [];
           for (let k = 0; k < {moves}; k++) {{
             const n = p.latencies.length;
             s.value = 100 + 15 * k; s.dispatchEvent(new Event('input'));
             while (p.latencies.length === n) await new Promise(r => setTimeout(r, 2));
             out.push(p.latencies[p.latencies.length - 1]);
           }}
           return out; }})()"
    );
    let mut ms: Vec<f64> = serde_json::from_value(b.eval(&script)).unwrap();
    ms.sort_by(f64::total_cmp);
    let median = ms[ms.len() / 2];
    let p95 = ms[(ms.len() * 95).div_ceil(100) - 1];
    println!("explore latency over {moves} slider moves (cook_torrance): median {median:.1} ms, p95 {p95:.1} ms, max {:.1} ms", ms[ms.len() - 1]);
}
