//! `lobe light --report` (docs/design.md §15.4): the split sum's error against the exact sum over
//! a sweep of the model's roughness, one row per value: the RMS, the largest relative error and
//! where it falls, and the mean relative error in bands of n·v (grazing, middle, normal), written
//! as `P_report.csv`, a plot `P_report.png` and `P_report.svg`, and `P.json`, all or none.

use super::split::{error_figures, lobe_of, split_sum, ErrorFigures};
use super::{check_image_size, exact, LightImage};
use crate::axis::Mapping;
use crate::backend::light::{sphere_pixels, EnvMap};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::lut::default_axis;
use crate::model::{ParamSet, Value};
use crate::output::{sibling, FileSet};
use crate::plot::{header_in, render_bytes, Format, Overlay, Style, FONT};
use anyhow::{Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::json;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Roughness values a report sweeps by default.
pub const DEFAULT_STEPS: usize = 9;

/// The fewest and most values a report sweeps.
pub const STEPS_RANGE: (usize, usize) = (2, 64);

/// The bands of n·v the mean relative error is given in: [lo, hi) each, the last closed.
pub const BANDS: [(&str, f64, f64); 3] = [
    ("grazing", 0.0, 0.3),
    ("middle", 0.3, 0.7),
    ("normal", 0.7, 1.0),
];

/// A lobe narrower than this many texel heights (π/H) is resolved poorly by either sum
/// (docs/design.md §15.2): such rows are flagged `lobe_resolved = 0`.
pub const RESOLVED_TEXELS: f64 = 3.0;

/// The columns of `P_report.csv`, in order (docs/commands.md describes each).
pub const CSV_COLUMNS: [&str; 13] = [
    "parameter",
    "value",
    "alpha",
    "rms",
    "max_relative",
    "max_relative_row",
    "max_relative_column",
    "max_relative_n_dot_v",
    "mean_relative",
    "mean_relative_grazing",
    "mean_relative_middle",
    "mean_relative_normal",
    "lobe_resolved",
];

/// Refuses a number of sweep values outside [`STEPS_RANGE`].
pub fn check_steps(steps: usize) -> Result<(), BadInput> {
    let (lo, hi) = STEPS_RANGE;
    if !(lo..=hi).contains(&steps) {
        return Err(BadInput::new(
            "report-steps",
            format!("{steps} report steps: a report sweeps {lo} to {hi} roughness values"),
        ));
    }
    Ok(())
}

/// The roughness axis a report sweeps: the model's main parameter (its LUT axis), for models
/// whose split sum has a microfacet lobe.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughnessAxis {
    /// The parameter's key (`alpha`, `roughness`).
    pub key: String,
    /// Its lower end.
    pub lo: f64,
    /// Its upper end.
    pub hi: f64,
    /// How the sweep's values are spaced between the ends.
    pub mapping: Mapping,
}

impl RoughnessAxis {
    /// The model's axis, or a refusal naming the model and the models that have one.
    pub fn of(params: &ParamSet, white_furnace: bool) -> Result<RoughnessAxis, BadInput> {
        let name = params.model().name();
        let none = || {
            BadInput::new(
                "report",
                format!(
                    "model {name}: --report sweeps the roughness of a microfacet lobe the split sum prefilters, and this model has none; the models with one are microfacet (alpha) and cook_torrance (roughness)"
                ),
            )
        };
        let lobe = lobe_of(params, white_furnace).map_err(|_| none())?;
        if lobe.specular.is_none() {
            return Err(none());
        }
        let (keys, lo, hi, mapping) = default_axis(params.model());
        Ok(RoughnessAxis {
            key: keys[0].to_string(),
            lo,
            hi,
            mapping,
        })
    }

    /// `steps` values, cell-centred in the mapping (t = (k + ½)/steps), as a LUT's rows.
    pub fn values(&self, steps: usize) -> Vec<f64> {
        (0..steps)
            .map(|k| {
                let t = (k as f64 + 0.5) / steps as f64;
                self.mapping.apply(self.lo, self.hi, t)
            })
            .collect()
    }
}

/// One value of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportRow {
    /// The parameter's value.
    pub value: f64,
    /// The split sum's lobe α at that value (√(αx αy)).
    pub alpha: f64,
    /// RMS and the largest relative error with its pixel ([`error_figures`]).
    pub figures: ErrorFigures,
    /// The mean of |split − exact| / exact over the sphere's pixels and channels where exact > 0.
    pub mean_relative: f64,
    /// The same mean within each of [`BANDS`]; None for a band with no such pixel.
    pub band_mean_relative: [Option<f64>; 3],
    /// Whether α spans at least [`RESOLVED_TEXELS`] texel heights of the map.
    pub lobe_resolved: bool,
}

