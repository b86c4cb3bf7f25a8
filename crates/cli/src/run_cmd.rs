//! `shscale run`, `merge`, `slurm`: experiments through the one runner (`shscale_lab::exp`).

use crate::args::{MergeArgs, OverrideArgs, RunArgs, SlurmArgs};
use anyhow::{bail, Context};
use shscale_lab::exp::config::Overrides;
use shscale_lab::exp::runner::{self, run_plan, Plan, RunEvent, SlurmOptions};
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
    let registry = shscale_experiments::registry();
    let plan = Plan::load(&config, &overrides(&a.overrides), &registry)?;
    if a.dry_run {
        print!("{}", plan.describe(shard));
        plan.check_limits(a.allow_large)?;
        return Ok(ExitCode::SUCCESS);
    }
    plan.check_limits(a.allow_large)?;
    println!(
        "{}: experiment {:?}, {} run(s){}",
        config.display(),
        plan.kind.name(),
        plan.runs.len(),
        shard
            .map(|(i, n)| format!(", shard {i}/{n}"))
            .unwrap_or_default()
    );
    // A progress bar with ETA over the pending runs (drawn on stderr only when it is a
    // terminal); every finished run is also logged as a line on stdout.
    let bar: std::sync::OnceLock<indicatif::ProgressBar> = std::sync::OnceLock::new();
    let log = |line: &str| match bar.get() {
        Some(b) if !b.is_hidden() => b.println(format!("  {line}")),
        _ => println!("  {line}"),
    };
    let s = run_plan(&plan, &a.out_dir, shard, &|ev| match ev {
        RunEvent::Begin { total, pending } => {
            log(&format!(
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
            let _ = bar.set(b);
        }
        RunEvent::Shared(what) => {
            if let Some(b) = bar.get() {
                b.set_message(what.chars().take(60).collect::<String>());
            }
            log(what);
        }
        RunEvent::Done(line) => {
            log(line);
            if let Some(b) = bar.get() {
                b.inc(1);
            }
        }
        RunEvent::Warn(line) => eprintln!("warning: {line}"),
    })?;
    if let Some(b) = bar.get() {
        b.finish_and_clear();
    }
    println!(
        "ran {}, skipped {} already done ({} redone after invalid rows), of {} in this shard → {}",
        s.ran,
        s.already_done,
        s.redone,
        s.in_shard,
        s.csv.display()
    );
    if shard.is_none() {
        let r = runner::report(plan.kind, &s.dir)?;
        for f in &r.files {
            println!("  wrote {}", f.display());
        }
        println!("{}", r.summary);
    }
    Ok(ExitCode::SUCCESS)
}

pub fn merge(a: MergeArgs) -> anyhow::Result<ExitCode> {
    let registry = shscale_experiments::registry();
    let m = runner::merge(&a.dirs, a.out.as_deref(), &registry)?;
    println!(
        "merged {} file(s), {} row(s) → {}",
        m.files,
        m.rows,
        m.out.join("runs.csv").display()
    );
    let r = runner::report(m.kind, &m.out)?;
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
    };
    print!(
        "{}",
        runner::slurm_script(&a.config, &plan, a.tasks, &a.binary, &a.out_dir, &opts)?
    );
    Ok(ExitCode::SUCCESS)
}

/// The kind of a results directory, from its manifest.
fn kind_of_dir(dir: &std::path::Path) -> anyhow::Result<&'static dyn shscale_lab::exp::DynKind> {
    let m = runner::Manifest::read(dir)?.with_context(|| {
        format!(
            "{}: no manifest.toml (not a results directory of shscale run)",
            dir.display()
        )
    })?;
    shscale_experiments::registry()
        .into_iter()
        .find(|k| k.name() == m.experiment)
        .with_context(|| {
            format!(
                "{}: experiment {:?} is not a kind of this shscale",
                dir.join("manifest.toml").display(),
                m.experiment
            )
        })
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
    let c = shscale_lab::exp::report::compare(ka, a, b, &out)?;
    print!("{}", c.markdown);
    for f in &c.files {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}

pub fn plot(
    dir: &std::path::Path,
    metric: &str,
    x: &str,
    series: Option<&str>,
    log_y: bool,
    linear_y: bool,
) -> anyhow::Result<ExitCode> {
    let kind = kind_of_dir(dir)?;
    let t = shscale_lab::exp::records::Results::read(&dir.join("runs.csv"))?;
    let log = if log_y {
        Some(true)
    } else if linear_y {
        Some(false)
    } else {
        None
    };
    let files =
        shscale_lab::plots::plot_column(dir, &t, &kind.param_columns(), metric, x, series, log)
            .map_err(|e| anyhow::anyhow!("{}", e.to_string().replace("Config(", "")))?;
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}
