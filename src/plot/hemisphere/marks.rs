//! What a panel draws over its heat map besides the rings: the azimuth labels, the mirror
//! direction (×) and the fixed direction (○).

use super::*;
use plotters::coord::cartesian::Cartesian2d;
use plotters::coord::types::RangedCoordf64;

/// The azimuth labels at 0°, 90°, 180° and 270°, counterclockwise from the right. On paper they
/// stand just outside the horizon circle (centre `c`, right edge `edge` in canvas pixels) and
/// are drawn only where they fit in `area`; on a screen at 1.08 chart units.
pub(super) fn draw_azimuth_labels<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    pa: &DrawingArea<DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    paper: bool,
    (c, edge): ((f64, f64), (f64, f64)),
) -> Result<()> {
    let (w, h) = area.dim_in_pixel();
    for k in 0..4 {
        let phi = 90.0 * k as f64;
        if paper {
            let (ox, oy) = area.get_base_pixel();
            let bounds = (
                ox as f64,
                oy as f64,
                (ox + w as i32) as f64,
                (oy + h as i32) as f64,
            );
            let label = format!("{}°", k * 90);
            // Clockwise from up: φ = 90° is up, φ = 0 to the right.
            let angle = rad(90.0 - phi);
            let l = Placed::by_circle(label, 12, c, edge.0 - c.0, angle, true);
            if l.inside(bounds) {
                draw_placed(area, &l, 12, BLACK)?;
            }
            continue;
        }
        let (x, y) = (1.08 * rad(phi).cos(), 1.08 * rad(phi).sin());
        pa.draw(&Text::new(
            format!("{}°", k * 90),
            (x, y),
            text_style(12, BLACK).pos(Pos::new(HPos::Center, VPos::Center)),
        ))
        .drawing("an azimuth label")?;
    }
    Ok(())
}

/// The mirror direction as a red × and the fixed direction as a ring, both outlined in white;
/// `c` and `edge` are the horizon circle's centre and right edge in canvas pixels.
pub(super) fn draw_directions(
    ink: &mut Overlay,
    px: &dyn Fn((f64, f64)) -> (f64, f64),
    panel: &HemispherePanel,
    opts: &HemisphereOptions,
    (c, edge): ((f64, f64), (f64, f64)),
) {
    let marker = |theta: f64, phi: f64| px(opts.projection.point(rad(theta), rad(phi)));
    let (mx, my) = marker(panel.mirror_deg.0, panel.mirror_deg.1);
    let d = 0.05 * (edge.0 - c.0);
    for (a, b) in [
        ((mx - d, my - d), (mx + d, my + d)),
        ((mx - d, my + d), (mx + d, my - d)),
    ] {
        ink.line(&[a, b], WHITE, 4.0, Dash::Solid, 1.0);
        ink.line(&[a, b], RED, 2.0, Dash::Solid, 1.0);
    }
    let (fx, fy) = marker(panel.theta_deg, panel.phi_deg);
    let ring: Vec<(f64, f64)> = (0..=48)
        .map(|k| {
            let a = rad(k as f64 * 7.5);
            (fx + 5.0 * a.cos(), fy + 5.0 * a.sin())
        })
        .collect();
    ink.line(&ring, WHITE, 3.0, Dash::Solid, 1.0);
    ink.line(&ring, BLACK, 1.0, Dash::Solid, 1.0);
}
