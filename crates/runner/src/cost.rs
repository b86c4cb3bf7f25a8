//! A plan's estimated cost — rays, peak bytes, seconds with the runner's own bookkeeping — and
//! the `--dry-run` survey that finds it for plans of up to 10⁷ runs without keeping them: runs
//! are resolved one at a time (in parallel chunks) and folded into a [`Tally`] that keeps a few
//! numbers per group and per run id (to count groups and find duplicates), never a run.

use crate::error::Error;
use crate::kind::Resolved;
use crate::timing::{self, Procedure};
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

/// A plan's estimated cost.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    pub runs: usize,
    pub groups: usize,
    pub rays: f64,
    /// The largest group's peak bytes.
    pub bytes: f64,
    /// Seconds on the development VM: the work (every time column's warm-up and repeats) and
    /// the runner's bookkeeping.
    pub seconds: f64,
    /// Of [`Estimate::seconds`], the runner's own ([`timing::BOOKKEEPING_SECONDS_PER_RUN`]).
    pub bookkeeping_seconds: f64,
    pub max_group_rays: f64,
    pub rays_driver: String,
    pub bytes_driver: String,
}

impl Estimate {
    /// Refuse work beyond the documented limits (`file` names the plan) unless `allow_large`.
    pub fn check_limits(&self, file: &str, allow_large: bool) -> Result<(), Error> {
        if allow_large {
            return Ok(());
        }
        if self.rays > timing::MAX_PLAN_RAYS {
            return Err(Error::Config(format!(
                "{file}: the plan would trace an estimated {:.2e} rays, more than the limit {:.0e} (largest group: {}); reduce it or pass --allow-large",
                self.rays, timing::MAX_PLAN_RAYS, self.rays_driver
            )));
        }
        if self.bytes > timing::MAX_PLAN_BYTES {
            return Err(Error::Config(format!(
                "{file}: a group of the plan would hold an estimated {:.1} GiB, more than the limit 8 GiB ({}); reduce it or pass --allow-large",
                self.bytes / (1u64 << 30) as f64,
                self.bytes_driver
            )));
        }
        Ok(())
    }
}

/// Runs folded one at a time into what the estimate needs: per group its shared cost (counted
/// once), per run id the first run with it, the largest group's drivers, the first runs.
#[derive(Default)]
pub(crate) struct Tally {
    runs: usize,
    rays: f64,
    seconds: f64,
    once_seconds: f64,
    /// Group key hash → the group's shared rays, timed seconds and once seconds.
    groups: HashMap<u64, (f64, f64, f64)>,
    /// Cache key hash → the seconds of the work runs share through it ([`Cost::cached_once`]).
    cached: HashMap<u64, f64>,
    bytes: f64,
    bytes_driver: (usize, String),
    max_group_rays: f64,
    rays_driver: (usize, String),
    /// Run id → the index of the first combination resolving to it.
    ids: HashMap<u64, usize>,
    /// The first two combinations found to resolve to one run.
    duplicate: Option<(usize, usize)>,
    /// The first [`FIRST_RUNS`] runs: index, id, canonical parameters.
    pub(crate) first: Vec<(usize, String, String)>,
}

/// How many runs the dry run lists.
pub const FIRST_RUNS: usize = 20;

/// A stable 64-bit hash (the same in every process and chunk).
fn key_hash(s: &str) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    s.hash(&mut h);
    h.finish()
}

/// A larger `(value, driver)` wins; between equals, the earlier run (so the result does not
/// depend on how the runs were split into chunks).
fn keep_max(best: &mut f64, driver: &mut (usize, String), v: f64, d: (usize, &str)) {
    if v > *best || (v == *best && d.0 < driver.0 && !driver.1.is_empty()) {
        *best = v;
        *driver = (d.0, d.1.to_string());
    }
}

