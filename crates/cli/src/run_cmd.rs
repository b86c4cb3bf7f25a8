//! `shscale run`: execute an experiment config.

use crate::args::{MergeArgs, RunArgs, SlurmArgs};
use anyhow::{bail, Context};
use shscale_lab::experiment::Plan;
use shscale_lab::runner::{run_plan, RunEvent};
use std::process::ExitCode;

pub fn run(a: RunArgs) -> anyhow::Result<ExitCode> {
    let Some(config) = a.config else {
        eprintln!("shscale run CONFIG: give an experiment config, e.g. `shscale run configs/probe_alpha_sweep.toml` (see configs/README.md)");
        return Ok(ExitCode::from(2));
    };
    let shard = match a.shard.as_deref() {
        None => None,
        Some(s) => {
            let (i, n) = s
                .split_once('/')
                .context("--shard: expected I/N, e.g. 0/4")?;
            let (i, n): (usize, usize) = (
                i.trim().parse().context("--shard: I is not a number")?,
                n.trim().parse().context("--shard: N is not a number")?,
            );
            if n == 0 || i >= n {
                bail!("--shard: {i}/{n} needs 0 ≤ I < N");
            }
            Some((i, n))
        }
    };
    // Studies (experiment kinds of the experiments crate) run whole; sweeps go to the runner.
    if let Some(kind) = study_kind(&config) {
        if shard.is_some() {
            bail!("--shard: {kind} studies run whole (seconds); only probe sweeps shard");
        }
        let ctx = shscale_lab::gpu_path::open_gpu(shscale_lab::gpu_path::GpuMode::Auto)?;
        println!("{}: study {kind:?}", config.display());
        let (dir, summary) = shscale_experiments::run_study(&config, &a.out_dir, ctx.as_ref())?;
        println!("{summary}");
        println!("wrote {}", dir.display());
        return Ok(ExitCode::SUCCESS);
    }
    let plan = Plan::load(&config)?;
    println!(
        "{}: experiment {:?}, {} run(s){}",
        config.display(),
        plan.experiment,
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
    })?;
    if let Some(b) = bar.get() {
        b.finish_and_clear();
    }
    println!(
        "ran {}, skipped {} already done, of {} in this shard → {}",
        s.ran,
        s.already_done,
        s.in_shard,
        s.csv.display()
    );
    if shard.is_none() {
        for f in shscale_lab::plots::probe_plots(&s.dir, &plan.swept)? {
            println!("  plot {}", f.display());
        }
        summary_table(&s.csv, &plan.swept)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The experiment kind of a config when it is a study of the experiments crate (not `probe`).
fn study_kind(config: &std::path::Path) -> Option<String> {
    let text = std::fs::read_to_string(config).ok()?;
    let table: toml::Table = toml::from_str(&text).ok()?;
    let kind = table.get("experiment")?.as_str()?;
    (kind != "probe" && shscale_experiments::KINDS.contains(&kind)).then(|| kind.to_string())
}

pub fn merge(a: MergeArgs) -> anyhow::Result<ExitCode> {
    let (files, rows) = shscale_lab::runner::merge(&a.dirs)?;
    println!(
        "merged {files} file(s), {rows} row(s) → {}",
        a.dirs[0].join("runs.csv").display()
    );
    Ok(ExitCode::SUCCESS)
}

pub fn slurm(a: SlurmArgs) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(&a.config)?;
    print!(
        "{}",
        shscale_lab::runner::slurm_script(&a.config, &plan, a.tasks, &a.binary, &a.out_dir)?
    );
    Ok(ExitCode::SUCCESS)
}

/// One line per run: its swept parameters, the mean `occ_rel_l2` at each probe radius and the
/// run's time (BSV + table + extrapolation), on stdout.
fn summary_table(csv: &std::path::Path, swept: &[String]) -> anyhow::Result<()> {
    let t = shscale_lab::plots::Table::read(csv)?;
    let col = |name: &str| t.columns.iter().position(|c| c == name);
    let mut radii: Vec<f64> = (0..t.rows.len()).map(|r| t.num(r, "radius")).collect();
    radii.sort_by(f64::total_cmp);
    radii.dedup();
    let mut runs: Vec<String> = Vec::new();
    for r in &t.rows {
        if !runs.contains(&r[0]) {
            runs.push(r[0].clone());
        }
    }
    let mut head = format!("  {:<17}", "run_id");
    for k in swept {
        head.push_str(&format!(" {k:>15}"));
    }
    for rho in &radii {
        head.push_str(&format!(" {:>9}", format!("occ@{rho}r")));
    }
    head.push_str(&format!(" {:>9}", "time_ms"));
    println!("  occ_rel_l2 (mean over base-sphere samples) per probe radius:");
    println!("{head}");
    for id in &runs {
        let rows: Vec<usize> = (0..t.rows.len()).filter(|&r| &t.rows[r][0] == id).collect();
        let mut line = format!("  {id:<17}");
        for k in swept {
            let v = col(k).map_or(String::new(), |c| t.rows[rows[0]][c].clone());
            line.push_str(&format!(" {v:>15}"));
        }
        for rho in &radii {
            let v = rows
                .iter()
                .find(|&&r| t.num(r, "radius") == *rho)
                .map_or(f64::NAN, |&r| t.num(r, "occ_rel_l2_mean"));
            line.push_str(&format!(" {v:>9.4}"));
        }
        let time: f64 = t.num(rows[0], "bsv_sampling_seconds")
            + t.num(rows[0], "table_build_seconds")
            + rows
                .iter()
                .map(|&r| t.num(r, "extrapolation_seconds"))
                .sum::<f64>();
        line.push_str(&format!(" {:>9.1}", time * 1e3));
        println!("{line}");
    }
    Ok(())
}
