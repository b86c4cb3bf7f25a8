//! The one runner of every experiment kind: plans (config + overrides → validated runs with ids,
//! checked against the cost limits), execution into `<out>/<kind>/<name>/` with resume, shards,
//! an advisory lock, atomic CSV rewrites and a manifest of every config version, the merge of
//! shard files, Slurm scripts, and the report (summary + the kind's plots).
//!
//! **Results never mix silently.** Every row carries every parameter of its run (swept or fixed)
//! as a column and its run id is the hash of all of them, so editing a fixed key and rerunning
//! under the same name adds rows that differ in that column; summaries and plots group by every
//! parameter column that varies in the CSV, and `manifest.toml` keeps every config version that
//! produced rows (appended once a run of it has succeeded, never rewritten).
//!
//! **Resume validates.** Existing rows are read with the `csv` crate; a row with the wrong cell
//! count, a cell of the wrong type, or a run id that its own parameter cells do not reproduce is
//! set aside (appended to `runs.csv.rejected`, never lost) with a warning, and a run with fewer
//! rows than it writes is redone.
//!
//! **Concurrency.** Every read-modify-write of the CSV and the manifest holds an exclusive
//! advisory lock on `<dir>/.lock` (`std::fs::File::lock`): a second process waits for it, re-reads
//! the file and adds its rows, so two processes on one directory never lose a row.

use super::config::{self, ConfigError, Overrides, Place};
use super::records::{self, Results};
use super::timing::{self, Procedure};
use super::{Ctx, DynKind, Resolved, RowCells};
use crate::LabError;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// A resolved plan.
pub struct Plan {
    pub kind: &'static dyn DynKind,
    pub file: String,
    pub name: String,
    pub text: String,
    pub overrides: Vec<String>,
    /// Swept keys, in expansion order.
    pub axes: Vec<String>,
    pub runs: Vec<Resolved>,
    pub gpu: crate::gpu_path::GpuMode,
    pub parallel_runs: bool,
    pub timing: Procedure,
}

/// `name`: letters, digits, `.`, `_`, `-`; not empty, not `.` or `..`.
pub fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty() || name == "." || name == ".." || name.len() > 128 {
        return Err(format!(
            "{name:?} must be 1 to 128 characters and not . or .."
        ));
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-')))
    {
        return Err(format!(
            "{name:?} contains {c:?}: a name is letters, digits, '.', '_' and '-' (no path separators)"
        ));
    }
    Ok(())
}

fn cfg(e: ConfigError) -> LabError {
    LabError::Config(e.to_string())
}

/// The kind of a config text (its `experiment` key), without resolving it.
pub fn kind_of(text: &str) -> Option<String> {
    let t: toml::Table = toml::from_str(text).ok()?;
    t.get("experiment")?.as_str().map(String::from)
}

