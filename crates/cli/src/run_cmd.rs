//! `shscale run`, `merge`, `slurm`: experiments through the one runner (`shscale_runner`).

use crate::args::{MergeArgs, OverrideArgs, RunArgs, SlurmArgs};
use anyhow::{bail, Context};
use shscale_runner::config::Overrides;
use shscale_runner::{self as runner, run_plan, Plan, RunEvent, SlurmOptions};
use std::process::ExitCode;

fn overrides(o: &OverrideArgs) -> Overrides {
    Overrides {
        set: o.set.clone(),
        sweep: o.sweep.clone(),
        name: o.name.clone(),
    }
}

fn parse_shard(s: &str) -> anyhow::Result<(usize, usize)> {
    let (i, n) = s
        .split_once('/')
        .with_context(|| format!("--shard {s}: expected I/N, e.g. 0/4"))?;
    let (i, n): (usize, usize) = (
        i.trim()
            .parse()
            .with_context(|| format!("--shard {s}: I = {i:?} is not a whole number ≥ 0"))?,
        n.trim()
            .parse()
            .with_context(|| format!("--shard {s}: N = {n:?} is not a whole number ≥ 1"))?,
    );
    if n == 0 || i >= n || n > 100_000 {
        bail!("--shard {s}: needs 0 ≤ I < N ≤ 100000");
    }
    Ok((i, n))
}

