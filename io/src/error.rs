//! The error every reader and writer returns.

use std::fmt;
use std::path::{Path, PathBuf};

/// A file that could not be read or written: which file, what was wrong, what was expected.
#[derive(Debug)]
pub struct IoError {
    path: PathBuf,
    message: String,
    source: Option<std::io::Error>,
}

impl IoError {
    /// An error about `path`; `message` says what was wrong and what was expected.
    pub fn new(path: &Path, message: impl Into<String>) -> IoError {
        IoError {
            path: path.to_path_buf(),
            message: message.into(),
            source: None,
        }
    }

    /// An operating-system error met while `doing` something with `path` ("cannot read").
    pub fn os(path: &Path, doing: &str, source: std::io::Error) -> IoError {
        IoError {
            path: path.to_path_buf(),
            message: format!("{doing}: {source}"),
            source: Some(source),
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What was wrong, without the file name.
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for IoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for IoError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source
            .as_ref()
            .map(|e| e as &(dyn std::error::Error + 'static))
    }
}
