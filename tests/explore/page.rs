//! The page's views in headless Chromium beside BRDF Explorer's: the 3D lobe shaded (and as a
//! wireframe), the slice's φd and θd controls, the lit views' exposure, tone map and torus; each
//! control's value in the link.

use super::cdp::Browser;
use super::server::{floats, Server};
use super::PAGE_TIMEOUT;
use serde_json::{json, Value};

fn open(server: &Server) -> Browser {
    let mut b = Browser::launch(1400, 1000);
    b.navigate(&server.url);
    wait_images(&mut b);
    b
}

/// Waits until the page has drawn its image views for its current state.
fn wait_images(b: &mut Browser) {
    b.wait_for(
        "!!(window.lobeExplore && window.lobeExplore.ready && window.lobeExplore.imagesRequest && document.querySelector('#images canvas.lit'))",
        PAGE_TIMEOUT,
    );
}

/// Sets the control `id` to `value` and sends the event a user's change sends.
fn set_control(b: &mut Browser, id: &str, value: &str, event: &str) {
    b.eval(&format!(
        "(() => {{ const c = document.getElementById('{id}'); c.value = '{value}'; c.dispatchEvent(new Event('{event}')); }})()"
    ));
}

/// Reloads the page (its state in the URL's fragment) and waits for the new page's images.
fn reload(b: &mut Browser) {
    b.eval("window.beforeReload = true");
    b.call("Page.reload", json!({}));
    b.wait_for("!window.beforeReload", PAGE_TIMEOUT);
    wait_images(b);
}

/// The RGBA bytes of a canvas, as JSON numbers.
fn canvas_bytes(b: &mut Browser, selector: &str) -> Vec<u8> {
    serde_json::from_value(b.eval(&format!(
        "(() => {{ const c = document.querySelector('{selector}'); return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data); }})()"
    )))
    .unwrap()
}

/// The shaded lobe fills its surface: every pixel about a point inside a Lambertian lobe (a
/// hemisphere of radius 1 on the log scale) is opaque, and its shading varies over the surface;
/// the wireframe leaves that patch mostly empty. The choice is in the link. "Opaque" is an alpha
/// of 240 or more: where two faces meet, each covers part of a pixel (antialiased), and the two
/// parts together may leave it a few levels short of 255.
#[test]
fn the_3d_lobe_is_a_shaded_surface_with_a_wireframe_toggle() {
    let server = Server::start(&["lambert"]);
    let mut b = open(&server);
    // The 15 × 15 pixels about the projection of (0, 0, 0.5), inside the hemisphere, and the
    // distinct colours of the whole canvas's opaque pixels.
    let look = "(() => { const c = document.getElementById('lobe3d'), g = c.getContext('2d');
        const [x, y] = window.lobeExplore.lobePoint(0, 0, 0.5);
        const patch = g.getImageData(Math.round(x) - 7, Math.round(y) - 7, 15, 15).data;
        let opaque = 0;
        for (let k = 3; k < patch.length; k += 4) if (patch[k] >= 240) opaque++;
        const all = g.getImageData(0, 0, c.width, c.height).data, colours = new Set();
        for (let k = 0; k < all.length; k += 4) if (all[k + 3] >= 240) colours.add(all[k] << 16 | all[k + 1] << 8 | all[k + 2]);
        return { opaque, colours: colours.size, faces: window.lobeExplore.lobeFaces }; })()";
    let shaded = b.eval(look);
    assert_eq!(shaded["opaque"], json!(225), "shaded: {shaded}");
    // A flat fill would be one colour (and its antialiased edge); Lambert's cosine over a
    // hemisphere's normals gives many.
    assert!(
        shaded["colours"].as_u64().unwrap() >= 30,
        "shaded: {shaded}"
    );
    // 63 rings of 64 quads and a cap of 64 triangles.
    assert_eq!(shaded["faces"], json!(64 * 63 + 64), "shaded: {shaded}");

    b.eval("document.getElementById('wireframe').click()");
    let wire = b.eval(look);
    assert!(
        wire["opaque"].as_u64().unwrap() < 225 / 2,
        "wireframe: {wire}"
    );
    assert_eq!(wire["faces"], json!(0), "wireframe: {wire}");
    reload(&mut b);
    assert_eq!(
        b.eval("document.getElementById('wireframe').checked"),
        json!(true)
    );
    assert_eq!(b.eval(look)["faces"], json!(0));
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}

