//! What every request passes before a handler sees it: the session token, a `Host` header that
//! names the bound address, no foreign `Origin`, and a bounded target and body.

use super::limits::{MAX_BODY_BYTES, MAX_BRDF_BYTES, MAX_ENV_BYTES, MAX_MERL_BYTES, MAX_URI_BYTES};
use super::State;
use axum::extract::Request;
use axum::http::{header, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use std::sync::Arc;

/// The request header the page's script sends the token in (the page itself and its assets
/// carry it in the query, `?token=`).
pub const TOKEN_HEADER: &str = "x-lobe-token";

pub(crate) async fn guard(
    axum::extract::State(state): axum::extract::State<Arc<State>>,
    request: Request,
    next: Next,
) -> Response {
    if let Err((status, message)) = check(&state, &request) {
        return refuse(status, message);
    }
    match bounded(request).await {
        Ok(request) => next.run(request).await,
        Err((status, message)) => refuse(status, message),
    }
}

/// The request with its body read within the route's bound where it came without a
/// Content-Length (chunked): `check` refuses a declared length above the bound before anything
/// is read, and this refuses an undeclared one at the first byte past it, with the same sentence.
async fn bounded(request: Request) -> Result<Request, (StatusCode, String)> {
    if request.headers().contains_key(header::CONTENT_LENGTH) {
        return Ok(request);
    }
    let path = request.uri().path().to_string();
    let limit = body_limit(&path);
    let (parts, body) = request.into_parts();
    let bytes = axum::body::to_bytes(body, limit).await.map_err(|_| {
        (
            StatusCode::PAYLOAD_TOO_LARGE,
            format!("the request body is over {limit} bytes; {path} takes at most {limit}"),
        )
    })?;
    Ok(Request::from_parts(parts, axum::body::Body::from(bytes)))
}

/// The largest body a route takes: a model file for the two upload routes, else a view request.
fn body_limit(path: &str) -> usize {
    match path {
        "/api/brdf" => MAX_BRDF_BYTES,
        "/api/merl" => MAX_MERL_BYTES,
        "/api/env" => MAX_ENV_BYTES,
        _ => MAX_BODY_BYTES,
    }
}

/// A refusal: the status and a sentence, as plain text.
pub(crate) fn refuse(status: StatusCode, message: String) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        message,
    )
        .into_response()
}

fn check(state: &State, request: &Request) -> Result<(), (StatusCode, String)> {
    let uri = request.uri();
    let target_len = uri.path_and_query().map_or(0, |p| p.as_str().len());
    if target_len > MAX_URI_BYTES {
        return Err((
            StatusCode::URI_TOO_LONG,
            format!(
                "the request target is {target_len} bytes; at most {MAX_URI_BYTES} are accepted"
            ),
        ));
    }
    let host = request
        .headers()
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    let any_host = state.hosts.is_empty();
    if !any_host && !state.hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) {
        return Err((
            StatusCode::FORBIDDEN,
            format!(
                "Host '{host}' refused: this server answers only to {}",
                state.hosts.join(" or ")
            ),
        ));
    }
    if let Some(origin) = request.headers().get(header::ORIGIN) {
        let origin = origin.to_str().unwrap_or("");
        let ours = state
            .hosts
            .iter()
            .any(|h| origin.eq_ignore_ascii_case(&format!("http://{h}")));
        if !ours && !any_host {
            return Err((
                StatusCode::FORBIDDEN,
                format!("Origin '{origin}' refused: no cross-origin requests"),
            ));
        }
    }
    let given = request
        .headers()
        .get(TOKEN_HEADER)
        .and_then(|h| h.to_str().ok())
        .map(str::to_string)
        .or_else(|| query_value(uri.query().unwrap_or(""), "token"));
    if !given.is_some_and(|t| same(t.as_bytes(), state.token.as_bytes())) {
        return Err((
            StatusCode::FORBIDDEN,
            "missing or wrong session token: open the URL that `lobe explore` printed, with its ?token=".to_string(),
        ));
    }
    let limit = body_limit(uri.path());
    let length = request
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|h| h.to_str().ok())
        .and_then(|t| t.parse::<u64>().ok());
    if let Some(length) = length.filter(|&n| n > limit as u64) {
        return Err((
            StatusCode::PAYLOAD_TOO_LARGE,
            format!(
                "the request body is {length} bytes; {} takes at most {limit}",
                uri.path()
            ),
        ));
    }
    Ok(())
}

/// The value of `key` in a query string (percent-decoding is not needed: tokens and the keys
/// looked up are plain ASCII).
pub(crate) fn query_value(query: &str, key: &str) -> Option<String> {
    query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v.to_string())
}

/// Compares in time independent of where the first difference is, so that timing does not
/// reveal the token a byte at a time.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}
