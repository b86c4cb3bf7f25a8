//! The runner's own cost (`shscale bench runner`): what the bookkeeping — plan, store, resume,
//! manifest, summary and report, merge — spends per run, measured on [`Tally`], a kind that
//! does no work, so everything timed is the runner's; and the same for any config, against the
//! summed time of its runs' own work.
//!
//! Not a timed test: the numbers are recorded in `docs/BENCHMARKS.md` with the machine.

use crate::config::Overrides;
use crate::error::Error;
use crate::kind::{Cost, Ctx, DynKind, Erased, KeyError, Kind};
use crate::merge::{merge, MergeOptions};
use crate::plan::{plan_dir, Plan};
use crate::report::report;
use crate::run::{run_plan, RunEvent};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A kind whose runs do no work: one row per run, `value = i·j`. Not in the registry of
/// experiments; it exists so the runner can be timed alone.
pub struct Tally;

/// [`Tally`]'s parameters: two integers to sweep.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TallyParams {
    pub i: usize,
    pub j: usize,
    /// A file every run "reads" (empty: none): hashed at plan time like a mesh, so the bench
    /// times inputs by content ([`hash_cost`]).
    pub input: String,
}

/// [`Tally`]'s row.
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct TallyRow {
    pub value: f64,
}

impl Kind for Tally {
    const NAME: &'static str = "tally";
    const QUESTION: &'static str = "What does the runner itself cost per run?";
    type Params = TallyParams;
    type Shared = ();
    type Row = TallyRow;
    type Error = Error;
    type Spec = TallyParams;

    fn resolve(p: &TallyParams) -> Result<TallyParams, KeyError> {
        Ok(p.clone())
    }
    fn inputs(p: &TallyParams, config_dir: &Path) -> Result<Vec<crate::inputs::Input>, KeyError> {
        Ok(if p.input.is_empty() {
            Vec::new()
        } else {
            vec![crate::inputs::Input::File {
                key: "input".into(),
                path: config_dir.join(&p.input),
            }]
        })
    }
    fn cost(_: &Self::Spec) -> (Cost, Cost) {
        (Cost::default(), Cost::default())
    }
    fn rows_per_run(_: &TallyParams) -> usize {
        1
    }
    fn shared(_: &TallyParams, _: &Ctx) -> Result<(), Error> {
        Ok(())
    }
    fn run(p: &TallyParams, _: &str, _: &(), _: &Ctx) -> Result<Vec<TallyRow>, Error> {
        Ok(vec![TallyRow {
            value: (p.i * p.j) as f64,
        }])
    }
    fn summary_columns() -> &'static [&'static str] {
        &["value"]
    }
    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("i", "an integer (swept)"),
            ("j", "an integer (swept)"),
            (
                "input",
                "a file every run reads (hashed by content), relative to the config",
            ),
        ]
    }
}

/// [`Tally`] as the runner sees it.
pub static TALLY: Erased<Tally> = Erased::new();

/// A [`Tally`] config of `runs` runs: `i` over 0..100 (fewer for small plans) times `j`.
pub fn tally_config(runs: usize) -> String {
    let a = runs.clamp(1, 100);
    let b = runs.div_ceil(a);
    let list = |n: usize| (0..n).map(|x| x.to_string()).collect::<Vec<_>>().join(", ");
    format!(
        "experiment = \"tally\"\nname = \"tally-{runs}\"\n\n[sweep]\ni = [{}]\nj = [{}]\n",
        list(a),
        list(b)
    )
}

/// What hashing inputs by content costs: one file of `bytes` hashed cold (read and BLAKE3), the
/// same bytes embedded in the binary (a bundled mesh), a cached lookup (a `stat` and the cache),
/// and the plan of `runs` runs that all read the file against the same plan without it.
#[derive(Clone, Debug, Serialize)]
pub struct HashCost {
    pub bytes: u64,
    pub cold_file_s: f64,
    pub cold_embedded_s: f64,
    pub cached_per_call_s: f64,
    pub runs: usize,
    pub plan_with_input_s: f64,
    pub plan_without_s: f64,
    /// Files (or embedded data) read to hash during the plan with the input: 1 when the cache
    /// works.
    pub reads_in_plan: usize,
}

