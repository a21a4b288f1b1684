//! Files committed together: the transaction.

use super::commit::{commit, Move};
use super::{
    check_replaceable, create_folders, folder_of, is_interrupted, lock_folders, registry,
    remove_created, resolve, Pending,
};
use crate::interrupt::Interrupted;
use anyhow::{bail, Result};
use std::collections::HashMap;
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
            commit(&moves, &[])
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
