//! `shscale plot` (and Python's `plot`): any column of a results table against another, from the
//! rows alone — the rows that pass the `--where` filters, a series per combination of the
//! `--series` columns (or of every other varying parameter), a panel per `--facet` value, the
//! interquartile band where the table has it; a line through rows that differ in a parameter at
//! one x refused; the file named by every selecting argument. Drawn by [`crate::plots`].

use crate::error::Error;
use crate::plots::Table;
use crate::plots::{stem_part, words, write_panels, Bands, Panel, MAX_PANELS};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What `shscale plot` draws: `metric` against `x`, one series per combination of the `series`
/// columns, one panel per value of `facet`, over the rows that match every `filters` pair.
pub struct PlotSpec<'a> {
    pub metric: &'a str,
    pub x: &'a str,
    /// Series columns (empty: every other varying key, faceting by the probe radius or the key
    /// with the most values when that would make more than [`MAX_SERIES_PER_PANEL`] series).
    pub series: &'a [String],
    pub facet: Option<&'a str>,
    /// `(column, value)`: keep rows whose cell is the value (numbers compared as numbers).
    pub filters: &'a [(String, String)],
    /// Forced linear (`Some(false)`) or log (`Some(true)`) y; `None` decides by the data.
    pub log_y: Option<bool>,
    pub log_x: bool,
    /// The file stem and the title, when not the default `plot_<metric>_vs_<x>[_by_<facet>]`
    /// and "<metric> against <x>".
    pub stem: Option<&'a str>,
    pub title: Option<&'a str>,
}

/// The most series a default plot puts in one panel before it facets.
pub const MAX_SERIES_PER_PANEL: usize = 8;

/// `shscale plot`: [`PlotSpec`] drawn from a results table into `dir` as
/// `plot_<metric>_vs_<x>[_by_<facet>].png/.svg`. `keys` are the columns that tell rows apart
/// (the kind's parameters and its row key, e.g. the probe radius): when two rows of one series
/// and panel share an x value but differ in a key, the line would zigzag between them, and the
/// plot is refused naming that key. A `*_mean` metric with `*_p25` and `*_p75` columns gets its
/// interquartile band. Rows whose cells are not numbers are left out.
pub fn plot_column(
    dir: &Path,
    t: &Table,
    keys: &[String],
    spec: &PlotSpec,
) -> Result<Vec<PathBuf>, Error> {
    let (metric, x) = (spec.metric, spec.x);
    check_columns(dir, t, spec)?;
    let rows = plot_rows(dir, t, spec)?;
    let distinct = |c: &str| t.distinct_in(rows.iter().copied(), c);
    let varying: Vec<String> = (keys.iter())
        .filter(|k| t.col(k).is_some() && distinct(k).len() > 1)
        .cloned()
        .collect();
    let (series, facet) = series_and_facet(t, &rows, &varying, spec);
    check_zigzag(t, &rows, &series, facet.as_deref(), &varying, x)?;
    let base = metric.strip_suffix("_mean");
    let band_cols = base.map(|b| (format!("{b}_p25"), format!("{b}_p75")));
    let band_cols = band_cols.filter(|(lo, hi)| t.col(lo).is_some() && t.col(hi).is_some());
    let facets: Vec<Option<String>> = match &facet {
        Some(c) => distinct(c).into_iter().map(Some).collect(),
        None => vec![None],
    };
    if facets.len() > MAX_PANELS {
        return Err(Error::Config(format!(
            "--facet {}: {} values, more than the {MAX_PANELS} panels a figure draws; filter with --where",
            facet.unwrap_or_default(),
            facets.len()
        )));
    }
    let panels: Vec<Panel> = (facets.iter())
        .map(|fv| {
            let keep: Vec<usize> = (rows.iter().copied())
                .filter(|&r| match (&facet, fv) {
                    (Some(c), Some(v)) => t.cell(r, c) == v,
                    _ => true,
                })
                .collect();
            let title = match (&facet, fv) {
                (Some(c), Some(v)) => format!("{} = {v}", words(c)),
                _ => String::new(),
            };
            panel_of(t, &keep, &series, spec, band_cols.as_ref(), title)
        })
        .collect();
    let mut title = spec.title.map_or_else(
        || format!("{} against {}", words(metric), words(x)),
        str::to_string,
    );
    if band_cols.is_some() {
        title.push_str(" (band: interquartile range over probes)");
    }
    let stem = spec
        .stem
        .map_or_else(|| plot_stem(spec, facet.as_deref()), str::to_string);
    write_panels(
        dir,
        &stem,
        &title,
        &words(x),
        &words(metric),
        &panels,
        spec.log_y,
        spec.log_x,
    )
}

/// A plot's file name: every argument that selects what is drawn (facet, series, filters) is in
/// it, so two plots of different rows or series never overwrite each other.
fn plot_stem(spec: &PlotSpec, facet: Option<&str>) -> String {
    let mut stem = format!("plot_{}_vs_{}", stem_part(spec.metric), stem_part(spec.x));
    if let Some(f) = facet {
        stem.push_str(&format!("_by_{}", stem_part(f)));
    }
    if !spec.series.is_empty() {
        let s: Vec<String> = spec.series.iter().map(|c| stem_part(c)).collect();
        stem.push_str(&format!("_series_{}", s.join("-")));
    }
    for (k, v) in spec.filters {
        stem.push_str(&format!("_where_{}-{}", stem_part(k), stem_part(v)));
    }
    stem
}

