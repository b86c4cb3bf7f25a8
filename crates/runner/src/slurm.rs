//! Slurm job-array scripts: the shards of a plan as an array, then a dependent merge job.

use crate::error::Error;
use crate::plan::{plan_dir, Plan};
use std::path::Path;

/// Options passed through to `sbatch`.
#[derive(Clone, Debug, Default)]
pub struct SlurmOptions {
    pub time: Option<String>,
    pub mem: Option<String>,
    pub partition: Option<String>,
    pub cpus_per_task: Option<usize>,
    pub account: Option<String>,
    /// At most this many array tasks run at once (`--array=0-N%K`).
    pub array_parallel: Option<usize>,
    /// `--dependency` of the array job, passed through.
    pub dependency: Option<String>,
}

/// A word quoted for a POSIX shell.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// The values `sbatch` is given, checked: `--tasks` 1..=100000, `--array-parallel` at most the
/// tasks, `--dependency` one word; each a word (not empty, no whitespace or control
/// character); `--cpus-per-task` ≥ 1; `--time` in one of Slurm's forms (minutes, `MM:SS`,
/// `HH:MM:SS`, `D-HH[:MM[:SS]]`, or `UNLIMITED`); `--mem` a whole number with an optional
/// unit K, M, G or T; `--binary` not empty and without control characters (spaces and quotes
/// are quoted in the script).
fn check_options(binary: &str, tasks: usize, opts: &SlurmOptions) -> Result<(), Error> {
    crate::check::int(tasks, 1, 100_000)
        .map_err(|m| Error::Config(format!("slurm: --tasks: {m}")))?;
    if let Some(k) = opts.array_parallel {
        crate::check::int(k, 1, tasks)
            .map_err(|m| Error::Config(format!("slurm: --array-parallel: {m} (the tasks)")))?;
    }
    if let Some(d) = &opts.dependency {
        if d.is_empty() || d.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(Error::Config(format!(
                "slurm: --dependency {d:?}: a Slurm dependency list has no spaces (e.g. afterok:123:456)"
            )));
        }
    }
    let word = |flag: &str, v: &str| -> Result<(), Error> {
        if v.is_empty() || v.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(Error::Config(format!(
                "slurm: {flag} {v:?}: needs a value without spaces"
            )));
        }
        Ok(())
    };
    // The binary is quoted in the script like every value: spaces and shell syntax in its path
    // are data, not refused; only an empty path or a control character is.
    if binary.is_empty() || binary.chars().any(|c| c.is_control()) {
        return Err(Error::Config(format!(
            "slurm: --binary {binary:?}: needs a path without control characters"
        )));
    }
    for (flag, v) in [
        ("--time", &opts.time),
        ("--mem", &opts.mem),
        ("--partition", &opts.partition),
        ("--account", &opts.account),
    ] {
        if let Some(v) = v {
            word(flag, v)?;
        }
    }
    if let Some(t) = &opts.time {
        let unlimited = t.eq_ignore_ascii_case("unlimited") || t.eq_ignore_ascii_case("infinite");
        let (days, rest) = t
            .split_once('-')
            .map_or((None, t.as_str()), |(d, r)| (Some(d), r));
        let digits =
            |s: &str| !s.is_empty() && s.len() <= 6 && s.bytes().all(|b| b.is_ascii_digit());
        let parts: Vec<&str> = rest.split(':').collect();
        let ok = unlimited
            || (days.is_none_or(digits) && parts.len() <= 3 && parts.iter().all(|p| digits(p)));
        if !ok {
            return Err(Error::Config(format!(
                "slurm: --time {t:?}: expected minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS or UNLIMITED"
            )));
        }
    }
    if let Some(m) = &opts.mem {
        let num = m.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
        let ok = !num.is_empty()
            && m.len() - num.len() <= 1
            && num.len() <= 12
            && num.bytes().all(|b| b.is_ascii_digit());
        if !ok {
            return Err(Error::Config(format!(
                "slurm: --mem {m:?}: expected a whole number with an optional unit K, M, G or T (e.g. 8G)"
            )));
        }
    }
    if let Some(c) = opts.cpus_per_task {
        crate::check::int(c, 1, 4096)
            .map_err(|m| Error::Config(format!("slurm: --cpus-per-task: {m}")))?;
    }
    Ok(())
}

/// The `sbatch` options of both jobs, each value shell-quoted.
fn sbatch_options(opts: &SlurmOptions) -> Vec<String> {
    let q = shell_quote;
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
    sb
}

/// A Slurm job-array script that runs `config` (with the plan's overrides) in `tasks` shards
/// and then, in a dependent job (`afterok`: a failed shard leaves it undone), merges them into
/// `<dir>/merged` with plots and summary. Every value written into the script is shell-quoted.
///
/// Submitting the script again after a failure completes only the missing runs (each shard
/// resumes its own file) and merges again: the merge job owns `<dir>/merged` and replaces its
/// own earlier output atomically (`merge --replace`).
pub fn slurm_script(
    config: &Path,
    plan: &Plan,
    tasks: usize,
    binary: &str,
    out_root: &Path,
    opts: &SlurmOptions,
) -> Result<String, Error> {
    check_options(binary, tasks, opts)?;
    // More tasks than runs would leave array tasks with nothing to do: capped (the caller says so).
    let tasks = tasks.min(plan.runs.len().max(1));
    let q = shell_quote;
    let dir = plan_dir(plan, out_root);
    let sb = sbatch_options(opts);
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
        "--replace".into(),
    ];
    let throttle = opts
        .array_parallel
        .map_or(String::new(), |k| format!("%{k}"));
    let after = opts
        .dependency
        .as_ref()
        .map_or(String::new(), |d| format!("--dependency={} ", q(d)));
    let job = format!("shscale-{}", plan.name);
    Ok(format!(
        r#"#!/usr/bin/env bash
# Generated by `shscale slurm`: {runs} run(s) of {cfg} in {tasks} shard(s), then a merge
# (with plots and summary) into {merged}.
# Submit with:  bash THIS_SCRIPT   (it calls sbatch twice). Submitting it again after a
# failure runs only the missing runs, then merges again (replacing its own earlier merge).
set -euo pipefail
OUT={out}
mkdir -p "$OUT"
RUN_CMD={run_cmd}
MERGE_CMD={merge_cmd}
array_job=$(sbatch --parsable --array=0-{last}{throttle} {after}--job-name={jobq} {sb}--output="$OUT/slurm-%A_%a.log" --wrap "$RUN_CMD")
merge_job=$(sbatch --parsable --dependency=afterok:"$array_job" --job-name={jobmq} {sb}--output="$OUT/slurm-merge-%j.log" --wrap "$MERGE_CMD")
echo "submitted array job $array_job ({tasks} tasks) and merge job $merge_job"
"#,
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
