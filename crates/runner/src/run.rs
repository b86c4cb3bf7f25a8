//! Running a plan: execution into `<out>/<kind>/<name>/` with resume, shards, an advisory lock,
//! rows appended once per finished run and a manifest of every config version. The plan is [`crate::plan`], the
//! store [`crate::store`], the manifest [`crate::manifest`], the merge of shard files
//! [`crate::merge`], Slurm scripts [`crate::slurm`] and the summary and report [`crate::report`].
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
//! **Bookkeeping in linear time.** The existing rows are read and validated once, when the plan
//! starts; finished runs' rows are then appended whole (flushed and synced) in group commits —
//! every run that finished within [`COMMIT_INTERVAL`] (100 ms) in one append and one sync, by a
//! timer that commits what finished at most [`COMMIT_INTERVAL`] after it finished (so a long run
//! never holds the rows of the runs before it) — and their ids kept in memory, so each run costs the same whatever the
//! file holds (docs/BENCHMARKS.md, "Group commits": 12–21 µs per run from 10³ to 10⁵ runs on
//! the Zen 5 VM, where rewriting the file per run cost 113 ms per run at 10³; with the
//! provenance columns, "Rows that know what made them": 20–37 µs on the Emerald Rapids VM,
//! where the runner before them took 8–13 µs). The file is put in plan
//! order once, and the manifest's last time moved, when the plan ends; on a long unsharded plan
//! the summary, plots and report of the rows so far are also written at most every
//! [`crate::plan::INTERIM_REPORT`] (30 s), never per run. A torn last line (a writer killed
//! mid-append) is set aside on the next start and its run redone; a process killed between
//! commits loses at most the last 100 ms of finished runs, which the next start redoes. An error
//! (or a panic) in a run commits the runs that finished before it.
//!
//! **Concurrency.** Every append and every manifest write holds an exclusive advisory lock on
//! `<dir>/.lock` (`std::fs::File::lock`): a second process waits for it, reads what the other
//! appended since it last looked (validated as on resume) and adds its rows only for runs not
//! already there, so two processes on one directory never lose or duplicate a run.

