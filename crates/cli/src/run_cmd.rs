//! `shscale run`: execute an experiment config.

use crate::args::{MergeArgs, RunArgs, SlurmArgs};
use anyhow::{bail, Context};
use shscale_lab::experiment::Plan;
use shscale_lab::runner::run_plan;
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
    let s = run_plan(&plan, &a.out_dir, shard, |line| println!("  {line}"))?;
    println!(
        "ran {}, skipped {} already done, of {} in this shard → {}",
        s.ran,
        s.already_done,
        s.in_shard,
        s.csv.display()
    );
    Ok(ExitCode::SUCCESS)
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
