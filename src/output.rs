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
//!   Names a file system cannot hold are found earlier: each temporary name is as long as its
//!   destination's, so a name that is too long fails when the set is created, before any work.
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

use crate::interrupt::Interrupted;
use anyhow::{bail, Context, Result};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};

pub use exr_header::sort_attributes as sort_exr_attributes;

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
/// there, no file in the way of its folder.
pub fn check_destination(dest: &Path) -> Result<()> {
    check_replaceable(dest)?;
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

/// A file being written: a temporary file beside its destination, renamed onto it by
/// [`Pending::commit`] (or its [`FileSet`]'s commit); dropped without a commit, it is removed.
pub struct Pending {
    tmp: Option<tempfile::NamedTempFile>,
    id: u64,
    dest: PathBuf,
}

impl Pending {
    /// A temporary file `.lobe-*.partial` beside `dest`. Fails, naming `dest`, when its folder
    /// does not exist or no file can be created there, when the name is too long for the file
    /// system, when `dest` is a folder or a read-only file, and once output is interrupted.
    pub fn new(dest: &Path) -> Result<Pending> {
        Pending::with_suffix(dest, ".partial")
    }

    /// As [`Pending::new`], but the temporary name ends in `.ext`, for writers that pick their
    /// format from the name of the file they are given (plotters' PNG backend).
    pub fn with_extension(dest: &Path, ext: &str) -> Result<Pending> {
        Pending::with_suffix(dest, &format!(".{ext}"))
    }

    fn with_suffix(dest: &Path, suffix: &str) -> Result<Pending> {
        if is_interrupted() {
            return Err(Interrupted.into());
        }
        let dir = folder_of(dest);
        if !dir.is_dir() {
            bail!("cannot write {}: {}", dest.display(), why_not_a_folder(dir));
        }
        open_folder_lock(dir).with_context(|| format!("cannot write {}", dest.display()))?;
        check_replaceable(dest)?;
        let name = dest
            .file_name()
            .map(|n| n.as_encoded_bytes())
            .unwrap_or(b"");
        let (prefix, suffix) = temp_affixes(name, suffix);
        let tmp = temp_builder(&prefix, &suffix)
            .tempfile_in(dir)
            .map_err(|e| {
                // ENAMETOOLONG: the temporary name is as long as the destination's.
                if e.kind() == io::ErrorKind::InvalidFilename {
                    anyhow::anyhow!(
                        "cannot write {}: the name is too long for the file system ({} bytes)",
                        dest.display(),
                        name.len()
                    )
                } else {
                    // The temporary-file error repeats its path once per attempt: the OS error
                    // alone says what went wrong.
                    let cause = e
                        .raw_os_error()
                        .map_or(e.kind().into(), io::Error::from_raw_os_error);
                    anyhow::anyhow!(
                        "cannot write {}: creating a file in {} failed: {cause}",
                        dest.display(),
                        dir.display()
                    )
                }
            })?;
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

    /// Renames the finished file onto its destination: a [`FileSet`] of one.
    pub fn commit(self) -> Result<()> {
        let mut set = FileSet::empty();
        set.files.push(self);
        set.commit()
    }

    /// Puts the header attributes of this finished EXR in name order: see
    /// [`sort_exr_attributes`].
    fn sort_exr(&self) -> Result<()> {
        sort_exr_attributes(self.file()).with_context(|| format!("writing {}", self.dest.display()))
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
/// interrupted ([`interrupt`]), so that a long encoding stops part-way. Call
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
/// whose order changes from run to run). Use [`EXR_ENCODING`] for the layers.
pub fn write_exr(
    pending: &Pending,
    encode: impl FnOnce(&mut OutputWriter) -> exr::error::UnitResult,
) -> Result<()> {
    let mut w = pending.writer();
    encode(&mut w).map_err(|e| encoder_error(pending.dest(), "EXR encoder", e))?;
    w.finish()?;
    pending.sort_exr()
}

/// Files that are only correct together, committed as one transaction (see the module's notes):
/// all of them replace their destinations, or none does.
pub struct FileSet {
    files: Vec<Pending>,
    /// Each file's destination as it resolves on disk ([`resolve`], made once as it is added),
    /// with its index: a set of thousands of files finds a repeated destination in one look-up.
    resolved: HashMap<PathBuf, usize>,
    /// Folders this set created, removed again (when empty) if it is not committed.
    folders: Vec<PathBuf>,
}

impl FileSet {
    /// A [`Pending`] file for each of `dests`, which [`FileSet::commit`] renames in this order
    /// (put the file that marks the set complete, such as a sidecar, last); `set[k]` is the
    /// file for `dests[k]`. Every destination is checked before any file is created.
    pub fn new(dests: &[&Path]) -> Result<FileSet> {
        for dest in dests {
            check_replaceable(dest)?;
        }
        let mut set = FileSet::empty();
        for dest in dests {
            set.add(dest)?;
        }
        Ok(set)
    }

    /// A set with no files yet.
    pub fn empty() -> FileSet {
        FileSet {
            files: Vec::new(),
            resolved: HashMap::new(),
            folders: Vec::new(),
        }
    }

    /// Adds a [`Pending`] file for `dest` (see [`Pending::new`]), returning its index; a
    /// destination already in the set, however written (`./t.json` and `t.json`), is refused.
    pub fn add(&mut self, dest: &Path) -> Result<usize> {
        let resolved = resolve(dest);
        if let Some(&other) = self.resolved.get(&resolved) {
            bail!(
                "cannot write {}: the same file as {} in one set",
                dest.display(),
                self.files[other].dest.display()
            );
        }
        self.files.push(Pending::new(dest)?);
        self.resolved.insert(resolved, self.files.len() - 1);
        Ok(self.files.len() - 1)
    }

    /// Creates `dir` and the missing folders above it (with the umask's permissions); those this
    /// call made are removed again, when empty, if the set is dropped without a commit.
    pub fn create_folder(&mut self, dir: &Path) -> Result<()> {
        create_folders(dir, &mut self.folders)
    }

    /// How many files the set holds.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether the set holds no file.
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// Renames every file onto its destination, in order, as one transaction (see the module's
    /// notes): all or none, the old files back if a step fails.
    pub fn commit(mut self) -> Result<()> {
        let files = std::mem::take(&mut self.files);
        let moves: Vec<Move> = files
            .iter()
            .map(|p| Move {
                from: p.path().to_path_buf(),
                to: p.dest.clone(),
            })
            .collect();
        let locks = lock_folders(moves.iter().map(|m| folder_of(&m.to)))?;
        let mut reg = registry();
        let result = if is_interrupted() {
            Err(Interrupted.into())
        } else {
            move_all(&moves)
        };
        if result.is_ok() {
            for p in &files {
                reg.staged.remove(&p.id);
            }
            self.folders.clear();
        }
        drop(reg);
        drop(locks);
        for mut p in files {
            if result.is_ok() {
                if let Some(tmp) = p.tmp.take() {
                    // Renamed away: nothing to remove.
                    let _ = tmp.into_temp_path().keep();
                }
            }
        }
        result
    }
}

impl Drop for FileSet {
    fn drop(&mut self) {
        self.files.clear();
        remove_created(&self.folders);
    }
}

impl std::ops::Index<usize> for FileSet {
    type Output = Pending;

    fn index(&self, k: usize) -> &Pending {
        &self.files[k]
    }
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

/// One rename of a transaction.
struct Move {
    from: PathBuf,
    to: PathBuf,
}

/// Where an old destination is kept while its transaction runs.
struct Backup {
    path: PathBuf,
    /// Moved aside (the destination is missing until the new file arrives), rather than linked.
    aside: bool,
}

#[cfg(test)]
thread_local! {
    /// How many times [`resolve`] ran on this thread (each is a `canonicalize`, a walk of the
    /// path on disk).
    static RESOLVES: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

#[cfg(test)]
thread_local! {
    /// The rename (by index) that fails, to exercise the way back.
    static FAIL_RENAME_AT: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Keeps the old `to` aside when there is one; fails (changing nothing) when `to` cannot be
/// replaced.
fn keep_old(to: &Path) -> Result<Option<Backup>> {
    if std::fs::symlink_metadata(to).is_err() {
        return Ok(None);
    }
    check_replaceable(to)?;
    let dir = folder_of(to);
    let builder = temp_builder(".lobe-", ".old");
    if let Ok(link) = builder.make_in(dir, |p| std::fs::hard_link(to, p)) {
        let path = link.into_temp_path().keep()?;
        return Ok(Some(Backup { path, aside: false }));
    }
    // No hard links here (or none allowed for this file): move the old file aside instead.
    let slot = builder
        .make_in(dir, |p| File::create_new(p))
        .with_context(|| {
            format!(
                "cannot replace {}: creating a file in {} failed",
                to.display(),
                dir.display()
            )
        })?
        .into_temp_path()
        .keep()?;
    match std::fs::rename(to, &slot) {
        Ok(()) => Ok(Some(Backup {
            path: slot,
            aside: true,
        })),
        Err(e) => {
            let _ = std::fs::remove_file(&slot);
            bail!(
                "cannot replace {}: {e} (is it immutable, or on a read-only file system?)",
                to.display()
            )
        }
    }
}

/// Puts the old files back: `renamed` destinations got their new file already.
fn restore(moves: &[Move], backups: Vec<Option<Backup>>, renamed: usize) -> Vec<String> {
    let mut failures = Vec::new();
    for (k, (m, b)) in moves.iter().zip(backups).enumerate().rev() {
        let back = match (b, k < renamed) {
            (Some(b), true) | (Some(b @ Backup { aside: true, .. }), false) => {
                std::fs::rename(&b.path, &m.to)
            }
            (Some(b), false) => std::fs::remove_file(&b.path),
            (None, true) => std::fs::remove_file(&m.to),
            (None, false) => Ok(()),
        };
        if let Err(e) = back {
            failures.push(format!("{}: {e}", m.to.display()));
        }
    }
    failures
}

/// The transaction's steps 2 and 3 (see the module's notes), under the caller's locks.
fn move_all(moves: &[Move]) -> Result<()> {
    let mut backups = Vec::with_capacity(moves.len());
    for m in moves {
        match keep_old(&m.to) {
            Ok(b) => backups.push(b),
            Err(e) => {
                let n = backups.len();
                restore(&moves[..n], backups, 0);
                return Err(e.context("nothing was changed"));
            }
        }
    }
    for (k, m) in moves.iter().enumerate() {
        #[cfg(test)]
        let injected = FAIL_RENAME_AT.with(|f| f.get()) == Some(k);
        #[cfg(not(test))]
        let injected = false;
        let renamed = if injected {
            Err(io::Error::other("injected failure"))
        } else {
            std::fs::rename(&m.from, &m.to)
        };
        if let Err(e) = renamed {
            let failures = restore(moves, backups, k);
            let e = anyhow::Error::new(e)
                .context(format!("moving the finished {} into place", m.to.display()));
            if failures.is_empty() {
                return Err(e.context("the files already replaced were put back"));
            }
            return Err(e.context(format!(
                "and putting back the old files failed: {}",
                failures.join("; ")
            )));
        }
    }
    for b in backups.into_iter().flatten() {
        let _ = std::fs::remove_file(&b.path);
    }
    Ok(())
}

/// A folder of output built in a staging folder beside its destination (`.lobe-<name>-*`) and
/// moved into place by [`StagingFolder::commit`]; dropped without a commit, the staging folder and
/// everything in it are removed and the destination is left as it was.
pub struct StagingFolder {
    tmp: Option<tempfile::TempDir>,
    id: u64,
    dest: PathBuf,
    /// Folders made for it (the destination's parents), removed again if it is not committed.
    folders: Vec<PathBuf>,
}

impl StagingFolder {
    /// A staging folder for `dest`, created in `dest`'s parent (made if missing); `name` goes into
    /// the staging folder's name. Fails when a file is in the way of `dest`.
    pub fn new(dest: &Path, name: &str) -> Result<StagingFolder> {
        if is_interrupted() {
            return Err(Interrupted.into());
        }
        if dest.exists() && !dest.is_dir() {
            bail!(
                "cannot write the folder {}: a file of that name is in the way",
                dest.display()
            );
        }
        let parent = folder_of(dest);
        let mut folders = Vec::new();
        create_folders(parent, &mut folders)?;
        let lockable = open_folder_lock(parent)
            .and_then(|_| match dest.is_dir() {
                true => open_folder_lock(dest).map(drop),
                false => Ok(()),
            })
            .with_context(|| format!("cannot write the folder {}", dest.display()));
        if let Err(e) = lockable {
            remove_created(&folders);
            return Err(e);
        }
        let prefix = format!(".lobe-{name}-");
        let mut b = tempfile::Builder::new();
        b.prefix(&prefix);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            b.permissions(std::fs::Permissions::from_mode(FOLDER_MODE));
        }
        let tmp = b
            .tempdir_in(parent)
            .with_context(|| format!("creating a staging folder in {}", parent.display()))?;
        let id = register(tmp.path(), true);
        Ok(StagingFolder {
            tmp: Some(tmp),
            id,
            dest: dest.to_path_buf(),
            folders,
        })
    }

    /// The staging folder itself.
    pub fn root(&self) -> &Path {
        self.tmp
            .as_ref()
            .expect("a staging folder has its folder until it is consumed")
            .path()
    }

    /// Where `rel` (a path relative to the destination) is written while staged.
    pub fn path(&self, rel: &str) -> PathBuf {
        self.root().join(rel)
    }

    /// Moves the finished folder into place. When the destination does not exist yet, the whole
    /// staging folder is renamed onto it in one step. Otherwise `files` (relative paths) are
    /// moved into it as one transaction (see the module's notes) in the order given (put the file
    /// that marks the folder complete last): every file or none, every check before the first
    /// rename, the old files back if a step fails. Anything else staged is removed.
    pub fn commit<S: AsRef<str>>(mut self, files: &[S]) -> Result<()> {
        let root = self.root().to_path_buf();
        if !self.dest.exists() {
            let locks = lock_folders([folder_of(&self.dest)].into_iter())?;
            let mut reg = registry();
            if is_interrupted() {
                return Err(Interrupted.into());
            }
            if !self.dest.exists() {
                let moved = std::fs::rename(&root, &self.dest);
                if moved.is_ok() {
                    reg.staged.remove(&self.id);
                    if let Some(tmp) = self.tmp.take() {
                        let _ = tmp.keep();
                    }
                    self.folders.clear();
                }
                drop(reg);
                drop(locks);
                return moved.with_context(|| {
                    format!("renaming the finished folder onto {}", self.dest.display())
                });
            }
        }
        let mut made = Vec::new();
        let moves: Vec<Move> = files
            .iter()
            .map(|f| Move {
                from: root.join(f.as_ref()),
                to: self.dest.join(f.as_ref()),
            })
            .collect();
        let prepared = moves
            .iter()
            .try_for_each(|m| create_folders(folder_of(&m.to), &mut made));
        let result = prepared.and_then(|()| {
            let _locks = lock_folders(moves.iter().map(|m| folder_of(&m.to)))?;
            let _reg = registry();
            if is_interrupted() {
                return Err(Interrupted.into());
            }
            move_all(&moves)
        });
        if result.is_err() {
            remove_created(&made);
        }
        result
    }
}

impl Drop for StagingFolder {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            drop(tmp);
            unregister(self.id);
        }
        remove_created(&self.folders);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// A scene writes thousands of files in one set: each destination is resolved on disk
    /// once, as it is added, so the set's cost grows linearly (resolving every earlier member
    /// again at each addition made 3000 tiny tables take minutes).
    #[test]
    fn a_set_resolves_each_destination_once() -> Result<()> {
        const FILES: usize = 200;
        let dir = tempfile::tempdir()?;
        let before = RESOLVES.with(|n| n.get());
        let mut set = FileSet::empty();
        for k in 0..FILES {
            set.add(&dir.path().join(format!("t{k}.json")))?;
        }
        assert_eq!(RESOLVES.with(|n| n.get()) - before, FILES);
        let again = set.add(&dir.path().join(".").join("t7.json"));
        assert!(again.is_err_and(|e| e.to_string().contains("the same file as")));
        Ok(())
    }

    #[test]
    fn a_failed_write_leaves_the_old_file() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let dest = dir.path().join("a.txt");
        std::fs::write(&dest, "old")?;
        let err = write_atomic(&dest, |w| -> Result<()> {
            w.write_all(b"new")?;
            bail!("stopped part-way")
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&dest)?, "old");
        assert_eq!(names(dir.path()), ["a.txt"]);
        write_atomic(&dest, |w| Ok(w.write_all(b"new")?))?;
        assert_eq!(std::fs::read_to_string(&dest)?, "new");
        assert_eq!(names(dir.path()), ["a.txt"]);
        Ok(())
    }

    #[test]
    fn a_missing_folder_is_named() {
        let err = Pending::new(Path::new("no/such/folder/a.txt")).err();
        let text = err.map(|e| format!("{e:#}")).unwrap_or_default();
        assert!(text.contains("no/such/folder"), "{text}");
        assert!(text.contains("does not exist"), "{text}");
    }

    #[test]
    fn a_folder_in_the_way_stops_the_set_before_any_file() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let (a, b) = (dir.path().join("t.npy"), dir.path().join("t.json"));
        std::fs::create_dir(&b)?;
        let err = FileSet::new(&[&a, &b]).err();
        let text = err.map(|e| format!("{e:#}")).unwrap_or_default();
        assert!(text.contains("in the way"), "{text}");
        assert_eq!(names(dir.path()), ["t.json"]);
        Ok(())
    }

    #[test]
    fn a_set_appears_whole_or_not_at_all() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let (a, b) = (dir.path().join("t.npy"), dir.path().join("t.json"));
        {
            let set = FileSet::new(&[&a, &b])?;
            set[0].file().write_all(b"1")?;
            // Dropped: nothing appears.
        }
        assert!(names(dir.path()).is_empty());
        let set = FileSet::new(&[&a, &b])?;
        set[0].file().write_all(b"1")?;
        set[1].file().write_all(b"2")?;
        set.commit()?;
        assert_eq!(names(dir.path()), ["t.json", "t.npy"]);
        Ok(())
    }

    /// The way back: a rename that fails after others succeeded (injected, as a race with another
    /// program would make it) restores every old file and removes every new one.
    #[test]
    fn a_failing_last_rename_puts_the_old_set_back() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let dests: Vec<PathBuf> = ["t.npy", "t.exr", "t.json"]
            .iter()
            .map(|n| dir.path().join(n))
            .collect();
        // The old set has two of the three files: the third is new in the failing run.
        std::fs::write(&dests[0], "old npy")?;
        std::fs::write(&dests[2], "old json")?;
        for fail_at in 0..3 {
            let refs: Vec<&Path> = dests.iter().map(|p| p.as_path()).collect();
            let set = FileSet::new(&refs)?;
            for k in 0..3 {
                set[k].file().write_all(b"new")?;
            }
            FAIL_RENAME_AT.with(|f| f.set(Some(fail_at)));
            let err = set.commit().err();
            FAIL_RENAME_AT.with(|f| f.set(None));
            let text = err.map(|e| format!("{e:#}")).unwrap_or_default();
            assert!(text.contains("put back"), "rename {fail_at}: {text}");
            assert_eq!(names(dir.path()), ["t.json", "t.npy"], "rename {fail_at}");
            assert_eq!(std::fs::read_to_string(&dests[0])?, "old npy");
            assert_eq!(std::fs::read_to_string(&dests[2])?, "old json");
        }
        Ok(())
    }

    /// A read-only old file is refused before any file of the set changes, and also when it
    /// turns read-only while the set is being written.
    #[cfg(unix)]
    #[test]
    fn a_read_only_old_file_is_refused() -> Result<()> {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir()?;
        let (a, b) = (dir.path().join("t.npy"), dir.path().join("t.json"));
        std::fs::write(&a, "old npy")?;
        std::fs::write(&b, "old json")?;
        let set = FileSet::new(&[&a, &b])?;
        set[0].file().write_all(b"new")?;
        set[1].file().write_all(b"new")?;
        std::fs::set_permissions(&b, std::fs::Permissions::from_mode(0o444))?;
        let text = set
            .commit()
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default();
        assert!(text.contains("read-only"), "{text}");
        assert_eq!(std::fs::read_to_string(&a)?, "old npy");
        let text = FileSet::new(&[&a, &b])
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default();
        assert!(text.contains("read-only"), "{text}");
        assert_eq!(names(dir.path()), ["t.json", "t.npy"]);
        Ok(())
    }

    /// A destination name one byte too long for the file system (255 bytes on ext4, tmpfs and
    /// most others) fails when its temporary file is made, naming the file.
    #[test]
    fn a_name_too_long_fails_before_any_work() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let ok = dir.path().join(format!("{}.npy", "n".repeat(251)));
        let long = dir.path().join(format!("{}.json", "n".repeat(251)));
        let text = FileSet::new(&[&ok, &long])
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default();
        assert!(text.contains("too long"), "{text}");
        assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
        Ok(())
    }

    #[test]
    fn one_file_twice_in_a_set_is_refused() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let a = dir.path().join("t.json");
        let b = dir.path().join(".").join("t.json");
        let text = FileSet::new(&[&a, &b])
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default();
        assert!(text.contains("same file"), "{text}");
        Ok(())
    }

    #[test]
    fn a_staged_folder_moves_in_whole_or_merges() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let dest = dir.path().join("out");
        let files = ["sub/a.txt", "index.html"];
        let stage = |dest: &Path| -> Result<StagingFolder> {
            let s = StagingFolder::new(dest, "test")?;
            std::fs::create_dir_all(s.path("sub"))?;
            for f in files {
                std::fs::write(s.path(f), f)?;
            }
            Ok(s)
        };
        drop(stage(&dest)?);
        assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
        stage(&dest)?.commit(&files)?;
        assert_eq!(names(&dest), ["index.html", "sub"]);
        std::fs::write(dest.join("keep.txt"), "mine")?;
        stage(&dest)?.commit(&files)?;
        assert_eq!(names(&dest), ["index.html", "keep.txt", "sub"]);
        assert_eq!(names(dir.path()), ["out"]);
        Ok(())
    }

    /// Merging into an existing folder with a folder in the way of the last file changes nothing:
    /// not the earlier files, and no new folder stays.
    #[test]
    fn a_merge_with_a_folder_in_the_way_changes_nothing() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let dest = dir.path().join("out");
        std::fs::create_dir_all(dest.join("index.html"))?;
        std::fs::write(dest.join("a.txt"), "old")?;
        let files = ["a.txt", "new/b.txt", "index.html"];
        let s = StagingFolder::new(&dest, "test")?;
        std::fs::create_dir_all(s.path("new"))?;
        for f in files {
            std::fs::write(s.path(f), "new")?;
        }
        let text = s
            .commit(&files)
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default();
        assert!(text.contains("in the way"), "{text}");
        assert_eq!(names(&dest), ["a.txt", "index.html"]);
        assert_eq!(std::fs::read_to_string(dest.join("a.txt"))?, "old");
        assert_eq!(names(dir.path()), ["out"]);
        Ok(())
    }
}
