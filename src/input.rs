//! Refused request values, tagged with the option they came from. A job's messages name the
//! value and its valid range in the library's own words; the tag lets a front end (the command
//! line, a form) point at its own spelling of that option without parsing the sentence.
//! Input files are read through [`open_input`] and [`read_regular`]: regular files only, each
//! with a bound on what is read.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// A request value a job refuses. `option` is the library's name for the input (a field of the
/// job's options, such as `"theta_i_deg"` or `"samples"`); the message is a whole sentence.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct BadInput {
    /// The library's name for the input that was refused.
    pub option: &'static str,
    /// What is wrong with it, naming the value and the valid range.
    pub message: String,
}

impl BadInput {
    /// A refusal of `option` with the sentence `message`.
    pub fn new(option: &'static str, message: impl Into<String>) -> BadInput {
        BadInput {
            option,
            message: message.into(),
        }
    }
}

/// The tag of the first [`BadInput`] anywhere in an error's chain.
pub fn option_of(e: &anyhow::Error) -> Option<&'static str> {
    // A BadInput added as context is found by downcasting the error itself; one that is a
    // cause, in the chain.
    e.downcast_ref::<BadInput>()
        .or_else(|| e.chain().find_map(|c| c.downcast_ref::<BadInput>()))
        .map(|b| b.option)
}

/// What kind of thing a path that is not a regular file is, for a message.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a folder"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading when it is a regular file once symbolic links are followed, and
/// returns it with its length. Anything else (a folder, a FIFO, a device such as /dev/zero, a
/// socket) is refused before a byte is read, with an error of kind `InvalidInput` that says what
/// it is, so no input can block the process or feed it without end. The file is opened without
/// blocking (a path swapped for a FIFO after the check cannot hang the open) and checked again
/// through the open handle.
pub fn open_regular(path: &Path) -> io::Result<(File, u64)> {
    let not_regular = |meta: &std::fs::Metadata| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{}; only a regular file can be read", kind_of(meta)),
        )
    };
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    Ok((file, meta.len()))
}

/// [`open_regular`] with a message naming the input: "cannot read scene x.toml: a folder; …";
/// `what` is the input's kind ("scene", "pairs file").
pub fn open_input(path: &Path, what: &str) -> anyhow::Result<(File, u64)> {
    open_regular(path).map_err(|e| anyhow::anyhow!("cannot read {what} {}: {e}", path.display()))
}

/// The bytes of the regular file `path` ([`open_input`]), refused when it holds more than
/// `max_bytes` (checked from its length before reading, and again while reading, should it
/// grow).
pub fn read_regular(path: &Path, what: &str, max_bytes: u64) -> anyhow::Result<Vec<u8>> {
    let (file, len) = open_input(path, what)?;
    let too_large = |n: u64| {
        anyhow::anyhow!(
            "{what} {} is {n} bytes; at most {max_bytes} bytes are read",
            path.display()
        )
    };
    if len > max_bytes {
        return Err(too_large(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| anyhow::anyhow!("cannot read {what} {}: {e}", path.display()))?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Text without the UTF-8 byte-order mark some editors put at its start.
pub fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[test]
    fn only_regular_files_within_their_bound_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "12345").unwrap();
        assert_eq!(read_regular(&file, "test input", 5).unwrap(), b"12345");
        let e = read_regular(&file, "test input", 4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("is 5 bytes; at most 4"), "{e}");
        let e = read_regular(dir.path(), "test input", 4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("a folder"), "{e}");
        #[cfg(unix)]
        {
            let e = read_regular(Path::new("/dev/zero"), "test input", 4).unwrap_err();
            assert!(e.to_string().contains("a device"), "{e}");
            let link = dir.path().join("zero.npy");
            std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
            let e = read_regular(&link, "test input", 4).unwrap_err();
            assert!(e.to_string().contains("a device"), "{e}");
            let fifo = dir.path().join("fifo");
            let c_path = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path; mkfifo only creates the node.
            assert_eq!(unsafe { libc::mkfifo(c_path.as_ptr(), 0o600) }, 0);
            let e = read_regular(&fifo, "test input", 4).unwrap_err();
            assert!(e.to_string().contains("FIFO"), "{e}");
        }
    }

    #[test]
    fn the_tag_is_found_under_added_context() {
        let e: anyhow::Result<()> = Err(BadInput::new("samples", "samples = 0: too few").into());
        let e = e.context("while planning").unwrap_err();
        assert_eq!(option_of(&e), Some("samples"));
        assert_eq!(format!("{e:#}"), "while planning: samples = 0: too few");
        assert_eq!(option_of(&anyhow::anyhow!("plain")), None);
    }
}