use crate::error::Error;
use crate::kind::{Ctx, Resolved, RowCells};
use crate::manifest::{unix_now, Manifest, Provenance, RowProvenance, Version};
use crate::plan::{plan_dir, Plan, StalePolicy};
use crate::records;
use crate::store::{append_rows, header, keep_rejected, load_rows, read_tail, validate, DirLock};
use shscale_files::atomic::write_atomic;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// Progress of [`run_plan`].
#[derive(Clone, Copy, Debug)]
pub enum RunEvent<'a> {
    Begin {
        total: usize,
        pending: usize,
    },
    /// A shared computation starts.
    Shared(&'a str),
    /// A run finished: a line saying which, and the seconds its work took. Its rows reach the
    /// file with the next group commit — at most [`COMMIT_INTERVAL`] later, and always before
    /// [`run_plan`] returns, with or without an error.
    Done {
        line: &'a str,
        secs: f64,
    },
    /// Something set aside or waited for.
    Warn(&'a str),
    /// The summary, plots and report of the rows so far were written to this directory (on a
    /// long unsharded plan, at most every [`Plan::interim_report`]).
    Interim(&'a Path),
}

/// How long finished runs' rows may wait to be committed (appended under the lock, flushed and
/// synced) together: one commit serves every run that finished within it, so a sweep of
/// sub-millisecond runs pays for a sync about ten times a second rather than once per run. A run
/// whose work took longer is committed as soon as it finishes; a process killed loses at most
/// this much finished work, which the next start redoes.
pub const COMMIT_INTERVAL: std::time::Duration = std::time::Duration::from_millis(100);

/// What a runner invocation did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub dir: PathBuf,
    pub csv: PathBuf,
    pub in_shard: usize,
    pub already_done: usize,
    pub ran: usize,
    pub redone: usize,
    /// Runs of the shard whose rows were stale (another numerical code, or inputs whose
    /// content changed): set aside into `<csv>.stale` and run again.
    pub stale: usize,
}

/// Run `plan` under `out_root`, optionally one shard `(i, n)`; `progress` hears of every step.
pub fn run_plan(
    plan: &Plan,
    out_root: &Path,
    shard: Option<(usize, usize)>,
    progress: &(dyn Fn(RunEvent) + Sync),
) -> Result<RunSummary, Error> {
    static NEVER: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    run_plan_until(plan, out_root, shard, progress, &NEVER)
}

/// [`run_plan`] that stops when `stop` is set: no run starts after it (the ones in progress
/// finish), the finished runs are committed, and the result is [`Error::Interrupted`] with the
/// count of runs finished in this call — unless every run had finished by then. A caller
/// that cannot take a signal on the runner's threads (Python's `run()`) sets it from its own.
pub fn run_plan_until(
    plan: &Plan,
    out_root: &Path,
    shard: Option<(usize, usize)>,
    progress: &(dyn Fn(RunEvent) + Sync),
    stop_flag: &std::sync::atomic::AtomicBool,
) -> Result<RunSummary, Error> {
    let kind = plan.kind;
    let dir = plan_dir(plan, out_root);
    let csv = shard_csv(&dir, shard)?;
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let waiting = |p: &Path| {
        progress(RunEvent::Warn(&format!(
            "waiting for another shscale process holding {}",
            p.display()
        )))
    };
    let (loaded, stale) = load_checked(plan, &dir, &csv, &waiting, progress)?;
    let device = open_device(plan, &loaded, kind)?;
    let gpu_device = device
        .as_ref()
        .map_or("none".to_string(), |d| d.description().to_string());
    let (summary, pending) = plan_progress(plan, shard, &loaded, &dir, &csv);
    let mut summary = summary;
    summary.stale = stale;
    progress(RunEvent::Begin {
        total: summary.in_shard,
        pending: pending.len(),
    });
    let version = version_of(plan, Provenance::here(&gpu_device));
    let writer = Writer {
        plan,
        dir: &dir,
        csv: &csv,
        version,
        order: (plan.runs.iter().enumerate())
            .map(|(i, r)| (r.id.as_str(), i))
            .collect(),
        header: header(plan.kind),
        state: std::sync::Mutex::new(Known::of(&csv, &loaded)),
        waiting: &waiting,
        progress,
        queue: std::sync::Mutex::new(Queue::new()),
        interim: plan.interim_report.filter(|_| shard.is_none()),
    };
    let ctx = Ctx {
        dir: &dir,
        config_dir: config_dir(plan),
        device: device.as_ref(),
        timing: plan.timing,
        stop: stop_flag,
    };
    run_with_commit_timer(plan, &pending, &ctx, &writer, progress)?;
    // On an error above, dropping the writer commits what finished before it.
    summary.ran = writer.finish()?;
    if stop_flag.load(std::sync::atomic::Ordering::Acquire) && summary.ran < pending.len() {
        return Err(Error::Interrupted {
            done: summary.ran,
            csv: csv.display().to_string(),
        });
    }
    Ok(summary)
}

/// The pending runs of `plan` run by [`run_groups`], with the finished ones committed on a
/// timer, not only when the next run finishes: a long run never holds the rows of the runs that
/// finished before it (SIGKILL loses at most COMMIT_INTERVAL of finished runs). Asked to stop,
/// it returns `Ok` once the runs in progress finish (the caller commits and says how much).
fn run_with_commit_timer(
    plan: &Plan,
    pending: &[usize],
    ctx: &Ctx,
    writer: &Writer,
    progress: &(dyn Fn(RunEvent) + Sync),
) -> Result<(), Error> {
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|scope| {
        let ticker = scope.spawn(|| -> Result<(), Error> {
            while !stop.load(std::sync::atomic::Ordering::Acquire) {
                std::thread::park_timeout(COMMIT_INTERVAL / 4);
                crate::contention::tick();
                let batch = (writer.queue.lock())
                    .unwrap_or_else(|e| e.into_inner())
                    .take(false);
                writer.commit(batch, false)?;
            }
            Ok(())
        });
        // The timer stops however this thread leaves the scope: a panic in a run unwinds
        // through the guard, which stops the timer, so the scope's join returns and the panic
        // reaches the process (a panicking run cannot leave the process waiting on the timer).
        let stopping = StopTimer {
            stop: &stop,
            timer: ticker.thread(),
        };
        let ran = run_groups(plan, pending, ctx, writer, progress);
        drop(stopping);
        let ticked = ticker
            .join()
            .unwrap_or_else(|_| Err(Error::Config("the commit timer panicked".into())));
        ran.and(ticked)
    })
    .or_else(|e| match e {
        // Asked to stop: the caller commits what finished; its error then says how much.
        Error::Interrupted { .. } => Ok(()),
        e => Err(e),
    })
}

