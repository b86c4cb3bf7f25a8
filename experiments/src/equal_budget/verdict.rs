//! The equal-budget verdicts, computed from the rows so they never go stale: configurations
//! (rows equal in every parameter but the seeds), each with its method's typed spec parsed once
//! from its cells; the Pareto front of error against rays; the papers' speed claim as stated;
//! equal accuracy per regime; each configuration named in words from its spec.

use serde::de::DeserializeOwned;
use serde::Serialize;
use shscale_field::bsv::RadialRule;
use shscale_field::evaluator::{FieldInterp, ShellSpacing};
use shscale_field::extrapolate::Plausibility;
use shscale_runner::plots::{write_panels, write_scatter_noted, Labels, Panel};
use shscale_runner::records::Results;
use shscale_scene::method::{Alpha, Combine, Extrapolation, Method, Spec, SphereFit};
use shscale_scene::Error;
use std::collections::BTreeMap;

/// The seed columns of both kinds: a row's replicate (rows of one configuration differ only in
/// these; a kind without one reads it as empty).
pub const SEED_COLUMNS: [&str; 4] = [
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
use std::path::{Path, PathBuf};

/// Mean and the half-width of its normal 95 % interval, `1.96·s/√n` (s the sample standard
/// deviation; `None` for fewer than 2 values).
pub fn mean_ci95(v: &[f64]) -> (Option<f64>, Option<f64>) {
    let m = shscale_field::metrics::mean_max(v.iter().map(|x| Some(*x))).0;
    let ci = (v.len() >= 2).then(|| {
        let m = m.unwrap_or(0.0);
        let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
        1.96 * (var / v.len() as f64).sqrt()
    });
    (m, ci)
}

/// Student's t quantile t_{0.975, df} for df = 1..=30 (beyond: 1.96 is within 4 %).
const T975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];

/// Mean of `v` and the half-width of its 95 % Student-t interval (`None` below 2 values).
pub fn mean_t95(v: &[f64]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let ci = (v.len() >= 2).then(|| {
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
        let t = T975.get(v.len() - 2).copied().unwrap_or(1.96);
        t * (var / n).sqrt()
    });
    (Some(m), ci)
}

/// Mean of `(cluster, value)` pairs and the half-width of its 95 % interval clustered by
/// `cluster` (receivers that share a direction are not independent): the cluster-robust
/// variance of the mean, `G/(G−1) · Σ_g (S_g − n_g·m)² / n²` over the G clusters (`S_g` the sum
/// of cluster g's n_g values), times 1.96² — the sandwich estimator of Liang & Zeger (1986) for
/// an intercept-only model, with the usual G/(G−1) small-sample factor; it assumes clusters are
/// independent and G large (here 240 directions). With one value per cluster it is the normal
/// interval with the population variance scaled by n/(n−1), i.e. [`mean_ci95`]'s. `None` for
/// fewer than 2 clusters.
pub fn mean_ci95_clustered(v: &[(usize, f64)]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().map(|x| x.1).sum::<f64>() / n;
    let mut clusters: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for &(c, x) in v {
        let e = clusters.entry(c).or_insert((0.0, 0.0));
        e.0 += x;
        e.1 += 1.0;
    }
    let g = clusters.len() as f64;
    let ci = (clusters.len() >= 2).then(|| {
        let ss: f64 = clusters.values().map(|(s, k)| (s - k * m).powi(2)).sum();
        1.96 * (g / (g - 1.0) * ss / (n * n)).sqrt()
    });
    (Some(m), ci)
}

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

/// The parameter columns of kind parameters `P`.
fn param_columns<P: Default + Serialize>() -> Vec<String> {
    shscale_runner::records::to_cells(&P::default())
        .map(|(h, _)| h)
        .unwrap_or_default()
}

/// The parameter columns that make a configuration of kind parameters `P`: all of them but
/// `grouping` (the columns a discussion is split by, and the seeds and receivers its rows
/// repeat over). Derived from `P`, so a new parameter is never merged away.
pub(crate) fn config_keys<P: Default + Serialize>(grouping: &[&str]) -> Vec<String> {
    (param_columns::<P>().into_iter())
        .filter(|h| !grouping.contains(&h.as_str()))
        .collect()
}

