//! Atomic, durable file output: every file the runner writes goes to a temporary beside its
//! target, is flushed to the disk (`fsync`), renamed into place, and the directory holding it is
//! flushed after the rename — so an interrupted run, a crash or a power cut leaves under the final
//! name either the old file or the new one, never a partial or empty one (a rename without the
//! file's `fsync` can reach the disk before the data on XFS, ext4 without `auto_da_alloc` and
//! cluster filesystems). Several files can be written as a unit ([`write_atomic_all`]).
//!
//! Temporaries are named `.<name>.tmp-<host>-<pid>-<token>` ([`tmp_path`]): the host name, the
//! process id and a random token drawn once per process, so processes on two Slurm nodes that
//! share a results folder (and may have equal pids) never write the same temporary.

use crate::error::Error;
use std::path::{Path, PathBuf};

/// The steps of one durable replace, in order; a test injects a failure at each
/// ([`tests`](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// Creating and writing the temporary.
    Write,
    /// `fsync` of the temporary's data.
    SyncFile,
    /// The rename onto the target.
    Rename,
    /// `fsync` of the directory, after the rename.
    SyncDir,
}

#[cfg(test)]
thread_local! {
    /// The step at which the next replace on this thread fails (tests only).
    pub(crate) static INJECT: std::cell::Cell<Option<Step>> = const { std::cell::Cell::new(None) };
}

/// An injected failure at `step` (tests only; always `Ok` in a build).
fn injected(step: Step, path: &Path) -> Result<(), Error> {
    #[cfg(test)]
    if INJECT.with(|c| c.get()) == Some(step) {
        INJECT.with(|c| c.set(None));
        return Err(Error::io(path, format!("injected failure at {step:?}")));
    }
    let _ = (step, path);
    Ok(())
}

/// This machine's host name as it goes into a file name (letters, digits, `-`, `.`; at most 32
/// characters; `host` when it cannot be read).
pub(crate) fn host_tag() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        let raw = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .or_else(|_| std::fs::read_to_string("/etc/hostname"))
            .unwrap_or_default();
        sanitize_host(&raw)
    })
}

/// A host name as it goes into a file name.
pub(crate) fn sanitize_host(raw: &str) -> String {
    let s: String = (raw.trim().chars())
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .take(32)
        .collect();
    if s.is_empty() {
        "host".into()
    } else {
        s
    }
}

/// A random token drawn once per process (8 hex digits, from the standard library's randomly
/// keyed hasher, the clock and the pid): a pid reused on another node, or by a later process,
/// gets another token.
pub(crate) fn process_token() -> &'static str {
    static TOKEN: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TOKEN.get_or_init(|| {
        use std::hash::{BuildHasher, Hasher};
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        h.write_u128(nanos);
        h.write_u32(std::process::id());
        format!("{:08x}", h.finish() as u32)
    })
}

/// The unique part of this process's temporary names: `<host>-<pid>-<token>`.
pub(crate) fn unique_tag() -> String {
    unique_tag_of(host_tag(), std::process::id(), process_token())
}

pub(crate) fn unique_tag_of(host: &str, pid: u32, token: &str) -> String {
    format!("{host}-{pid}-{token}")
}

/// The temporary beside `path` that atomic writes of this process go through:
/// `.<name>.tmp-<host>-<pid>-<token>`.
pub fn tmp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", unique_tag()))
}

/// `fsync` of the directory holding `path` (its entry, after a rename or a create, reaches the
/// disk). Filesystems that cannot sync a directory (`EINVAL`) are taken as done.
pub fn sync_parent(path: &Path) -> Result<(), Error> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    sync_dir(dir)
}

/// `fsync` of a directory; `EINVAL` (a filesystem without directory sync) is taken as done.
pub(crate) fn sync_dir(dir: &Path) -> Result<(), Error> {
    let f = std::fs::File::open(dir).map_err(|e| Error::io(dir, e))?;
    match f.sync_all() {
        Err(e) if e.raw_os_error() == Some(22) => Ok(()),
        r => r.map_err(|e| Error::io(dir, e)),
    }
}

/// `fsync` of a file already written (a temporary an encoder wrote by path).
pub(crate) fn sync_file(path: &Path) -> Result<(), Error> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    f.sync_all().map_err(|e| Error::io(path, e))
}

