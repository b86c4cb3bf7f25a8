//! The seam between the runner and an experiment kind ([`Kind`]) and its type-erased form
//! ([`DynKind`], made by [`Erased`]) that the registry lists.
//!
//! A kind is one type implementing [`Kind`]: its parameters (one struct, serde; the config's
//! keys with their defaults, unknown keys rejected), what runs of a group share, its output row
//! (one struct, serde: the CSV columns derive from it) and its report. A new parameter is one
//! field of the parameter struct; every field can be a `[sweep]` axis without further code
//! ([`crate::config`]). A new kind is one file plus one line in the registry
//! (`shscale_experiments::registry`). The recipe is in `docs/ARCHITECTURE.md`.

use crate::device::{Device, GpuMode};
use crate::error::Error;
use crate::{config, records, timing};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::any::Any;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A parameter problem found by [`Kind::resolve`]: the key (dotted path) and what is wrong.
#[derive(Clone, Debug)]
pub struct KeyError {
    pub key: String,
    pub message: String,
}

impl KeyError {
    pub fn new(key: &str, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }
}

/// Estimated cost of one run (or of a group's shared work), for `--dry-run` and the limits.
#[derive(Clone, Debug, Default)]
pub struct Cost {
    /// Rays traced.
    pub rays: f64,
    /// Peak bytes held.
    pub bytes: f64,
    /// Seconds of the timed work on this machine (from the measured rates in [`timing`]), for
    /// one call: the estimate multiplies them by the timing procedure's warm-up + repeats.
    pub seconds: f64,
    /// Seconds of the work done once whatever the timing procedure — references and truths,
    /// untimed set-up, image writing.
    pub once_seconds: f64,
    /// The keys that drive the cost, in words (`hemisphere_res = 256 → 131072 rays per probe`).
    pub drivers: String,
    /// Seconds of work shared through a cache by every run naming the same key (a one-off fit
    /// of a mesh that several runs reuse): counted once per distinct key in the plan.
    pub cached_once: Option<(String, f64)>,
}

/// What a kind's work sees of the runner.
pub struct Ctx<'a> {
    /// The results directory (per-run images go here).
    pub dir: &'a Path,
    /// The folder of the config file: scene paths in parameters are relative to it (mesh paths of
    /// the probe kinds are read relative to the working directory).
    pub config_dir: &'a Path,
    /// The device the kind opened ([`Kind::open_device`]) under the config's `gpu` setting.
    pub device: Option<&'a Device>,
    /// The timing procedure every time column uses.
    pub timing: timing::Procedure,
    /// Set by the caller to stop the plan: no run starts after it is set
    /// ([`crate::run_plan_until`]).
    pub stop: &'a std::sync::atomic::AtomicBool,
}

/// A kind's parameters together with what was parsed from them at resolve time (the enums of
/// its enum-like values); it derefs to the parameters, so the work reads `p.order` as before and
/// `p.typed` for the parsed values.
pub struct Typed<P, T> {
    pub params: P,
    pub typed: T,
}

impl<P, T> std::ops::Deref for Typed<P, T> {
    type Target = P;
    fn deref(&self) -> &P {
        &self.params
    }
}

