//! The routes: the page and its assets, the model list, and one route per view, each answering
//! with what a [`Session`](crate::Session) computes (binary little-endian f32 RGB for the
//! views, JSON for the albedo and the model list).

use super::cells::{hemisphere_cell, lobe_cell, slice_cell, Cell, Setting, DEFAULT_PHI_D_DEG};
use super::download;
use super::guard::{self, refuse};
use super::limits::*;
use super::objects::{sphere_cell, torus_cell};
use super::reply::{
    answer, bad, check_incidence, evaluate, json_response, model_json, resolve, Refusal, Shared,
};
use super::upload::{self, renamed};
use super::{State, ASSETS, INDEX_HTML};
use crate::backend::Query;
use crate::model::{Model, ParamSet};
use crate::plot::hemisphere::{cell_direction, cell_point, Projection};
use crate::plot::polar::{light_direction, view_direction};
use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Request};
use axum::http::{header, HeaderName, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use glam::DVec3;
use serde_json::json;
use std::sync::Arc;

pub(crate) fn router(state: Arc<State>) -> Router {
    let mut router = Router::new().route("/", get(index));
    for (path, content_type, text) in ASSETS {
        router = router.route(path, get(move || asset(content_type, text)));
    }
    router
        .route("/api/models", get(models))
        .route("/api/status", get(status))
        .route("/api/polar", post(polar))
        .route("/api/hemisphere", post(hemisphere))
        .route("/api/slice", post(slice))
        .route("/api/sphere", post(sphere))
        .route("/api/torus", post(torus))
        .route("/api/lobe", post(lobe))
        .route("/api/albedo", post(albedo))
        .route("/api/samples", post(samples))
        .route("/api/light", post(light))
        .route("/api/table", post(download::table))
        .route("/api/plot", post(download::polar_svg))
        // The routes above read a small JSON body; the guard bounds it (a declared length before
        // it is read, a chunked body as it arrives), and so does this, should the guard change.
        .layer(DefaultBodyLimit::max(MAX_BODY_BYTES))
        .route("/api/brdf", post(upload::brdf))
        .route("/api/merl", post(upload::merl))
        .route("/api/env", post(super::env::env))
        .fallback(|r: Request| async move {
            refuse(
                StatusCode::NOT_FOUND,
                format!("no such page: {}", r.uri().path()),
            )
        })
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            guard::guard,
        ))
        .with_state(state)
}

/// The page: scripts only from this server, requests only to it.
const CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

async fn index(state: Shared) -> Response {
    let html = INDEX_HTML.replace("__TOKEN__", &state.token);
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CONTENT_SECURITY_POLICY, CSP),
            (header::CACHE_CONTROL, "no-store"),
            (header::REFERRER_POLICY, "no-referrer"),
        ],
        html,
    )
        .into_response()
}

async fn asset(content_type: &'static str, text: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CACHE_CONTROL, "no-store"),
            (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        ],
        text,
    )
        .into_response()
}

/// What a view asks for: a model with its parameters (as `lobe table --model M --material P
/// --set K=V` takes them) and the view's settings.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewRequest {
    model: String,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    sets: Vec<String>,
    #[serde(default)]
    white_furnace: bool,
    #[serde(default)]
    theta_i_deg: f64,
    /// Polar: view angles; hemisphere: cells across; albedo: view directions.
    samples: usize,
    /// The slice's φd, degrees (default [`DEFAULT_PHI_D_DEG`]); refused by the other views.
    #[serde(default)]
    phi_d_deg: Option<f64>,
}

/// Parses and checks a view request; `max` bounds `samples`, `what` names them; `uses_phi_d`:
/// the view reads `phi_d_deg` (the slice), which the others refuse rather than ignore.
fn parse_view(
    body: &[u8],
    max: usize,
    what: &str,
    uses_phi_d: bool,
) -> Result<(ViewRequest, ParamSet), Refusal> {
    let req: ViewRequest =
        serde_json::from_slice(body).map_err(|e| bad(format!("request body: {e}")))?;
    if !(1..=max).contains(&req.samples) {
        return Err(bad(format!(
            "samples {}: expected {what} from 1 to {max}",
            req.samples
        )));
    }
    check_incidence(req.theta_i_deg)?;
    match req.phi_d_deg {
        Some(_) if !uses_phi_d => {
            return Err(bad(
                "phi_d_deg: only the slice (/api/slice) has a difference azimuth".to_string(),
            ))
        }
        Some(v) => check_phi_d(v)?,
        None => {}
    }
    let params = resolve(&req.model, req.material.as_deref(), &req.sets)?;
    Ok((req, params))
}

