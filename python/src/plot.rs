//! Pictures, as `lobe plot` draws them: the package wraps the file in an object that shows
//! itself in Jupyter.

use crate::errors::{from_anyhow, invalid};
use crate::{job, model, settings, PySession};
use lobe::plot::{albedo_curve, hemisphere, polar};
use lobe::plot::{Channel, PlotSettings, Request, Subject};
use pyo3::prelude::*;

/// Draws `kind` ("polar", "hemisphere" or "albedo") of `models` into `path`; returns the title.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (session, kind, models, material, sets, theta_i_deg, log, cos, white_furnace, channel, method, path))]
pub fn plot(
    py: Python<'_>,
    session: &Bound<'_, PySession>,
    kind: &str,
    models: Vec<String>,
    material: Option<&str>,
    sets: Vec<String>,
    theta_i_deg: Option<Vec<f64>>,
    log: bool,
    cos: bool,
    white_furnace: bool,
    channel: &str,
    method: &str,
    path: std::path::PathBuf,
) -> PyResult<String> {
    let subjects: Vec<Subject> = models
        .iter()
        .map(|m| {
            let mut subject = Subject::new(model::resolve(m, material, &sets)?, material);
            if m.contains('{') {
                subject.label = m.clone();
            }
            Ok(subject)
        })
        .collect::<PyResult<_>>()?;
    let angles = theta_i_deg.unwrap_or_else(|| vec![0.0, 30.0, 60.0, 80.0]);
    let request = match kind {
        "polar" => Request::Polar(polar::PolarOptions {
            theta_i_deg: angles,
            ..Default::default()
        }),
        "hemisphere" => Request::Hemisphere(hemisphere::HemisphereOptions {
            theta_deg: angles,
            ..Default::default()
        }),
        "albedo" => Request::Albedo(albedo_curve::AlbedoOptions {
            method: settings(method, None, lobe::integrate::DEFAULT_SEED, false)?.method,
            ..Default::default()
        }),
        other => {
            return Err(invalid(
                "kind",
                format!("'{other}' is not a plot; give polar, hemisphere or albedo"),
            ))
        }
    };
    // The canvas `lobe plot` gives each kind on a screen (src/cli/plot.rs): 1200 px wide;
    // hemisphere panels in rows under a 150 px title, 30 px a caption.
    let size = match kind {
        "polar" => (1200, 680),
        "hemisphere" => {
            let cols = match &request {
                Request::Hemisphere(o) => o.theta_deg.len(),
                _ => 1,
            };
            let maps = 1200u32.saturating_sub(hemisphere::COLOUR_BAR_WIDTH);
            let per_row = hemisphere::panel_columns(maps, cols);
            let rows = subjects.len() * cols.div_ceil(per_row);
            let side = (maps / per_row as u32).clamp(20, 520);
            (1200, (150 + rows as u32 * (side + 30)).clamp(150, 8000))
        }
        _ => (1200, 800),
    };
    let common = PlotSettings {
        size,
        white_furnace,
        cos,
        // The hemisphere's colours are logarithmic unless asked otherwise, as on the command line.
        log: log || kind == "hemisphere",
        channel: Channel::from_name(channel).map_err(|e| from_anyhow("channel", e))?,
        ..PlotSettings::default()
    };
    common.check().map_err(|e| from_anyhow("plot", e))?;
    let s = &session.get().inner;
    // The job `lobe plot` runs (`Session::plot`), called one level down so that its errors are
    // sorted as this package has always sorted a picture's: refusals are `ValueError`s.
    let plotted = job::run(py, s, || {
        lobe::plot::plot(&s.evaluator(), &subjects, &common, &request, &path)
            .map_err(crate::errors::from_job)
    })?;
    Ok(plotted.title().to_string())
}

/// The SVG text `svg` as a PNG of `width` × `height` pixels, rasterised as lobe's own pictures
/// are (resvg, with the embedded DejaVu Sans): for pictures drawn in Python (`lobe.batch`'s
/// heat map).
#[pyfunction]
pub fn rasterise_svg<'py>(
    py: Python<'py>,
    svg: &str,
    width: u32,
    height: u32,
) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
    let png = lobe::plot::rasterise(svg, (width, height)).map_err(|e| from_anyhow("svg", e))?;
    Ok(pyo3::types::PyBytes::new(py, &png))
}
