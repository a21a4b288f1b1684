//! NumPy `.npy` version 1.0, little-endian float32, C order: a streaming writer (the header is
//! known before the data, so a table of any size goes to disk chunk by chunk) and a reader.
//! Format: <https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html>.

use anyhow::{bail, Context, Result};
use std::io::{Read, Write};

const MAGIC: &[u8] = b"\x93NUMPY";

/// The header for a float32 array of `shape`, padded so that the data starts on 64 bytes.
pub fn header(shape: &[usize]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {tuple}, }}");
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

/// Reads a float32 C-order `.npy`: (shape, data offset in bytes, values).
pub fn read(path: &std::path::Path) -> Result<(Vec<usize>, Vec<f32>)> {
    let mut f = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut bytes = Vec::new();
    f.read_to_end(&mut bytes)?;
    let (shape, offset) = parse_header(&bytes)
        .with_context(|| format!("reading the header of {}", path.display()))?;
    let n: usize = shape.iter().product();
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

/// Parses a version 1 or 2 header of a little-endian float32 C-order array.
pub fn parse_header(bytes: &[u8]) -> Result<(Vec<usize>, usize)> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        bail!("not a .npy file");
    }
    let (len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => bail!("unsupported .npy version {v}"),
    };
    let dict = std::str::from_utf8(bytes.get(start..start + len).context("truncated header")?)?;
    if !dict.contains("'<f4'") || !dict.contains("'fortran_order': False") {
        bail!("only little-endian float32 in C order is supported; header: {dict}");
    }
    let open = dict.find("'shape': (").context("no shape")? + "'shape': (".len();
    let close = dict[open..].find(')').context("no shape")? + open;
    let shape: Result<Vec<usize>, _> = dict[open..close]
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::parse)
        .collect();
    Ok((shape?, start + len))
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
}
