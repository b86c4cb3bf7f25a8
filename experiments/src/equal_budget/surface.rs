//! The verdict of the `budget` kind with receivers at every distance (`receiver_layout =
//! "continuous"`): error against the distance to the surface, per method, each method at its
//! best over its own searched parameters, with intervals over seeds that vary what matters.
//!
//! A *seed* is one replicate of the whole study: its receiver directions and radii
//! (`probe_seed`), its truth (`truth_seed`) and the occluder's orientation against the
//! world-fixed sampling grids (`orientation_seed`). A configuration's number is the mean over
//! its seeds; its interval is Student's t over the seed means (`t_{0.975, n−1}·s/√n`): the seed is
//! the independent unit, so the receivers of one seed — which share its orientation and truth —
//! are never counted as independent. A winner is compared with the best configuration of any
//! other method under the same budget by the paired difference over seeds (same orientation,
//! receivers and truth), with its own t interval; where that interval holds zero the cell says
//! "tie".
//!
//! Budgets: the rays, the bytes and the frame time of the papers' extrapolation (one sphere,
//! `latlong:12x20`, H = 16, the study's equal-ray budget fixed before the runs), each a cap under
//! which every method's searched configurations compete, and no cap. The time cap is the upper
//! end of the papers' frame's interval ([`papers_cap`]).

use super::verdict::{
    is_papers_extrapolation, mean_t95, name, place_zeros, sampling, seed_of, variant, Config, Split,
};
use shscale_present::plots::{write_panels, Bands, Panel, MAX_PANELS};
use shscale_runner::records::Results;
use shscale_scene::method::Method;
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The inner edges of the distance-to-surface bins, bounding radii: octaves from 0.04r, so
/// bin k holds d in [0.04·2^(k−1), 0.04·2^k) (bin 0 everything below 0.04r, bin 6 everything
/// from 1.28r). Fixed before any run with them.
pub const SURFACE_EDGES: [f64; 6] = [0.04, 0.08, 0.16, 0.32, 0.64, 1.28];

/// The bin of [`SURFACE_EDGES`] a distance to the surface falls in.
pub fn surface_bin(d: f64) -> usize {
    SURFACE_EDGES.iter().filter(|&&e| d >= e).count()
}

/// A bin's representative distance: the geometric middle of its edges (bin 0: 0.02r, where
/// the continuous layout's nearest receivers start; bin 6: 1.81r).
pub(crate) fn surface_bin_mid(k: usize) -> f64 {
    let lo = if k == 0 { 0.02 } else { SURFACE_EDGES[k - 1] };
    let hi = SURFACE_EDGES
        .get(k)
        .copied()
        .unwrap_or(2.0 * SURFACE_EDGES[5]);
    (lo * hi).sqrt()
}

/// The distinct seeds of a table.
pub(crate) fn distinct_seeds(t: &Results) -> usize {
    let mut v: Vec<String> = (0..t.rows.len()).map(|r| seed_of(t, r)).collect();
    v.sort();
    v.dedup();
    v.len()
}

/// A configuration's per-seed values of `col` (finite only), by seed.
fn per_seed(t: &Results, c: &Config, col: &str) -> BTreeMap<String, f64> {
    (c.rows.iter())
        .map(|&r| (seed_of(t, r), t.num(r, col)))
        .filter(|(_, x)| x.is_finite())
        .collect()
}

/// The mean over seeds of `col` and its t interval.
fn seed_mean(t: &Results, c: &Config, col: &str) -> (Option<f64>, Option<f64>) {
    mean_t95(&per_seed(t, c, col).into_values().collect::<Vec<_>>())
}

/// The paired difference `b − a` of `col` over the seeds both hold, and its t interval.
fn paired(t: &Results, a: &Config, b: &Config, col: &str) -> (Option<f64>, Option<f64>) {
    let (pa, pb) = (per_seed(t, a, col), per_seed(t, b, col));
    let d: Vec<f64> = (pa.iter())
        .filter_map(|(s, x)| pb.get(s).map(|y| y - x))
        .collect();
    mean_t95(&d)
}