/// The plan's device as its `gpu` setting says — opened as required under `gpu = "auto"` when
/// a run still to do needs it ([`crate::Kind::needs_device`]): a machine without one is then
/// refused before any work, naming that run, in one line.
fn open_device(
    plan: &Plan,
    loaded: &crate::store::Loaded,
    kind: &dyn crate::DynKind,
) -> Result<Option<crate::Device>, Error> {
    let needing = (plan.runs.iter())
        .filter(|r| !loaded.complete.contains(&r.id))
        .find(|r| kind.needs_device(r));
    match (plan.gpu, needing) {
        (crate::GpuMode::Auto, Some(r)) => kind.open_device(crate::GpuMode::Required).map_err(|e| {
            let why = e.to_string();
            let why = why.trim_start_matches("gpu = \"required\": ");
            Error::Config(format!(
                "run {} asks for the GPU timing (device = \"gpu\") and gpu = \"auto\" found no adapter: {why}",
                r.id
            ))
        }),
        _ => kind.open_device(plan.gpu),
    }
}

/// Stops the commit timer when dropped (at the end of the runs, or by a panic's unwinding).
struct StopTimer<'a> {
    stop: &'a std::sync::atomic::AtomicBool,
    timer: &'a std::thread::Thread,
}

impl Drop for StopTimer<'_> {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Release);
        self.timer.unpark();
    }
}

/// The CSV a run of `plan` (or of one shard `(i, n)` of it) writes in `dir`; a shard outside
/// `0 ≤ i < n` refused.
fn shard_csv(dir: &Path, shard: Option<(usize, usize)>) -> Result<PathBuf, Error> {
    Ok(match shard {
        Some((i, n)) if n == 0 || i >= n => {
            return Err(Error::Config(format!("--shard {i}/{n}: need 0 ≤ I < N")))
        }
        Some((i, n)) => dir.join(format!("runs.shard-{i}-of-{n}.csv")),
        None => dir.join("runs.csv"),
    })
}

/// The provenance cells of one run's rows: the plan's timing procedure, the binary's
/// numerical fingerprint and revision, the run's inputs and how busy the machine was.
fn provenance_cells(
    plan: &Plan,
    version: &Version,
    r: &Resolved,
    concurrent: bool,
    busy: crate::contention::Reading,
) -> Result<Vec<String>, Error> {
    use crate::contention::round2;
    let prov = RowProvenance {
        threads: rayon::current_num_threads(),
        timing_concurrent: concurrent,
        timing_warmup: plan.timing.warmup,
        timing_repeats: plan.timing.repeats,
        code: version.provenance.code.clone(),
        inputs: r.inputs_digest.clone(),
        other_cpu: round2(busy.other_cpu),
        steal: round2(busy.steal),
        load_1m: round2(busy.load_1m),
        contended: busy.contended,
        git_revision: version.provenance.git_revision.clone(),
        git_dirty: version.provenance.git_dirty,
    };
    records::to_cells(&prov)
        .map(|(_, c)| c)
        .map_err(Error::Config)
}

