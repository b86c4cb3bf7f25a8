//! The experiment runner: executes a [`Plan`]'s runs and writes one tidy CSV row per run and
//! probe radius to `<out>/<experiment>/<name>/runs.csv`, plus `manifest.toml` (the config text,
//! machine, date, revision).
//!
//! Each run also writes `visibility_<run_id>.exr/.png`: truth vs extrapolated visibility at one
//! probe per radius (the papers' Fig. 5).
//!
//! Resumable and crash-safe: finished runs are recognised by their run id in the existing CSV and
//! skipped; after every run the whole CSV is rewritten to a temporary file and renamed into place,
//! so a process killed at any moment (SIGKILL included) leaves either the previous or the new file
//! — never a partial row. `shard = (i, n)` runs the runs whose index ≡ i (mod n), deterministically,
//! into `runs.shard-i-of-n.csv`.

use crate::experiment::{Plan, ProbeParams};
use crate::LabError;
use rayon::prelude::*;
use shscale_field::probe::{base_key, probe_base, probe_with, ProbeBase, ProbeSpec};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{AnalyticSphere, MeshBvh, Occluder, Sphere};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// CSV columns (DESIGN.md §6 metric names).
pub const COLUMNS: &[&str] = &[
    "run_id",
    "experiment",
    "mesh",
    "order",
    "alpha_deg",
    "layout",
    "hemisphere_res",
    "sampling_radius",
    "k_count",
    "k_spacing",
    "k_interp",
    "on_surface_eps",
    "radius",
    "k",
    "probes",
    "inside_count",
    "unoccluded_truth_count",
    "clamped_count",
    "vis_rel_l2_mean",
    "vis_rel_l2_max",
    "occ_rel_l2_mean",
    "occ_rel_l2_max",
    "on_surface_count",
    "vis_rel_l2_on_surface_mean",
    "occ_rel_l2_on_surface_mean",
    "occ_rel_l2_on_surface_max",
    "bsv_sampling_seconds",
    "table_build_seconds",
    "extrapolation_seconds",
    "truth_seconds",
    "device",
    "threads",
    "gpu_bsv_sampling_seconds",
    "gpu_sh_conversion_seconds",
    "gpu_device",
    "git_revision",
];

/// Progress of [`run_plan`], for a progress bar or a log.
#[derive(Clone, Copy, Debug)]
pub enum RunEvent<'a> {
    /// Runs in this shard, and how many of them still have to run.
    Begin { total: usize, pending: usize },
    /// A shared computation (BSV and truth of a group of runs) starts.
    Shared(&'a str),
    /// A run finished (its rows are on disk).
    Done(&'a str),
}

/// What a runner invocation did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub dir: PathBuf,
    pub csv: PathBuf,
    pub in_shard: usize,
    pub already_done: usize,
    pub ran: usize,
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> LabError {
    LabError::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

/// Write `text` to `path` through a temporary file and a rename.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), LabError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    std::fs::write(&tmp, text).map_err(|e| io_err(path, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}

fn git_revision() -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into())
}

/// The occluder of a run, its closed-form sphere (analytic) or its mesh.
type RunOccluder = (
    Box<dyn Occluder>,
    Option<Sphere>,
    Option<shscale_geometry::Mesh>,
);

fn occluder_for(mesh: &str) -> Result<RunOccluder, LabError> {
    if mesh == "sphere" {
        let s = AnalyticSphere::unit();
        return Ok((Box::new(s), Some(s.sphere), None));
    }
    // Procedural, bundled or a file; placed in the unit sphere (results are in units of r).
    let m = crate::render::placed_mesh(mesh, glam::DVec3::ZERO, 1.0, false)?;
    Ok((
        Box::new(MeshBvh::build(&m, UpdateStrategy::Rebuild)),
        None,
        Some(m),
    ))
}

