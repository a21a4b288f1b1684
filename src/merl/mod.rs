//! Measured BRDFs in the MERL database's file format (Matusik, Pfister, Brand & McMillan 2003,
//! "A data-driven reflectance model"), read exactly as MERL's reference reader (`BRDFRead.cpp`)
//! reads them, and written in the same layout:
//!
//! - three little-endian int32, the table's dimensions 90 90 180 (θh, θd, φd); only their
//!   product, 1,458,000, is checked, as that reader checks it;
//! - 3 × 1,458,000 little-endian float64, planar: every red bin, then every green, then every
//!   blue; nothing after them (a file of any other length is refused);
//! - f = stored × scale, scale = (1/1500, 1.15/1500, 1.66/1500) for (r, g, b);
//! - bin = φd + 180 (θd + 90 θh) with θh → ⌊90 √(θh/(π/2))⌋ (0 when θh ≤ 0), θd → ⌊90 θd/(π/2)⌋,
//!   φd → φd + π where negative, then ⌊180 φd/π⌋, each clamped to its axis; the angles are
//!   Rusinkiewicz's half/difference angles as that reader builds them
//!   ([`crate::grid::pair_to_half_diff`]);
//! - a negative stored value marks a bin without a measurement: it is read as 0, and counted.
//!
//! [`read`] loads a file, [`model::load`] makes it a model every command can use (its lookup and
//! the f64 twin in [`lookup`]), and [`write::write`] writes any isotropic model in the format.

pub use crate::model::merl as lookup;
pub use crate::model::merl::{bin, bin_centre, MerlTable, BINS, DIMS};
pub mod model;
pub mod write;

use std::path::{Path, PathBuf};

/// f = stored × SCALE per channel (r, g, b), as MERL's reader scales.
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// The header's length in bytes: three int32.
pub const HEADER_BYTES: usize = 12;

/// A MERL file's length in bytes: the header and 3 × [`BINS`] float64.
pub const FILE_BYTES: usize = HEADER_BYTES + 3 * 8 * BINS;

/// A file refused: its path and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct MerlError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong, in a sentence.
    pub problem: String,
}

/// The three int32 dimensions of a header, refused unless their product is [`BINS`] (computed in
/// i64: no overflow) or the bytes are fewer than [`HEADER_BYTES`].
pub fn parse_header(bytes: &[u8]) -> Result<[i32; 3], String> {
    if bytes.len() < HEADER_BYTES {
        return Err(format!(
            "truncated: {} bytes, fewer than the {HEADER_BYTES}-byte header of three int32 dimensions",
            bytes.len()
        ));
    }
    let dim = |k: usize| {
        i32::from_le_bytes([
            bytes[4 * k],
            bytes[4 * k + 1],
            bytes[4 * k + 2],
            bytes[4 * k + 3],
        ])
    };
    let dims = [dim(0), dim(1), dim(2)];
    let product: i64 = dims.iter().map(|&d| d as i64).product();
    if product != BINS as i64 {
        return Err(format!(
            "the dimensions {} x {} x {} (product {product}) are not a MERL table's 90 x 90 x 180 = {BINS} bins",
            dims[0], dims[1], dims[2]
        ));
    }
    Ok(dims)
}

/// Checks a file's length against [`FILE_BYTES`].
fn check_length(len: u64) -> Result<(), String> {
    let want = FILE_BYTES as u64;
    match len.cmp(&want) {
        std::cmp::Ordering::Less => Err(format!(
            "truncated: {len} bytes, but the header and {BINS} bins of 3 float64 take {want}"
        )),
        std::cmp::Ordering::Greater => Err(format!(
            "oversized: {len} bytes, {} more than the {want} of a header and {BINS} bins of 3 float64",
            len - want
        )),
        std::cmp::Ordering::Equal => Ok(()),
    }
}

