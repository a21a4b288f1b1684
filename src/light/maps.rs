//! Environment maps: lat-long OpenEXR and Radiance `.hdr` files, read as Mitsuba 3's `envmap`
//! reads them (row 0 at +y, u = atan2(x, −z)/2π mod 1, v = acos(y)/π: src/backend/light.rs), and
//! the built-in procedural maps (docs/design.md §15.1).
//!
//! Files are untrusted input: read through [`crate::input::read_regular`] (regular files only, at
//! most [`MAX_MAP_FILE_BYTES`]), recognised by their magic bytes before any decoding, their size
//! checked from the header before a texel is decoded ([`check_size`]), and every texel checked
//! finite and ≥ 0 ([`EnvMap::new`]).

use crate::backend::light::{check_size, texel_direction, EnvMap};
use crate::input::{read_regular, BadInput};
use anyhow::{anyhow, bail, Context, Result};
use glam::DVec3;
use std::io::Cursor;
use std::path::Path;

/// The most bytes read from a map file: a float32 RGBA EXR of [`crate::backend::light::MAX_MAP_TEXELS`]
/// texels uncompressed, with room for its header and offset table.
pub const MAX_MAP_FILE_BYTES: u64 = (1 << 25) * 16 + (1 << 20);

/// OpenEXR's magic number (the file's first four bytes: 20000630 little-endian).
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// The most bytes of a Radiance header (its text lines before the resolution line).
const MAX_HDR_HEADER_BYTES: usize = 64 << 10;

/// The built-in maps' size: 256 × 128 texels (1.4° per texel), fine enough for the sky's sun
/// (an angular spread of 5.7°) and the studio's lights' soft edges.
pub const BUILTIN_WIDTH: u32 = 256;
/// See [`BUILTIN_WIDTH`].
pub const BUILTIN_HEIGHT: u32 = 128;

/// A built-in procedural map (formulas in docs/design.md §15.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builtin {
    /// A blue sky brighter at the horizon, a dark ground and a soft sun.
    Sky,
    /// A dark studio with three round soft-edged area lights (key, fill, top).
    Studio,
    /// Radiance 1 in every direction.
    Constant,
}

impl Builtin {
    /// Every built-in map.
    pub const ALL: [Builtin; 3] = [Builtin::Sky, Builtin::Studio, Builtin::Constant];

    /// The name `--env` takes.
    pub fn name(self) -> &'static str {
        match self {
            Builtin::Sky => "sky",
            Builtin::Studio => "studio",
            Builtin::Constant => "constant",
        }
    }

    /// The built-in map called `name`, if one is.
    pub fn from_name(name: &str) -> Option<Builtin> {
        Builtin::ALL.into_iter().find(|b| b.name() == name)
    }

    /// The map's radiance in the world direction `d` (unit, +y up).
    pub fn radiance(self, d: DVec3) -> DVec3 {
        match self {
            Builtin::Constant => DVec3::ONE,
            Builtin::Sky => sky_radiance(d),
            Builtin::Studio => studio_radiance(d),
        }
    }

    /// The map at [`BUILTIN_WIDTH`] × [`BUILTIN_HEIGHT`], each texel the radiance at its centre.
    pub fn map(self) -> EnvMap {
        procedural_map(BUILTIN_WIDTH, BUILTIN_HEIGHT, |d| self.radiance(d))
            .expect("the built-in maps are finite and non-negative")
    }
}

/// The sky's sun: its direction (up, to the right and toward the camera, so that its highlight
/// shows on the sphere's upper right), its peak radiance and its angular spread σ.
const SUN_DIRECTION: DVec3 = DVec3::new(0.4, 0.5, 0.7);
const SUN_RADIANCE: DVec3 = DVec3::new(40.0, 36.0, 30.0);
const SUN_SIGMA: f64 = 0.1;
/// The sky at the zenith and at the horizon, and the ground.
const SKY_ZENITH: DVec3 = DVec3::new(0.25, 0.45, 0.85);
const SKY_HORIZON: DVec3 = DVec3::new(0.75, 0.8, 0.85);
const GROUND: DVec3 = DVec3::new(0.25, 0.22, 0.2);