/// Every group with pending runs (`pending`: indices into the plan), its shared work once and
/// then its runs, each run's rows handed to `writer` as it finishes and logged by its id and the
/// swept parameters' values.
fn run_groups(
    plan: &Plan,
    pending: &[usize],
    ctx: &Ctx,
    writer: &Writer,
    progress: &(dyn Fn(RunEvent) + Sync),
) -> Result<(), Error> {
    let columns = plan.kind.param_columns();
    let swept: Vec<(&str, usize)> = (plan.axes.iter())
        .filter_map(|a| columns.iter().position(|c| c == a).map(|i| (a.as_str(), i)))
        .collect();
    let label = |r: &Resolved| {
        let values: Vec<String> = (swept.iter())
            .map(|(a, i)| format!("{a}={}", r.cells.get(*i).map_or("", String::as_str)))
            .collect();
        if values.is_empty() {
            r.id.clone()
        } else {
            format!("{} {}", r.id, values.join(" "))
        }
    };
    let groups = plan.groups();
    let group_count = groups.len();
    let mut todo = vec![false; plan.runs.len()];
    for &i in pending {
        todo[i] = true;
    }
    for (gi, g) in groups.into_iter().enumerate() {
        let runs: Vec<&Resolved> = (g.iter())
            .filter(|&&i| todo[i])
            .map(|&i| &plan.runs[i])
            .collect();
        if runs.is_empty() {
            continue;
        }
        // A group of one run shares nothing: no line for it.
        if runs.len() > 1 {
            progress(RunEvent::Shared(&format!(
                "group {} of {group_count}: shared work for {} run(s)",
                gi + 1,
                runs.len()
            )));
        }
        let concurrent = plan.parallel_runs && runs.len() > 1;
        plan.kind
            .run_group(&runs, ctx, concurrent, &|r, rows, secs, busy| {
                writer.write_run(r, rows, concurrent, busy)?;
                progress(RunEvent::Done {
                    line: &format!("{} in {secs:.2} s", label(r)),
                    secs,
                });
                Ok(())
            })?;
    }
    Ok(())
}

/// The runs of this shard still to do (not complete in `loaded`), and the summary so far: how
/// many are in the shard, already done, and redone because their rows were set aside.
fn plan_progress(
    plan: &Plan,
    shard: Option<(usize, usize)>,
    loaded: &crate::store::Loaded,
    dir: &Path,
    csv: &Path,
) -> (RunSummary, Vec<usize>) {
    let mine: Vec<usize> = (0..plan.runs.len())
        .filter(|i| shard.is_none_or(|(s, n)| i % n == s))
        .collect();
    let pending: Vec<usize> = (mine.iter().copied())
        .filter(|&i| !loaded.complete.contains(&plan.runs[i].id))
        .collect();
    let rejected_ids: BTreeSet<String> = (loaded.rejected.iter())
        .filter_map(|(_, _, r)| r.first().cloned())
        .collect();
    let summary = RunSummary {
        dir: dir.to_path_buf(),
        csv: csv.to_path_buf(),
        in_shard: mine.len(),
        already_done: mine.len() - pending.len(),
        ran: 0,
        stale: 0,
        redone: (pending.iter())
            .filter(|&&i| rejected_ids.contains(&plan.runs[i].id))
            .count(),
    };
    (summary, pending)
}