/// Rename a finished temporary onto `target` durably: the temporary's data synced first, the
/// directory after.
pub fn rename_durable(tmp: &Path, target: &Path) -> Result<(), Error> {
    injected(Step::SyncFile, target)?;
    sync_file(tmp)?;
    rename_then_sync_dir(tmp, target)
}

/// The rename of a synced temporary onto `target`, then the directory's sync.
fn rename_then_sync_dir(tmp: &Path, target: &Path) -> Result<(), Error> {
    injected(Step::Rename, target)?;
    std::fs::rename(tmp, target).map_err(|e| Error::io(target, e))?;
    injected(Step::SyncDir, target)?;
    sync_parent(target)
}

/// Write `bytes` to a new temporary at `tmp` and sync it.
fn write_synced(tmp: &Path, bytes: &[u8], target: &Path) -> Result<(), Error> {
    use std::io::Write;
    injected(Step::Write, target)?;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(tmp)
        .map_err(|e| Error::io(tmp, e))?;
    f.write_all(bytes).map_err(|e| Error::io(tmp, e))?;
    injected(Step::SyncFile, target)?;
    f.sync_all().map_err(|e| Error::io(tmp, e))
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

    /// The temporary beside `path`, `.<stem>.tmp-<host>-<pid>-<token>.<extension>` (the
    /// extension kept: image encoders choose their format by it), removed when the guard drops.
    pub fn beside(&mut self, path: &Path) -> PathBuf {
        let t = tmp_keeping_extension(path);
        self.0.push(t.clone());
        t
    }
}

/// The temporary beside `path` that keeps its extension:
/// `.<stem>.tmp-<host>-<pid>-<token>.<extension>`.
pub fn tmp_keeping_extension(path: &Path) -> PathBuf {
    let stem = (path.file_stem()).map_or(String::new(), |n| n.to_string_lossy().to_string());
    let ext = (path.extension()).map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
    path.with_file_name(format!(".{stem}.tmp-{}{ext}", unique_tag()))
}

impl Drop for Temporaries {
    fn drop(&mut self) {
        for t in &self.0 {
            let _ = std::fs::remove_file(t);
        }
    }
}

/// Write `text` to `path` through a synced temporary, a rename and the directory's sync; the
/// temporary is removed when any step fails (the target then keeps its old bytes).
pub fn write_atomic(path: &Path, text: &str) -> Result<(), Error> {
    write_atomic_all(&[(path, text)])
}

/// Write `bytes` to `path` durably as [`write_atomic`] does (binary files: ray sets, bit
/// masks). A directory at `path` is refused.
pub fn write_atomic_bytes(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    if path.is_dir() {
        return Err(Error::io(path, "is a directory"));
    }
    let mut guard = Temporaries::new();
    let tmp = guard.beside(path);
    write_synced(&tmp, bytes, path)?;
    rename_then_sync_dir(&tmp, path)
}

/// Write several files as a unit: every text to a synced temporary beside its target first,
/// then the renames, in order, each followed by its directory's sync; when any write fails no
/// target is touched, and every error path removes the temporaries not yet renamed. A directory
/// at a target is refused before anything is written.
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
        if let Err(e) = write_synced(&tmp, text.as_bytes(), path) {
            let _ = std::fs::remove_file(&tmp);
            cleanup(&written);
            return Err(e);
        }
        written.push(tmp);
    }
    for (i, (path, _)) in files.iter().enumerate() {
        if let Err(e) = rename_then_sync_dir(&written[i], path) {
            cleanup(&written[i..]);
            return Err(e);
        }
    }
    Ok(())
}

/// An output folder written as a unit: every file goes first into a hidden staging folder
/// (`.shscale-staging-<host>-<pid>-<token>-<n>`) made in the nearest existing ancestor of the target, so a
/// command that fails creates nothing and changes nothing under the target — the staging folder
/// is removed when the guard drops, on every path out. [`Staging::commit`] creates the target
/// and renames each staged file into it, each synced before its rename and the folder after (one
/// rename per file: a crash mid-commit can leave some files new and some old, never a partial
/// or empty file). Files already in the target and not staged are
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
        for (gone, pid) in clean_dead_staging(&base) {
            eprintln!(
                "notice: removed {} (left by process {pid} of this host, which is no longer running)",
                gone.display()
            );
        }
        let n = N.fetch_add(1, Ordering::Relaxed);
        let dir = base.join(format!(".shscale-staging-{}-{n}", unique_tag()));
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
            sync_file(s)?;
        }
        for s in &staged {
            let t = self.target(s);
            std::fs::rename(s, &t).map_err(|e| Error::io(&t, e))?;
        }
        sync_dir(&self.out)?;
        sync_parent(&self.out)?;
        Ok(files.iter().map(|f| self.target(f)).collect())
    }
}