/// Sky: G below the horizon, H + (Z − H) y above it, plus the sun
/// S exp((d·s − 1)/σ²), a Gaussian of about σ radians about s.
fn sky_radiance(d: DVec3) -> DVec3 {
    let base = if d.y < 0.0 {
        GROUND
    } else {
        SKY_HORIZON + (SKY_ZENITH - SKY_HORIZON) * d.y
    };
    let s = SUN_DIRECTION.normalize();
    base + SUN_RADIANCE * ((d.dot(s) - 1.0) / (SUN_SIGMA * SUN_SIGMA)).exp()
}

/// The studio's lights: (direction, angular radius in degrees, RGB radiance).
const STUDIO_LIGHTS: [(DVec3, f64, DVec3); 3] = [
    // Key: upper left, toward the camera.
    (DVec3::new(-0.6, 0.5, 0.6), 20.0, DVec3::new(6.0, 5.7, 5.4)),
    // Fill: right, dimmer and wider.
    (DVec3::new(0.7, 0.2, 0.7), 30.0, DVec3::new(1.35, 1.43, 1.5)),
    // Top: above, slightly behind.
    (DVec3::new(0.0, 1.0, -0.3), 15.0, DVec3::new(8.0, 8.0, 8.0)),
];
/// Half the width of a studio light's soft edge, in degrees.
const STUDIO_EDGE_DEG: f64 = 3.0;
/// The studio's walls.
const STUDIO_BACKGROUND: f64 = 0.03;

/// smoothstep(a, b, x) = t²(3 − 2t), t = clamp((x − a)/(b − a), 0, 1).
fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Studio: B + Σ_k L_k (1 − smoothstep(r_k − e, r_k + e, γ_k)), γ_k the angle between d and
/// light k's direction.
fn studio_radiance(d: DVec3) -> DVec3 {
    let e = STUDIO_EDGE_DEG.to_radians();
    STUDIO_LIGHTS
        .iter()
        .fold(DVec3::splat(STUDIO_BACKGROUND), |acc, &(a, r, l)| {
            let gamma = d.dot(a.normalize()).clamp(-1.0, 1.0).acos();
            let r = r.to_radians();
            acc + l * (1.0 - smoothstep(r - e, r + e, gamma))
        })
}

/// A `w` × `h` map whose texels are `radiance` at their centres (rounded to f32).
pub fn procedural_map(w: u32, h: u32, radiance: impl Fn(DVec3) -> DVec3) -> Result<EnvMap> {
    check_size(w, h)?;
    let texels = (0..h)
        .flat_map(|i| (0..w).map(move |j| (i, j)))
        .map(|(i, j)| radiance(texel_direction(w, h, i, j)).as_vec3().to_array())
        .collect();
    Ok(EnvMap::new(w, h, texels)?)
}

/// What `--env` names: a built-in map's name, else the path of a map file.
pub fn resolve(env: &str) -> Result<EnvMap> {
    match Builtin::from_name(env) {
        Some(b) => Ok(b.map()),
        None => read_map(Path::new(env)),
    }
}

/// Reads the lat-long map `path`: OpenEXR (R, G and B of its first layer that has them, any
/// sample type) or Radiance RGBE (`.hdr`), told apart by their first bytes.
pub fn read_map(path: &Path) -> Result<EnvMap> {
    let bytes = read_regular(path, "environment map", MAX_MAP_FILE_BYTES)?;
    let shown = path.display();
    let map = if bytes.starts_with(&EXR_MAGIC) {
        read_exr(&bytes).with_context(|| format!("environment map {shown} (OpenEXR)"))
    } else if bytes.starts_with(b"#?") {
        read_hdr(&bytes).with_context(|| format!("environment map {shown} (Radiance HDR)"))
    } else {
        let head: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
        return Err(BadInput::new(
            "env",
            format!(
                "{shown} is not an environment map: an OpenEXR file starts with the bytes 76 2f 31 01 \
                 and a Radiance .hdr file with '#?', this one with [{}]; --env also takes {}",
                head.join(" "),
                Builtin::ALL.map(Builtin::name).join(", ")
            ),
        )
        .into());
    };
    map
}

