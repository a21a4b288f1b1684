//! Output as transactions: every file or set of files lobe writes appears complete, from one run,
//! or not at all, and what was there before stays until the new files are all in place.
//!
//! A file is written to a temporary file in its destination's folder (the same file system, so
//! the final step is a rename, which replaces the destination in one step) and renamed into place
//! only once it and every file of its set are complete. Dropped before that (an error, a failed
//! write part-way such as a full disk, or an interruption), the temporary file is removed and the
//! destination keeps what it held before.
//!
//! - [`Pending`]: one file; [`write_atomic`] wraps the common case of one writer.
//! - [`FileSet`]: files that belong together (a table's `.exr`, `.npy` and `.json`, a scene's
//!   outputs). [`FileSet::commit`] is the transaction:
//!   1. it takes an advisory lock (`flock`) on every destination folder, in one order, so that two
//!      processes writing one set take turns and the set comes from one of them;
//!   2. it checks every destination before the first rename: no folder in the way, no read-only
//!      file (lobe does not replace those), and the old file can be kept aside (a hard link, or a
//!      rename where links are not possible; an immutable file refuses both);
//!   3. it renames the new files into place; should a rename still fail, the files already
//!      replaced get their old contents back and the new ones are removed.
//!
//!   The commit flushes the new files and writes a record first, so that a process killed
//!   part-way leaves what the next run completes (`output/commit.rs`), and it
//!   refuses to overwrite a member of another set (`output/owner.rs`).
//!
//!   Names a file system cannot hold are found earlier: each temporary name is as long as its
//!   destination's, so a name that is too long fails when the set is created, before any work.
//! - [`ArtifactSet`]: the files of one computed array (a table, a LUT) in one set: `.npy` files,
//!   an EXR, text files and a JSON sidecar beside the EXR, with their encodings
//!   (`output/artifacts.rs`; `.npy` in [`npy`]).
//! - [`StagingFolder`]: a whole folder of output, built beside its destination and moved into it
//!   once every file is there, by the same transaction.
//!
//! New files and folders get the permissions the process's umask gives a plainly created file
//! (0666 and 0777 less the umask).
//!
//! Interruption is process-wide: [`interrupt`] (the command line calls it on Ctrl-C, SIGTERM and
//! SIGHUP) makes every [`OutputWriter`] fail at its next write, so encoders stop part-way, and
//! every commit not yet started refuse; [`remove_staged`] removes every temporary file and
//! staging folder at once, for a process about to exit without unwinding.
//!
//! Temporary names start with `.lobe-`, so that a run killed outright (where no cleanup runs)
//! leaves files that are easy to recognise.

mod exr_header;

#[cfg(test)]
mod artifact_tests;
mod artifacts;
mod commit;
pub mod npy;
mod owner;
mod pending;
mod set;
mod staging;
#[cfg(test)]
mod tests;

use crate::interrupt::Interrupted;
use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};

pub use artifacts::{exr_text, file_name, sibling, ArtifactSet, ExrLayer, NpyStream, Provenance};
pub use exr_header::sort_attributes as sort_exr_attributes;
pub use owner::{replace_sets, set_json, ENGINE_LUT_SET, LUT_SET, SAMPLES_SET, TABLE_SET};
pub use pending::{write_atomic, write_exr, OutputWriter, Pending};
pub use set::FileSet;
pub use staging::{check_folder_destination, StagingFolder};

/// The EXR encoding of lobe's images: RLE in 64 × 64 tiles (lossless and fast, as exr's
/// `FAST_LOSSLESS`), with the tiles in increasing order: the encoder compresses in parallel, and
/// an unspecified order would write them as they finish, differently from run to run.
pub const EXR_ENCODING: exr::image::Encoding = exr::image::Encoding {
    line_order: exr::meta::attribute::LineOrder::Increasing,
    ..exr::image::Encoding::FAST_LOSSLESS
};

/// The folder `dest` goes into (`.` for a bare file name).
pub fn folder_of(dest: &Path) -> &Path {
    match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The mode new files are created with, before the umask.
#[cfg(unix)]
const FILE_MODE: u32 = 0o666;
/// The mode new folders are created with, before the umask.
#[cfg(unix)]
const FOLDER_MODE: u32 = 0o777;

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Everything staged and not yet committed or removed: what [`remove_staged`] removes.
struct Registry {
    next: u64,
    staged: BTreeMap<u64, (PathBuf, bool)>,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    next: 0,
    staged: BTreeMap::new(),
});

fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Notes a staged path (a file, or a folder when `folder`), returning its key.
fn register(path: &Path, folder: bool) -> u64 {
    let mut reg = registry();
    reg.next += 1;
    let id = reg.next;
    reg.staged.insert(id, (path.to_path_buf(), folder));
    id
}

fn unregister(id: u64) {
    registry().staged.remove(&id);
}

/// Stops all output of this process: every [`OutputWriter`] fails at its next write and every
/// commit not yet started refuses with [`Interrupted`]; new temporary files are refused too. For
/// a signal handler: there is no way back.
pub fn interrupt() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}

/// Whether [`interrupt`] was called.
pub fn is_interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Calls [`interrupt`], waits for a commit under way to finish (a set is never left half
/// renamed), then removes every temporary file and staging folder of this process; returns how
/// many it removed. For a process about to exit without unwinding (a second Ctrl-C).
pub fn remove_staged() -> usize {
    interrupt();
    let mut reg = registry();
    let staged = std::mem::take(&mut reg.staged);
    let mut removed = 0;
    for (path, folder) in staged.into_values() {
        let gone = if folder {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        removed += usize::from(gone.is_ok());
    }
    removed
}

/// The error an encoder's failure becomes: [`Interrupted`] when output was interrupted (the
/// writer refused), else the encoder's message with the file it was writing.
pub fn encoder_error(dest: &Path, encoder: &str, e: impl std::fmt::Display) -> anyhow::Error {
    if is_interrupted() {
        anyhow::Error::new(Interrupted)
    } else {
        anyhow::anyhow!("writing {}: {encoder}: {e}", dest.display())
    }
}

/// The name of a temporary file for a destination named `name`: `.lobe-`, six random
/// characters, `-`, then as much of `name` as makes the temporary name exactly as long as `name`
/// (so that a name too long for the file system fails here, before any work), then `suffix`.
fn temp_affixes(name: &[u8], suffix: &str) -> (String, String) {
    const PREFIX: &str = ".lobe-";
    const RANDOM: usize = 6;
    let overhead = PREFIX.len() + RANDOM + 1 + suffix.len();
    let fill: String = name
        .iter()
        .take(name.len().saturating_sub(overhead))
        .map(|&b| {
            if b.is_ascii_alphanumeric() || b == b'_' || b == b'.' {
                b as char
            } else {
                '_'
            }
        })
        .collect();
    (PREFIX.to_string(), format!("-{fill}{suffix}"))
}

fn temp_builder<'a>(prefix: &'a str, suffix: &'a str) -> tempfile::Builder<'a, 'a> {
    let mut b = tempfile::Builder::new();
    b.prefix(prefix).suffix(suffix).rand_bytes(6);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(FILE_MODE));
    }
    b
}

/// Refuses a destination that no rename should replace: a folder, or a read-only file.
fn check_replaceable(dest: &Path) -> Result<()> {
    let Ok(meta) = std::fs::symlink_metadata(dest) else {
        return Ok(());
    };
    if meta.is_dir() {
        bail!(
            "cannot write {}: a folder of that name is in the way",
            dest.display()
        );
    }
    if !meta.file_type().is_symlink() && meta.permissions().readonly() {
        bail!(
            "cannot write {}: the file there is read-only, and lobe does not replace read-only files; make it writable (chmod u+w) or remove it",
            dest.display()
        );
    }
    Ok(())
}

/// Checks, before any work, that `dest` can be written: no folder of that name, no read-only file
/// there, no file in the way of its folder, and no member of a set of a kind unless sets are
/// replaced ([`replace_sets`]).
pub fn check_destination(dest: &Path) -> Result<()> {
    check_replaceable(dest)?;
    owner::check_single(dest)?;
    let mut at = Some(folder_of(dest));
    while let Some(p) = at.filter(|p| !p.as_os_str().is_empty()) {
        if p.exists() {
            if !p.is_dir() {
                bail!(
                    "cannot write {}: the file {} is in the way of its folder",
                    dest.display(),
                    p.display()
                );
            }
            break;
        }
        at = p.parent();
    }
    Ok(())
}

