//! One file written through a temporary file beside its destination.

use super::commit::recover_folder;
use super::owner::check_single;
use super::{
    check_replaceable, encoder_error, folder_of, is_interrupted, open_folder_lock, register,
    sort_exr_attributes, temp_affixes, temp_builder, unregister, why_not_a_folder,
};
use crate::interrupt::Interrupted;
use anyhow::{bail, Context, Result};
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A file being written: a temporary file beside its destination, renamed onto it by
/// [`Pending::commit`] (or its [`FileSet`](super::FileSet)'s commit); dropped without a commit, it is removed.
pub struct Pending {
    pub(super) tmp: Option<tempfile::NamedTempFile>,
    pub(super) id: u64,
    pub(super) dest: PathBuf,
}

impl Pending {
    /// A temporary file `.lobe-*.partial` beside `dest`. Fails, naming `dest`, when its folder
    /// does not exist or no file can be created there, when the name is too long for the file
    /// system, when `dest` is a folder or a read-only file, and once output is interrupted.
    /// A member of a set (see [`FileSet::add_set`](super::FileSet::add_set)) is refused too, unless sets are replaced
    /// ([`super::replace_sets`]).
    pub fn new(dest: &Path) -> Result<Pending> {
        check_single(dest)?;
        Pending::with_suffix(dest, ".partial")
    }

    /// As [`Pending::new`], but the temporary name ends in `.ext`, for writers that pick their
    /// format from the name of the file they are given (plotters' PNG backend).
    pub fn with_extension(dest: &Path, ext: &str) -> Result<Pending> {
        check_single(dest)?;
        Pending::with_suffix(dest, &format!(".{ext}"))
    }

    /// [`Pending::new`] without the check of which set owns `dest`: for a [`FileSet`](super::FileSet), which
    /// checks its members as sets.
    pub(super) fn with_suffix(dest: &Path, suffix: &str) -> Result<Pending> {
        if is_interrupted() {
            return Err(Interrupted.into());
        }
        let dir = folder_of(dest);
        if !dir.is_dir() {
            bail!("cannot write {}: {}", dest.display(), why_not_a_folder(dir));
        }
        open_folder_lock(dir).with_context(|| format!("cannot write {}", dest.display()))?;
        recover_folder(dir);
        check_replaceable(dest)?;
        let name = dest
            .file_name()
            .map(|n| n.as_encoded_bytes())
            .unwrap_or(b"");
        let (prefix, suffix) = temp_affixes(name, suffix);
        // A run cleaning up after dead runs removes the temporary files it can lock: one made
        // here and removed before this run locked it is made again.
        let mut attempts = 0;
        let tmp = loop {
            let tmp = temp_builder(&prefix, &suffix)
                .tempfile_in(dir)
                .map_err(|e| temp_error(e, dest, dir, name.len()))?;
            attempts += 1;
            if held(tmp.as_file(), tmp.path()) || attempts == MAX_TEMP_ATTEMPTS {
                break tmp;
            }
        };
        // Held while the file lives: how a later run tells it from one left by a run that died.
        if !held(tmp.as_file(), tmp.path()) {
            bail!(
                "cannot write {}: no temporary file in {} could be locked",
                dest.display(),
                dir.display()
            );
        }
        let id = register(tmp.path(), false);
        Ok(Pending {
            tmp: Some(tmp),
            id,
            dest: dest.to_path_buf(),
        })
    }

    fn tmp(&self) -> &tempfile::NamedTempFile {
        self.tmp
            .as_ref()
            .expect("a pending file has its temporary file until it is consumed")
    }

    /// The temporary file, open for reading and writing.
    pub fn file(&self) -> &File {
        self.tmp().as_file()
    }