impl Plan {
    /// Read and resolve a config file with overrides against the registry of kinds.
    pub fn load(
        path: &Path,
        ov: &Overrides,
        registry: &[&'static dyn DynKind],
    ) -> Result<Self, LabError> {
        let text = std::fs::read_to_string(path).map_err(|e| LabError::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "experiment".into());
        Self::parse(&path.display().to_string(), &stem, &text, ov, registry)
    }

    /// Resolve config text (`file` names it in errors; `stem` is the default name).
    pub fn parse(
        file: &str,
        stem: &str,
        text: &str,
        ov: &Overrides,
        registry: &[&'static dyn DynKind],
    ) -> Result<Self, LabError> {
        let ex = config::expand(file, text, ov).map_err(cfg)?;
        let at_key = |key: &'static str| {
            let p = config::parse_path(key);
            let place = ex
                .set_places
                .iter()
                .find(|(sp, _)| p.starts_with(sp))
                .map(|(_, pl)| pl.clone())
                .unwrap_or_else(|| match ex.source.line_of(&p) {
                    Some((line, _)) => Place::Line {
                        file: file.into(),
                        line,
                    },
                    None => Place::File(file.into()),
                });
            move |message: String| ConfigError {
                place,
                key: key.into(),
                message,
            }
        };
        let kind = *registry
            .iter()
            .find(|k| k.name() == ex.runner.experiment)
            .ok_or_else(|| {
                cfg(at_key("experiment")(format!(
                    "{:?} is not a known experiment kind (one of {})",
                    ex.runner.experiment,
                    registry
                        .iter()
                        .map(|k| k.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                )))
            })?;
        let name = ex.runner.name.clone().unwrap_or_else(|| stem.to_string());
        check_name(&name).map_err(|m| cfg(at_key("name")(m)))?;
        let gpu = match ex.runner.gpu.as_deref() {
            None => crate::gpu_path::GpuMode::Auto,
            Some(g) => crate::gpu_path::GpuMode::parse(g).map_err(|m| cfg(at_key("gpu")(m)))?,
        };
        let mut timing = Procedure::default();
        if let Some(w) = ex.runner.timing_warmup {
            timing.warmup = w;
        }
        if let Some(r) = ex.runner.timing_repeats {
            timing.repeats = r;
        }
        if timing.warmup > timing::MAX_REPEATS {
            return Err(cfg(at_key("timing_warmup")(format!(
                "{} is more than the limit {}",
                timing.warmup,
                timing::MAX_REPEATS
            ))));
        }
        if !(1..=timing::MAX_REPEATS).contains(&timing.repeats) {
            return Err(cfg(at_key("timing_repeats")(format!(
                "{} is outside 1..={}",
                timing.repeats,
                timing::MAX_REPEATS
            ))));
        }
        let mut runs: Vec<Resolved> = Vec::with_capacity(ex.combinations.len());
        let mut ids = HashMap::new();
        for (i, c) in ex.combinations.iter().enumerate() {
            let r = kind.resolve(&ex, c).map_err(cfg)?;
            if let Some(j) = ids.insert(r.id.clone(), i) {
                return Err(LabError::Config(format!(
                    "{file}: sweep: combinations {} and {} resolve to the same run ({})",
                    j + 1,
                    i + 1,
                    r.canonical
                )));
            }
            runs.push(r);
        }
        Ok(Self {
            kind,
            file: file.into(),
            name,
            text: text.into(),
            overrides: ov.flags(),
            axes: ex.axes.clone(),
            runs,
            gpu,
            parallel_runs: ex.runner.parallel_runs.unwrap_or(true),
            timing,
        })
    }

    /// Groups of run indices sharing work, in plan order.
    pub fn groups(&self) -> Vec<Vec<usize>> {
        let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
        for (i, r) in self.runs.iter().enumerate() {
            match groups.iter_mut().find(|g| g.0 == r.group) {
                Some(g) => g.1.push(i),
                None => groups.push((r.group.clone(), vec![i])),
            }
        }
        groups.into_iter().map(|g| g.1).collect()
    }

    /// The plan's estimated cost: total rays and seconds, the largest group's bytes.
    pub fn estimate(&self) -> Estimate {
        let mut e = Estimate {
            runs: self.runs.len(),
            ..Default::default()
        };
        for g in self.groups() {
            e.groups += 1;
            let first = &self.runs[g[0]];
            let mut bytes = first.shared_cost.bytes;
            e.rays += first.shared_cost.rays;
            e.seconds += first.shared_cost.seconds * self.timing_factor();
            for &i in &g {
                let c = &self.runs[i].cost;
                e.rays += c.rays;
                e.seconds += c.seconds * self.timing_factor();
                bytes = bytes.max(first.shared_cost.bytes + c.bytes);
            }
            if bytes > e.bytes {
                e.bytes = bytes;
                e.bytes_driver = first.shared_cost.drivers.clone();
            }
            if first.shared_cost.rays > e.max_group_rays {
                e.max_group_rays = first.shared_cost.rays;
                e.rays_driver = first.shared_cost.drivers.clone();
            }
        }
        e
    }

    fn timing_factor(&self) -> f64 {
        (self.timing.warmup + self.timing.repeats) as f64
    }

    /// Refuse plans beyond the documented limits unless `allow_large`.
    pub fn check_limits(&self, allow_large: bool) -> Result<(), LabError> {
        if allow_large {
            return Ok(());
        }
        let e = self.estimate();
        if e.rays > timing::MAX_PLAN_RAYS {
            return Err(LabError::Config(format!(
                "{}: the plan would trace an estimated {:.2e} rays, more than the limit {:.0e} (largest group: {}); reduce it or pass --allow-large",
                self.file, e.rays, timing::MAX_PLAN_RAYS, e.rays_driver
            )));
        }
        if e.bytes > timing::MAX_PLAN_BYTES {
            return Err(LabError::Config(format!(
                "{}: a group of the plan would hold an estimated {:.1} GiB, more than the limit 8 GiB ({}); reduce it or pass --allow-large",
                self.file,
                e.bytes / (1u64 << 30) as f64,
                e.bytes_driver
            )));
        }
        Ok(())
    }

    /// The dry-run description: runs, groups, estimates.
    pub fn describe(&self, shard: Option<(usize, usize)>) -> String {
        let e = self.estimate();
        let mut s = format!(
            "plan {:?} of kind {:?} from {}{}\n  {} run(s) in {} group(s) sharing work{}\n  estimated: {:.3e} rays, {:.1} MiB peak, {:.1} s on the development VM ({} warm-up + {} timed repeat(s) each)\n",
            self.name,
            self.kind.name(),
            self.file,
            if self.overrides.is_empty() {
                String::new()
            } else {
                format!(" with {}", self.overrides.join(" "))
            },
            e.runs,
            e.groups,
            shard.map_or(String::new(), |(i, n)| format!(
                "; shard {i}/{n} holds {}",
                (0..self.runs.len()).filter(|j| j % n == i).count()
            )),
            e.rays,
            e.bytes / (1u64 << 20) as f64,
            e.seconds,
            self.timing.warmup,
            self.timing.repeats,
        );
        if !e.rays_driver.is_empty() {
            s.push_str(&format!("  largest group: {}\n", e.rays_driver));
        }
        s.push_str(&format!(
            "  swept: {}\n",
            if self.axes.is_empty() {
                "nothing".to_string()
            } else {
                self.axes.join(", ")
            }
        ));
        for (i, r) in self.runs.iter().enumerate().take(20) {
            s.push_str(&format!("  run {i:>3} {} {}\n", r.id, r.canonical));
        }
        if self.runs.len() > 20 {
            s.push_str(&format!("  … and {} more\n", self.runs.len() - 20));
        }
        s.push_str("  (dry run: nothing written)\n");
        s
    }
}

/// A plan's estimated cost.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    pub runs: usize,
    pub groups: usize,
    pub rays: f64,
    pub bytes: f64,
    pub seconds: f64,
    pub max_group_rays: f64,
    pub rays_driver: String,
    pub bytes_driver: String,
}

/// Columns the runner adds to every row after the kind's.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RowProvenance {
    pub threads: usize,
    /// Whether the row's times were taken while other runs executed (not comparable).
    pub timing_concurrent: bool,
    pub timing_warmup: usize,
    pub timing_repeats: usize,
    pub git_revision: String,
    pub git_dirty: bool,
}

