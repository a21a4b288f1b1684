//! The plotted numbers beside each picture as CSV, for re-plotting elsewhere (matplotlib,
//! gnuplot, a spreadsheet): one row per plotted point, the series named by its label.
//!
//! Numbers are written with Rust's shortest round-trip formatting, so a reader parses back the
//! exact f64 values the picture was drawn from.

use super::{Plotted, Subject};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Where the data of a picture go: `path` with the extension `.csv`.
pub fn data_csv_path(path: &Path) -> PathBuf {
    path.with_extension("csv")
}

/// Writes [`data_csv`] of `plotted` to [`data_csv_path`] of `path`, whole or not at all.
pub fn write_data_csv(path: &Path, subjects: &[Subject], plotted: &Plotted) -> Result<()> {
    let text = data_csv(subjects, plotted);
    let dest = data_csv_path(path);
    crate::output::write_atomic(&dest, |w| {
        std::io::Write::write_all(w, text.as_bytes())
            .with_context(|| format!("writing {}", dest.display()))
    })
}

/// A CSV field: quoted when it holds a comma, quote or line break.
fn field(text: &str) -> String {
    if text.contains([',', '"', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The plotted data as CSV text with a header row. Columns by kind:
/// - polar: `label,theta_i_deg,theta_o_deg,value,r,g,b` (θo signed, positive on the mirror side);
/// - hemisphere: `label,theta_deg,phi_deg,row,col,value` (the fixed direction, then the cell;
///   cells outside the disc are left out);
/// - slice: `label,theta_h_deg,theta_d_deg,value` at the cell centres;
/// - 3d: `label,theta_i_deg,phi_i_deg,x,y,z,value` (surface points in chart units);
/// - albedo: `label,mu,E,r,g,b`.
pub fn data_csv(subjects: &[Subject], plotted: &Plotted) -> String {
    let label = |k: usize| field(&subjects[k].label);
    let mut out = String::new();
    // Writing to a String cannot fail; the results are ignored for that reason.
    match plotted {
        Plotted::Polar(d) => {
            out.push_str("label,theta_i_deg,theta_o_deg,value,r,g,b\n");
            for s in &d.series {
                for ((a, v), c) in s.theta_o_deg.iter().zip(&s.value).zip(&s.rgb) {
                    let _ = writeln!(
                        out,
                        "{},{},{a},{v},{},{},{}",
                        label(s.subject),
                        s.theta_i_deg,
                        c[0],
                        c[1],
                        c[2]
                    );
                }
            }
        }
        Plotted::Hemisphere(d) => {
            out.push_str("label,theta_deg,phi_deg,row,col,value\n");
            for p in &d.panels {
                for (k, v) in p.values.iter().enumerate() {
                    if v.is_nan() {
                        continue;
                    }
                    let (row, col) = (k / d.res, k % d.res);
                    let _ = writeln!(
                        out,
                        "{},{},{},{row},{col},{v}",
                        label(p.subject),
                        p.theta_deg,
                        p.phi_deg
                    );
                }
            }
        }
        Plotted::Slice(d) => {
            out.push_str("label,theta_h_deg,theta_d_deg,value\n");
            let cell = |k: usize| (k as f64 + 0.5) * 90.0 / d.res as f64;
            for p in &d.panels {
                for (k, v) in p.values.iter().enumerate() {
                    let (row, col) = (k / d.res, k % d.res);
                    let _ = writeln!(out, "{},{},{},{v}", label(p.subject), cell(col), cell(row));
                }
            }
        }
        Plotted::Surface3d(d) => {
            out.push_str("label,theta_i_deg,phi_i_deg,x,y,z,value\n");
            for p in &d.panels {
                for (q, v) in p.points.iter().zip(&p.values) {
                    let _ = writeln!(
                        out,
                        "{},{},{},{},{},{},{v}",
                        label(p.subject),
                        p.theta_i_deg,
                        p.phi_i_deg,
                        q[0],
                        q[1],
                        q[2]
                    );
                }
            }
        }
        Plotted::Albedo(d) => {
            out.push_str("label,mu,E,r,g,b\n");
            for c in &d.curves {
                for ((m, e), rgb) in c.mu.iter().zip(&c.albedo).zip(&c.rgb) {
                    let _ = writeln!(
                        out,
                        "{},{m},{e},{},{},{}",
                        label(c.subject),
                        rgb[0],
                        rgb[1],
                        rgb[2]
                    );
                }
            }
        }
    }
    out
}
