//! Direction pairs given in degrees: one direction as `THETA,PHI` text, and the pairs file, a
//! CSV with the header `theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg` and one (ωi, ωo) per line.
//! θ may run to 180° (a direction below the horizon is a valid question whose answer is f = 0);
//! |φ| is at most a million degrees. A pairs file is read a chunk at a time ([`PairsReader`]).

use crate::grid::direction_deg;
use anyhow::{bail, Context, Result};
use glam::DVec3;
use std::io::{BufRead, Read};
use std::path::Path;

/// The first line of a pairs file (spaces around the commas are allowed).
pub const HEADER: &str = "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg";

/// The largest |φ| accepted, degrees: a million degrees still holds the angle to 1.2e-10°
/// in f64; far beyond it the angle's fraction of a turn is lost to rounding (at 1e15° one step
/// of f64 is 0.125°), so such a φ names no direction.
pub const MAX_ABS_PHI_DEG: f64 = 1e6;

/// The longest line of a pairs file, bytes, without its line end: four numbers written at full
/// precision take under 120. A longer line is refused as it is read, so that an input without
/// line ends (such as `/dev/zero`) cannot fill memory.
pub const MAX_LINE_BYTES: usize = 1024;

/// Pairs read, evaluated and written at a time by a streaming reader's users: 2.6 MB of pairs
/// in flight (angles, directions and values), and large enough that the GPU runs full
/// dispatches.
pub const CHUNK_PAIRS: usize = 1 << 16;

/// A number for a message: plain when short, in scientific notation when plain would be long
/// (1e308 is written `1e308`, not as 309 digits).
pub fn fmt_value(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() > 16 {
        format!("{x:e}")
    } else {
        plain
    }
}