/// One experiment kind. See the module documentation.
pub trait Kind: Send + Sync + 'static {
    /// `experiment = "…"` in a config.
    const NAME: &'static str;
    /// The question the kind answers, in words (the summary's heading).
    const QUESTION: &'static str;
    /// One run's parameters: `#[serde(deny_unknown_fields, default)]`, flat (every field one
    /// CSV cell; lists through [`records::list`]), `Default` = the documented defaults.
    type Params: Serialize + DeserializeOwned + Default + Clone + Send + Sync + 'static;
    /// What runs of one group share (computed once per group).
    type Shared: Send + Sync;
    /// One output row (flat, like the parameters).
    type Row: Serialize + DeserializeOwned + Default + Send;
    /// The kind's errors: its own work's, converted into the runner's [`Error`] at the seam.
    type Error: Into<Error>;
    /// One run's parameters as its work uses them, resolved once before anything runs:
    /// enum-like values parsed into their enums ([`Typed`]: the parameters with what was parsed
    /// from them), or the parameters themselves for a kind without any.
    type Spec: Send + Sync + 'static;

    /// Check one run's parameters (bounds included) and resolve them, before anything runs;
    /// the work sees only the result.
    fn resolve(p: &Self::Params) -> Result<Self::Spec, KeyError>;
    /// [`Kind::resolve`] where the parameters name files (a scene) relative to `config_dir`, the
    /// config file's folder: the checks that need those files happen here, at plan time (so
    /// `--dry-run` makes them), before any work. Rows read back from a CSV are resolved by
    /// [`Kind::resolve`]. Default: [`Kind::resolve`].
    fn resolve_in(p: &Self::Params, config_dir: &Path) -> Result<Self::Spec, KeyError> {
        let _ = config_dir;
        Self::resolve(p)
    }
    /// Every file one run reads and every bundled asset it reads by name
    /// ([`crate::inputs::Input`]): hashed by content at plan time, their hashes identify the
    /// run's rows with its parameters and the numerical fingerprint, so editing a file re-runs
    /// exactly the runs that read it (docs/provenance.md). Paths as the run opens them
    /// (`config_dir`: the config file's folder, for parameters relative to it). A kind that
    /// reads a file it does not declare here has rows that do not know what made them. Default:
    /// none.
    fn inputs(p: &Self::Params, config_dir: &Path) -> Result<Vec<crate::inputs::Input>, KeyError> {
        let _ = (p, config_dir);
        Ok(Vec::new())
    }
    /// Runs with equal keys share one [`Kind::Shared`]. Default: none share.
    fn group_key(p: &Self::Params) -> String {
        records::canonical(p).unwrap_or_default()
    }
    /// The estimated cost of the work of a group (`shared`) and of each run, from the resolved
    /// spec.
    fn cost(p: &Self::Spec) -> (Cost, Cost);
    /// The estimated cost where it depends on files the parameters name (paths relative to
    /// `config_dir`, the config file's folder), e.g. a scene. Default: [`Kind::cost`].
    fn cost_in(p: &Self::Spec, config_dir: &Path) -> (Cost, Cost) {
        let _ = config_dir;
        Self::cost(p)
    }
    /// Rows one run writes (resume treats a run with fewer as unfinished).
    fn rows_per_run(p: &Self::Params) -> usize;
    /// The shared work of a group, from its first run's parameters.
    fn shared(p: &Self::Spec, ctx: &Ctx) -> Result<Self::Shared, Self::Error>;
    /// One run: its rows.
    fn run(
        p: &Self::Spec,
        run_id: &str,
        shared: &Self::Shared,
        ctx: &Ctx,
    ) -> Result<Vec<Self::Row>, Self::Error>;
    /// Open the device the kind's runs time their GPU path on, as the config's `gpu` setting
    /// says (the manifest records its description, `none` without one). Default: none.
    fn open_device(mode: GpuMode) -> Result<Option<Device>, Self::Error> {
        let _ = mode;
        Ok(None)
    }
    /// Whether a run cannot do without the device [`Kind::open_device`] opens (a GPU timing it
    /// was asked for, not one it may skip): with the config's `gpu = "auto"`, a plan holding
    /// such a run opens the device as required, so a machine without one is refused before any
    /// work in one line, not told "continuing with the CPU path" and then failed run by run.
    /// Default: none.
    fn needs_device(p: &Self::Spec) -> bool {
        let _ = p;
        false
    }
    /// The row key and the error metric of the report's "best per key" table (the lowest value of
    /// the metric at each value of the key, with the parameters that gave it). Default: none.
    fn best_of() -> Option<(&'static str, &'static str)> {
        None
    }
    /// Columns of [`Kind::Row`] that hold times (excluded from comparisons of merged results).
    fn time_columns() -> &'static [&'static str] {
        &[]
    }
    /// The headline metric columns shown in the summary table (one per row).
    fn summary_columns() -> &'static [&'static str];
    /// Plots and images of a results directory beyond the summary; the files written.
    fn report(dir: &Path, table: &records::Results) -> Result<Vec<PathBuf>, Self::Error> {
        let _ = (dir, table);
        Ok(Vec::new())
    }
    /// Every parameter key with its meaning, unit and valid range, in words: the config
    /// reference (`shscale config-reference`, `docs/config-reference.md`); a test checks that
    /// every field of [`Kind::Params`] is described.
    fn describe() -> &'static [(&'static str, &'static str)];
    /// Our numbers against the claim the results test, in words (Markdown, computed from the
    /// rows so it never goes stale): appended to `summary.md`, and a figure's section of
    /// `paper-figs/README.md`. Default: nothing.
    fn discussion(table: &records::Results) -> Result<String, Self::Error> {
        let _ = table;
        Ok(String::new())
    }
    /// The answer first: a short table (at most [`MAX_VERDICT_LINES`] lines of Markdown, computed
    /// from the rows) that opens `summary.md` before the long discussion — which method wins
    /// per regime, with the grid it covers. Default: nothing.
    fn verdict(table: &records::Results) -> Result<String, Self::Error> {
        let _ = table;
        Ok(String::new())
    }
    /// The paper figure of the results in `dir`: files written to `out`, named `<stem>.*`
    /// (`shscale figs`). Default: none.
    fn figure(
        dir: &Path,
        table: &records::Results,
        out: &Path,
        stem: &str,
    ) -> Result<Vec<PathBuf>, Self::Error> {
        let _ = (dir, table, out, stem);
        Ok(Vec::new())
    }
}

