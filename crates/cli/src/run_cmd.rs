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
    if shard.is_none() {
        // Plot against the first sweep axis that is numeric, else against the probe radius.
        let numeric = [
            "order",
            "hemisphere_res",
            "k_count",
            "alpha_deg",
            "sampling_radius",
            "on_surface_eps",
        ];
        let param = plan
            .swept
            .iter()
            .find(|k| numeric.contains(&k.as_str()))
            .map(String::as_str)
            .unwrap_or("radius");
        for f in shscale_lab::plots::probe_plots(&s.dir, param)? {
            println!("  plot {}", f.display());
        }
        summary_table(&s.csv)?;
    }
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

/// Mean occ_rel_l2 per run and radius, as a small table on stdout.
fn summary_table(csv: &std::path::Path) -> anyhow::Result<()> {
    let t = shscale_lab::plots::Table::read(csv)?;
    println!(
        "  {:<18} {:>10} {:>8} {:>8} {:>16}",
        "run_id", "alpha_deg", "order", "radius", "occ_rel_l2_mean"
    );
    for r in 0..t.rows.len() {
        println!(
            "  {:<18} {:>10} {:>8} {:>8} {:>16.4}",
            t.rows[r][0],
            t.num(r, "alpha_deg"),
            t.num(r, "order"),
            t.num(r, "radius"),
            t.num(r, "occ_rel_l2_mean")
        );
    }
    Ok(())
}