/// Check the manifest and the existing rows before any work: a directory of another kind is
/// refused; rows set aside are kept in `<csv>.rejected` (with a warning each) and the CSV keeps
/// only the valid ones; rows of this plan's runs that are stale ([`stale_rows`]) are set aside
/// into `<csv>.stale` and their runs redone, or the run refused ([`Plan::stale`]), said in one
/// line. Returns the rows kept and how many of the plan's runs were stale.
fn load_checked(
    plan: &Plan,
    dir: &Path,
    csv: &Path,
    waiting: &dyn Fn(&Path),
    progress: &(dyn Fn(RunEvent) + Sync),
) -> Result<(crate::store::Loaded, usize), Error> {
    let kind = plan.kind;
    let _lock = DirLock::acquire(dir, waiting)?;
    let manifest = Manifest::read(dir)?;
    if let Some(m) = &manifest {
        if m.experiment != kind.name() {
            return Err(Error::Io {
                path: dir.join("manifest.toml").display().to_string(),
                reason: format!("belongs to experiment {:?}", m.experiment),
            });
        }
    }
    let mut l = load_rows(kind, csv)?;
    for (line, why, _) in &l.rejected {
        progress(RunEvent::Warn(&format!(
            "{}:{line}: row set aside ({why}); kept in {}.rejected",
            csv.display(),
            csv.display()
        )));
    }
    let st = stale_rows(plan, &l, manifest.as_ref());
    if !st.runs.is_empty() {
        let line = st.describe(csv);
        if plan.stale == StalePolicy::Refuse {
            return Err(Error::Config(format!(
                "{line}; stopped (--stale refuse): nothing was run or moved. Run again with --stale rerun to set them aside and recompute them, or give another --name to keep this folder as it is"
            )));
        }
        progress(RunEvent::Warn(&format!(
            "{line}: re-running them; their old rows are set aside in {}.stale (--stale refuse stops instead)",
            csv.display()
        )));
    }
    if let Some(w) = st.others_line() {
        progress(RunEvent::Warn(&w));
    }
    if !l.rejected.is_empty() || !st.runs.is_empty() {
        keep_rejected(csv, &l.rejected)?;
        let mut kept = Vec::with_capacity(l.rows.len());
        let mut aside = Vec::new();
        for (i, r) in std::mem::take(&mut l.rows).into_iter().enumerate() {
            match st.runs.get(&r[0]) {
                Some(why) => aside.push((i as u64 + 2, why.clone(), r)),
                None => kept.push(r),
            }
        }
        crate::store::set_aside(csv, "stale", &aside)?;
        for id in st.runs.keys() {
            l.complete.remove(id);
        }
        l.rows = kept;
        write_atomic(csv, &records::write_text(&header(kind), &l.rows)?)?;
    }
    Ok((l, st.runs.len()))
}

/// The stale runs of a plan in a results file: run id → why (its rows' numerical code is not
/// this binary's, or its inputs' digest is not the one hashed now), with counts for the line
/// that says so; and rows of runs outside the plan computed by other code (kept).
#[derive(Default)]
struct Stale {
    runs: std::collections::BTreeMap<String, String>,
    by_code: std::collections::BTreeMap<String, usize>,
    by_inputs: usize,
    changed_inputs: BTreeSet<String>,
    done: usize,
    others_of_other_code: usize,
}

impl Stale {
    fn describe(&self, csv: &Path) -> String {
        let mut why = Vec::new();
        for (code, n) in &self.by_code {
            why.push(format!(
                "{n} computed by numerical code {code} (this binary's is {})",
                crate::manifest::CODE_FINGERPRINT
            ));
        }
        if self.by_inputs > 0 {
            let named: Vec<&str> = self.changed_inputs.iter().map(String::as_str).collect();
            why.push(format!(
                "{} read inputs whose content changed{}",
                self.by_inputs,
                if named.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", named.join(", "))
                }
            ));
        }
        format!(
            "{}: {} of the {} finished run(s) of this plan are stale — {}",
            csv.display(),
            self.runs.len(),
            self.done,
            why.join("; ")
        )
    }

    fn others_line(&self) -> Option<String> {
        (self.others_of_other_code > 0).then(|| {
            format!(
                "the results file also holds {} row(s) of runs outside this plan computed by other numerical code than this binary's {} (kept; the summary names them)",
                self.others_of_other_code,
                crate::manifest::CODE_FINGERPRINT
            )
        })
    }
}