/// An image the page holds (a Float32Array) as f32 values, None where empty. JSON has no NaN (an
/// empty cell comes back as null), and serde_json may read a number's last bit of an f64 wrongly,
/// which rounding to f32 undoes.
fn page_image(b: &mut Browser, expr: &str) -> Vec<Option<f32>> {
    let v: Vec<Option<f64>> =
        serde_json::from_value(b.eval(&format!("Array.from({expr})"))).unwrap();
    v.into_iter().map(|x| x.map(|x| x as f32)).collect()
}

/// A view's answer as [`page_image`] gives the page's.
fn server_image(body: &[u8]) -> Vec<Option<f32>> {
    floats(body)
        .into_iter()
        .map(|v| (!v.is_nan()).then_some(v))
        .collect()
}

/// The page's request for its first model's image views, as the page sent it.
fn image_request(b: &mut Browser) -> Value {
    let mut r = b.eval("window.lobeExplore.imagesRequest[0]");
    r["samples"] = json!(64);
    r
}

/// The slice's φd slider asks the server for the slice at that φd (the page draws what the
/// server answers for it), and its θd slider picks the row drawn as a curve of θh; both are in
/// the link.
#[test]
fn the_slice_follows_its_phi_d_and_theta_d_controls() {
    let server = Server::start(&["cook_torrance{roughness=0.3}"]);
    let mut b = open(&server);
    assert_eq!(b.eval("window.lobeExplore.slicePhiD"), json!(90));
    let slice = |b: &mut Browser| page_image(b, "window.lobeExplore.slice[0]");
    let before = slice(&mut b);

    set_control(&mut b, "phi-d", "30", "input");
    b.wait_for(
        "window.lobeExplore.slicePhiD === 30 && !!document.querySelector('#images canvas.lit')",
        PAGE_TIMEOUT,
    );
    let drawn = slice(&mut b);
    assert_ne!(drawn, before, "the slice did not change with φd");
    let mut req = image_request(&mut b);
    req["phi_d_deg"] = json!(30);
    let r = server.post("/api/slice", &req);
    assert_eq!(r.status, 200, "{}", r.text());
    let want = server_image(&r.body);
    assert_eq!(drawn.len(), want.len());
    for (k, (d, w)) in drawn.iter().zip(&want).enumerate() {
        assert_eq!(d, w, "slice cell {k}: drawn, and the server's at φd = 30°");
    }
    assert!(
        drawn.iter().any(Option::is_none),
        "at φd = 30° some cells fall below the horizon"
    );
    let caption = "[...document.querySelectorAll('#images .images')[0].children].map((d) => d.textContent).join(' | ')";
    assert!(
        b.eval(caption).as_str().unwrap().contains("φd = 30°"),
        "{}",
        b.eval(caption)
    );

    // θd: the curve is the slice's row at the chosen θd (rows cell-centred over [0°, 90°)).
    let row = 10;
    let cut_before = b.eval("window.lobeExplore.sliceCut[0]");
    set_control(&mut b, "theta-d", &row.to_string(), "input");
    let cut: Vec<Option<f64>> =
        serde_json::from_value(b.eval("window.lobeExplore.sliceCut[0]")).unwrap();
    assert_ne!(
        json!(cut),
        cut_before,
        "the θh curve did not change with θd"
    );
    for (col, v) in cut.iter().enumerate() {
        let k = 3 * (row * 64 + col);
        let lum = match (drawn[k], drawn[k + 1], drawn[k + 2]) {
            (Some(r), Some(g), Some(b)) => {
                Some(0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64)
            }
            _ => None,
        };
        match (v, lum) {
            (None, None) => {}
            (Some(v), Some(lum)) => assert!(
                (v - lum).abs() <= 1e-12 * lum.abs(),
                "θh column {col}: drawn {v}, the slice's row {row} has {lum}"
            ),
            _ => panic!("θh column {col}: drawn {v:?}, the slice's row {row} has {lum:?}"),
        }
    }
    // Row 10's centre, 14.765625°, as the page writes numbers (5 significant digits).
    let theta_d = (row as f64 + 0.5) * 90.0 / 64.0;
    let label = b.eval("document.getElementById('theta-d-value').textContent");
    assert_eq!(label, json!(format!("{theta_d:.3}°")));

    reload(&mut b);
    assert_eq!(b.eval("window.lobeExplore.slicePhiD"), json!(30));
    assert_eq!(
        b.eval("document.getElementById('theta-d').value"),
        json!(row.to_string())
    );
    assert_eq!(b.eval("window.lobeExplore.sliceCut[0]"), json!(cut));
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}