/// GPU BSV timing of a run (median of 5 frames), where the GPU path applies: a mesh (the
/// analytic sphere has no triangles) and `N ≤ 8`; empty cells otherwise.
fn gpu_columns(
    gpu: Option<&shscale_gpu::GpuContext>,
    p: &ProbeParams,
    mesh: Option<&shscale_geometry::Mesh>,
) -> Result<[String; 3], LabError> {
    let (Some(ctx), Some(m)) = (gpu, mesh) else {
        return Ok(Default::default());
    };
    if p.order > shscale_gpu::MAX_GPU_ORDER {
        return Ok(Default::default());
    }
    let b = m.bounding_sphere();
    let sphere = Sphere {
        center: b.center,
        radius: b.radius * p.sampling_radius,
    };
    let t = crate::gpu_path::time_gpu_bsv(ctx, m, p.layout, p.order, p.hemisphere_res, sphere, 5)?;
    Ok([
        t.sampling_seconds.to_string(),
        t.conversion_seconds.to_string(),
        t.device,
    ])
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

/// The papers' Fig. 5 for one run: per probe radius (rows), the ray-traced full-frequency
/// visibility (left) and the extrapolated band-limited visibility (right) at one probe point,
/// lat-long maps in the entity frame (row 0 = +z), written as EXR + PNG.
pub fn visibility_figure(
    dir: &Path,
    run_id: &str,
    order: usize,
    occ: &dyn Occluder,
    examples: &[shscale_field::probe::ProbeExample],
) -> Result<(), LabError> {
    const W: usize = 256;
    const H: usize = 128;
    if examples.is_empty() {
        return Ok(());
    }
    let basis =
        shscale_sh::ShBasis::<f64>::new(order).map_err(|e| LabError::Config(e.to_string()))?;
    let set = shscale_sh::DirectionSet::latlong(H, W);
    let mut px = vec![[0f32; 3]; 2 * W * H * examples.len()];
    let mut y = vec![0.0; order * order];
    for (row, ex) in examples.iter().enumerate() {
        let truth = shscale_field::truth::visibility_map(occ, ex.point, W, H);
        for j in 0..H {
            for i in 0..W {
                let base = (row * H + j) * 2 * W;
                let t = truth[j * W + i];
                px[base + i] = [t; 3];
                basis.eval(set.dirs[j * W + i], &mut y);
                let v: f64 = ex.extrapolated.iter().zip(&y).map(|(a, b)| a * b).sum();
                px[base + W + i] = [v as f32; 3];
            }
        }
    }
    let exr = dir.join(format!("visibility_{run_id}.exr"));
    crate::io::write_exr(&exr, 2 * W, H * examples.len(), &px)?;
    crate::io::write_png_unit(&exr.with_extension("png"), 2 * W, H * examples.len(), &px)
}

fn spec_of(p: &ProbeParams) -> ProbeSpec {
    ProbeSpec {
        order: p.order,
        alpha: p.alpha_deg.to_radians(),
        layout: p.layout,
        hemisphere_res: p.hemisphere_res,
        sampling_radius: p.sampling_radius,
        radii: p.radii.clone(),
        k_count: p.k_count,
        k_spacing: p.k_spacing,
        k_interp: p.k_interp,
        on_surface_eps: p.on_surface_eps,
    }
}

/// What runs sharing a mesh and a [`base_key`] share: the occluder, the BSV and truth, and the
/// GPU BSV timing (which depends on the same parameters).
struct Shared {
    occ: Box<dyn Occluder>,
    base: ProbeBase,
    gpu: [String; 3],
}

fn run_rows(
    p: &ProbeParams,
    experiment: &str,
    rev: &str,
    dir: &Path,
    shared: &Shared,
) -> Result<Vec<String>, LabError> {
    let res = probe_with(&shared.base, &spec_of(p))?;
    visibility_figure(
        dir,
        &p.run_id(),
        p.order,
        shared.occ.as_ref(),
        &res.examples,
    )?;
    let threads = rayon::current_num_threads();
    let [gpu_sampling, gpu_conversion, gpu_device] = &shared.gpu;
    Ok(res
        .rows
        .iter()
        .map(|r| {
            [
                p.run_id(),
                experiment.to_string(),
                p.mesh.clone(),
                p.order.to_string(),
                p.alpha_deg.to_string(),
                p.layout.name(),
                p.hemisphere_res.to_string(),
                p.sampling_radius.to_string(),
                p.k_count.to_string(),
                p.k_spacing_name().to_string(),
                p.k_interp_name().to_string(),
                p.on_surface_eps.to_string(),
                r.radius.to_string(),
                r.k.to_string(),
                r.probes.to_string(),
                r.inside_count.to_string(),
                r.unoccluded_truth_count.to_string(),
                r.clamped_count.to_string(),
                fmt_opt(r.vis_rel_l2_mean),
                fmt_opt(r.vis_rel_l2_max),
                fmt_opt(r.occ_rel_l2_mean),
                fmt_opt(r.occ_rel_l2_max),
                r.on_surface_count.to_string(),
                fmt_opt(r.vis_rel_l2_on_surface_mean),
                fmt_opt(r.occ_rel_l2_on_surface_mean),
                fmt_opt(r.occ_rel_l2_on_surface_max),
                res.bsv_sampling_seconds.to_string(),
                res.table_build_seconds.to_string(),
                r.extrapolation_seconds.to_string(),
                r.truth_seconds.to_string(),
                "cpu".to_string(),
                threads.to_string(),
                gpu_sampling.clone(),
                gpu_conversion.clone(),
                gpu_device.clone(),
                rev.to_string(),
            ]
            .into_iter()
            .map(|c| {
                if c.contains(',') || c.contains('"') {
                    format!("\"{}\"", c.replace('"', "\"\""))
                } else {
                    c
                }
            })
            .collect::<Vec<_>>()
            .join(",")
        })
        .collect())
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
    let dir = out_root.join(&plan.experiment).join(&plan.name);
    std::fs::create_dir_all(&dir).map_err(|e| io_err(&dir, e))?;
    let csv = match shard {
        Some((i, n)) => dir.join(format!("runs.shard-{i}-of-{n}.csv")),
        None => dir.join("runs.csv"),
    };
    let rev = git_revision();
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let gpu = crate::gpu_path::open_gpu(plan.gpu)?;
    let gpu_device = gpu.as_ref().map_or("none".to_string(), |c| c.describe());
    let manifest = format!(
        "# shscale run manifest\nconfig_file = {:?}\nexperiment = {:?}\nname = {:?}\nruns = {}\ngit_revision = {:?}\nunix_time = {now}\nos = {:?}\narch = {:?}\nthreads = {}\nparallel_runs = {}\ngpu = {:?}\ngpu_device = {gpu_device:?}\n\n[config]\ntext = '''\n{}'''\n",
        plan.file,
        plan.experiment,
        plan.name,
        plan.runs.len(),
        rev,
        std::env::consts::OS,
        std::env::consts::ARCH,
        rayon::current_num_threads(),
        plan.parallel_runs,
        plan.gpu.name(),
        plan.text
    );
    write_atomic(&dir.join("manifest.toml"), &manifest)?;
    let header = COLUMNS.join(",");
    // A run killed mid-write leaves at most a `.runs….tmp-PID` file beside the CSV, never a
    // partial row; it is not removed here, since a concurrent shard may own it.
    let mut lines: Vec<String> = Vec::new();
    if csv.exists() {
        let text = std::fs::read_to_string(&csv).map_err(|e| io_err(&csv, e))?;
        let mut it = text.lines();
        if it.next() != Some(header.as_str()) {
            return Err(LabError::Io {
                path: csv.display().to_string(),
                reason: "existing CSV has different columns; refusing to overwrite it".into(),
            });
        }
        lines.extend(it.map(String::from));
    }
    let done: HashSet<String> = lines
        .iter()
        .filter_map(|l| l.split(',').next())
        .map(String::from)
        .collect();
    let mine: Vec<&ProbeParams> = plan
        .runs
        .iter()
        .enumerate()
        .filter(|(i, _)| shard.is_none_or(|(s, n)| i % n == s))
        .map(|(_, r)| r)
        .collect();
    let mut summary = RunSummary {
        dir: dir.clone(),
        csv: csv.clone(),
        in_shard: mine.len(),
        already_done: 0,
        ran: 0,
    };
    // Runs already in the CSV are skipped; the rest are grouped by what they can share (mesh and
    // base key: BSV, truth, GPU timing), each group's shared part computed once, then its runs
    // executed in parallel on rayon's one pool (their own inner parallel loops join the same
    // pool, so nothing is oversubscribed). Every finished run rewrites the CSV atomically, rows
    // in plan order, so a kill at any moment loses no finished run and leaves no partial row.
    let order: HashMap<String, usize> = plan
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| (r.run_id(), i))
        .collect();
    let pending: Vec<&ProbeParams> = mine
        .iter()
        .copied()
        .filter(|r| !done.contains(&r.run_id()))
        .collect();
    summary.already_done = mine.len() - pending.len();
    progress(RunEvent::Begin {
        total: mine.len(),
        pending: pending.len(),
    });
    let mut groups: Vec<(String, Vec<&ProbeParams>)> = Vec::new();
    for r in &pending {
        let key = format!("mesh={};{}", r.mesh, base_key(&spec_of(r)));
        match groups.iter_mut().find(|g| g.0 == key) {
            Some(g) => g.1.push(r),
            None => groups.push((key, vec![r])),
        }
    }
    let state = std::sync::Mutex::new((lines, 0usize));
    let write = |rows: Vec<String>| -> Result<(), LabError> {
        let mut st = state.lock().unwrap_or_else(|e| e.into_inner());
        st.0.extend(rows);
        let rank = |l: &String| {
            l.split(',')
                .next()
                .and_then(|id| order.get(id))
                .copied()
                .unwrap_or(usize::MAX)
        };
        // Stable: rows of one run keep their radius order.
        st.0.sort_by_key(rank);
        let mut text = header.clone();
        text.push('\n');
        for l in &st.0 {
            text.push_str(l);
            text.push('\n');
        }
        write_atomic(&csv, &text)?;
        st.1 += 1;
        Ok(())
    };
    for (_, runs) in &groups {
        let first = runs[0];
        progress(RunEvent::Shared(&format!(
            "BSV + truth for {} run(s) sharing mesh {} {}",
            runs.len(),
            first.mesh,
            base_key(&spec_of(first))
        )));
        let (occ, analytic, mesh) = occluder_for(&first.mesh)?;
        let base = probe_base(occ.as_ref(), analytic, &spec_of(first))?;
        let gpu_cols = gpu_columns(gpu.as_ref(), first, mesh.as_ref())?;
        let shared = Shared {
            occ,
            base,
            gpu: gpu_cols,
        };
        let run_one = |run: &&ProbeParams| -> Result<(), LabError> {
            let t0 = Instant::now();
            let rows = run_rows(run, &plan.experiment, &rev, &dir, &shared)?;
            write(rows)?;
            progress(RunEvent::Done(&format!(
                "{} {} in {:.2} s",
                run.run_id(),
                run.canonical(),
                t0.elapsed().as_secs_f64()
            )));
            Ok(())
        };
        if plan.parallel_runs {
            runs.par_iter().try_for_each(run_one)?;
        } else {
            runs.iter().try_for_each(run_one)?;
        }
    }
    summary.ran = state.lock().unwrap_or_else(|e| e.into_inner()).1;
    Ok(summary)
}

