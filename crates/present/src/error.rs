//! The presentation's error: a request that cannot be drawn, or a file.

/// A presentation error: a request that cannot be drawn (named in words), or a file that could
/// not be read or written (named).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A plot or figure asked for what cannot be drawn, in words that name the culprit.
    #[error("{0}")]
    Config(String),
    /// A file that could not be read or written.
    #[error("{path}: {reason}")]
    Io { path: String, reason: String },
}

impl Error {
    /// A file error naming `path`.
    pub fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        }
    }
}

impl From<shscale_files::Error> for Error {
    fn from(e: shscale_files::Error) -> Self {
        Self::Io {
            path: e.path,
            reason: e.reason,
        }
    }
}