/// sRGB's encoding of a linear value in [0, 1] (IEC 61966-2-1).
fn srgb(c: f64) -> f64 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The tone maps the page offers, from their sources: clipping at white; Reinhard et al. 2002,
/// eq. 3; Narkowicz 2016's ACES fit.
fn tone(name: &str, x: f64) -> f64 {
    match name {
        "clamp" => x.min(1.0),
        "reinhard" => x / (1.0 + x),
        "aces" => ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).min(1.0),
        _ => unreachable!("{name}"),
    }
}

/// A lit view's byte for a radiance `v`: relative to white Lambertian's (π v), times 2^ev,
/// tone-mapped, sRGB-encoded.
fn lit_byte(v: f64, ev: f64, tone_map: &str) -> f64 {
    (255.0
        * srgb(
            tone(
                tone_map,
                (std::f64::consts::PI * v * 2f64.powf(ev)).max(0.0),
            )
            .clamp(0.0, 1.0),
        ))
    .round()
}

/// The lit object's pixels, against the radiance the server sent for them through each exposure
/// and tone map; the torus, the server's own image; all three choices in the link.
#[test]
fn the_lit_views_take_exposure_a_tone_map_and_a_torus() {
    let server = Server::start(&["--material", "gold", "cook_torrance{roughness=0.3}"]);
    let mut b = open(&server);
    let radiance = page_image(&mut b, "window.lobeExplore.lit[0]");
    let check = |b: &mut Browser, ev: f64, tone_map: &str| -> Vec<u8> {
        set_control(b, "exposure", &ev.to_string(), "input");
        set_control(b, "tone-map", tone_map, "change");
        let px = canvas_bytes(b, "#images canvas.lit");
        for (k, v) in radiance.chunks(3).enumerate() {
            let Some(rgb) = v.iter().copied().collect::<Option<Vec<f32>>>() else {
                assert_eq!(px[4 * k + 3], 0, "cell {k} is off the sphere");
                continue;
            };
            for c in 0..3 {
                let want = lit_byte(rgb[c] as f64, ev, tone_map);
                let got = px[4 * k + c] as f64;
                // The page rounds the same values in f64; only the last bit of a power may differ.
                assert!(
                    (got - want).abs() <= 1.0,
                    "cell {k} channel {c}, radiance {}, {ev} EV, {tone_map}: drawn {got}, expected {want}",
                    rgb[c]
                );
            }
        }
        px
    };
    check(&mut b, 0.0, "clamp");
    let clipped = check(&mut b, 2.0, "clamp");
    let reinhard = check(&mut b, 2.0, "reinhard");
    let aces = check(&mut b, 2.0, "aces");
    check(&mut b, -1.5, "aces");
    assert!(
        clipped != reinhard && reinhard != aces && clipped != aces,
        "the tone maps drew the same image"
    );

    set_control(&mut b, "lit-object", "torus", "change");
    b.wait_for(
        "window.lobeExplore.litObject === 'torus' && !!document.querySelector('#images canvas.lit')",
        PAGE_TIMEOUT,
    );
    let drawn = page_image(&mut b, "window.lobeExplore.lit[0]");
    let r = server.post("/api/torus", &image_request(&mut b));
    assert_eq!(r.status, 200, "{}", r.text());
    assert!(
        drawn == server_image(&r.body),
        "the page's torus is not the server's"
    );
    let px = canvas_bytes(&mut b, "#images canvas.lit");
    let centre = 4 * (32 * 64 + 32);
    assert_eq!(px[centre + 3], 0, "the torus's hole is drawn");
    assert!(px.chunks(4).filter(|p| p[3] == 255).count() > 64 * 64 / 4);

    reload(&mut b);
    assert_eq!(b.eval("window.lobeExplore.litObject"), json!("torus"));
    assert_eq!(
        b.eval("[document.getElementById('exposure').value, document.getElementById('tone-map').value]"),
        json!(["-1.5", "aces"])
    );
    assert!(b.errors().is_empty(), "console errors: {:?}", b.errors());
}