/// [`Stale`] of the loaded rows against the plan; `manifest` names the inputs that changed.
fn stale_rows(plan: &Plan, l: &crate::store::Loaded, manifest: Option<&Manifest>) -> Stale {
    let h = header(plan.kind);
    let (Some(code_at), Some(inputs_at)) = (
        h.iter().position(|c| c == "code"),
        h.iter().position(|c| c == "inputs"),
    ) else {
        return Stale::default();
    };
    let runs: HashMap<&str, &Resolved> = plan.runs.iter().map(|r| (r.id.as_str(), r)).collect();
    let mut st = Stale::default();
    let code = crate::manifest::CODE_FINGERPRINT;
    let mut seen = BTreeSet::new();
    for row in &l.rows {
        let Some(r) = runs.get(row[0].as_str()) else {
            if row[code_at] != code {
                st.others_of_other_code += 1;
            }
            continue;
        };
        if seen.insert(row[0].clone()) {
            st.done += 1;
        }
        if st.runs.contains_key(&row[0]) {
            continue;
        }
        let why = if row[code_at] != code {
            *st.by_code.entry(row[code_at].clone()).or_default() += 1;
            format!(
                "stale: numerical code {}, this binary's is {code}",
                row[code_at]
            )
        } else if row[inputs_at] != r.inputs_digest {
            st.by_inputs += 1;
            for h in r.inputs.iter() {
                let before = (manifest.into_iter().flat_map(|m| m.versions.iter()))
                    .filter_map(|v| v.inputs.get(&h.label))
                    .any(|old| *old != h.hash);
                if before {
                    st.changed_inputs.insert(h.label.clone());
                }
            }
            format!(
                "stale: inputs {} changed to {} since the row was computed",
                row[inputs_at], r.inputs_digest
            )
        } else {
            continue;
        };
        st.runs.insert(row[0].clone(), why);
    }
    st
}

/// The config version a plan runs as: its id hashes the text, the overrides, the numerical
/// fingerprint and the content of every input the plan reads — not the git revision, so a
/// docs-only commit runs the same version.
fn version_of(plan: &Plan, prov: Provenance) -> Version {
    let inputs: std::collections::BTreeMap<String, String> = (plan.runs.iter())
        .flat_map(|r| r.inputs.iter())
        .map(|h| (h.label.clone(), h.hash.clone()))
        .collect();
    let listed: String = (inputs.iter())
        .map(|(l, h)| format!("{l}\t{h}\n"))
        .collect();
    Version {
        id: records::run_id(
            "version",
            &format!(
                "{}\n{}\n{}\n{listed}",
                plan.text,
                plan.overrides.join(" "),
                prov.code,
            ),
        ),
        config_file: plan.file.clone(),
        overrides: plan.overrides.clone(),
        axes: plan.axes.clone(),
        runs_in_plan: plan.runs.len(),
        first_unix_time: prov.unix_time,
        last_unix_time: prov.unix_time,
        provenance: prov,
        inputs,
        config_text: plan.text.clone(),
    }
}

