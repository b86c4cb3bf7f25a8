//! Plans: a config with overrides resolved against the registry of kinds into validated runs with
//! ids, their estimated cost (checked against the limits, [`crate::cost`]) and the results
//! directory; and the survey of a plan for `--dry-run`, which resolves the runs one at a time
//! and keeps only the estimate.

use crate::config::{self, ConfigError, Overrides, Place};
use crate::cost::{Estimate, Tally};
use crate::device::GpuMode;
use crate::error::Error;
use crate::kind::{DynKind, Resolved};
use crate::timing::{self, Procedure};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A resolved plan.
pub struct Plan {
    pub kind: &'static dyn DynKind,
    pub file: String,
    pub name: String,
    pub text: String,
    pub overrides: Vec<String>,
    /// Swept keys, in expansion order.
    pub axes: Vec<String>,
    pub runs: Vec<Resolved>,
    pub gpu: GpuMode,
    pub parallel_runs: bool,
    pub timing: Procedure,
    /// How often a long unsharded plan writes the summary, plots and report of its rows so far
    /// while it runs ([`INTERIM_REPORT`]; `None`: only when it ends).
    pub interim_report: Option<std::time::Duration>,
    /// What a run does with stale rows of this plan ([`StalePolicy`]; the `--stale` flag).
    pub stale: StalePolicy,
}

/// What a run does with rows of its plan that are stale: computed by another numerical code
/// than this binary's, or from inputs whose content has changed since (docs/provenance.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StalePolicy {
    /// Set the stale rows aside into `<csv>.stale` (valid CSV, restorable) and run those runs
    /// again: the default, so a results folder holds the current code's numbers for the
    /// current inputs.
    #[default]
    Rerun,
    /// Stop before any work, naming the stale runs and both ways on (`--stale rerun`, or
    /// another `--name`).
    Refuse,
}

shscale_names::names!(StalePolicy { Rerun = "rerun", Refuse = "refuse" });

impl StalePolicy {
    /// `rerun` or `refuse` (the `--stale` flag).
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| format!("--stale {s:?}: expected rerun or refuse"))
    }
}

/// How often a long plan writes its summary and report while it runs, so a reader can follow:
/// never per run, and about every 30 s.
pub const INTERIM_REPORT: std::time::Duration = std::time::Duration::from_secs(30);

/// `name`: letters, digits, `.`, `_`, `-`; not empty, not `.` or `..`.
pub(crate) fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty() || name == "." || name == ".." || name.len() > 128 {
        return Err(format!(
            "{name:?} must be 1 to 128 characters and not . or .."
        ));
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-')))
    {
        return Err(format!(
            "{name:?} contains {c:?}: a name is letters, digits, '.', '_' and '-' (no path separators)"
        ));
    }
    Ok(())
}

fn cfg(e: ConfigError) -> Error {
    Error::Place(e)
}

