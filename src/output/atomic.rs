//! The one way every output file is written (images, first hits, JSON, CSV,
//! HTML, jsonl, cached references): under a temporary name next to its final
//! one (`NAME.partial`), synced to disk, then renamed into place. A write that
//! fails (disk full, permissions, ...) returns an error naming the *final*
//! path, so a file under its final name is always complete and a failed write
//! leaves nothing behind that looks finished. [`write_file`] removes its
//! temporary on failure; a streamed [`AtomicFile`] that is dropped without
//! [`AtomicFile::commit`] (a run that failed or was interrupted half way)
//! keeps `NAME.partial`, which shows how far it got.
//!
//! Encoders (PNG, EXR) write into memory first and hand the bytes to
//! [`write_file`]: a library writer that buffers internally and flushes on
//! drop would swallow the error of its last write (`image::save_buffer` did:
//! a full disk left a 0-byte PNG that was then renamed into place).

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: cannot write: {message}")]
    Write { path: PathBuf, message: String },
}

impl OutputError {
    /// The final path and the problem (`cannot write: ...`), for error
    /// types of other modules that name the file themselves.
    pub fn into_parts(self) -> (PathBuf, String) {
        match self {
            OutputError::Write { path, message } => (path, format!("cannot write: {message}")),
        }
    }

    fn new(path: &Path, message: impl std::fmt::Display) -> Self {
        OutputError::Write {
            path: path.to_path_buf(),
            message: message.to_string(),
        }
    }
}

/// `path` with `.partial` appended to its file name.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// A file being written under its temporary name; [`AtomicFile::commit`]
/// puts it in place, dropping it uncommitted leaves only `NAME.partial`.
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    file: File,
}

impl AtomicFile {
    /// Creates `path`'s parent directories and opens `path.partial` for writing.
    /// A `path` that exists as something other than a regular file (a
    /// device such as `/dev/null`, a FIFO, a socket, a folder) is refused:
    /// the rename into place would replace it (`trace convert --out
    /// /dev/null` turned the system's /dev/null into a regular file; an
    /// audit's run found it).
    pub fn create(path: &Path) -> Result<Self, OutputError> {
        not_special(path)?;
        if let Some(parent) = path.parent() {
            if !parent.as_os_str().is_empty() {
                std::fs::create_dir_all(parent).map_err(|e| OutputError::new(path, e))?;
            }
        }
        let tmp = partial_path(path);
        let file = File::create(&tmp).map_err(|e| OutputError::new(path, e))?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            file,
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends `bytes` (unbuffered: callers write whole records or files).
    pub fn write_all(&mut self, bytes: &[u8]) -> Result<(), OutputError> {
        self.file
            .write_all(bytes)
            .map_err(|e| OutputError::new(&self.path, e))
    }

    /// Syncs the data to disk (errors a full disk reports late surface
    /// here, not lost in a close) and renames the file into place. On
    /// failure the temporary is removed: it is known to be broken.
    pub fn commit(self) -> Result<(), OutputError> {
        let AtomicFile { path, tmp, file } = self;
        if let Err(e) = not_special(&path) {
            drop(file);
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        let done = file
            .sync_all()
            .and_then(|()| {
                drop(file);
                std::fs::rename(&tmp, &path)
            })
            .map_err(|e| OutputError::new(&path, e));
        if done.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        done
    }

    /// Closes and removes the temporary.
    pub fn discard(self) {
        let AtomicFile { tmp, file, .. } = self;
        drop(file);
        let _ = std::fs::remove_file(&tmp);
    }
}

/// Fails where `path` exists (after symlinks) as anything but a regular file.
fn not_special(path: &Path) -> Result<(), OutputError> {
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => Err(OutputError::new(
            path,
            if m.is_dir() {
                "it is a directory, not a file"
            } else {
                "it is a device, FIFO or socket, not a regular file"
            },
        )),
        _ => Ok(()),
    }
}

/// Writes `bytes` as the file `path` (see the module documentation); on any
/// failure nothing is left, under either name.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut f = AtomicFile::create(path)?;
    match f.write_all(bytes) {
        Ok(()) => f.commit(),
        Err(e) => {
            f.discard();
            Err(e)
        }
    }
}

/// Writes what `encode` produces as the file `path`; an encoding error is
/// reported like a write error and writes nothing.
pub fn write_encoded(
    path: &Path,
    encode: impl FnOnce(&mut Vec<u8>) -> Result<(), String>,
) -> Result<(), OutputError> {
    let mut bytes = Vec::new();
    encode(&mut bytes).map_err(|e| OutputError::new(path, e))?;
    write_file(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("stereocache-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_written_file_is_complete_and_leaves_no_temporary() {
        let d = dir("ok");
        let p = d.join("sub/a.txt");
        write_file(&p, b"hello").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"hello");
        assert!(!partial_path(&p).exists());
        // Replacing an existing file.
        write_file(&p, b"bye").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"bye");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn an_uncommitted_file_stays_partial() {
        let d = dir("drop");
        let p = d.join("a.jsonl");
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.write_all(b"{}\n").unwrap();
        }
        assert!(!p.exists());
        assert_eq!(std::fs::read(partial_path(&p)).unwrap(), b"{}\n");
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"[]\n").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"[]\n");
        assert!(!partial_path(&p).exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn an_encoding_error_writes_nothing() {
        let d = dir("enc");
        let p = d.join("a.png");
        let e = write_encoded(&p, |_| Err("no".into())).unwrap_err();
        assert!(e.to_string().contains("a.png: cannot write: no"), "{e}");
        assert!(!p.exists() && !partial_path(&p).exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    /// A special file is never replaced by the rename (`/dev/null` became a
    /// regular file under `trace convert --out /dev/null`): a FIFO made for
    /// the test stands in for the device, which a regression would break.
    #[cfg(unix)]
    #[test]
    fn special_files_are_not_replaced() {
        let p = std::env::temp_dir().join(format!("sc-fifo-{}", std::process::id()));
        let _ = std::fs::remove_file(&p);
        let made = std::process::Command::new("mkfifo").arg(&p).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo (coreutils) failed");
        let e = write_file(&p, b"x").unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        assert!(!std::fs::metadata(&p).unwrap().is_file());
        assert!(!partial_path(&p).exists());
        std::fs::remove_file(&p).unwrap();
    }
}
