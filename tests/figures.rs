//! Pictures fit for print: every piece of text lies inside its canvas and is drawn whole (text
//! measured with ab_glyph on the embedded DejaVu Sans, the font resvg draws with), a polar plot
//! shows its smallest lobe, overlaid albedo curves differ in colour or line pattern, and the CSV
//! beside a picture holds the numbers it was drawn from.

use lobe::model::Model;
use lobe::plot::albedo_curve::AlbedoOptions;
use lobe::plot::polar::PolarOptions;
use lobe::plot::{self, PlotSettings, Plotted, Request, Subject};
use lobe::Evaluator;
use std::collections::BTreeSet;
use std::path::Path;

#[path = "figures/paper.rs"]
mod paper;

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

fn draw_svg(subjects: &[Subject], common: &PlotSettings, request: &Request) -> (String, Plotted) {
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
    let common = PlotSettings::default();
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
    let (svg, plotted) = draw_svg(&[s], &PlotSettings::default(), &request);
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
    let (svg, _) = draw_svg(&subjects, &PlotSettings::default(), &request);
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
        &PlotSettings::default(),
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

/// The root element's attribute `name` of an SVG.
fn root_attr(svg: &str, name: &str) -> String {
    let end = svg.find('>').expect("an SVG root element");
    attr(&svg[..end], name).unwrap_or_default().to_string()
}

/// Width and height of a PNG, from its IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let be = |k: usize| u32::from_be_bytes(bytes[k..k + 4].try_into().unwrap());
    (be(16), be(20))
}

/// A polar plot of phong in `style` on the canvas for `pixels` written pixels, to `name`.
fn polar_in_style(dir: &Path, name: &str, style: plot::Style, pixels: (u32, u32)) -> Vec<u8> {
    let common = PlotSettings {
        style,
        size: style.canvas_for(pixels),
        ..PlotSettings::default()
    };
    let request = Request::Polar(PolarOptions {
        theta_i_deg: vec![0.0, 45.0],
        samples: 90,
        ..PolarOptions::default()
    });
    let path = dir.join(name);
    let subjects = [subject("phong", Some("gold"), &[])];
    plot::plot(&Evaluator::cpu(), &subjects, &common, &request, &path)
        .unwrap_or_else(|e| panic!("{name}: {e:#}"));
    std::fs::read(&path).unwrap()
}

/// The paper style writes a single-column figure: 3.5 in at 300 dpi (1050 px, an SVG of 252 pt),
/// no title, text of 8–9.5 pt (the 12 px of tick labels at 8.1 pt), lines half the screen's
/// weight; the screen style writes the canvas as it is.
#[test]
fn the_paper_style_sets_a_single_column_figure() {
    // A font size is written rounded to 3 decimals of a canvas pixel.
    const PT_ROUNDING: f64 = 0.05;
    let dir = tempfile::tempdir().unwrap();
    let paper = plot::Style::Paper;
    let pixels = (1050, 700);
    assert_eq!(paper.canvas_for(pixels), (300, 200));
    assert_eq!(
        png_size(&polar_in_style(dir.path(), "p.png", paper, pixels)),
        pixels
    );
    assert_eq!(
        png_size(&polar_in_style(
            dir.path(),
            "s.png",
            plot::Style::Screen,
            (1200, 680)
        )),
        (1200, 680)
    );
    let svg = String::from_utf8(polar_in_style(dir.path(), "p.svg", paper, pixels)).unwrap();
    assert_eq!(root_attr(&svg, "width"), "252pt");
    assert_eq!(root_attr(&svg, "height"), "168pt");
    assert_eq!(root_attr(&svg, "viewBox"), "0 0 300 200");
    // A canvas pixel is zoom × 72/300 pt on the page.
    let pt_per_canvas_px = paper.zoom() * 72.0 / plot::PAPER_DPI;
    let texts = svg_texts(&svg);
    assert!(
        texts.iter().all(|t| !t.bold),
        "a paper figure has no title: {texts:?}"
    );
    let sizes: Vec<f64> = texts.iter().map(|t| t.em * pt_per_canvas_px).collect();
    assert!(sizes.len() > 8, "{sizes:?}");
    for pt in &sizes {
        assert!(
            (8.0..=9.5 + PT_ROUNDING).contains(pt),
            "a text of {pt:.2} pt: {sizes:?}"
        );
    }
    let tick_pt = plot::svg_em(12) * pt_per_canvas_px;
    assert!(
        (tick_pt - 8.13).abs() < PT_ROUNDING,
        "tick labels {tick_pt} pt"
    );
    assert!(
        sizes.iter().any(|pt| (pt - tick_pt).abs() < PT_ROUNDING),
        "no tick label: {sizes:?}"
    );
    let screen = String::from_utf8(polar_in_style(
        dir.path(),
        "s.svg",
        plot::Style::Screen,
        (1200, 680),
    ))
    .unwrap();
    assert_eq!(root_attr(&screen, "width"), "1200");
    // Every line of the paper figure is half as heavy as the same line on the screen.
    let widths = |svg: &str| -> Vec<f64> {
        polylines(svg)
            .iter()
            .filter_map(|p| p.2.parse().ok())
            .collect()
    };
    let (on_paper, on_screen) = (widths(&svg), widths(&screen));
    assert!(!on_paper.is_empty());
    let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
    assert_eq!(max(&on_paper), max(&on_screen) * plot::PAPER_STROKE);
}