/// `GET /api/status`: evaluations stopped because their page stopped waiting, so far.
async fn status(state: Shared) -> Response {
    json_response(&json!({
        "stopped": state.stopped.load(std::sync::atomic::Ordering::SeqCst),
    }))
}

/// f32 RGB values as little-endian bytes, with the count of invalid values (NaN, ±Inf,
/// negative) in a header.
fn binary(values: &[[f64; 3]], invalid: u64, params: &ParamSet) -> Response {
    let floats: Vec<f32> = values.iter().flatten().map(|&v| v as f32).collect();
    let bytes: Vec<u8> = floats.iter().flat_map(|v| v.to_le_bytes()).collect();
    (
        [
            (header::CONTENT_TYPE, "application/octet-stream".to_string()),
            (header::CACHE_CONTROL, "no-store".to_string()),
            (
                HeaderName::from_static("x-lobe-invalid"),
                invalid.to_string(),
            ),
            // The values evaluated (defaults, preset, assignments), for the page's controls.
            (
                HeaderName::from_static("x-lobe-params"),
                ascii_json(&params.to_json()),
            ),
        ],
        bytes,
    )
        .into_response()
}

/// JSON with every character outside printable ASCII escaped, as a header value must be.
fn ascii_json(v: &serde_json::Value) -> String {
    v.to_string()
        .chars()
        .map(|c| match c {
            ' '..='~' => c.to_string(),
            c => c
                .encode_utf16(&mut [0; 2])
                .iter()
                .map(|u| format!("\\u{u:04x}"))
                .collect(),
        })
        .collect()
}

/// The view angles of a polar curve, degrees: `n` cell centres over (−90°, 90°); positive is
/// φo = 0, the mirror side of a light at φi = 180° ([`crate::plot::polar`]).
pub fn polar_angles_deg(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| -90.0 + (k as f64 + 0.5) * 180.0 / n as f64)
        .collect()
}

async fn polar(state: Shared, body: Bytes) -> Response {
    answer(polar_values(state.0, body).await)
}

async fn polar_values(state: Arc<State>, body: Bytes) -> Result<Response, Refusal> {
    let (req, params) = parse_view(&body, MAX_POLAR_SAMPLES, "view angles", false)?;
    let wi = light_direction(req.theta_i_deg.to_radians());
    let pairs: Vec<(DVec3, DVec3)> = polar_angles_deg(req.samples)
        .into_iter()
        .map(|s| (wi, view_direction(s.to_radians())))
        .collect();
    let p = params.clone();
    let (f, count) = evaluate(&state, params.model(), move |session| {
        session.eval_pairs_counting(Query::one(&p).with_white_furnace(req.white_furnace), &pairs)
    })
    .await?;
    Ok(binary(&f, count.invalid, &params))
}

async fn hemisphere(state: Shared, body: Bytes) -> Response {
    answer(image(state.0, body, hemisphere_cell, false).await)
}

async fn slice(state: Shared, body: Bytes) -> Response {
    answer(image(state.0, body, slice_cell, true).await)
}

async fn sphere(state: Shared, body: Bytes) -> Response {
    answer(image(state.0, body, sphere_cell, false).await)
}

async fn torus(state: Shared, body: Bytes) -> Response {
    answer(image(state.0, body, torus_cell, false).await)
}

async fn lobe(state: Shared, body: Bytes) -> Response {
    answer(image(state.0, body, lobe_cell, false).await)
}

/// Refuses a slice's φd outside [0°, 360°].
fn check_phi_d(phi_d_deg: f64) -> Result<(), Refusal> {
    if !(phi_d_deg.is_finite() && (0.0..=360.0).contains(&phi_d_deg)) {
        return Err(bad(format!(
            "phi_d_deg {phi_d_deg}: expected the slice's difference azimuth in [0, 360] degrees"
        )));
    }
    Ok(())
}

