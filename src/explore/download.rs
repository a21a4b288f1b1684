//! The page's downloads that lobe's own writers make: the lobe table of one model (the `.npy` or
//! the EXR that `lobe table` writes) and the polar plot as SVG (what `lobe plot` writes). Each is
//! written into a folder of its own inside the server's temporary folder, read back and removed,
//! so a download is byte for byte the file of the command line the page shows beside it.

use super::reply::{answer, bad, check_incidence, evaluate, resolve, Refusal, Shared};
use super::State;
use crate::backend::Query;
use crate::grid::Grid;
use crate::model::ParamSet;
use crate::plot::{self, polar, Channel, PlotSettings, Request, Subject};
use axum::body::Bytes;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use std::path::Path;
use std::sync::Arc;

/// The grid of a downloaded table (`lobe table --grid full --res TABLE_RES`): every model's,
/// isotropic or not, at 3° in θ and 6° in φ: 3.24 million cells, 39 MB as `.npy`.
pub const TABLE_GRID: &str = "full";
/// See [`TABLE_GRID`].
pub const TABLE_RES: &str = "30,60,30,60";

/// Models one plot request may overlay: the page's overlay, far below a plot's own bound.
const MAX_PLOT_MODELS: usize = 16;

/// One model as the page holds it: a name, a preset and `KEY=VALUE` assignments.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelEntry {
    model: String,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    sets: Vec<String>,
}

impl ModelEntry {
    fn params(&self) -> Result<ParamSet, Refusal> {
        resolve(&self.model, self.material.as_deref(), &self.sets)
    }

    /// The label `lobe plot` gives the model named `NAME{K=V,...}` (with its preset in front),
    /// or the plain subject's where it has no assignments.
    fn subject(&self, params: ParamSet) -> Subject {
        let mut subject = Subject::new(params, self.material.as_deref());
        if !self.sets.is_empty() {
            let spec = format!("{}{{{}}}", self.model, self.sets.join(","));
            subject.label = match &self.material {
                Some(m) => format!("{m} {spec}"),
                None => spec,
            };
        }
        subject
    }
}

/// `POST /api/table`'s body: one model and the file wanted.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct TableRequest {
    model: String,
    #[serde(default)]
    material: Option<String>,
    #[serde(default)]
    sets: Vec<String>,
    #[serde(default)]
    white_furnace: bool,
    format: String,
}

/// `POST /api/table`: the table of one model on [`TABLE_GRID`], as `.npy` or EXR.
pub(super) async fn table(state: Shared, body: Bytes) -> Response {
    answer(table_file(state.0, body).await)
}

async fn table_file(state: Arc<State>, body: Bytes) -> Result<Response, Refusal> {
    let req: TableRequest =
        serde_json::from_slice(&body).map_err(|e| bad(format!("request body: {e}")))?;
    let entry = ModelEntry {
        model: req.model,
        material: req.material,
        sets: req.sets,
    };
    let params = entry.params()?;
    let (kind, content_type) = match req.format.as_str() {
        "npy" => ("npy", "application/octet-stream"),
        "exr" => ("exr", "image/x-exr"),
        other => {
            return Err(bad(format!(
                "format {other:?}: expected \"npy\" or \"exr\""
            )))
        }
    };
    let grid = Grid::parse(TABLE_GRID, TABLE_RES).map_err(|e| bad(format!("grid: {e}")))?;
    let folder = scratch(&state)?;
    let bytes = evaluate(&state, params.model(), move |session| {
        let exr = folder.path().join("table.exr");
        session.write_table(
            Query::one(&params).with_white_furnace(req.white_furnace),
            grid,
            &exr,
            false,
            &mut |_, _| {},
        )?;
        let path = match kind {
            "npy" => crate::table::sibling_paths(&exr).0,
            _ => exr,
        };
        read_back(&path)
    })
    .await?;
    Ok(file_response(content_type, &format!("table.{kind}"), bytes))
}

/// `POST /api/plot`: the polar plot of the page's models at its θi, as `lobe plot --kind polar
/// -o polar.svg` draws it.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PlotRequest {
    models: Vec<ModelEntry>,
    #[serde(default)]
    white_furnace: bool,
    theta_i_deg: f64,
    #[serde(default)]
    cos: bool,
    #[serde(default)]
    log: bool,
}

pub(super) async fn polar_svg(state: Shared, body: Bytes) -> Response {
    answer(polar_file(state.0, body).await)
}

async fn polar_file(state: Arc<State>, body: Bytes) -> Result<Response, Refusal> {
    let req: PlotRequest =
        serde_json::from_slice(&body).map_err(|e| bad(format!("request body: {e}")))?;
    if !(1..=MAX_PLOT_MODELS).contains(&req.models.len()) {
        return Err(bad(format!(
            "{} models: a plot overlays 1 to {MAX_PLOT_MODELS}",
            req.models.len()
        )));
    }
    check_incidence(req.theta_i_deg)?;
    let subjects = req
        .models
        .iter()
        .map(|m| Ok(m.subject(m.params()?)))
        .collect::<Result<Vec<_>, Refusal>>()?;
    // `lobe plot`'s defaults for a polar plot on the screen (1200 × 680, 4 decades, luminance).
    let common = PlotSettings {
        white_furnace: req.white_furnace,
        cos: req.cos,
        log: req.log,
        decades: 4.0,
        channel: Channel::Luminance,
        size: (1200, 680),
        style: plot::Style::Screen,
    };
    let request = Request::Polar(polar::PolarOptions {
        theta_i_deg: vec![req.theta_i_deg],
        samples: polar::DEFAULT_SAMPLES,
        radius: if req.log {
            polar::Radius::Auto
        } else {
            polar::Radius::Linear
        },
    });
    // One session draws them all: the shader session where any model is compiled at run time.
    let model = subjects
        .iter()
        .map(|s| s.params.model())
        .find(|m| m.chunk_timeout().is_some())
        .unwrap_or(subjects[0].params.model());
    let folder = scratch(&state)?;
    let bytes = evaluate(&state, model, move |session| {
        let svg = folder.path().join("polar.svg");
        session.plot(&subjects, &common, &request, &svg)?;
        read_back(&svg)
    })
    .await?;
    Ok(file_response("image/svg+xml", "polar.svg", bytes))
}

/// A folder of its own for one download, inside the server's temporary folder (removed with
/// it, and when the download's folder handle drops).
fn scratch(state: &State) -> Result<tempfile::TempDir, Refusal> {
    tempfile::Builder::new()
        .prefix("download-")
        .tempdir_in(state.uploads.path())
        .map_err(|e| {
            (
                StatusCode::INTERNAL_SERVER_ERROR,
                format!("a folder for the download: {e}"),
            )
        })
}

fn read_back(path: &Path) -> crate::Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| crate::Error::Io {
        what: format!("reading back {}", path.display()),
        source,
    })
}

fn file_response(content_type: &'static str, name: &str, bytes: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type.to_string()),
            (header::CACHE_CONTROL, "no-store".to_string()),
            (header::X_CONTENT_TYPE_OPTIONS, "nosniff".to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{name}\""),
            ),
        ],
        bytes,
    )
        .into_response()
}
