//! A MERL file opened from the page is the model `--model PATH` makes of it: the same values at
//! the same directions, byte for byte; a file of the wrong size is refused with a sentence.

use super::cdp;
use super::server::{http, Server};
use super::PAGE_TIMEOUT;
use serde_json::json;
use std::process::Command;

#[test]
fn a_merl_file_opened_from_the_page_is_the_command_lines_model() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("gold-ct.binary");
    let out = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "table",
            "--format",
            "merl",
            "--grid",
            "halfdiff",
            "--material",
            "gold",
        ])
        .args(["--model", "cook_torrance", "-o"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let server = Server::start(&[file.to_str().unwrap()]);
    let catalog = server.get_json("/api/models");
    let given = catalog["initial"][0]["model"].as_str().unwrap().to_string();

    let bytes = std::fs::read(&file).unwrap();
    let headers = [("x-lobe-token", server.token.as_str())];
    let r = http(
        &server.addr,
        "POST",
        "/api/merl?name=opened.binary",
        &headers,
        &bytes,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let opened: serde_json::Value = serde_json::from_slice(&r.body).unwrap();
    let opened = opened["name"].as_str().unwrap().to_string();
    assert_ne!(opened, given);
    let polar = |model: &str| {
        let r = server.post(
            "/api/polar",
            &json!({"model": model, "theta_i_deg": 35, "samples": 181}),
        );
        assert_eq!(r.status, 200, "{model}: {}", r.text());
        r.body
    };
    assert!(
        polar(&given) == polar(&opened),
        "the opened file's values differ from the command line's model"
    );

    // A file of another size: refused, naming it as the page gave it.
    let r = http(
        &server.addr,
        "POST",
        "/api/merl?name=short.binary",
        &headers,
        &bytes[..1000],
    );
    assert_eq!(r.status, 422, "{}", r.text());
    assert!(r.text().contains("short.binary"), "{}", r.text());

    // Through the page's file input: a model with its lookup menu.
    let mut b = cdp::Browser::launch(1400, 1000);
    b.navigate(&server.url);
    b.wait_for(
        "!!(window.lobeExplore && window.lobeExplore.ready)",
        PAGE_TIMEOUT,
    );
    b.set_file("#open-brdf", &file);
    b.wait_for(
        "window.lobeExplore.request && window.lobeExplore.request.length === 2 && window.lobeExplore.polar.length === 2",
        PAGE_TIMEOUT,
    );
    let card = "document.querySelectorAll('#models .card')[1]";
    assert_eq!(
        b.eval(&format!(
            "!!{card}.querySelector('select[data-key=lookup]')"
        )),
        json!(true),
        "no lookup menu: {}",
        b.eval(&format!("{card}.innerHTML"))
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}