/// Every column a plot names exists, or an error naming it and listing the columns.
fn check_columns(dir: &Path, t: &Table, spec: &PlotSpec) -> Result<(), Error> {
    let named = [spec.metric, spec.x]
        .into_iter()
        .chain(spec.series.iter().map(String::as_str))
        .chain(spec.facet)
        .chain(spec.filters.iter().map(|(k, _)| k.as_str()));
    for c in named {
        if t.col(c).is_none() {
            return Err(Error::Config(format!(
                "{c:?} is not a column of {} (columns: {})",
                dir.join("runs.csv").display(),
                t.columns.join(", ")
            )));
        }
    }
    Ok(())
}

/// The rows a plot draws: those passing its `--where` filters (cells equal as text or as
/// numbers) with numbers in both the metric and x; an error saying which when none.
fn plot_rows(dir: &Path, t: &Table, spec: &PlotSpec) -> Result<Vec<usize>, Error> {
    let (metric, x) = (spec.metric, spec.x);
    if t.rows.is_empty() {
        return Err(Error::Config(format!(
            "{} has no rows (its header alone): nothing to plot",
            dir.join("runs.csv").display()
        )));
    }
    let same = |cell: &str, want: &str| {
        cell == want
            || matches!((cell.parse::<f64>(), want.parse::<f64>()), (Ok(a), Ok(b)) if a == b)
    };
    let rows: Vec<usize> = (0..t.rows.len())
        .filter(|&r| spec.filters.iter().all(|(k, v)| same(t.cell(r, k), v)))
        .filter(|&r| t.num(r, x).is_finite() && t.num(r, metric).is_finite())
        .collect();
    if !rows.is_empty() {
        return Ok(rows);
    }
    let filters: Vec<String> = (spec.filters.iter())
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    Err(Error::Config(if filters.is_empty() {
        format!("no row has numbers in both {metric:?} and {x:?}")
    } else {
        format!(
            "no row matches --where {} with numbers in both {metric:?} and {x:?}",
            filters.join(" --where ")
        )
    }))
}

/// Series and facet: as asked, or every other varying key, faceted (by the radius where it
/// varies, else the key with the most values that fits) when the series would be too many.
fn series_and_facet(
    t: &Table,
    rows: &[usize],
    varying: &[String],
    spec: &PlotSpec,
) -> (Vec<String>, Option<String>) {
    let distinct = |c: &str| t.distinct_in(rows.iter().copied(), c);
    let mut facet = spec.facet.map(str::to_string);
    let mut series: Vec<String> = if spec.series.is_empty() {
        (varying.iter())
            .filter(|c| *c != spec.x && *c != spec.metric && Some(c.as_str()) != spec.facet)
            .cloned()
            .collect()
    } else {
        spec.series.to_vec()
    };
    let combos = |cols: &[String]| -> usize {
        let mut seen: Vec<Vec<&str>> = rows
            .iter()
            .map(|&r| cols.iter().map(|c| t.cell(r, c)).collect())
            .collect();
        seen.sort();
        seen.dedup();
        seen.len()
    };
    if spec.series.is_empty() && facet.is_none() && combos(&series) > MAX_SERIES_PER_PANEL {
        let pick = (series.iter())
            .filter(|c| distinct(c).len() <= MAX_PANELS)
            .max_by_key(|c| (c.as_str() == "radius", distinct(c).len()))
            .cloned();
        if let Some(f) = pick {
            series.retain(|c| *c != f);
            facet = Some(f);
        }
    }
    (series, facet)
}

/// A key that varies within one series and panel at one x makes a zigzag: refused, naming it.
fn check_zigzag(
    t: &Table,
    rows: &[usize],
    series: &[String],
    facet: Option<&str>,
    varying: &[String],
    x: &str,
) -> Result<(), Error> {
    let mut at: BTreeMap<(String, String, String), usize> = BTreeMap::new();
    for &r in rows {
        let label: Vec<&str> = series.iter().map(|c| t.cell(r, c)).collect();
        let f = facet.map_or("", |c| t.cell(r, c));
        let k = (
            f.to_string(),
            label.join("\u{1f}"),
            t.cell(r, x).to_string(),
        );
        if let Some(&first) = at.get(&k) {
            let differ: Vec<&String> = (varying.iter())
                .filter(|c| t.cell(r, c) != t.cell(first, c))
                .collect();
            if let Some(c) = differ.first() {
                return Err(Error::Config(format!(
                    "--x {x}: rows of one series differ in {c:?} at the same x ({x} = {}: {c} = {} and {}), which would draw a zigzag; add --series {c}, --facet {c} or --where {c}=VALUE",
                    t.cell(r, x),
                    t.cell(first, c),
                    t.cell(r, c)
                )));
            }
        } else {
            at.insert(k, r);
        }
    }
    Ok(())
}

/// One panel of `rows`: a line per series label, and the interquartile band where the table
/// has the metric's `_p25`/`_p75` columns.
fn panel_of(
    t: &Table,
    rows: &[usize],
    series: &[String],
    spec: &PlotSpec,
    band_cols: Option<&(String, String)>,
    title: String,
) -> Panel {
    let mut by: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut bands = Bands::new();
    for &r in rows {
        let label = if series.is_empty() {
            words(spec.metric)
        } else {
            (series.iter())
                .map(|g| format!("{} = {}", words(g), t.cell(r, g)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let xv = t.num(r, spec.x);
        by.entry(label.clone())
            .or_default()
            .push((xv, t.num(r, spec.metric)));
        if let Some((lo, hi)) = band_cols {
            let (l, h) = (t.num(r, lo), t.num(r, hi));
            if l.is_finite() && h.is_finite() {
                bands.entry(label).or_default().push((xv, l, h));
            }
        }
    }
    Panel {
        title,
        series: by,
        bands,
        scatter: false,
    }
}
