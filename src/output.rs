//! Atomic output: every file lobe writes appears complete or not at all.
//!
//! A file is written to a temporary file in its destination's folder (the same file system, so
//! the final step is a rename, which replaces the destination in one step) and renamed into place
//! only once it is complete. Dropped before that (an error, a failed write part-way such as a full
//! disk, or Ctrl-C through the evaluator's cancellation token), the temporary file is removed and the
//! destination keeps what it held before.
//!
//! - [`Pending`]: one file; [`write_atomic`] wraps the common case of one buffered writer.
//! - [`FileSet`]: files that belong together (a table's `.exr`, `.npy` and `.json`): every
//!   destination is checked before anything is written, and all are renamed at the end.
//! - [`StagingFolder`]: a whole folder of output, built beside its destination and moved into it
//!   once every file is there.
//!
//! Temporary names start with `.lobe-`, so that a run killed outright (where no cleanup runs)
//! leaves files that are easy to recognise.

use anyhow::{bail, Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The folder `dest` goes into (`.` for a bare file name).
fn folder_of(dest: &Path) -> &Path {
    match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Temporary files are created private (0600); output is as readable as a plainly created file.
#[cfg(unix)]
const FILE_MODE: u32 = 0o644;
#[cfg(unix)]
const FOLDER_MODE: u32 = 0o755;

/// A file being written: a temporary file beside its destination, renamed onto it by
/// [`Pending::commit`]; dropped without a commit, it is removed.
pub struct Pending {
    tmp: tempfile::NamedTempFile,
    dest: PathBuf,
}

impl Pending {
    /// A temporary file `.lobe-*.partial` beside `dest`. Fails, naming `dest`, when its folder
    /// does not exist or no file can be created there.
    pub fn new(dest: &Path) -> Result<Pending> {
        Pending::with_suffix(dest, ".partial")
    }

    /// As [`Pending::new`], but the temporary name ends in `.ext`, for writers that pick their
    /// format from the name of the file they are given (plotters' PNG backend).
    pub fn with_extension(dest: &Path, ext: &str) -> Result<Pending> {
        Pending::with_suffix(dest, &format!(".{ext}"))
    }

    fn with_suffix(dest: &Path, suffix: &str) -> Result<Pending> {
        let dir = folder_of(dest);
        if !dir.is_dir() {
            bail!(
                "cannot write {}: the folder {} does not exist",
                dest.display(),
                dir.display()
            );
        }
        let tmp = tempfile::Builder::new()
            .prefix(".lobe-")
            .suffix(suffix)
            .tempfile_in(dir)
            .with_context(|| {
                format!(
                    "cannot write {}: creating a file in {} failed",
                    dest.display(),
                    dir.display()
                )
            })?;
        Ok(Pending {
            tmp,
            dest: dest.to_path_buf(),
        })
    }

    /// The temporary file, open for reading and writing.
    pub fn file(&self) -> &File {
        self.tmp.as_file()
    }

    /// The temporary file's path, for writers that open the file themselves (and for reading back
    /// what was written).
    pub fn path(&self) -> &Path {
        self.tmp.path()
    }

    /// Where the file goes.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Renames the finished file onto its destination, with the permissions a plainly created
    /// file gets.
    pub fn commit(self) -> Result<()> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Best effort: a file that stays private is still correct output.
            let _ = self
                .tmp
                .as_file()
                .set_permissions(std::fs::Permissions::from_mode(FILE_MODE));
        }
        let dest = self.dest;
        self.tmp
            .persist(&dest)
            .map_err(|e| e.error)
            .with_context(|| format!("renaming the finished file onto {}", dest.display()))?;
        Ok(())
    }
}

/// Writes `dest` through `write`, which gets a buffered writer on a [`Pending`] file; the buffer
/// is flushed (so a late write error is not lost) and the file committed only when `write`
/// succeeds. Returns what `write` returns.
pub fn write_atomic<T>(
    dest: &Path,
    write: impl FnOnce(&mut BufWriter<&File>) -> Result<T>,
) -> Result<T> {
    let pending = Pending::new(dest)?;
    let value = {
        let mut w = BufWriter::new(pending.file());
        let value = write(&mut w)?;
        w.flush()
            .with_context(|| format!("writing {}", dest.display()))?;
        value
    };
    pending.commit()?;
    Ok(value)
}

