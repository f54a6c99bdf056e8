//! The one error type of scene loading: names the file, the item and the problem.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl SceneError {
    pub fn invalid(path: &Path, message: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
    /// A failure to create or write `path` (not "cannot read").
    pub fn write(path: &Path, source: std::io::Error) -> Self {
        SceneError::invalid(path, format!("cannot write: {source}"))
    }
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        SceneError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
