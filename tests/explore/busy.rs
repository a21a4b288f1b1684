//! A shader that never returns, opened from the page: the page says it is busy and then shows
//! the time limit's message, the server answers built-in models all the while, and the shader's
//! hung device is left behind: the next request for it fails the same way instead of finding a
//! device that takes no more work, and built-ins never stop.

use super::cdp;
use super::server::{manifest, Server};
use super::PAGE_TIMEOUT;
use serde_json::json;

/// The time limit of each chunk of a `.brdf` model's work in this test, seconds: long enough
/// for a built-in's request to be answered while the shader runs, short for the suite.
const SHADER_LIMIT_S: &str = "3";

#[test]
fn an_endless_shader_shows_busy_and_never_stops_the_server() {
    let server = Server::start_with_env(&["lambert"], &[("LOBE_BRDF_TIMEOUT", SHADER_LIMIT_S)]);
    let mut b = cdp::Browser::launch(1400, 1000);
    b.navigate(&server.url);
    b.wait_for(
        "!!(window.lobeExplore && window.lobeExplore.ready)",
        PAGE_TIMEOUT,
    );
    let lambert = json!({"model": "lambert", "theta_i_deg": 30, "samples": 9});

    b.set_file(
        "#open-brdf",
        &manifest().join("testdata/brdf/bad/endless.brdf"),
    );
    let status = "document.getElementById('status').textContent";
    b.wait_for(&format!("{status} === 'computing…'"), PAGE_TIMEOUT);
    // While the shader runs, a built-in model is answered, and the page still waits on it.
    let r = server.post("/api/polar", &lambert);
    assert_eq!(r.status, 200, "{}", r.text());
    assert_eq!(
        b.eval(status),
        json!("computing…"),
        "the shader's request ended first"
    );

    b.wait_for(
        "window.lobeExplore.errors.some((e) => e.includes('did not finish within'))",
        PAGE_TIMEOUT,
    );
    let catalog = server.get_json("/api/models");
    let name = catalog["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap().to_string())
        .find(|n| n.contains("endless"))
        .expect("the opened file is in the model list");

    // The page goes on once the model is removed: the remaining model is drawn again.
    let frames = b.eval("window.lobeExplore.frames");
    b.eval("document.querySelectorAll('#models .card')[1].querySelectorAll('button')[1].click()");
    b.wait_for(
        &format!("window.lobeExplore.frames > {frames} && window.lobeExplore.request.length === 1"),
        PAGE_TIMEOUT,
    );
    assert_eq!(
        b.eval("document.getElementById('error').hidden"),
        json!(true)
    );

    // The shader again: a fresh device, the same limit (not a device that takes no more work).
    // The largest hemisphere image: lavapipe ends a loop this long early (with undefined
    // values) after about half a millisecond a value, so what keeps a request there past the
    // limit is its number of values: 256² cells, half a minute, far past 3 s, where a polar
    // curve's 4096 took 3 to 5 s.
    let r = server.post(
        "/api/hemisphere",
        &json!({"model": name, "theta_i_deg": 30, "samples": lobe::explore::MAX_IMAGE_RES}),
    );
    assert!(
        r.status == 422 && r.text().contains("did not finish within"),
        "{} {}",
        r.status,
        r.text()
    );
    let r = server.post("/api/polar", &lambert);
    assert_eq!(r.status, 200, "{}", r.text());
    // The browser logs each refused request; anything else would be the page's own error.
    let page_errors: Vec<String> = b
        .errors()
        .into_iter()
        .filter(|e| !(e.contains("\"source\":\"network\"") && e.contains("status of 422")))
        .collect();
    assert!(page_errors.is_empty(), "console errors: {page_errors:?}");
}
