//! The experiment kinds of the runner and the papers' figures, one module per kind, each
//! answering one question (docs/conventions.md §8). Every kind runs through the one runner
//! (`shscale_runner`): run ids, resume, shards, merge, Slurm and a manifest.
//!
//! - [`sparsity`] — Fig. 2: where are the non-zeros of a scaling matrix, and is the pattern
//!   really independent of τ?
//! - [`m_elements`] — Fig. 3: how smoothly do elements of `M_k` vary with k, and how well does a
//!   40-entry table interpolate them?
//! - [`probe`] (pictures in [`probe::figure`]) — Fig. 5 and the accuracy sweeps: extrapolated
//!   vs actual visibility at radii around the sampling sphere.
//! - [`shadows`] — Fig. 7: shadows of the extrapolated field vs a fully sampled shadow field and
//!   ray-traced truth.
//! - [`timing`] — Table 1: per-stage times and FPS of the deforming sequences.
//! - [`srf`], [`midrange`], [`extremes`] — the source-radiance, mid-range-lighting and stability
//!   studies.
//! - [`alpha_fit`] — the best cone angle α at each distance, against 45° and the closed-form law.
//! - [`equal_budget`] — every method of the one vocabulary ([`shscale_scene::method`]) at equal
//!   rays, bytes and time per frame: on spherical receivers (`budget`) and on a scene's
//!   receiver plane in image space against full-frequency truth (`budget_plane`).
//!
//! [`regenerate`] runs every config of a folder (`configs/paper/`) through the runner and writes
//! each kind's figure into an output folder (`paper-figs/`) with the data behind it
//! (`<stem>.csv`) and an index `README.md` with, per figure, the config, the claim, our numbers
//! and the comparison — generated from the rows, so the text never goes stale.

pub mod alpha_fit;
mod common;
pub mod equal_budget;
pub mod extremes;
mod figures;
pub mod m_elements;
pub mod midrange;
pub mod probe;
pub mod shadows;
pub mod sparsity;
pub mod srf;
pub mod timing;

use shscale_runner::config::Overrides;
use shscale_runner::GpuMode;
use shscale_runner::{self as runner, Plan, RunEvent};
use shscale_runner::{DynKind, Erased};
use shscale_scene::Error;
use std::path::{Path, PathBuf};

static PROBE: Erased<crate::probe::Probe> = Erased::new();
static MIDRANGE: Erased<midrange::MidRange> = Erased::new();
static SPARSITY: Erased<sparsity::Sparsity> = Erased::new();
static M_ELEMENTS: Erased<m_elements::MElements> = Erased::new();
static SHADOWS: Erased<shadows::Shadows> = Erased::new();
static TIMING: Erased<timing::Timing> = Erased::new();
static SRF: Erased<srf::Srf> = Erased::new();
static EXTREMES: Erased<extremes::Extremes> = Erased::new();
static ALPHA_FIT: Erased<alpha_fit::AlphaFit> = Erased::new();
static BUDGET: Erased<equal_budget::spheres::Budget> = Erased::new();
static BUDGET_PLANE: Erased<equal_budget::plane::BudgetPlane> = Erased::new();

/// The kind of a results directory, from its `manifest.toml`: an error naming the directory when
/// it has none, or naming the manifest when its experiment is not a kind of this build.
pub fn kind_of_dir(dir: &Path) -> Result<&'static dyn DynKind, Error> {
    let m = shscale_runner::Manifest::read(dir)?.ok_or_else(|| {
        Error::config(format!(
            "{}: no manifest.toml (not a results directory of shscale run)",
            dir.display()
        ))
    })?;
    registry()
        .into_iter()
        .find(|k| k.name() == m.experiment)
        .ok_or_else(|| {
            Error::config(format!(
                "{}: experiment {:?} is not a kind of this shscale",
                dir.join("manifest.toml").display(),
                m.experiment
            ))
        })
}

