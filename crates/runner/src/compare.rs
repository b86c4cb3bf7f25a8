//! `shscale compare A B`: two results directories of one kind side by side — their rows matched on
//! the parameters they share, each headline metric for A, B and B − A (`compare.md`), and a plot
//! per metric — written to a staging folder and moved into place only when all of it succeeded.

use crate::error::Error;
use crate::kind::DynKind;
use crate::records::Results;
use shscale_files::atomic::write_atomic;
use shscale_present::markdown::md_cell;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// What [`compare`] found: the Markdown table (also written as `compare.md`) and the files.
pub struct Comparison {
    pub markdown: String,
    pub files: Vec<PathBuf>,
}

/// `shscale compare A B`: the kind's headline metrics of two results directories over the
/// parameters both share, and their differences. Rows are matched on every parameter that varies
/// in either directory (and on the kind's row coordinate — the first summary column, such as the
/// probe radius — when both hold the same values of it); parameters fixed at different values in
/// the two are listed. Writes `compare.md` and one plot per metric into `out`.
pub fn compare(kind: &dyn DynKind, a: &Path, b: &Path, out: &Path) -> Result<Comparison, Error> {
    let (ta, tb) = (
        Results::read(&a.join("runs.csv"))?,
        Results::read(&b.join("runs.csv"))?,
    );
    check_comparable(kind, (a, &ta), (b, &tb))?;
    let m = Matching::of(kind, &ta, &tb);
    let (ma, mb) = (m.means(&ta), m.means(&tb));
    let mut md = m.header_md(kind, (a, &ta), (b, &tb));
    let avg = |v: (f64, usize)| if v.1 > 0 { v.0 / v.1 as f64 } else { f64::NAN };
    let (na, nb) = (dir_name(a), dir_name(b));
    let mut matched = 0;
    let mut plots: Vec<Facets> = vec![BTreeMap::new(); m.metrics.len()];
    for (k, va) in &ma {
        let Some(vb) = mb.get(k) else { continue };
        matched += 1;
        let mut cells: Vec<String> = k.iter().map(|c| md_cell(c)).collect();
        for i in 0..m.metrics.len() {
            let (x, y) = (avg(va[i]), avg(vb[i]));
            cells.extend([compare_cell(x), compare_cell(y), compare_cell(y - x)]);
            if let Some(xv) = k.first().and_then(|s| s.parse::<f64>().ok()) {
                let rest = m.rest_of(k);
                let facet = m.facet.map_or(String::new(), |f| k[f].clone());
                let series = plots[i].entry(facet).or_default();
                series
                    .entry(format!("A: {na}{rest}"))
                    .or_default()
                    .push((xv, x));
                series
                    .entry(format!("B: {nb}{rest}"))
                    .or_default()
                    .push((xv, y));
            }
        }
        md.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    md.push_str(&format!(
        "\n{matched} matched row group(s); {} only in A, {} only in B.\n",
        ma.keys().filter(|k| !mb.contains_key(*k)).count(),
        mb.keys().filter(|k| !ma.contains_key(*k)).count()
    ));
    // Stale or mixed rows, and rows timed on a busy machine, named as the report names them;
    // and rows of two numerical codes across A and B.
    let has_times = !kind.time_columns().is_empty();
    for (side, t) in [("A", &ta), ("B", &tb)] {
        for n in crate::manifest::row_notes(t, has_times) {
            md.push_str(&format!("\n{side}: {n}\n"));
        }
    }
    let codes = |t: &Results| {
        t.col("code")
            .map(|c| t.rows.iter().map(|r| r[c].clone()).collect::<BTreeSet<_>>())
    };
    if let (Some(x), Some(y)) = (codes(&ta), codes(&tb)) {
        if x != y {
            md.push_str(&format!(
                "\nA and B were computed by different numerical codes (A: {}; B: {}): a difference may be the code's, not the parameters'.\n",
                x.into_iter().collect::<Vec<_>>().join(", "),
                y.into_iter().collect::<Vec<_>>().join(", ")
            ));
        }
    }
    ta.check_read("compare")?;
    tb.check_read("compare")?;
    // Everything goes to a staging folder first: a comparison that fails creates nothing.
    let staging = shscale_files::atomic::Staging::new(out)?;
    let mut files = compare_plots(staging.path(), &m, &plots)?;
    let p = staging.path().join("compare.md");
    write_atomic(&p, &md)?;
    files.insert(0, p);
    let files = staging.commit(&files)?;
    Ok(Comparison {
        markdown: md,
        files,
    })
}

/// Two sides that can be compared: each holds rows (a side without rows would read its fixed
/// parameters as blanks), and a headline metric column is on both or neither — never a column
/// of "—" (a metric on both sides without a number on one, e.g. no on-surface samples, is a
/// result, shown as "—").
fn check_comparable(
    kind: &dyn DynKind,
    (a, ta): (&Path, &Results),
    (b, tb): (&Path, &Results),
) -> Result<(), Error> {
    let sides = [(ta, a, "A"), (tb, b, "B")];
    for (t, dir, side) in sides {
        if t.rows.is_empty() {
            return Err(Error::Io {
                path: dir.join("runs.csv").display().to_string(),
                reason: format!("compare: {side} holds no rows (runs.csv is its header alone)"),
            });
        }
    }
    for metric in kind.summary_columns() {
        let has = sides.map(|(t, _, _)| t.col(metric).is_some());
        for (i, (_, dir, side)) in sides.iter().enumerate() {
            if has[1 - i] && !has[i] {
                return Err(Error::Io {
                    path: dir.join("runs.csv").display().to_string(),
                    reason: format!(
                        "compare: {side} has no column {metric:?}, which the other has"
                    ),
                });
            }
        }
    }
    Ok(())
}

/// A metric's plotted series per facet value (`""` when the rows have no facet).
type Facets = BTreeMap<String, BTreeMap<String, Vec<(f64, f64)>>>;

/// A plot per metric of the matched rows, A against B over the first key, into `dir`: one panel
/// per value of the kind's row coordinate (the probe radius, say) when the rows have one and it
/// takes 2 to [`shscale_present::plots::MAX_PANELS`] values — as the report splits its plots —, else one
/// panel.
fn compare_plots(dir: &Path, m: &Matching, plots: &[Facets]) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for (i, c) in m.metrics.iter().enumerate() {
        if plots[i].is_empty() || m.keys.is_empty() {
            continue;
        }
        let title = format!("{c}: A vs B");
        let (x_words, y_words) = (
            shscale_present::plots::words(&m.keys[0]),
            shscale_present::plots::words(c),
        );
        let stem = format!("compare_{c}");
        let facet = m.facet.map(|f| shscale_present::plots::words(&m.keys[f]));
        match facet {
            Some(name) if plots[i].len() <= shscale_present::plots::MAX_PANELS => {
                let mut values: Vec<(&String, _)> = plots[i].iter().collect();
                values.sort_by(|a, b| numeric_order(a.0, b.0));
                let panels: Vec<shscale_present::plots::Panel> = (values.into_iter())
                    .map(|(v, series)| shscale_present::plots::Panel {
                        title: format!("{name} = {v}"),
                        series: series.clone(),
                        bands: Default::default(),
                        scatter: false,
                    })
                    .collect();
                files.extend(shscale_present::plots::write_panels(
                    dir, &stem, &title, &x_words, &y_words, &panels, None, false,
                )?);
            }
            _ => {
                let mut all: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
                for (v, series) in &plots[i] {
                    for (name, pts) in series {
                        let name = match (&facet, v.is_empty()) {
                            (Some(f), false) => format!("{name}, {f} = {v}"),
                            _ => name.clone(),
                        };
                        all.entry(name).or_default().extend(pts);
                    }
                }
                let labels = shscale_present::plots::Labels {
                    title: &title,
                    x: &x_words,
                    y: &y_words,
                };
                files.extend(shscale_present::plots::write_both(
                    dir,
                    &stem,
                    &labels,
                    &all,
                    false,
                    &[],
                )?);
            }
        }
    }
    Ok(files)
}