/// The process a staging folder's or temporary's name says made it, when it is of this host:
/// `.shscale-staging-<host>-<pid>-<token>-<n>` or `.<name>.tmp-<host>-<pid>-<token>[.ext]`.
fn maker_on_this_host(name: &str) -> Option<u32> {
    let host = host_tag();
    let rest = if let Some(r) = name.strip_prefix(".shscale-staging-") {
        r.strip_prefix(host)?.strip_prefix('-')?
    } else {
        let at = name.find(&format!(".tmp-{host}-"))?;
        &name[at + 6 + host.len()..]
    };
    let mut parts = rest.splitn(3, '-');
    let pid: u32 = parts.next()?.parse().ok()?;
    let token = parts.next()?;
    let token = token.split('.').next()?;
    (token.len() == 8 && token.chars().all(|c| c.is_ascii_hexdigit())).then_some(pid)
}

/// Remove the staging folders and temporaries in `dir` that a process of this host left when it
/// was killed (`kill -9` during a merge or a report): made by a pid other than this process's
/// that no longer runs (`/proc/<pid>` absent). Those of other hosts sharing the folder, of live
/// processes and of this process are left alone. Returns what was removed, with its pid.
pub(crate) fn clean_dead_staging(dir: &Path) -> Vec<(PathBuf, u32)> {
    let proc_fs = Path::new("/proc/self").exists();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let me = std::process::id();
    let mut gone = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        let Some(pid) = maker_on_this_host(&name) else {
            continue;
        };
        if !proc_fs || pid == me || Path::new(&format!("/proc/{pid}")).exists() {
            continue;
        }
        let p = e.path();
        let removed = match e.file_type() {
            Ok(t) if t.is_dir() => std::fs::remove_dir_all(&p).is_ok(),
            Ok(t) if t.is_file() => std::fs::remove_file(&p).is_ok(),
            _ => false,
        };
        if removed {
            gone.push((p, pid));
        }
    }
    gone.sort();
    gone
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

#[cfg(test)]
mod durable_tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shscale-durable-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = (std::fs::read_dir(d).unwrap().flatten())
            .map(|e| e.file_name().to_string_lossy().to_string())
            .collect();
        v.sort();
        v
    }

    /// A failure injected at each step of the replace (writing the temporary, its `fsync`, the
    /// rename, the directory's `fsync`) leaves the old file or the new one under the target —
    /// never an empty or partial one — and no temporary; the same for a unit of two files and
    /// for binary output.
    #[test]
    fn a_failure_at_every_step_leaves_the_old_or_the_new_file() {
        let d = scratch("inject");
        let (a, b) = (d.join("runs.csv"), d.join("manifest.toml"));
        for step in [Step::Write, Step::SyncFile, Step::Rename, Step::SyncDir] {
            for unit in [false, true] {
                std::fs::write(&a, "old rows\n").unwrap();
                std::fs::write(&b, "old manifest\n").unwrap();
                INJECT.with(|c| c.set(Some(step)));
                let r = if unit {
                    write_atomic_all(&[(&a, "new rows\n"), (&b, "new manifest\n")])
                } else {
                    write_atomic(&a, "new rows\n")
                };
                let e = r.expect_err("the injected failure is reported").to_string();
                println!("{step:?} unit={unit}: {e}");
                assert!(e.contains("injected failure"), "{e}");
                let got = std::fs::read_to_string(&a).unwrap();
                // Before the rename the old bytes stand; after it (the directory's sync) the new.
                let want = if step == Step::SyncDir {
                    "new rows\n"
                } else {
                    "old rows\n"
                };
                assert_eq!(got, want, "{step:?} unit={unit}");
                assert_eq!(
                    std::fs::read_to_string(&b).unwrap(),
                    "old manifest\n",
                    "{step:?}: the unit's second file was touched"
                );
                assert_eq!(names(&d), ["manifest.toml", "runs.csv"], "{step:?}");
            }
            std::fs::write(&a, "old").unwrap();
            INJECT.with(|c| c.set(Some(step)));
            assert!(write_atomic_bytes(&a, b"new").is_err());
            let got = std::fs::read(&a).unwrap();
            assert!(
                got == b"old" || (step == Step::SyncDir && got == b"new"),
                "{step:?}"
            );
            assert_eq!(names(&d), ["manifest.toml", "runs.csv"], "{step:?}");
        }
        // Without an injected failure every step runs: the new bytes, synced.
        write_atomic(&a, "new rows\n").unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new rows\n");
        std::fs::remove_dir_all(&d).ok();
    }

    /// Two processes with the same pid on two hosts sharing a folder get different temporaries
    /// (the host names differ, and so do their tokens); a host name with a path separator or
    /// spaces cannot leave the folder.
    #[test]
    fn temporary_names_are_unique_across_two_simulated_hosts() {
        let (a, b) = (
            unique_tag_of(&sanitize_host("node01"), 4242, "0badf00d"),
            unique_tag_of(&sanitize_host("node02"), 4242, "0badf00d"),
        );
        assert_ne!(a, b);
        // The same host and pid (a pid reused after a restart) with another token.
        assert_ne!(
            unique_tag_of("node01", 4242, "0badf00d"),
            unique_tag_of("node01", 4242, "12345678")
        );
        assert_eq!(sanitize_host("../evil host\n"), ".._evil_host");
        assert_eq!(sanitize_host(""), "host");
        let t = tmp_path(Path::new("/x/runs.csv"));
        let name = t.file_name().unwrap().to_string_lossy().to_string();
        let want = format!(
            ".runs.csv.tmp-{}-{}-{}",
            host_tag(),
            std::process::id(),
            process_token()
        );
        assert_eq!(name, want);
        assert_eq!(t.parent(), Some(Path::new("/x")));
        assert_eq!(process_token().len(), 8);
    }
}