/// The folder of the config file (`.` for a bare name): paths in parameters are relative to it.
fn config_dir(plan: &Plan) -> &Path {
    Path::new(&plan.file)
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Writes finished runs' rows, with the manifest that describes them, under the lock — in
/// time independent of the rows already there: finished runs wait in a queue and are committed
/// together (one append, flushed and synced, at most every [`COMMIT_INTERVAL`]); the file is read
/// only from where this process last left it (rows other processes appended since, validated as
/// on resume), and the finished runs are kept in memory. The rows are put in plan order once,
/// when the plan ends ([`Writer::finish`]); dropping the writer on an error commits the queue.
struct Writer<'a> {
    plan: &'a Plan,
    dir: &'a Path,
    csv: &'a Path,
    version: Version,
    /// Plan order of the run ids (rows are kept in it).
    order: HashMap<&'a str, usize>,
    /// The kind's CSV header.
    header: Vec<String>,
    /// What this process knows of the file, and the runs it wrote.
    state: std::sync::Mutex<Known>,
    waiting: &'a (dyn Fn(&Path) + Sync),
    progress: &'a (dyn Fn(RunEvent) + Sync),
    /// Finished runs not yet committed.
    queue: std::sync::Mutex<Queue>,
    /// How often the summary and report of the rows so far are written (unsharded plans).
    interim: Option<std::time::Duration>,
}

/// Finished runs waiting for the next commit: their ids and rows.
struct Queue {
    runs: Vec<(String, Vec<Vec<String>>)>,
    last_commit: std::time::Instant,
    last_report: std::time::Instant,
}

impl Queue {
    fn new() -> Self {
        let now = std::time::Instant::now();
        Self {
            runs: Vec::new(),
            last_commit: now,
            last_report: now,
        }
    }

    /// The queued runs, if it is time to commit them (or `now`).
    fn take(&mut self, now: bool) -> Vec<(String, Vec<Vec<String>>)> {
        if self.runs.is_empty() || !(now || self.last_commit.elapsed() >= COMMIT_INTERVAL) {
            return Vec::new();
        }
        self.last_commit = std::time::Instant::now();
        std::mem::take(&mut self.runs)
    }
}

/// The results file as this process last read or wrote it.
#[derive(Default)]
struct Known {
    /// Its length, and the line the next row starts on.
    offset: u64,
    next_line: u64,
    /// The complete runs in it.
    complete: BTreeSet<String>,
    /// Runs this process wrote.
    ran: usize,
}

impl Known {
    /// What a freshly loaded (and cleaned) file holds.
    fn of(csv: &Path, loaded: &crate::store::Loaded) -> Self {
        Self {
            offset: std::fs::metadata(csv).map_or(0, |m| m.len()),
            next_line: loaded.rows.len() as u64 + 2,
            complete: loaded.complete.clone(),
            ran: 0,
        }
    }
}

