//! Reading the files a user names (scenes, glTF buffers and images, traces,
//! experiment files, MaterialX documents bound from a glTF): only regular
//! files, and a declared length is read at most. A device (`/dev/zero`,
//! `/dev/urandom`), a FIFO or a directory would otherwise be read until
//! memory runs out, or block forever; each is refused with an I/O error
//! whose message says what the path is, for the caller to prefix with the
//! file's name.

use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Every file this process has checked or read as input, canonical (what
/// [`overwritten_input`] compares outputs against).
static READ: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Fails unless `path` (after symlinks) is a regular file; records it as
/// one of the run's inputs.
pub fn check_regular(path: &Path) -> io::Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path)?;
    if meta.is_file() {
        if let Ok(c) = std::fs::canonicalize(path) {
            let mut read = READ.lock().unwrap_or_else(|e| e.into_inner());
            if !read.contains(&c) {
                read.push(c);
            }
        }
        return Ok(meta);
    }
    let what = if meta.is_dir() {
        "a directory"
    } else {
        "a device, FIFO or socket"
    };
    Err(io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("not a regular file ({what})"),
    ))
}

/// Opens a regular file (checked before opening, so a FIFO does not block,
/// and again on the handle).
fn open_regular(path: &Path) -> io::Result<(std::fs::File, u64)> {
    check_regular(path)?;
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    Ok((file, meta.len()))
}

/// The bytes of a regular file.
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    read_at_most(path, u64::MAX)
}

/// The first `limit` bytes of a regular file (all of it when shorter).
pub fn read_at_most(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let (file, len) = open_regular(path)?;
    let want = len.min(limit);
    let mut out = Vec::with_capacity(usize::try_from(want).unwrap_or(0).min(1 << 30));
    file.take(want).read_to_end(&mut out)?;
    Ok(out)
}

/// The length of a regular file, without reading it.
pub fn regular_len(path: &Path) -> io::Result<u64> {
    Ok(check_regular(path)?.len())
}

/// The text of a regular file (UTF-8).
pub fn read_to_string(path: &Path) -> io::Result<String> {
    let bytes = read(path)?;
    // A UTF-16 file (as some editors save text) is named as such.
    let what = if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        "the text is UTF-16 (it starts with a UTF-16 byte-order mark); save it as UTF-8"
    } else {
        "stream did not contain valid UTF-8"
    };
    String::from_utf8(bytes).map_err(|_| io::Error::new(io::ErrorKind::InvalidData, what))
}

/// The first input file this process has read (a scene, its buffers and
/// images, an environment map, a trace, a MaterialX document) that a run
/// writing into the folder `out` would overwrite: one whose folder is `out`
/// (after symlinks) and whose path relative to it `writes` names. None where
/// `out` does not exist yet. Until session 52 `render` and `replay` wrote
/// over such files without a word (an environment map named left.exr, a
/// trace named frames.jsonl, a texture named left.png in the scene's
/// folder; an audit's finding).
pub fn overwritten_input(out: &Path, writes: &dyn Fn(&Path) -> bool) -> Option<PathBuf> {
    let out = std::fs::canonicalize(out).ok()?;
    let read = READ.lock().unwrap_or_else(|e| e.into_inner());
    read.iter()
        .find(|p| p.strip_prefix(&out).is_ok_and(writes))
        .cloned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_without_reading() {
        for p in ["/dev/zero", "/dev/urandom", "/dev/null"] {
            if Path::new(p).exists() {
                let e = read(Path::new(p)).unwrap_err().to_string();
                assert!(e.contains("not a regular file (a device"), "{p}: {e}");
                assert!(read_to_string(Path::new(p)).is_err());
            }
        }
        let e = read(&std::env::temp_dir()).unwrap_err().to_string();
        assert!(e.contains("a directory"), "{e}");
    }

    /// A UTF-16 file is named as such (it was "not valid UTF-8").
    #[test]
    fn utf16_text_is_named() {
        let p = std::env::temp_dir().join(format!("stereocache-utf16-{}", std::process::id()));
        std::fs::write(&p, [0xFF, 0xFE, b't', 0, b',', 0]).unwrap();
        let e = read_to_string(&p).unwrap_err().to_string();
        assert!(e.contains("UTF-16"), "{e}");
        std::fs::write(&p, [0xC3, 0x28]).unwrap();
        let e = read_to_string(&p).unwrap_err().to_string();
        assert!(e.contains("not contain valid UTF-8"), "{e}");
        std::fs::remove_file(&p).unwrap();
    }

    #[test]
    fn reads_stop_at_the_limit() {
        let p = std::env::temp_dir().join(format!("stereocache-input-{}", std::process::id()));
        std::fs::write(&p, b"0123456789").unwrap();
        assert_eq!(read_at_most(&p, 4).unwrap(), b"0123");
        assert_eq!(read(&p).unwrap(), b"0123456789");
        assert_eq!(regular_len(&p).unwrap(), 10);
        std::fs::remove_file(&p).unwrap();
    }
}