/// An image view: `res` × `res` cells (`cell` says what each evaluates), f32 RGB in rows from the
/// top, NaN where the view has no value; `uses_phi_d` as for [`parse_view`].
async fn image(
    state: Arc<State>,
    body: Bytes,
    cell: Cell,
    uses_phi_d: bool,
) -> Result<Response, Refusal> {
    let (req, params) = parse_view(&body, MAX_IMAGE_RES, "cells across", uses_phi_d)?;
    let phi_d_deg = req.phi_d_deg.unwrap_or(DEFAULT_PHI_D_DEG);
    let res = req.samples;
    let at = Setting {
        theta_i: req.theta_i_deg.to_radians(),
        phi_d: phi_d_deg.to_radians(),
    };
    let mut cells = Vec::with_capacity(res * res);
    let mut pairs = Vec::new();
    for row in 0..res {
        for col in 0..res {
            let c = cell(res, row, col, at);
            cells.push(c.map(|(_, _, factor)| factor));
            pairs.extend(c.map(|(wi, wo, _)| (wi, wo)));
        }
    }
    let p = params.clone();
    let (f, count) = evaluate(&state, params.model(), move |session| {
        session.eval_pairs_counting(Query::one(&p).with_white_furnace(req.white_furnace), &pairs)
    })
    .await?;
    let mut values = f.into_iter();
    let image: Vec<[f64; 3]> = cells
        .iter()
        .map(|c| match c {
            Some(factor) => values
                .next()
                .map_or([f64::NAN; 3], |v| v.map(|x| x * factor)),
            None => [f64::NAN; 3],
        })
        .collect();
    Ok(binary(&image, count.invalid, &params))
}

/// The view directions of an E(μ) curve: μ = k/n for k = 1..n, at φo = 0.
pub fn albedo_mus(n: usize) -> Vec<f64> {
    (1..=n).map(|k| k as f64 / n as f64).collect()
}

async fn albedo(state: Shared, body: Bytes) -> Response {
    answer(albedo_values(state.0, body).await)
}

async fn albedo_values(state: Arc<State>, body: Bytes) -> Result<Response, Refusal> {
    let (req, params) = parse_view(&body, MAX_ALBEDO_POINTS, "view directions", false)?;
    let settings = crate::AlbedoSettings {
        white_furnace: req.white_furnace,
        ..crate::AlbedoSettings::default()
    };
    let mus = albedo_mus(req.samples);
    let points: Vec<(f64, f64)> = mus.iter().map(|&m| (m, 0.0)).collect();
    let (e, hemi) = evaluate(&state, params.model(), move |session| {
        let e = session.directional_albedo(&params, &settings, &points)?;
        let hemi = session.hemispherical_albedo(&params, &settings, 0.0)?;
        Ok((e, hemi))
    })
    .await?;
    let v = |d: DVec3| json!([d.x, d.y, d.z]);
    let body = json!({
        "mu": mus,
        "albedo": e.iter().map(|p| v(p.albedo)).collect::<Vec<_>>(),
        "error": e.iter().map(|p| v(p.error)).collect::<Vec<_>>(),
        "hemispherical": v(hemi.albedo),
        "hemispherical_error": v(hemi.error),
        "method": "peak",
    });
    Ok(json_response(&body))
}

/// What the samples view asks for: a model as [`ViewRequest`] names it, the view direction
/// (θo, φo), how many draws from which stream, and the pdf's cells across.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SamplesRequest {
    model: String,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    sets: Vec<String>,
    #[serde(default)]
    white_furnace: bool,
    theta_o_deg: f64,
    #[serde(default)]
    phi_o_deg: f64,
    draws: usize,
    #[serde(default)]
    seed: u32,
    /// Cells across the pdf's equal-area disc.
    res: usize,
}

/// The view direction of `lobe sample --theta-o-deg T --phi-o-deg P`, refused outside
/// θo ∈ [0°, 90°) or for a φo that is not finite.
fn view_of(theta_o_deg: f64, phi_o_deg: f64) -> Result<DVec3, Refusal> {
    if !(theta_o_deg.is_finite() && (0.0..90.0).contains(&theta_o_deg)) {
        return Err(bad(format!(
            "theta_o_deg {theta_o_deg}: expected a view angle in [0, 90) degrees"
        )));
    }
    if !phi_o_deg.is_finite() {
        return Err(bad(format!(
            "phi_o_deg {phi_o_deg}: expected a finite azimuth in degrees"
        )));
    }
    let (t, p) = (theta_o_deg.to_radians(), phi_o_deg.to_radians());
    Ok(DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()))
}

async fn samples(state: Shared, body: Bytes) -> Response {
    answer(samples_values(state.0, body).await)
}