/// Files that are only correct together. The renames at the end cannot be undone one by one, so
/// [`FileSet::new`] refuses, before creating anything, a destination that no rename can replace
/// (a folder of that name); then no file of the set can appear without the others.
pub struct FileSet {
    files: Vec<Pending>,
}

impl FileSet {
    /// A [`Pending`] file for each of `dests`, which [`FileSet::commit`] renames in this order
    /// (put the file that marks the set complete, such as a sidecar, last); `set[k]` is the
    /// file for `dests[k]`.
    pub fn new(dests: &[&Path]) -> Result<FileSet> {
        for dest in dests {
            if dest.is_dir() {
                bail!(
                    "cannot write {}: a folder of that name is in the way",
                    dest.display()
                );
            }
        }
        let files = dests
            .iter()
            .map(|d| Pending::new(d))
            .collect::<Result<_>>()?;
        Ok(FileSet { files })
    }

    /// Renames every file onto its destination, in order.
    pub fn commit(self) -> Result<()> {
        for file in self.files {
            file.commit()?;
        }
        Ok(())
    }
}

impl std::ops::Index<usize> for FileSet {
    type Output = Pending;

    fn index(&self, k: usize) -> &Pending {
        &self.files[k]
    }
}

/// A folder of output built in a staging folder beside its destination (`.lobe-<name>-*`) and
/// moved into place by [`StagingFolder::commit`]; dropped without a commit, the staging folder and
/// everything in it are removed and the destination is left as it was.
pub struct StagingFolder {
    tmp: tempfile::TempDir,
    dest: PathBuf,
}

impl StagingFolder {
    /// A staging folder for `dest`, created in `dest`'s parent (made if missing); `name` goes into
    /// the staging folder's name. Fails when a file is in the way of `dest`.
    pub fn new(dest: &Path, name: &str) -> Result<StagingFolder> {
        if dest.exists() && !dest.is_dir() {
            bail!(
                "cannot write the folder {}: a file of that name is in the way",
                dest.display()
            );
        }
        let parent = folder_of(dest);
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating the folder {}", parent.display()))?;
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".lobe-{name}-"))
            .tempdir_in(parent)
            .with_context(|| format!("creating a staging folder in {}", parent.display()))?;
        Ok(StagingFolder {
            tmp,
            dest: dest.to_path_buf(),
        })
    }

    /// The staging folder itself.
    pub fn root(&self) -> &Path {
        self.tmp.path()
    }

    /// Where `rel` (a path relative to the destination) is written while staged.
    pub fn path(&self, rel: &str) -> PathBuf {
        self.tmp.path().join(rel)
    }

    /// Moves the finished folder into place. When the destination does not exist yet, the whole
    /// staging folder is renamed onto it in one step: it appears complete or not at all.
    /// Otherwise `files` (relative paths) are renamed into it one by one in the order given (put
    /// the file that marks the folder complete last), and anything else staged is removed.
    pub fn commit<S: AsRef<str>>(self, files: &[S]) -> Result<()> {
        // tempfile makes the folder private (0700); output is as readable as any other.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mut dirs = vec![self.tmp.path().to_path_buf()];
            for f in files {
                let mut at = Path::new(f.as_ref()).parent();
                while let Some(p) = at.filter(|p| !p.as_os_str().is_empty()) {
                    let d = self.tmp.path().join(p);
                    if !dirs.contains(&d) {
                        dirs.push(d);
                    }
                    at = p.parent();
                }
            }
            for d in dirs {
                std::fs::set_permissions(&d, std::fs::Permissions::from_mode(FOLDER_MODE))
                    .with_context(|| format!("setting the permissions of {}", d.display()))?;
            }
        }
        if !self.dest.exists() {
            let from = self.tmp.keep();
            return std::fs::rename(&from, &self.dest).with_context(|| {
                let _ = std::fs::remove_dir_all(&from);
                format!("renaming the finished folder onto {}", self.dest.display())
            });
        }
        for f in files {
            let to = self.dest.join(f.as_ref());
            if let Some(p) = to.parent() {
                std::fs::create_dir_all(p)
                    .with_context(|| format!("creating the folder {}", p.display()))?;
            }
            if to.is_dir() {
                bail!(
                    "cannot write {}: a folder of that name is in the way",
                    to.display()
                );
            }
            std::fs::rename(self.tmp.path().join(f.as_ref()), &to)
                .with_context(|| format!("moving the finished {} into place", to.display()))?;
        }
        Ok(())
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
}
