//! Environment maps opened from the page (`POST /api/env?name=FILE`, the file's bytes as the
//! body): kept in the server's folder while the reader behind `lobe light --env FILE` reads them
//! (the same formats, limits and refusals), shrunk by 2 × 2 box averages while wider than
//! [`MAX_LIT_MAP_WIDTH`] so that the lit view's exact sum stays cheap, and kept under the file's
//! name for `POST /api/light`.

use super::guard::query_value;
use super::limits::{MAX_ENV_BYTES, MAX_UPLOADS};
use super::reply::{answer, bad, json_response, Refusal, Shared};
use super::State;
use crate::backend::light::EnvMap;
use axum::extract::Request;
use axum::http::StatusCode;
use axum::response::Response;
use serde_json::json;
use std::sync::Arc;

/// The widest map the lit view sums over; a wider one is box-averaged down to it.
pub const MAX_LIT_MAP_WIDTH: u32 = 256;

/// `POST /api/env?name=FILE.exr|FILE.hdr`.
pub(super) async fn env(state: Shared, request: Request) -> Response {
    answer(open(state.0, request).await)
}

async fn open(state: Arc<State>, request: Request) -> Result<Response, Refusal> {
    let name = query_value(request.uri().query().unwrap_or(""), "name").unwrap_or_default();
    let body = axum::body::to_bytes(request.into_body(), MAX_ENV_BYTES)
        .await
        .map_err(|_| {
            (
                StatusCode::PAYLOAD_TOO_LARGE,
                format!("an environment map file may be at most {MAX_ENV_BYTES} bytes"),
            )
        })?;
    let opened = state.maps.lock().map_or(0, |list| list.len());
    if opened >= MAX_UPLOADS {
        return Err(bad(format!(
            "{opened} maps opened already: a page may open at most {MAX_UPLOADS}; restart \
             lobe explore for more"
        )));
    }
    let clean: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .take(64)
        .collect();
    let label = if clean.is_empty() {
        "uploaded".to_string()
    } else {
        clean
    };
    let path = state
        .uploads
        .path()
        .join(format!("env-{opened}-{}", label.replace('.', "_")));
    std::fs::write(&path, &body).map_err(|e| {
        (
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("keeping {label}: {e}"),
        )
    })?;
    let shown = path.display().to_string();
    let read_path = path.clone();
    let read = tokio::task::spawn_blocking(move || crate::light::maps::read_map(&read_path))
        .await
        .map_err(|e| {
            (
                StatusCode::INTERNAL_SERVER_ERROR,
                format!("reading {label}: {e}"),
            )
        })?;
    // The map is kept in memory, not its file.
    let _ = std::fs::remove_file(&path);
    let map = read.map_err(|e| bad(format!("{e:#}").replace(&shown, &label)))?;
    let (file_width, file_height) = (map.width(), map.height());
    let map = shrunk(map).map_err(|e| bad(format!("{label}: {e:#}")))?;
    let mut list = state.maps.lock().map_err(|_| {
        (
            StatusCode::INTERNAL_SERVER_ERROR,
            "the opened maps' list is unavailable".to_string(),
        )
    })?;
    let taken = |n: &str| {
        crate::light::maps::Builtin::from_name(n).is_some() || list.iter().any(|(m, _)| m == n)
    };
    let mut id = label.clone();
    for k in 2.. {
        if !taken(&id) {
            break;
        }
        id = format!("{label}-{k}");
    }
    let body = json!({
        "name": id,
        "file_width": file_width,
        "file_height": file_height,
        "width": map.width(),
        "height": map.height(),
        "downsampled": map.width() != file_width,
    });
    list.push((id, Arc::new(map)));
    Ok(json_response(&body))
}

/// `map` halved (each texel the mean of a 2 × 2 block; an odd last row or column dropped) while
/// wider than [`MAX_LIT_MAP_WIDTH`].
pub fn shrunk(map: EnvMap) -> anyhow::Result<EnvMap> {
    let mut map = map;
    while map.width() > MAX_LIT_MAP_WIDTH && map.height() >= 2 {
        let (w, h) = (map.width() / 2, map.height() / 2);
        let texels = (0..h)
            .flat_map(|i| (0..w).map(move |j| (i, j)))
            .map(|(i, j)| {
                let mut sum = [0.0f64; 3];
                for (r, c) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    let t = map.texel(2 * i + r, 2 * j + c);
                    for k in 0..3 {
                        sum[k] += t[k] as f64 / 4.0;
                    }
                }
                sum.map(|v| v as f32)
            })
            .collect();
        map = EnvMap::new(w, h, texels)?;
    }
    Ok(map)
}