/// Where a plan's run writes, and the machine.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Provenance {
    pub git_revision: String,
    /// Whether the checkout had local changes.
    pub git_dirty: bool,
    pub shscale_version: String,
    pub cpu_model: String,
    pub threads: usize,
    pub gpu_device: String,
    pub os: String,
    pub arch: String,
    pub unix_time: u64,
}

fn git(args: &[&str]) -> Option<String> {
    std::process::Command::new("git")
        .args(args)
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
}

fn unix_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

impl Provenance {
    /// Read off this process and machine.
    pub fn here(gpu_device: &str) -> Self {
        let rev = git(&["rev-parse", "--short", "HEAD"]);
        let dirty = rev.is_some()
            && git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|t| {
                t.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        Self {
            git_revision: rev.unwrap_or_else(|| "unknown".into()),
            git_dirty: dirty,
            shscale_version: env!("CARGO_PKG_VERSION").into(),
            cpu_model: cpu,
            threads: rayon::current_num_threads(),
            gpu_device: gpu_device.into(),
            os: std::env::consts::OS.into(),
            arch: std::env::consts::ARCH.into(),
            unix_time: unix_now(),
        }
    }
}

/// One config version that produced rows.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Version {
    /// Hash of the config text, the overrides and the revision.
    pub id: String,
    pub config_file: String,
    pub overrides: Vec<String>,
    pub axes: Vec<String>,
    pub runs_in_plan: usize,
    pub first_unix_time: u64,
    pub last_unix_time: u64,
    pub provenance: Provenance,
    pub config_text: String,
}

/// `manifest.toml`: the kind, the name and every config version that produced rows.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    pub experiment: String,
    pub name: String,
    #[serde(default)]
    pub versions: Vec<Version>,
}

impl Manifest {
    /// Read `dir/manifest.toml` (`None` when absent).
    pub fn read(dir: &Path) -> Result<Option<Self>, LabError> {
        let p = dir.join("manifest.toml");
        if !p.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&p).map_err(|e| io_err(&p, e))?;
        toml::from_str(&text).map(Some).map_err(|e| LabError::Io {
            path: p.display().to_string(),
            reason: format!(
                "not a manifest of this shscale version ({}); move it (and its runs.csv) away or choose another name",
                e.message().trim()
            ),
        })
    }

    fn add(&mut self, v: &Version) {
        match self.versions.iter_mut().find(|x| x.id == v.id) {
            Some(x) => x.last_unix_time = v.last_unix_time,
            None => self.versions.push(v.clone()),
        }
    }
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> LabError {
    LabError::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

/// Write `text` to `path` through a temporary file and a rename; the temporary is removed when
/// either step fails.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), LabError> {
    write_atomic_all(&[(path, text)])
}

/// Write several files as a unit: every text to a temporary beside its target first, then the
/// renames, in order; when any write fails no target is touched, and every error path removes
/// the temporaries not yet renamed. A directory at a target is refused before anything is
/// written.
pub fn write_atomic_all(files: &[(&Path, &str)]) -> Result<(), LabError> {
    let tmp_of = crate::io::tmp_path;
    if let Some((p, _)) = files.iter().find(|(p, _)| p.is_dir()) {
        return Err(io_err(p, "is a directory"));
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
            return Err(io_err(path, e));
        }
        written.push(tmp);
    }
    for (i, (path, _)) in files.iter().enumerate() {
        if let Err(e) = std::fs::rename(&written[i], path) {
            cleanup(&written[i..]);
            return Err(io_err(path, e));
        }
    }
    Ok(())
}