/// An OpenEXR map from its bytes: the header's size checked before the pixels are decoded.
fn read_exr(bytes: &[u8]) -> Result<EnvMap> {
    use exr::prelude::*;
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| anyhow!("unreadable header: {e}"))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| anyhow!("the file has no layer"))?;
    let size = header.layer_size;
    let side = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
    check_size(side(size.0), side(size.1))?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("R")
        .required("G")
        .required("B")
        .collect_pixels(
            |size: Vec2<usize>, _| (size.0, vec![[0.0f32; 3]; size.0 * size.1]),
            |(w, px): &mut (usize, Vec<[f32; 3]>), at: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                px[at.1 * *w + at.0] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| anyhow!("{e} (a map needs channels R, G and B)"))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
    Ok(EnvMap::new(w, h, layer.channel_data.pixels.1)?)
}

/// A Radiance RGBE map from its bytes (Ward, "Real Pixels", Graphics Gems II, 1991; the
/// header and run-length encoding as Radiance's `color.c` writes them): `#?` and text lines up
/// to an empty line (`FORMAT=32-bit_rle_rgbe` or none; the XYZ format is refused), the
/// resolution `-Y H +X W` (rows from the top, the lat-long layout), then H scanlines, each
/// either flat (4 bytes a texel) or, for 8 ≤ W < 32768, the adaptive run-length form
/// (2, 2, W high, W low, then each channel as runs). A texel (r, g, b, e) is (r, g, b) 2^(e − 136),
/// 0 where e = 0 (Walter's `rgbe.c`, as Mitsuba reads it).
fn read_hdr(bytes: &[u8]) -> Result<EnvMap> {
    let mut at = 0usize;
    let line = |at: &mut usize| -> Result<&[u8]> {
        let rest = &bytes[*at..];
        let end = rest
            .iter()
            .take(MAX_HDR_HEADER_BYTES)
            .position(|&b| b == b'\n')
            .ok_or_else(|| anyhow!("the header ends without its resolution line"))?;
        *at += end + 1;
        Ok(&rest[..end])
    };
    loop {
        let l = line(&mut at)?;
        if at > MAX_HDR_HEADER_BYTES {
            bail!("the header is longer than {MAX_HDR_HEADER_BYTES} bytes");
        }
        if l.is_empty() {
            break;
        }
        if let Some(format) = l.strip_prefix(b"FORMAT=") {
            if format != b"32-bit_rle_rgbe" {
                bail!(
                    "FORMAT={}: only 32-bit_rle_rgbe is read",
                    String::from_utf8_lossy(format)
                );
            }
        }
    }
    let res = String::from_utf8_lossy(line(&mut at)?).into_owned();
    let parts: Vec<&str> = res.split_whitespace().collect();
    let (h, w) = match parts[..] {
        ["-Y", h, "+X", w] => (
            h.parse::<u32>()
                .map_err(|_| anyhow!("resolution line '{res}': bad height"))?,
            w.parse::<u32>()
                .map_err(|_| anyhow!("resolution line '{res}': bad width"))?,
        ),
        _ => bail!(
            "resolution line '{res}': only '-Y H +X W' (rows from the top, left to right) is read"
        ),
    };
    check_size(w, h)?;
    let (wu, hu) = (w as usize, h as usize);
    let mut texels = Vec::with_capacity(wu * hu);
    let mut scan = vec![[0u8; 4]; wu];
    for row in 0..hu {
        at = read_scanline(bytes, at, &mut scan)
            .with_context(|| format!("scanline {row} of {h}"))?;
        texels.extend(scan.iter().map(|&[r, g, b, e]| rgbe_to_rgb(r, g, b, e)));
    }
    Ok(EnvMap::new(w, h, texels)?)
}

