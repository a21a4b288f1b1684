//! NumPy `.npy` version 1.0, little-endian float32, C order: a streaming writer (the header is
//! known before the data, so a table of any size goes to disk chunk by chunk; artifact sets,
//! [`super::ArtifactSet`], write through it) and a reader.
//! Format: <https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html>.

use anyhow::{bail, Context, Result};
use std::io::Write;

const MAGIC: &[u8] = b"\x93NUMPY";

/// The header for a float32 array of `shape`, padded so that the data starts on 64 bytes.
pub fn header(shape: &[usize]) -> Vec<u8> {
    header_of("<f4", shape)
}

/// The header for a float64 array of `shape`, padded so that the data starts on 64 bytes.
pub fn header_f64(shape: &[usize]) -> Vec<u8> {
    header_of("<f8", shape)
}

/// The header for a C-order array of `shape` whose elements `descr` names (`<f4`, `<f8`).
fn header_of(descr: &str, shape: &[usize]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {tuple}, }}");
    let unpadded = MAGIC.len() + 2 + 2 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// Writes f32 values as little-endian bytes.
pub fn write_f32(w: &mut impl Write, values: &[f32]) -> std::io::Result<()> {
    if cfg!(target_endian = "little") {
        w.write_all(bytemuck::cast_slice(values))
    } else {
        values
            .iter()
            .try_for_each(|v| w.write_all(&v.to_le_bytes()))
    }
}

/// Writes f64 values as little-endian bytes.
pub fn write_f64(w: &mut impl Write, values: &[f64]) -> std::io::Result<()> {
    if cfg!(target_endian = "little") {
        w.write_all(bytemuck::cast_slice(values))
    } else {
        values
            .iter()
            .try_for_each(|v| w.write_all(&v.to_le_bytes()))
    }
}

/// The largest `.npy` that [`read`] takes in, header and data: 2^28 float32 values (a full grid
/// of 64 × 64 × 128 × 128 RGB cells is a quarter of it), so that reading one stays well within a
/// process's memory whatever the file claims.
pub const MAX_READ_BYTES: u64 = 1 << 30;

/// Reads a float32 C-order `.npy` (a regular file, at most [`MAX_READ_BYTES`]): (shape, values).
/// The header's shape must account for the file's length exactly.
pub fn read(path: &std::path::Path) -> Result<(Vec<usize>, Vec<f32>)> {
    let bytes = crate::input::read_regular(path, "NumPy file", MAX_READ_BYTES)?;
    let (shape, offset) = parse_header(&bytes)
        .with_context(|| format!("reading the header of {}", path.display()))?;
    let n = shape
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .filter(|n| n.checked_mul(4).is_some())
        .with_context(|| format!("{}: the shape {shape:?} is too large", path.display()))?;
    let data = &bytes[offset..];
    if data.len() != 4 * n {
        bail!(
            "{}: expected {} float32 values, found {} bytes",
            path.display(),
            n,
            data.len()
        );
    }
    Ok((
        shape,
        data.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    ))
}

/// Parses a version 1, 2 or 3 header of a little-endian float32 C-order array: (shape, data
/// offset in bytes). The header is a Python dict literal with exactly the keys `descr`,
/// `fortran_order` and `shape` (the format's definition); a repeated, unknown or missing key is
/// refused, since which of two `shape`s a reader believes is not for lobe to guess.
pub fn parse_header(bytes: &[u8]) -> Result<(Vec<usize>, usize)> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        bail!("not a .npy file");
    }
    let (len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10usize),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v @ (2 | 3) => bail!("truncated .npy version {v} header"),
        v => bail!("unsupported .npy version {v}"),
    };
    let text = bytes
        .get(start..start.saturating_add(len))
        .context("truncated header")?;
    let dict = std::str::from_utf8(text).context("the header is not text")?;
    let (mut descr, mut fortran, mut shape) = (None, None, None);
    for (key, value) in header_items(dict).with_context(|| format!("header {}", dict.trim()))? {
        let slot = match key {
            "descr" => &mut descr,
            "fortran_order" => &mut fortran,
            "shape" => &mut shape,
            other => bail!("header key '{other}' is not one of descr, fortran_order, shape"),
        };
        if slot.replace(value).is_some() {
            bail!("header key '{key}' is given twice: {}", dict.trim());
        }
    }
    match (descr, fortran, shape) {
        (
            Some(HeaderValue::Str("<f4")),
            Some(HeaderValue::Bool(false)),
            Some(HeaderValue::Ints(s)),
        ) => Ok((s, start + len)),
        (Some(_), Some(_), Some(_)) => bail!(
            "only little-endian float32 ('<f4') in C order (fortran_order False) with a shape \
             tuple is supported; header: {}",
            dict.trim()
        ),
        _ => bail!(
            "the header needs descr, fortran_order and shape: {}",
            dict.trim()
        ),
    }
}

/// A value in a `.npy` header.
#[derive(Debug, PartialEq)]
enum HeaderValue<'a> {
    Str(&'a str),
    Bool(bool),
    Ints(Vec<usize>),
}