/// The exclusive advisory lock of a results directory, held while alive.
pub struct DirLock(std::fs::File);

impl DirLock {
    /// Take `dir/.lock`, waiting for another process (`waiting` is called once if it must wait).
    pub fn acquire(dir: &Path, waiting: &dyn Fn(&Path)) -> Result<Self, LabError> {
        let p = dir.join(".lock");
        let f = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&p)
            .map_err(|e| io_err(&p, e))?;
        match f.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                waiting(&p);
                f.lock().map_err(|e| io_err(&p, e))?;
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(io_err(&p, e)),
        }
        Ok(Self(f))
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        let _ = self.0.unlock();
    }
}

/// The full header of a kind's CSV.
pub fn header(kind: &dyn DynKind) -> Vec<String> {
    let mut h = vec!["run_id".to_string(), "experiment".to_string()];
    h.extend(kind.param_columns());
    h.extend(kind.row_columns());
    h.extend(
        records::to_cells(&RowProvenance::default())
            .map(|(h, _)| h)
            .unwrap_or_default(),
    );
    h
}

/// Valid rows of a results file, the complete runs, and what was set aside.
#[derive(Default)]
pub struct Loaded {
    pub rows: Vec<Vec<String>>,
    pub complete: BTreeSet<String>,
    /// `(line, reason)` of rows set aside.
    pub rejected: Vec<(u64, String, Vec<String>)>,
}

/// Read and validate a kind's CSV (`Ok(default)` when absent). A header of another version is an
/// error (the file is left alone); invalid rows are returned in `rejected`.
pub fn load_rows(kind: &dyn DynKind, path: &Path) -> Result<Loaded, LabError> {
    if !path.exists() {
        return Ok(Loaded::default());
    }
    let (columns, raw) = records::read_raw(path)?;
    let want = header(kind);
    if columns != want {
        let diff = want
            .iter()
            .zip(columns.iter().chain(std::iter::repeat(&String::new())))
            .position(|(a, b)| a != b)
            .unwrap_or(want.len().min(columns.len()));
        return Err(LabError::Io {
            path: path.display().to_string(),
            reason: format!(
                "its columns are not this version's {} columns (column {}: {:?}, expected {:?}); it is left untouched — move it away or choose another name",
                kind.name(),
                diff + 1,
                columns.get(diff).map_or("", String::as_str),
                want.get(diff).map_or("", String::as_str),
            ),
        });
    }
    let np = kind.param_columns().len();
    let nr = kind.row_columns().len();
    let (ph, rh, vh) = (
        &want[2..2 + np],
        &want[2 + np..2 + np + nr],
        &want[2 + np + nr..],
    );
    let mut out = Loaded::default();
    let mut by_run: Vec<(String, usize, Vec<records::CsvLine>)> = Vec::new();
    for (line, r) in raw {
        let reason = if r.len() != want.len() {
            Some(format!("{} cells, the header has {}", r.len(), want.len()))
        } else if r[1] != kind.name() {
            Some(format!("experiment {:?} is not {:?}", r[1], kind.name()))
        } else {
            match kind.resolve_cells(ph, &r[2..2 + np]) {
                Err(m) => Some(format!("parameters: {m}")),
                Ok(res) if res.id != r[0] => Some(format!(
                    "run id {} does not match its parameters (they hash to {})",
                    r[0], res.id
                )),
                Ok(res) => kind
                    .check_row(rh, &r[2 + np..2 + np + nr])
                    .and_then(|_| {
                        records::from_cells::<RowProvenance>(vh, &r[2 + np + nr..]).map(|_| ())
                    })
                    .err()
                    .map(|m| format!("cells: {m}"))
                    .or_else(|| {
                        match by_run.iter_mut().find(|x| x.0 == res.id) {
                            Some(x) => x.2.push((line, r.clone())),
                            None => {
                                by_run.push((res.id.clone(), res.rows, vec![(line, r.clone())]))
                            }
                        }
                        None
                    }),
            }
        };
        if let Some(why) = reason {
            out.rejected.push((line, why, r));
        }
    }
    for (id, want_rows, rows) in by_run {
        if rows.len() == want_rows {
            out.complete.insert(id);
            out.rows.extend(rows.into_iter().map(|(_, r)| r));
        } else {
            let have = rows.len();
            for (line, r) in rows {
                out.rejected.push((
                    line,
                    format!("run {id} has {have} of its {want_rows} rows (partial); it is redone"),
                    r,
                ));
            }
        }
    }
    Ok(out)
}

