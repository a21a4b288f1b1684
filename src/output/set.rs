//! Files committed together: the transaction.

use super::{
    check_replaceable, create_folders, folder_of, is_interrupted, lock_folders, registry,
    remove_created, resolve, temp_builder, Pending,
};
use crate::interrupt::Interrupted;
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};

/// Files that are only correct together, committed as one transaction (see the module's notes):
/// all of them replace their destinations, or none does.
pub struct FileSet {
    pub(super) files: Vec<Pending>,
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

/// One rename of a transaction.
pub(super) struct Move {
    pub(super) from: PathBuf,
    pub(super) to: PathBuf,
}

/// Where an old destination is kept while its transaction runs.
struct Backup {
    path: PathBuf,
    /// Moved aside (the destination is missing until the new file arrives), rather than linked.
    aside: bool,
}

#[cfg(test)]
thread_local! {
    /// The rename (by index) that fails, to exercise the way back.
    pub(super) static FAIL_RENAME_AT: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
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
pub(super) fn move_all(moves: &[Move]) -> Result<()> {
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