/// The experiment kinds of the runner (`experiment = "…"`), one line each. A new kind is one
/// file implementing `shscale_runner::Kind` plus one line here.
pub fn registry() -> Vec<&'static dyn DynKind> {
    vec![
        &PROBE,
        &MIDRANGE,
        &SPARSITY,
        &M_ELEMENTS,
        &SHADOWS,
        &TIMING,
        &SRF,
        &EXTREMES,
        &ALPHA_FIT,
        &BUDGET,
        &BUDGET_PLANE,
    ]
}

/// Run every `*.toml` of `configs` (sorted) through the runner — results under `runs_root`,
/// resumed if already there — then write each kind's figure into `out` as `<config stem>.*`
/// with the rows behind it (`<stem>.csv`), and `out/README.md`. `gpu` replaces the configs' own
/// GPU setting. `progress` gets a line per figure. Returns the files written to `out`.
pub fn regenerate(
    configs: &Path,
    out: &Path,
    runs_root: &Path,
    gpu: Option<GpuMode>,
    mut progress: impl FnMut(&str),
) -> Result<Vec<PathBuf>, Error> {
    let io = |p: &Path, e: std::io::Error| Error::io(p, e);
    let (paths, plans) = figure_plans(configs, gpu)?;
    // Every figure goes to a staging folder first and moves into `out` only when all succeeded:
    // a failing figure (or a bad `--runs`) creates and changes nothing there.
    let staging = shscale_runner::Staging::new(out)?;
    let stage = staging.path().to_path_buf();
    let mut index = String::from(
        "# paper-figs/\n\nThe papers' figures, regenerated by `shscale figs` (from `configs/paper/*.toml`, each run through the experiment \
runner; do not edit this file by hand — it is rewritten with the figures). Per figure: the config, the paper's claim, our numbers \
and how they compare, and `<figure>.csv`, the rows behind it. Paper references: Wang et al., *Spherical Harmonics Scaling* (\"SHS\"); \
Zhou et al., *Shadow Fields for Deformable Objects*, MSR-TR-2005-96 (\"TR\").\n\n",
    );
    let mut all = Vec::new();
    for (p, plan) in paths.iter().zip(&plans) {
        let t = std::time::Instant::now();
        let stem = p
            .file_stem()
            .map_or("figure".into(), |s| s.to_string_lossy().to_string());
        let warn = std::sync::Mutex::new(Vec::new());
        let s = runner::run_plan(plan, runs_root, None, &|ev| {
            if let RunEvent::Warn(w) = ev {
                warn.lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .push(w.to_string());
            }
        })?;
        for w in warn.into_inner().unwrap_or_default() {
            progress(&format!("warning: {w}"));
        }
        let report = runner::report(plan.kind, &s.dir)?;
        let table = shscale_runner::records::Results::read(&s.csv)?;
        let mut files = plan.kind.figure(&s.dir, &table, &stage, &stem)?;
        let csv = stage.join(format!("{stem}.csv"));
        let text = std::fs::read_to_string(&s.csv).map_err(|e| io(&s.csv, e))?;
        shscale_runner::write_atomic(&csv, &text)?;
        files.push(csv);
        progress(&format!(
            "{} → {} file(s) in {:.1} s ({} run(s), {} already done)",
            p.display(),
            files.len(),
            t.elapsed().as_secs_f64(),
            s.ran,
            s.already_done
        ));
        index.push_str(&index_section(p, &stem, &s.dir, &report.discussion, &files));
        all.extend(files);
    }
    let readme = stage.join("README.md");
    shscale_runner::write_atomic(&readme, &index)?;
    all.push(readme);
    Ok(staging.commit(&all)?)
}

/// The figure configs of a folder (`*.toml`, sorted) and their plans, every one resolved and
/// checked against the limits before any work: a bad one fails the command with nothing
/// written.
fn figure_plans(configs: &Path, gpu: Option<GpuMode>) -> Result<(Vec<PathBuf>, Vec<Plan>), Error> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(configs)
        .map_err(|e| Error::io(configs, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(Error::config(format!(
            "{}: no *.toml figure configs",
            configs.display()
        )));
    }
    let registry = registry();
    let mut plans = Vec::new();
    for p in &paths {
        let mut plan = Plan::load(p, &Overrides::default(), &registry)?;
        if let Some(g) = gpu {
            plan.gpu = g;
        }
        plan.check_limits(false)?;
        plans.push(plan);
    }
    Ok((paths, plans))
}

