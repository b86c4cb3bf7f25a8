//! Atomic file output: every file the runner writes goes to a temporary beside its target and is
//! renamed into place, so an interrupted run never leaves a partial file under the final name;
//! several files can be written as a unit ([`write_atomic_all`]).

use crate::error::Error;
use std::path::{Path, PathBuf};

/// The temporary beside `path` that atomic writes go through: `.<name>.tmp-<pid>`.
pub fn tmp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Temporary files that must not outlive an error: each path handed out by
/// [`Temporaries::beside`] is removed when the guard drops, on every path out — a temporary
/// already renamed into place no longer exists, so its removal is a no-op.
#[derive(Default)]
pub struct Temporaries(Vec<PathBuf>);

impl Temporaries {
    pub fn new() -> Self {
        Self::default()
    }

    /// The temporary beside `path`, `.<stem>.tmp-<pid>.<extension>` (the extension kept: image
    /// encoders choose their format by it), removed when the guard drops.
    pub fn beside(&mut self, path: &Path) -> PathBuf {
        let stem = (path.file_stem()).map_or(String::new(), |n| n.to_string_lossy().to_string());
        let ext = (path.extension()).map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
        let t = path.with_file_name(format!(".{stem}.tmp-{}{ext}", std::process::id()));
        self.0.push(t.clone());
        t
    }
}

impl Drop for Temporaries {
    fn drop(&mut self) {
        for t in &self.0 {
            let _ = std::fs::remove_file(t);
        }
    }
}

/// Write `text` to `path` through a temporary file and a rename; the temporary is removed when
/// either step fails.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), Error> {
    write_atomic_all(&[(path, text)])
}

/// Write several files as a unit: every text to a temporary beside its target first, then the
/// renames, in order; when any write fails no target is touched, and every error path removes
/// the temporaries not yet renamed. A directory at a target is refused before anything is
/// written.
pub fn write_atomic_all(files: &[(&Path, &str)]) -> Result<(), Error> {
    let tmp_of = tmp_path;
    if let Some((p, _)) = files.iter().find(|(p, _)| p.is_dir()) {
        return Err(Error::io(p, "is a directory"));
    }
    let mut written: Vec<PathBuf> = Vec::new();
    let cleanup = |tmps: &[PathBuf]| {
        for t in tmps {
            let _ = std::fs::remove_file(t);
        }
    };
    for (path, text) in files {
        let tmp = tmp_of(path);
        if let Err(e) = std::fs::write(&tmp, text) {
            let _ = std::fs::remove_file(&tmp);
            cleanup(&written);
            return Err(Error::io(path, e));
        }
        written.push(tmp);
    }
    for (i, (path, _)) in files.iter().enumerate() {
        if let Err(e) = std::fs::rename(&written[i], path) {
            cleanup(&written[i..]);
            return Err(Error::io(path, e));
        }
    }
    Ok(())
}