/// A resolved run, kind-erased.
#[derive(Clone)]
pub struct Resolved {
    pub id: String,
    /// Canonical serialisation of the parameters (the run id's input).
    pub canonical: String,
    /// The parameter cells, in [`DynKind::param_columns`] order.
    pub cells: Vec<String>,
    pub group: String,
    pub shared_cost: Cost,
    pub cost: Cost,
    pub rows: usize,
    /// The inputs the run reads, with their content hashes (empty when resolved from CSV cells).
    pub inputs: Arc<Vec<crate::inputs::Hashed>>,
    /// [`crate::inputs::digest`] of [`Resolved::inputs`]: the rows' `inputs` cell.
    pub inputs_digest: String,
    params: Arc<dyn Any + Send + Sync>,
}

/// Rows of one finished run, handed to the runner: cells in [`DynKind::row_columns`] order.
pub type RowCells = Vec<Vec<String>>;

/// Where [`DynKind::run_group`] hands each finished run: its rows, seconds and contention.
pub type Sink<'a> =
    dyn Fn(&Resolved, RowCells, f64, crate::contention::Reading) -> Result<(), Error> + Sync + 'a;

/// A kind behind a vtable: what the runner needs.
pub trait DynKind: Send + Sync {
    fn name(&self) -> &'static str;
    fn question(&self) -> &'static str;
    fn param_columns(&self) -> Vec<String>;
    fn row_columns(&self) -> Vec<String>;
    fn time_columns(&self) -> &'static [&'static str];
    /// The CSV type of every parameter and row column ([`records::column_types`]).
    fn column_types(&self) -> Vec<(String, String)>;
    fn summary_columns(&self) -> &'static [&'static str];
    /// Deserialise and validate one combination.
    fn resolve(
        &self,
        ex: &config::Expanded,
        combo: &config::Combination,
    ) -> Result<Resolved, config::ConfigError>;
    /// Re-resolve a run from its CSV cells (`headers` and `cells` of the parameter columns),
    /// for validating rows on resume and merge. Errors are reasons, in words.
    fn resolve_cells(&self, headers: &[String], cells: &[String]) -> Result<Resolved, String>;
    /// The run id and rows per run of parameter cells: [`DynKind::resolve_cells`] without the
    /// cost, group and parameters, for validating rows (once per row read on resume and merge).
    fn id_of_cells(&self, headers: &[String], cells: &[String]) -> Result<(String, usize), String>;
    /// Check that row cells have the row struct's types.
    fn check_row(&self, headers: &[String], cells: &[String]) -> Result<(), String>;
    /// Run a group: the shared work once, then every run (in parallel when `parallel`);
    /// `sink` gets each finished run's rows, the seconds it took and how busy the machine was
    /// meanwhile ([`crate::contention`]).
    fn run_group(
        &self,
        runs: &[&Resolved],
        ctx: &Ctx,
        parallel: bool,
        sink: &Sink<'_>,
    ) -> Result<(), Error>;
    fn report(&self, dir: &Path, table: &records::Results) -> Result<Vec<PathBuf>, Error>;
    /// [`Kind::open_device`].
    fn open_device(&self, mode: GpuMode) -> Result<Option<Device>, Error>;
    /// [`Kind::needs_device`] of a resolved run (false for a run of another kind).
    fn needs_device(&self, r: &Resolved) -> bool;
    fn discussion(&self, table: &records::Results) -> Result<String, Error>;
    /// [`Kind::verdict`].
    fn verdict(&self, table: &records::Results) -> Result<String, Error>;
    fn best_of(&self) -> Option<(&'static str, &'static str)>;
    fn describe(&self) -> &'static [(&'static str, &'static str)];
    /// The parameter keys with their default cells (the CSV/TOML form).
    fn defaults(&self) -> Vec<(String, String)>;
    fn figure(
        &self,
        dir: &Path,
        table: &records::Results,
        out: &Path,
        stem: &str,
    ) -> Result<Vec<PathBuf>, Error>;
}