/// Every row's method, parsed once from its cells with `spec` (`None` where they no longer
/// parse): the kind's parameter columns are found once for the table, not once per row and use.
pub(crate) fn specs_of<P: Default + Serialize + DeserializeOwned>(
    t: &Results,
    spec: impl Fn(&P) -> Option<Spec>,
) -> Vec<Option<Spec>> {
    let headers = param_columns::<P>();
    (0..t.rows.len())
        .map(|r| {
            let cells: Vec<String> = headers.iter().map(|h| t.cell(r, h).to_string()).collect();
            let p: P = shscale_runner::records::from_cells(&headers, &cells).ok()?;
            spec(&p)
        })
        .collect()
}

/// Row `r`'s parameters, parsed from its cells (`None` where they no longer parse).
pub(crate) fn params_of<P: Default + Serialize + DeserializeOwned>(
    t: &Results,
    r: usize,
) -> Option<P> {
    let headers = param_columns::<P>();
    let cells: Vec<String> = headers.iter().map(|h| t.cell(r, h).to_string()).collect();
    shscale_runner::records::from_cells(&headers, &cells).ok()
}

/// A configuration: its rows (one per seed) and its method, parsed once.
#[derive(Clone)]
pub(crate) struct Config {
    pub rows: Vec<usize>,
    pub spec: Spec,
}

impl Config {
    /// Mean of `col` over the seeds, and its range.
    fn mean(&self, t: &Results, col: &str) -> (f64, f64, f64) {
        let v: Vec<f64> = self.rows.iter().map(|&r| t.num(r, col)).collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (m, lo, hi)
    }
    fn first(&self) -> usize {
        self.rows[0]
    }
    fn method(&self) -> Method {
        self.spec.method()
    }
}

