//! The verdict tables and sentences: winners per regime at equal rays, the papers' speed
//! claim as stated, equal accuracy per regime.

use super::*;

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
            // Both through their per-receiver caches, where the rows have them (the plane's;
            // `budget`'s rows have no such column, and a lookup would be recorded as missing).
            let cached = if t.col("cached_frame_seconds").is_none() {
                String::new()
            } else {
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
