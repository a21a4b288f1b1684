//! Optional parameters (microfacet's `f0`, `alpha_x`, `alpha_y`: the model derives them when they
//! are not given) have controls too: a button sets one at its default and shows its control, the
//! next request carries it, and unsetting it drops it again.

use super::cdp;
use super::server::Server;
use super::PAGE_TIMEOUT;
use serde_json::json;

#[test]
fn an_optional_parameter_can_be_set_and_unset_from_the_page() {
    let server = Server::start(&["microfacet"]);
    let mut b = cdp::Browser::launch(1400, 1000);
    b.navigate(&server.url);
    b.wait_for(
        "!!(window.lobeExplore && window.lobeExplore.ready)",
        PAGE_TIMEOUT,
    );
    let card = "document.querySelectorAll('#models .card')[0]";
    let f0_control = format!(
        "[...{card}.querySelectorAll('.param label')].some((l) => l.textContent.endsWith('f0'))"
    );
    assert_eq!(b.eval(&f0_control), json!(false));
    let catalog = server.get_json("/api/models");
    let f0 = catalog["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "microfacet")
        .unwrap()["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["key"] == "f0")
        .expect("microfacet has f0")
        .clone();
    assert_eq!(f0["optional"], json!(true));

    let frames = b.eval("window.lobeExplore.frames");
    b.eval(&format!(
        "{card}.querySelector('.optional button[data-key=\"f0\"]').click()"
    ));
    b.wait_for(
        &format!(
            "window.lobeExplore.frames > {frames} && \
             window.lobeExplore.request[0].sets.some((s) => s.startsWith('f0='))"
        ),
        PAGE_TIMEOUT,
    );
    assert_eq!(b.eval(&f0_control), json!(true));

    let frames = b.eval("window.lobeExplore.frames");
    b.eval(&format!("{card}.querySelector('button.unset').click()"));
    b.wait_for(
        &format!(
            "window.lobeExplore.frames > {frames} && \
             !window.lobeExplore.request[0].sets.some((s) => s.startsWith('f0='))"
        ),
        PAGE_TIMEOUT,
    );
    assert_eq!(b.eval(&f0_control), json!(false));
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}