/// The timing procedure of the config's `timing_warmup` and `timing_repeats`, within their limits.
fn timing_of(
    ex: &config::Expanded,
    at_key: &dyn Fn(&'static str) -> Box<dyn FnOnce(String) -> ConfigError>,
) -> Result<Procedure, Error> {
    let mut timing = Procedure::default();
    if let Some(w) = ex.runner.timing_warmup {
        timing.warmup = w;
    }
    if let Some(r) = ex.runner.timing_repeats {
        timing.repeats = r;
    }
    if timing.warmup > timing::MAX_REPEATS {
        return Err(cfg(at_key("timing_warmup")(format!(
            "{} is more than the limit {}",
            timing.warmup,
            timing::MAX_REPEATS
        ))));
    }
    if !(1..=timing::MAX_REPEATS).contains(&timing.repeats) {
        return Err(cfg(at_key("timing_repeats")(format!(
            "{} is outside 1..={}",
            timing.repeats,
            timing::MAX_REPEATS
        ))));
    }
    Ok(timing)
}

/// The most runs one plan holds and runs (its runs are resolved and kept in memory, ≈ 2.4 kB
/// each at 10⁵); `--dry-run` surveys plans up to [`config::MAX_COMBINATIONS`] without keeping
/// them ([`survey`]).
pub const MAX_RUNS: usize = 100_000;

/// Every combination resolved by `kind` into a run; two combinations of one run are an error.
fn resolve_runs(
    file: &str,
    kind: &dyn DynKind,
    ex: &config::Expanded,
) -> Result<Vec<Resolved>, Error> {
    use rayon::prelude::*;
    if ex.len() > MAX_RUNS {
        return Err(Error::Config(format!(
            "{file}: sweep: the plan has {} runs, more than the limit {MAX_RUNS} one plan runs; split the sweep into several configs (or [[sweep]] blocks run as separate names), and see its cost with --dry-run",
            ex.len()
        )));
    }
    // Resolved in parallel (a plan of 10⁵ runs spends seconds here), checked in order: the
    // first bad combination is the one reported.
    let resolved: Vec<Result<Resolved, ConfigError>> = (0..ex.len())
        .into_par_iter()
        .map(|i| kind.resolve(ex, &ex.combination(i)?))
        .collect();
    let runs: Vec<Resolved> = resolved
        .into_iter()
        .collect::<Result<_, _>>()
        .map_err(cfg)?;
    let mut ids = HashMap::with_capacity(runs.len());
    for (i, r) in runs.iter().enumerate() {
        if let Some(j) = ids.insert(r.id.as_str(), i) {
            return Err(Error::Config(format!(
                "{file}: sweep: combinations {} and {} resolve to the same run ({}){}",
                ex.describe_combination(j),
                ex.describe_combination(i),
                r.canonical,
                same_run_hint(ex)
            )));
        }
    }
    Ok(runs)
}

/// The way out of two combinations of one run: the overrides that made them alike, if any.
fn same_run_hint(ex: &config::Expanded) -> String {
    let flags: Vec<String> = (ex.set_places.iter())
        .filter_map(|(_, p)| match p {
            config::Place::Flag(f) if f.starts_with("--set") => Some(f.clone()),
            _ => None,
        })
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    if flags.is_empty() {
        "; make the blocks differ in a parameter, or drop the run from one of them".into()
    } else {
        format!(
            "; {} set the same value in every block, making them alike — narrow the config to the blocks you want (a config of its own)",
            flags.join(", ")
        )
    }
}

/// What a plan takes from the runner's keys: its kind, name, `gpu` setting and timing.
struct Head {
    kind: &'static dyn DynKind,
    name: String,
    gpu: GpuMode,
    timing: Procedure,
}

impl Head {
    /// The runner's keys of `ex` resolved against `registry`, errors at their places.
    fn of(
        file: &str,
        stem: &str,
        ex: &config::Expanded,
        registry: &[&'static dyn DynKind],
    ) -> Result<Self, Error> {
        let at_key = |key: &'static str| {
            let p = config::parse_path(key);
            let place = ex
                .set_places
                .iter()
                .find(|(sp, _)| p.starts_with(sp))
                .map(|(_, pl)| pl.clone())
                .unwrap_or_else(|| match ex.source.line_of(&p) {
                    Some((line, _)) => Place::Line {
                        file: file.into(),
                        line,
                    },
                    None => Place::File(file.into()),
                });
            Box::new(move |message: String| ConfigError {
                place,
                key: key.into(),
                message,
            }) as Box<dyn FnOnce(String) -> ConfigError>
        };
        let kind = *registry
            .iter()
            .find(|k| k.name() == ex.runner.experiment)
            .ok_or_else(|| {
                cfg(at_key("experiment")(format!(
                    "{:?} is not a known experiment kind (one of {})",
                    ex.runner.experiment,
                    registry
                        .iter()
                        .map(|k| k.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                )))
            })?;
        let name = ex.runner.name.clone().unwrap_or_else(|| stem.to_string());
        check_name(&name).map_err(|m| cfg(at_key("name")(m)))?;
        let gpu = match ex.runner.gpu.as_deref() {
            None => GpuMode::Auto,
            Some(g) => GpuMode::parse(g).map_err(|m| cfg(at_key("gpu")(m)))?,
        };
        let timing = timing_of(ex, &at_key)?;
        Ok(Self {
            kind,
            name,
            gpu,
            timing,
        })
    }
}

impl Plan {
    /// Read and resolve a config file with overrides against the registry of kinds.
    pub fn load(
        path: &Path,
        ov: &Overrides,
        registry: &[&'static dyn DynKind],
    ) -> Result<Self, Error> {
        let (file, stem, text) = read_config(path)?;
        Self::parse(&file, &stem, &text, ov, registry)
    }

    /// Resolve config text (`file` names it in errors; `stem` is the default name).
    pub fn parse(
        file: &str,
        stem: &str,
        text: &str,
        ov: &Overrides,
        registry: &[&'static dyn DynKind],
    ) -> Result<Self, Error> {
        let ex = config::expand(file, text, ov).map_err(cfg)?;
        let Head {
            kind,
            name,
            gpu,
            timing,
        } = Head::of(file, stem, &ex, registry)?;
        let runs = resolve_runs(file, kind, &ex)?;
        Ok(Self {
            kind,
            file: file.into(),
            name,
            text: text.into(),
            overrides: ov.flags(),
            axes: ex.axes.clone(),
            runs,
            gpu,
            parallel_runs: ex.runner.parallel_runs.unwrap_or(true),
            timing,
            interim_report: Some(INTERIM_REPORT),
            stale: StalePolicy::default(),
        })
    }

    /// Groups of run indices sharing work, in plan order (of their first run); linear in the
    /// runs.
    pub fn groups(&self) -> Vec<Vec<usize>> {
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut slot: HashMap<&str, usize> = HashMap::new();
        for (i, r) in self.runs.iter().enumerate() {
            let g = *slot.entry(r.group.as_str()).or_insert_with(|| {
                groups.push(Vec::new());
                groups.len() - 1
            });
            groups[g].push(i);
        }
        groups
    }

    /// The plan's estimated cost: total rays and seconds (bookkeeping included), the largest
    /// group's bytes.
    pub fn estimate(&self) -> Estimate {
        self.tally().estimate(self.timing)
    }

    /// Every run folded into the estimate's tally.
    fn tally(&self) -> Tally {
        let mut t = Tally::default();
        for (i, r) in self.runs.iter().enumerate() {
            t.add(i, r);
        }
        t
    }

    /// Refuse plans beyond the documented limits unless `allow_large`.
    pub fn check_limits(&self, allow_large: bool) -> Result<(), Error> {
        self.estimate().check_limits(&self.file, allow_large)
    }

    /// The dry-run description: runs, groups, estimates.
    pub fn describe(&self, shard: Option<(usize, usize)>) -> String {
        let t = self.tally();
        Survey {
            kind: self.kind,
            file: self.file.clone(),
            name: self.name.clone(),
            overrides: self.overrides.clone(),
            axes: self.axes.clone(),
            timing: self.timing,
            estimate: t.estimate(self.timing),
            first: t.first,
        }
        .describe(shard)
    }
}

/// A plan surveyed for `--dry-run` without keeping its runs ([`survey`]).
pub struct Survey {
    pub kind: &'static dyn DynKind,
    pub file: String,
    pub name: String,
    pub overrides: Vec<String>,
    pub axes: Vec<String>,
    pub timing: Procedure,
    pub estimate: Estimate,
    /// The first runs: index, id, canonical parameters.
    pub first: Vec<(usize, String, String)>,
}

/// A config file's name (for errors), stem (the default plan name) and text.
fn read_config(path: &Path) -> Result<(String, String, String), Error> {
    let text = shscale_files::input::read_regular_string(path)?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "experiment".into());
    Ok((path.display().to_string(), stem, text))
}

/// [`survey`] of a config file.
pub fn survey_file(
    path: &Path,
    ov: &Overrides,
    registry: &[&'static dyn DynKind],
) -> Result<Survey, Error> {
    let (file, stem, text) = read_config(path)?;
    survey(&file, &stem, &text, ov, registry)
}

/// Resolve config text as [`Plan::parse`] does, run by run, keeping only the estimate: memory
/// independent of the runs but for a few numbers per group and run id, so plans of up to
/// [`config::MAX_COMBINATIONS`] runs are surveyed in bounded memory (10⁶ `sparsity` runs:
/// 4.0 s and 150 MB on the development VM; a plan over [`MAX_RUNS`] is surveyed, not run). The same errors as [`Plan::parse`]: the first bad combination, two
/// combinations of one run.
pub fn survey(
    file: &str,
    stem: &str,
    text: &str,
    ov: &Overrides,
    registry: &[&'static dyn DynKind],
) -> Result<Survey, Error> {
    use rayon::prelude::*;
    let ex = config::expand(file, text, ov).map_err(cfg)?;
    let head = Head::of(file, stem, &ex, registry)?;
    const CHUNK: usize = 4096;
    let chunks = ex.len().div_ceil(CHUNK);
    let tallies: Vec<Result<Tally, ConfigError>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut t = Tally::default();
            for i in c * CHUNK..((c + 1) * CHUNK).min(ex.len()) {
                t.add(i, &head.kind.resolve(&ex, &ex.combination(i)?)?);
            }
            Ok(t)
        })
        .collect();
    let mut all = Tally::default();
    for t in tallies {
        all = all.merge(t.map_err(cfg)?);
    }
    if let Some((j, i)) = all.duplicate() {
        return Err(Error::Config(format!(
            "{file}: sweep: combinations {} and {} resolve to the same run{}",
            ex.describe_combination(j),
            ex.describe_combination(i),
            same_run_hint(&ex)
        )));
    }
    Ok(Survey {
        kind: head.kind,
        file: file.into(),
        name: head.name,
        overrides: ov.flags(),
        axes: ex.axes.clone(),
        timing: head.timing,
        estimate: all.estimate(head.timing),
        first: all.first,
    })
}

impl Survey {
    /// The dry-run description: runs, groups, estimates, the first runs.
    pub fn describe(&self, shard: Option<(usize, usize)>) -> String {
        let e = &self.estimate;
        let mut s = format!(
            "plan {:?} of kind {:?} from {}{}\n  {} run(s) in {} group(s) sharing work{}\n  estimated: {:.3e} rays, {:.1} MiB peak, {} ({} warm-up + {} timed repeat(s) each; {:.1} s of it the runner's bookkeeping)\n",
            self.name,
            self.kind.name(),
            self.file,
            if self.overrides.is_empty() {
                String::new()
            } else {
                format!(" with {}", self.overrides.join(" "))
            },
            e.runs,
            e.groups,
            shard.map_or(String::new(), |(i, n)| format!(
                "; shard {i}/{n} holds {}",
                e.runs / n + usize::from(i < e.runs % n)
            )),
            e.rays,
            e.bytes / (1u64 << 20) as f64,
            if e.seconds.is_nan() {
                "time not estimated (a run's cost depends on a file read when it runs)".to_string()
            } else {
                let on = match timing::machine_speed() {
                    Some(k) => {
                        format!("on this machine (at {k:.2}× the development VM's ray rate)")
                    }
                    None => "on the development VM".to_string(),
                };
                if e.seconds < 10.0 {
                    format!("{:.2} s {on}", e.seconds)
                } else {
                    format!("{:.1} s {on}", e.seconds)
                }
            },
            self.timing.warmup,
            self.timing.repeats,
            e.bookkeeping_seconds,
        );
        if let Some(w) = timing::calibration_warning() {
            s.push_str(&format!("  warning: {w}\n"));
        }
        if !e.rays_driver.is_empty() {
            s.push_str(&format!("  largest group: {}\n", e.rays_driver));
        }
        s.push_str(&format!(
            "  swept: {}\n",
            if self.axes.is_empty() {
                "nothing".to_string()
            } else {
                self.axes.join(", ")
            }
        ));
        for (i, id, canonical) in &self.first {
            s.push_str(&format!("  run {i:>3} {id} {canonical}\n"));
        }
        if e.runs > self.first.len() {
            s.push_str(&format!("  … and {} more\n", e.runs - self.first.len()));
        }
        if e.runs > MAX_RUNS {
            s.push_str(&format!(
                "  note: more than the {MAX_RUNS} runs one plan runs; split the sweep into several configs to run it\n"
            ));
        }
        s.push_str("  (dry run: nothing written)\n");
        s
    }
}

/// The results directory of a plan.
pub fn plan_dir(plan: &Plan, out_root: &Path) -> PathBuf {
    out_root.join(plan.kind.name()).join(&plan.name)
}