    /// A buffered writer on the temporary file that fails once output is interrupted.
    pub fn writer(&self) -> OutputWriter<'_> {
        OutputWriter {
            inner: BufWriter::new(self.file()),
            dest: &self.dest,
        }
    }

    /// The temporary file's path, for writers that open the file themselves (and for reading back
    /// what was written).
    pub fn path(&self) -> &Path {
        self.tmp().path()
    }

    /// Where the file goes.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Puts the header attributes of this finished EXR in name order: see
    /// [`sort_exr_attributes`].
    fn sort_exr(&self) -> Result<()> {
        sort_exr_attributes(self.file()).with_context(|| format!("writing {}", self.dest.display()))
    }
}

/// How many temporary files [`Pending::new`] makes before giving up when each is removed under it.
const MAX_TEMP_ATTEMPTS: usize = 8;

/// Locks `file`, just made at `path`, for as long as it is open, and says whether `path` is still
/// that file (not removed under it by a run cleaning up before the lock was taken).
pub(super) fn held(file: &File, path: &Path) -> bool {
    if file.try_lock().is_err() {
        return false;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::symlink_metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        path.exists()
    }
}

/// The error of a temporary file that could not be made for `dest` in `dir`.
fn temp_error(e: io::Error, dest: &Path, dir: &Path, name_len: usize) -> anyhow::Error {
    // ENAMETOOLONG: the temporary name is as long as the destination's.
    if e.kind() == io::ErrorKind::InvalidFilename {
        anyhow::anyhow!(
            "cannot write {}: the name is too long for the file system ({name_len} bytes)",
            dest.display()
        )
    } else {
        // The temporary-file error repeats its path once per attempt: the OS error alone says
        // what went wrong.
        let cause = e
            .raw_os_error()
            .map_or(e.kind().into(), io::Error::from_raw_os_error);
        anyhow::anyhow!(
            "cannot write {}: creating a file in {} failed: {cause}",
            dest.display(),
            dir.display()
        )
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            drop(tmp);
            unregister(self.id);
        }
    }
}

/// A buffered writer on a [`Pending`] file that fails at its next write once output is
/// interrupted ([`interrupt`](super::interrupt)), so that a long encoding stops part-way. Call
/// [`OutputWriter::finish`] at the end: a late write error is not lost.
pub struct OutputWriter<'a> {
    inner: BufWriter<&'a File>,
    dest: &'a Path,
}

impl OutputWriter<'_> {
    /// Flushes the buffer; the error names the destination.
    pub fn finish(mut self) -> Result<()> {
        self.flush()
            .map_err(|e| encoder_error(self.dest, "flushing", e))
    }
}

impl Write for OutputWriter<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if is_interrupted() {
            // Not ErrorKind::Interrupted, which write_all retries.
            return Err(io::Error::other(Interrupted));
        }
        self.inner.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl Seek for OutputWriter<'_> {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.inner.seek(pos)
    }
}

/// Writes `dest` through `write`, which gets an [`OutputWriter`] on a [`Pending`] file; the
/// buffer is flushed (so a late write error is not lost) and the file committed only when `write`
/// succeeds. Returns what `write` returns.
pub fn write_atomic<T>(
    dest: &Path,
    write: impl FnOnce(&mut OutputWriter) -> Result<T>,
) -> Result<T> {
    let pending = Pending::new(dest)?;
    let value = {
        let mut w = pending.writer();
        let value = write(&mut w).map_err(|e| {
            if is_interrupted() {
                anyhow::Error::new(Interrupted)
            } else {
                e
            }
        })?;
        w.finish()?;
        value
    };
    pending.commit()?;
    Ok(value)
}

/// Encodes an EXR into `pending` through `encode` (given an [`OutputWriter`]: the encoding stops
/// at its next chunk once output is interrupted), then puts the header's attributes in name order
/// so that one input gives the same bytes every run (exr keeps custom attributes in a hash map,
/// whose order changes from run to run). Use [`EXR_ENCODING`](super::EXR_ENCODING) for the layers.
pub fn write_exr(
    pending: &Pending,
    encode: impl FnOnce(&mut OutputWriter) -> exr::error::UnitResult,
) -> Result<()> {
    let mut w = pending.writer();
    encode(&mut w).map_err(|e| encoder_error(pending.dest(), "EXR encoder", e))?;
    w.finish()?;
    pending.sort_exr()
}