/// The [`DynKind`] of a [`Kind`].
pub struct Erased<K: Kind>(std::marker::PhantomData<K>);

impl<K: Kind> Erased<K> {
    pub const fn new() -> Self {
        Self(std::marker::PhantomData)
    }
}

impl<K: Kind> Default for Erased<K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<K: Kind> Erased<K> {
    /// `config_dir`: the config's folder when resolved from a config (the cost may read files
    /// it names), `None` from CSV cells.
    fn resolved(
        &self,
        p: K::Params,
        spec: K::Spec,
        config_dir: Option<&Path>,
        inputs: Vec<crate::inputs::Hashed>,
    ) -> Result<Resolved, String> {
        let (headers, cells) = records::to_cells(&p)?;
        let canonical = records::canonical_of(&headers, &cells);
        let (shared_cost, cost) = match config_dir {
            Some(d) => K::cost_in(&spec, d),
            None => K::cost(&spec),
        };
        Ok(Resolved {
            id: records::run_id(K::NAME, &canonical),
            canonical,
            cells,
            group: K::group_key(&p),
            shared_cost,
            cost,
            rows: K::rows_per_run(&p),
            inputs_digest: crate::inputs::digest(&inputs),
            inputs: Arc::new(inputs),
            params: Arc::new(spec),
        })
    }
}

fn params_of<K: Kind>(r: &Resolved) -> Result<&K::Spec, Error> {
    r.params
        .downcast_ref::<K::Spec>()
        .ok_or_else(|| Error::Config(format!("run {} is not of kind {}", r.id, K::NAME)))
}