impl Writer<'_> {
    /// Queue a finished run's rows, and commit the queue when it is due.
    fn write_run(
        &self,
        r: &Resolved,
        rows: RowCells,
        concurrent: bool,
        busy: crate::contention::Reading,
    ) -> Result<(), Error> {
        let kind = self.plan.kind;
        let pcells = &provenance_cells(self.plan, &self.version, r, concurrent, busy)?;
        let lines: Vec<Vec<String>> = rows
            .into_iter()
            .map(|row| {
                let mut cells = vec![r.id.clone(), kind.name().to_string()];
                cells.extend(r.cells.iter().cloned());
                cells.extend(row);
                cells.extend(pcells.iter().cloned());
                cells
            })
            .collect();
        let batch = {
            let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
            q.runs.push((r.id.clone(), lines));
            q.take(false)
        };
        self.commit(batch, true)
    }

    /// Append the rows of `batch`'s runs not already in the file, in one write, flushed and
    /// synced, under the lock; record the version after its first rows; and, when due, write the
    /// summary and report of the rows so far.
    fn commit(
        &self,
        batch: Vec<(String, Vec<Vec<String>>)>,
        may_report: bool,
    ) -> Result<(), Error> {
        if batch.is_empty() {
            return Ok(());
        }
        let mut known = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let _lock = DirLock::acquire(self.dir, self.waiting)?;
        self.catch_up(&mut known)?;
        let mut lines = Vec::new();
        let runs = batch.len();
        for (id, rows) in batch {
            if known.complete.insert(id) {
                lines.extend(rows);
            }
        }
        if !lines.is_empty() {
            let fresh = known.offset == 0;
            known.offset = append_rows(self.csv, &self.header, &lines)?;
            known.next_line += lines.len() as u64 + u64::from(fresh);
        }
        // The manifest that describes the rows, after them: the version is recorded once its
        // first run has succeeded, and its last time when the plan ends.
        if known.ran == 0 {
            self.record_version()?;
        }
        known.ran += runs;
        if let Some(every) = self.interim.filter(|_| may_report) {
            let due = {
                let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
                let due = q.last_report.elapsed() >= every;
                if due {
                    q.last_report = std::time::Instant::now();
                }
                due
            };
            if due {
                match crate::report::report(self.plan.kind, self.dir) {
                    Ok(_) => (self.progress)(RunEvent::Interim(self.dir)),
                    Err(e) => (self.progress)(RunEvent::Warn(&format!(
                        "the interim report of the rows so far failed: {e}"
                    ))),
                }
            }
        }
        Ok(())
    }

    /// Add this plan's config version to `manifest.toml` (or move its last time to now).
    fn record_version(&self) -> Result<(), Error> {
        let mut m = Manifest::read(self.dir)?.unwrap_or(Manifest {
            experiment: self.plan.kind.name().into(),
            name: self.plan.name.clone(),
            versions: Vec::new(),
            missing: Vec::new(),
        });
        let mut v = self.version.clone();
        v.last_unix_time = unix_now();
        m.add(&v);
        let text = toml::to_string(&m).map_err(|e| Error::Config(e.to_string()))?;
        Ok(write_atomic(&self.dir.join("manifest.toml"), &text)?)
    }

    /// Read what other processes appended since this one last read or wrote the file (or, when
    /// the file was rewritten meanwhile, all of it again).
    fn catch_up(&self, known: &mut Known) -> Result<(), Error> {
        let kind = self.plan.kind;
        let len = std::fs::metadata(self.csv).map_or(0, |m| m.len());
        if len == known.offset {
            return Ok(());
        }
        if len < known.offset || known.offset == 0 {
            let l = load_rows(kind, self.csv)?;
            let ran = known.ran;
            *known = Known::of(self.csv, &l);
            known.ran = ran;
            return Ok(());
        }
        let (raw, len) = read_tail(self.csv, known.offset, known.next_line)?;
        known.next_line += raw.len() as u64;
        let l = validate(kind, &self.header, raw);
        known.complete.extend(l.complete);
        known.offset = len;
        Ok(())
    }

    /// Put the file's rows in plan order, once, at the end of the plan: rows of this plan in
    /// plan order, others (earlier versions, other processes) first in their order.
    fn finish(&self) -> Result<usize, Error> {
        let kind = self.plan.kind;
        let rest = (self.queue.lock().unwrap_or_else(|e| e.into_inner())).take(true);
        self.commit(rest, false)?;
        let known = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if known.ran == 0 {
            return Ok(0);
        }
        let _lock = DirLock::acquire(self.dir, self.waiting)?;
        let mut cur = load_rows(kind, self.csv)?;
        cur.rows.sort_by_key(|row| {
            row.first()
                .and_then(|id| self.order.get(id.as_str()))
                .map_or(0, |i| i + 1)
        });
        write_atomic(self.csv, &records::write_text(&header(kind), &cur.rows)?)?;
        write_atomic(
            &self.dir.join("runs.schema.json"),
            &crate::schema::schema_json(kind),
        )?;
        self.record_version()?;
        Ok(known.ran)
    }
}

impl Drop for Writer<'_> {
    /// Runs that finished before an error (or a panic) are committed, not lost.
    fn drop(&mut self) {
        let rest = (self.queue.lock().unwrap_or_else(|e| e.into_inner())).take(true);
        if let Err(e) = self.commit(rest, false) {
            (self.progress)(RunEvent::Warn(&format!(
                "rows of finished runs could not be written: {e}"
            )));
        }
    }
}