/// Rows grouped by configuration (equal cells in `keys`), in the order of the table, each with
/// its spec (`spec_of`; rows whose parameters no longer parse are left out).
pub(crate) fn by_config(
    t: &Results,
    rows: &[usize],
    keys: &[String],
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> Vec<Config> {
    let mut index: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut out: Vec<Config> = Vec::new();
    for &r in rows {
        let key = keys
            .iter()
            .map(|k| t.cell(r, k))
            .collect::<Vec<_>>()
            .join(";");
        match index.get(&key) {
            Some(&i) => out[i].rows.push(r),
            None => {
                let Some(spec) = spec_of(r) else { continue };
                index.insert(key, out.len());
                out.push(Config {
                    rows: vec![r],
                    spec,
                });
            }
        }
    }
    out
}

/// A number as its CSV cell writes it (`3.0`, `0.05`): the discussion names parameters as the
/// rows spell them.
fn cell(x: f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e16 {
        format!("{x:.1}")
    } else {
        x.to_string()
    }
}

/// The papers' full field: uniform shells over [1, 8]·s, trilinear.
fn is_papers_field(s: &Spec) -> bool {
    matches!(s, Spec::FullField(f) if f.spacing == ShellSpacing::Uniform
        && f.shell_max == 8.0
        && f.interp == FieldInterp::Trilinear)
}

/// The papers' extrapolation: one sphere, fixed α, no mitigation, on the bounding sphere.
pub(crate) fn is_papers_extrapolation(s: &Spec) -> bool {
    matches!(s, Spec::Extrapolated(e) if matches!(e.alpha, Alpha::Fixed(_))
        && e.plausibility == Plausibility::None
        && e.sampling_radius == 1.0
        && e.radial == RadialRule::Uniform)
}

/// Per-direction radii (any rule but the uniform one).
fn is_radial(s: &Spec) -> bool {
    s.extrapolation()
        .is_some_and(|e| e.radial != RadialRule::Uniform)
}

/// The series a spec belongs to: its method and, where it is not the papers', its variant.
pub(crate) fn variant(s: &Spec) -> String {
    match s {
        Spec::FullField(_) if is_papers_field(s) => "full field (papers')".into(),
        Spec::FullField(f) => format!(
            "full field ({}, [1, {}]r, {})",
            f.spacing.name(),
            cell(f.shell_max),
            f.interp.name()
        ),
        Spec::RayTraced { .. } => "ray tracing".into(),
        Spec::SphereSet {
            parts,
            combine,
            internal_order,
            fit,
        } => format!(
            "sphere set (S = {parts}{}{})",
            match fit {
                SphereFit::Area => "",
                SphereFit::Inscribed => ", inscribed",
            },
            match (combine, internal_order) {
                (Combine::Quadrature, _) => ", quadrature".to_string(),
                (Combine::Union, _) => ", union".to_string(),
                (Combine::Shexp, _) => ", SHEXP".to_string(),
                (_, 0) => String::new(),
                (_, m) => format!(", M = {m}"),
            }
        ),
        Spec::Extrapolated(e) => extrapolation_variant("extrapolation", None, e),
        Spec::SubVolumes {
            parts,
            ex,
            combine: Combine::Shexp,
        } => extrapolation_variant("sub-volumes in log space", Some(*parts), ex),
        Spec::SubVolumes { parts, ex, .. } => {
            extrapolation_variant("sub-volumes", Some(*parts), ex)
        }
    }
}

fn extrapolation_variant(base: &str, parts: Option<usize>, e: &Extrapolation) -> String {
    let mut v = Vec::new();
    if let Some(p) = parts {
        v.push(format!("P = {p}"));
    }
    if e.alpha == Alpha::Fit {
        v.push("α fit".to_string());
    }
    if e.plausibility == Plausibility::Clamp {
        v.push("clamp".into());
    }
    if e.sampling_radius != 1.0 {
        v.push(format!("s = {}", cell(e.sampling_radius)));
    }
    match e.radial {
        RadialRule::Clearance { delta } => v.push(format!("clearance δ = {}", cell(delta))),
        RadialRule::Occlusion { tau, t_max } => {
            v.push(format!("occlusion τ = {} to {}r", cell(tau), cell(t_max)))
        }
        RadialRule::Uniform => {}
    }
    if v.is_empty() {
        base.into()
    } else {
        format!("{base} ({})", v.join(", "))
    }
}

/// A configuration in words.
pub(crate) fn name(c: &Config) -> String {
    let s = &c.spec;
    match s {
        Spec::FullField(f) => format!(
            "{}, {} shells of `{}`, H = {}",
            variant(s),
            f.count,
            f.layout.name(),
            f.hemisphere_res
        ),
        Spec::RayTraced { rt_res } => format!("ray tracing, T = {rt_res}"),
        Spec::SphereSet { .. } => variant(s),
        Spec::Extrapolated(e) | Spec::SubVolumes { ex: e, .. } => format!(
            "{}, `{}`{}, H = {}{}",
            variant(s),
            e.layout.name(),
            if c.method() == Method::SubVolumes {
                " each"
            } else {
                ""
            },
            e.hemisphere_res,
            match e.alpha {
                Alpha::Fixed(deg) => format!(", α = {}°", cell(deg)),
                // α by distance: the variant says so.
                Alpha::Fit => String::new(),
            }
        ),
    }
}

/// One part of a verdict table: its label (the order, or the scenes' kind) and its groups (a
/// mesh or a scene each, with its configurations), every group scored alike.
pub(crate) struct Split {
    pub label: String,
    pub groups: Vec<(String, Vec<Config>)>,
}

/// The sampling at which the verdict table compares methods at equal rays: the papers' method
/// (one sphere, fixed α, no mitigation) on a 12 × 20 layout at H = 16, the equal-ray budget the
/// study was designed around (fixed before its runs; 61,440 rays).
pub(crate) const EQUAL_RAYS_SAMPLING: (&str, usize) = ("latlong:12x20", 16);

impl Split {
    /// Add `group` with its configurations to the split labelled `label` in `splits` (a new
    /// split, in order of first appearance, when there is none).
    pub(crate) fn add(splits: &mut Vec<Split>, label: String, group: String, configs: Vec<Config>) {
        match splits.iter_mut().find(|s| s.label == label) {
            Some(s) => s.groups.push((group, configs)),
            None => splits.push(Split {
                label,
                groups: vec![(group, configs)],
            }),
        }
    }
}

/// The rays of the papers' extrapolation at [`EQUAL_RAYS_SAMPLING`] in `configs`: the study's
/// equal-rays budget. `None` when that configuration is not among them.
fn papers_rays(t: &Results, configs: &[Config]) -> Option<f64> {
    let (layout, h) = EQUAL_RAYS_SAMPLING;
    (configs.iter())
        .filter(|c| is_papers_extrapolation(&c.spec))
        .filter(|c| sampling(&c.spec) == Some((layout.to_string(), h)))
        .map(|c| c.mean(t, "rays").0)
        .find(|x| x.is_finite())
}

/// The winners of one regime over a split's groups, one cell: each winning variant with the
/// groups it wins, then the winners' error range (seed means) and, in brackets, the lowest and
/// highest single seed among them. `within(group configs)` bounds the rays (`None`: any).
fn winners_cell(
    t: &Results,
    split: &Split,
    col: &str,
    within: &dyn Fn(&[Config]) -> Option<f64>,
    (seeded, methods): (bool, bool),
) -> String {
    let mut by_variant: Vec<(String, Vec<&str>)> = Vec::new();
    let (mut m_lo, mut m_hi, mut s_lo, mut s_hi) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for (group, configs) in (split.groups.iter()).filter(|(_, c)| !methods || contested(c)) {
        let cap = within(configs).unwrap_or(f64::INFINITY);
        let best = (configs.iter())
            .map(|c| (c, c.mean(t, "rays").0, c.mean(t, col)))
            .filter(|(_, rays, (m, _, _))| rays.is_finite() && *rays <= cap && m.is_finite())
            .min_by(|a, b| a.2 .0.total_cmp(&b.2 .0));
        let Some((c, _, (m, lo, hi))) = best else {
            continue;
        };
        let v = variant(&c.spec);
        match by_variant.iter_mut().find(|(name, _)| *name == v) {
            Some((_, gs)) => gs.push(group),
            None => by_variant.push((v, vec![group])),
        }
        (m_lo, m_hi, s_lo, s_hi) = (m_lo.min(m), m_hi.max(m), s_lo.min(lo), s_hi.max(hi));
    }
    if by_variant.is_empty() {
        return "—".into();
    }
    let names: Vec<String> = (by_variant.iter())
        .map(|(v, gs)| format!("{v}: {}", gs.join(", ")))
        .collect();
    let range = if m_lo == m_hi {
        format!("{m_lo:.3}")
    } else {
        format!("{m_lo:.3}–{m_hi:.3}")
    };
    let seeds = if seeded {
        format!(" [{s_lo:.3}–{s_hi:.3}]")
    } else {
        String::new()
    };
    format!("{} — {range}{seeds}", names.join("; "))
}

/// A group where methods compete: it holds more than one method (the analytic sphere of the
/// radial-rule block, say, holds extrapolations only, and is no verdict on which method wins).
fn contested(configs: &[Config]) -> bool {
    let first = configs.first().map(Config::method);
    configs.iter().any(|c| Some(c.method()) != first)
}

/// The verdict table that opens a summary ([`shscale_runner::kind::Kind::verdict`]): per split
/// and regime (`(column, label)`), the most accurate configuration of each group at no more
/// rays than the papers' extrapolation there, and at any rays. `grid` says which receivers the
/// verdict covers; it is printed under the table with how to read it. `seeded`: the
/// configurations repeat over seeds (their single-seed range is shown).
pub(crate) fn verdict_table(
    t: &Results,
    splits: &[Split],
    regimes: &[(&str, &str)],
    grid: &str,
    seeded: bool,
) -> String {
    let budgets: Vec<f64> = (splits.iter())
        .flat_map(|s| s.groups.iter().filter_map(|(_, c)| papers_rays(t, c)))
        .collect();
    let at = match (
        budgets.iter().copied().reduce(f64::min),
        budgets.iter().copied().reduce(f64::max),
    ) {
        (Some(a), Some(b)) if a == b => format!(" ({a:.0})"),
        (Some(a), Some(b)) => format!(" ({a:.0}–{b:.0})"),
        _ => String::new(),
    };
    // Methods against each other where any group holds several; else (a study of one
    // method's variants) its variants against each other.
    let methods = (splits.iter()).any(|s| s.groups.iter().any(|(_, c)| contested(c)));
    let (layout, h) = EQUAL_RAYS_SAMPLING;
    let mut rows = 0;
    let mut s = format!(
        "| | regime | most accurate at ≤ the rays of the papers' method, `{layout}` at H = {h}{at} | most accurate at any rays in the sweep |\n|---|---|---|---|\n"
    );
    for split in splits {
        for (col, label) in regimes {
            let papers = |c: &[Config]| papers_rays(t, c).or(Some(-1.0));
            let equal = winners_cell(t, split, col, &papers, (seeded, methods));
            let any = winners_cell(t, split, col, &|_| None, (seeded, methods));
            if any == "—" {
                // No group scores this regime (no near receivers under floating objects).
                continue;
            }
            s.push_str(&format!(
                "| {} | {label} | {equal} | {any} |\n",
                split.label
            ));
            rows += 1;
        }
    }
    if rows == 0 {
        return String::new();
    }
    s.push_str(&format!(
        "\n{grid}. Each cell: the winning {} and where it wins{}; the winners' error{}. Rays are not the whole budget (time and memory differ, see below); a verdict holds on this grid only.\n",
        if methods { "method" } else { "variant (these runs compare one method's variants)" },
        if methods { " (a mesh or scene holding one method only is left out)" } else { "" },
        if seeded {
            " (seed means), in brackets the lowest and highest single seed"
        } else {
            " (one run per configuration)"
        }
    ));
    s
}

/// The lower-left Pareto front of `(x, y)` points: sorted by x, each with a lower y than all
/// before it.
pub fn pareto(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut best = f64::INFINITY;
    p.into_iter()
        .filter(|&(_, y)| {
            let keep = y < best;
            best = best.min(y);
            keep
        })
        .collect()
}

/// The sampling (layout, H) of a spec that samples hemispheres.
pub(crate) fn sampling(s: &Spec) -> Option<(String, usize)> {
    match s {
        Spec::FullField(f) => Some((f.layout.name(), f.hemisphere_res)),
        _ => s
            .extrapolation()
            .map(|e| (e.layout.name(), e.hemisphere_res)),
    }
}

/// What a front plot shows: its file stem and title, the budget column `x` and the error column
/// `y`, each with its axis label.
pub(crate) struct Front<'a> {
    pub stem: String,
    pub title: String,
    pub x: &'a str,
    pub x_label: &'a str,
    pub y: &'a str,
    pub y_label: &'a str,
}