/// `path` as it resolves on disk: its folder's canonical path and its name (the file itself may
/// not exist yet); `path` itself when its folder cannot be resolved.
pub fn resolve(path: &Path) -> PathBuf {
    #[cfg(test)]
    RESOLVES.with(|n| n.set(n.get() + 1));
    match (std::fs::canonicalize(folder_of(path)), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// Why `dir`, which is not a folder, cannot hold a file: it is something else, or the first of
/// its ancestors that exists is a file, or it is missing.
fn why_not_a_folder(dir: &Path) -> String {
    if dir.exists() {
        return format!("{} is not a folder", dir.display());
    }
    let file_above = dir
        .ancestors()
        .skip(1)
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| a.exists())
        .filter(|a| !a.is_dir());
    match file_above {
        Some(file) => format!(
            "the folder {} cannot exist: {} is a file, not a folder",
            dir.display(),
            file.display()
        ),
        None => format!("the folder {} does not exist", dir.display()),
    }
}

/// `create_dir_all` that notes, in `made`, every folder it created (outermost first).
fn create_folders(dir: &Path, made: &mut Vec<PathBuf>) -> Result<()> {
    let mut missing = Vec::new();
    let mut at = Some(dir);
    while let Some(p) = at.filter(|p| !p.as_os_str().is_empty()) {
        match std::fs::symlink_metadata(p) {
            Ok(m) if m.is_dir() => break,
            Ok(m) if m.file_type().is_symlink() && p.is_dir() => break,
            Ok(_) => bail!(
                "cannot create the folder {}: a file of that name is in the way",
                p.display()
            ),
            Err(_) => missing.push(p.to_path_buf()),
        }
        at = p.parent();
    }
    for p in missing.into_iter().rev() {
        let mut b = std::fs::DirBuilder::new();
        #[cfg(unix)]
        {
            use std::os::unix::fs::DirBuilderExt;
            b.mode(FOLDER_MODE);
        }
        match b.create(&p) {
            Ok(()) => made.push(p),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && p.is_dir() => {}
            Err(e) => {
                return Err(e).with_context(|| format!("creating the folder {}", p.display()))
            }
        }
    }
    Ok(())
}

/// Removes the folders in `made` (outermost first) that are still empty, innermost first.
fn remove_created(made: &[PathBuf]) {
    for p in made.iter().rev() {
        let _ = std::fs::remove_dir(p);
    }
}

/// Advisory locks (`flock`, released when the files close) on each distinct folder of `dirs`,
/// taken in one order (by device and inode) so that processes locking overlapping folders cannot
/// deadlock. The lock is what keeps two runs writing one set from mixing their files, so a folder
/// that cannot be opened or locked is refused ([`open_folder_lock`]), never passed over.
fn lock_folders<'a>(dirs: impl Iterator<Item = &'a Path>) -> Result<Vec<File>> {
    let mut open: Vec<((u64, u64), File)> = Vec::new();
    for d in dirs {
        let f = open_folder_lock(d)?;
        let key = folder_key(&f);
        if !open.iter().any(|(k, _)| *k == key) {
            open.push((key, f));
        }
    }
    open.sort_by_key(|(k, _)| *k);
    open.into_iter()
        .map(|(_, f)| f.lock().map(|()| f))
        .collect::<io::Result<Vec<File>>>()
        .context("cannot lock an output folder against other lobe runs")
}

/// The folder `dir` opened for its lock. A folder that can be written but not read (mode 733)
/// cannot be opened, and with no lock two runs could each commit part of one set: refused, as
/// early as a file is staged there and again at the commit.
fn open_folder_lock(dir: &Path) -> Result<File> {
    File::open(dir).map_err(|e| {
        anyhow::anyhow!(
            "cannot lock the output folder {} ({e}): lobe locks the folder it writes in, so that \
             two runs cannot mix their files, and needs to read the folder for that; make it \
             readable or write elsewhere",
            dir.display()
        )
    })
}

#[cfg(unix)]
fn folder_key(f: &File) -> (u64, u64) {
    use std::os::unix::fs::MetadataExt;
    f.metadata().map(|m| (m.dev(), m.ino())).unwrap_or((0, 0))
}

#[cfg(not(unix))]
fn folder_key(_: &File) -> (u64, u64) {
    (0, 0)
}

#[cfg(test)]
thread_local! {
    /// How many times [`resolve`] ran on this thread (each is a `canonicalize`, a walk of the
    /// path on disk).
    static RESOLVES: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}