/// The (key, value) items of a header's dict literal `{'k': v, ...}`, whose values are quoted
/// strings, `True`/`False` or tuples of integers; whitespace and one trailing comma allowed.
fn header_items(dict: &str) -> Result<Vec<(&str, HeaderValue<'_>)>> {
    let mut rest = dict.trim();
    rest = rest.strip_prefix('{').context("expected '{'")?.trim_start();
    let mut items = Vec::new();
    loop {
        if let Some(after) = rest.strip_prefix('}') {
            if !after.trim().is_empty() {
                bail!("text after the closing '}}'");
            }
            return Ok(items);
        }
        let (key, after) = quoted(rest).context("expected a quoted key")?;
        rest = after
            .trim_start()
            .strip_prefix(':')
            .context("expected ':'")?
            .trim_start();
        let value;
        (value, rest) = header_value(rest)?;
        items.push((key, value));
        rest = rest.trim_start();
        match rest.strip_prefix(',') {
            Some(after) => rest = after.trim_start(),
            None if rest.starts_with('}') => {}
            None => bail!("expected ',' or '}}' after '{key}'"),
        }
    }
}

/// A quoted string at the start of `s` (single or double quotes), and the text after it.
fn quoted(s: &str) -> Option<(&str, &str)> {
    let q = s.chars().next().filter(|c| *c == '\'' || *c == '"')?;
    let end = s[1..].find(q)? + 1;
    Some((&s[1..end], &s[end + 1..]))
}

fn header_value(s: &str) -> Result<(HeaderValue<'_>, &str)> {
    if let Some((text, rest)) = quoted(s) {
        return Ok((HeaderValue::Str(text), rest));
    }
    for (word, b) in [("True", true), ("False", false)] {
        if let Some(rest) = s.strip_prefix(word) {
            return Ok((HeaderValue::Bool(b), rest));
        }
    }
    let inner = s
        .strip_prefix('(')
        .context("expected a string, True, False or a tuple")?;
    let close = inner.find(')').context("a tuple without its ')'")?;
    let body = inner[..close].trim();
    // `()` is a scalar's shape and `(4,)` a vector's: one trailing comma, nothing empty before it.
    let body = body.strip_suffix(',').unwrap_or(body);
    let ints: Result<Vec<usize>, _> = match body {
        "" => Ok(Vec::new()),
        _ => body.split(',').map(|p| p.trim().parse::<usize>()).collect(),
    };
    let ints = ints.with_context(|| format!("shape ({}): expected integers", &inner[..close]))?;
    Ok((HeaderValue::Ints(ints), &inner[close + 1..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_aligned_and_parses_back() {
        for shape in [vec![3], vec![2, 3, 4, 3], vec![100, 7, 3]] {
            let h = header(&shape);
            assert_eq!(h.len() % 64, 0);
            assert_eq!(parse_header(&h).unwrap(), (shape.clone(), h.len()));
        }
    }

    /// A header made by hand around `dict` (version 1).
    fn with_dict(dict: &str) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        out.extend_from_slice(&[1, 0]);
        out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
        out.extend_from_slice(dict.as_bytes());
        out
    }

    /// NumPy writes its keys in this order with a trailing comma; other writers (and a scalar's
    /// empty shape) vary the spelling but not the meaning.
    #[test]
    fn headers_other_writers_make_parse() {
        for (dict, shape) in [
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }",
                vec![2, 3],
            ),
            (
                "{\"shape\": (4,), \"descr\": \"<f4\", \"fortran_order\": False}",
                vec![4],
            ),
            ("{'descr':'<f4','fortran_order':False,'shape':()}", vec![]),
        ] {
            let h = with_dict(dict);
            assert_eq!(parse_header(&h).unwrap(), (shape, h.len()), "{dict}");
        }
    }

    /// Which of two shapes a reader believes is a guess, so a repeated key is refused, as are an
    /// unknown key, a missing one and a type lobe does not read (a `'<f4'` written as another
    /// key's value once passed a substring check).
    #[test]
    fn a_repeated_unknown_or_missing_key_is_refused() {
        for (dict, says) in [
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), 'shape': (4,), }",
                "twice",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), 'x': 1}",
                "expected a string",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), 'x': '<f4'}",
                "not one of",
            ),
            ("{'descr': '<f4', 'shape': (2,)}", "needs descr"),
            (
                "{'descr': '<f8', 'fortran_order': False, 'shape': (2,), 'o': '<f4'}",
                "not one of",
            ),
            (
                "{'descr': '<f8', 'fortran_order': False, 'shape': (2,)}",
                "only little-endian",
            ),
            (
                "{'descr': '<f4', 'fortran_order': True, 'shape': (2,)}",
                "only little-endian",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2, -1)}",
                "expected integers",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2,)} x",
                "after the closing",
            ),
        ] {
            let e = format!("{:#}", parse_header(&with_dict(dict)).unwrap_err());
            assert!(e.contains(says), "{dict}: {e}");
        }
    }
}