/// Merge shard CSVs (`runs*.csv` found directly in each of `dirs`) into `<dirs[0]>/runs.csv`:
/// rows keyed by run id (and radius) are deduplicated, kept in first-seen order; every input must
/// carry exactly [`COLUMNS`]. Written atomically. Returns `(files read, rows written)`.
pub fn merge(dirs: &[PathBuf]) -> Result<(usize, usize), LabError> {
    let first = dirs
        .first()
        .ok_or_else(|| LabError::Config("merge: give at least one directory".into()))?;
    let header = COLUMNS.join(",");
    let out = first.join("runs.csv");
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
                n.starts_with("runs") && n.ends_with(".csv")
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
    let mut seen = HashSet::new();
    let mut rows = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).map_err(|e| io_err(f, e))?;
        let mut it = text.lines();
        if it.next() != Some(header.as_str()) {
            return Err(LabError::Io {
                path: f.display().to_string(),
                reason: "columns differ from this version's runs.csv".into(),
            });
        }
        // Rows are keyed by (run id, probe radius); the radius column is found by name.
        let radius_col = COLUMNS
            .iter()
            .position(|c| *c == "radius")
            .expect("runs.csv has a radius column");
        for l in it {
            let cells: Vec<&str> = l.split(',').collect();
            let key = (
                cells.first().copied().unwrap_or("").to_string(),
                cells.get(radius_col).copied().unwrap_or("").to_string(),
            );
            if seen.insert(key) {
                rows.push(l.to_string());
            }
        }
    }
    let mut text = header;
    text.push('\n');
    for r in &rows {
        text.push_str(r);
        text.push('\n');
    }
    write_atomic(&out, &text)?;
    Ok((files.len(), rows.len()))
}

