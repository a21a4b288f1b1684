//! The polar plot laid out for a paper figure: the half disc as large as the canvas allows, the
//! legend in rows under it, and only the labels that fit. Every label is measured on the
//! embedded font and kept only where it overlaps no other label and covers no curve: the spoke
//! labels at the finest step of 15°, 30°, 45° or 90° whose labels stand apart, the ring labels
//! from the outermost inwards, the incidence labels inside the horizon where the curves leave
//! room. The caption is one short line; the full title and parameters are in the JSON beside the
//! picture.

use super::*;
use crate::plot::{
    draw_placed, keep_apart, svg_em, text_width, LegendRows, Placed, LABEL_GAP, ROWS_HEIGHT,
};

/// Text size of the spoke, ring and incidence labels, in canvas pixels (8.1 pt on paper).
const LABEL_TEXT: u32 = 12;

/// Text size of the caption, in canvas pixels (8.8 pt on paper).
const CAPTION_TEXT: u32 = 13;

/// The steps between labelled spokes, finest first, in degrees.
const SPOKE_STEPS: [i32; 4] = [15, 30, 45, 90];

/// The legend for a paper figure: as on the screen for one model or one θi; for several of
/// both, one row per model (solid) and one per θi in grey with its line pattern.
fn entries(
    data: &PolarData,
    subjects: &[Subject],
    styles: &[SeriesStyle],
    opts: &PolarOptions,
) -> Vec<LegendEntry> {
    if subjects.len() == 1 || opts.theta_i_deg.len() == 1 {
        return legend_entries(data, subjects, styles, opts);
    }
    let mut out: Vec<LegendEntry> = subjects
        .iter()
        .zip(styles)
        .map(|(s, st)| LegendEntry {
            label: s.label.clone(),
            colour: st.colour,
            dash: Dash::Solid,
            marker: st.marker,
        })
        .collect();
    for (k, &t) in opts.theta_i_deg.iter().enumerate() {
        out.push(LegendEntry {
            label: format!("θi = {}°", fmt_value(t)),
            colour: RGBColor(90, 90, 90),
            dash: Dash::nth(k),
            marker: Marker::None,
        });
    }
    if !data.deltas.is_empty() {
        out.push(LegendEntry {
            label: "arrow: δ spike, ρ = albedo".into(),
            colour: BLACK,
            dash: Dash::Solid,
            marker: Marker::None,
        });
    }
    out
}

/// The one-line caption: the plotted quantity, its unit and the radius mapping.
fn caption(data: &PolarData, common: &PlotSettings) -> String {
    let q = if common.cos { "f·cosθi" } else { "f" };
    let unit = match common.channel {
        super::super::Channel::Luminance => "1/sr".to_string(),
        c => format!("{}, 1/sr", c.name()),
    };
    match data.radius {
        Radius::Normalised => format!("{q} / its peak"),
        Radius::Log => format!("{q} ({unit}), log radius"),
        _ => format!("{q} ({unit})"),
    }
}

/// Draws the paper figure of `data` on `root`.
pub(super) fn draw_paper<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &PolarData,
    subjects: &[Subject],
    common: &PlotSettings,
    opts: &PolarOptions,
) -> Result<()> {
    let styles = subject_styles(subjects);
    let entries = entries(data, subjects, &styles, opts);
    let (w, h) = root.dim_in_pixel();
    let (wf, hf) = (w as f64, h as f64);
    let rows = LegendRows::new(&entries, wf - 4.0);
    let legend_h = rows.height() as f64;
    let caption = caption(data, common);
    let label_h = svg_em(LABEL_TEXT) + 2.0 * LABEL_GAP;
    let side = text_width("-90°", svg_em(LABEL_TEXT), false) + 2.0 * LABEL_GAP;
    let caption_w = text_width(&caption, svg_em(CAPTION_TEXT), false);
    // The caption shares the ring labels' row, left of the centre, when it fits in the radius;
    // else it takes a row of its own.
    let fit =
        |extra: f64| ((wf - 2.0 * side - 2.0) / 2.0).min(hf - legend_h - 2.0 * label_h - extra);
    let mut r = fit(0.0);
    let own_row = caption_w + 6.0 > r + side;
    if own_row {
        r = fit(ROWS_HEIGHT as f64);
    }
    let r = r.max(10.0);
    let below = label_h + if own_row { ROWS_HEIGHT as f64 } else { 0.0 };
    let spare = hf - legend_h - (label_h + r + below);
    let centre = (wf / 2.0, (spare / 2.0).max(0.0) + label_h + r);
    let px = |(x, y): (f64, f64)| (centre.0 + x * r, centre.1 - y * r);
    super::frame::draw_frame(ink, &px, &data.scale);
    let angle_index = |t: f64| opts.theta_i_deg.iter().position(|&a| a == t).unwrap_or(0);
    let incidence_colour = |t: f64| {
        if subjects.len() == 1 {
            (palette(angle_index(t)), Dash::Solid)
        } else {
            (RGBColor(90, 90, 90), Dash::nth(angle_index(t)))
        }
    };
    for &t in &opts.theta_i_deg {
        let (colour, dash) = incidence_colour(t);
        ink.line(&[px((0.0, 0.0)), px(at(1.0, -t))], colour, 1.0, dash, 0.6);
    }
    let curve_points = draw_curves(ink, data, &styles, &opts.theta_i_deg, &px, 60.0);
    let canvas = (0.0, 0.0, wf, hf);
    let spokes = spoke_labels(centre, r, canvas);
    let mut fixed = spokes.clone();
    let ring_y = centre.1 + label_h / 2.0;
    let rings = ring_labels(&data.scale, (centre, r), ring_y, canvas, &fixed);
    fixed.extend(rings.iter().cloned());
    let mut cap = Placed::new(caption, CAPTION_TEXT, 0.0, 0.0);
    if own_row {
        (cap.x, cap.y) = (centre.0, centre.1 + label_h + ROWS_HEIGHT as f64 / 2.0);
    } else {
        (cap.x, cap.y) = (centre.0 - 6.0 - cap.half_w, ring_y);
    }
    fixed.push(cap.clone());
    for l in spokes.iter().chain(&rings) {
        draw_placed(root, l, LABEL_TEXT, BLACK)?;
    }
    draw_placed(root, &cap, CAPTION_TEXT, BLACK)?;
    draw_deltas(
        root,
        ink,
        data,
        subjects,
        common,
        &styles,
        &mut fixed,
        (centre, r),
    )?;
    // Incidence labels inside the horizon, where they cover no curve.
    for &t in &opts.theta_i_deg {
        let text = format!("ωi {}°", fmt_value(t));
        let l = Placed::by_circle(text, LABEL_TEXT, centre, r, rad(-t), false);
        if keep_apart(vec![l.clone()], &fixed, &curve_points).is_empty() {
            continue;
        }
        ink.label(
            (l.x, l.y),
            &l.text,
            svg_em(LABEL_TEXT),
            incidence_colour(t).0,
        );
        fixed.push(l);
    }
    let legend_area = root.split_vertically((hf - legend_h).round() as i32).1;
    rows.draw(&legend_area, ink, &entries)
}

