//! Artifact sets: what lobe writes for one computed array (a lobe table, an albedo LUT, an engine
//! LUT), one [`FileSet`] of files that share the EXR's stem, committed in this order:
//!
//! - `PATH.npy`, and `PATH_SUFFIX.npy` for each further array (`PATH_avg.npy`): float32 `.npy`
//!   ([`super::npy`]), streamed chunk by chunk or written whole;
//! - `PATH.exr`: float32 layers, RLE in tiles ([`super::EXR_ENCODING`]), `lobe.*` header
//!   attributes in name order;
//! - `PATH.EXT` for each text file (`PATH.h`, a C header);
//! - `PATH.json`: the sidecar, last, since it is the set's record ([`super::set_json`]): the job's
//!   own fields and those every sidecar has ([`Provenance`]).
//!
//! A job says what its arrays, layers and fields are; the set owns the paths, the encodings and
//! the transaction. Every destination is checked before the first temporary file is made (so
//! before any work), every member is written to a temporary file, and nothing replaces what is
//! there until the set is committed: dropped before that (an error, an interruption), no file
//! appears and none is replaced.

use super::{encoder_error, npy, write_exr, FileSet, OutputWriter, EXR_ENCODING};
use anyhow::{bail, Result};
use exr::prelude::*;
use serde_json::Value;
use std::borrow::BorrowMut;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};

/// The file beside `exr_path` named by its stem, `suffix` and `ext`: `PATH.ext` for an empty
/// suffix, else `PATH{suffix}.ext` (`PATH_avg.npy`).
pub fn sibling(exr_path: &Path, suffix: &str, ext: &str) -> PathBuf {
    if suffix.is_empty() {
        return exr_path.with_extension(ext);
    }
    let stem = exr_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    exr_path.with_file_name(format!("{stem}{suffix}.{ext}"))
}

/// The last component of `p`, as sidecars name their files.
pub fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// An EXR text attribute; characters outside ASCII (which OpenEXR text cannot hold) become '?'.
pub fn exr_text(s: &str) -> AttributeValue {
    AttributeValue::Text(
        Text::new_or_none(s.replace(|c: char| !c.is_ascii(), "?")).unwrap_or_default(),
    )
}

/// Where a set's values come from: the fields every sidecar holds.
pub struct Provenance<'a> {
    /// The model's name (`"model"`).
    pub model: &'a str,
    /// Its parameters as JSON (`"parameters"`): all of them, or those the job keeps fixed.
    pub parameters: Value,
    /// Whether every specular Fresnel factor was 1 (`"white_furnace"`; docs/design.md §3).
    pub white_furnace: bool,
    /// The backend that evaluated it, as `Evaluator::name` says (`"backend"`).
    pub backend: &'a str,
}

/// One EXR layer of float32 channels, from values in memory.
pub struct ExrLayer<'a> {
    /// The layer's name.
    pub name: &'a str,
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The channels' names; the file stores them in name order.
    pub channels: &'a [&'a str],
    /// Row-major texels, `channels.len()` values each, interleaved.
    pub values: &'a [f32],
    /// `lobe.*` header attributes (name, text).
    pub attributes: &'a [(&'a str, String)],
}

/// The members of one artifact set staged in a [`FileSet`]: `S` is the set itself (the artifact
/// set commits it, [`ArtifactSet::create`]) or a borrow of a larger one that its owner commits
/// ([`ArtifactSet::stage`]).
pub struct ArtifactSet<S: BorrowMut<FileSet> = FileSet> {
    set: S,
    /// The index in `set` of the first member.
    first: usize,
    npy: Vec<PathBuf>,
    exr: PathBuf,
    text: Vec<PathBuf>,
    json: PathBuf,
}

impl ArtifactSet<FileSet> {
    /// A set of `kind` ([`super::TABLE_SET`], …) beside `exr_path`: an `.npy` for each of
    /// `npy_suffixes` ([`sibling`]; `""` is `PATH.npy`), the EXR, a text file for each of
    /// `text_exts`, the sidecar. Fails, naming the file, before any file is made when a
    /// destination cannot be written (see [`FileSet::add_set`]).
    pub fn create(
        kind: &str,
        exr_path: &Path,
        npy_suffixes: &[&str],
        text_exts: &[&str],
    ) -> Result<ArtifactSet> {
        ArtifactSet::in_set(FileSet::empty(), kind, exr_path, npy_suffixes, text_exts)
    }

    /// Writes the sidecar ([`ArtifactSet::finish`]) and commits the set: every member replaces
    /// its destination, or none does.
    pub fn commit(self, provenance: &Provenance, fields: Value) -> Result<()> {
        self.finish(provenance, fields)?.commit()
    }
}

