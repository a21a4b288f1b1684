use super::commit::FAIL_RENAME_AT;
use super::*;
use std::io::Write;

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

/// Writes a record `name` in `dir` for a set of `kind` with `members`.
fn record(dir: &Path, name: &str, kind: &str, members: &[&str]) -> Result<()> {
    let paths: Vec<PathBuf> = members.iter().map(|m| dir.join(m)).collect();
    let refs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    let v = serde_json::json!({ "set": set_json(kind, &refs) });
    std::fs::write(dir.join(name), v.to_string())?;
    Ok(())
}

/// `L_avg.npy` belongs to the LUT whose record is `L.json` (its name cut at the `_`): a file
/// written on its own over it is refused, naming the set, before any file is made.
#[test]
fn a_member_is_found_through_its_records_name() -> Result<()> {
    let dir = tempfile::tempdir()?;
    record(
        dir.path(),
        "L.json",
        "lut",
        &["L.npy", "L_avg.npy", "L.json"],
    )?;
    std::fs::write(dir.path().join("L_avg.npy"), "old")?;
    let text = FileSet::new(&[&dir.path().join("L_avg.npy")])
        .err()
        .map(|e| format!("{e:#}"))
        .unwrap_or_default();
    assert!(
        text.contains("lut set") && text.contains("L.json"),
        "{text}"
    );
    assert_eq!(names(dir.path()), ["L.json", "L_avg.npy"]);
    Ok(())
}

/// A set of the same kind and record replaces the earlier one and removes the members it no
/// longer has; a file named like a member but listed by no record is left alone.
#[test]
fn a_set_of_the_same_kind_loses_its_stale_members() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    record(d, "t.json", "table", &["t.npy", "t_extra.npy", "t.json"])?;
    for n in ["t.npy", "t_extra.npy", "t_other.npy"] {
        std::fs::write(d.join(n), "old")?;
    }
    let (npy, json) = (d.join("t.npy"), d.join("t.json"));
    let set = FileSet::new_set("table", &[&npy, &json], 1)?;
    set[0].file().write_all(b"new")?;
    let v = serde_json::json!({ "set": set_json("table", &[&npy, &json]) });
    set[1].file().write_all(v.to_string().as_bytes())?;
    set.commit()?;
    assert_eq!(names(d), ["t.json", "t.npy", "t_other.npy"]);
    assert_eq!(std::fs::read_to_string(&npy)?, "new");
    Ok(())
}
