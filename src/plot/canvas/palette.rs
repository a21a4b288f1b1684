//! Colours, markers and line patterns: the colour map of heat maps and the styles of overlaid
//! series.

use crate::plot::Subject;
use plotters::prelude::*;

/// Matplotlib's viridis at t = 0, 1/8, …, 1 (sRGB 8-bit), interpolated linearly: perceptually
/// ordered and readable in grey and by colour-blind readers.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 145, 140),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// The colour map at t in [0, 1].
pub fn colour_map(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let k = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let u = x - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    let mix = |p: u8, q: u8| (p as f64 + u * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Line colours for overlaid series: the Okabe–Ito palette (distinguishable by colour-blind
/// readers) without its yellow, which is too light on white.
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// The k-th line colour of [`PALETTE`], starting again after seven.
pub fn palette(k: usize) -> RGBColor {
    PALETTE[k % PALETTE.len()]
}

/// A symbol repeated along a curve, so that series whose colours repeat stay apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// No symbol: the line alone.
    None,
    /// A filled disc.
    Circle,
    /// A filled square.
    Square,
    /// A filled triangle, point up.
    Triangle,
    /// A filled diamond.
    Diamond,
}

/// How one series is drawn: its colour, line pattern and the marker along it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeriesStyle {
    /// The line's colour.
    pub colour: RGBColor,
    /// The line's pattern, where a plot has no other use for it (albedo curves).
    pub dash: Dash,
    /// The symbol along the line.
    pub marker: Marker,
}

/// The k-th series style: the seven colours of [`PALETTE`] solid with no marker, then again
/// dashed with circles, dotted with squares, long-dashed with triangles and solid with
/// diamonds. Colour and pattern together tell 28 series apart without the markers, which a
/// plot that uses the pattern for something else (polar θi) still has.
pub fn series_style(k: usize) -> SeriesStyle {
    const MARKERS: [Marker; 5] = [
        Marker::None,
        Marker::Circle,
        Marker::Square,
        Marker::Triangle,
        Marker::Diamond,
    ];
    let round = k / PALETTE.len();
    SeriesStyle {
        colour: palette(k),
        dash: Dash::nth(round),
        marker: MARKERS[round % MARKERS.len()],
    }
}

/// The built-in models' places in [`series_style`]. The first seven take the seven colours;
/// the others repeat a colour with a marker, each the colour of a model of another kind (a
/// glossy lobe with a diffuse one), which are seldom compared in one plot.
const MODEL_STYLES: [(&str, usize); 10] = [
    ("lambert", 0),
    ("phong", 1),
    ("blinn_phong", 2),
    ("oren_nayar", 3),
    ("cook_torrance", 4),
    ("smooth_layered", 5),
    ("coupled", 6),
    ("microfacet", 7),
    ("eon", 8),
    ("ashikhmin_shirley", 10),
];

/// The style of each subject. When every subject is a different model, each model keeps its
/// place in `MODEL_STYLES` (a model registered at run time: the places after them), so that a
/// model has the same look in every plot; otherwise (one model in several materials) the
/// subjects take the styles in order.
pub fn subject_styles(subjects: &[Subject]) -> Vec<SeriesStyle> {
    let names: Vec<&str> = subjects.iter().map(|s| s.params.model().name()).collect();
    let distinct = names
        .iter()
        .collect::<std::collections::BTreeSet<_>>()
        .len()
        == names.len();
    if !distinct {
        return (0..subjects.len()).map(series_style).collect();
    }
    let mut next = MODEL_STYLES.iter().map(|m| m.1).max().unwrap_or(0) + 1;
    names
        .iter()
        .map(|name| match MODEL_STYLES.iter().find(|m| m.0 == *name) {
            Some(&(_, k)) => series_style(k),
            None => {
                next += 1;
                series_style(next - 1)
            }
        })
        .collect()
}

/// Line patterns for a second overlaid dimension (θi when several models are drawn).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dash {
    /// An unbroken line.
    Solid,
    /// Dashes of 10 pixels with gaps of 6.
    Dashed,
    /// Dots of 2 pixels with gaps of 4.
    Dotted,
    /// Long dashes of 22 pixels with a dot between.
    Long,
}

impl Dash {
    /// The k-th pattern, starting again after four: solid, dashed, dotted, long.
    pub fn nth(k: usize) -> Dash {
        [Dash::Solid, Dash::Dashed, Dash::Dotted, Dash::Long][k % 4]
    }

    /// The SVG `stroke-dasharray` in pixels; None for a solid line.
    pub(crate) fn dasharray(self) -> Option<&'static str> {
        match self {
            Dash::Solid => None,
            Dash::Dashed => Some("10 6"),
            Dash::Dotted => Some("2 4"),
            Dash::Long => Some("22 5 3 5"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_model_has_a_style_place() {
        for m in crate::model::Model::ALL {
            assert!(
                MODEL_STYLES.iter().any(|s| s.0 == m.name()),
                "{} has no place in MODEL_STYLES",
                m.name()
            );
        }
    }
}