/// One scanline of `scan.len()` texels from `bytes[at..]`; returns where the next begins.
fn read_scanline(bytes: &[u8], mut at: usize, scan: &mut [[u8; 4]]) -> Result<usize> {
    let w = scan.len();
    let truncated = || anyhow!("the file ends inside it (truncated)");
    let head = bytes.get(at..at + 4).ok_or_else(truncated)?;
    let adaptive = (8..0x8000).contains(&w) && head[0] == 2 && head[1] == 2 && head[2] < 0x80;
    if !adaptive {
        if head[..3] == [1, 1, 1] {
            bail!("the old run-length encoding is not read (rewrite the file with a current tool)");
        }
        let flat = bytes.get(at..at + 4 * w).ok_or_else(truncated)?;
        for (t, c) in scan.iter_mut().zip(flat.chunks_exact(4)) {
            t.copy_from_slice(c);
        }
        return Ok(at + 4 * w);
    }
    let stated = (head[2] as usize) << 8 | head[3] as usize;
    if stated != w {
        bail!("its run-length header says {stated} texels, the image is {w} wide");
    }
    at += 4;
    for channel in 0..4 {
        let mut x = 0usize;
        while x < w {
            let count = *bytes.get(at).ok_or_else(truncated)? as usize;
            at += 1;
            if count > 128 {
                let n = count - 128;
                let v = *bytes.get(at).ok_or_else(truncated)?;
                at += 1;
                if x + n > w {
                    bail!("a run of {n} texels at column {x} passes the row's end ({w})");
                }
                scan[x..x + n].iter_mut().for_each(|t| t[channel] = v);
                x += n;
            } else {
                if count == 0 || x + count > w {
                    bail!("a literal of {count} texels at column {x} in a row of {w}");
                }
                let run = bytes.get(at..at + count).ok_or_else(truncated)?;
                at += count;
                for (t, &v) in scan[x..x + count].iter_mut().zip(run) {
                    t[channel] = v;
                }
                x += count;
            }
        }
    }
    Ok(at)
}

/// An RGBE texel's linear RGB.
fn rgbe_to_rgb(r: u8, g: u8, b: u8, e: u8) -> [f32; 3] {
    if e == 0 {
        return [0.0; 3];
    }
    let f = libm::ldexpf(1.0, e as i32 - 136);
    [r as f32 * f, g as f32 * f, b as f32 * f]
}

/// The RGBE bytes of linear RGB (for writing test maps): Walter's `float2rgbe`.
pub fn rgb_to_rgbe(rgb: [f32; 3]) -> [u8; 4] {
    let v = rgb[0].max(rgb[1]).max(rgb[2]);
    if v < 1e-32 {
        return [0; 4];
    }
    let (m, e) = libm::frexpf(v);
    let scale = m * 256.0 / v;
    [
        (rgb[0] * scale) as u8,
        (rgb[1] * scale) as u8,
        (rgb[2] * scale) as u8,
        (e + 128) as u8,
    ]
}

