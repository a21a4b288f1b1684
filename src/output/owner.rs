//! Which set owns a file: a set of a kind (a table, a LUT, an engine LUT) names its kind and
//! its members in its JSON sidecar, its record:
//!
//! ```json
//! "set": { "kind": "table", "members": ["t.npy", "t.exr", "t.json"] }
//! ```
//!
//! The record of a member `NAME.EXT` is found beside it as `NAME.json`, or, cutting `NAME` at
//! each `_` from the right, as `PREFIX.json` (`L_avg.npy` belongs to the LUT `L.json`). A run
//! replaces a set only with one of the same kind and record, removing the members that set had
//! and the new one lacks; it refuses, before any work, to replace a member of another set, or
//! (for a set of a kind) a file that no set owns, unless told to replace such sets whole
//! ([`replace_sets`]: the command line's `--replace`).

use super::{folder_of, resolve};
use anyhow::Result;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// The kind of a table's set (`.npy`, `.exr`, `.json`).
pub const TABLE_SET: &str = "table";
/// The kind of an albedo LUT's set (`.npy`, `_avg.npy`, `.exr`, `.json`).
pub const LUT_SET: &str = "lut";
/// The kind of an engine LUT's set (`.npy`, maybe `_avg.npy`, `.exr`, `.h`, `.json`).
pub const ENGINE_LUT_SET: &str = "engine_lut";
/// The kind of a sampler's draws (`.npy`, `.json`).
pub const SAMPLES_SET: &str = "samples";

static REPLACE: AtomicBool = AtomicBool::new(false);

/// Lets every later commit of this process replace whole the sets (and the files no set owns)
/// that its files would overwrite, instead of refusing.
pub fn replace_sets(replace: bool) {
    REPLACE.store(replace, Ordering::SeqCst);
}

/// The largest record read: sidecars are a few kilobytes; a bigger `.json` is someone else's.
const MAX_RECORD_BYTES: u64 = 1 << 20;

/// What a set's record says: `"set": {"kind": …, "members": […]}` for `members` (paths in the
/// record's folder, the record among them), to put into the record.
pub fn set_json(kind: &str, members: &[&Path]) -> Value {
    let names: Vec<String> = members
        .iter()
        .map(|m| {
            m.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        })
        .collect();
    serde_json::json!({ "kind": kind, "members": names })
}

/// Refuses `dest`, a file written on its own, where it is a member of a set (see [`plan`]).
pub(super) fn check_single(dest: &Path) -> Result<()> {
    let group = Group {
        kind: None,
        record: None,
        record_file: None,
        members: vec![dest.to_path_buf()],
    };
    let dest = resolve(dest);
    plan(&group, &|p| *p == dest).map(drop)
}

/// A set as its record describes it.
pub(super) struct Owner {
    kind: String,
    /// The record, resolved ([`resolve`]).
    record: PathBuf,
    /// Every member, in the record's folder.
    members: Vec<PathBuf>,
}