#[cfg(test)]
mod leftover_tests {
    use super::*;

    /// A staging folder and a temporary left by a dead process of this host are removed by the
    /// next staging in that folder; those of a live process, of this process and of another host
    /// stay.
    #[test]
    fn leftovers_of_a_dead_process_of_this_host_are_cleaned_and_no_other() {
        if !Path::new("/proc/self").exists() {
            eprintln!("notice: no /proc: leftovers are kept here; skipped");
            return;
        }
        let d = std::env::temp_dir().join(format!("shscale-leftovers-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        // A pid that does not run: the largest one Linux hands out, checked.
        let dead = (4_000_000..4_194_304)
            .rev()
            .find(|p| !Path::new(&format!("/proc/{p}")).exists())
            .unwrap();
        let host = host_tag();
        let dead_stage = d.join(format!(".shscale-staging-{host}-{dead}-0badf00d-0"));
        std::fs::create_dir_all(&dead_stage).unwrap();
        std::fs::write(dead_stage.join(".a.tmp-x.png"), "partial").unwrap();
        let dead_tmp = d.join(format!(".runs.csv.tmp-{host}-{dead}-0badf00d"));
        std::fs::write(&dead_tmp, "partial").unwrap();
        let live = d.join(format!(".shscale-staging-{host}-1-0badf00d-0"));
        let mine = d.join(format!(".shscale-staging-{}-7", unique_tag()));
        let other_host = d.join(format!(".shscale-staging-{host}x-{dead}-0badf00d-0"));
        for p in [&live, &mine, &other_host] {
            std::fs::create_dir_all(p).unwrap();
        }
        std::fs::write(d.join("runs.csv"), "kept").unwrap();
        let gone = clean_dead_staging(&d);
        let names: Vec<PathBuf> = gone.iter().map(|(p, _)| p.clone()).collect();
        let mut want = vec![dead_stage.clone(), dead_tmp.clone()];
        want.sort();
        assert_eq!(names, want);
        assert!(gone.iter().all(|(_, p)| *p == dead));
        for p in [&live, &mine, &other_host] {
            assert!(p.exists(), "{} was removed", p.display());
        }
        assert_eq!(std::fs::read_to_string(d.join("runs.csv")).unwrap(), "kept");
        // Through a staging: the next one finds nothing more to remove.
        drop(Staging::new(&d.join("out")).unwrap());
        assert!(clean_dead_staging(&d).is_empty());
        std::fs::remove_dir_all(&d).ok();
    }
}
