//! The ground floor's file error: the path and what went wrong.

/// A file or folder that could not be read or written, named.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: {reason}")]
pub struct Error {
    pub path: String,
    pub reason: String,
}

impl Error {
    /// A file error naming `path`.
    pub fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self {
            path: path.display().to_string(),
            reason: e.to_string(),
        }
    }
}