/// Cells in numeric order where both are numbers, else as text.
fn numeric_order(a: &str, b: &str) -> std::cmp::Ordering {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x.total_cmp(&y),
        _ => a.cmp(b),
    }
}

/// The last component of a directory, for series names.
fn dir_name(p: &Path) -> String {
    p.file_name()
        .map_or(p.display().to_string(), |n| n.to_string_lossy().to_string())
}

/// A compared mean: `—` when undefined, `e` notation below 10⁻³, else four decimals.
fn compare_cell(x: f64) -> String {
    if !x.is_finite() {
        "—".to_string()
    } else if x != 0.0 && x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// How the rows of two results directories are matched: on the parameters that vary in either
/// (and the first summary column when it is a shared key of few values), the parameters fixed at
/// different values (reported), and the metrics compared.
struct Matching<'a> {
    keys: Vec<String>,
    /// The index in `keys` of the kind's row coordinate (the first summary column), when rows
    /// are matched on it and another key gives the x axis: the plots' facet.
    facet: Option<usize>,
    differ: Vec<String>,
    metrics: Vec<&'a str>,
}

impl<'a> Matching<'a> {
    fn of(kind: &'a dyn DynKind, ta: &Results, tb: &Results) -> Self {
        let params = kind.param_columns();
        let distinct = |t: &Results, c: &str| -> BTreeSet<String> {
            (0..t.rows.len())
                .map(|r| t.cell(r, c).to_string())
                .collect()
        };
        let mut keys: Vec<String> = Vec::new();
        let mut differ = Vec::new();
        for p in &params {
            let (da, db) = (distinct(ta, p), distinct(tb, p));
            if da.len() > 1 || db.len() > 1 {
                keys.push(p.clone());
            } else if da != db {
                differ.push(format!(
                    "{p} (A: {}, B: {})",
                    da.iter().next().cloned().unwrap_or_default(),
                    db.iter().next().cloned().unwrap_or_default()
                ));
            }
        }
        let summary = kind.summary_columns();
        // The headline metrics, then the kind's stage times (where the time goes), once each.
        let mut metrics: Vec<&str> = summary.to_vec();
        for t in kind.time_columns() {
            // A stage's time, not its spread or interval ends.
            let spread = ["_spread", "_lo", "_hi"].iter().any(|s| t.ends_with(s));
            if !spread && !metrics.contains(t) {
                metrics.push(t);
            }
        }
        let mut facet = None;
        if let Some(first) = summary.first() {
            if !params.iter().any(|p| p == first)
                && distinct(ta, first) == distinct(tb, first)
                && distinct(ta, first).len() <= 64
            {
                keys.push(first.to_string());
                metrics.retain(|m| m != first);
                facet = (keys.len() > 1).then_some(keys.len() - 1);
            }
        }
        metrics.retain(|m| {
            !keys.iter().any(|k| k == m) && (0..ta.rows.len()).any(|r| ta.num(r, m).is_finite())
        });
        Self {
            keys,
            facet,
            differ,
            metrics,
        }
    }

