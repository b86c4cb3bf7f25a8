//! Plans: a config with overrides resolved against the registry of kinds into validated runs with
//! ids, their estimated cost (checked against the limits) and the results directory.

use crate::config::{self, ConfigError, Overrides, Place};
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
}

/// `name`: letters, digits, `.`, `_`, `-`; not empty, not `.` or `..`.
pub fn check_name(name: &str) -> Result<(), String> {
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
    Error::Config(e.to_string())
}

/// The kind of a config text (its `experiment` key), without resolving it.
pub fn kind_of(text: &str) -> Option<String> {
    let t: toml::Table = toml::from_str(text).ok()?;
    t.get("experiment")?.as_str().map(String::from)
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

/// Every combination resolved by `kind` into a run; two combinations of one run are an error.
fn resolve_runs(
    file: &str,
    kind: &dyn DynKind,
    ex: &config::Expanded,
) -> Result<Vec<Resolved>, Error> {
    use rayon::prelude::*;
    // Resolved in parallel (a plan of 10⁵ runs spends seconds here), checked in order: the
    // first bad combination is the one reported.
    let resolved: Vec<Result<Resolved, ConfigError>> = (ex.combinations.par_iter())
        .map(|c| kind.resolve(ex, c))
        .collect();
    let runs: Vec<Resolved> = resolved
        .into_iter()
        .collect::<Result<_, _>>()
        .map_err(cfg)?;
    let mut ids = HashMap::with_capacity(runs.len());
    for (i, r) in runs.iter().enumerate() {
        if let Some(j) = ids.insert(r.id.as_str(), i) {
            return Err(Error::Config(format!(
                "{file}: sweep: combinations {} and {} resolve to the same run ({})",
                j + 1,
                i + 1,
                r.canonical
            )));
        }
    }
    Ok(runs)
}

impl Plan {
    /// Read and resolve a config file with overrides against the registry of kinds.
    pub fn load(
        path: &Path,
        ov: &Overrides,
        registry: &[&'static dyn DynKind],
    ) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "experiment".into());
        Self::parse(&path.display().to_string(), &stem, &text, ov, registry)
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
        let timing = timing_of(&ex, &at_key)?;
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

    /// The plan's estimated cost: total rays and seconds, the largest group's bytes.
    pub fn estimate(&self) -> Estimate {
        let mut e = Estimate {
            runs: self.runs.len(),
            ..Default::default()
        };
        for g in self.groups() {
            e.groups += 1;
            let first = &self.runs[g[0]];
            let mut bytes = first.shared_cost.bytes;
            e.rays += first.shared_cost.rays;
            e.seconds += first.shared_cost.seconds * self.timing_factor();
            for &i in &g {
                let c = &self.runs[i].cost;
                e.rays += c.rays;
                e.seconds += c.seconds * self.timing_factor();
                bytes = bytes.max(first.shared_cost.bytes + c.bytes);
            }
            if bytes > e.bytes {
                e.bytes = bytes;
                e.bytes_driver = first.shared_cost.drivers.clone();
            }
            if first.shared_cost.rays > e.max_group_rays {
                e.max_group_rays = first.shared_cost.rays;
                e.rays_driver = first.shared_cost.drivers.clone();
            }
        }
        e
    }

    fn timing_factor(&self) -> f64 {
        (self.timing.warmup + self.timing.repeats) as f64
    }

    /// Refuse plans beyond the documented limits unless `allow_large`.
    pub fn check_limits(&self, allow_large: bool) -> Result<(), Error> {
        if allow_large {
            return Ok(());
        }
        let e = self.estimate();
        if e.rays > timing::MAX_PLAN_RAYS {
            return Err(Error::Config(format!(
                "{}: the plan would trace an estimated {:.2e} rays, more than the limit {:.0e} (largest group: {}); reduce it or pass --allow-large",
                self.file, e.rays, timing::MAX_PLAN_RAYS, e.rays_driver
            )));
        }
        if e.bytes > timing::MAX_PLAN_BYTES {
            return Err(Error::Config(format!(
                "{}: a group of the plan would hold an estimated {:.1} GiB, more than the limit 8 GiB ({}); reduce it or pass --allow-large",
                self.file,
                e.bytes / (1u64 << 30) as f64,
                e.bytes_driver
            )));
        }
        Ok(())
    }

    /// The dry-run description: runs, groups, estimates.
    pub fn describe(&self, shard: Option<(usize, usize)>) -> String {
        let e = self.estimate();
        let mut s = format!(
            "plan {:?} of kind {:?} from {}{}\n  {} run(s) in {} group(s) sharing work{}\n  estimated: {:.3e} rays, {:.1} MiB peak, {:.1} s on the development VM ({} warm-up + {} timed repeat(s) each)\n",
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
                (0..self.runs.len()).filter(|j| j % n == i).count()
            )),
            e.rays,
            e.bytes / (1u64 << 20) as f64,
            e.seconds,
            self.timing.warmup,
            self.timing.repeats,
        );
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
        for (i, r) in self.runs.iter().enumerate().take(20) {
            s.push_str(&format!("  run {i:>3} {} {}\n", r.id, r.canonical));
        }
        if self.runs.len() > 20 {
            s.push_str(&format!("  … and {} more\n", self.runs.len() - 20));
        }
        s.push_str("  (dry run: nothing written)\n");
        s
    }
}

/// A plan's estimated cost.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    pub runs: usize,
    pub groups: usize,
    pub rays: f64,
    pub bytes: f64,
    pub seconds: f64,
    pub max_group_rays: f64,
    pub rays_driver: String,
    pub bytes_driver: String,
}

/// The results directory of a plan.
pub fn plan_dir(plan: &Plan, out_root: &Path) -> PathBuf {
    out_root.join(plan.kind.name()).join(&plan.name)
}
