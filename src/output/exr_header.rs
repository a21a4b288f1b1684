//! The attributes of an OpenEXR header put in name order, in place.
//!
//! An OpenEXR file starts with the magic number and a version field (4 bytes each), then one
//! header (a multi-part file: several, and an empty one after the last): a list of attributes,
//! each a name and a type name (both null-terminated), a 32-bit little-endian size and that many
//! bytes of value, ended by a null byte (OpenEXR, "The OpenEXR File Layout"). Readers take the
//! attributes in any order. Sorting them permutes records of unchanged sizes, so the header keeps
//! its length and the offset tables after it stay valid.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom, Write};

/// The magic number every OpenEXR file starts with.
const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// The version field's flag of a multi-part file.
const MULTIPART: u32 = 0x1000;
/// The largest attribute value read: a header attribute is text or a few numbers, far below this;
/// a larger size means the bytes are not a header.
const MAX_ATTRIBUTE_BYTES: usize = 1 << 26;

fn invalid(what: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("not an OpenEXR header: {what}"),
    )
}

/// A null-terminated string, without its null byte.
fn read_name(r: &mut impl BufRead) -> io::Result<Vec<u8>> {
    let mut name = Vec::new();
    r.read_until(0, &mut name)?;
    if name.pop() != Some(0) {
        return Err(invalid("the file ends inside an attribute name"));
    }
    Ok(name)
}

/// One header's attributes as (name, the whole record); empty at the end of a multi-part list.
fn read_header(r: &mut impl BufRead) -> io::Result<Vec<(Vec<u8>, Vec<u8>)>> {
    let mut attributes = Vec::new();
    loop {
        let name = read_name(r)?;
        if name.is_empty() {
            return Ok(attributes);
        }
        let kind = read_name(r)?;
        let mut size = [0u8; 4];
        r.read_exact(&mut size)?;
        let n = usize::try_from(i32::from_le_bytes(size))
            .ok()
            .filter(|&n| n <= MAX_ATTRIBUTE_BYTES)
            .ok_or_else(|| invalid("an attribute size out of range"))?;
        let mut record = Vec::with_capacity(name.len() + kind.len() + 6 + n);
        record.extend_from_slice(&name);
        record.push(0);
        record.extend_from_slice(&kind);
        record.push(0);
        record.extend_from_slice(&size);
        let start = record.len();
        record.resize(start + n, 0);
        r.read_exact(&mut record[start..])?;
        attributes.push((name, record));
    }
}

/// Rewrites the header(s) of the OpenEXR file `file` with the attributes of each header in name
/// order (see the module's notes); the rest of the file is untouched.
pub fn sort_attributes(file: &File) -> io::Result<()> {
    let mut r = BufReader::new(file);
    r.seek(SeekFrom::Start(0))?;
    let mut start = [0u8; 8];
    r.read_exact(&mut start)?;
    if start[..4] != MAGIC {
        return Err(invalid("no magic number"));
    }
    let multipart = u32::from_le_bytes([start[4], start[5], start[6], start[7]]) & MULTIPART != 0;
    let mut sorted = Vec::new();
    loop {
        let mut header = read_header(&mut r)?;
        if header.is_empty() {
            if !multipart {
                return Err(invalid("a header without attributes"));
            }
            // The empty header that ends a multi-part list.
            sorted.push(0);
            break;
        }
        header.sort_by(|a, b| a.0.cmp(&b.0));
        for (_, record) in header {
            sorted.extend_from_slice(&record);
        }
        sorted.push(0);
        if !multipart {
            break;
        }
    }
    drop(r);
    let mut w = file;
    w.seek(SeekFrom::Start(start.len() as u64))?;
    w.write_all(&sorted)?;
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header of three attributes in the order c, a, b comes out a, b, c, with the bytes after it
    /// untouched.
    #[test]
    fn attributes_come_out_in_name_order() -> io::Result<()> {
        let record = |name: &str, value: &[u8]| {
            let mut r = name.as_bytes().to_vec();
            r.push(0);
            r.extend_from_slice(b"string\0");
            r.extend_from_slice(&(value.len() as i32).to_le_bytes());
            r.extend_from_slice(value);
            r
        };
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&2u32.to_le_bytes());
        let tail = b"\x01\x02offsets and chunks";
        let mut expected = bytes.clone();
        for (n, v) in [("c", &b"3"[..]), ("a", b"one"), ("b", b"\0\0")] {
            bytes.extend(record(n, v));
        }
        for (n, v) in [("a", &b"one"[..]), ("b", b"\0\0"), ("c", b"3")] {
            expected.extend(record(n, v));
        }
        bytes.push(0);
        expected.push(0);
        bytes.extend_from_slice(tail);
        expected.extend_from_slice(tail);
        let mut f = tempfile::tempfile()?;
        f.write_all(&bytes)?;
        sort_attributes(&f)?;
        let mut got = Vec::new();
        f.seek(SeekFrom::Start(0))?;
        f.read_to_end(&mut got)?;
        assert_eq!(got, expected);
        Ok(())
    }
}
