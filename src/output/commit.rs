//! The commit of a transaction and its record, so that a process killed part-way leaves nothing
//! the next run cannot complete.
//!
//! Under the locks of every folder involved, a commit:
//! 1. checks every destination (no folder in the way, no read-only file): a refusal changes
//!    nothing;
//! 2. flushes every new file to the disk (`fsync`);
//! 3. writes its record, `.lobe-<id>.journal`, into every folder involved (the renames, the files
//!    it removes, and where each old file is kept), flushes it and the folders: from here on the
//!    new set wins;
//! 4. keeps each old file aside under `.lobe-<id>-<k>.old` (a hard link, or a rename where links
//!    are not possible);
//! 5. renames each new file onto its destination, removes each file the set no longer has, and
//!    flushes the folders;
//! 6. removes the old files kept aside, then the record.
//!
//! Should a rename fail (another program in the way), the record turns to "back" and the old
//! files are put back. The next run that writes into one of these folders ([`recover_folder`])
//! finds a record left by a process that died, finishes what it says (the renames not yet made,
//! or putting the old files back), and removes the temporary files (`.lobe-*`) whose writer is
//! gone: a writer holds a lock on each of its temporary files while it lives.
//!
//! `LOBE_CRASH_AT=N` is a test hook: the process aborts at the N-th step of its commits (counted
//! from 1 across the run), as a `kill -9` there would stop it; `tests/crash.rs` stops a run at
//! every step and checks what the next run finds.

use super::{check_replaceable, folder_of, lock_folders};
use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::collections::HashSet;
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

/// One rename of a transaction.
pub(super) struct Move {
    pub(super) from: PathBuf,
    pub(super) to: PathBuf,
}

/// One step of a commit: a rename of `from` onto `to`, or (no `from`) the removal of `to`;
/// `backup` is where the old `to` is kept while the commit runs (none when there was no old file).
struct Step {
    from: Option<PathBuf>,
    to: PathBuf,
    backup: Option<PathBuf>,
}

/// What a commit's record says to do with a commit that did not finish.
#[derive(Clone, Copy, PartialEq)]
enum Direction {
    /// Complete it: every new file in place, every removed file gone.
    Forward,
    /// Undo it: every old file back.
    Back,
}

#[cfg(test)]
thread_local! {
    /// The rename (by index) that fails, to exercise the way back.
    pub(super) static FAIL_RENAME_AT: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Counts the steps of this process's commits; aborts at the one `LOBE_CRASH_AT` names.
fn crash_point() {
    static AT: OnceLock<Option<u64>> = OnceLock::new();
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let at = AT.get_or_init(|| std::env::var("LOBE_CRASH_AT").ok()?.trim().parse().ok());
    if let Some(at) = *at {
        if COUNT.fetch_add(1, Ordering::SeqCst) + 1 == at {
            std::process::abort();
        }
    }
}

/// Flushes the folder `dir` itself (its entries: new names, renames, removals) to the disk.
pub(super) fn sync_folder(dir: &Path) -> io::Result<()> {
    File::open(dir)?.sync_all()
}

/// Flushes every file and folder under `dir`, and `dir` itself, to the disk.
pub(super) fn sync_tree(dir: &Path) -> io::Result<()> {
    for e in std::fs::read_dir(dir)? {
        let e = e?;
        if e.file_type()?.is_dir() {
            sync_tree(&e.path())?;
        } else {
            File::open(e.path())?.sync_all()?;
        }
    }
    sync_folder(dir)
}

/// Each distinct folder among `paths`' folders, in first-seen order.
fn folders<'a>(paths: impl Iterator<Item = &'a Path>) -> Vec<PathBuf> {
    let mut seen = Vec::new();
    for p in paths {
        let d = folder_of(p).to_path_buf();
        if !seen.contains(&d) {
            seen.push(d);
        }
    }
    seen
}