/// The whole sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The swept axis.
    pub axis: RoughnessAxis,
    /// One row per value, in increasing order.
    pub rows: Vec<ReportRow>,
}

/// The mean relative error over the sphere and in each band of n·v.
pub fn relative_means(exact: &LightImage, split: &LightImage) -> (f64, [Option<f64>; 3]) {
    let size = exact.size;
    let (mut all, mut n_all) = (0.0, 0usize);
    let mut bands = [(0.0, 0usize); 3];
    for p in sphere_pixels(size, 0..size) {
        let (e, s) = (exact.at(p.row, p.col), split.at(p.row, p.col));
        let mu = p.n.z;
        let band = BANDS
            .iter()
            .position(|&(_, lo, hi)| mu >= lo && (mu < hi || hi == 1.0));
        for c in 0..3 {
            if e[c] > 0.0 {
                let r = (s[c] - e[c]).abs() / e[c];
                all += r;
                n_all += 1;
                if let Some(b) = band {
                    bands[b].0 += r;
                    bands[b].1 += 1;
                }
            }
        }
    }
    let mean = |(s, n): (f64, usize)| (n > 0).then(|| s / n as f64);
    (mean((all, n_all)).unwrap_or(0.0), bands.map(mean))
}

/// The sweep of `params`'s roughness ([`RoughnessAxis`]) under `map`: per value the exact sum and
/// the split sum of a `size`² sphere and the split sum's error figures; `progress` gets (rows
/// done, rows) over every value's two passes. Ctrl-C stops it between bands of rows.
pub fn report(
    eval: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    map: &EnvMap,
    size: u32,
    steps: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Report> {
    check_image_size(size)?;
    check_steps(steps)?;
    let axis = RoughnessAxis::of(params, white_furnace)?;
    eval.supports(params.model())?;
    let rows_per_value = 2 * size as u64;
    let total = steps as u64 * rows_per_value;
    let texel = std::f64::consts::PI / map.height() as f64;
    let mut rows = Vec::new();
    progress(0, total);
    for (k, value) in axis.values(steps).into_iter().enumerate() {
        let mut p = params.clone();
        p.set(&axis.key, Value::One(value))
            .with_context(|| format!("the report's {} = {value}", axis.key))?;
        let base = k as u64 * rows_per_value;
        let e = exact(eval, &p, white_furnace, map, size, &mut |d, _| {
            progress(base + d, total)
        })?;
        let s = split_sum(eval, &p, white_furnace, map, size, &mut |d, _| {
            progress(base + size as u64 + d, total)
        })?;
        let alpha = lobe_of(&p, white_furnace)?
            .specular
            .map(|l| l.alpha)
            .unwrap_or(0.0);
        let (mean_relative, band_mean_relative) = relative_means(&e, &s);
        rows.push(ReportRow {
            value,
            alpha,
            figures: error_figures(&e, &s),
            mean_relative,
            band_mean_relative,
            lobe_resolved: alpha >= RESOLVED_TEXELS * texel,
        });
    }
    Ok(Report { axis, rows })
}

/// The report's files beside `exr_path`: `P_report.csv`, `P_report.png`, `P_report.svg`, then
/// `P.json`. Refuses a path that does not end in `.exr`.
pub fn paths(exr_path: &Path) -> Result<Vec<PathBuf>> {
    super::files::paths(exr_path, super::Method::Exact, false)?;
    Ok(vec![
        sibling(exr_path, "_report", "csv"),
        sibling(exr_path, "_report", "png"),
        sibling(exr_path, "_report", "svg"),
        sibling(exr_path, "", "json"),
    ])
}

fn num(v: f64) -> String {
    format!("{v}")
}

/// The report as CSV text: a header row of [`CSV_COLUMNS`], then one row per value; a band with
/// no pixel is left empty.
pub fn csv_text(report: &Report) -> String {
    let mut out = CSV_COLUMNS.join(",");
    out.push('\n');
    for r in &report.rows {
        let band = |b: Option<f64>| b.map(num).unwrap_or_default();
        // Writing to a String cannot fail.
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            report.axis.key,
            num(r.value),
            num(r.alpha),
            num(r.figures.rms),
            num(r.figures.max_relative),
            r.figures.at.0,
            r.figures.at.1,
            num(r.figures.mu),
            num(r.mean_relative),
            band(r.band_mean_relative[0]),
            band(r.band_mean_relative[1]),
            band(r.band_mean_relative[2]),
            u8::from(r.lobe_resolved),
        );
    }
    out
}