/// A PDF picture: one page of the printed size (3.5 in = 252 pt wide for the paper style), its
/// text kept as text in DejaVu Sans embedded in the file (a TrueType font program, subset).
#[test]
fn a_pdf_plot_is_one_page_with_the_font_embedded() {
    let dir = tempfile::tempdir().unwrap();
    let pdf = polar_in_style(dir.path(), "p.pdf", plot::Style::Paper, (1050, 700));
    assert!(pdf.starts_with(b"%PDF-"), "not a PDF");
    let text = String::from_utf8_lossy(&pdf);
    assert!(text.trim_end().ends_with("%%EOF"), "an unfinished PDF");
    assert!(text.contains("/Count 1"), "one page");
    assert!(
        text.contains("/MediaBox [0 0 252 168]"),
        "page size: {}",
        text.lines()
            .find(|l| l.contains("MediaBox"))
            .unwrap_or("no MediaBox")
    );
    let base_font = text
        .split("/BaseFont /")
        .nth(1)
        .and_then(|r| r.split(|c: char| c.is_whitespace() || c == '/').next())
        .expect("a font");
    assert!(base_font.contains("DejaVuSans"), "font {base_font}");
    assert!(
        text.contains("/FontFile2"),
        "the font program is not embedded"
    );
}

/// The rows of a CSV text below its header, split at commas (the labels hold no commas here).
fn csv_rows(text: &str, header: &str) -> Vec<Vec<String>> {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(header));
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// `lobe compare -o` and `lobe fit -o` (one function, `plot::difference::write_plots`) write a CSV beside
/// each picture: the polar curves by their drawn labels and the difference cells, every value
/// the picture was drawn from.
#[test]
fn compare_pictures_have_their_numbers_beside_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = subject("phong", None, &["shininess=50"]);
    a.label = "A: phong".into();
    let mut b = subject("blinn_phong", None, &[]);
    b.label = "B: blinn_phong".into();
    let opts = lobe::plot::difference::PlotOptions {
        theta_i_deg: vec![0.0, 45.0],
        res: 24,
        ..lobe::plot::difference::PlotOptions::default()
    };
    let prefix = dir.path().join("cmp");
    let plots = lobe::plot::difference::write_plots(
        &Evaluator::cpu(),
        &a,
        &b,
        &opts,
        &prefix,
        plot::Format::Svg,
    )
    .unwrap();
    let polar = std::fs::read_to_string(dir.path().join("cmp_polar.csv")).unwrap();
    let rows = csv_rows(&polar, "label,theta_i_deg,theta_o_deg,value,r,g,b");
    let expected: Vec<(String, f64, f64, f64)> = plots
        .polar
        .series
        .iter()
        .flat_map(|s| {
            let label = [&a, &b][s.subject].label.clone();
            s.theta_o_deg
                .iter()
                .zip(&s.value)
                .map(move |(t, v)| (label.clone(), s.theta_i_deg, *t, *v))
        })
        .collect();
    let got: Vec<(String, f64, f64, f64)> = rows
        .iter()
        .map(|r| {
            (
                r[0].clone(),
                r[1].parse().unwrap(),
                r[2].parse().unwrap(),
                r[3].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        got.len(),
        2 * 2 * plot::polar::DEFAULT_SAMPLES,
        "A and B at two θi"
    );
    assert_eq!(got, expected);
    let labels: BTreeSet<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(labels, BTreeSet::from(["A: phong", "B: blinn_phong"]));

    let difference = std::fs::read_to_string(dir.path().join("cmp_difference.csv")).unwrap();
    let rows = csv_rows(&difference, "label,theta_deg,phi_deg,row,col,value");
    let d = &plots.difference;
    let expected: Vec<(f64, usize, usize, f64)> = d
        .panels
        .iter()
        .flat_map(|p| {
            p.values
                .iter()
                .enumerate()
                .filter(|(_, v)| !v.is_nan())
                .map(move |(k, v)| (p.theta_deg, k / d.res, k % d.res, *v))
        })
        .collect();
    assert!(expected.len() > 2 * 24 * 24 / 2, "two discs of cells");
    let label = plot::difference::difference_label();
    // The label holds commas: quoted.
    let quoted = format!("\"{label}\"");
    assert!(difference.contains(&quoted), "{label} not in the CSV");
    let got: Vec<(f64, usize, usize, f64)> = csv_rows(
        &difference.replace(&quoted, "D"),
        "label,theta_deg,phi_deg,row,col,value",
    )
    .iter()
    .map(|r| {
        assert_eq!(r[0], "D");
        (
            r[1].parse().unwrap(),
            r[3].parse().unwrap(),
            r[4].parse().unwrap(),
            r[5].parse().unwrap(),
        )
    })
    .collect();
    assert_eq!(rows.len(), got.len());
    assert_eq!(got, expected);
}

/// The tick labels of a picture's colour bar: the numeric texts right of every panel (the bar
/// is the rightmost 110 px), with their heights.
fn colour_bar_ticks(svg: &str, width: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(k) = rest.find("<text") {
        rest = &rest[k..];
        let open_end = rest.find('>').unwrap();
        let close = rest.find("</text>").unwrap();
        let tag = &rest[..open_end];
        let x: f64 = attr(tag, "x").unwrap_or("0").parse().unwrap();
        let y: f64 = attr(tag, "y").unwrap_or("0").parse().unwrap();
        let text = rest[open_end + 1..close].trim();
        if let (true, None, Ok(v)) = (
            x > width - 110.0,
            attr(tag, "transform"),
            text.parse::<f64>(),
        ) {
            out.push((v, y));
        }
        rest = &rest[close..];
    }
    out
}

/// `lobe plot --kind hemisphere` of a `.brdf` file (GGX at α = 0.05, whose values over the
/// hemisphere span decades): its colour bar carries at least four ticks, logarithmic: the tick heights are a
/// straight line in log10 of the values, and they are not in the values themselves.
#[test]
fn a_brdf_file_hemisphere_has_a_logarithmic_colour_bar_with_four_ticks() {
    // Tick heights are whole pixels: a straight line fits them to within one pixel.
    const PIXEL: f64 = 1.0;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ggx.svg");
    let brdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/brdf/ggx.brdf");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "plot",
            "--kind",
            "hemisphere",
            "--res",
            "48",
            "--theta-i-deg",
            "30",
            "--set",
            "alpha=0.05",
            "--model",
        ])
        .arg(&brdf)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let svg = std::fs::read_to_string(&out).unwrap();
    let width: f64 = root_attr(&svg, "width").parse().unwrap();
    let ticks = colour_bar_ticks(&svg, width);
    assert!(ticks.len() >= 4, "colour bar ticks {ticks:?}");
    let csv = std::fs::read_to_string(dir.path().join("ggx.csv")).unwrap();
    let values: Vec<f64> = csv
        .lines()
        .skip(1)
        .filter_map(|l| l.rsplit(',').next()?.parse().ok())
        .filter(|v: &f64| *v > 0.0)
        .collect();
    let (lo, hi) = values
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), v| (l.min(*v), h.max(*v)));
    assert!(hi / lo > 100.0, "the map spans {lo} to {hi}, not decades");
    // Straight in log10(v), not in v: residuals of a line through the end ticks.
    let residual = |f: &dyn Fn(f64) -> f64| -> f64 {
        let (a, b) = (ticks[0], ticks[ticks.len() - 1]);
        ticks
            .iter()
            .map(|&(v, y)| {
                let t = (f(v) - f(a.0)) / (f(b.0) - f(a.0));
                (a.1 + t * (b.1 - a.1) - y).abs()
            })
            .fold(0.0, f64::max)
    };
    assert!(
        residual(&|v: f64| v.log10()) <= PIXEL,
        "ticks {ticks:?} are not logarithmic"
    );
    assert!(
        residual(&|v: f64| v) > 10.0 * PIXEL,
        "ticks {ticks:?} look linear"
    );
}