    /// The comparison's heading (what was matched and what differs) and its table header.
    fn header_md(
        &self,
        kind: &dyn DynKind,
        (a, ta): (&Path, &Results),
        (b, tb): (&Path, &Results),
    ) -> String {
        let mut md = format!(
            "# Comparison of {} results\n\nA: `{}` ({} rows), B: `{}` ({} rows). Rows matched on: {}. Parameters fixed at different values: {}.\n\n",
            kind.name(),
            a.display(),
            ta.rows.len(),
            b.display(),
            tb.rows.len(),
            if self.keys.is_empty() { "nothing (one row each)".to_string() } else { self.keys.join(", ") },
            if self.differ.is_empty() { "none".to_string() } else { self.differ.join("; ") }
        );
        let mut head: Vec<String> = self.keys.clone();
        for c in &self.metrics {
            head.extend([format!("{c} A"), format!("{c} B"), format!("{c} B − A")]);
        }
        md.push_str(&format!(
            "| {} |\n|{}\n",
            head.join(" | "),
            "---|".repeat(head.len())
        ));
        md
    }

    /// Sum and count of each metric per key.
    fn means(&self, t: &Results) -> BTreeMap<Vec<String>, Vec<(f64, usize)>> {
        let mut m: BTreeMap<Vec<String>, Vec<(f64, usize)>> = BTreeMap::new();
        for r in 0..t.rows.len() {
            let key = self.keys.iter().map(|k| t.cell(r, k).to_string()).collect();
            let e = m
                .entry(key)
                .or_insert_with(|| vec![(0.0, 0); self.metrics.len()]);
            for (i, c) in self.metrics.iter().enumerate() {
                let v = t.num(r, c);
                if v.is_finite() {
                    e[i].0 += v;
                    e[i].1 += 1;
                }
            }
        }
        m
    }

    /// `, key = value, …` of a key's values after the first, the facet left out (a series'
    /// name).
    fn rest_of(&self, k: &[String]) -> String {
        let pairs: Vec<String> = (self.keys.iter().zip(k).enumerate())
            .skip(1)
            .filter(|(i, _)| Some(*i) != self.facet)
            .map(|(_, (n, v))| format!("{n} = {v}"))
            .collect();
        if pairs.is_empty() {
            String::new()
        } else {
            format!(", {}", pairs.join(", "))
        }
    }
}