impl Tally {
    /// Fold in run `i`.
    pub(crate) fn add(&mut self, i: usize, r: &Resolved) {
        self.runs += 1;
        self.rays += r.cost.rays;
        self.seconds += r.cost.seconds;
        self.once_seconds += r.cost.once_seconds;
        if let Some((key, seconds)) = &r.cost.cached_once {
            self.cached.entry(key_hash(key)).or_insert(*seconds);
        }
        let s = &r.shared_cost;
        self.groups
            .entry(key_hash(&r.group))
            .or_insert((s.rays, s.seconds, s.once_seconds));
        let (bytes, rays) = (s.bytes + r.cost.bytes, s.rays);
        keep_max(
            &mut self.bytes,
            &mut self.bytes_driver,
            bytes,
            (i, &s.drivers),
        );
        keep_max(
            &mut self.max_group_rays,
            &mut self.rays_driver,
            rays,
            (i, &s.drivers),
        );
        let id = u64::from_str_radix(&r.id, 16).unwrap_or_else(|_| key_hash(&r.id));
        if let Some(&j) = self.ids.get(&id) {
            self.note_duplicate(j.min(i), j.max(i));
        } else {
            self.ids.insert(id, i);
        }
        if i < FIRST_RUNS {
            self.first.push((i, r.id.clone(), r.canonical.clone()));
        }
    }

    fn note_duplicate(&mut self, j: usize, i: usize) {
        if self.duplicate.is_none_or(|(_, b)| i < b) {
            self.duplicate = Some((j, i));
        }
    }

    /// Both tallies in one.
    pub(crate) fn merge(mut self, o: Tally) -> Tally {
        self.runs += o.runs;
        self.rays += o.rays;
        self.seconds += o.seconds;
        self.once_seconds += o.once_seconds;
        for (g, c) in o.groups {
            self.groups.entry(g).or_insert(c);
        }
        for (k, c) in o.cached {
            self.cached.entry(k).or_insert(c);
        }
        keep_max(
            &mut self.bytes,
            &mut self.bytes_driver,
            o.bytes,
            (o.bytes_driver.0, &o.bytes_driver.1),
        );
        keep_max(
            &mut self.max_group_rays,
            &mut self.rays_driver,
            o.max_group_rays,
            (o.rays_driver.0, &o.rays_driver.1),
        );
        if let Some((j, i)) = o.duplicate {
            self.note_duplicate(j, i);
        }
        for (id, i) in o.ids {
            match self.ids.get(&id) {
                Some(&j) => self.note_duplicate(j.min(i), j.max(i)),
                None => {
                    self.ids.insert(id, i);
                }
            }
        }
        self.first.extend(o.first);
        self.first.sort_by_key(|f| f.0);
        self
    }

    /// The first two combinations that resolve to one run, if any.
    pub(crate) fn duplicate(&self) -> Option<(usize, usize)> {
        self.duplicate
    }

    /// The estimate, every time column timed with `timing`'s warm-up and repeats; in this
    /// machine's seconds when its speed was measured ([`timing::set_machine_speed`]), else the
    /// development VM's.
    pub(crate) fn estimate(&self, timing: Procedure) -> Estimate {
        let speed = timing::machine_speed().unwrap_or(1.0);
        let factor = (timing.warmup + timing.repeats) as f64;
        let (shared_rays, shared_seconds, shared_once) = (self.groups.values())
            .fold((0.0, 0.0, 0.0), |(r, s, o), (gr, gs, go)| {
                (r + gr, s + gs, o + go)
            });
        let bookkeeping =
            self.runs as f64 * timing::BOOKKEEPING_SECONDS_PER_RUN + timing::PLAN_OVERHEAD_SECONDS;
        Estimate {
            runs: self.runs,
            groups: self.groups.len(),
            rays: self.rays + shared_rays,
            bytes: self.bytes,
            seconds: ((self.seconds + shared_seconds) * factor
                + self.once_seconds
                + shared_once
                + self.cached.values().sum::<f64>()
                + bookkeeping)
                / speed,
            bookkeeping_seconds: bookkeeping / speed,
            max_group_rays: self.max_group_rays,
            rays_driver: self.rays_driver.1.clone(),
            bytes_driver: self.bytes_driver.1.clone(),
        }
    }
}
