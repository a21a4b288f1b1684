//! A whole folder of output, staged beside its destination.

use super::commit::{commit, recover_folder, sync_folder, sync_tree, Move};
use super::pending::held;
use super::{
    create_folders, folder_of, is_interrupted, lock_folders, open_folder_lock, register, registry,
    remove_created, unregister, FOLDER_MODE,
};
use crate::interrupt::Interrupted;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// A folder of output built in a staging folder beside its destination (`.lobe-<name>-*`) and
/// moved into place by [`StagingFolder::commit`]; dropped without a commit, the staging folder and
/// everything in it are removed and the destination is left as it was.
pub struct StagingFolder {
    tmp: Option<tempfile::TempDir>,
    /// A lock on the staging folder, held while it lives: how a later run tells it from one left
    /// by a run that died.
    _lock: std::fs::File,
    id: u64,
    dest: PathBuf,
    /// Folders made for it (the destination's parents), removed again if it is not committed.
    folders: Vec<PathBuf>,
}

/// Checks, before any work, that a folder of output can be written at `dest`: no file in the way,
/// and the folder that would receive files (`dest` itself when it exists, else the nearest folder
/// above it that does) is neither read-only (no write permission: refused even where the process
/// could write anyway, as running as root, just as read-only files are) nor unwritable (a file
/// cannot be created there: a read-only file system, an immutable folder).
pub fn check_folder_destination(dest: &Path) -> Result<()> {
    if dest.exists() && !dest.is_dir() {
        bail!(
            "cannot write the folder {}: a file of that name is in the way",
            dest.display()
        );
    }
    let Some(receiver) = dest
        .ancestors()
        .map(|a| match a.as_os_str().is_empty() {
            true => Path::new("."),
            false => a,
        })
        .find(|a| a.exists())
    else {
        return Ok(());
    };
    if !receiver.is_dir() {
        bail!(
            "cannot write the folder {}: {} is a file, not a folder",
            dest.display(),
            receiver.display()
        );
    }
    let meta = std::fs::metadata(receiver)
        .with_context(|| format!("cannot write the folder {}", dest.display()))?;
    if meta.permissions().readonly() {
        bail!(
            "cannot write the folder {}: {} is read-only, and lobe does not write into read-only \
             folders; make it writable (chmod u+w) or write elsewhere",
            dest.display(),
            receiver.display()
        );
    }
    tempfile::Builder::new()
        .prefix(".lobe-probe-")
        .tempfile_in(receiver)
        .map(drop)
        .map_err(|e| {
            let cause = e
                .raw_os_error()
                .map_or(e.kind().into(), std::io::Error::from_raw_os_error);
            anyhow::anyhow!(
                "cannot write the folder {}: creating a file in {} failed: {cause}",
                dest.display(),
                receiver.display()
            )
        })
}

impl StagingFolder {
    /// A staging folder for `dest`, created in `dest`'s parent (made if missing); `name` goes into
    /// the staging folder's name. Fails as [`check_folder_destination`] does.
    pub fn new(dest: &Path, name: &str) -> Result<StagingFolder> {
        if is_interrupted() {
            return Err(Interrupted.into());
        }
        check_folder_destination(dest)?;
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
        recover_folder(parent);
        if dest.is_dir() {
            recover_folder(dest);
        }
        let prefix = format!(".lobe-{name}-");
        let mut b = tempfile::Builder::new();
        b.prefix(&prefix);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            b.permissions(std::fs::Permissions::from_mode(FOLDER_MODE));
        }
        // As for temporary files (see `Pending::new`): one removed before it was locked is made
        // again.
        let (tmp, lock) = loop {
            let tmp = b
                .tempdir_in(parent)
                .with_context(|| format!("creating a staging folder in {}", parent.display()))?;
            let lock = std::fs::File::open(tmp.path())
                .with_context(|| format!("opening the staging folder {}", tmp.path().display()))?;
            if held(&lock, tmp.path()) {
                break (tmp, lock);
            }
        };
        let id = register(tmp.path(), true);
        Ok(StagingFolder {
            _lock: lock,
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
                let moved = sync_tree(&root)
                    .and_then(|()| std::fs::rename(&root, &self.dest))
                    .and_then(|()| sync_folder(folder_of(&self.dest)));
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
            commit(&moves, &[])
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