impl<K: Kind> DynKind for Erased<K> {
    fn name(&self) -> &'static str {
        K::NAME
    }
    fn question(&self) -> &'static str {
        K::QUESTION
    }
    fn param_columns(&self) -> Vec<String> {
        records::to_cells(&K::Params::default())
            .map(|(h, _)| h)
            .unwrap_or_default()
    }
    fn row_columns(&self) -> Vec<String> {
        records::to_cells(&K::Row::default())
            .map(|(h, _)| h)
            .unwrap_or_default()
    }
    fn time_columns(&self) -> &'static [&'static str] {
        K::time_columns()
    }
    fn column_types(&self) -> Vec<(String, String)> {
        let mut v = records::column_types::<K::Params>().unwrap_or_default();
        v.extend(records::column_types::<K::Row>().unwrap_or_default());
        v
    }
    fn summary_columns(&self) -> &'static [&'static str] {
        K::summary_columns()
    }
    fn resolve(
        &self,
        ex: &config::Expanded,
        combo: &config::Combination,
    ) -> Result<Resolved, config::ConfigError> {
        let p: K::Params = config::deserialize(ex, combo)?;
        let dir = Path::new(&ex.source.file)
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let spec = K::resolve_in(&p, dir)
            .map_err(|e| ex.error(combo, &config::parse_path(&e.key), e.message))?;
        let at = |key: &str, m: String| ex.error(combo, &config::parse_path(key), m);
        let declared = K::inputs(&p, dir).map_err(|e| at(&e.key, e.message))?;
        let inputs = crate::inputs::hash_all(&declared).map_err(|(k, m)| at(&k, m))?;
        self.resolved(p, spec, Some(dir), inputs)
            .map_err(|m| ex.error(combo, &[], format!("cannot be written as a CSV row: {m}")))
    }
    fn resolve_cells(&self, headers: &[String], cells: &[String]) -> Result<Resolved, String> {
        let p: K::Params = records::from_cells(headers, cells)?;
        let spec = K::resolve(&p).map_err(|e| format!("{}: {}", e.key, e.message))?;
        self.resolved(p, spec, None, Vec::new())
    }
    fn id_of_cells(&self, headers: &[String], cells: &[String]) -> Result<(String, usize), String> {
        let p: K::Params = records::from_cells(headers, cells)?;
        K::resolve(&p).map_err(|e| format!("{}: {}", e.key, e.message))?;
        let (h, c) = records::to_cells(&p)?;
        let id = records::run_id(K::NAME, &records::canonical_of(&h, &c));
        Ok((id, K::rows_per_run(&p)))
    }
    fn check_row(&self, headers: &[String], cells: &[String]) -> Result<(), String> {
        records::from_cells::<K::Row>(headers, cells).map(|_| ())
    }
    fn run_group(
        &self,
        runs: &[&Resolved],
        ctx: &Ctx,
        parallel: bool,
        sink: &Sink<'_>,
    ) -> Result<(), Error> {
        use rayon::prelude::*;
        let Some(first) = runs.first() else {
            return Ok(());
        };
        let shared = K::shared(params_of::<K>(first)?, ctx).map_err(Into::into)?;
        let one = |r: &&Resolved| -> Result<(), Error> {
            if ctx.stop.load(std::sync::atomic::Ordering::Acquire) {
                return Err(Error::Interrupted {
                    done: 0,
                    csv: String::new(),
                });
            }
            let s0 = crate::contention::sample();
            let t0 = std::time::Instant::now();
            let rows = K::run(params_of::<K>(r)?, &r.id, &shared, ctx).map_err(Into::into)?;
            let secs = t0.elapsed().as_secs_f64();
            let busy = crate::contention::since(s0);
            let cells = rows
                .iter()
                .map(|row| records::to_cells(row).map(|(_, c)| c))
                .collect::<Result<Vec<_>, _>>()
                .map_err(Error::Config)?;
            sink(r, cells, secs, busy)
        };
        if parallel {
            runs.par_iter().try_for_each(one)
        } else {
            runs.iter().try_for_each(one)
        }
    }
    fn report(&self, dir: &Path, table: &records::Results) -> Result<Vec<PathBuf>, Error> {
        K::report(dir, table).map_err(Into::into)
    }
    fn open_device(&self, mode: GpuMode) -> Result<Option<Device>, Error> {
        K::open_device(mode).map_err(Into::into)
    }
    fn needs_device(&self, r: &Resolved) -> bool {
        params_of::<K>(r).is_ok_and(K::needs_device)
    }
    fn best_of(&self) -> Option<(&'static str, &'static str)> {
        K::best_of()
    }
    fn discussion(&self, table: &records::Results) -> Result<String, Error> {
        K::discussion(table).map_err(Into::into)
    }
    fn verdict(&self, table: &records::Results) -> Result<String, Error> {
        K::verdict(table).map_err(Into::into)
    }
    fn describe(&self) -> &'static [(&'static str, &'static str)] {
        K::describe()
    }
    fn defaults(&self) -> Vec<(String, String)> {
        records::to_cells(&K::Params::default())
            .map(|(h, c)| h.into_iter().zip(c).collect())
            .unwrap_or_default()
    }
    fn figure(
        &self,
        dir: &Path,
        table: &records::Results,
        out: &Path,
        stem: &str,
    ) -> Result<Vec<PathBuf>, Error> {
        K::figure(dir, table, out, stem).map_err(Into::into)
    }
}

/// The columns that tell a kind's rows apart, for `shscale_present::column_plot::plot_column`: its parameters and its row key
/// (the first headline column, e.g. the probe radius).
pub fn row_keys(kind: &dyn DynKind) -> Vec<String> {
    let mut keys = kind.param_columns();
    if let Some(first) = kind.summary_columns().first() {
        if !keys.iter().any(|k| k == first) {
            keys.push(first.to_string());
        }
    }
    keys
}