/// Spoke labels just outside the horizon (centre and radius in canvas pixels), at the finest
/// step whose labels stand apart; those outside `canvas` are left out.
fn spoke_labels(centre: (f64, f64), r: f64, canvas: (f64, f64, f64, f64)) -> Vec<Placed> {
    let spokes = SPOKE_STEPS
        .iter()
        .map(|&step| {
            (-90..=90)
                .step_by(step as usize)
                .map(|a| {
                    let text = format!("{a}°");
                    Placed::by_circle(text, LABEL_TEXT, centre, r, rad(a as f64), true)
                })
                .collect::<Vec<Placed>>()
        })
        .find(|all| keep_apart(all.clone(), &[], &[]).len() == all.len())
        .unwrap_or_default();
    spokes.into_iter().filter(|l| l.inside(canvas)).collect()
}

/// Ring labels under the diameter at height `ring_y`, from the outermost ring inwards, each
/// where it stands apart from those before and from the `fixed` labels.
fn ring_labels(
    scale: &Scale,
    (centre, r): ((f64, f64), f64),
    ring_y: f64,
    canvas: (f64, f64, f64, f64),
    fixed: &[Placed],
) -> Vec<Placed> {
    let mut ticks = scale.ticks();
    ticks.reverse();
    let rings: Vec<Placed> = ticks
        .iter()
        .filter(|&&v| scale.unit(v) > 0.0)
        .map(|&v| {
            let x = centre.0 + scale.unit(v) * r;
            Placed::new(fmt_value(v), LABEL_TEXT, x, ring_y)
        })
        .filter(|l| l.inside(canvas))
        .collect();
    keep_apart(rings, fixed, &[])
}

/// The delta lobes' arrows, and their albedo labels outside the horizon where they fit.
#[allow(clippy::too_many_arguments)]
fn draw_deltas<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ink: &mut Overlay,
    data: &PolarData,
    subjects: &[Subject],
    common: &PlotSettings,
    styles: &[SeriesStyle],
    fixed: &mut Vec<Placed>,
    (centre, r): ((f64, f64), f64),
) -> Result<()> {
    let px = |rho: f64, s_deg: f64| {
        let s = rad(s_deg);
        (centre.0 + rho * r * s.sin(), centre.1 - rho * r * s.cos())
    };
    for d in &data.deltas {
        let colour = if subjects.len() == 1 {
            let k = data
                .series
                .iter()
                .position(|s| s.theta_i_deg == d.theta_i_deg)
                .unwrap_or(0);
            palette(k)
        } else {
            styles[d.subject].colour
        };
        let tip = px(1.0, d.mirror_deg);
        ink.line(&[centre, tip], colour, 3.0, Dash::Solid, 1.0);
        let back = |da: f64| px(0.93, d.mirror_deg + da);
        ink.line(&[back(-2.5), tip, back(2.5)], colour, 3.0, Dash::Solid, 1.0);
        let text = format!("δ ρ={}", fmt_value(common.channel.of(d.albedo)));
        let l = Placed::by_circle(text, LABEL_TEXT, centre, r, rad(d.mirror_deg), true);
        let (w, h) = root.dim_in_pixel();
        if !l.inside((0.0, 0.0, w as f64, h as f64))
            || keep_apart(vec![l.clone()], fixed, &[]).is_empty()
        {
            continue;
        }
        draw_placed(root, &l, LABEL_TEXT, colour)?;
        fixed.push(l);
    }
    Ok(())
}