/// The budget axes the verdict caps: (column, words).
pub(crate) const AXES: [(&str, &str); 3] = [
    ("rays", "rays"),
    ("frame_seconds", "time per frame"),
    ("memory_bytes", "bytes"),
];

/// The papers' extrapolation at the study's equal-ray sampling among `configs`: its budget on
/// axis `col` (seed mean). On time that is the upper end of its frame's interval
/// (`frame_seconds_hi`, the order-statistic bound of the median): a configuration competes when
/// its median frame is not measurably slower — a variant of the same cost (the papers' method at
/// 1.1r, say) is then in or out by its cost, not by a sitting's noise. `None` when it is not
/// among them.
fn papers_cap(t: &Results, configs: &[Config], col: &str) -> Option<f64> {
    let (layout, h) = super::verdict::EQUAL_RAYS_SAMPLING;
    let col = if col == "frame_seconds" {
        "frame_seconds_hi"
    } else {
        col
    };
    (configs.iter())
        .filter(|c| is_papers_extrapolation(&c.spec))
        .find(|c| sampling(&c.spec) == Some((layout.to_string(), h)))
        .and_then(|c| seed_mean(t, c, col).0)
}

/// The most accurate configuration on `col` among those within `cap` on `axis` (and passing
/// `keep`), with its seed mean.
fn best<'a>(
    t: &Results,
    configs: &'a [Config],
    col: &str,
    cap: Option<(&str, f64)>,
    keep: &dyn Fn(&Config) -> bool,
) -> Option<(&'a Config, f64)> {
    (configs.iter())
        .filter(|c| keep(c))
        .filter(|c| match cap {
            Some((axis, x)) => seed_mean(t, c, axis)
                .0
                .is_some_and(|v| v <= x * (1.0 + 1e-9)),
            None => true,
        })
        .filter_map(|c| Some((c, seed_mean(t, c, col).0?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// One cell: the winner (its variant, mean ± interval) and the paired gap to the best other
/// method under the same cap, or "tie" where that gap's interval holds zero.
fn cell(t: &Results, configs: &[Config], col: &str, cap: Option<(&str, f64)>) -> String {
    let Some((w, _)) = best(t, configs, col, cap, &|_| true) else {
        return "—".into();
    };
    let (m, ci) = seed_mean(t, w, col);
    let mut s = format!("{} {}", name(w), pm(m.unwrap_or(f64::NAN), ci));
    let other = |c: &Config| c.spec.method() != w.spec.method();
    if let Some((r, _)) = best(t, configs, col, cap, &other) {
        let (d, dci) = paired(t, w, r, col);
        let d = d.unwrap_or(f64::NAN);
        let tie = dci.is_some_and(|h| d.abs() <= h);
        s.push_str(&format!(
            "; {} {}{}",
            r.spec.method().name(),
            if d >= 0.0 { "+" } else { "" },
            pm(d, dci)
        ));
        if tie {
            s.push_str(" **tie**");
        }
    }
    s
}

/// `m ± h` (3 decimals), or `m` without an interval.
fn pm(m: f64, h: Option<f64>) -> String {
    match h {
        Some(h) => format!("{m:.3} ± {h:.3}"),
        None => format!("{m:.3}"),
    }
}

/// The regimes of the continuous verdict: every distance bin, then all receivers and the
/// contact directions. (column, words).
pub(crate) fn sphere_regimes() -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = (0..=SURFACE_EDGES.len())
        .map(|k| (format!("occ_rel_l2_s{k}_mean"), bin_words(k)))
        .collect();
    v.push(("occ_rel_l2_mean".into(), "all receivers".into()));
    v.push((
        "occ_rel_l2_contact_mean".into(),
        "contact directions".into(),
    ));
    v
}

/// Bin k's distances in words.
pub(crate) fn bin_words(k: usize) -> String {
    let e = &SURFACE_EDGES;
    match k {
        0 => format!("d < {}r", e[0]),
        k if k == e.len() => format!("d ≥ {}r", e[e.len() - 1]),
        k => format!("{}r ≤ d < {}r", e[k - 1], e[k]),
    }
}

/// A group's budget cap on `axis` (`None`: no cap), or `Err` where the papers' extrapolation
/// is not among its configurations (no cap can be drawn).
fn group_cap<'a>(
    t: &Results,
    configs: &[Config],
    axis: Option<&'a str>,
) -> Result<Option<(&'a str, f64)>, ()> {
    match axis {
        Some(a) => papers_cap(t, configs, a).map(|x| Some((a, x))).ok_or(()),
        None => Ok(None),
    }
}

/// The budgets of the tables: each axis capped at the papers' extrapolation, then none.
fn caps() -> Vec<(Option<&'static str>, String)> {
    (AXES.iter())
        .map(|(a, w)| (Some(*a), format!("≤ papers' {w}")))
        .chain(std::iter::once((None, "any budget".to_string())))
        .collect()
}

/// The compact verdict (a summary's opening table, at most 20 lines): per split and regime, per
/// budget, the winning method(s) with the groups each wins (a group marked `~` where the best
/// other method ties it) and the range of the winners' seed means.
pub fn verdict(t: &Results, splits: &[Split], regimes: &[(String, String)], grid: &str) -> String {
    let caps = caps();
    let mut s = format!(
        "| | regime | {} |\n|---|---|{}\n",
        caps.iter()
            .map(|c| c.1.as_str())
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(caps.len())
    );
    // One row per regime whatever the splits (a summary opens with at most 20 lines): with
    // several splits (orders) each cell holds every split's answer, labelled.
    let mut rows = 0;
    let label0 = (splits.iter().map(|s| s.label.as_str()))
        .collect::<Vec<_>>()
        .join(", ");
    for (col, label) in regimes {
        let cells: Vec<String> = (caps.iter())
            .map(|(axis, _)| {
                let per: Vec<(String, String)> = (splits.iter())
                    .map(|sp| (sp.label.clone(), compact_cell(t, sp, col, *axis)))
                    .collect();
                if per.len() == 1 {
                    return per[0].1.clone();
                }
                if per.iter().all(|(_, c)| c == "—") {
                    return "—".into();
                }
                (per.iter())
                    .map(|(l, c)| format!("**{l}** {c}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect();
        if cells.iter().all(|c| c == "—") {
            continue;
        }
        s.push_str(&format!("| {label0} | {label} | {} |\n", cells.join(" | ")));
        rows += 1;
    }
    if rows == 0 {
        return String::new();
    }
    s.push_str(&format!(
        "\n{grid}. Each cell: the method whose best searched configuration is most accurate under the budget (the papers' extrapolation at `latlong:12x20`, H = 16, sets each cap; on time the upper end of its frame's interval), the groups it wins (`~`: the best other method's paired gap over the seeds holds zero — a tie), and the winners' seed means; per-group tables with intervals below.\n"
    ));
    s
}

/// One compact cell ([`verdict`]).
fn compact_cell(t: &Results, split: &Split, col: &str, axis: Option<&str>) -> String {
    let mut by: Vec<(&'static str, Vec<String>)> = Vec::new();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (group, configs) in &split.groups {
        let Ok(cap) = group_cap(t, configs, axis) else {
            continue;
        };
        let Some((w, m)) = best(t, configs, col, cap, &|_| true) else {
            continue;
        };
        let other = |c: &Config| c.spec.method() != w.spec.method();
        let tie = best(t, configs, col, cap, &other).is_some_and(|(r, _)| {
            let (d, h) = paired(t, w, r, col);
            matches!((d, h), (Some(d), Some(h)) if d.abs() <= h)
        });
        let name = w.spec.method().name();
        let g = format!("{group}{}", if tie { "~" } else { "" });
        match by.iter_mut().find(|(n, _)| *n == name) {
            Some((_, gs)) => gs.push(g),
            None => by.push((name, vec![g])),
        }
        (lo, hi) = (lo.min(m), hi.max(m));
    }
    if by.is_empty() {
        return "—".into();
    }
    let names: Vec<String> = by
        .iter()
        .map(|(n, gs)| format!("{n}: {}", gs.join(", ")))
        .collect();
    let (a, b) = (format!("{lo:.3}"), format!("{hi:.3}"));
    let range = if a == b { a } else { format!("{a}–{b}") };
    format!("{} — {range}", names.join("; "))
}

/// The full tables (a discussion's): per split and budget (the papers' rays, time, bytes, none),
/// `regimes` (column, words) × groups (meshes or scenes), each cell the winner with its interval
/// and the paired gap to the best other method.
pub fn tables(t: &Results, splits: &[Split], regimes: &[(String, String)], grid: &str) -> String {
    let mut s = String::new();
    for split in splits {
        let groups: Vec<&(String, Vec<Config>)> = split.groups.iter().collect();
        let header: Vec<&str> = groups.iter().map(|(g, _)| g.as_str()).collect();
        for (axis, words) in caps() {
            s.push_str(&format!(
                "**{}, {words}**\n\n| regime | {} |\n|---|{}\n",
                split.label,
                header.join(" | "),
                "---|".repeat(header.len())
            ));
            for (col, label) in regimes {
                let cells: Vec<String> = (groups.iter())
                    .map(|(_, configs)| match group_cap(t, configs, axis) {
                        Ok(cap) => cell(t, configs, col, cap),
                        Err(()) => "—".into(),
                    })
                    .collect();
                if cells.iter().all(|c| c == "—") {
                    continue;
                }
                s.push_str(&format!("| {label} | {} |\n", cells.join(" | ")));
            }
            s.push('\n');
        }
    }
    if s.is_empty() {
        return s;
    }
    s.push_str(&method_tables(t, splits, regimes));
    s.push_str(&format!(
        "{grid}. Each cell of the per-group tables: the most accurate configuration in the search under the budget (mean over seeds ± the 95 % Student-t half-width over the seed means), then the best configuration of any other method under the same budget and its paired gap over the seeds (+: worse than the winner), **tie** where the gap's interval holds zero. Winners are selected on the same seeds they are scored on.\n"
    ));
    s
}

/// Per split and budget, every method side by side: rows the regimes, a column per method,
/// each cell the range over the groups of that method's best searched configuration there
/// (seed means; `—` where the method is not in the search or over the budget).
fn method_tables(t: &Results, splits: &[Split], regimes: &[(String, String)]) -> String {
    let mut s = String::new();
    for split in splits {
        let methods: Vec<Method> = (METHODS.iter().copied())
            .filter(|m| {
                (split.groups.iter()).any(|(_, cs)| cs.iter().any(|c| c.spec.method() == *m))
            })
            .collect();
        let names: Vec<&str> = methods.iter().map(|m| m.name()).collect();
        for (axis, words) in caps() {
            s.push_str(&format!(
                "**{}, {words}: each method at its best (range over the groups)**\n\n| regime | {} |\n|---|{}\n",
                split.label,
                names.join(" | "),
                "---|".repeat(names.len())
            ));
            for (col, label) in regimes {
                let cells: Vec<String> = (methods.iter())
                    .map(|m| {
                        let keep = |c: &Config| c.spec.method() == *m;
                        let v: Vec<f64> = (split.groups.iter())
                            .filter_map(|(_, configs)| {
                                let cap = group_cap(t, configs, axis).ok()?;
                                best(t, configs, col, cap, &keep).map(|b| b.1)
                            })
                            .collect();
                        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                        let (a, b) = (format!("{lo:.3}"), format!("{hi:.3}"));
                        match v.len() {
                            0 => "—".to_string(),
                            _ if a == b => a,
                            _ => format!("{a}–{b}"),
                        }
                    })
                    .collect();
                if cells.iter().all(|c| c == "—") {
                    continue;
                }
                s.push_str(&format!("| {label} | {} |\n", cells.join(" | ")));
            }
            s.push('\n');
        }
    }
    s
}

/// The figures: per split, error against distance to the surface (one panel per group, one
/// curve per method with its seed band; each method its most accurate configuration over all
/// receivers within the papers' rays, and within its time), and per budget axis each method's
/// own Pareto front over its search (seed means, bands ± the t interval of each front point).
pub fn figures(
    dir: &Path,
    t: &Results,
    splits: &[Split],
    tag: &dyn Fn(&str) -> String,
) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for split in splits {
        let groups: Vec<&(String, Vec<Config>)> = split.groups.iter().take(MAX_PANELS).collect();
        let lbl = tag(&split.label);
        for (axis, words) in [("rays", "rays"), ("frame_seconds", "time")] {
            let panels: Vec<Panel> = (groups.iter())
                .filter_map(|(g, configs)| {
                    let cap = papers_cap(t, configs, axis)?;
                    Some(curve_panel(t, g, configs, (axis, cap)))
                })
                .collect();
            if panels.is_empty() {
                continue;
            }
            files.extend(write_panels(
                dir,
                &format!("surface_{words}_{lbl}"),
                &format!("{}: error against distance to the surface, each method's best within the papers' {words}", split.label),
                "distance to the surface (bounding radii)",
                "mean occ_rel_l2 (band: 95 % over seeds)",
                &panels,
                None,
                true,
            )?);
        }
        for (axis, words) in AXES {
            let panels: Vec<Panel> = (groups.iter())
                .map(|(g, configs)| front_panel(t, g, configs, axis))
                .collect();
            files.extend(write_panels(
                dir,
                &format!("fronts_{}_{lbl}", axis.split('_').next().unwrap_or(axis)),
                &format!(
                    "{}: each method's front over its own search, against {words}",
                    split.label
                ),
                words,
                "mean occ_rel_l2 (band: 95 % over seeds)",
                &panels,
                None,
                true,
            )?);
        }
    }
    Ok(files)
}

/// The methods drawn, in order.
const METHODS: [Method; 5] = [
    Method::Extrapolated,
    Method::SubVolumes,
    Method::FullField,
    Method::RayTraced,
    Method::SphereSet,
];

/// One group's curves: per method, its most accurate configuration over all receivers within
/// `cap`, its bin means against the bins' middles, the seed bands.
fn curve_panel(t: &Results, group: &str, configs: &[Config], (axis, cap): (&str, f64)) -> Panel {
    let (mut series, mut bands) = (BTreeMap::new(), Bands::new());
    for m in METHODS {
        let keep = |c: &Config| c.spec.method() == m;
        let Some((c, _)) = best(t, configs, "occ_rel_l2_mean", Some((axis, cap)), &keep) else {
            continue;
        };
        let name = format!("{}: {}", m.name(), variant(&c.spec));
        let (mut pts, mut band) = (Vec::new(), Vec::new());
        for k in 0..=SURFACE_EDGES.len() {
            let (mean, ci) = seed_mean(t, c, &format!("occ_rel_l2_s{k}_mean"));
            if let Some(y) = mean {
                let x = surface_bin_mid(k);
                pts.push((x, y));
                let h = ci.unwrap_or(0.0);
                band.push((x, y - h, y + h));
            }
        }
        bands.insert(name.clone(), band);
        series.insert(name, pts);
    }
    Panel {
        title: group.to_string(),
        series,
        bands,
        scatter: false,
    }
}

/// One group's per-method fronts on `axis`: each method's configurations' seed means, their
/// lower-left Pareto front, with bands ± the t interval of the error at each front point.
/// Zero-cost points (sphere sets cast no rays) at a quarter of the smallest positive cost.
fn front_panel(t: &Results, group: &str, configs: &[Config], axis: &str) -> Panel {
    let (mut series, mut bands) = (BTreeMap::new(), Bands::new());
    let mut min_pos = f64::INFINITY;
    for m in METHODS {
        let pts: Vec<(f64, f64, f64)> = (configs.iter())
            .filter(|c| c.spec.method() == m)
            .filter_map(|c| {
                let x = seed_mean(t, c, axis).0?;
                let (y, h) = seed_mean(t, c, "occ_rel_l2_mean");
                Some((x, y?, h.unwrap_or(0.0)))
            })
            .collect();
        let front = super::verdict::pareto(pts.iter().map(|p| (p.0, p.1)));
        if front.is_empty() {
            continue;
        }
        min_pos = (front.iter().map(|p| p.0).filter(|&x| x > 0.0)).fold(min_pos, f64::min);
        let band = (front.iter())
            .filter_map(|f| pts.iter().find(|p| p.0 == f.0 && p.1 == f.1))
            .map(|p| (p.0, p.1 - p.2, p.1 + p.2))
            .collect();
        bands.insert(m.name().to_string(), band);
        series.insert(m.name().to_string(), front);
    }
    let x0 = if min_pos.is_finite() {
        min_pos / 4.0
    } else {
        1.0
    };
    for b in bands.values_mut() {
        for p in b.iter_mut().filter(|p| p.0 == 0.0) {
            p.0 = x0;
        }
    }
    let zeros = place_zeros(&mut series, x0, false);
    Panel {
        title: if zeros {
            format!("{group} (zero cost at the left edge)")
        } else {
            group.to_string()
        },
        series,
        bands,
        scatter: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_t_interval_matches_a_hand_computation_and_needs_two_values() {
        // Five values 1..5: mean 3, s = √2.5, t_{0.975,4} = 2.776445 (the tables' 2.776).
        let (m, h) = mean_t95(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        let want = 2.776_445_105 * (2.5f64 / 5.0).sqrt();
        assert_eq!(m, Some(3.0));
        let err = (h.unwrap() - want).abs();
        assert!(err < 1e-9, "half-width {h:?} vs {want} (error {err:.1e})");
        assert_eq!(mean_t95(&[0.3]), (Some(0.3), None));
        assert_eq!(mean_t95(&[]), (None, None));
        // Forty values: t_{0.975,39} = 2.022691 (to 1e-7), not the 1.96 the old table fell back to.
        let v: Vec<f64> = (0..40).map(|i| i as f64).collect();
        let (_, h) = mean_t95(&v);
        let s = (v.iter().map(|x| (x - 19.5f64).powi(2)).sum::<f64>() / 39.0).sqrt();
        let want = 2.022_690_901 * s / 40f64.sqrt();
        assert!((h.unwrap() - want).abs() < 1e-7 * want, "{h:?} vs {want}");
    }

    #[test]
    fn the_bins_words_name_their_edges() {
        assert_eq!(bin_words(0), "d < 0.04r");
        assert_eq!(bin_words(1), "0.04r ≤ d < 0.08r");
        assert_eq!(bin_words(6), "d ≥ 1.28r");
    }

    /// The bins: octaves from 0.04r, the edges in the upper bin; middles inside their bins.
    #[test]
    fn the_surface_bins_are_octaves_from_a_twenty_fifth_of_the_radius() {
        assert_eq!(surface_bin(0.0), 0);
        assert_eq!(surface_bin(0.0399), 0);
        assert_eq!(surface_bin(0.04), 1);
        assert_eq!(surface_bin(1.279), 5);
        assert_eq!(surface_bin(1.28), 6);
        assert_eq!(surface_bin(1e6), 6);
        for k in 0..=SURFACE_EDGES.len() {
            assert_eq!(surface_bin(surface_bin_mid(k)), k);
        }
    }
}