/// A method's family: one colour and marker each on the front plots (at most eight).
fn family(s: &Spec) -> &'static str {
    match s {
        Spec::FullField(_) if is_papers_field(s) => "full field (papers')",
        Spec::FullField(_) => "full field (other shells)",
        Spec::RayTraced { .. } => "ray tracing",
        Spec::SphereSet { .. } => "sphere sets",
        Spec::SubVolumes { .. } => "sub-volumes",
        Spec::Extrapolated(_) if is_papers_extrapolation(s) => "extrapolation (papers')",
        Spec::Extrapolated(_) => "extrapolation (variants)",
    }
}

/// Points at x = 0 (a method that casts no rays) cannot sit on a log axis: they are drawn at
/// `x0` (a quarter of the smallest positive x of the figure), and (with `rename`) their series
/// says so. Returns whether any point moved.
pub(crate) fn place_zeros(
    series: &mut BTreeMap<String, Vec<(f64, f64)>>,
    x0: f64,
    rename: bool,
) -> bool {
    let zero_keys: Vec<String> = (series.iter())
        .filter(|(_, v)| v.iter().any(|p| p.0 == 0.0))
        .map(|(k, _)| k.clone())
        .collect();
    for k in &zero_keys {
        let mut v = series.remove(k).unwrap_or_default();
        for p in v.iter_mut().filter(|p| p.0 == 0.0) {
            p.0 = x0;
        }
        let k = if rename {
            format!("{k} (0 at the left edge)")
        } else {
            k.clone()
        };
        series.insert(k, v);
    }
    !zero_keys.is_empty()
}