/// `POST /api/samples`: [`Session::sample`](crate::Session::sample)'s draws for the request's
/// ωo and seed (those of `lobe sample` with the same flags), and
/// [`Session::pdf`](crate::Session::pdf) at the centre of each cell of the hemisphere view's
/// equal-area disc (rows from the top, null outside the disc), as JSON.
async fn samples_values(state: Arc<State>, body: Bytes) -> Result<Response, Refusal> {
    let req: SamplesRequest =
        serde_json::from_slice(&body).map_err(|e| bad(format!("request body: {e}")))?;
    if !(1..=MAX_VIEW_DRAWS).contains(&req.draws) {
        return Err(bad(format!(
            "draws {}: expected from 1 to {MAX_VIEW_DRAWS} draws",
            req.draws
        )));
    }
    if !(1..=MAX_IMAGE_RES).contains(&req.res) {
        return Err(bad(format!(
            "res {}: expected the pdf's cells across from 1 to {MAX_IMAGE_RES}",
            req.res
        )));
    }
    let wo = view_of(req.theta_o_deg, req.phi_o_deg)?;
    let params = resolve(&req.model, req.material.as_deref(), &req.sets)?;
    let res = req.res;
    let cells: Vec<Option<DVec3>> = (0..res * res)
        .map(|k| {
            let (x, y) = cell_point(res, k / res, k % res);
            cell_direction(Projection::EqualArea, x, y)
        })
        .collect();
    let pairs: Vec<(DVec3, DVec3)> = cells.iter().flatten().map(|&wi| (wi, wo)).collect();
    let p = params.clone();
    let (draws, pdf) = evaluate(&state, params.model(), move |session| {
        let query = Query::one(&p).with_white_furnace(req.white_furnace);
        let draws = session.sample(query, wo, req.draws, req.seed)?;
        let pdf = session.pdf(query, &pairs)?;
        Ok((draws, pdf))
    })
    .await?;
    let mut pdf = pdf.into_iter();
    let grid: Vec<Option<f64>> = cells.iter().map(|c| c.and_then(|_| pdf.next())).collect();
    let lost = (0..draws.len())
        .filter(|&k| !draws.delta[k] && draws.pdf[k] == 0.0)
        .count();
    let delta = draws.delta.iter().filter(|&&d| d).count();
    let body = json!({
        "wo": draws.wo,
        "seed": draws.seed,
        "wi": draws.wi,
        "pdf": draws.pdf,
        "delta": draws.delta,
        "lost": lost,
        "delta_count": delta,
        "res": res,
        "pdf_grid": grid,
        "backend": draws.backend,
        "params": params.to_json(),
    });
    Ok(json_response(&body))
}

/// What the lit view asks for: a model as [`ViewRequest`] names it, a built-in map by name and
/// the image's pixels per side.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct LightRequest {
    model: String,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    sets: Vec<String>,
    env: String,
    size: u32,
}

async fn light(state: Shared, body: Bytes) -> Response {
    answer(light_values(state.0, body).await)
}

/// `POST /api/light`: [`Session::light`](crate::Session::light) and
/// [`Session::light_split_sum`](crate::Session::light_split_sum) of the sphere under a built-in
/// map, as JSON (linear radiance, rows from the top, RGB flattened); `split` is null with the
/// reason in `split_note` for a model that has no split sum.
async fn light_values(state: Arc<State>, body: Bytes) -> Result<Response, Refusal> {
    let req: LightRequest =
        serde_json::from_slice(&body).map_err(|e| bad(format!("request body: {e}")))?;
    if !(1..=MAX_LIGHT_SIZE).contains(&req.size) {
        return Err(bad(format!(
            "size {}: expected the lit sphere's pixels per side from 1 to {MAX_LIGHT_SIZE}",
            req.size
        )));
    }
    let map: Arc<crate::backend::light::EnvMap> =
        match crate::light::maps::Builtin::from_name(&req.env) {
            Some(builtin) => Arc::new(builtin.map()),
            None => {
                let list = state
                    .maps
                    .lock()
                    .map_err(|_| bad("the opened maps' list is unavailable".to_string()))?;
                match list.iter().find(|(name, _)| *name == req.env) {
                    Some((_, m)) => m.clone(),
                    None => {
                        let opened: Vec<&str> = list.iter().map(|(n, _)| n.as_str()).collect();
                        return Err(bad(format!(
                            "env '{}': expected a built-in map (sky, studio or constant) or a map \
                             opened from the page ({})",
                            req.env,
                            if opened.is_empty() {
                                "none yet".to_string()
                            } else {
                                opened.join(", ")
                            }
                        )));
                    }
                }
            }
        };
    let params = resolve(&req.model, req.material.as_deref(), &req.sets)?;
    let size = req.size;
    let p = params.clone();
    let (exact, split) = evaluate(&state, params.model(), move |session| {
        let exact = session.light(&p, &map, size, &mut |_, _| {})?;
        let split = match session.light_split_sum(&p, &map, size, &mut |_, _| {}) {
            Ok(s) => Ok(s),
            Err(e @ crate::Error::Cancelled(_)) => return Err(e),
            Err(e) => Err(e.to_string()),
        };
        Ok((exact, split))
    })
    .await?;
    let flat = |i: &crate::light::LightImage| -> Vec<f32> {
        i.pixels.iter().flatten().map(|&v| v as f32).collect()
    };
    let body = json!({
        "size": size,
        "env": req.env,
        "exact": flat(&exact),
        "split": split.as_ref().ok().map(flat),
        "split_note": split.as_ref().err(),
    });
    Ok(json_response(&body))
}