/// A whole file's bytes as a table: the header ([`parse_header`]), the length, then the values
/// (a NaN or infinite value, or one whose f exceeds the largest f32, is refused; a negative one
/// is missing).
pub fn parse(bytes: &[u8]) -> Result<MerlTable, String> {
    parse_header(bytes)?;
    check_length(bytes.len() as u64)?;
    let mut values = Vec::with_capacity(3 * BINS);
    let mut missing = 0;
    for (k, chunk) in bytes[HEADER_BYTES..].chunks_exact(8).enumerate() {
        let mut b = [0u8; 8];
        b.copy_from_slice(chunk);
        let stored = f64::from_le_bytes(b);
        // f must fit f32, as the GPU kernels and the tables hold it (docs/design.md §2.1);
        // negative values stay the format's marker of a missing bin.
        if !stored.is_finite() || stored * SCALE[k / BINS] > f32::MAX as f64 {
            let (c, bin) = (k / BINS, k % BINS);
            return Err(format!(
                "value {stored:e} at {} bin {bin} (theta_h {}, theta_d {}, phi_d {}); a MERL value is a finite number whose f = value x {} is at most {:e} (the largest f32)",
                ["red", "green", "blue"][c],
                bin / (DIMS[1] * DIMS[2]),
                bin / DIMS[2] % DIMS[1],
                bin % DIMS[2],
                SCALE[c],
                f32::MAX
            ));
        }
        if stored < 0.0 {
            missing += 1;
            values.push(0.0);
        } else {
            values.push(stored * SCALE[k / BINS]);
        }
    }
    Ok(MerlTable { values, missing })
}

/// Reads a MERL file. Its length is checked before it is read, so an oversized file is refused
/// without reading it; every refusal names the file.
pub fn read(path: &Path) -> Result<MerlTable, MerlError> {
    let refuse = |problem: String| MerlError {
        path: path.to_path_buf(),
        problem,
    };
    let meta = std::fs::metadata(path).map_err(|e| refuse(format!("cannot read it: {e}")))?;
    if !meta.is_file() {
        return Err(refuse("not a file".into()));
    }
    if meta.len() > FILE_BYTES as u64 {
        // The header still says whether it is a MERL file at all.
        let mut head = [0u8; HEADER_BYTES];
        let mut f =
            std::fs::File::open(path).map_err(|e| refuse(format!("cannot read it: {e}")))?;
        std::io::Read::read_exact(&mut f, &mut head)
            .map_err(|e| refuse(format!("cannot read its header: {e}")))?;
        parse_header(&head).map_err(refuse)?;
        return Err(refuse(check_length(meta.len()).err().unwrap_or_default()));
    }
    let bytes = std::fs::read(path).map_err(|e| refuse(format!("cannot read it: {e}")))?;
    parse(&bytes).map_err(refuse)
}

/// The file's bytes for a table of f in 1/sr (planar, 3 × [`BINS`]): the header 90 90 180 and
/// f / [`SCALE`] per value, which [`parse`] reads back as f (to a rounding of the division).
pub fn encode(values: &[f64]) -> Vec<u8> {
    assert_eq!(values.len(), 3 * BINS, "a MERL table has 3 x {BINS} values");
    let mut out = Vec::with_capacity(FILE_BYTES);
    for d in DIMS {
        out.extend_from_slice(&(d as i32).to_le_bytes());
    }
    for (k, v) in values.iter().enumerate() {
        out.extend_from_slice(&(v / SCALE[k / BINS]).to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_has_merl_sizes() {
        assert_eq!(BINS, 1_458_000);
        assert_eq!(FILE_BYTES, 34_992_012);
        assert_eq!(bin(89, 89, 179), BINS - 1);
        assert_eq!(bin(1, 0, 0), 90 * 180);
    }

    #[test]
    fn headers_with_the_product_pass_whatever_their_order() {
        let header = |d: [i32; 3]| d.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>();
        assert!(parse_header(&header([90, 90, 180])).is_ok());
        assert!(parse_header(&header([180, 90, 90])).is_ok());
        let e = parse_header(&header([90, 90, 181])).unwrap_err();
        assert!(e.contains("90 x 90 x 181") && e.contains("1466100"), "{e}");
        // A product that overflows i32 (as C's int product would) is still refused.
        let e = parse_header(&header([i32::MAX, i32::MAX, 2])).unwrap_err();
        assert!(e.contains("product"), "{e}");
        assert!(parse_header(&[0; 11]).unwrap_err().contains("truncated"));
    }
}