/// One front plot: the error column `y` of `rows` against the budget column `x` (rays, bytes or
/// `frame_seconds`, then with the interval of each median as bars), one series per method
/// family ([`family`]: one colour and marker each), the Pareto front drawn over them; a method
/// at zero cost is drawn at the left edge (log axes have no 0), its legend entry says so. A
/// companion `<stem>_by_family` draws one panel per family, one series per variant
/// ([`variant`]). Nothing is written without a finite point.
pub(crate) fn write_front(
    dir: &Path,
    t: &Results,
    rows: &[usize],
    f: &Front,
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> Result<Vec<PathBuf>, Error> {
    let (variants, bars) = front_points(t, rows, f, spec_of);
    // One series per family: its variants' points together.
    let mut series: Series = (variants.iter())
        .map(|(fam, v)| (fam.to_string(), v.values().flatten().copied().collect()))
        .collect();
    let Some(min_pos) = (series.values().flatten())
        .map(|p| p.0)
        .filter(|&x| x > 0.0)
        .reduce(f64::min)
    else {
        return Ok(Vec::new());
    };
    let x0 = min_pos / 4.0;
    // The front over the true costs, then placed like its points.
    let mut front = pareto(series.values().flatten().copied());
    for p in front.iter_mut().filter(|p| p.0 == 0.0) {
        p.0 = x0;
    }
    let zeros = place_zeros(&mut series, x0, true);
    for v in series.values_mut() {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let title = if zeros {
        format!("{} (zero cost at the left edge)", f.title)
    } else {
        f.title.clone()
    };
    let labels = Labels {
        title: &title,
        x: f.x_label,
        y: f.y_label,
    };
    let bars = if f.x == "frame_seconds" {
        &bars[..]
    } else {
        &[]
    };
    let mut files = write_scatter_noted(dir, &f.stem, &labels, &series, &front, bars, true, &[])?;
    files.extend(write_by_family(dir, f, variants, x0)?);
    Ok(files)
}

/// The points of a front: per family ([`family`]) its variants' ([`variant`]) `(x, y)` with a
/// finite y and a finite x ≥ 0, and per point its `(y, time low, time high)` bar.
fn front_points(
    t: &Results,
    rows: &[usize],
    f: &Front,
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> (ByFamily, Vec<(f64, f64, f64)>) {
    let mut variants: ByFamily = BTreeMap::new();
    let mut bars = Vec::new();
    for &r in rows {
        let (xv, y) = (t.num(r, f.x), t.num(r, f.y));
        let Some(spec) = spec_of(r) else { continue };
        if xv.is_finite() && xv >= 0.0 && y.is_finite() {
            (variants.entry(family(&spec)).or_default())
                .entry(variant(&spec))
                .or_default()
                .push((xv, y));
            let (lo, hi) = (t.num(r, "frame_seconds_lo"), t.num(r, "frame_seconds_hi"));
            bars.push((y, lo, hi));
        }
    }
    (variants, bars)
}

/// The `<stem>_by_family` companion of a front: one panel per family, markers only, one series
/// per variant, zero-cost points at `x0` (said in the panel's title).
fn write_by_family(
    dir: &Path,
    f: &Front,
    variants: ByFamily,
    x0: f64,
) -> Result<Vec<PathBuf>, Error> {
    let panels: Vec<Panel> = (variants.into_iter())
        .map(|(fam, mut series)| {
            let zeros = place_zeros(&mut series, x0, false);
            Panel {
                title: if zeros {
                    format!("{fam} (zero cost at the left edge)")
                } else {
                    fam.to_string()
                },
                series,
                bands: Default::default(),
                scatter: true,
            }
        })
        .collect();
    Ok(write_panels(
        dir,
        &format!("{}_by_family", f.stem),
        &format!("{}: each family's variants", f.title),
        f.x_label,
        f.y_label,
        &panels,
        None,
        true,
    )?)
}

/// The papers' claim as stated: at the same layout and H, the papers' method (one sphere, fixed
/// α, no mitigation) against the papers' 16-shell full field — rays and time to produce the data.
pub(crate) fn speed_claim(t: &Results, configs: &[Config], err: &str) -> String {
    let mut parts = Vec::new();
    for ex in configs.iter().filter(|c| is_papers_extrapolation(&c.spec)) {
        let e = ex.first();
        let ff = configs.iter().find(|c| {
            is_papers_field(&c.spec)
                && matches!(c.spec, Spec::FullField(f) if f.count == 16)
                && sampling(&c.spec) == sampling(&ex.spec)
        });
        if let Some(ff) = ff {
            let f = ff.first();
            let rays = t.num(f, "rays") / t.num(e, "rays");
            // Per seed the ratio of the medians and the interval from the medians' intervals;
            // the mean ratio over the seeds, the widest interval.
            let mut ratio = 0.0;
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            let pairs: Vec<(usize, usize)> = (ff.rows.iter())
                .filter_map(|&f| {
                    // The row's seed over every seed column either kind has (the plane's is
                    // `placement_seed`; a missing column reads as empty, not as a match of all).
                    let seed = seed_of(t, f);
                    let e = (ex.rows.iter()).find(|&&e| seed_of(t, e) == seed)?;
                    Some((f, *e))
                })
                .collect();
            for &(f, e) in &pairs {
                ratio += t.num(f, "frame_seconds") / t.num(e, "frame_seconds") / pairs.len() as f64;
                lo = lo.min(t.num(f, "frame_seconds_lo") / t.num(e, "frame_seconds_hi"));
                hi = hi.max(t.num(f, "frame_seconds_hi") / t.num(e, "frame_seconds_lo"));
            }
            let (ee, _, _) = ex.mean(t, err);
            let (ef, _, _) = ff.mean(t, err);
            let (layout, h) = sampling(&ex.spec).unwrap_or_default();
            // Both through their per-receiver caches, where the rows have them (the plane).
            let cached = {
                let c = |r: &[usize], col: &str| -> f64 {
                    r.iter().map(|&i| t.num(i, col)).sum::<f64>() / r.len() as f64
                };
                let (cf, ce) = (
                    c(&ff.rows, "cached_frame_seconds"),
                    c(&ex.rows, "cached_frame_seconds"),
                );
                if cf.is_finite() && ce.is_finite() && ce > 0.0 {
                    format!(
                        "; through per-receiver caches of both (built once: {:.1} / {:.1} ms) {:.1}× ({:.2} / {:.2} ms a frame)",
                        1e3 * c(&ff.rows, "cache_seconds"),
                        1e3 * c(&ex.rows, "cache_seconds"),
                        cf / ce,
                        1e3 * cf,
                        1e3 * ce
                    )
                } else {
                    String::new()
                }
            };
            parts.push(format!(
                "`{layout}`, H = {h}: the full field casts {rays:.0}× the rays and takes {ratio:.1}× the time per frame (interval {lo:.1}–{hi:.1}×){cached}; error ({err}) {ee:.3} extrapolated, {ef:.3} full field",
            ));
        }
    }
    if parts.is_empty() {
        return "The claim as stated (the papers' 16-shell field against one sphere at the same sampling) is not among these runs.\n\n".into();
    }
    format!(
        "*The claim as stated* (\"about 20 times faster than full shadow field computation\", at the papers' sampling: one sphere against the papers' 16-shell field of the same layout and H): {}.\n\n",
        parts.join("; ")
    )
}

/// A ray count in the discussion: `0` for none (sphere sets), else three significant digits.
fn rays_text(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.2e}")
    }
}

/// A configuration's mean rays and error in one regime, and its index.
type Point = (f64, f64, usize);

/// The most accurate point passing `keep`.
fn most_accurate(pts: &[Point], keep: impl Fn(usize) -> bool) -> Option<&Point> {
    (pts.iter())
        .filter(|p| keep(p.2))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// The cheapest point passing `keep` at least as accurate as `err`.
fn cheapest_as_accurate(pts: &[Point], err: f64, keep: impl Fn(usize) -> bool) -> Option<&Point> {
    (pts.iter())
        .filter(|p| keep(p.2) && p.1 <= err)
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Equal accuracy in one regime (`col`): the Pareto front against rays, the cheapest full
/// field at least as accurate as the best extrapolation, and how the papers' proposals and the
/// successor compare with one sphere sampled on its sampling sphere.
pub(crate) fn equal_accuracy(t: &Results, configs: &[Config], col: &str, regime: &str) -> String {
    let pts: Vec<Point> = (configs.iter().enumerate())
        .map(|(i, c)| (c.mean(t, "rays").0, c.mean(t, col).0, i))
        .filter(|(x, y, _)| x.is_finite() && *x >= 0.0 && y.is_finite())
        .collect();
    if pts.is_empty() {
        return String::new();
    }
    let front = pareto(pts.iter().map(|p| (p.0, p.1)));
    let on_front: Vec<String> = front
        .iter()
        .filter_map(|f| pts.iter().find(|p| p.0 == f.0 && p.1 == f.1))
        .map(|&(x, _, i)| {
            let (m, lo, hi) = configs[i].mean(t, col);
            format!(
                "{} at {} rays ({m:.3} [{lo:.3}–{hi:.3}])",
                name(&configs[i]),
                rays_text(x)
            )
        })
        .collect();
    let method = |i: usize| configs[i].method();
    let verdict = match most_accurate(&pts, |i| method(i) == Method::Extrapolated) {
        Some(bx) => {
            let families: [(&str, &dyn Fn(usize) -> bool); 2] = [
                ("papers' full field", &|i| is_papers_field(&configs[i].spec)),
                ("full field of any construction", &|i| {
                    method(i) == Method::FullField
                }),
            ];
            let parts: Vec<String> = (families.iter())
                .map(
                    |(label, keep)| match cheapest_as_accurate(&pts, bx.1, keep) {
                        Some(f) => format!(
                            "{label}: {} ({:.3}) at {:.2e} rays, {:.2}× the extrapolation's",
                            name(&configs[f.2]),
                            f.1,
                            f.0,
                            f.0 / bx.0
                        ),
                        None => format!("{label}: none of these runs"),
                    },
                )
                .collect();
            format!(
                " The most accurate extrapolation is {} ({:.3} at {:.2e} rays); the cheapest as accurate — {}.",
                name(&configs[bx.2]),
                bx.1,
                bx.0,
                parts.join("; ")
            )
        }
        None => String::new(),
    };
    format!(
        "*{regime}*: lowest error for the rays (Pareto front) — {}.{verdict}{}\n\n",
        on_front.join("; "),
        proposals(configs, &pts)
    )
}

/// The papers' proposals and the successor: does each beat one sphere sampled on its sampling
/// sphere, and which full field is as accurate for fewer rays?
fn proposals(configs: &[Config], pts: &[Point]) -> String {
    let spec = |i: usize| &configs[i].spec;
    let one_sphere = most_accurate(pts, |i| {
        spec(i).method() == Method::Extrapolated && !is_radial(spec(i))
    });
    let new_methods: [(&str, &dyn Fn(usize) -> bool); 3] = [
        ("Sub-volumes", &|i| spec(i).method() == Method::SubVolumes),
        ("Per-direction radii", &|i| {
            spec(i).method() == Method::Extrapolated && is_radial(spec(i))
        }),
        ("Sphere sets", &|i| spec(i).method() == Method::SphereSet),
    ];
    let mut sub = String::new();
    for (label, keep) in new_methods {
        let Some(b) = most_accurate(pts, keep) else {
            continue;
        };
        sub.push_str(&format!(
            " {label}: the most accurate is {} ({:.3} at {} rays)",
            name(&configs[b.2]),
            b.1,
            rays_text(b.0)
        ));
        if let Some(o) = one_sphere {
            sub.push_str(&format!(
                ", {} the most accurate extrapolation sampled on its sphere ({:.3})",
                if b.1 < o.1 {
                    "better than"
                } else {
                    "no better than"
                },
                o.1
            ));
        }
        match cheapest_as_accurate(pts, b.1, |i| spec(i).method() == Method::FullField) {
            Some(f) => sub.push_str(&format!(
                "; the cheapest full field as accurate: {} ({:.3}) at {:.2e} rays.",
                name(&configs[f.2]),
                f.1,
                f.0
            )),
            None => sub.push_str("; no full field in these runs is as accurate."),
        }
    }
    sub
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_mean_interval_is_the_normal_one_and_needs_two_values() {
        // [1, 2, 3]: mean 2, sample s.d. 1, so 1.96/√3.
        let (m, ci) = super::mean_ci95(&[1.0, 2.0, 3.0]);
        assert_eq!(m, Some(2.0));
        assert!((ci.unwrap() - 1.96 / 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(super::mean_ci95(&[4.0]), (Some(4.0), None));
        assert_eq!(super::mean_ci95(&[]), (None, None));
        // Equal values: no spread.
        assert_eq!(super::mean_ci95(&[0.5; 4]).1, Some(0.0));
    }

    #[test]
    fn the_clustered_interval_is_the_normal_one_for_singletons_and_wider_for_shared_clusters() {
        // One value per cluster: the same as the normal interval.
        let v = [1.0, 2.0, 3.0, 7.0];
        let single: Vec<(usize, f64)> = v.iter().enumerate().map(|(i, x)| (i, *x)).collect();
        let (m, ci) = super::mean_ci95_clustered(&single);
        let (m0, ci0) = super::mean_ci95(&v);
        assert_eq!(m, m0);
        assert!((ci.unwrap() - ci0.unwrap()).abs() < 1e-12, "{ci:?} {ci0:?}");
        // Each value repeated five times in its cluster (five radii on one direction): the
        // independent interval shrinks by √5, the clustered one stays that of the four clusters.
        let rep: Vec<(usize, f64)> = single.iter().flat_map(|&p| [p; 5]).collect();
        let flat: Vec<f64> = rep.iter().map(|p| p.1).collect();
        let (_, naive) = super::mean_ci95(&flat);
        let (mr, clustered) = super::mean_ci95_clustered(&rep);
        assert_eq!(mr, m0);
        // 4 clusters: G/(G−1)·Σ(5(x−m))²/20² = (4/3)·Σ(x−m)²/16 — the singletons' value.
        assert!((clustered.unwrap() - ci0.unwrap()).abs() < 1e-12);
        assert!(
            naive.unwrap() < 0.5 * clustered.unwrap(),
            "{naive:?} {clustered:?}"
        );
        // Degenerate inputs: nothing, and one cluster.
        assert_eq!(super::mean_ci95_clustered(&[]), (None, None));
        assert_eq!(super::mean_ci95_clustered(&[(3, 1.0), (3, 2.0)]).1, None);
    }

    #[test]
    fn the_pareto_front_keeps_strict_improvements_in_order() {
        let f = super::pareto(
            [
                (3.0, 1.0),
                (1.0, 5.0),
                (2.0, 5.0),
                (0.0, 9.0),
                (4.0, f64::NAN),
            ]
            .into_iter(),
        );
        assert_eq!(f, vec![(0.0, 9.0), (1.0, 5.0), (3.0, 1.0)]);
    }
}