/// Renames `moves` into place and removes `removals` as one transaction (see the module's notes),
/// under the caller's locks of every folder involved.
pub(super) fn commit(moves: &[Move], removals: &[PathBuf]) -> Result<()> {
    for to in moves.iter().map(|m| &m.to).chain(removals) {
        check_replaceable(to).context("nothing was changed")?;
    }
    // In parallel: a scene commits thousands of small files, and the file system groups
    // concurrent flushes into few journal commits.
    moves.par_iter().try_for_each(|m| {
        File::open(&m.from)
            .and_then(|f| f.sync_all())
            .with_context(|| format!("flushing {} to the disk", m.to.display()))
    })?;
    crash_point();
    let id = format!("{:08x}{:08x}", std::process::id(), rand_u32());
    let mut steps: Vec<Step> = Vec::new();
    let present = |p: &Path| std::fs::symlink_metadata(p).is_ok();
    let backup_of = |k: usize, to: &Path| folder_of(to).join(format!(".lobe-{id}-{k}.old"));
    for m in moves {
        let backup = present(&m.to).then(|| backup_of(steps.len(), &m.to));
        steps.push(Step {
            from: Some(m.from.clone()),
            to: m.to.clone(),
            backup,
        });
    }
    for r in removals.iter().filter(|r| present(r)) {
        let backup = Some(backup_of(steps.len(), r));
        steps.push(Step {
            from: None,
            to: r.clone(),
            backup,
        });
    }
    let dirs = folders(steps.iter().map(|s| s.to.as_path()));
    // A record also beside each staging folder the new files come from: a run cleaning up there
    // finishes the commit before it removes the staging folder.
    let mut record_dirs = dirs.clone();
    for d in moves.iter().filter_map(|m| staging_parent(&m.from)) {
        if !record_dirs.contains(&d) {
            record_dirs.push(d);
        }
    }
    let journals: Vec<PathBuf> = record_dirs
        .iter()
        .map(|d| d.join(format!(".lobe-{id}.journal")))
        .collect();
    write_journal(&journals, &steps, Direction::Forward)
        .context("writing the commit's record; nothing was changed")?;
    crash_point();
    for (k, s) in steps.iter().enumerate() {
        if let Err(e) = keep_old(s) {
            undo(&steps[..k]);
            remove_journals(&journals);
            return Err(e.context("nothing was changed"));
        }
        crash_point();
    }
    for (k, s) in steps.iter().enumerate() {
        if let Err(e) = apply_step(k, s) {
            let _ = write_journal(&journals, &steps, Direction::Back);
            let failures = undo(&steps);
            remove_journals(&journals);
            let e = e.context(format!("moving the finished {} into place", s.to.display()));
            if failures.is_empty() {
                return Err(e.context("the files already replaced were put back"));
            }
            return Err(e.context(format!(
                "and putting back the old files failed: {}",
                failures.join("; ")
            )));
        }
        crash_point();
    }
    for d in &dirs {
        sync_folder(d).with_context(|| format!("flushing the folder {}", d.display()))?;
    }
    crash_point();
    for b in steps.iter().filter_map(|s| s.backup.as_ref()) {
        let _ = std::fs::remove_file(b);
    }
    crash_point();
    remove_journals(&journals);
    Ok(())
}

/// The folder holding the staging folder (`.lobe-*`) that `path` lies in, if it lies in one.
fn staging_parent(path: &Path) -> Option<PathBuf> {
    let staged = path.ancestors().skip(1).find(|a| {
        a.file_name()
            .is_some_and(|n| n.as_encoded_bytes().starts_with(b".lobe-"))
    })?;
    Some(folder_of(staged).to_path_buf())
}

fn rand_u32() -> u32 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
    );
    h.finish() as u32
}

/// The rename (or removal) of step `k`.
fn apply_step(k: usize, s: &Step) -> Result<()> {
    #[cfg(test)]
    if FAIL_RENAME_AT.with(|f| f.get()) == Some(k) {
        anyhow::bail!(io::Error::other("injected failure"));
    }
    let _ = k;
    match &s.from {
        Some(from) => std::fs::rename(from, &s.to)?,
        None => std::fs::remove_file(&s.to)?,
    }
    Ok(())
}

