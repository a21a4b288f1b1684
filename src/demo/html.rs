//! The pieces of HTML the demo's page and its sections share: escaping, figures, RGB cells and
//! the albedo tables' rows.

use super::{AlbedoRow, ALBEDO_MU};
use std::fmt::Write as _;

/// HTML-escapes text.
pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An RGB triple as the page shows it (and tests/demo.rs parses it): four decimals, one
/// channel a line (the cell keeps the line breaks), so that the columns stay narrow and the
/// digits of r, g and b line up.
pub fn rgb_text(v: [f64; 3]) -> String {
    format!("{:.4}\n{:.4}\n{:.4}", v[0], v[1], v[2])
}

/// The style of a loss cell: a blue whose strength grows with the largest channel's loss
/// (none at 0, full at half the energy lost or more).
fn loss_style(loss: [f64; 3]) -> String {
    let worst = loss.iter().copied().fold(0.0, f64::max).clamp(0.0, 0.5) / 0.5;
    format!(
        " style=\"background: rgba(0, 114, 178, {:.2})\"",
        0.35 * worst
    )
}

/// A figure: the picture at `src`, linked to itself, with its caption.
pub(super) fn figure(out: &mut String, src: &str, size: (usize, usize), caption: &str) {
    let _ = writeln!(
        out,
        "<figure><a href=\"{0}\"><img src=\"{0}\" width=\"{1}\" height=\"{2}\" alt=\"{3}\"></a><figcaption>{3}</figcaption></figure>",
        esc(src),
        size.0,
        size.1,
        esc(caption)
    );
}

/// The header row of an albedo table.
pub(super) const ALBEDO_HEADER: &str = "<tr><th>model</th><th>E(μ=0.1)</th><th>E(μ=0.5)</th><th>E(μ=1)</th><th>Ē</th><th>max E</th><th>1 − E<sub>avg</sub></th><th>err</th><th>data</th></tr>";

/// One row of an albedo table (the columns of [`ALBEDO_HEADER`]).
pub(super) fn albedo_row(h: &mut String, a: &AlbedoRow) {
    let loss = a.e_avg.map(|x| 1.0 - x);
    let _ = write!(
        h,
        "<tr data-albedo=\"{}\" data-material=\"{}\" data-model=\"{}\"><td>{}</td>",
        esc(&a.json),
        esc(&a.material),
        esc(&a.model),
        esc(&a.model)
    );
    for (k, e) in a.e.iter().enumerate() {
        let _ = write!(
            h,
            "<td class=\"rgb\" data-field=\"mu={}\">{}</td>",
            ALBEDO_MU[k],
            rgb_text(*e)
        );
    }
    let _ = write!(
        h,
        "<td class=\"rgb\" data-field=\"hemispherical\">{}</td>",
        rgb_text(a.hemispherical)
    );
    let _ = write!(
        h,
        "<td class=\"num{}\" data-field=\"max_e\" title=\"at μ = {:.3}\">{:.4}{}</td>",
        if a.gains_energy() { " gain" } else { "" },
        a.max_e_mu,
        a.max_e,
        if a.gains_energy() { " gain" } else { "" }
    );
    let _ = write!(
        h,
        "<td class=\"rgb loss\" data-field=\"loss\"{}>{}</td><td class=\"num\">{:.1e}</td><td><a href=\"{}\">json</a></td></tr>",
        loss_style(loss),
        rgb_text(loss),
        a.error,
        esc(&a.json)
    );
    let _ = writeln!(h);
}
