//! The runner's error: a config problem (the message names the file, line and key), a file that
//! could not be read or written (named), or an error of a kind's own work, carried as it is.

use std::path::Path;

/// Errors of the runner and of the kinds it runs.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A config, parameter or input problem, in words that name the culprit.
    #[error("{0}")]
    Config(String),
    /// A config problem at a known place (file and line, sweep element, `--set` flag) with its
    /// key, kept as it is so that a caller can ask where it was; shown as the config error.
    #[error(transparent)]
    Place(#[from] crate::config::ConfigError),
    /// A file or directory that could not be read or written.
    #[error("{path}: {reason}")]
    Io { path: String, reason: String },
    /// An error of a kind's own work (its numerical crates, its device), shown as it is.
    #[error(transparent)]
    Kind(Box<dyn std::error::Error + Send + Sync>),
    /// The caller asked the plan to stop ([`crate::run_plan_until`]); the runs finished before
    /// are committed, the others are left for the next start.
    #[error("interrupted: {done} run(s) finished and saved in {csv}; the others are left for the next start of the same plan")]
    Interrupted { done: usize, csv: String },
}

impl From<shscale_files::Error> for Error {
    fn from(e: shscale_files::Error) -> Self {
        Self::Io {
            path: e.path,
            reason: e.reason,
        }
    }
}

impl From<shscale_present::Error> for Error {
    fn from(e: shscale_present::Error) -> Self {
        match e {
            shscale_present::Error::Config(m) => Self::Config(m),
            shscale_present::Error::Io { path, reason } => Self::Io { path, reason },
        }
    }
}

impl Error {
    /// A file error naming `path`.
    pub fn io(path: &Path, e: impl std::fmt::Display) -> Self {
        Self::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        }
    }
}
