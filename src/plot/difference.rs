//! Two models against each other: A and B overlaid in the plane of incidence ([`super::polar`]),
//! and the relative difference of B from A over the hemisphere of ωo for fixed ωi, in the
//! hemisphere map's projection ([`super::hemisphere`]).
//!
//! The map's value at a direction is the signed relative difference of the plotted channel,
//! (B − A) / max(|A|, |B|, [`RELATIVE_FLOOR`]): the same floored ratio that `lobe compare`
//! reports bin by bin ([`crate::loss::relative`]), with its sign kept so that the picture says
//! which model is brighter where. It lies in [−1, 1]; the colour scale is symmetric about 0.
//!
//! [`write_plots`] writes both pictures as one transaction; `lobe compare -o` and `lobe fit`
//! (target against fit) call it.

use super::hemisphere::{self, draw_panel, HemisphereData, HemisphereOptions};
use super::polar::{self, PolarData, PolarOptions};
use super::{colour_bar, header_in, Format, PlotSettings, Subject};
use crate::eval::Evaluator;
use crate::loss::RELATIVE_FLOOR;
use crate::output::FileSet;
use anyhow::{Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The signed relative difference (b − a) / max(|a|, |b|, [`RELATIVE_FLOOR`]) (module docs).
pub fn signed_relative(a: f64, b: f64) -> f64 {
    (b - a) / a.abs().max(b.abs()).max(RELATIVE_FLOOR)
}

/// Smallest half-range of the difference map's colour scale: two equal models still get a
/// scale (a grey-free map at 0) rather than a division by a zero range.
const MIN_HALF_RANGE: f64 = 1e-9;

/// The difference maps of `b` against `a`: one panel per fixed direction of `opts`, each cell
/// the signed relative difference of the plotted channel (module docs), NaN outside the disc;
/// the scale runs from −m to m with m the largest |difference| over all panels.
pub fn difference_data(
    eval: &Evaluator,
    a: &Subject,
    b: &Subject,
    common: &PlotSettings,
    opts: &HemisphereOptions,
) -> Result<HemisphereData> {
    let both = [a.clone(), b.clone()];
    let maps = hemisphere::hemisphere_data(eval, &both, common, opts)?;
    let n = opts.theta_deg.len();
    let (pa, pb) = maps.panels.split_at(n);
    let mut panels = Vec::with_capacity(n);
    let mut largest = 0.0f64;
    for (p, q) in pa.iter().zip(pb) {
        let values: Vec<f64> = p
            .values
            .iter()
            .zip(&q.values)
            .map(|(&x, &y)| {
                if x.is_finite() && y.is_finite() {
                    signed_relative(x, y)
                } else {
                    f64::NAN
                }
            })
            .collect();
        let mut best: Option<usize> = None;
        for (k, v) in values.iter().enumerate() {
            if v.is_finite() && best.is_none_or(|j| v.abs() > values[j].abs()) {
                best = Some(k);
            }
        }
        if let Some(k) = best {
            largest = largest.max(values[k].abs());
        }
        let peak_deg = match best {
            Some(k) => {
                let (x, y) = hemisphere::cell_point(opts.res, k / opts.res, k % opts.res);
                hemisphere::cell_direction(opts.projection, x, y)
                    .map_or((f64::NAN, f64::NAN), hemisphere::angles_deg)
            }
            None => (f64::NAN, f64::NAN),
        };
        panels.push(hemisphere::HemispherePanel {
            subject: 0,
            values,
            peak_deg,
            ..p.clone()
        });
    }
    let m = largest.max(MIN_HALF_RANGE);
    Ok(HemisphereData {
        title: format!(
            "relative difference (B − A) over every ωo for fixed ωi: {} against {}",
            b.label, a.label
        ),
        panels,
        scale: super::Scale {
            lo: -m,
            hi: m,
            log: false,
        },
        ..maps
    })
}

/// The picture of a [`difference_data`] result as the bytes of a `format` file.
pub fn difference_picture(
    data: &HemisphereData,
    a: &Subject,
    b: &Subject,
    common: &PlotSettings,
    opts: &HemisphereOptions,
    format: Format,
) -> Result<Vec<u8>> {
    super::render_bytes(format, common.page(), |root, ink| {
        draw(root, ink, data, a, b, common, opts)
    })
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut super::Overlay,
    data: &HemisphereData,
    a: &Subject,
    b: &Subject,
    common: &PlotSettings,
    opts: &HemisphereOptions,
) -> Result<()> {
    let mut lines = vec![a.describe(), b.describe()];
    let mut note = format!(
        "colour: (B − A) / max(|A|, |B|, {}) of {}; 0 where they agree, > 0 where B is brighter; \
         seen from above, +x right; × mirror direction, ○ ωi",
        super::fmt_value(RELATIVE_FLOOR),
        common.quantity()
    );
    if !common.switches().is_empty() {
        note = format!("{note}; {}", common.switches());
    }
    lines.push(note);
    let body = header_in(common.style, root, &data.title, &lines)?;
    let (w, _) = body.dim_in_pixel();
    let (maps, bar) = body.split_horizontally(w - 110);
    let areas = maps.split_evenly((1, opts.theta_deg.len()));
    let only = std::slice::from_ref(a);
    for (panel, area) in data.panels.iter().zip(areas.iter()) {
        draw_panel(area, ink, panel, data, only, opts, common.style)?;
    }
    colour_bar(&bar, &data.scale, "relative difference (B − A)")?;
    Ok(())
}

/// What [`write_plots`] draws: the fixed directions, the channel, the switches and the sizes.
#[derive(Clone, Debug)]
pub struct PlotOptions {
    /// θi of the polar curves and of the difference panels, in degrees, each in [0, 90).
    pub theta_i_deg: Vec<f64>,
    /// The plotted channel, switches and the polar picture's size.
    pub common: PlotSettings,
    /// Cells across each difference panel.
    pub res: usize,
    /// The difference picture's size in pixels.
    pub difference_size: (u32, u32),
}

impl Default for PlotOptions {
    fn default() -> PlotOptions {
        PlotOptions {
            theta_i_deg: vec![0.0, 30.0, 60.0],
            common: PlotSettings {
                size: (1200, 680),
                ..PlotSettings::default()
            },
            res: 128,
            difference_size: (1200, 560),
        }
    }
}

/// The two files of [`write_plots`] and what they show.
#[derive(Clone, Debug)]
pub struct Plots {
    /// `PREFIX_polar.EXT`: A and B in the plane of incidence.
    pub polar_path: PathBuf,
    /// `PREFIX_difference.EXT`: the relative difference over the hemisphere.
    pub difference_path: PathBuf,
    /// The curves drawn.
    pub polar: PolarData,
    /// The difference maps drawn.
    pub difference: HemisphereData,
}

/// The files [`write_plots`] writes for `prefix`: `PREFIX_polar.EXT` and
/// `PREFIX_difference.EXT`.
pub fn plot_paths(prefix: &Path, format: Format) -> (PathBuf, PathBuf) {
    let ext = match format {
        Format::Png => "png",
        Format::Svg => "svg",
        Format::Pdf => "pdf",
    };
    let name = prefix
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let with = |what: &str| prefix.with_file_name(format!("{name}_{what}.{ext}"));
    (with("polar"), with("difference"))
}

/// `subject` with every `{…}` of its label left out: `A: microfacet{alpha=0.2}` → `A: microfacet`.
fn short_label(subject: &Subject) -> Subject {
    let mut label = String::new();
    let mut depth = 0usize;
    for c in subject.label.chars() {
        match c {
            '{' => depth += 1,
            '}' => depth = depth.saturating_sub(1),
            _ if depth == 0 => label.push(c),
            _ => {}
        }
    }
    Subject {
        label,
        params: subject.params.clone(),
    }
}

/// The label of the difference maps' cells in their CSV: `(B - A)/max(|A|, |B|, 1e-4)`.
pub fn difference_label() -> String {
    format!(
        "(B - A)/max(|A|, |B|, {})",
        super::fmt_value(RELATIVE_FLOOR)
    )
}

/// Draws A and B overlaid (their labels say which is which: `lobe compare` uses `A: SPEC`) in
/// the plane of incidence and the relative difference of B from A over the hemisphere (module
/// docs), and writes them as `PREFIX_polar.EXT` and `PREFIX_difference.EXT` (see
/// [`plot_paths`]), each with the full parameters of A and B in a `.json` beside it
/// ([`super::params_json`]) and the plotted numbers in a `.csv` beside it
/// ([`super::csv::data_csv`]: the polar curves by their drawn labels; the difference cells
/// labelled [`difference_label`]), in one transaction: all six files or none.
pub fn write_plots(
    eval: &Evaluator,
    a: &Subject,
    b: &Subject,
    opts: &PlotOptions,
    prefix: &Path,
    format: Format,
) -> Result<Plots> {
    let (polar_path, difference_path) = plot_paths(prefix, format);
    let (polar_json, difference_json) = (
        super::params_json_path(&polar_path),
        super::params_json_path(&difference_path),
    );
    let (polar_csv, difference_csv) = (
        super::csv::data_csv_path(&polar_path),
        super::csv::data_csv_path(&difference_path),
    );
    let set = FileSet::new(&[
        polar_path.as_path(),
        polar_json.as_path(),
        polar_csv.as_path(),
        difference_path.as_path(),
        difference_json.as_path(),
        difference_csv.as_path(),
    ])?;
    let both = [a.clone(), b.clone()];
    let polar_opts = PolarOptions {
        theta_i_deg: opts.theta_i_deg.clone(),
        samples: polar::DEFAULT_SAMPLES,
        radius: polar::Radius::Auto,
    };
    // Drawn with short labels (`A: microfacet`): the header names each side's parameters and
    // the JSON keeps the full labels, so a model spec in the legend and title adds only length.
    let drawn = [short_label(a), short_label(b)];
    let polar = polar::polar_data(eval, &drawn, &opts.common, &polar_opts)?;
    let polar_bytes = polar::polar_picture(&polar, &drawn, &opts.common, &polar_opts, format)?;
    let hemi_opts = HemisphereOptions {
        theta_deg: opts.theta_i_deg.clone(),
        res: opts.res,
        ..HemisphereOptions::default()
    };
    let common = PlotSettings {
        size: opts.difference_size,
        log: false,
        ..opts.common.clone()
    };
    let [da, db] = &drawn;
    let difference = difference_data(eval, da, db, &common, &hemi_opts)?;
    let difference_bytes = difference_picture(&difference, da, db, &common, &hemi_opts, format)?;
    let json = |title: &str| -> Result<Vec<u8>> {
        Ok((serde_json::to_string_pretty(&super::params_json(&both, title))? + "\n").into_bytes())
    };
    let polar_table = super::csv::data_csv(&drawn, &super::Plotted::Polar(polar.clone()));
    let difference_label = Subject {
        label: difference_label(),
        params: a.params.clone(),
    };
    let difference_table = super::csv::data_csv(
        std::slice::from_ref(&difference_label),
        &super::Plotted::Hemisphere(difference.clone()),
    );
    let contents = [
        polar_bytes,
        json(&polar.title)?,
        polar_table.into_bytes(),
        difference_bytes,
        json(&difference.title)?,
        difference_table.into_bytes(),
    ];
    for (k, bytes) in contents.iter().enumerate() {
        let mut w = set[k].writer();
        w.write_all(bytes)
            .with_context(|| format!("writing {}", set[k].dest().display()))?;
        w.finish()?;
    }
    set.commit()?;
    Ok(Plots {
        polar_path,
        difference_path,
        polar,
        difference,
    })
}
