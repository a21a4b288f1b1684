//! The view routes over HTTP: what they refuse as the command line refuses it, the slice at a
//! chosen φd and the torus under the point light, cell by cell against `lobe eval`.

use super::server::{floats, Server};
use super::{assert_close, lobe_eval, SAME_BACKEND_REL};
use glam::DVec3;
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

/// The slice at a chosen φd: each cell the pair of its (θh, θd) at φh = 0 and that φd, empty
/// (NaN) where ωi or ωo falls below the horizon; φd is the slice's alone, and bounded.
#[test]
fn the_slice_at_a_chosen_phi_d_equals_lobe_eval() {
    let server = Server::start(&["lambert"]);
    let spec = "cook_torrance{roughness=0.3}";
    let (res, phi_d) = (6, 150.0f64);
    let r = server.post(
        "/api/slice",
        &json!({"model": "cook_torrance", "sets": ["roughness=0.3"], "theta_i_deg": 40, "samples": res, "phi_d_deg": phi_d}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let slice = floats(&r.body);
    let step = 90.0 / res as f64;
    let (mut pairs, mut cells) = (Vec::new(), Vec::new());
    for row in 0..res {
        for col in 0..res {
            let (th, td) = ((col as f64 + 0.5) * step, (row as f64 + 0.5) * step);
            let (wi, wo) = lobe::grid::half_diff_to_pair(
                th.to_radians(),
                0.0,
                td.to_radians(),
                phi_d.to_radians(),
            );
            let k = row * res + col;
            if wi.z <= 0.0 || wo.z <= 0.0 {
                assert!(
                    slice[3 * k].is_nan(),
                    "cell {k} (θh {th}°, θd {td}°) is below the horizon: {}",
                    slice[3 * k]
                );
                continue;
            }
            let ((ti, pi), (to, po)) = (lobe::grid::angles_deg(wi), lobe::grid::angles_deg(wo));
            pairs.push([ti, pi, to, po]);
            cells.push(k);
        }
    }
    assert!(
        cells.len() > res && cells.len() < res * res,
        "{} of {} cells above the horizon at φd = {phi_d}°",
        cells.len(),
        res * res
    );
    for ((k, w), p) in cells.iter().zip(lobe_eval(spec, &pairs)).zip(&pairs) {
        assert_close(
            &format!("{spec} slice at φd = {phi_d}°, cell {k} {p:?}"),
            slice[3 * k] as f64,
            w[0],
            SAME_BACKEND_REL,
        );
    }
    // Another φd, another slice; none given is φd = 90°.
    let ask = |extra: serde_json::Value| {
        let mut body = json!({"model": "cook_torrance", "theta_i_deg": 40, "samples": res});
        body.as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        server.post("/api/slice", &body)
    };
    let at = |phi: f64| ask(json!({"phi_d_deg": phi})).body;
    assert_eq!(ask(json!({})).body, at(90.0));
    assert_ne!(at(90.0), at(30.0));
    for (path, body, says) in [
        ("/api/slice", json!({"phi_d_deg": 361}), "phi_d_deg 361"),
        ("/api/slice", json!({"phi_d_deg": -1}), "phi_d_deg -1"),
        (
            "/api/hemisphere",
            json!({"phi_d_deg": 45}),
            "only the slice",
        ),
        ("/api/polar", json!({"phi_d_deg": 45}), "only the slice"),
    ] {
        let mut req = json!({"model": "lambert", "samples": 4});
        req.as_object_mut()
            .unwrap()
            .extend(body.as_object().unwrap().clone());
        let r = server.post(path, &req);
        assert_eq!(r.status, 422, "{path} {req}: {}", r.text());
        assert!(r.text().contains(says), "{path} {req}: {}", r.text());
    }
}

/// The lit view's torus as src/explore/objects.rs states it: radii 0.62
/// (to the tube's centre) and 0.3, its axis tipped 45° from +z towards +y, seen from +z
/// (orthographic, the image spanning [-1, 1]), lit by the polar plot's light.
const TORUS_R: f64 = 0.62;
const TORUS_TUBE: f64 = 0.3;

fn torus_axis() -> DVec3 {
    DVec3::new(0.0, 1.0, 1.0).normalize()
}

/// The torus's quartic implicit function, negative inside: (|p|² + R² − r²)² − 4R²ρ², ρ the
/// distance from the axis.
fn torus_implicit(p: DVec3) -> f64 {
    let h = p.dot(torus_axis());
    let s = p.length_squared() + TORUS_R * TORUS_R - TORUS_TUBE * TORUS_TUBE;
    s * s - 4.0 * TORUS_R * TORUS_R * (p.length_squared() - h * h)
}

/// The first point where the ray from `o` along `d` enters the torus: the implicit function's
/// first sign change in steps of 1e-4 (thinner than any chord these tests' rays cut), bisected
/// to the last bit. The server marches a distance instead (sphere tracing): another method.
fn torus_entry(o: DVec3, d: DVec3) -> Option<DVec3> {
    let steps = 40_000;
    let at = |k: usize| 4.0 * k as f64 / steps as f64;
    for k in 1..=steps {
        if torus_implicit(o + at(k) * d) < 0.0 {
            let (mut lo, mut hi) = (at(k - 1), at(k));
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if torus_implicit(o + mid * d) < 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Some(o + hi * d);
        }
    }
    None
}

/// Cells of the lit torus against `lobe eval`: empty off the torus and in its hole, f·cos θi
/// where the light reaches, 0 where the torus shadows itself. The model is isotropic, so the
/// tangent around the normal does not enter.
#[test]
fn the_lit_torus_equals_lobe_eval() {
    let server = Server::start(&["lambert"]);
    let spec = "cook_torrance{roughness=0.3}";
    let (res, theta_i) = (15, 60.0f64);
    let r = server.post(
        "/api/torus",
        &json!({"model": "cook_torrance", "sets": ["roughness=0.3"], "theta_i_deg": theta_i, "samples": res}),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let image = floats(&r.body);
    assert_eq!(image.len(), 3 * res * res);
    let light = DVec3::new(-theta_i.to_radians().sin(), 0.0, theta_i.to_radians().cos());
    let (mut pairs, mut lit, mut dark) = (Vec::new(), Vec::new(), Vec::new());
    let mut shadowed = 0;
    for row in 0..res {
        for col in 0..res {
            let k = row * res + col;
            let h = 2.0 / res as f64;
            let (x, y) = (-1.0 + (col as f64 + 0.5) * h, 1.0 - (row as f64 + 0.5) * h);
            let Some(p) = torus_entry(DVec3::new(x, y, 2.0), -DVec3::Z) else {
                assert!(
                    image[3 * k].is_nan(),
                    "cell {k} ({x}, {y}) misses the torus: {}",
                    image[3 * k]
                );
                continue;
            };
            assert!(
                !image[3 * k].is_nan(),
                "cell {k} ({x}, {y}) meets the torus at {p}"
            );
            // The implicit function's gradient: 4 s p − 8 R² (p − (p·a) a).
            let s = p.length_squared() + TORUS_R * TORUS_R - TORUS_TUBE * TORUS_TUBE;
            let n = (4.0 * s * p
                - 8.0 * TORUS_R * TORUS_R * (p - p.dot(torus_axis()) * torus_axis()))
            .normalize();
            if n.dot(light) <= 0.0 {
                dark.push(k);
                continue;
            }
            if torus_entry(p + 1e-6 * n, light).is_some() {
                dark.push(k);
                shadowed += 1;
                continue;
            }
            let (t, b) = n.any_orthonormal_pair();
            let local = |w: DVec3| DVec3::new(w.dot(t), w.dot(b), w.dot(n));
            let ((ti, pi), (to, po)) = (
                lobe::grid::angles_deg(local(light)),
                lobe::grid::angles_deg(local(DVec3::Z)),
            );
            pairs.push([ti, pi, to, po]);
            lit.push((k, n.dot(light)));
        }
    }
    let middle = res * res / 2;
    assert!(
        image[3 * middle].is_nan(),
        "the middle cell looks through the hole"
    );
    assert!(
        lit.len() > 10 && shadowed > 0,
        "{} lit and {} dark cells, {shadowed} of them in the torus's shadow",
        lit.len(),
        dark.len()
    );
    for k in &dark {
        assert_eq!(
            image[3 * k],
            0.0,
            "cell {k} is in the torus's shadow or faces away"
        );
    }
    for (((k, cos), w), p) in lit.iter().zip(lobe_eval(spec, &pairs)).zip(&pairs) {
        assert_close(
            &format!("{spec} torus cell {k} {p:?}"),
            image[3 * k] as f64,
            w[0] * cos,
            SAME_BACKEND_REL,
        );
    }
}