/// A flat (not run-length encoded) Radiance file of a map, `-Y H +X W`.
pub fn encode_hdr(map: &EnvMap) -> Vec<u8> {
    let mut out = format!(
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {} +X {}\n",
        map.height(),
        map.width()
    )
    .into_bytes();
    for t in map.texels() {
        out.extend_from_slice(&rgb_to_rgbe(*t));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// A flat RGBE file reads back the values RGBE can hold (powers of two times small integers
    /// are exact), with the texel order of the lat-long layout.
    #[test]
    fn flat_hdr_files_read_back() {
        let texels: Vec<[f32; 3]> = (0..32).map(|k| [k as f32, 0.5, 2.0]).collect();
        let map = EnvMap::new(8, 4, texels).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "m.hdr", &encode_hdr(&map));
        let back = read_map(&p).unwrap();
        assert_eq!((back.width(), back.height()), (8, 4));
        for (k, t) in back.texels().iter().enumerate() {
            // RGBE keeps 8 bits of mantissa for the largest channel: 0.5 next to 31 loses its
            // low bits, so compare within one unit of the shared exponent's last place.
            let largest = (k as f32).max(2.0);
            let ulp = largest / 128.0;
            for (c, want) in [k as f32, 0.5, 2.0].iter().enumerate() {
                assert!((t[c] - want).abs() <= ulp, "texel {k} channel {c}: {t:?}");
            }
        }
    }

    /// The adaptive run-length form decodes: runs and literals, per channel.
    #[test]
    fn run_length_hdr_scanlines_decode() {
        let w = 10usize;
        let mut bytes = b"#?RADIANCE\n\n-Y 1 +X 10\n".to_vec();
        bytes.extend_from_slice(&[2, 2, 0, w as u8]);
        // R: a run of 10 texels of 128; G: 10 literals; B: runs 4 + 6; E: a run of 129 (2^-7).
        bytes.extend_from_slice(&[128 + 10, 128]);
        bytes.push(10);
        bytes.extend((0..10).map(|k| k as u8 * 10));
        bytes.extend_from_slice(&[128 + 4, 64, 128 + 6, 32]);
        bytes.extend_from_slice(&[128 + 10, 129]);
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "rle.hdr", &bytes);
        let map = read_map(&p).unwrap();
        let f = 2f32.powi(129 - 136);
        for x in 0..w {
            let t = map.texel(0, x as u32);
            let b = if x < 4 { 64.0 } else { 32.0 };
            assert_eq!(t, [128.0 * f, (x * 10) as f32 * f, b * f], "texel {x}");
        }
        // The same file cut short is refused as truncated, naming the scanline.
        let cut = write(dir.path(), "cut.hdr", &bytes[..bytes.len() - 3]);
        let e = format!("{:#}", read_map(&cut).unwrap_err());
        assert!(e.contains("truncated") && e.contains("scanline 0"), "{e}");
    }

    /// Not a map, an XYZ file, a flipped layout and a size over the bound are refused with
    /// sentences that say so.
    #[test]
    fn files_that_are_not_maps_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "a.png", b"\x89PNG\r\n\x1a\n....");
        let e = format!("{:#}", read_map(&p).unwrap_err());
        assert!(
            e.contains("is not an environment map") && e.contains("89 50 4e 47"),
            "{e}"
        );
        let p = write(
            dir.path(),
            "x.hdr",
            b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0",
        );
        let e = format!("{:#}", read_map(&p).unwrap_err());
        assert!(e.contains("xyze"), "{e}");
        let p = write(dir.path(), "f.hdr", b"#?RADIANCE\n\n+Y 1 +X 1\n\0\0\0\0");
        let e = format!("{:#}", read_map(&p).unwrap_err());
        assert!(e.contains("-Y H +X W"), "{e}");
        let p = write(
            dir.path(),
            "big.hdr",
            b"#?RADIANCE\n\n-Y 100000 +X 100000\n",
        );
        let e = format!("{:#}", read_map(&p).unwrap_err());
        assert!(e.contains("[1, 16384]"), "{e}");
        let p = write(dir.path(), "nohead.hdr", b"#?RADIANCE\nno end");
        assert!(read_map(&p).is_err());
    }

    /// The built-in maps are what their formulas say at a few directions.
    #[test]
    fn builtin_maps_follow_their_formulas() {
        assert_eq!(Builtin::Constant.radiance(DVec3::Y), DVec3::ONE);
        let s = SUN_DIRECTION.normalize();
        let at_sun = Builtin::Sky.radiance(s);
        let base = SKY_HORIZON + (SKY_ZENITH - SKY_HORIZON) * s.y;
        assert!((at_sun - (base + SUN_RADIANCE)).length() < 1e-12);
        assert!((Builtin::Sky.radiance(-DVec3::Y) - GROUND).length() < 1e-12);
        let key = STUDIO_LIGHTS[0].0.normalize();
        let want = DVec3::splat(STUDIO_BACKGROUND) + STUDIO_LIGHTS[0].2;
        assert!((Builtin::Studio.radiance(key) - want).length() < 1e-12);
        for b in Builtin::ALL {
            let m = b.map();
            assert_eq!((m.width(), m.height()), (BUILTIN_WIDTH, BUILTIN_HEIGHT));
            assert_eq!(Builtin::from_name(b.name()), Some(b));
        }
    }
}

/// Writes `map` as a lat-long OpenEXR file (float32 R, G, B, row 0 at +y, Mitsuba's `envmap`
/// layout), whole or not at all: the file `--env` reads back to the same texels, and that
/// Mitsuba's `envmap` lights the same way. `env` names the map in the header.
pub fn write_map(map: &EnvMap, env: &str, path: &Path) -> Result<()> {
    if path.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "--write-env {}: the map is written as OpenEXR, the name must end in .exr",
            path.display()
        );
    }
    let out = crate::output::Pending::new(path)?;
    let rgb: Vec<[f64; 3]> = map.texels().iter().map(|t| t.map(|c| c as f64)).collect();
    super::prefilter::encode_rgb(
        map.width(),
        map.height(),
        &rgb,
        &[
            ("lobe.kind", "env".to_string()),
            ("lobe.env", env.to_string()),
            (
                "lobe.layout",
                "lat-long, Mitsuba's envmap: +y up, u = atan2(x, -z) / 2pi, v = acos(y) / pi"
                    .to_string(),
            ),
        ],
        &out,
    )?;
    out.commit()
}