/// The assignments that take a set from its model's defaults to itself.
fn changed_assignments(p: &ParamSet) -> Vec<String> {
    // The defaults of the model's name, not of its current component choices, so that a changed
    // choice is listed.
    let defaults =
        ParamSet::for_model(p.model().name()).unwrap_or_else(|_| ParamSet::defaults(p.model()));
    p.entries()
        .into_iter()
        .filter(|(k, v)| defaults.get(k) != *v)
        .map(|(k, v)| format!("{k}={v}"))
        .collect()
}

async fn models(state: Shared) -> Response {
    // A spec's name part that is not its model's name is the file it was loaded from.
    let given = state.initial.iter().map(|(label, p)| {
        let name = label.split('{').next().unwrap_or(label).trim();
        (
            p.model(),
            (name != p.model().name()).then(|| name.to_string()),
        )
    });
    let uploaded = state.uploaded.lock().map(|u| u.clone()).unwrap_or_default();
    let mut list: Vec<(Model, Option<String>)> = Model::ALL.iter().map(|&m| (m, None)).collect();
    for (m, source) in given.chain(uploaded.iter().map(|(m, s, _)| (*m, Some(s.clone())))) {
        if !list.iter().any(|(k, _)| k.name() == m.name()) {
            list.push((m, source));
        }
    }
    let shown =
        |m: Model, v: serde_json::Value| match uploaded.iter().find(|u| u.0.name() == m.name()) {
            Some((_, label, path)) => renamed(v, path, label),
            None => v,
        };
    let initial: Vec<serde_json::Value> = state
        .initial
        .iter()
        .map(|(_, p)| json!({"model": p.model().name(), "sets": changed_assignments(p)}))
        .collect();
    // The maps opened on the page, by the names `POST /api/light` takes (a link names one).
    let maps: Vec<String> = state
        .maps
        .lock()
        .map(|list| list.iter().map(|(name, _)| name.clone()).collect())
        .unwrap_or_default();
    json_response(&json!({
        "models": list
            .iter()
            .map(|(m, source)| shown(*m, model_json(*m, source.as_deref())))
            .collect::<Vec<_>>(),
        "materials": crate::material::all_names(),
        "material": state.material,
        "initial": initial,
        "maps": maps,
        "backend": state.session.backend_name(),
        "limits": {
            "polar_samples": MAX_POLAR_SAMPLES,
            "hemisphere_res": MAX_IMAGE_RES,
            "albedo_points": MAX_ALBEDO_POINTS,
            "brdf_bytes": MAX_BRDF_BYTES,
            "merl_bytes": MAX_MERL_BYTES,
        },
        "table": {"grid": download::TABLE_GRID, "res": download::TABLE_RES},
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::direction_deg;

    /// The direction of `lobe eval --wo-deg THETA,PHI` for a polar view angle `s` (degrees):
    /// (|s|, 0) on the mirror side, (|s|, 180) on the other.
    fn eval_angles_of_view(s_deg: f64) -> (f64, f64) {
        (s_deg.abs(), if s_deg >= 0.0 { 0.0 } else { 180.0 })
    }

    /// The polar geometry written as `lobe eval` angles reaches the same directions.
    #[test]
    fn polar_directions_are_eval_angles() {
        for s in polar_angles_deg(7) {
            let (t, p) = eval_angles_of_view(s);
            let d = direction_deg(t, p) - view_direction(s.to_radians());
            assert!(d.length() < 1e-12, "s = {s}: {d}");
        }
        let wi = direction_deg(30.0, 180.0) - light_direction(30f64.to_radians());
        assert!(wi.length() < 1e-12, "{wi}");
    }
}