/// Append set-aside rows to `<csv>.rejected` (never lost).
fn keep_rejected(csv: &Path, rejected: &[(u64, String, Vec<String>)]) -> Result<(), LabError> {
    if rejected.is_empty() {
        return Ok(());
    }
    use std::io::Write;
    let p = PathBuf::from(format!("{}.rejected", csv.display()));
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&p)
        .map_err(|e| io_err(&p, e))?;
    for (line, why, cells) in rejected {
        writeln!(f, "# line {line}: {why}\n{}", cells.join(",")).map_err(|e| io_err(&p, e))?;
    }
    Ok(())
}

/// Progress of [`run_plan`].
#[derive(Clone, Copy, Debug)]
pub enum RunEvent<'a> {
    Begin {
        total: usize,
        pending: usize,
    },
    /// A shared computation starts.
    Shared(&'a str),
    /// A run finished (its rows are on disk).
    Done(&'a str),
    /// Something set aside or waited for.
    Warn(&'a str),
}

/// What a runner invocation did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub dir: PathBuf,
    pub csv: PathBuf,
    pub in_shard: usize,
    pub already_done: usize,
    pub ran: usize,
    pub redone: usize,
}

/// The results directory of a plan.
pub fn plan_dir(plan: &Plan, out_root: &Path) -> PathBuf {
    out_root.join(plan.kind.name()).join(&plan.name)
}

/// Run `plan` under `out_root`, optionally one shard `(i, n)`; `progress` hears of every step.
pub fn run_plan(
    plan: &Plan,
    out_root: &Path,
    shard: Option<(usize, usize)>,
    progress: &(dyn Fn(RunEvent) + Sync),
) -> Result<RunSummary, LabError> {
    if let Some((i, n)) = shard {
        if n == 0 || i >= n {
            return Err(LabError::Config(format!("--shard {i}/{n}: need 0 ≤ I < N")));
        }
    }
    let kind = plan.kind;
    let dir = plan_dir(plan, out_root);
    std::fs::create_dir_all(&dir).map_err(|e| io_err(&dir, e))?;
    let csv = match shard {
        Some((i, n)) => dir.join(format!("runs.shard-{i}-of-{n}.csv")),
        None => dir.join("runs.csv"),
    };
    let waiting = |p: &Path| {
        progress(RunEvent::Warn(&format!(
            "waiting for another shscale process holding {}",
            p.display()
        )))
    };
    // Check the manifest and the existing rows before any work.
    let loaded = {
        let _lock = DirLock::acquire(&dir, &waiting)?;
        if let Some(m) = Manifest::read(&dir)? {
            if m.experiment != kind.name() {
                return Err(LabError::Io {
                    path: dir.join("manifest.toml").display().to_string(),
                    reason: format!("belongs to experiment {:?}", m.experiment),
                });
            }
        }
        let l = load_rows(kind, &csv)?;
        for (line, why, _) in &l.rejected {
            progress(RunEvent::Warn(&format!(
                "{}:{line}: row set aside ({why}); kept in {}.rejected",
                csv.display(),
                csv.display()
            )));
        }
        if !l.rejected.is_empty() {
            // Keep what was set aside, then leave only valid rows in the CSV.
            keep_rejected(&csv, &l.rejected)?;
            write_atomic(&csv, &records::write_text(&header(kind), &l.rows)?)?;
        }
        l
    };
    let gpu = crate::gpu_path::open_gpu(plan.gpu)?;
    let gpu_device = gpu.as_ref().map_or("none".to_string(), |c| c.describe());
    let prov = Provenance::here(&gpu_device);
    let version = Version {
        id: records::run_id(
            "version",
            &format!(
                "{}\n{}\n{}{}",
                plan.text,
                plan.overrides.join(" "),
                prov.git_revision,
                if prov.git_dirty { "+dirty" } else { "" }
            ),
        ),
        config_file: plan.file.clone(),
        overrides: plan.overrides.clone(),
        axes: plan.axes.clone(),
        runs_in_plan: plan.runs.len(),
        first_unix_time: prov.unix_time,
        last_unix_time: prov.unix_time,
        provenance: prov.clone(),
        config_text: plan.text.clone(),
    };
    let mine: Vec<usize> = (0..plan.runs.len())
        .filter(|i| shard.is_none_or(|(s, n)| i % n == s))
        .collect();
    let rejected_ids: BTreeSet<String> = loaded
        .rejected
        .iter()
        .filter_map(|(_, _, r)| r.first().cloned())
        .collect();
    let pending: Vec<usize> = mine
        .iter()
        .copied()
        .filter(|&i| !loaded.complete.contains(&plan.runs[i].id))
        .collect();
    let mut summary = RunSummary {
        dir: dir.clone(),
        csv: csv.clone(),
        in_shard: mine.len(),
        already_done: mine.len() - pending.len(),
        ran: 0,
        redone: pending
            .iter()
            .filter(|&&i| rejected_ids.contains(&plan.runs[i].id))
            .count(),
    };
    progress(RunEvent::Begin {
        total: mine.len(),
        pending: pending.len(),
    });
    let order: HashMap<&str, usize> = plan
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| (r.id.as_str(), i))
        .collect();
    let ran = std::sync::Mutex::new(0usize);
    let concurrent_of = |group_len: usize| plan.parallel_runs && group_len > 1;
    let threads = rayon::current_num_threads();
    let write_run = |r: &Resolved, rows: RowCells, concurrent: bool| -> Result<(), LabError> {
        let mut count = ran.lock().unwrap_or_else(|e| e.into_inner());
        let _lock = DirLock::acquire(&dir, &waiting)?;
        // Re-read under the lock: another process may have added rows.
        let mut cur = load_rows(kind, &csv)?;
        if !cur.complete.contains(&r.id) {
            let prov = RowProvenance {
                threads,
                timing_concurrent: concurrent,
                timing_warmup: plan.timing.warmup,
                timing_repeats: plan.timing.repeats,
                git_revision: version.provenance.git_revision.clone(),
                git_dirty: version.provenance.git_dirty,
            };
            let (_, pcells) = records::to_cells(&prov).map_err(LabError::Config)?;
            for row in rows {
                let mut cells = vec![r.id.clone(), kind.name().to_string()];
                cells.extend(r.cells.iter().cloned());
                cells.extend(row);
                cells.extend(pcells.iter().cloned());
                cur.rows.push(cells);
            }
        }
        // Rows of this plan in plan order, others (earlier versions, other processes) first in
        // their order (a stable sort).
        cur.rows.sort_by_key(|row| {
            row.first()
                .and_then(|id| order.get(id.as_str()))
                .map_or(0, |i| i + 1)
        });
        let mut m = Manifest::read(&dir)?.unwrap_or(Manifest {
            experiment: kind.name().into(),
            name: plan.name.clone(),
            versions: Vec::new(),
        });
        let mut v = version.clone();
        v.last_unix_time = unix_now();
        m.add(&v);
        // The rows and the manifest that describes them, as a unit.
        write_atomic_all(&[
            (&csv, &records::write_text(&header(kind), &cur.rows)?),
            (
                &dir.join("manifest.toml"),
                &toml::to_string(&m).map_err(|e| LabError::Config(e.to_string()))?,
            ),
        ])?;
        *count += 1;
        Ok(())
    };
    let config_dir = Path::new(&plan.file)
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let ctx = Ctx {
        dir: &dir,
        config_dir,
        gpu: gpu.as_ref(),
        timing: plan.timing,
    };
    for g in plan.groups() {
        let runs: Vec<&Resolved> = g
            .iter()
            .filter(|i| pending.contains(i))
            .map(|&i| &plan.runs[i])
            .collect();
        if runs.is_empty() {
            continue;
        }
        progress(RunEvent::Shared(&format!(
            "shared work for {} run(s): {}",
            runs.len(),
            runs[0].group.chars().take(120).collect::<String>()
        )));
        let concurrent = concurrent_of(runs.len());
        kind.run_group(&runs, &ctx, concurrent, &|r, rows, secs| {
            write_run(r, rows, concurrent)?;
            progress(RunEvent::Done(&format!(
                "{} {} in {secs:.2} s",
                r.id, r.canonical
            )));
            Ok(())
        })?;
    }
    summary.ran = *ran.lock().unwrap_or_else(|e| e.into_inner());
    Ok(summary)
}