/// Keeps the old `s.to` at `s.backup`: a hard link, or, where none can be made, the file itself
/// moved there. Fails (changing nothing) when neither works.
fn keep_old(s: &Step) -> Result<()> {
    let Some(backup) = &s.backup else {
        return Ok(());
    };
    if std::fs::hard_link(&s.to, backup).is_ok() {
        return Ok(());
    }
    // No hard links here (or none allowed for this file): move the old file aside instead.
    std::fs::rename(&s.to, backup).map_err(|e| {
        anyhow::anyhow!(
            "cannot replace {}: {e} (is it immutable, or on a read-only file system?)",
            s.to.display()
        )
    })
}

/// Puts every old file of `steps` back and removes the new files, whatever part of the commit
/// ran; returns what could not be put back.
fn undo(steps: &[Step]) -> Vec<String> {
    let mut failures = Vec::new();
    for s in steps.iter().rev() {
        let back = match (&s.backup, &s.from) {
            // A link to a file still in place: renaming it onto that file changes nothing, and
            // removing it after is all there is to do.
            (Some(b), _) if std::fs::symlink_metadata(b).is_ok() => {
                std::fs::rename(b, &s.to).map(|()| {
                    let _ = std::fs::remove_file(b);
                })
            }
            (Some(_), _) => Ok(()),
            // A new file with no old one: gone from wherever it is.
            (None, Some(from)) if std::fs::symlink_metadata(from).is_ok() => {
                std::fs::remove_file(from)
            }
            (None, Some(_)) => match std::fs::remove_file(&s.to) {
                Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
                other => other,
            },
            (None, None) => Ok(()),
        };
        if let Err(e) = back {
            failures.push(format!("{}: {e}", s.to.display()));
        }
    }
    failures
}

/// Completes what a commit did not finish: every rename not yet made, every removal.
fn redo(steps: &[Step]) {
    for s in steps {
        match &s.from {
            Some(from) if std::fs::symlink_metadata(from).is_ok() => {
                let _ = std::fs::rename(from, &s.to);
            }
            Some(_) => {}
            None => {
                let _ = std::fs::remove_file(&s.to);
            }
        }
    }
    for b in steps.iter().filter_map(|s| s.backup.as_ref()) {
        let _ = std::fs::remove_file(b);
    }
}

/// A path as the record holds it: its bytes in hexadecimal, so that any name the file system
/// holds comes back as it was.
fn path_text(p: &Path) -> String {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    abs.as_os_str()
        .as_encoded_bytes()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn path_from(v: &Value) -> Option<PathBuf> {
    let text = v.as_str()?;
    let bytes: Option<Vec<u8>> = (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(text.get(i..i + 2)?, 16).ok())
        .collect();
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStringExt;
        Some(PathBuf::from(std::ffi::OsString::from_vec(bytes?)))
    }
    #[cfg(not(unix))]
    {
        String::from_utf8(bytes?).ok().map(PathBuf::from)
    }
}

/// Writes the record into each of `journals` and flushes it and its folder.
fn write_journal(journals: &[PathBuf], steps: &[Step], direction: Direction) -> Result<()> {
    let opt = |p: &Option<PathBuf>| p.as_deref().map_or(Value::Null, |p| path_text(p).into());
    let record = json!({
        "lobe_commit": 1,
        "direction": if direction == Direction::Forward { "forward" } else { "back" },
        "journals": journals.iter().map(|j| path_text(j)).collect::<Vec<_>>(),
        "steps": steps.iter().map(|s| json!({
            "from": opt(&s.from),
            "to": path_text(&s.to),
            "backup": opt(&s.backup),
        })).collect::<Vec<_>>(),
    });
    let text = serde_json::to_vec(&record)?;
    for j in journals {
        let tmp = j.with_extension("journal-new");
        let mut f = File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        f.write_all(&text)?;
        f.sync_all()?;
        std::fs::rename(&tmp, j)?;
        sync_folder(folder_of(j))?;
    }
    Ok(())
}

fn remove_journals(journals: &[PathBuf]) {
    for j in journals {
        let _ = std::fs::remove_file(j);
    }
}

