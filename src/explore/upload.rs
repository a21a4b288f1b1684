//! Model files opened from the page: a `.brdf` file (compiled) or a MERL file (read), each kept in
//! the server's temporary folder under a name of its own and loaded by the code behind
//! `--model PATH`, with the same limits; messages name the file as the page gave it.

use super::guard::query_value;
use super::limits::{MAX_BRDF_BYTES, MAX_MERL_BYTES, MAX_UPLOADS};
use super::reply::{answer, bad, json_response, model_json, Refusal, Shared};
use super::State;
use axum::body::Bytes;
use axum::extract::Request;
use axum::http::StatusCode;
use axum::response::Response;
use serde_json::json;
use std::path::PathBuf;
use std::sync::Arc;

/// The two kinds of model file the page opens.
#[derive(Clone, Copy)]
enum Kind {
    Brdf,
    Merl,
}

impl Kind {
    fn extension(self) -> &'static str {
        match self {
            Kind::Brdf => "brdf",
            Kind::Merl => "binary",
        }
    }

    fn max_bytes(self) -> usize {
        match self {
            Kind::Brdf => MAX_BRDF_BYTES,
            Kind::Merl => MAX_MERL_BYTES,
        }
    }
}

/// `POST /api/brdf?name=FILE.brdf`: the file's text as the body.
pub(super) async fn brdf(state: Shared, request: Request) -> Response {
    answer(open(state.0, request, Kind::Brdf).await)
}

/// `POST /api/merl?name=FILE.binary`: the file's bytes as the body.
pub(super) async fn merl(state: Shared, request: Request) -> Response {
    answer(open(state.0, request, Kind::Merl).await)
}

async fn open(state: Arc<State>, request: Request, kind: Kind) -> Result<Response, Refusal> {
    let name = query_value(request.uri().query().unwrap_or(""), "name").unwrap_or_default();
    let max = kind.max_bytes();
    let body = axum::body::to_bytes(request.into_body(), max)
        .await
        .map_err(|_| {
            (
                StatusCode::PAYLOAD_TOO_LARGE,
                format!("a .{} file may be at most {max} bytes", kind.extension()),
            )
        })?;
    let opened = state.uploaded.lock().map_or(0, |list| list.len());
    if opened >= MAX_UPLOADS {
        return Err(bad(format!(
            "{opened} files opened already: a page may open at most {MAX_UPLOADS}; restart \
             lobe explore for more"
        )));
    }
    let (path, label) = keep(&state, &name, kind, &body)?;
    let shown = path.display().to_string();
    let brdf_options = state.brdf.clone();
    let loaded = tokio::task::spawn_blocking(move || match kind {
        Kind::Brdf => crate::brdf::load(&path, &brdf_options)
            .map(|l| (l.model, l.notes))
            .map_err(anyhow::Error::from),
        Kind::Merl => crate::merl::model::load(&path).map(|l| (l.model, Vec::new())),
    })
    .await
    .map_err(|e| {
        (
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("loading {label}: {e}"),
        )
    })?;
    let (model, notes) = loaded.map_err(|e| {
        // A file that did not load is not kept: only the models a page opened hold disk space.
        let _ = std::fs::remove_file(&shown);
        bad(format!("{e:#}").replace(&shown, &label))
    })?;
    if let Ok(mut list) = state.uploaded.lock() {
        list.push((model, label.clone(), shown.clone()));
    }
    let mut v = model_json(model, Some(&label));
    v["notes"] = json!(notes);
    Ok(json_response(&renamed(v, &shown, &label)))
}

/// Writes an opened file into the server's own folder under a name made of its stem's letters,
/// digits, `-` and `_` (numbered where taken); returns the path and the name messages use.
fn keep(state: &State, name: &str, kind: Kind, body: &Bytes) -> Result<(PathBuf, String), Refusal> {
    let ext = kind.extension();
    let stem: String = name
        .strip_suffix(&format!(".{ext}"))
        .unwrap_or(name)
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(64)
        .collect();
    let stem = if stem.is_empty() {
        "uploaded".to_string()
    } else {
        stem
    };
    if matches!(kind, Kind::Brdf) && std::str::from_utf8(body).is_err() {
        return Err(bad(format!("{stem}.{ext}: not a text file (not UTF-8)")));
    }
    // The model is named after the file's stem: number it where a file or a model (one given on
    // the command line, say) has the name already.
    let taken =
        |name: &str, path: &std::path::Path| path.exists() || crate::Model::from_name(name).is_ok();
    let mut name = stem.clone();
    let mut path = state.uploads.path().join(format!("{name}.{ext}"));
    for k in 2.. {
        if !taken(&name, &path) {
            break;
        }
        name = format!("{stem}-{k}");
        path = state.uploads.path().join(format!("{name}.{ext}"));
    }
    std::fs::write(&path, body).map_err(|e| {
        (
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("keeping {stem}.{ext}: {e}"),
        )
    })?;
    Ok((path, format!("{stem}.{ext}")))
}

/// `v` with every mention of the folder path `from` in its strings replaced by the name `to`.
pub(super) fn renamed(v: serde_json::Value, from: &str, to: &str) -> serde_json::Value {
    match v {
        serde_json::Value::String(text) => json!(text.replace(from, to)),
        serde_json::Value::Array(items) => {
            json!(items
                .into_iter()
                .map(|x| renamed(x, from, to))
                .collect::<Vec<_>>())
        }
        serde_json::Value::Object(map) => serde_json::Value::Object(
            map.into_iter()
                .map(|(k, x)| (k, renamed(x, from, to)))
                .collect(),
        ),
        other => other,
    }
}