/// [`HashCost`] of `bytes` (written to a file in `dir`, which must exist) and a plan of `runs`
/// runs reading it.
pub fn hash_cost(dir: &Path, bytes: &'static [u8], runs: usize) -> Result<HashCost, Error> {
    use crate::inputs::{hash_all, hash_embedded, hash_file, Input, HASHED_READS};
    use std::sync::atomic::Ordering;
    let f = dir.join("input-cold.bin");
    std::fs::write(&f, bytes).map_err(|e| Error::io(&f, e))?;
    let t = Instant::now();
    hash_file(&f)?;
    let cold_file_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    hash_embedded(bytes);
    let cold_embedded_s = t.elapsed().as_secs_f64();
    let one = [Input::File {
        key: "input".into(),
        path: f.clone(),
    }];
    let n = 10_000;
    let t = Instant::now();
    for _ in 0..n {
        hash_all(&one).map_err(|(k, m)| Error::Config(format!("{k}: {m}")))?;
    }
    let cached_per_call_s = t.elapsed().as_secs_f64() / n as f64;
    let g = dir.join("input-plan.bin");
    std::fs::write(&g, bytes).map_err(|e| Error::io(&g, e))?;
    let cfg = dir.join("tally.toml");
    let file = cfg.display().to_string();
    let without = tally_config(runs);
    let with = without.replace("\n\n[sweep]", "\ninput = \"input-plan.bin\"\n\n[sweep]");
    let t = Instant::now();
    Plan::parse(&file, "bench", &without, &Overrides::default(), &[&TALLY])?;
    let plan_without_s = t.elapsed().as_secs_f64();
    let before = HASHED_READS.load(Ordering::Relaxed);
    let t = Instant::now();
    let p = Plan::parse(&file, "bench", &with, &Overrides::default(), &[&TALLY])?;
    let plan_with_input_s = t.elapsed().as_secs_f64();
    let reads_in_plan = HASHED_READS.load(Ordering::Relaxed) - before;
    if p.runs.iter().any(|r| r.inputs.len() != 1) {
        return Err(Error::Config(
            "bench: a run of the plan does not read its input".into(),
        ));
    }
    Ok(HashCost {
        bytes: bytes.len() as u64,
        cold_file_s,
        cold_embedded_s,
        cached_per_call_s,
        runs: p.runs.len(),
        plan_with_input_s,
        plan_without_s,
        reads_in_plan,
    })
}

/// What one sweep cost, in seconds of wall time.
#[derive(Clone, Debug, Serialize)]
pub struct SweepCost {
    pub runs: usize,
    /// Reading and resolving the config into its plan.
    pub plan_s: f64,
    /// [`run_plan`]: every run, its rows appended, the manifest, the file put in plan order.
    pub run_s: f64,
    /// The runs' own work, summed (as the runner timed each run).
    pub work_s: f64,
    /// The summary, plots and report, once at the end.
    pub report_s: f64,
    /// A second `run` of the finished plan (nothing to do): plan, load and validate the rows.
    pub resume_s: f64,
    /// Bookkeeping per run: `(plan + run + report − work) / runs`.
    pub overhead_per_run_s: f64,
    /// The whole sweep over its runs' own work.
    pub total_over_work: f64,
    /// Bytes of `runs.csv` and of `report.html` at the end.
    pub csv_bytes: u64,
    pub html_bytes: u64,
    /// The process's peak resident memory so far (Linux; 0 elsewhere).
    pub peak_rss_bytes: u64,
}

