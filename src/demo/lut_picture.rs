//! The demo's picture of its albedo LUT (the LUT's own files come from [`crate::lut::write`]).

use anyhow::Result;
use std::path::Path;

/// The LUT as a picture: E(μ, α) as a heat map (μ across, α up, each cell drawn at its true
/// extent on the α axis, which is not uniform) with a colour bar from 0 to 1.
pub(super) fn draw_lut(
    spec: &crate::lut::LutSpec,
    lut: &crate::lut::LutSummary,
    path: &Path,
) -> Result<(u32, u32)> {
    use crate::plot::{colour_bar, colour_map, header, Drawn, Scale, FONT};
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
            spec.params.to_text(),
            spec.lo,
            spec.hi,
            spec.mapping.formula()
        ),
        "1 − E is the energy single scattering loses (Kulla–Conty compensate it); dark = low E"
            .to_string(),
    ];
    let draw = |root: &DrawingArea<SVGBackend, plotters::coord::Shift>,
                _ink: &mut crate::plot::Ink|
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
                        colour_map(e).filled(),
                    )
                })
            }))
            .drawing("the LUT")?;
        colour_bar(
            &bar_area,
            &Scale {
                lo: 0.0,
                hi: 1.0,
                log: false,
            },
            "E (white furnace)",
        )
    };
    crate::plot::render(path, size, draw)?;
    Ok(size)
}