/// What [`write_report`] made.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportSummary {
    /// The files ([`paths`]), the JSON last.
    pub paths: Vec<PathBuf>,
    /// The backend, as the evaluator names it.
    pub backend: String,
    /// Seconds the sweep took (writing not included).
    pub seconds: f64,
    /// The sweep.
    pub report: Report,
}

/// The sweep ([`report`]) written beside `exr_path` as CSV, PNG and SVG plots and the JSON; the
/// destinations are checked before any work and the files replace what was there together or
/// not at all. `env` names the map in the files.
#[allow(clippy::too_many_arguments)]
pub fn write_report(
    eval: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    map: &EnvMap,
    env: &str,
    size: u32,
    steps: usize,
    exr_path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<ReportSummary> {
    check_image_size(size)?;
    check_steps(steps)?;
    RoughnessAxis::of(params, white_furnace)?;
    let paths = paths(exr_path)?;
    let refs: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
    let set = FileSet::new(&refs)?;
    let started = std::time::Instant::now();
    let report = report(eval, params, white_furnace, map, size, steps, progress)?;
    let seconds = started.elapsed().as_secs_f64();
    let backend = eval.name();
    let model = params.model().name();
    let title = format!(
        "Split sum − exact sum under {env}: {model} over {}",
        report.axis.key
    );
    let lines = vec![
        format!(
            "{size}² sphere seen from +z, map {} × {} texels, {} values of {} ({} spacing), {backend}",
            map.width(),
            map.height(),
            steps,
            report.axis.key,
            report.axis.mapping.name()
        ),
        "relative error |split − exact| / exact over the sphere's pixels and R, G, B (logarithmic); grey band: lobe narrower than 3 texels (either sum resolves it poorly)".to_string(),
    ];
    let png = picture(&report, &title, &lines, Format::Png)?;
    let svg = picture(&report, &title, &lines, Format::Svg)?;
    let band = |b: Option<f64>| b.map(|v| json!(v)).unwrap_or(json!(null));
    let rows: Vec<_> = report
        .rows
        .iter()
        .map(|r| {
            json!({
                "value": r.value,
                "alpha": r.alpha,
                "rms": r.figures.rms,
                "max_relative": r.figures.max_relative,
                "max_relative_pixel": { "row": r.figures.at.0, "column": r.figures.at.1, "n_dot_v": r.figures.mu },
                "mean_relative": r.mean_relative,
                "mean_relative_by_n_dot_v": {
                    "grazing": band(r.band_mean_relative[0]),
                    "middle": band(r.band_mean_relative[1]),
                    "normal": band(r.band_mean_relative[2]),
                },
                "lobe_resolved": r.lobe_resolved,
            })
        })
        .collect();
    let worst = report
        .rows
        .iter()
        .max_by(|a, b| a.figures.max_relative.total_cmp(&b.figures.max_relative));
    let settings = json!({
        "kind": "light_report",
        "model": model,
        "parameters": params.to_json(),
        "white_furnace": white_furnace,
        "env": env,
        "map": { "width": map.width(), "height": map.height() },
        "size": size,
        "sweep": {
            "parameter": report.axis.key,
            "lo": report.axis.lo,
            "hi": report.axis.hi,
            "mapping": report.axis.mapping.name(),
            "steps": steps,
            "values": "cell-centred: t = (k + 1/2) / steps mapped onto [lo, hi]",
        },
        "bands": BANDS.iter().map(|(name, lo, hi)| json!({ "name": name, "n_dot_v": [lo, hi] })).collect::<Vec<_>>(),
        "definition": "split sum - exact sum over the pixels inside the sphere and R, G, B; relative errors where exact > 0",
        "lobe_resolved": format!("alpha >= {RESOLVED_TEXELS} texel heights (pi / map height)"),
        "rows": rows,
        "largest_relative": worst.map(|r| json!({
            "value": r.value,
            "max_relative": r.figures.max_relative,
            "n_dot_v": r.figures.mu,
        })),
        "files": {
            "csv": crate::output::file_name(&paths[0]),
            "png": crate::output::file_name(&paths[1]),
            "svg": crate::output::file_name(&paths[2]),
        },
        "csv_columns": CSV_COLUMNS,
        "backend": backend,
        "seconds": seconds,
    });
    let json_text = serde_json::to_string_pretty(&settings)? + "\n";
    let contents = [
        csv_text(&report).into_bytes(),
        png,
        svg,
        json_text.into_bytes(),
    ];
    for (k, bytes) in contents.iter().enumerate() {
        let mut w = set[k].writer();
        w.write_all(bytes)
            .with_context(|| format!("writing {}", set[k].dest().display()))?;
        w.finish()?;
    }
    set.commit()?;
    Ok(ReportSummary {
        paths,
        backend,
        seconds,
        report,
    })
}

/// The plot's canvas, pixels.
const CANVAS: (u32, u32) = (1000, 640);

/// The report's plot: relative error against the parameter, one line per figure.
/// Decades the report's logarithmic error axis spans at most below its largest value.
const REPORT_DECADES: i32 = 8;

fn picture(report: &Report, title: &str, lines: &[String], format: Format) -> Result<Vec<u8>> {
    render_bytes(format, CANVAS, |root, ink| {
        draw(root, ink, report, title, lines)
    })
}

/// A line of the plot: its legend, colour and the figure it draws of each row.
type Series = (
    &'static str,
    RGBColor,
    Box<dyn Fn(&ReportRow) -> Option<f64>>,
);

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    _ink: &mut Overlay,
    report: &Report,
    title: &str,
    lines: &[String],
) -> Result<()> {
    use crate::plot::Drawn as _;
    let body = header_in(Style::Screen, root, title, lines)?;
    let rows = &report.rows;
    let series: [Series; 5] = [
        (
            "largest relative error",
            RGBColor(0, 0, 0),
            Box::new(|r| Some(r.figures.max_relative)),
        ),
        (
            "mean relative error",
            RGBColor(110, 110, 110),
            Box::new(|r| Some(r.mean_relative)),
        ),
        (
            "mean, n·v < 0.3 (grazing)",
            RGBColor(200, 40, 40),
            Box::new(|r| r.band_mean_relative[0]),
        ),
        (
            "mean, 0.3 ≤ n·v < 0.7",
            RGBColor(220, 140, 0),
            Box::new(|r| r.band_mean_relative[1]),
        ),
        (
            "mean, n·v ≥ 0.7 (normal)",
            RGBColor(30, 90, 200),
            Box::new(|r| r.band_mean_relative[2]),
        ),
    ];
    // A logarithmic error axis: the errors of the sharpest lobes are often decades above the
    // rest. It spans the smallest positive value to the largest, at most REPORT_DECADES.
    let values: Vec<f64> = rows
        .iter()
        .flat_map(|r| series.iter().filter_map(move |s| (s.2)(r)))
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let top = values.iter().copied().fold(0.0f64, f64::max);
    let (y_lo, y_hi) = if top > 0.0 {
        let floor = top * 10f64.powi(-REPORT_DECADES);
        let least = values.iter().copied().fold(top, f64::min).max(floor);
        (least / 1.5, top * 1.5)
    } else {
        (1e-6, 1.0)
    };
    let (x_lo, x_hi) = (report.axis.lo, report.axis.hi);
    let mut chart = ChartBuilder::on(&body)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(x_lo..x_hi, (y_lo..y_hi).log_scale())
        .drawing("the report's chart")?;
    chart
        .configure_mesh()
        .x_desc(report.axis.key.as_str())
        .y_desc("relative error")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()
        .drawing("the report's axes")?;
    // The values whose lobe is narrower than the map resolves, shaded.
    if let Some(last) = rows.iter().rev().find(|r| !r.lobe_resolved) {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(x_lo, y_lo), (last.value, y_hi)],
                RGBColor(225, 225, 225).filled(),
            )))
            .drawing("the unresolved band")?;
    }
    for (name, colour, of) in &series {
        let points: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| of(r).map(|v| (r.value, v)))
            .filter(|p| p.1.is_finite())
            // A value below the axis (0, or decades below the largest) sits on its floor.
            .map(|(x, v)| (x, v.max(y_lo)))
            .collect();
        let colour = *colour;
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .drawing("a report line")?
            .label(*name)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2)));
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .drawing("the report's points")?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .drawing("the report's legend")?;
    Ok(())
}
