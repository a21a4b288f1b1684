//! Files committed together: the transaction.

use super::commit::{commit, Move};
use super::owner::{plan, Group};
use super::{
    check_replaceable, create_folders, folder_of, is_interrupted, lock_folders, registry,
    remove_created, resolve, Pending,
};
use crate::interrupt::Interrupted;
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

impl Pending {
    /// Renames the finished file onto its destination: a [`FileSet`] of one.
    pub fn commit(self) -> Result<()> {
        FileSet::of_one(self).commit()
    }
}

/// Files that are only correct together, committed as one transaction (see the module's notes):
/// all of them replace their destinations, or none does.
pub struct FileSet {
    pub(super) files: Vec<Pending>,
    /// Each file's destination as it resolves on disk ([`resolve`], made once as it is added),
    /// with its index: a set of thousands of files finds a repeated destination in one look-up.
    resolved: HashMap<PathBuf, usize>,
    /// Folders this set created, removed again (when empty) if it is not committed.
    folders: Vec<PathBuf>,
    /// The sets the files make up (see [`super::owner`]).
    pub(super) groups: Vec<Group>,
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

    /// [`FileSet::new`] for the members of one set of `kind` whose record (its JSON sidecar) is
    /// `dests[record]`: see [`FileSet::add_set`].
    pub fn new_set(kind: &str, dests: &[&Path], record: usize) -> Result<FileSet> {
        let mut set = FileSet::empty();
        set.add_set(kind, dests, record)?;
        Ok(set)
    }

    /// A set with no files yet.
    pub fn empty() -> FileSet {
        FileSet {
            files: Vec::new(),
            resolved: HashMap::new(),
            folders: Vec::new(),
            groups: Vec::new(),
        }
    }

    /// Adds a [`Pending`] file for `dest` (see [`Pending::new`]), written on its own (a plot, a
    /// picture), returning its index; a destination already in the set, however written
    /// (`./t.json` and `t.json`), is refused, and so is a member of a set of a kind unless sets
    /// are replaced ([`super::replace_sets`]).
    pub fn add(&mut self, dest: &Path) -> Result<usize> {
        self.add_group(None, &[dest], 0)
    }

    /// Adds the members of one set of `kind` (`"table"`, `"lut"`, …) whose record is
    /// `dests[record]`, returning the index of the first. Refused before any file is created
    /// (`output/owner.rs`) when a destination belongs to another set or (an existing file) to
    /// none, unless sets are replaced ([`super::replace_sets`]); the commit removes the members
    /// of this set's earlier version that it no longer has. The record must hold a JSON object;
    /// the commit adds [`super::set_json`] of the members to it as `"set"`. Every destination is
    /// checked (a folder in the way, a read-only file) before the first file is created.
    pub fn add_set(&mut self, kind: &str, dests: &[&Path], record: usize) -> Result<usize> {
        for dest in dests {
            check_replaceable(dest)?;
        }
        self.add_group(Some(kind), dests, record)
    }

    fn add_group(&mut self, kind: Option<&str>, dests: &[&Path], record: usize) -> Result<usize> {
        let mut resolved = Vec::with_capacity(dests.len());
        for dest in dests {
            let r = resolve(dest);
            let earlier = self.resolved.get(&r).copied().or_else(|| {
                let k = resolved.iter().position(|o| *o == r)?;
                Some(self.files.len() + k)
            });
            if let Some(other) = earlier {
                let other = self
                    .files
                    .get(other)
                    .map_or_else(|| dests[other - self.files.len()], |p| p.dest.as_path());
                bail!(
                    "cannot write {}: the same file as {} in one set",
                    dest.display(),
                    other.display()
                );
            }
            resolved.push(r);
        }
        let group = Group {
            kind: kind.map(str::to_string),
            record: kind.and(dests.get(record)).map(|r| r.to_path_buf()),
            record_file: kind.map(|_| self.files.len() + record),
            members: dests.iter().map(|d| d.to_path_buf()).collect(),
        };
        // The files first (a folder in the way, a name too long), then which sets they belong to.
        let first = self.files.len();
        let staged = dests.iter().zip(&resolved).try_for_each(|(dest, r)| {
            self.files.push(Pending::with_suffix(dest, ".partial")?);
            self.resolved.insert(r.clone(), self.files.len() - 1);
            Ok(())
        });
        let planned = staged.and_then(|()| plan(&group, &|p| self.resolved.contains_key(p)));
        if let Err(e) = planned {
            for r in &resolved {
                if self.resolved.get(r).is_some_and(|&k| k >= first) {
                    self.resolved.remove(r);
                }
            }
            self.files.truncate(first);
            return Err(e);
        }
        self.groups.push(group);
        Ok(first)
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
        self.stamp_records()?;
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
            // Again under the locks: another run may have committed a set here since.
            self.removals()
                .and_then(|removals| commit(&moves, &removals))
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

impl FileSet {
    /// The set of the one file `p`, written on its own.
    pub(super) fn of_one(p: Pending) -> FileSet {
        let mut set = FileSet::empty();
        set.resolved.insert(resolve(&p.dest), 0);
        set.groups.push(Group {
            kind: None,
            record: None,
            record_file: None,
            members: vec![p.dest.clone()],
        });
        set.files.push(p);
        set
    }

    /// Adds to each record of a set of a kind its `"set"`: kind and members.
    fn stamp_records(&self) -> Result<()> {
        for g in &self.groups {
            let (Some(kind), Some(k)) = (&g.kind, g.record_file) else {
                continue;
            };
            let file = &self.files[k];
            let bytes = std::fs::read(file.path())
                .with_context(|| format!("reading back {}", file.dest.display()))?;
            let mut v: serde_json::Value = serde_json::from_slice(&bytes)
                .with_context(|| format!("{} is not JSON", file.dest.display()))?;
            let Some(record) = v.as_object_mut() else {
                bail!("{} is not a JSON object", file.dest.display());
            };
            let members: Vec<&Path> = g.members.iter().map(PathBuf::as_path).collect();
            record.insert("set".into(), super::set_json(kind, &members));
            let text = serde_json::to_string_pretty(&v)? + "\n";
            std::fs::write(file.path(), text)
                .map_err(|e| super::encoder_error(&file.dest, "JSON", e))?;
        }
        Ok(())
    }

    /// What the commit removes besides renaming its files (see [`plan`]).
    fn removals(&self) -> Result<Vec<PathBuf>> {
        let claimed = |p: &Path| self.resolved.contains_key(p);
        let mut removals: Vec<PathBuf> = Vec::new();
        for g in &self.groups {
            for r in plan(g, &claimed)? {
                if !removals.contains(&r) {
                    removals.push(r);
                }
            }
        }
        Ok(removals)
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
