//! Direction pairs given in degrees: one direction as `THETA,PHI` text, and the pairs file, a
//! CSV with the header `theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg` and one (ωi, ωo) per line.
//! θ may run to 180° (a direction below the horizon is a valid question whose answer is f = 0);
//! φ is any finite angle.

use crate::grid::direction;
use anyhow::{bail, Context, Result};
use glam::DVec3;
use std::path::Path;

/// The first line of a pairs file (spaces around the commas are allowed).
pub const HEADER: &str = "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg";

/// Checks one direction in degrees: θ in [0, 180], φ finite.
pub fn check_angles(theta: f64, phi: f64) -> Result<()> {
    if !(0.0..=180.0).contains(&theta) {
        bail!("theta = {theta} deg is out of range; valid range is [0, 180] (f = 0 beyond 90)");
    }
    if !phi.is_finite() {
        bail!("phi = {phi} deg must be a finite number");
    }
    Ok(())
}

/// Parses one direction `THETA,PHI` in degrees and checks it.
pub fn parse_direction(text: &str) -> Result<[f64; 2]> {
    let nums: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            anyhow::anyhow!("direction '{text}': expected THETA,PHI in degrees, e.g. 30,0")
        })?;
    let [theta, phi] = nums[..] else {
        bail!("direction '{text}': expected two numbers THETA,PHI in degrees, e.g. 30,0")
    };
    check_angles(theta, phi).with_context(|| format!("direction '{text}'"))?;
    Ok([theta, phi])
}

/// Parses the text of a pairs file; `source` names it in messages (a path). Blank lines are
/// skipped; every other line after the header holds four numbers.
pub fn parse_csv(text: &str, source: &str) -> Result<Vec<[f64; 4]>> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    match lines.next() {
        Some((_, h)) if h.replace(' ', "") == HEADER => {}
        _ => bail!("{source}: the first line must be the header {HEADER}"),
    }
    let mut out = Vec::new();
    for (n, line) in lines {
        let at = format!("{source} line {}", n + 1);
        let nums: Vec<f64> = line
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| anyhow::anyhow!("{at}: '{line}' is not four numbers"))?;
        let [ti, pi, to, po] = nums[..] else {
            bail!("{at}: expected four numbers, found {}", nums.len())
        };
        check_angles(ti, pi).with_context(|| at.clone())?;
        check_angles(to, po).with_context(|| at.clone())?;
        out.push([ti, pi, to, po]);
    }
    Ok(out)
}

/// Reads and parses a pairs file.
pub fn read_csv(path: &Path) -> Result<Vec<[f64; 4]>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_csv(&text, &path.display().to_string())
}

/// The unit vectors (ωi, ωo) of pairs in degrees `[θi, φi, θo, φo]`.
pub fn directions(angles: &[[f64; 4]]) -> Vec<(DVec3, DVec3)> {
    angles
        .iter()
        .map(|[ti, pi, to, po]| {
            (
                direction(ti.to_radians(), pi.to_radians()),
                direction(to.to_radians(), po.to_radians()),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(r: Result<impl std::fmt::Debug>) -> String {
        format!("{:#}", r.unwrap_err())
    }

    #[test]
    fn a_direction_is_two_numbers_in_range() {
        assert_eq!(parse_direction(" 30 , -45 ").unwrap(), [30.0, -45.0]);
        assert_eq!(parse_direction("180,0").unwrap(), [180.0, 0.0]);
        let e = err(parse_direction("200,0"));
        assert!(e.contains("'200,0'") && e.contains("theta = 200") && e.contains("[0, 180]"));
        assert!(err(parse_direction("-10,0")).contains("theta = -10"));
        assert!(err(parse_direction("nan,0")).contains("theta = NaN"));
        assert!(err(parse_direction("30,inf")).contains("finite"));
        assert!(err(parse_direction("30")).contains("two numbers THETA,PHI"));
        assert!(err(parse_direction("a,b")).contains("THETA,PHI"));
    }

    #[test]
    fn a_pairs_file_needs_its_header_and_four_numbers_a_line() {
        let good = format!("{HEADER}\n10,0,20,180\n\n 1 , 2 , 3 , 4 \n");
        assert_eq!(
            parse_csv(&good, "p.csv").unwrap(),
            vec![[10.0, 0.0, 20.0, 180.0], [1.0, 2.0, 3.0, 4.0]]
        );
        assert!(err(parse_csv("a,b,c,d\n", "p.csv")).contains("p.csv: the first line"));
        assert!(err(parse_csv("", "p.csv")).contains(HEADER));
        let e = err(parse_csv(&format!("{HEADER}\n1,2,3\n"), "p.csv"));
        assert!(e.contains("p.csv line 2") && e.contains("found 3"), "{e}");
        let e = err(parse_csv(&format!("{HEADER}\n1,2,x,4\n"), "p.csv"));
        assert!(e.contains("'1,2,x,4' is not four numbers"), "{e}");
        let e = err(parse_csv(&format!("{HEADER}\n10,0,300,4\n"), "p.csv"));
        assert!(e.contains("p.csv line 2: theta = 300"), "{e}");
    }

    #[test]
    fn directions_are_unit_vectors_from_the_angles() {
        let d = directions(&[[0.0, 0.0, 90.0, 90.0]]);
        assert!((d[0].0 - DVec3::Z).length() < 1e-15);
        assert!((d[0].1 - DVec3::Y).length() < 1e-15);
    }
}
