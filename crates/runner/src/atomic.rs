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

/// Write `bytes` to `path` through a temporary file and a rename (binary files: ray sets, bit
/// masks); the temporary is removed when either step fails. A directory at `path` is refused.
pub fn write_atomic_bytes(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    if path.is_dir() {
        return Err(Error::io(path, "is a directory"));
    }
    let mut guard = Temporaries::new();
    let tmp = guard.beside(path);
    std::fs::write(&tmp, bytes).map_err(|e| Error::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
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

/// An output folder written as a unit: every file goes first into a hidden staging folder
/// (`.shscale-staging-<pid>-<n>`) made in the nearest existing ancestor of the target, so a
/// command that fails creates nothing and changes nothing under the target — the staging folder
/// is removed when the guard drops, on every path out. [`Staging::commit`] creates the target
/// and renames each staged file into it (one rename per file: a crash mid-commit can leave some
/// files new and some old, never a partial file). Files already in the target and not staged are
/// left alone.
pub struct Staging {
    dir: PathBuf,
    out: PathBuf,
}

impl Staging {
    /// Stage for `out`. Refuses an `out` that exists and is not a directory, or whose nearest
    /// existing ancestor is not one, before anything is written.
    pub fn new(out: &Path) -> Result<Self, Error> {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        if let Ok(m) = std::fs::metadata(out) {
            if !m.is_dir() {
                return Err(Error::io(out, "exists and is not a directory"));
            }
        }
        let mut base = out.to_path_buf();
        loop {
            match std::fs::metadata(&base) {
                Ok(m) if m.is_dir() => break,
                Ok(_) => {
                    return Err(Error::io(
                        out,
                        format!("{} is not a directory", base.display()),
                    ))
                }
                Err(_) => {}
            }
            base = match base.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                _ => PathBuf::from("."),
            };
        }
        let n = N.fetch_add(1, Ordering::Relaxed);
        let dir = base.join(format!(".shscale-staging-{}-{n}", std::process::id()));
        // The error names the target the user gave, not the staging folder it never saw.
        std::fs::create_dir(&dir).map_err(|e| {
            Error::io(
                out,
                format!(
                    "cannot write there (its staging folder in {}: {e})",
                    base.display()
                ),
            )
        })?;
        Ok(Self {
            dir,
            out: out.to_path_buf(),
        })
    }

    /// Where the command writes its files (flat; the names are the final names).
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The final path of a staged file.
    pub fn target(&self, staged: &Path) -> PathBuf {
        match staged.strip_prefix(&self.dir) {
            Ok(rest) => self.out.join(rest),
            Err(_) => staged.to_path_buf(),
        }
    }

    /// Create the target folder and move every staged file into it; the staged paths in `files`
    /// are returned as their final paths. A directory in the target where a staged file goes is
    /// refused before any file moves.
    pub fn commit(self, files: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
        let mut staged: Vec<PathBuf> = Vec::new();
        for e in std::fs::read_dir(&self.dir).map_err(|e| Error::io(&self.dir, e))? {
            let e = e.map_err(|e| Error::io(&self.dir, e))?;
            if !e.file_type().is_ok_and(|t| t.is_file()) {
                return Err(Error::io(&e.path(), "staged output is not a plain file"));
            }
            staged.push(e.path());
        }
        staged.sort();
        for s in &staged {
            let t = self.target(s);
            if t.is_dir() {
                return Err(Error::io(&t, "is a directory"));
            }
        }
        std::fs::create_dir_all(&self.out).map_err(|e| Error::io(&self.out, e))?;
        for s in &staged {
            let t = self.target(s);
            std::fs::rename(s, &t).map_err(|e| Error::io(&t, e))?;
        }
        Ok(files.iter().map(|f| self.target(f)).collect())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

#[cfg(test)]
mod staging_tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shscale-staging-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_target_that_cannot_be_written_is_named_not_its_staging_folder() {
        // /proc takes no new folder: the error names the target the user gave.
        if !Path::new("/proc/self").exists() {
            eprintln!("notice: no /proc: skipped");
            return;
        }
        let e = Staging::new(Path::new("/proc/figs"))
            .err()
            .expect("/proc is not writable");
        let m = e.to_string();
        println!("{m}");
        assert!(
            m.starts_with("/proc/figs:") && m.contains("cannot write there"),
            "{m}"
        );
    }

    #[test]
    fn a_dropped_staging_leaves_nothing_and_a_commit_moves_every_file() {
        let d = scratch("unit");
        let out = d.join("a/b/out");
        {
            let s = Staging::new(&out).unwrap();
            std::fs::write(s.path().join("x.txt"), "x").unwrap();
            // Dropped without commit: an error path.
        }
        let left: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().collect();
        assert!(left.is_empty(), "left behind: {left:?}");
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join("keep.txt"), "old").unwrap();
        std::fs::write(out.join("x.txt"), "old").unwrap();
        let s = Staging::new(&out).unwrap();
        let staged = s.path().join("x.txt");
        std::fs::write(&staged, "new").unwrap();
        let files = s.commit(&[staged]).unwrap();
        assert_eq!(files, vec![out.join("x.txt")]);
        assert_eq!(std::fs::read_to_string(out.join("x.txt")).unwrap(), "new");
        assert_eq!(
            std::fs::read_to_string(out.join("keep.txt")).unwrap(),
            "old"
        );
        let names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().to_string())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        let parent: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(parent, vec![std::ffi::OsString::from("a")]);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_file_where_the_folder_or_an_ancestor_should_be_is_refused_before_writing() {
        let d = scratch("refuse");
        std::fs::write(d.join("f"), "f").unwrap();
        for out in [d.join("f"), d.join("f/sub/deeper")] {
            let e = Staging::new(&out).err().expect("refused").to_string();
            assert!(e.contains("not a directory"), "{e}");
        }
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("f")]);
        std::fs::remove_dir_all(&d).ok();
    }
}
