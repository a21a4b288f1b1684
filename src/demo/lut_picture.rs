//! The demo's picture of its albedo LUT (the LUT's own files come from [`crate::lut::write`]).

use anyhow::Result;
use std::path::Path;

/// The LUT as a picture: E(μ, α) as a heat map (μ across, α up, each cell drawn at its true
/// extent on the α axis, which is not uniform) with a colour bar and labelled contour lines.
pub(super) fn draw_lut(
    spec: &crate::lut::LutSpec,
    lut: &crate::lut::LutSummary,
    path: &Path,
) -> Result<(u32, u32)> {
    use crate::plot::{
        colour_bar, colour_map, contour_segments, fmt_value, header, pixel_map, Dash, Drawn, Scale,
        FONT,
    };
    use plotters::prelude::*;
    let size = (900u32, 760u32);
    let (n_mu, n_p) = (spec.n_mu, spec.n_p);
    // Cell edges on the α axis: the mapping at t = k/Np.
    let edges: Vec<f64> = (0..=n_p)
        .map(|k| spec.mapping.apply(spec.lo, spec.hi, k as f64 / n_p as f64))
        .collect();
    let title = format!(
        "Albedo LUT E(μ, α): GGX microfacet, white furnace ({} × {} cells)",
        n_mu, n_p
    );
    let lines = vec![
        format!(
            "{} with α from {} to {} ({})",
            active_params(spec),
            spec.lo,
            spec.hi,
            spec.mapping.formula()
        ),
        "1 − E is the energy single scattering loses (Kulla–Conty compensate it); white lines: \
         contours of E"
            .to_string(),
    ];
    // The colour scale starts at the tenth below the smallest E, so that the colours spread
    // over what the table holds.
    let min = lut.e.iter().map(|e| e.x).fold(1.0, f64::min);
    let scale = Scale {
        lo: ((min * 10.0).floor() / 10.0).clamp(0.0, 0.9),
        hi: 1.0,
        log: false,
    };
    let draw = |root: &DrawingArea<SVGBackend, plotters::coord::Shift>,
                ink: &mut crate::plot::Overlay|
     -> Result<()> {
        let body = header(root, &title, &lines)?;
        let (w, _) = body.dim_in_pixel();
        let (chart_area, bar_area) = body.split_horizontally(w - 110);
        let mut chart = ChartBuilder::on(&chart_area)
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..1.0f64, spec.lo..spec.hi)
            .drawing("the LUT's axes")?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("μ = cos θo")
            .y_desc(format!("α ({})", spec.keys.join(", ")))
            .axis_desc_style((FONT, 16))
            .label_style((FONT, 13))
            .draw()
            .drawing("the LUT's axes")?;
        chart
            .draw_series((0..n_p).flat_map(|k| {
                let edges = &edges;
                (0..n_mu).map(move |j| {
                    let e = lut.e[k * n_mu + j].x;
                    Rectangle::new(
                        [
                            (j as f64 / n_mu as f64, edges[k]),
                            ((j + 1) as f64 / n_mu as f64, edges[k + 1]),
                        ],
                        colour_map(scale.unit(e)).filled(),
                    )
                })
            }))
            .drawing("the LUT")?;
        // Contours through the cell centres, each labelled once, near its middle.
        let px = pixel_map(chart.plotting_area());
        let xs: Vec<f64> = (0..n_mu).map(|j| (j as f64 + 0.5) / n_mu as f64).collect();
        let ys: Vec<f64> = (0..n_p).map(|k| 0.5 * (edges[k] + edges[k + 1])).collect();
        let values: Vec<f64> = lut.e.iter().map(|e| e.x).collect();
        for level in CONTOURS {
            let segments = contour_segments(&values, &xs, &ys, level);
            for (a, b) in &segments {
                ink.line(&[px(*a), px(*b)], WHITE, 1.5, Dash::Solid, 0.9);
            }
            let mut mids: Vec<(f64, f64)> = segments
                .iter()
                .map(|(a, b)| (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1)))
                .collect();
            mids.sort_by(|p, q| p.0.total_cmp(&q.0));
            if let Some(&m) = mids.get(mids.len() * 2 / 3) {
                ink.label(px(m), &fmt_value(level), 12.0, BLACK);
            }
        }
        colour_bar(&bar_area, &scale, "E (white furnace)")
    };
    crate::plot::render(path, size, draw)?;
    Ok(size)
}

/// The E values the LUT picture draws contour lines at.
const CONTOURS: [f64; 6] = [0.5, 0.6, 0.7, 0.8, 0.9, 0.95];

/// The LUT's fixed parameters that its components use, without the swept axis.
fn active_params(spec: &crate::lut::LutSpec) -> String {
    spec.params
        .active_entries()
        .iter()
        .filter(|(k, _)| !spec.keys.iter().any(|a| a == k))
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}