/// Checks one direction in degrees: θ in [0, 180], |φ| at most [`MAX_ABS_PHI_DEG`].
pub fn check_angles(theta: f64, phi: f64) -> Result<()> {
    if !(0.0..=180.0).contains(&theta) {
        bail!(
            "theta = {} deg is out of range; valid range is [0, 180] (f = 0 beyond 90)",
            fmt_value(theta)
        );
    }
    if !phi.is_finite() {
        bail!("phi = {phi} deg must be a finite number");
    }
    if phi.abs() > MAX_ABS_PHI_DEG {
        bail!(
            "phi = {} deg is out of range; valid range is [-{MAX_ABS_PHI_DEG:e}, {MAX_ABS_PHI_DEG:e}] \
             (beyond it f64 no longer holds the angle to a useful fraction of a turn)",
            fmt_value(phi)
        );
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

/// A pairs file read a chunk at a time: memory stays at one chunk and one line whatever the
/// input's size. The header is checked when the reader is made; a UTF-8 byte order mark before
/// it is skipped; blank lines are skipped; every other line holds four numbers.
pub struct PairsReader<R> {
    input: R,
    source: String,
    line: usize,
    buf: Vec<u8>,
}

impl<R: BufRead> PairsReader<R> {
    /// Reads up to the header of `input` and checks it; `source` names the input in messages
    /// (a path, or "stdin").
    pub fn new(input: R, source: &str) -> Result<Self> {
        let mut reader = PairsReader {
            input,
            source: source.to_string(),
            line: 0,
            buf: Vec::new(),
        };
        let header = reader.next_line()?.map(|h| h.replace(' ', ""));
        if header.as_deref() != Some(HEADER) {
            bail!("{source}: the first line must be the header {HEADER}");
        }
        Ok(reader)
    }

    /// The next line that is not blank, without its line end; None at the end of the input.
    fn next_line(&mut self) -> Result<Option<String>> {
        loop {
            self.buf.clear();
            let limit = MAX_LINE_BYTES as u64 + 1;
            let n = (&mut self.input)
                .take(limit)
                .read_until(b'\n', &mut self.buf)
                .with_context(|| format!("reading {}", self.source))?;
            if n == 0 {
                return Ok(None);
            }
            self.line += 1;
            if self.buf.len() > MAX_LINE_BYTES && self.buf.last() != Some(&b'\n') {
                bail!(
                    "{} line {}: longer than {MAX_LINE_BYTES} bytes; a line holds four numbers",
                    self.source,
                    self.line
                );
            }
            let mut text = std::str::from_utf8(&self.buf).map_err(|_| {
                anyhow::anyhow!("{} line {}: not UTF-8 text", self.source, self.line)
            })?;
            if self.line == 1 {
                text = crate::input::without_bom(text);
            }
            let text = text.trim_end_matches(['\n', '\r']);
            if !text.trim().is_empty() {
                return Ok(Some(text.to_string()));
            }
        }
    }

    /// Up to `max` more pairs in degrees `[θi, φi, θo, φo]`, each checked; empty at the end.
    pub fn next_chunk(&mut self, max: usize) -> Result<Vec<[f64; 4]>> {
        let mut out = Vec::with_capacity(max.min(CHUNK_PAIRS));
        while out.len() < max {
            let Some(line) = self.next_line()? else { break };
            let at = format!("{} line {}", self.source, self.line);
            out.push(parse_row(&line, &at)?);
        }
        Ok(out)
    }
}

/// One line of pairs: four numbers, each direction checked; `at` locates it in messages.
fn parse_row(line: &str, at: &str) -> Result<[f64; 4]> {
    let mut nums = [0.0; 4];
    let mut count = 0;
    for field in line.split(',') {
        let v: f64 = field
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("{at}: '{line}' is not four numbers"))?;
        if count < 4 {
            nums[count] = v;
        }
        count += 1;
    }
    if count != 4 {
        bail!("{at}: expected four numbers, found {count}");
    }
    let [ti, pi, to, po] = nums;
    check_angles(ti, pi).with_context(|| at.to_string())?;
    check_angles(to, po).with_context(|| at.to_string())?;
    Ok(nums)
}

/// Parses the whole text of a pairs file; `source` names it in messages (a path).
pub fn parse_csv(text: &str, source: &str) -> Result<Vec<[f64; 4]>> {
    read_all(PairsReader::new(text.as_bytes(), source)?)
}

/// Reads and parses a whole pairs file (for a few pairs; [`PairsReader`] streams a large one).
pub fn read_csv(path: &Path) -> Result<Vec<[f64; 4]>> {
    let (file, _) = crate::input::open_input(path, "pairs file")?;
    let reader = std::io::BufReader::new(file);
    read_all(PairsReader::new(reader, &path.display().to_string())?)
}

fn read_all<R: BufRead>(mut reader: PairsReader<R>) -> Result<Vec<[f64; 4]>> {
    let mut out = Vec::new();
    loop {
        let chunk = reader.next_chunk(CHUNK_PAIRS)?;
        if chunk.is_empty() {
            return Ok(out);
        }
        out.extend(chunk);
    }
}

/// The unit vectors (ωi, ωo) of pairs in degrees `[θi, φi, θo, φo]`.
pub fn directions(angles: &[[f64; 4]]) -> Vec<(DVec3, DVec3)> {
    angles
        .iter()
        .map(|[ti, pi, to, po]| (direction_deg(*ti, *pi), direction_deg(*to, *po)))
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
    fn a_byte_order_mark_before_the_header_is_skipped() {
        let text = format!("\u{feff}{HEADER}\r\n10,0,20,180\r\n");
        assert_eq!(
            parse_csv(&text, "p.csv").unwrap(),
            vec![[10.0, 0.0, 20.0, 180.0]]
        );
    }

    #[test]
    fn a_line_longer_than_the_limit_is_refused_as_it_is_read() {
        // An endless input without line ends, as /dev/zero is: refused after one line's bytes.
        let zeros = std::io::repeat(0).take(u64::MAX);
        let e = err(PairsReader::new(std::io::BufReader::new(zeros), "zeros").map(|_| ()));
        assert!(
            e.contains("zeros line 1") && e.contains("longer than 1024 bytes"),
            "{e}"
        );
        let long = format!("{HEADER}\n{}1,2,3,4\n", " ".repeat(MAX_LINE_BYTES));
        let e = err(parse_csv(&long, "p.csv"));
        assert!(e.contains("p.csv line 2: longer than"), "{e}");
        let fits = format!("{HEADER}\n{}1,2,3,4\n", " ".repeat(MAX_LINE_BYTES - 8));
        assert_eq!(parse_csv(&fits, "p.csv").unwrap().len(), 1);
    }

    #[test]
    fn huge_angles_are_refused_in_short_notation() {
        let e = err(parse_direction("1e308,0"));
        assert!(e.contains("theta = 1e308 deg"), "{e}");
        let e = err(parse_direction("30,1e308"));
        assert!(
            e.contains("phi = 1e308 deg") && e.contains("[-1e6, 1e6]"),
            "{e}"
        );
        assert_eq!(parse_direction("30,-1e6").unwrap(), [30.0, -1e6]);
        assert_eq!(fmt_value(-12.5), "-12.5");
    }

    #[test]
    fn chunks_follow_the_file_in_order() {
        let text = format!("{HEADER}\n1,0,0,0\n2,0,0,0\n\n3,0,0,0\n");
        let mut r = PairsReader::new(text.as_bytes(), "p.csv").unwrap();
        assert_eq!(
            r.next_chunk(2).unwrap(),
            vec![[1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]]
        );
        assert_eq!(r.next_chunk(2).unwrap(), vec![[3.0, 0.0, 0.0, 0.0]]);
        assert!(r.next_chunk(2).unwrap().is_empty());
    }

    #[test]
    fn directions_are_unit_vectors_from_the_angles() {
        let d = directions(&[[0.0, 0.0, 90.0, 90.0]]);
        assert!((d[0].0 - DVec3::Z).length() < 1e-15);
        assert!((d[0].1 - DVec3::Y).length() < 1e-15);
    }
}
