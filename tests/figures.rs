//! Pictures fit for print: every piece of text lies inside its canvas and is drawn whole (text
//! measured with ab_glyph on the embedded DejaVu Sans, the font resvg draws with), a polar plot
//! shows its smallest lobe, overlaid albedo curves differ in colour or line pattern, and the CSV
//! beside a picture holds the numbers it was drawn from.

use lobe::model::Model;
use lobe::plot::albedo::AlbedoOptions;
use lobe::plot::polar::PolarOptions;
use lobe::plot::{self, Common, Plotted, Request, Subject};
use lobe::Evaluator;
use std::collections::BTreeSet;
use std::path::Path;

/// Text may pass the canvas edge by this much: plotters rounds text positions to whole pixels
/// and resvg's anti-aliasing spreads a glyph's edge over one more.
const TEXT_SLACK_PX: f64 = 1.5;

/// The smallest lobe of a polar plot must reach this far from the origin to be read: about the
/// height of a tick label (12 px).
const MIN_LOBE_PX: f64 = 12.0;

/// A text element of an SVG: position, anchor, em size, weight, content and whether rotated.
#[derive(Debug)]
struct SvgText {
    x: f64,
    anchor: String,
    em: f64,
    bold: bool,
    rotated: bool,
    text: String,
}

/// The value of attribute `name` in the tag text `tag`.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let end = tag[start..].find('"')? + start;
    Some(&tag[start..end])
}

fn svg_texts(svg: &str) -> Vec<SvgText> {
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
        out.push(SvgText {
            x: attr(tag, "x").unwrap_or("0").parse().unwrap(),
            anchor: attr(tag, "text-anchor").unwrap_or("start").to_string(),
            em: attr(tag, "font-size").unwrap_or("16").parse().unwrap(),
            bold: attr(tag, "font-weight") == Some("bold"),
            rotated: attr(tag, "transform").is_some(),
            text,
        });
        rest = &rest[close..];
    }
    out
}

/// Width in pixels of `text` in DejaVu Sans at `em` pixels, with kerning: the advances ab_glyph
/// reads from the font's tables, as resvg lays the text out.
fn measured(text: &str, em: f64, bold: bool) -> f64 {
    use ab_glyph::{Font, FontRef};
    let bytes = if bold {
        dejavu::sans::bold()
    } else {
        dejavu::sans::regular()
    };
    let face = FontRef::try_from_slice(bytes).unwrap();
    let units = face.units_per_em().unwrap() as f64;
    let ids: Vec<_> = text.chars().map(|c| face.glyph_id(c)).collect();
    let advance: f64 = ids.iter().map(|&g| face.h_advance_unscaled(g) as f64).sum();
    let kern: f64 = ids
        .windows(2)
        .map(|w| face.kern_unscaled(w[0], w[1]) as f64)
        .sum();
    (advance + kern) * em / units
}

/// Every unrotated text of `svg` lies within [0, width] and none is shortened with "…".
fn assert_text_inside(svg: &str, width: f64, what: &str) {
    let texts = svg_texts(svg);
    assert!(!texts.is_empty(), "{what}: no text found");
    for t in texts.iter().filter(|t| !t.rotated) {
        assert!(
            !t.text.contains('…'),
            "{what}: the text \"{}\" was shortened",
            t.text
        );
        let w = measured(&t.text, t.em, t.bold);
        let (left, right) = match t.anchor.as_str() {
            "middle" => (t.x - w / 2.0, t.x + w / 2.0),
            "end" => (t.x - w, t.x),
            _ => (t.x, t.x + w),
        };
        assert!(
            left >= -TEXT_SLACK_PX && right <= width + TEXT_SLACK_PX,
            "{what}: \"{}\" ({:.1} px wide at {:.1} px) spans x = {left:.1} to {right:.1}, outside the canvas 0 to {width}",
            t.text,
            w,
            t.em
        );
    }
}

/// Polylines of `svg` as (stroke, dasharray, stroke-width, points).
fn polylines(svg: &str) -> Vec<(String, String, String, Vec<(f64, f64)>)> {
    svg.lines()
        .filter(|l| l.starts_with("<polyline"))
        .map(|l| {
            let pts = attr(l, "points")
                .unwrap_or("")
                .split(' ')
                .filter_map(|p| {
                    let (x, y) = p.split_once(',')?;
                    Some((x.parse().ok()?, y.parse().ok()?))
                })
                .collect();
            (
                attr(l, "stroke").unwrap_or("").to_string(),
                attr(l, "stroke-dasharray").unwrap_or("solid").to_string(),
                attr(l, "stroke-width").unwrap_or("").to_string(),
                pts,
            )
        })
        .collect()
}

fn subject(model: &str, material: Option<&str>, sets: &[&str]) -> Subject {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let params = lobe::resolve_params(model, material, &sets)
        .unwrap_or_else(|e| panic!("{model} {material:?}: {e}"));
    Subject::new(params, material)
}

fn draw_svg(subjects: &[Subject], common: &Common, request: &Request) -> (String, Plotted) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plot.svg");
    let plotted = plot::plot(&Evaluator::cpu(), subjects, common, request, &path)
        .unwrap_or_else(|e| panic!("plotting: {e:#}"));
    (std::fs::read_to_string(&path).unwrap(), plotted)
}