/// A figure's section of `paper-figs/README.md`: its title, config, the paper's claim, our
/// discussion (computed from the rows), the files and the picture.
fn index_section(p: &Path, stem: &str, dir: &Path, discussion: &str, files: &[PathBuf]) -> String {
    let mut index = String::new();
    let (title, claim) = runner::title_and_claim(dir);
    let title = title.unwrap_or_else(|| stem.to_string());
    index.push_str(&format!("## {title}\n\nConfig: `{}`\n\n", p.display()));
    if let Some(c) = claim {
        index.push_str(&format!("**Paper.** {}\n\n", c.trim()));
    }
    index.push_str(discussion.trim_end());
    index.push_str("\n\nFiles: ");
    let names: Vec<String> = files
        .iter()
        .filter_map(|x| x.file_name().map(|n| format!("`{}`", n.to_string_lossy())))
        .collect();
    index.push_str(&names.join(", "));
    index.push_str("\n\n");
    if let Some(png) = files
        .iter()
        .find(|x| x.extension().is_some_and(|e| e == "png"))
    {
        index.push_str(&format!(
            "![{title}]({})\n\n",
            png.file_name().unwrap_or_default().to_string_lossy()
        ));
    }
    index
}

#[cfg(test)]
mod tests {
    /// A file that computes rows (`*_rows.rs`) imports nothing from a file the numerical
    /// fingerprint leaves out (a `verdict/` folder, `*_report.rs`, `discussion.rs`, `figure.rs`,
    /// `figures.rs`): a row computed with such code would change without its rows going stale
    /// (the clustered interval of `budget`'s rows once lived in `verdict/stats.rs`).
    #[test]
    fn row_files_import_nothing_the_fingerprint_leaves_out() {
        fn walk(d: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for e in std::fs::read_dir(d).unwrap().flatten() {
                let p = e.path();
                if p.is_dir() {
                    walk(&p, out);
                } else if p.to_string_lossy().ends_with("_rows.rs") {
                    out.push(p);
                }
            }
        }
        let mut files = Vec::new();
        walk(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
            &mut files,
        );
        assert!(files.len() >= 2, "{files:?}");
        let left_out = [
            "verdict::",
            "_report::",
            "discussion::",
            "figure::",
            "figures::",
        ];
        for f in &files {
            let text = std::fs::read_to_string(f).unwrap();
            for line in text.lines().filter(|l| l.trim_start().starts_with("use ")) {
                assert!(
                    !left_out.iter().any(|m| line.contains(m)),
                    "{}: {line}",
                    f.display()
                );
            }
        }
    }

    /// Every column of every kind that holds a time — a duration in seconds or milliseconds,
    /// its spread or its interval's ends, a rate of frames — is one of the kind's time columns
    /// (machine-dependent: the schema marks them, `compare` and the reports treat them apart,
    /// docs/provenance.md), so a time is never read as an accuracy metric.
    #[test]
    fn every_time_column_of_every_kind_is_declared_a_time() {
        let timed = |c: &str| {
            [
                "_seconds",
                "_seconds_lo",
                "_seconds_hi",
                "_spread",
                "_ms",
                "fps",
            ]
            .iter()
            .any(|s| c.ends_with(s))
        };
        let mut missing = Vec::new();
        for kind in super::registry() {
            let times = kind.time_columns();
            for c in shscale_runner::header(kind) {
                if timed(&c) && !times.contains(&c.as_str()) {
                    missing.push(format!("{}.{c}", kind.name()));
                }
            }
        }
        assert!(missing.is_empty(), "times not declared: {missing:?}");
    }
}