/// A record read back: its direction, its steps and every copy of it.
fn read_journal(path: &Path) -> Option<(Direction, Vec<Step>, Vec<PathBuf>)> {
    let v: Value = serde_json::from_slice(&std::fs::read(path).ok()?).ok()?;
    let direction = match v["direction"].as_str()? {
        "forward" => Direction::Forward,
        "back" => Direction::Back,
        _ => return None,
    };
    let steps = v["steps"]
        .as_array()?
        .iter()
        .map(|s| {
            Some(Step {
                from: path_from(&s["from"]),
                to: path_from(&s["to"])?,
                backup: path_from(&s["backup"]),
            })
        })
        .collect::<Option<Vec<Step>>>()?;
    let journals = v["journals"]
        .as_array()?
        .iter()
        .map(path_from)
        .collect::<Option<Vec<PathBuf>>>()?;
    Some((direction, steps, journals))
}

/// Finishes the commits whose process died in `dir` (their records) and removes the temporary
/// files there whose writer is gone; once per folder and process, and only when no other run
/// holds the folder's lock (that run, or the next, does it then).
pub(super) fn recover_folder(dir: &Path) {
    static DONE: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);
    let key = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    {
        let mut done = DONE.lock().unwrap_or_else(|e| e.into_inner());
        if !done.get_or_insert_with(HashSet::new).insert(key) {
            return;
        }
    }
    // The records first: finishing one takes the locks of all its folders, this one included.
    let records = match locked_scan(dir) {
        Some((_lock, found)) => found
            .into_iter()
            .filter(|p| p.as_os_str().as_encoded_bytes().ends_with(b".journal"))
            .collect(),
        None => Vec::new(),
    };
    for r in &records {
        finish_record(r);
    }
    if let Some((_lock, found)) = locked_scan(dir) {
        for t in found {
            remove_if_orphaned(&t);
        }
    }
}

/// The folder's lock, when no other run holds it, and the temporary names (`.lobe-*`) in it.
fn locked_scan(dir: &Path) -> Option<(File, Vec<PathBuf>)> {
    let lock = File::open(dir).ok()?;
    lock.try_lock().ok()?;
    let found = std::fs::read_dir(dir)
        .ok()?
        .flatten()
        .filter(|e| e.file_name().as_encoded_bytes().starts_with(b".lobe-"))
        .map(|e| e.path())
        .collect();
    Some((lock, found))
}

/// Completes or undoes the commit recorded in `record`, under the locks of its folders.
fn finish_record(record: &Path) {
    let Some((direction, steps, journals)) = read_journal(record) else {
        return;
    };
    let dirs = folders(
        steps
            .iter()
            .map(|s| s.to.as_path())
            .chain(std::iter::once(record)),
    );
    let Ok(_locks) = lock_folders(dirs.iter().map(PathBuf::as_path)) else {
        return;
    };
    // Another run may have finished it while this one waited for the locks.
    if std::fs::symlink_metadata(record).is_err() {
        return;
    }
    match direction {
        Direction::Forward => redo(&steps),
        Direction::Back => {
            undo(&steps);
        }
    }
    for d in &dirs {
        let _ = sync_folder(d);
    }
    remove_journals(&journals);
    let _ = std::fs::remove_file(record);
}

/// Removes a temporary file or staging folder left by a run that is gone: its writer holds a lock
/// on it while it lives, so one this process can lock has none. Called under the folder's lock,
/// where no commit runs: backups (`.old`) and half-written records are left over too, and a
/// record still there could not be finished (its other folders locked): it stays.
fn remove_if_orphaned(path: &Path) {
    let name = path
        .file_name()
        .map(|n| n.as_encoded_bytes())
        .unwrap_or(b"");
    if name.ends_with(b".journal") {
        return;
    }
    let leftover = name.ends_with(b".old") || name.ends_with(b".journal-new");
    if !leftover {
        let Ok(f) = File::open(path) else {
            return;
        };
        if f.try_lock().is_err() {
            return;
        }
    }
    let meta = std::fs::symlink_metadata(path);
    let _ = match meta {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(path),
        Ok(_) => std::fs::remove_file(path),
        Err(_) => Ok(()),
    };
}