impl Owner {
    fn describe(&self) -> String {
        let names: Vec<String> = self
            .members
            .iter()
            .filter_map(|m| m.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .collect();
        format!(
            "the {} set of {} ({})",
            self.kind,
            self.record.display(),
            names.join(", ")
        )
    }
}

/// The set `record` describes, if it is a set's record.
fn read_record(record: &Path) -> Option<Owner> {
    let meta = std::fs::metadata(record).ok()?;
    if !meta.is_file() || meta.len() > MAX_RECORD_BYTES {
        return None;
    }
    let v: Value = serde_json::from_slice(&std::fs::read(record).ok()?).ok()?;
    let set = v.get("set")?;
    let kind = set.get("kind")?.as_str()?.to_string();
    let dir = folder_of(record);
    let members = set
        .get("members")?
        .as_array()?
        .iter()
        .map(|m| {
            let name = m.as_str()?;
            // A member is a name in the record's folder, nothing else.
            (!name.is_empty() && !name.contains('/') && name != "." && name != "..")
                .then(|| dir.join(name))
        })
        .collect::<Option<Vec<PathBuf>>>()?;
    Some(Owner {
        kind,
        record: resolve(record),
        members,
    })
}

/// The set that owns `file` (which exists): the first record among its candidates that lists it.
fn owner_of(file: &Path) -> Option<Owner> {
    let name = file.file_name()?.to_str()?;
    let dir = folder_of(file);
    let stem = match name.rsplit_once('.') {
        Some((stem, _)) if !stem.is_empty() => stem,
        _ => name,
    };
    let mut prefix = Some(stem);
    while let Some(p) = prefix {
        if let Some(owner) = read_record(&dir.join(format!("{p}.json"))) {
            if owner
                .members
                .iter()
                .any(|m| m.file_name() == file.file_name())
            {
                return Some(owner);
            }
        }
        prefix = p
            .rsplit_once('_')
            .map(|(head, _)| head)
            .filter(|h| !h.is_empty());
    }
    None
}

/// Files of one set in a [`super::FileSet`]: of a kind, with its record, or (no kind) a file
/// written on its own, such as a plot.
pub(super) struct Group {
    pub(super) kind: Option<String>,
    /// The record's destination.
    pub(super) record: Option<PathBuf>,
    /// The record's index in its [`super::FileSet`].
    pub(super) record_file: Option<usize>,
    pub(super) members: Vec<PathBuf>,
}

fn exists(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok()
}

/// What committing `group` must also remove: the members of its own earlier set that it lacks,
/// and, when replacing ([`replace_sets`]), the rest of every set it overwrites a member of.
/// Refuses (naming both sets) a member of another set, or, for a set of a kind, a file no set
/// owns, unless replacing. `claimed` says whether a resolved path is a destination of the whole
/// transaction.
pub(super) fn plan(group: &Group, claimed: &dyn Fn(&Path) -> bool) -> Result<Vec<PathBuf>> {
    let own_record = group.record.as_deref().map(resolve);
    let is_own = |o: &Owner| {
        group.kind.as_deref() == Some(&o.kind) && own_record.as_ref() == Some(&o.record)
    };
    let mut removals = Vec::new();
    let mut conflicts: Vec<String> = Vec::new();
    let mut replaced: Vec<(Owner, Vec<String>)> = Vec::new();
    let mut unowned: Vec<String> = Vec::new();
    for dest in group.members.iter().filter(|d| exists(d)) {
        match owner_of(dest) {
            Some(o) if is_own(&o) => {}
            Some(o) => {
                let name = dest.display().to_string();
                match replaced.iter_mut().find(|(r, _)| r.record == o.record) {
                    Some((_, names)) => names.push(name),
                    None => replaced.push((o, vec![name])),
                }
            }
            None if group.kind.is_some() => unowned.push(dest.display().to_string()),
            None => {}
        }
    }
    for (o, names) in &replaced {
        let verb = if names.len() == 1 {
            "belongs"
        } else {
            "belong"
        };
        conflicts.push(format!("{} {verb} to {}", names.join(", "), o.describe()));
    }
    if !unowned.is_empty() {
        let verb = if unowned.len() == 1 {
            "belongs"
        } else {
            "belong"
        };
        conflicts.push(format!(
            "{} {verb} to no lobe set (another program's files, or an older lobe's)",
            unowned.join(", ")
        ));
    }
    let mut replaced: Vec<Owner> = replaced.into_iter().map(|(o, _)| o).collect();
    if let Some(o) = group
        .record
        .as_deref()
        .and_then(read_record)
        .filter(|o| is_own(o))
    {
        replaced.push(o);
    }
    for o in &replaced {
        for m in &o.members {
            if exists(m) && !claimed(&resolve(m)) && !removals.contains(m) {
                removals.push(m.clone());
            }
        }
    }
    if !conflicts.is_empty() && !REPLACE.load(Ordering::SeqCst) {
        let what = match (&group.kind, &group.record) {
            (Some(kind), Some(record)) => format!("the {kind} set of {}", record.display()),
            _ => group
                .members
                .iter()
                .map(|m| m.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        };
        // Tagged `replace`: the command line names its flag for letting a run replace them.
        return Err(crate::input::BadInput::new(
            "replace",
            format!(
                "cannot write {what}: {}; lobe replaces a set only with one of the same kind \
                 and name (remove the other files, write elsewhere, or let this run replace \
                 them, and every other member of their sets, whole)",
                conflicts.join("; ")
            ),
        )
        .into());
    }
    Ok(removals)
}