impl<'s> ArtifactSet<&'s mut FileSet> {
    /// [`ArtifactSet::create`] into `set`, which commits it with whatever else it holds.
    pub fn stage(
        set: &'s mut FileSet,
        kind: &str,
        exr_path: &Path,
        npy_suffixes: &[&str],
        text_exts: &[&str],
    ) -> Result<ArtifactSet<&'s mut FileSet>> {
        ArtifactSet::in_set(set, kind, exr_path, npy_suffixes, text_exts)
    }
}

impl<S: BorrowMut<FileSet>> ArtifactSet<S> {
    fn in_set(
        mut set: S,
        kind: &str,
        exr_path: &Path,
        npy_suffixes: &[&str],
        text_exts: &[&str],
    ) -> Result<ArtifactSet<S>> {
        let npy: Vec<PathBuf> = npy_suffixes
            .iter()
            .map(|s| sibling(exr_path, s, "npy"))
            .collect();
        let text: Vec<PathBuf> = text_exts
            .iter()
            .map(|ext| sibling(exr_path, "", ext))
            .collect();
        let json = sibling(exr_path, "", "json");
        let dests = member_order(&npy, exr_path, &text, &json);
        let first = set.borrow_mut().add_set(kind, &dests, dests.len() - 1)?;
        Ok(ArtifactSet {
            set,
            first,
            npy,
            exr: exr_path.to_path_buf(),
            text,
            json,
        })
    }

    /// Every member's destination in commit order: the `.npy` files, the EXR, the text files,
    /// the sidecar.
    pub fn paths(&self) -> Vec<&Path> {
        member_order(&self.npy, &self.exr, &self.text, &self.json)
    }

    /// The `k`th `.npy` file's destination.
    pub fn npy_path(&self, k: usize) -> &Path {
        &self.npy[k]
    }

    /// The EXR's destination.
    pub fn exr_path(&self) -> &Path {
        &self.exr
    }

    /// The sidecar's destination.
    pub fn json_path(&self) -> &Path {
        &self.json
    }

    /// The first destination, in the order EXR, `.npy` files, text files, sidecar, where a file
    /// exists already.
    pub fn existing(&self) -> Option<&Path> {
        std::iter::once(self.exr.as_path())
            .chain(self.npy.iter().map(PathBuf::as_path))
            .chain(self.text.iter().map(PathBuf::as_path))
            .chain([self.json.as_path()])
            .find(|p| p.exists())
    }

    /// The staged file of member `k` (commit order).
    fn member(&self, k: usize) -> &super::Pending {
        &self.set.borrow()[self.first + k]
    }

    /// Writes the `k`th `.npy` file whole: `values`, row-major over `shape`.
    pub fn npy(&self, k: usize, shape: &[usize], values: &[f32]) -> Result<()> {
        if shape.iter().product::<usize>() != values.len() {
            bail!(
                "{}: {} values do not fill the shape {shape:?}",
                self.npy[k].display(),
                values.len()
            );
        }
        let mut s = self.npy_stream(k, shape)?;
        s.write(values)?;
        s.finish()
    }

