//! Links: one that names a model opened on the page, after the server restarted (the model is gone
//! with it): the page opens the file again from the copy this browser kept, and where it kept
//! none it says which file to open, showing the link's other models; and the lit view's map,
//! kept where the server holds it, else the default with a notice.

use super::cdp::Browser;
use super::server::{http, manifest, Server};
use super::PAGE_TIMEOUT;
use serde_json::json;

/// A port free now, for servers started one after another on it (a restart keeps its port, and
/// the page's origin with it: a browser keeps a copy per origin).
fn free_port() -> String {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().port().to_string()
}

/// Opens `url` with the state `hash` and waits until the page has drawn `models` models.
fn open_link(b: &mut Browser, url: &str, hash: &str, models: usize) {
    b.navigate(&format!("{url}{hash}"));
    b.wait_for(
        &format!("!!(window.lobeExplore && window.lobeExplore.ready && window.lobeExplore.request.length === {models})"),
        PAGE_TIMEOUT,
    );
}

#[test]
fn a_link_to_an_opened_file_survives_a_restart_or_says_what_to_open() {
    let port = free_port();
    let args = ["--port", port.as_str(), "lambert"];
    let server = Server::start(&args);
    let mut b = Browser::launch(1400, 1000);
    open_link(&mut b, &server.url, "", 1);
    b.set_file("#open-brdf", &manifest().join("testdata/brdf/ggx.brdf"));
    b.wait_for(
        "window.lobeExplore.request.length === 2 && window.lobeExplore.polar.length === 2",
        PAGE_TIMEOUT,
    );
    // A parameter of the opened model set on the page, which the link carries too.
    b.eval("(() => { const s = document.querySelectorAll('#models .card')[1].querySelector('input[type=range][data-key=alpha]'); s.value = 400; s.dispatchEvent(new Event('input')); })()");
    b.wait_for(
        "window.lobeExplore.request[1].sets.some((s) => s.startsWith('alpha='))",
        PAGE_TIMEOUT,
    );
    let model = b.eval("window.lobeExplore.request[1].model");
    let alpha = b.eval("window.lobeExplore.request[1].sets.find((s) => s.startsWith('alpha='))");
    let hash = b.eval("location.hash").as_str().unwrap().to_string();
    // The page closed first, so that no request of its is cut off by the server's end.
    b.navigate("about:blank");
    drop(server);

    // Restarted (a new token): the page opens ggx.brdf again from its copy, with the link's value.
    let server = Server::start(&args);
    open_link(&mut b, &server.url, &hash, 2);
    assert_eq!(b.eval("window.lobeExplore.request[1].model"), model);
    assert_eq!(
        b.eval("window.lobeExplore.request[1].sets.find((s) => s.startsWith('alpha='))"),
        alpha
    );
    let notices = b.eval("window.lobeExplore.notices");
    assert!(
        notices.to_string().contains("ggx.brdf was opened again"),
        "{notices}"
    );
    let catalog = server.get_json("/api/models");
    assert!(
        catalog["models"]
            .as_array()
            .unwrap()
            .iter()
            .any(|m| m["name"] == model && m["source"] == "ggx.brdf"),
        "the restarted server has no {model} from ggx.brdf"
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
    let hash = b.eval("location.hash").as_str().unwrap().to_string();

    // Restarted again, this browser's copy gone: the page says which file to open, and shows the
    // link's other model.
    b.eval("localStorage.clear()");
    b.navigate("about:blank");
    drop(server);
    let server = Server::start(&args);
    open_link(&mut b, &server.url, &hash, 1);
    assert_eq!(
        b.eval("window.lobeExplore.request[0].model"),
        json!("lambert")
    );
    let shown = b.eval("document.getElementById('notices').hidden ? '' : document.getElementById('notices').textContent");
    let shown = shown.as_str().unwrap();
    assert!(
        shown.contains(&format!("names the model {}", model.as_str().unwrap()))
            && shown.contains("Open ggx.brdf again"),
        "notice: {shown}"
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}

/// The page's state with its `env` set to `env`, as a fragment.
fn with_env(b: &mut Browser, env: &str) -> String {
    let expr = format!(
        "'#' + encodeURIComponent(JSON.stringify({{ ...JSON.parse(decodeURIComponent(location.hash.slice(1))), env: {} }}))",
        json!(env)
    );
    b.eval(&expr).as_str().unwrap().to_string()
}

/// Waits until the lit view has asked for `env` and its menu shows it.
fn wait_for_map(b: &mut Browser, env: &str) {
    b.wait_for(
        &format!(
            "!!(window.lobeExplore.lightRequest && window.lobeExplore.lightRequest.env === {e} && document.getElementById('light-env').value === {e})",
            e = json!(env)
        ),
        PAGE_TIMEOUT,
    );
}

#[test]
fn a_link_keeps_the_lit_views_map_where_the_server_holds_it() {
    let server = Server::start(&["lambert"]);
    let mut b = Browser::launch(1400, 1000);
    open_link(&mut b, &server.url, "", 1);
    wait_for_map(&mut b, "sky");

    // A built-in map chosen in the menu: the link carries it, the command names it, a reload
    // keeps it.
    b.eval("(() => { const m = document.getElementById('light-env'); m.value = 'studio'; m.dispatchEvent(new Event('change')); })()");
    wait_for_map(&mut b, "studio");
    let command = b.eval("document.getElementById('command').textContent");
    assert!(
        command
            .as_str()
            .unwrap()
            .contains("lobe light --model 'lambert' --env 'studio' --size 96"),
        "{command}"
    );
    let hash = b.eval("location.hash").as_str().unwrap().to_string();
    b.navigate("about:blank");
    open_link(&mut b, &server.url, &hash, 1);
    wait_for_map(&mut b, "studio");

    // A map opened on the page: a link naming it lights the sphere with it while this server
    // holds it.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("room.exr");
    let map = lobe::light::maps::procedural_map(32, 16, |d| {
        lobe::glam::DVec3::new(1.0 + d.x, 1.5 + d.y, 2.0 + 0.5 * d.z)
    })
    .unwrap();
    lobe::light::maps::write_map(&map, "room", &file).unwrap();
    let r = http(
        &server.addr,
        "POST",
        "/api/env?name=room.exr",
        &[("x-lobe-token", server.token.as_str())],
        &std::fs::read(&file).unwrap(),
    );
    assert_eq!(r.status, 200, "{}", r.text());
    assert_eq!(server.get_json("/api/models")["maps"], json!(["room.exr"]));
    let opened = with_env(&mut b, "room.exr");
    let unknown = with_env(&mut b, "elsewhere.exr");
    b.navigate("about:blank");
    open_link(&mut b, &server.url, &opened, 1);
    wait_for_map(&mut b, "room.exr");
    assert_eq!(b.eval("window.lobeExplore.notices"), json!([]));

    // A map this server does not hold (a link from another server, or from before a restart):
    // the default map, and a notice naming the map.
    b.navigate("about:blank");
    open_link(&mut b, &server.url, &unknown, 1);
    wait_for_map(&mut b, "sky");
    let shown = b.eval("document.getElementById('notices').hidden ? '' : document.getElementById('notices').textContent");
    let shown = shown.as_str().unwrap();
    assert!(
        shown.contains("environment map elsewhere.exr") && shown.contains("shows sky"),
        "notice: {shown}"
    );
    assert!(
        b.eval("decodeURIComponent(location.hash)")
            .as_str()
            .unwrap()
            .contains("\"env\":\"sky\""),
        "the link still names the missing map"
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}