/// A legend label wider than the legend's column is wrapped onto more lines, whole; a title
/// holding a word wider than the canvas is broken inside it rather than drawn past the edge.
#[test]
fn legend_labels_and_titles_stay_whole_and_inside_the_canvas() {
    let mut a = subject("cook_torrance", Some("gold"), &[]);
    a.label =
        "A: gold cook_torrance with specular=0.5,diffuse=0.3,roughness=0.2,ior=1.5 as measured"
            .into();
    let mut b = subject("microfacet", Some("gold"), &[]);
    b.label = format!("B: {}", "microfacet_with_a_very_long_name_".repeat(6));
    let common = Common::default();
    let request = Request::Polar(PolarOptions {
        theta_i_deg: vec![30.0, 60.0],
        samples: 64,
        ..PolarOptions::default()
    });
    let (svg, _) = draw_svg(&[a.clone(), b], &common, &request);
    assert_text_inside(&svg, common.size.0 as f64, "polar overlay");
    // The end of A's label is drawn (before, the legend cut it and wrote "…").
    let texts: String = svg_texts(&svg)
        .iter()
        .map(|t| t.text.clone() + " ")
        .collect();
    assert!(
        texts.contains("as measured"),
        "the end of the label \"{}\" is not drawn",
        a.label
    );
}

/// On a linear radius the θi = 0° lobe of glazed ceramic (peak ≈ 2/sr, beside the 80° lobe's
/// ≈ 540/sr) reached about 2 px from the origin; the radius turns logarithmic by itself.
#[test]
fn a_polar_plot_shows_its_smallest_lobe() {
    let s = subject("cook_torrance", Some("glazed_ceramic"), &[]);
    let request = Request::Polar(PolarOptions {
        theta_i_deg: vec![0.0, 30.0, 60.0, 80.0],
        samples: 720,
        ..PolarOptions::default()
    });
    let (svg, plotted) = draw_svg(&[s], &Common::default(), &request);
    let Plotted::Polar(data) = plotted else {
        panic!("not a polar plot")
    };
    let lines = polylines(&svg);
    // The spokes are grey two-point lines from the origin.
    let origin = lines
        .iter()
        .find(|l| l.0 == "#c8c8c8" && l.3.len() == 2)
        .map(|l| l.3[0])
        .expect("no spoke drawn");
    let curves: Vec<&Vec<(f64, f64)>> = lines
        .iter()
        .filter(|l| l.2 == "2" && l.3.len() > 20)
        .map(|l| &l.3)
        .collect();
    assert_eq!(curves.len(), 4, "expected one curve per θi");
    for (curve, series) in curves.iter().zip(&data.series) {
        let reach = curve
            .iter()
            .map(|p| (p.0 - origin.0).hypot(p.1 - origin.1))
            .fold(0.0, f64::max);
        assert!(
            reach >= MIN_LOBE_PX,
            "θi = {}°: the lobe reaches {reach:.1} px from the origin, under {MIN_LOBE_PX} px (radius: {})",
            series.theta_i_deg,
            data.radius_note
        );
    }
    assert!(
        data.radius_note.contains("log"),
        "the plot does not say its radius is logarithmic: {}",
        data.radius_note
    );
}

/// Ten models in one albedo plot: seven colours repeat, so the line pattern tells the repeated
/// colours apart (before, every curve was solid and three colours were shared).
#[test]
fn ten_albedo_curves_differ_in_colour_or_pattern() {
    let subjects: Vec<Subject> = Model::ALL
        .iter()
        .map(|m| subject(m.name(), Some("gold"), &[]))
        .collect();
    let request = Request::Albedo(AlbedoOptions {
        n_mu: 8,
        ..AlbedoOptions::default()
    });
    let (svg, _) = draw_svg(&subjects, &Common::default(), &request);
    let curves: Vec<(String, String)> = polylines(&svg)
        .into_iter()
        .filter(|l| l.2 == "2" && l.3.len() >= 8)
        .map(|l| (l.0, l.1))
        .collect();
    assert_eq!(curves.len(), subjects.len(), "one curve per model");
    let distinct: BTreeSet<&(String, String)> = curves.iter().collect();
    assert_eq!(
        distinct.len(),
        curves.len(),
        "colour and pattern repeat among the curves: {curves:?}"
    );
}

/// The CSV beside a plot parses back to exactly the values the picture was drawn from.
#[test]
fn the_csv_beside_a_plot_holds_the_plotted_values() {
    let s = subject("phong", None, &["shininess=50"]);
    let request = Request::Polar(PolarOptions {
        theta_i_deg: vec![0.0, 45.0],
        samples: 64,
        ..PolarOptions::default()
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lobe.svg");
    let subjects = [s];
    let plotted = plot::plot(
        &Evaluator::cpu(),
        &subjects,
        &Common::default(),
        &request,
        &path,
    )
    .unwrap();
    plot::csv::write_data_csv(&path, &subjects, &plotted).unwrap();
    let csv_path = plot::csv::data_csv_path(&path);
    assert_eq!(csv_path, Path::new(&dir.path().join("lobe.csv")));
    let text = std::fs::read_to_string(&csv_path).unwrap();
    let Plotted::Polar(data) = plotted else {
        panic!("not a polar plot")
    };
    let mut rows = text.lines();
    assert_eq!(
        rows.next(),
        Some("label,theta_i_deg,theta_o_deg,value,r,g,b")
    );
    let expected: Vec<(f64, f64, f64, [f64; 3])> = data
        .series
        .iter()
        .flat_map(|s| {
            s.theta_o_deg
                .iter()
                .zip(&s.value)
                .zip(&s.rgb)
                .map(move |((a, v), c)| (s.theta_i_deg, *a, *v, *c))
        })
        .collect();
    let got: Vec<(f64, f64, f64, [f64; 3])> = rows
        .map(|r| {
            let f: Vec<&str> = r.split(',').collect();
            assert_eq!(f[0], "phong", "{r}");
            let n = |k: usize| f[k].parse::<f64>().unwrap();
            (n(1), n(2), n(3), [n(4), n(5), n(6)])
        })
        .collect();
    assert_eq!(got.len(), 2 * 64);
    assert_eq!(got, expected);
}