/// Plan, run, report and resume `text` (a config of a kind in `registry`; `file` names it in
/// errors, and the paths it holds — a scene — are read relative to its folder, as `run` does)
/// under `out_root`, which should be empty. The plan is held to the work limits unless
/// `allow_large`, as `run` holds it.
pub fn sweep(
    text: &str,
    file: &str,
    registry: &[&'static dyn DynKind],
    out_root: &Path,
    allow_large: bool,
) -> Result<SweepCost, Error> {
    let t = Instant::now();
    let plan = Plan::parse(file, "bench", text, &Overrides::default(), registry)?;
    plan.check_limits(allow_large)?;
    let plan_s = t.elapsed().as_secs_f64();
    let work = std::sync::Mutex::new(0.0f64);
    let t = Instant::now();
    run_plan(&plan, out_root, None, &|e| {
        if let RunEvent::Done { secs, .. } = e {
            *work.lock().unwrap_or_else(|p| p.into_inner()) += secs;
        }
    })?;
    let run_s = t.elapsed().as_secs_f64();
    let dir = plan_dir(&plan, out_root);
    let t = Instant::now();
    report(plan.kind, &dir)?;
    let report_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let again = Plan::parse(file, "bench", text, &Overrides::default(), registry)?;
    let s = run_plan(&again, out_root, None, &|_| {})?;
    let resume_s = t.elapsed().as_secs_f64();
    if s.ran != 0 {
        return Err(Error::Config(format!(
            "bench: the resumed plan ran {} run(s); a finished plan should run none",
            s.ran
        )));
    }
    let work_s = work.into_inner().unwrap_or_else(|p| p.into_inner());
    let runs = plan.runs.len();
    let size = |f: &str| std::fs::metadata(dir.join(f)).map_or(0, |m| m.len());
    Ok(SweepCost {
        runs,
        plan_s,
        run_s,
        work_s,
        report_s,
        resume_s,
        overhead_per_run_s: (plan_s + run_s + report_s - work_s) / runs.max(1) as f64,
        total_over_work: (plan_s + run_s + report_s) / work_s,
        csv_bytes: size("runs.csv"),
        html_bytes: size("report.html"),
        peak_rss_bytes: peak_rss(),
    })
}

/// What merging shard files cost.
#[derive(Clone, Debug, Serialize)]
pub struct MergeCost {
    pub shards: usize,
    pub rows: usize,
    /// [`merge`]: every shard validated, runs deduplicated, `runs.csv` and the manifest written.
    pub merge_s: f64,
    /// The merged directory's summary, plots and report.
    pub report_s: f64,
}

/// Split the finished `runs.csv` of `dir` into `shards` shard files (rows dealt out as
/// `--shard i/n` would) in a fresh directory `<dir>-shards` beside it, then merge them.
pub fn merge_shards(dir: &Path, shards: usize) -> Result<MergeCost, Error> {
    let (header, rows) = crate::records::read_raw(&dir.join("runs.csv"))?;
    let shard_dir = PathBuf::from(format!("{}-shards", dir.display()));
    let _ = std::fs::remove_dir_all(&shard_dir);
    std::fs::create_dir_all(&shard_dir).map_err(|e| Error::io(&shard_dir, e))?;
    let manifest = dir.join("manifest.toml");
    std::fs::copy(&manifest, shard_dir.join("manifest.toml"))
        .map_err(|e| Error::io(&manifest, e))?;
    let n = shards.max(1);
    let mut dealt: Vec<Vec<Vec<String>>> = vec![Vec::new(); n];
    for (i, (_, r)) in rows.into_iter().enumerate() {
        dealt[i % n].push(r);
    }
    for (i, part) in dealt.iter().enumerate() {
        let p = shard_dir.join(format!("runs.shard-{i}-of-{n}.csv"));
        let text = crate::records::write_text(&header, part)?;
        std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
    }
    let out = shard_dir.join("merged");
    let t = Instant::now();
    let m = merge(
        std::slice::from_ref(&shard_dir),
        Some(&out),
        &[&TALLY],
        MergeOptions::default(),
    )?;
    let merge_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    report(m.kind, &out)?;
    Ok(MergeCost {
        shards: m.files,
        rows: m.rows,
        merge_s,
        report_s: t.elapsed().as_secs_f64(),
    })
}

/// The peak resident memory of this process (`VmHWM`, Linux), 0 where unknown.
pub(crate) fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashing_a_plan_of_many_runs_reads_its_input_once() {
        let d = std::env::temp_dir().join(format!("shscale-hashcost-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let c = hash_cost(&d, b"v 0 0 0\n", 500).unwrap();
        assert_eq!(c.runs, 500);
        assert_eq!(c.reads_in_plan, 1, "{c:?}");
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn tally_configs_have_the_runs_asked_for_and_the_bench_resumes_to_nothing() {
        for runs in [1, 7, 100, 300] {
            let p = Plan::parse(
                "t.toml",
                "t",
                &tally_config(runs),
                &Overrides::default(),
                &[&TALLY],
            )
            .unwrap();
            assert!(p.runs.len() >= runs && p.runs.len() < runs + 100, "{runs}");
        }
        let root =
            std::env::temp_dir().join(format!("shscale-bench-runner-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let s = sweep(&tally_config(200), "--runs 200", &[&TALLY], &root, false).unwrap();
        assert_eq!(s.runs, 200);
        assert!(s.csv_bytes > 0 && s.html_bytes > 0, "{s:?}");
        let m = merge_shards(&root.join("tally").join("tally-200"), 7).unwrap();
        assert_eq!((m.shards, m.rows), (7, 200));
        std::fs::remove_dir_all(&root).ok();
    }
}
