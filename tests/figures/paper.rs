//! Paper figures read cleanly: on the narrow canvas of `--style paper`, for every plot kind with
//! one model and with several, no text overlaps other text or runs past the canvas, no label
//! covers a curve, and the plot itself takes most of the figure.

use super::{attr, measured, polylines};

/// Two texts may touch by this much, in canvas pixels: plotters rounds text positions to whole
/// pixels, and the boxes below are the font's full ascent and descent, more than most glyphs fill.
const OVERLAP_SLACK_PX: f64 = 1.0;

/// Text may pass the canvas edge by this much, in canvas pixels (whole-pixel positions).
const EDGE_SLACK_PX: f64 = 1.0;

/// DejaVu Sans's glyphs reach this far above the baseline (ascent of accented capitals and "°"),
/// and this far below it ("g", "y", "("), in ems.
const ASCENT_EM: f64 = 0.76;
const DESCENT_EM: f64 = 0.24;

/// resvg's ex is half an em (usvg resolves `ex` units as font-size / 2).
const EX_EM: f64 = 0.5;

/// The smallest share of a paper polar figure's canvas that its half disc (2r × r) must cover.
/// The half disc of a 300 × 170 canvas with a legend beside it can be at most ~56 % (r ≤ 97 px by
/// the height, with the horizon labels around it); the old layout covered 26 %.
const MIN_HALF_DISC_SHARE: f64 = 0.40;

/// The box a text element of an SVG covers on the canvas.
#[derive(Debug, Clone)]
struct TextBox {
    text: String,
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl TextBox {
    fn overlap(&self, o: &TextBox) -> f64 {
        let w = self.x1.min(o.x1) - self.x0.max(o.x0);
        let h = self.y1.min(o.y1) - self.y0.max(o.y0);
        w.min(h)
    }

    fn contains(&self, p: (f64, f64)) -> bool {
        (self.x0..=self.x1).contains(&p.0) && (self.y0..=self.y1).contains(&p.1)
    }
}

/// A length of `dy` in pixels for an em of `em`: `0.76em`, `0.5ex`, `-0.5ex` or a number.
fn length(dy: &str, em: f64) -> f64 {
    if let Some(v) = dy.strip_suffix("em") {
        v.parse::<f64>().unwrap() * em
    } else if let Some(v) = dy.strip_suffix("ex") {
        v.parse::<f64>().unwrap() * EX_EM * em
    } else {
        dy.parse().unwrap_or(0.0)
    }
}

/// Every text of `svg` as the box it covers: advance width measured on the embedded font,
/// ascent and descent about the baseline that `y` and `dy` place, turned for `rotate(270, …)`.
fn text_boxes(svg: &str) -> Vec<TextBox> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(k) = rest.find("<text") {
        rest = &rest[k..];
        let open_end = rest.find('>').expect("an unclosed <text> tag");
        let close = rest.find("</text>").expect("a <text> without </text>");
        let tag = &rest[..open_end];
        let text = rest[open_end + 1..close]
            .trim()
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&amp;", "&");
        rest = &rest[close..];
        let num = |name: &str| -> f64 { attr(tag, name).unwrap_or("0").parse().unwrap() };
        let (x, y, em) = (num("x"), num("y"), num("font-size"));
        let w = measured(&text, em, attr(tag, "font-weight") == Some("bold"));
        let (l, r) = match attr(tag, "text-anchor").unwrap_or("start") {
            "middle" => (-w / 2.0, w / 2.0),
            "end" => (-w, 0.0),
            _ => (0.0, w),
        };
        let base = length(attr(tag, "dy").unwrap_or("0"), em);
        let (t, b) = (base - ASCENT_EM * em, base + DESCENT_EM * em);
        let (x0, x1, y0, y1) = match attr(tag, "transform") {
            None => (x + l, x + r, y + t, y + b),
            // rotate(270, x, y) turns (dx, dy) about (x, y) into (dy, −dx).
            Some(tr) if tr.starts_with("rotate(270") => (x + t, x + b, y - r, y - l),
            // rotate(90, x, y) turns (dx, dy) into (−dy, dx).
            Some(tr) if tr.starts_with("rotate(90") => (x - b, x - t, y + l, y + r),
            Some(tr) => panic!("a text turned by {tr}"),
        };
        out.push(TextBox {
            text,
            x0,
            y0,
            x1,
            y1,
        });
    }
    out
}

/// The canvas of an SVG: its view box's width and height.
fn canvas(svg: &str) -> (f64, f64) {
    let end = svg.find('>').unwrap();
    let vb = attr(&svg[..end], "viewBox")
        .or_else(|| attr(&svg[..end], "width").map(|_| ""))
        .unwrap();
    let v: Vec<f64> = vb.split(' ').filter_map(|s| s.parse().ok()).collect();
    (v[2], v[3])
}

/// `lobe plot --style paper --backend cpu` of `kind` for `models` (comma-separated), as SVG.
fn paper_svg(kind: &str, models: &str, material: &str, extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.svg");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "plot",
            "--backend",
            "cpu",
            "--style",
            "paper",
            "--kind",
            kind,
        ])
        .args(["--model", models, "--material", material])
        .args(extra)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{kind} {models}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    std::fs::read_to_string(&out).unwrap()
}

/// The figures every rule is checked on: each kind with one model and with three.
fn figures() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for kind in ["polar", "hemisphere", "slice", "3d", "albedo"] {
        // Small grids: the layout does not depend on the resolution of the data.
        let extra: &[&str] = match kind {
            "hemisphere" | "slice" => &["--res", "24"],
            _ => &[],
        };
        for (models, material) in [
            ("cook_torrance", "glazed_ceramic"),
            ("cook_torrance,phong,microfacet", "gold"),
        ] {
            out.push((
                format!("{kind} of {models}"),
                paper_svg(kind, models, material, extra),
            ));
        }
    }
    out
}