pub fn run(a: RunArgs) -> anyhow::Result<ExitCode> {
    let Some(config) = a.config else {
        eprintln!("error: shscale run CONFIG: give an experiment config, e.g. `shscale run configs/quickstart.toml` (see configs/README.md)");
        return Ok(ExitCode::from(2));
    };
    let shard = a.shard.as_deref().map(parse_shard).transpose()?;
    crate::flags::out_folder("--out-dir", &a.out_dir)?;
    let registry = shscale_experiments::registry();
    if a.dry_run {
        crate::flags::calibrate_estimates()?;
        // Surveyed run by run, never held: a plan of 10⁶ runs in bounded memory.
        let s = runner::plan::survey_file(&config, &overrides(&a.overrides), &registry)?;
        print!("{}", s.describe(shard));
        s.estimate.check_limits(&s.file, a.allow_large)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut plan = Plan::load(&config, &overrides(&a.overrides), &registry)?;
    plan.check_limits(a.allow_large)?;
    plan.stale = match a.stale {
        crate::args::StaleArg::Rerun => runner::StalePolicy::Rerun,
        crate::args::StaleArg::Refuse => runner::StalePolicy::Refuse,
    };
    let json = a.format == crate::args::TextFormat::Json;
    if !json {
        println!(
            "{}: experiment {:?}, {} run(s){}",
            config.display(),
            plan.kind.name(),
            plan.runs.len(),
            shard
                .map(|(i, n)| format!(", shard {i}/{n}"))
                .unwrap_or_default()
        );
    }
    let progress = RunProgress::new(json);
    explain_interrupts(&plan, &a.out_dir, shard);
    let s = run_plan(&plan, &a.out_dir, shard, &|ev| progress.on(ev))?;
    progress.finish();
    if !json {
        println!(
        "ran {}, skipped {} already done ({} redone after invalid rows, {} after stale rows), of {} in this shard → {}",
        s.ran,
        s.already_done,
        s.redone,
        s.stale,
        s.in_shard,
        s.csv.display()
    );
    }
    let files = if shard.is_none() {
        runner::report(plan.kind, &s.dir)?.files
    } else {
        Vec::new()
    };
    if json {
        crate::output::print_json(&serde_json::json!({
            "experiment": plan.kind.name(),
            "name": plan.name,
            "dir": s.dir.display().to_string(),
            "csv": s.csv.display().to_string(),
            "runs_in_shard": s.in_shard,
            "ran": s.ran,
            "already_done": s.already_done,
            "redone": s.redone,
            "stale": s.stale,
            "files": files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        }))?;
        return Ok(ExitCode::SUCCESS);
    }
    for f in &files {
        println!("  wrote {}", f.display());
    }
    if shard.is_none() {
        println!(
            "{}",
            std::fs::read_to_string(s.dir.join("summary.md")).unwrap_or_default()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// On Ctrl-C, say what was kept (the CSV this run appends to) and the command that resumes it
/// (this one, every argument that needs it shell-quoted).
fn explain_interrupts(plan: &Plan, out_dir: &std::path::Path, shard: Option<(usize, usize)>) {
    let dir = runner::plan::plan_dir(plan, out_dir);
    let csv = match shard {
        Some((i, n)) => dir.join(format!("runs.shard-{i}-of-{n}.csv")),
        None => dir.join("runs.csv"),
    };
    let plain = |a: &str| {
        !a.is_empty()
            && a.chars()
                .all(|c| c.is_ascii_alphanumeric() || "_./=:,+-@%".contains(c))
    };
    let resume: Vec<String> = std::env::args()
        .map(|a| {
            if plain(&a) {
                a
            } else {
                runner::shell_quote(&a)
            }
        })
        .collect();
    crate::interrupt::explain_on_interrupt(&csv, &resume.join(" "));
}

/// A progress bar with ETA over the pending runs (drawn on stderr only when it is a terminal);
/// every finished run is also logged as a line on stdout (nothing with `--format json`).
struct RunProgress {
    json: bool,
    bar: std::sync::OnceLock<indicatif::ProgressBar>,
    start: std::time::Instant,
    last: std::sync::Mutex<std::time::Instant>,
}

impl RunProgress {
    fn new(json: bool) -> Self {
        let start = std::time::Instant::now();
        Self {
            json,
            bar: std::sync::OnceLock::new(),
            start,
            last: std::sync::Mutex::new(start),
        }
    }

    fn log(&self, line: &str) {
        match self.bar.get() {
            _ if self.json => {}
            Some(b) if !b.is_hidden() => b.println(format!("  {line}")),
            _ => println!("  {line}"),
        }
    }

    fn on(&self, ev: RunEvent) {
        match ev {
            RunEvent::Begin { total, pending } => {
                self.log(&format!(
                    "{} of {total} run(s) to do, {} already done",
                    pending,
                    total - pending
                ));
                let b = indicatif::ProgressBar::new(pending as u64);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "  [{elapsed_precise}] {bar:30} {pos}/{len} runs, ETA {eta} {msg}",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                let _ = self.bar.set(b);
            }
            RunEvent::Shared(what) => {
                if let Some(b) = self.bar.get() {
                    b.set_message(what.chars().take(60).collect::<String>());
                }
                self.log(what);
            }
            RunEvent::Done { line, .. } => {
                crate::interrupt::note_finished();
                self.log(line);
                if let Some(b) = self.bar.get() {
                    b.inc(1);
                    self.line_off_terminal(b);
                }
            }
            RunEvent::Warn(line) => eprintln!("warning: {line}"),
            RunEvent::Interim(dir) => self.log(&format!(
                "summary and report of the rows so far: {}",
                dir.join("report.html").display()
            )),
        }
    }

    /// Off a terminal: one progress line on stderr at most every 10 s.
    fn line_off_terminal(&self, b: &indicatif::ProgressBar) {
        let mut l = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if b.is_hidden() && l.elapsed() >= crate::output::Progress::every() {
            *l = std::time::Instant::now();
            let (pos, len) = (b.position(), b.length().unwrap_or(0));
            let secs = self.start.elapsed().as_secs_f64();
            eprintln!(
                "progress: {pos}/{len} runs, {secs:.0} s elapsed, ETA {:.0} s",
                secs / pos.max(1) as f64 * len.saturating_sub(pos) as f64
            );
        }
    }

    fn finish(&self) {
        if let Some(b) = self.bar.get() {
            b.finish_and_clear();
        }
    }
}

pub fn merge(a: MergeArgs) -> anyhow::Result<ExitCode> {
    let registry = shscale_experiments::registry();
    let opts = runner::MergeOptions {
        replace: a.replace,
        allow_mixed: a.allow_mixed,
        allow_partial: a.allow_partial,
    };
    // Merge and report into a staging folder, moved into the output only when both succeeded:
    // a merge whose report fails (a `summary.md` that is a directory, say) replaces nothing.
    let Some(first) = a.dirs.first() else {
        runner::merge(&a.dirs, a.out.as_deref(), &registry, opts)?;
        bail!("merge: give at least one directory");
    };
    let out = a.out.clone().unwrap_or_else(|| first.join("merged"));
    let target = out.join("runs.csv");
    if target.exists() && !a.replace {
        bail!(
            "{}: exists; merge never overwrites — choose another --out (or --replace)",
            target.display()
        );
    }
    let staging = runner::Staging::new(&out)?;
    let m = runner::merge(&a.dirs, Some(staging.path()), &registry, opts)?;
    let mut staged = runner::report_staged(m.kind, staging.path(), &staging)?;
    staged.files.extend([
        staging.path().join("runs.csv"),
        staging.path().join("manifest.toml"),
    ]);
    let mut r = runner::commit_report(staging, staged)?;
    r.files.retain(|f| {
        f.file_name()
            .is_none_or(|n| n != "runs.csv" && n != "manifest.toml")
    });
    let m = runner::MergeSummary { out, ..m };
    if a.format == crate::args::TextFormat::Json {
        crate::output::print_json(&serde_json::json!({
            "experiment": m.kind.name(),
            "out": m.out.display().to_string(),
            "csv": m.out.join("runs.csv").display().to_string(),
            "files_merged": m.files,
            "rows": m.rows,
            "notes": m.notes,
            "files": r.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        }))?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "merged {} file(s), {} row(s) → {}",
        m.files,
        m.rows,
        m.out.join("runs.csv").display()
    );
    for n in &m.notes {
        eprintln!("warning: {n}");
    }
    for f in &r.files {
        println!("  wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}

pub fn slurm(a: SlurmArgs) -> anyhow::Result<ExitCode> {
    let registry = shscale_experiments::registry();
    let plan = Plan::load(&a.config, &overrides(&a.overrides), &registry)?;
    let opts = SlurmOptions {
        time: a.time,
        mem: a.mem,
        partition: a.partition,
        cpus_per_task: a.cpus_per_task,
        account: a.account,
        array_parallel: a.array_parallel,
        dependency: a.dependency,
    };
    let script = runner::slurm_script(&a.config, &plan, a.tasks, &a.binary, &a.out_dir, &opts)?;
    if a.tasks > plan.runs.len() {
        eprintln!(
            "notice: --tasks {} is more than the plan's {} run(s); the array has {} task(s)",
            a.tasks,
            plan.runs.len(),
            plan.runs.len().max(1)
        );
    }
    print!("{script}");
    Ok(ExitCode::SUCCESS)
}

/// The kind of a results directory, from its manifest.
fn kind_of_dir(dir: &std::path::Path) -> anyhow::Result<&'static dyn shscale_runner::DynKind> {
    Ok(shscale_experiments::kind_of_dir(dir)?)
}

pub fn report(dir: &std::path::Path) -> anyhow::Result<ExitCode> {
    let kind = kind_of_dir(dir)?;
    let r = runner::report(kind, dir)?;
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}

pub fn compare(
    a: &std::path::Path,
    b: &std::path::Path,
    out: Option<&std::path::Path>,
    json: bool,
) -> anyhow::Result<ExitCode> {
    let (ka, kb) = (kind_of_dir(a)?, kind_of_dir(b)?);
    if ka.name() != kb.name() {
        bail!(
            "{} holds {} results and {} holds {}: compare needs one kind",
            a.display(),
            ka.name(),
            b.display(),
            kb.name()
        );
    }
    let name = |p: &std::path::Path| {
        p.file_name()
            .map_or("results".to_string(), |n| n.to_string_lossy().to_string())
    };
    let out = out.map(std::path::Path::to_path_buf).unwrap_or_else(|| {
        a.parent()
            .unwrap_or(std::path::Path::new("."))
            .join(format!("compare_{}_vs_{}", name(a), name(b)))
    });
    let c = shscale_runner::compare::compare(ka, a, b, &out)?;
    if json {
        crate::output::print_json(&serde_json::json!({
            "experiment": ka.name(),
            "a": a.display().to_string(),
            "b": b.display().to_string(),
            "out": out.display().to_string(),
            "markdown": c.markdown,
            "files": c.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        }))?;
        return Ok(ExitCode::SUCCESS);
    }
    print!("{}", c.markdown);
    for f in &c.files {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}

pub fn plot(f: crate::args::PlotArgs) -> anyhow::Result<ExitCode> {
    let (dir, metric, x) = (f.dir.as_path(), f.metric.as_str(), f.x.as_str());
    let filters: Vec<(String, String)> = (f.filters.iter())
        .map(|w| match w.split_once('=') {
            Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
            _ => Err(anyhow::anyhow!(
                "--where {w}: expected COLUMN=VALUE, e.g. --where radius=0.5"
            )),
        })
        .collect::<anyhow::Result<_>>()?;
    let kind = kind_of_dir(dir)?;
    let t = shscale_runner::records::Results::read(&dir.join("runs.csv"))?;
    let log_y = if f.log_y {
        Some(true)
    } else if f.linear_y {
        Some(false)
    } else {
        None
    };
    let keys = shscale_runner::kind::row_keys(kind);
    let spec = shscale_present::column_plot::PlotSpec {
        metric,
        x,
        series: &f.series,
        facet: f.facet.as_deref(),
        filters: &filters,
        log_y,
        log_x: f.log_x,
        stem: None,
        title: None,
    };
    let files = shscale_present::column_plot::plot_column(dir, &t, &keys, &spec)?;
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}