    /// Starts the `k`th `.npy` file, an array of `shape` whose values follow in row-major order
    /// through [`NpyStream::write`].
    pub fn npy_stream(&self, k: usize, shape: &[usize]) -> Result<NpyStream<'_>> {
        let dest = &self.npy[k];
        let mut w = self.member(k).writer();
        let header = npy::header(shape);
        w.write_all(&header)
            .map_err(|e| encoder_error(dest, "npy", e))?;
        let start = header.len() as u64;
        Ok(NpyStream {
            w,
            dest,
            start,
            at: start,
        })
    }

    /// Writes the EXR from layers in memory; the image's size is the first layer's.
    pub fn exr(&self, layers: &[ExrLayer]) -> Result<()> {
        let Some(first) = layers.first() else {
            bail!("{}: an EXR needs a layer", self.exr.display());
        };
        let bounds = IntegerBounds::from_dimensions((first.width, first.height));
        let layers: Vec<_> = layers.iter().map(channels_layer).collect();
        let image = Image::from_layers(ImageAttributes::new(bounds), Layers::from_vec(layers));
        write_exr(self.member(self.npy.len()), |w| {
            image.write().to_buffered(w)
        })
    }

    /// Writes the EXR as one RGB layer `name` of `width × height` pixels from the finished
    /// `npy`th `.npy` file (RGB triples), pixel (x, y) holding its cell `cell(x, y)`. The `.npy`
    /// is read through a memory map, so no step holds the whole array in memory.
    pub fn exr_rgb_from_npy(
        &self,
        npy: usize,
        name: &str,
        (width, height): (usize, usize),
        cell: &(dyn Fn(usize, usize) -> usize + Sync),
        attributes: &[(&str, String)],
    ) -> Result<()> {
        let file = std::fs::File::open(self.member(npy).path())?;
        // SAFETY: the temporary file is ours alone and is not modified while mapped.
        let map = unsafe { memmap2::Mmap::map(&file)? };
        let (_, offset) = npy::parse_header(&map)?;
        let data: &[u8] = &map[offset..];
        let value = |cell: usize, c: usize| {
            let b = &data[(cell * 3 + c) * 4..(cell * 3 + c) * 4 + 4];
            f32::from_le_bytes([b[0], b[1], b[2], b[3]])
        };
        let channels = SpecificChannels::rgb(|Vec2(x, y)| {
            let cell = cell(x, y);
            (value(cell, 0), value(cell, 1), value(cell, 2))
        });
        let mut layer = Layer::new(
            (width, height),
            LayerAttributes::named(name),
            EXR_ENCODING,
            channels,
        );
        insert_attributes(&mut layer.attributes, attributes);
        write_exr(self.member(self.npy.len()), |w| {
            Image::from_layer(layer).write().to_buffered(w)
        })
    }

    /// Writes the `k`th text file.
    pub fn text(&self, k: usize, contents: &str) -> Result<()> {
        self.write_member(self.npy.len() + 1 + k, &self.text[k], "text", contents)
    }

    /// Writes the sidecar: `fields` (a JSON object) with the [`Provenance`] fields added, as
    /// pretty JSON; the commit adds the set's record (`"set"`). Returns the [`FileSet`] (or its
    /// borrow) to commit.
    pub fn finish(self, provenance: &Provenance, mut fields: Value) -> Result<S> {
        let Some(object) = fields.as_object_mut() else {
            bail!("{}: a sidecar is a JSON object", self.json.display());
        };
        let common = [
            ("model", Value::from(provenance.model)),
            ("parameters", provenance.parameters.clone()),
            ("white_furnace", Value::from(provenance.white_furnace)),
            ("backend", Value::from(provenance.backend)),
        ];
        for (key, value) in common {
            if object.insert(key.into(), value).is_some() {
                bail!(
                    "{}: the sidecar field {key} is given twice",
                    self.json.display()
                );
            }
        }
        let text = serde_json::to_string_pretty(&fields)? + "\n";
        let last = self.npy.len() + 1 + self.text.len();
        self.write_member(last, &self.json, "JSON", &text)?;
        Ok(self.set)
    }

    fn write_member(&self, k: usize, dest: &Path, encoder: &str, contents: &str) -> Result<()> {
        let mut w = self.member(k).writer();
        w.write_all(contents.as_bytes())
            .map_err(|e| encoder_error(dest, encoder, e))?;
        w.finish()
    }
}

/// The members in commit order: the `.npy` files, the EXR, the text files, the sidecar (the set's
/// record, last).
fn member_order<'a>(
    npy: &'a [PathBuf],
    exr: &'a Path,
    text: &'a [PathBuf],
    json: &'a Path,
) -> Vec<&'a Path> {
    (npy.iter().map(PathBuf::as_path))
        .chain([exr])
        .chain(text.iter().map(PathBuf::as_path))
        .chain([json])
        .collect()
}

/// A `.npy` file being streamed ([`ArtifactSet::npy_stream`]).
pub struct NpyStream<'a> {
    w: OutputWriter<'a>,
    dest: &'a Path,
    /// Where the values begin (the header's length) and where the next write lands, in bytes.
    start: u64,
    at: u64,
}

impl NpyStream<'_> {
    /// Appends `values` (row-major, continuing where the last call ended).
    pub fn write(&mut self, values: &[f32]) -> Result<()> {
        npy::write_f32(&mut self.w, values).map_err(|e| encoder_error(self.dest, "npy", e))?;
        self.at += values.len() as u64 * 4;
        Ok(())
    }

    /// Writes `values` from value index `first` on (row-major), seeking only where the last
    /// write did not end there: runs of a table may arrive out of order.
    pub fn write_at(&mut self, first: u64, values: &[f32]) -> Result<()> {
        let place = self.start + first * 4;
        if self.at != place {
            self.w
                .seek(std::io::SeekFrom::Start(place))
                .map_err(|e| encoder_error(self.dest, "npy", e))?;
            self.at = place;
        }
        self.write(values)
    }

    /// Flushes the file; a late write error is not lost. Whether the values fill the shape is
    /// the caller's to keep.
    pub fn finish(self) -> Result<()> {
        self.w.finish()
    }
}

/// One EXR layer of `l`'s channels (exr keeps them in name order).
fn channels_layer(l: &ExrLayer) -> Layer<AnyChannels<FlatSamples>> {
    let n = l.channels.len();
    let channels = (l.channels.iter().enumerate())
        .map(|(c, &ch)| {
            let samples = l.values.iter().skip(c).step_by(n).copied().collect();
            AnyChannel::new(ch, FlatSamples::F32(samples))
        })
        .collect();
    let mut layer = Layer::new(
        (l.width, l.height),
        LayerAttributes::named(l.name),
        EXR_ENCODING,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    insert_attributes(&mut layer.attributes, l.attributes);
    layer
}

fn insert_attributes(attributes: &mut LayerAttributes, list: &[(&str, String)]) {
    for (k, v) in list {
        attributes.other.insert(Text::new_or_panic(*k), exr_text(v));
    }
}