/// What [`report`] wrote: the summary text, the kind's discussion in it, and the files.
pub struct Report {
    pub summary: String,
    pub discussion: String,
    pub files: Vec<PathBuf>,
}

/// The summary table and the kind's plots of a results directory's `runs.csv`: one line per
/// run, with every parameter that varies in the CSV and the kind's headline columns.
pub fn report(kind: &dyn DynKind, dir: &Path) -> Result<Report, LabError> {
    let csv = dir.join("runs.csv");
    let t = Results::read(&csv)?;
    let varying = t.varying(&kind.param_columns());
    let (title, claim) = title_and_claim(dir);
    let mut s = format!(
        "# {}{} — {}\n\n{}{}\n\nRows: {} in `runs.csv`; parameters that vary: {}.\n\n",
        title.map_or(String::new(), |t| format!("{t}\n\nExperiment ")),
        kind.name(),
        dir.file_name()
            .map_or(String::new(), |n| n.to_string_lossy().to_string()),
        claim.map_or(String::new(), |c| format!(
            "**Claim.** {}\n\n**Question.** ",
            c.trim()
        )),
        kind.question(),
        t.rows.len(),
        if varying.is_empty() {
            "none".to_string()
        } else {
            varying.join(", ")
        }
    );
    let mut cols: Vec<String> = std::iter::once("run_id".to_string())
        .chain(varying.iter().cloned())
        .collect();
    for c in kind.summary_columns() {
        if !cols.iter().any(|x| x == c) {
            cols.push(c.to_string());
        }
    }
    s.push_str(&format!("| {} |\n", cols.join(" | ")));
    s.push_str(&format!("|{}\n", "---|".repeat(cols.len())));
    for r in 0..t.rows.len() {
        let cells: Vec<String> = cols
            .iter()
            .map(|c| {
                let v = t.cell(r, c);
                match v.parse::<f64>() {
                    Ok(x) if (v.contains('.') || v.contains('e')) && x != 0.0 && x.abs() < 1e-3 => {
                        format!("{x:.3e}")
                    }
                    Ok(x) if v.contains('.') || v.contains('e') => format!("{x:.4}"),
                    _ => v.to_string(),
                }
            })
            .collect();
        s.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    let concurrent = (0..t.rows.len())
        .filter(|&r| t.cell(r, "timing_concurrent") == "true")
        .count();
    if concurrent > 0 {
        s.push_str(&format!(
            "\n{concurrent} row(s) were timed while other runs executed (`timing_concurrent`): their times are not comparable and are left out of speed plots.\n"
        ));
    }
    let discussion = kind.discussion(&t)?;
    if !discussion.trim().is_empty() {
        s.push_str(&format!(
            "\n## Our numbers against the claim\n\n{}\n",
            discussion.trim_end()
        ));
    }
    let p = dir.join("summary.md");
    write_atomic(&p, &s)?;
    let figures = kind.report(dir, &t)?;
    let mut files = vec![p];
    files.extend(super::report::write_report(dir, &s, &figures)?);
    files.extend(figures);
    Ok(Report {
        summary: s,
        discussion,
        files,
    })
}

/// `title` and `claim` of the newest config version in `dir/manifest.toml`.
pub fn title_and_claim(dir: &Path) -> (Option<String>, Option<String>) {
    let Some(text) = Manifest::read(dir)
        .ok()
        .flatten()
        .and_then(|m| m.versions.last().map(|v| v.config_text.clone()))
    else {
        return (None, None);
    };
    let t: toml::Table = toml::from_str(&text).unwrap_or_default();
    let get = |k: &str| t.get(k).and_then(|v| v.as_str()).map(String::from);
    (get("title"), get("claim"))
}

/// What [`merge`] did.
pub struct MergeSummary {
    pub out: PathBuf,
    pub files: usize,
    pub rows: usize,
    pub kind: &'static dyn DynKind,
}

/// Merge the `runs*.csv` of `dirs` into `out` (default `<dirs[0]>/merged`), a new directory:
/// every row validated as on resume (an invalid one is an error naming its file and line), runs
/// deduplicated by id (the first file's rows win), the manifests' versions united, then the
/// report. Never overwrites an input: `out/runs.csv` must not exist.
pub fn merge(
    dirs: &[PathBuf],
    out: Option<&Path>,
    registry: &[&'static dyn DynKind],
) -> Result<MergeSummary, LabError> {
    let first = dirs
        .first()
        .ok_or_else(|| LabError::Config("merge: give at least one directory".into()))?;
    let out = out.map_or_else(|| first.join("merged"), Path::to_path_buf);
    let mut files = Vec::new();
    for d in dirs {
        let rd = std::fs::read_dir(d).map_err(|e| io_err(d, e))?;
        let mut here: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                let n = p
                    .file_name()
                    .map(|n| n.to_string_lossy().to_string())
                    .unwrap_or_default();
                n.starts_with("runs") && n.ends_with(".csv") && p.is_file()
            })
            .collect();
        here.sort();
        files.extend(here);
    }
    if files.is_empty() {
        return Err(LabError::Config(format!(
            "merge: no runs*.csv in {}",
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let target = out.join("runs.csv");
    if target.exists() {
        return Err(LabError::Io {
            path: target.display().to_string(),
            reason: "exists; merge never overwrites — choose another --out".into(),
        });
    }
    // The kind: from the first manifest, else from the first row.
    let kind_name = match Manifest::read(first)? {
        Some(m) => m.experiment,
        None => {
            let (_, rows) = records::read_raw(&files[0])?;
            rows.first()
                .and_then(|(_, r)| r.get(1).cloned())
                .ok_or_else(|| LabError::Io {
                    path: files[0].display().to_string(),
                    reason: "no manifest.toml beside it and no rows to tell the experiment".into(),
                })?
        }
    };
    let kind = *registry
        .iter()
        .find(|k| k.name() == kind_name)
        .ok_or_else(|| LabError::Config(format!("merge: unknown experiment {kind_name:?}")))?;
    let mut seen = BTreeSet::new();
    let mut rows = Vec::new();
    let mut manifest = Manifest {
        experiment: kind_name.clone(),
        name: first
            .file_name()
            .map_or("merged".into(), |n| n.to_string_lossy().to_string()),
        versions: Vec::new(),
    };
    for d in dirs {
        if let Some(m) = Manifest::read(d)? {
            if m.experiment != kind_name {
                return Err(LabError::Io {
                    path: d.join("manifest.toml").display().to_string(),
                    reason: format!(
                        "experiment {:?}, not {kind_name:?}: results of different kinds do not merge",
                        m.experiment
                    ),
                });
            }
            for v in &m.versions {
                manifest.add(v);
            }
        }
    }
    for f in &files {
        let l = load_rows(kind, f)?;
        if let Some((line, why, _)) = l.rejected.first() {
            return Err(LabError::Io {
                path: format!("{}:{line}", f.display()),
                reason: format!("{why}; nothing merged"),
            });
        }
        let mut ids_here = BTreeSet::new();
        for r in l.rows {
            if !seen.contains(&r[0]) {
                ids_here.insert(r[0].clone());
                rows.push(r);
            }
        }
        seen.extend(ids_here);
    }
    std::fs::create_dir_all(&out).map_err(|e| io_err(&out, e))?;
    write_atomic_all(&[
        (
            &out.join("manifest.toml"),
            &toml::to_string(&manifest).map_err(|e| LabError::Config(e.to_string()))?,
        ),
        (&target, &records::write_text(&header(kind), &rows)?),
    ])?;
    Ok(MergeSummary {
        out,
        files: files.len(),
        rows: rows.len(),
        kind,
    })
}

/// Options passed through to `sbatch`.
#[derive(Clone, Debug, Default)]
pub struct SlurmOptions {
    pub time: Option<String>,
    pub mem: Option<String>,
    pub partition: Option<String>,
    pub cpus_per_task: Option<usize>,
    pub account: Option<String>,
}

/// A word quoted for a POSIX shell.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// A Slurm job-array script that runs `config` (with the plan's overrides) in `tasks` shards
/// and then, in a dependent job, merges them into `<dir>/merged` with plots and summary. Every
/// value written into the script is shell-quoted.
pub fn slurm_script(
    config: &Path,
    plan: &Plan,
    tasks: usize,
    binary: &str,
    out_root: &Path,
    opts: &SlurmOptions,
) -> Result<String, LabError> {
    if tasks == 0 || tasks > 100_000 {
        return Err(LabError::Config(format!(
            "slurm: --tasks {tasks} is outside 1..=100000"
        )));
    }
    let q = shell_quote;
    let dir = plan_dir(plan, out_root);
    let mut sb = Vec::new();
    if let Some(t) = &opts.time {
        sb.push(format!("--time={}", q(t)));
    }
    if let Some(m) = &opts.mem {
        sb.push(format!("--mem={}", q(m)));
    }
    if let Some(p) = &opts.partition {
        sb.push(format!("--partition={}", q(p)));
    }
    if let Some(c) = opts.cpus_per_task {
        sb.push(format!("--cpus-per-task={c}"));
    }
    if let Some(a) = &opts.account {
        sb.push(format!("--account={}", q(a)));
    }
    let mut run_words = vec![
        q(binary),
        "run".into(),
        q(&config.display().to_string()),
        "--out-dir".into(),
        q(&out_root.display().to_string()),
    ];
    for o in &plan.overrides {
        let (flag, val) = o.split_once(' ').unwrap_or((o.as_str(), ""));
        run_words.push(flag.to_string());
        run_words.push(q(val));
    }
    run_words.push("--shard".into());
    run_words.push(format!("\"$SLURM_ARRAY_TASK_ID\"/{tasks}"));
    let merge_words = [
        q(binary),
        "merge".into(),
        q(&dir.display().to_string()),
        "--out".into(),
        q(&dir.join("merged").display().to_string()),
    ];
    let job = format!("shscale-{}", plan.name);
    Ok(format!(
        "#!/usr/bin/env bash\n# Generated by `shscale slurm`: {runs} run(s) of {cfg} in {tasks} shard(s), then a merge\n# (with plots and summary) into {merged}.\n# Submit with:  bash THIS_SCRIPT   (it calls sbatch twice)\nset -euo pipefail\nOUT={out}\nmkdir -p \"$OUT\"\nRUN_CMD={run_cmd}\nMERGE_CMD={merge_cmd}\narray_job=$(sbatch --parsable --array=0-{last} --job-name={jobq} {sb}--output=\"$OUT/slurm-%A_%a.log\" --wrap \"$RUN_CMD\")\nsbatch --dependency=afterok:\"$array_job\" --job-name={jobmq} {sb}--output=\"$OUT/slurm-merge-%j.log\" --wrap \"$MERGE_CMD\"\necho \"submitted array job $array_job ({tasks} tasks) and its merge\"\n",
        runs = plan.runs.len(),
        cfg = config.display().to_string().replace('\n', " "),
        merged = dir.join("merged").display().to_string().replace('\n', " "),
        out = q(&out_root.display().to_string()),
        run_cmd = q(&run_words.join(" ")),
        merge_cmd = q(&merge_words.join(" ")),
        last = tasks - 1,
        jobq = q(&job),
        jobmq = q(&format!("{job}-merge")),
        sb = sb.iter().map(|s| format!("{s} ")).collect::<String>(),
    ))
}