/// Every text of every paper figure lies inside the canvas and overlaps no other text. Before,
/// the polar plot's spoke labels ran together ("-15°", "0°", "15°"), "ωi 30°" sat on "-30°",
/// the radius labels "10" and "100" collided, and the hemisphere's azimuth labels were cut at
/// the panel edges.
#[test]
fn paper_figures_have_no_text_over_text_or_past_the_canvas() {
    let mut faults = Vec::new();
    for (what, svg) in figures() {
        let (w, h) = canvas(&svg);
        let boxes = text_boxes(&svg);
        assert!(!boxes.is_empty(), "{what}: no text");
        for b in &boxes {
            if b.x0 < -EDGE_SLACK_PX
                || b.y0 < -EDGE_SLACK_PX
                || b.x1 > w + EDGE_SLACK_PX
                || b.y1 > h + EDGE_SLACK_PX
            {
                faults.push(format!(
                    "{what}: \"{}\" spans ({:.1}, {:.1})–({:.1}, {:.1}), outside the canvas {w} × {h}",
                    b.text, b.x0, b.y0, b.x1, b.y1
                ));
            }
        }
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                let o = a.overlap(b);
                if o > OVERLAP_SLACK_PX {
                    faults.push(format!(
                        "{what}: \"{}\" and \"{}\" overlap by {o:.1} px",
                        a.text, b.text
                    ));
                }
            }
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

/// No text of a paper polar figure covers a point of a plotted curve (before, "90°" sat on the
/// θi = 80° lobe of glazed ceramic where it meets the horizon).
#[test]
fn paper_polar_labels_leave_the_curves_free() {
    for (models, material) in [
        ("cook_torrance", "glazed_ceramic"),
        ("cook_torrance,phong,microfacet", "gold"),
    ] {
        let svg = paper_svg("polar", models, material, &[]);
        let boxes = text_boxes(&svg);
        // Curves are the long polylines of the data-line width (2 px on the screen, halved).
        let curves: Vec<Vec<(f64, f64)>> = polylines(&svg)
            .into_iter()
            .filter(|l| l.2 == "1" && l.3.len() > 50 && l.0 != "#000000")
            .map(|l| l.3)
            .collect();
        assert!(!curves.is_empty(), "{models}: no curve found");
        for b in &boxes {
            let hit = curves.iter().flatten().find(|p| b.contains(**p));
            assert!(
                hit.is_none(),
                "{models}: the text \"{}\" at ({:.1}, {:.1})–({:.1}, {:.1}) covers the curve point {:?}",
                b.text,
                b.x0,
                b.y0,
                b.x1,
                b.y1,
                hit
            );
        }
    }
}

/// The half disc of a paper polar figure covers at least [`MIN_HALF_DISC_SHARE`] of the canvas
/// (before, a four-line caption under it left it 26 %).
#[test]
fn a_paper_polar_figure_is_mostly_half_disc() {
    let svg = paper_svg("polar", "cook_torrance", "glazed_ceramic", &[]);
    let (w, h) = canvas(&svg);
    // The horizon is the black semicircle: its width is 2r.
    let horizon = polylines(&svg)
        .into_iter()
        .filter(|l| l.0 == "#000000" && l.3.len() > 100)
        .map(|l| l.3)
        .next()
        .expect("no horizon drawn");
    let (lo, hi) = horizon
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let r = (hi - lo) / 2.0;
    let share = 2.0 * r * r / (w * h);
    assert!(
        share >= MIN_HALF_DISC_SHARE,
        "the half disc of radius {r:.1} px covers {:.0} % of the {w} × {h} canvas, under {:.0} %",
        share * 100.0,
        MIN_HALF_DISC_SHARE * 100.0
    );
}

/// The cells of a paper slice are drawn at sub-pixel precision, one rectangle a cell, so the
/// 1050-px PNG rasterises them at its own resolution: with 24 cells across, the cells' left edges
/// are 24 evenly spaced positions. Before, the cells were whole-canvas-pixel rectangles (3 or 4
/// canvas pixels, 10.5 or 14 written pixels), merged into runs of one colour.
#[test]
fn paper_heat_map_cells_are_drawn_at_the_written_resolution() {
    // Positions are written with two decimals.
    const POSITION_ROUNDING_PX: f64 = 0.011;
    let svg = paper_svg("slice", "cook_torrance", "gold", &["--res", "24"]);
    let mut lefts: Vec<f64> = svg
        .lines()
        .filter(|l| l.starts_with("<rect") && !l.contains("opacity"))
        .filter_map(|l| attr(l, "x")?.parse().ok())
        .collect();
    lefts.sort_by(f64::total_cmp);
    lefts.dedup_by(|a, b| (*a - *b).abs() < POSITION_ROUNDING_PX);
    assert_eq!(
        lefts.len(),
        24,
        "expected the left edges of 24 columns of cells drawn at sub-pixel precision: {lefts:?}"
    );
    let steps: Vec<f64> = lefts.windows(2).map(|w| w[1] - w[0]).collect();
    let (lo, hi) = steps
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), s| (a.min(*s), b.max(*s)));
    assert!(
        hi - lo <= 2.0 * POSITION_ROUNDING_PX,
        "the columns are not evenly spaced: steps {steps:?}"
    );
}
