//! What every route answers with and how it runs its work: refusals (a status and a sentence),
//! a model's parameters from a request, evaluation on a blocking thread with a cancellation token
//! of the request's own, and JSON.

use super::guard::refuse;
use super::limits::MAX_ASSIGNMENTS;
use super::State;
use crate::model::{Model, ParamKind, ParamSet, Value};
use crate::resolve::split_spec;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use serde_json::json;
use std::sync::Arc;

pub(super) type Shared = axum::extract::State<Arc<State>>;

/// A request that cannot be answered: the status and the sentence the page shows.
pub(super) type Refusal = (StatusCode, String);

pub(super) fn bad(message: String) -> Refusal {
    (StatusCode::UNPROCESSABLE_ENTITY, message)
}

/// Refuses an incidence angle outside [0°, 90°).
pub(super) fn check_incidence(theta_i_deg: f64) -> Result<(), Refusal> {
    if !(theta_i_deg.is_finite() && (0.0..90.0).contains(&theta_i_deg)) {
        return Err(bad(format!(
            "theta_i_deg {theta_i_deg}: expected an incidence angle in [0, 90) degrees"
        )));
    }
    Ok(())
}

/// A model's parameters as the page's command lines give them, `--model 'M{K=V,...}'
/// --material P`, with at most [`MAX_ASSIGNMENTS`] assignments. The assignments are read as
/// that spec's own, by the command line's parser ([`split_spec`]), so that what it refuses (a
/// key given twice) is refused here in its words.
pub(super) fn resolve(
    model: &str,
    material: Option<&str>,
    sets: &[String],
) -> Result<ParamSet, Refusal> {
    if sets.len() > MAX_ASSIGNMENTS {
        return Err(bad(format!(
            "{} assignments: at most {MAX_ASSIGNMENTS} are accepted",
            sets.len()
        )));
    }
    let spec = format!("{model}{{{}}}", sets.join(","));
    let (name, own) = split_spec(&spec).map_err(|e| bad(format!("{e:#}")))?;
    crate::resolve_params(name, material, &own).map_err(|e| bad(format!("model {model}: {e}")))
}

/// Runs `job` on a blocking thread (evaluation holds a core) and turns its failure into a
/// refusal: a parameter the model refuses, or a shader of its own that runs past its time limit,
/// is the request's fault, anything else the server's.
pub(super) async fn blocking<T: Send + 'static>(
    job: impl FnOnce() -> crate::Result<T> + Send + 'static,
) -> Result<T, Refusal> {
    match tokio::task::spawn_blocking(job).await {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e @ crate::Error::Param(_))) => Err(bad(e.to_string())),
        // The model's own shader did not finish within its limit: the model's fault.
        Ok(Err(e @ crate::Error::Gpu(crate::gpu::GpuError::ModelTimeout { .. }))) => {
            Err(bad(e.to_string()))
        }
        Ok(Err(e)) => Err((StatusCode::INTERNAL_SERVER_ERROR, e.to_string())),
        Err(e) => Err((
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("evaluation failed: {e}"),
        )),
    }
}

/// Runs `job` on a blocking thread on the session that evaluates `model`
/// ([`State::session_for`]), with a cancellation token of its own: when the page stops waiting
/// (it dropped a stale request, so the connection closed and this future is dropped), the job
/// stops at its next chunk instead of finishing for no one. A shader that timed out retires its
/// session.
pub(super) async fn evaluate<T: Send + 'static>(
    state: &Arc<State>,
    model: Model,
    job: impl FnOnce(&crate::Session) -> crate::Result<T> + Send + 'static,
) -> Result<T, Refusal> {
    let state = state.clone();
    let token = state.session.cancel_token().child();
    let _stop = StopOnDrop(token.clone());
    blocking(move || {
        let session = state.session_for(model)?;
        let call = session.with_cancel(token.clone());
        let result = job(&call);
        match &result {
            Err(crate::Error::Cancelled(_)) if !state.session.cancel_token().is_cancelled() => {
                state
                    .stopped
                    .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            }
            Err(e) => state.retire_if_hung(&session, e),
            Ok(_) => {}
        }
        result
    })
    .await
}

/// Sets its token when dropped (see [`evaluate`]).
struct StopOnDrop(crate::CancelToken);

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        self.0.cancel();
    }
}

pub(super) fn answer(r: Result<Response, Refusal>) -> Response {
    r.unwrap_or_else(|(status, message)| refuse(status, message))
}

pub(super) fn json_response(v: &serde_json::Value) -> Response {
    (
        [
            (header::CONTENT_TYPE, "application/json"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        v.to_string(),
    )
        .into_response()
}

/// A model's parameter table as the page builds its controls from it; `source` is the file a
/// model defined at run time came from, as the command line names it.
pub(super) fn model_json(model: Model, source: Option<&str>) -> serde_json::Value {
    let finite = |x: f64| if x.is_finite() { json!(x) } else { json!(null) };
    let params: Vec<serde_json::Value> = model
        .params()
        .iter()
        .map(|s| {
            let (kind, options) = match s.kind {
                ParamKind::Rgb => ("rgb", json!(null)),
                ParamKind::Scalar => ("scalar", json!(null)),
                ParamKind::Flag => ("flag", json!(null)),
                ParamKind::Choice(o) => ("choice", json!(o)),
            };
            let default = match s.default_value() {
                Value::One(x) => json!(x),
                Value::Three(c) => json!(c),
                Value::Choice(name) => json!(name),
            };
            json!({
                "key": s.key, "kind": kind, "min": finite(s.min), "max": finite(s.max),
                "min_exclusive": s.min_exclusive, "default": default, "options": options,
                "doc": s.doc,
                "optional": model.info().optional_keys.contains(&s.key),
            })
        })
        .collect();
    json!({
        "name": model.name(),
        "description": model.description(),
        "params": params,
        "source": source,
    })
}
