//! The equal-budget verdicts, computed from the rows so they never go stale: configurations
//! (rows equal in every parameter but the seeds), each with its method's typed spec parsed once
//! from its cells; the Pareto front of error against rays; the papers' speed claim as stated;
//! equal accuracy per regime; each configuration named in words from its spec.
//!
//! Its means, intervals and the Pareto front are `super::stats` (counted: rows use them);
//! [`configs`]: rows grouped into
//! configurations and named in words; [`fronts`]: the front plots; [`prose`]: the verdict
//! tables and sentences.

mod configs;
mod fronts;
mod prose;

pub use super::stats::{mean_t95, pareto};
pub(crate) use configs::*;
pub(crate) use fronts::*;
pub(crate) use prose::*;

use serde::de::DeserializeOwned;
use serde::Serialize;
use shscale_field::bsv::RadialRule;
use shscale_field::evaluator::{FieldInterp, ShellSpacing};
use shscale_field::extrapolate::Plausibility;
use shscale_present::plots::{write_panels, write_scatter_noted, Labels, Panel};
use shscale_runner::records::Results;
use shscale_scene::method::{
    Alpha, Combine, Extrapolation, Method, RayTracedSpec, SetSpec, Spec, SphereFit, SubVolumeSpec,
};
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The seed columns of both kinds: a row's replicate (rows of one configuration differ only in
/// these; a kind without one reads it as empty).
pub(crate) const SEED_COLUMNS: [&str; 4] = [
    "probe_seed",
    "truth_seed",
    "orientation_seed",
    "placement_seed",
];

/// A row's seed: its seed columns' cells.
pub(crate) fn seed_of(t: &Results, r: usize) -> String {
    SEED_COLUMNS
        .map(|c| if t.col(c).is_some() { t.cell(r, c) } else { "" })
        .join(";")
}

/// Named point series of a plot.
type Series = BTreeMap<String, Vec<(f64, f64)>>;

/// A front's series per method family ([`family`]), one per variant.
type ByFamily = BTreeMap<&'static str, Series>;

/// A file-name-safe name of a mesh parameter: a bundled name as is, a path by its file stem,
/// every character but letters, digits, `.`, `_` and `-` replaced by `_`.
pub(crate) fn plot_name(mesh: &str) -> String {
    let stem = Path::new(mesh)
        .file_stem()
        .map_or(mesh.to_string(), |s| s.to_string_lossy().into_owned());
    stem.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The distinct pairs of cells `(a, b)` of a table, in order of appearance: the fronts are
/// drawn per pair (per mesh and order on spherical receivers — errors at different orders are
/// against different truths; per scene and frame count on the plane).
pub(crate) fn distinct_pairs(t: &Results, a: &str, b: &str) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = Vec::new();
    for r in 0..t.rows.len() {
        let k = (t.cell(r, a).to_string(), t.cell(r, b).to_string());
        if !v.contains(&k) {
            v.push(k);
        }
    }
    v
}

/// The rows as splits of groups of configurations: one group per distinct pair of cells of the
/// columns `(a, b)` (a mesh and its order, a scene and its frames), its configurations those of
/// [`by_config`] over `keys`; `place(a, b)` names the group's split and the group.
pub(crate) fn splits_by(
    t: &Results,
    (a, b): (&str, &str),
    keys: &[String],
    specs: &[Option<Spec>],
    place: &dyn Fn(&str, &str) -> (String, String),
) -> Vec<Split> {
    let mut splits: Vec<Split> = Vec::new();
    for (x, y) in distinct_pairs(t, a, b) {
        let rows: Vec<usize> = (0..t.rows.len())
            .filter(|&r| t.cell(r, a) == x && t.cell(r, b) == y)
            .collect();
        let configs = by_config(t, &rows, keys, &|r| specs[r]);
        let (label, group) = place(&x, &y);
        Split::add(&mut splits, label, group, configs);
    }
    splits
}
