//! The [`Overlay`] layer: SVG elements with sub-pixel coordinates drawn over plotters' picture.

use super::*;
use plotters::prelude::*;

/// `#rrggbb` of a colour.
fn hex(c: RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}

/// A coordinate with two decimals: sub-pixel positions, and the same text for the same input.
fn coord(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// SVG elements drawn over plotters' picture in canvas pixels with sub-pixel precision: the
/// curves, markers and masks whose shape matters (plotters rounds every coordinate to a whole
/// pixel). PNG and SVG share them: the PNG is the SVG rasterised.
#[derive(Debug, Default)]
pub struct Overlay {
    pub(super) svg: String,
}

impl Overlay {
    /// A polyline through `points` (canvas pixels); non-finite points break it into pieces.
    pub fn line(
        &mut self,
        points: &[(f64, f64)],
        colour: RGBColor,
        width: f64,
        dash: Dash,
        opacity: f64,
    ) {
        for run in points.split(|p| !(p.0.is_finite() && p.1.is_finite())) {
            if run.len() < 2 {
                continue;
            }
            let mut pts = String::new();
            let mut last: Option<(f64, f64)> = None;
            for (k, &p) in run.iter().enumerate() {
                // Points closer than a tenth of a pixel to the last one add nothing visible.
                if let Some(q) = last {
                    if k + 1 < run.len() && (p.0 - q.0).abs() < 0.1 && (p.1 - q.1).abs() < 0.1 {
                        continue;
                    }
                }
                if !pts.is_empty() {
                    pts.push(' ');
                }
                pts.push_str(&format!("{},{}", coord(p.0), coord(p.1)));
                last = Some(p);
            }
            let dash = dash
                .dasharray()
                .map(|d| format!(" stroke-dasharray=\"{d}\""))
                .unwrap_or_default();
            let opacity = if opacity < 1.0 {
                format!(" stroke-opacity=\"{}\"", coord(opacity))
            } else {
                String::new()
            };
            self.svg.push_str(&format!(
                "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" stroke-linejoin=\"round\" stroke-linecap=\"round\"{dash}{opacity} points=\"{pts}\"/>\n",
                hex(colour),
                coord(width)
            ));
        }
    }

    /// One marker centred on `p`, `r` pixels in radius, filled with `colour` and ringed in white.
    pub fn marker(&mut self, p: (f64, f64), marker: Marker, colour: RGBColor, r: f64) {
        let (x, y) = p;
        let style = format!(
            "fill=\"{}\" stroke=\"white\" stroke-width=\"1\"",
            hex(colour)
        );
        let shape = match marker {
            Marker::None => return,
            Marker::Circle => format!(
                "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" {style}/>",
                coord(x),
                coord(y),
                coord(r)
            ),
            Marker::Square => {
                let a = r * 0.9;
                format!(
                    "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" {style}/>",
                    coord(x - a),
                    coord(y - a),
                    coord(2.0 * a),
                    coord(2.0 * a)
                )
            }
            Marker::Triangle => {
                let a = r * 1.2;
                self.polygon(
                    &[(x, y - a), (x + a, y + 0.8 * a), (x - a, y + 0.8 * a)],
                    &style,
                );
                return;
            }
            Marker::Diamond => {
                let a = r * 1.25;
                self.polygon(&[(x, y - a), (x + a, y), (x, y + a), (x - a, y)], &style);
                return;
            }
        };
        self.svg.push_str(&shape);
        self.svg.push('\n');
    }

    fn polygon(&mut self, pts: &[(f64, f64)], style: &str) {
        let pts: Vec<String> = pts
            .iter()
            .map(|p| format!("{},{}", coord(p.0), coord(p.1)))
            .collect();
        self.svg.push_str(&format!(
            "<polygon points=\"{}\" {style}/>\n",
            pts.join(" ")
        ));
    }

    /// Markers along `points` (canvas pixels), one every `spacing` pixels of arc length,
    /// starting half a spacing in (with an offset `phase` in [0, 1) of a spacing, so that
    /// overlaid curves do not put their markers at the same places).
    pub fn markers_along(
        &mut self,
        points: &[(f64, f64)],
        marker: Marker,
        colour: RGBColor,
        spacing: f64,
        phase: f64,
    ) {
        if marker == Marker::None {
            return;
        }
        let mut next = spacing * (0.5 + phase);
        let mut s = 0.0;
        for w in points.windows(2) {
            let (a, b) = (w[0], w[1]);
            if !(a.0.is_finite() && a.1.is_finite() && b.0.is_finite() && b.1.is_finite()) {
                continue;
            }
            let len = (b.0 - a.0).hypot(b.1 - a.1);
            while next <= s + len {
                let u = (next - s) / len;
                self.marker(
                    (a.0 + u * (b.0 - a.0), a.1 + u * (b.1 - a.1)),
                    marker,
                    colour,
                    4.0,
                );
                next += spacing;
            }
            s += len;
        }
    }

    /// A label centred on `p` (canvas pixels), `size` pixels high, in `colour` with a white
    /// halo so that it reads on any background.
    pub fn label(&mut self, p: (f64, f64), text: &str, size: f64, colour: RGBColor) {
        let text = text
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;");
        self.svg.push_str(&format!(
            "<text x=\"{}\" y=\"{}\" dy=\"0.35em\" text-anchor=\"middle\" font-family=\"{FONT}\" font-size=\"{}\" fill=\"{}\" stroke=\"white\" stroke-width=\"3\" stroke-linejoin=\"round\" paint-order=\"stroke\">{text}</text>\n",
            coord(p.0),
            coord(p.1),
            coord(size),
            hex(colour)
        ));
    }

    /// A rectangle (x0, y0)–(x1, y1) in canvas pixels filled with `colour`, unstroked: a heat
    /// map's cell at sub-pixel precision, so that it is rasterised at the written resolution.
    pub fn rect(&mut self, (x0, y0, x1, y1): (f64, f64, f64, f64), colour: RGBColor) {
        self.svg.push_str(&format!(
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\"/>\n",
            coord(x0.min(x1)),
            coord(y0.min(y1)),
            coord((x1 - x0).abs()),
            coord((y1 - y0).abs()),
            hex(colour)
        ));
    }

    /// A white mask over everything outside the circle of radius `r` about `c` within the
    /// rectangle (x0, y0)–(x1, y1): an anti-aliased round edge for a heat map drawn in square
    /// cells.
    pub fn mask_outside_circle(&mut self, rect: (f64, f64, f64, f64), c: (f64, f64), r: f64) {
        let (x0, y0, x1, y1) = rect;
        self.svg.push_str(&format!(
            "<path fill=\"white\" fill-rule=\"evenodd\" d=\"M{},{}H{}V{}H{}Z M{},{}a{r},{r} 0 1,0 {d},0a{r},{r} 0 1,0 -{d},0Z\"/>\n",
            coord(x0),
            coord(y0),
            coord(x1),
            coord(y1),
            coord(x0),
            coord(c.0 - r),
            coord(c.1),
            r = coord(r),
            d = coord(2.0 * r)
        ));
    }
}