/// A Slurm job-array script that runs `config` in `tasks` shards (one array task each) and then
/// merges them in a dependent job. `binary` is the path of the shscale executable on the cluster.
pub fn slurm_script(
    config: &Path,
    plan: &Plan,
    tasks: usize,
    binary: &str,
    out_root: &Path,
) -> Result<String, LabError> {
    if tasks == 0 {
        return Err(LabError::Config("slurm: --tasks must be ≥ 1".into()));
    }
    let dir = out_root.join(&plan.experiment).join(&plan.name);
    Ok(format!(
        r#"#!/usr/bin/env bash
# Generated by `shscale slurm`: {runs} run(s) of {cfg} in {tasks} shard(s), then a merge.
# Submit with:  bash THIS_SCRIPT   (it calls sbatch twice)
set -euo pipefail
CONFIG={cfg:?}
OUT={out:?}
BIN={bin:?}
DIR={dir:?}
mkdir -p "$OUT"
array_job=$(sbatch --parsable --array=0-{last} --job-name=shscale-{name} --output="$OUT/slurm-%A_%a.log" \
  --wrap "\"$BIN\" run \"$CONFIG\" --out-dir \"$OUT\" --shard \$SLURM_ARRAY_TASK_ID/{tasks}")
sbatch --dependency=afterok:"$array_job" --job-name=shscale-{name}-merge --output="$OUT/slurm-merge-%j.log" \
  --wrap "\"$BIN\" merge \"$DIR\""
echo "submitted array job $array_job ({tasks} tasks) and its merge"
"#,
        runs = plan.runs.len(),
        cfg = config.display().to_string(),
        tasks = tasks,
        last = tasks - 1,
        name = plan.name,
        out = out_root.display().to_string(),
        bin = binary,
        dir = dir.display().to_string(),
    ))
}
