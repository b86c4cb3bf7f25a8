//! The report of a results directory: `report.md` and a self-contained `report.html` (every plot
//! embedded as inline SVG, no external file or script needed) with the summary tables, each
//! figure with a caption saying what it shows, the config and its overrides, the plan (axes and
//! runs per config version) and the provenance of every version (revision, machine, GPU, time).
//! Written by [`crate::report`] after every run and by `shscale report DIR`.

use crate::error::Error;
use crate::kind::DynKind;
use crate::manifest::Manifest;
use crate::records::Results;
use shscale_files::atomic::{write_atomic, write_atomic_all};
use shscale_present::markdown::{esc, fence_for, markdown_to_html, md_cell, md_text};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The caption of a plot: the title plotters drew first in its SVG (its first `<text>`).
pub(crate) fn svg_title(svg: &str) -> Option<String> {
    let start = svg.find("<text")?;
    let open = start + svg[start..].find('>')? + 1;
    let close = open + svg[open..].find("</text>")?;
    let t = svg[open..close].trim();
    (!t.is_empty()).then(|| {
        t.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&amp;", "&")
    })
}

/// A caption for an image file without an SVG title, from its name.
fn caption_of_name(p: &Path) -> String {
    let stem = p
        .file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().to_string());
    stem.replace('_', " ")
}

/// Write `report.md` and `report.html` of `dir` from its summary text and the figure files
/// written with it; returns both paths.
pub fn write_report(dir: &Path, summary: &str, files: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let (md, html) = report_texts(dir, summary, files)?;
    let (pm, ph) = (dir.join("report.md"), dir.join("report.html"));
    write_atomic_all(&[(&pm, &md), (&ph, &html)])?;
    Ok(vec![pm, ph])
}

/// The texts of `report.md` and `report.html` ([`write_report`]), not written.
fn report_texts(dir: &Path, summary: &str, files: &[PathBuf]) -> Result<(String, String), Error> {
    let manifest = Manifest::read(dir)?;
    let mut md = String::from(summary.trim_end());
    md.push_str("\n\n## Figures\n\n");
    let figures = figures_of(files)?;
    if figures.is_empty() {
        md.push_str("No figures for these results.\n");
    }
    for (i, (cap, f, svg)) in figures.iter().enumerate() {
        md.push_str(&format!(
            "Figure {}. {cap}. File: `{}`{}.\n\n",
            i + 1,
            file_name(f),
            if svg.is_some() {
                format!(" (PNG: `{}`)", file_name(&f.with_extension("png")))
            } else {
                String::new()
            }
        ));
    }
    let versions = manifest.as_ref().map_or(&[][..], |m| &m.versions[..]);
    md.push_str(&provenance_md(versions));
    let html = report_html(summary, &md, &figures);
    Ok((md, html))
}

/// A figure of a report: its caption, its file, and its SVG text (inlined in the HTML).
type Figure = (String, PathBuf, Option<String>);

fn file_name(p: &Path) -> String {
    p.file_name()
        .map_or(String::new(), |n| n.to_string_lossy().to_string())
}

/// The figures among `files`: every SVG (captioned by its title), and PNGs without an SVG twin.
fn figures_of(files: &[PathBuf]) -> Result<Vec<Figure>, Error> {
    let mut figures: Vec<Figure> = Vec::new();
    for f in files {
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext == "svg" {
            let svg = std::fs::read_to_string(f).map_err(|e| Error::io(f, e))?;
            let cap = svg_title(&svg).unwrap_or_else(|| caption_of_name(f));
            figures.push((cap, f.clone(), Some(svg)));
        } else if ext == "png" && !files.contains(&f.with_extension("svg")) {
            figures.push((caption_of_name(f), f.clone(), None));
        }
    }
    Ok(figures)
}

/// `## Plan and provenance`: one row per config version, then the newest version's config.
fn provenance_md(versions: &[crate::manifest::Version]) -> String {
    let mut md = String::new();
    md.push_str("## Plan and provenance\n\n");
    md.push_str("| version | config | overrides | axes | runs in plan | git revision | shscale | CPU | threads | GPU | first run (UTC) | last run (UTC) |\n|---|---|---|---|---:|---|---|---|---:|---|---|---|\n");
    for v in versions {
        let p = &v.provenance;
        md.push_str(&format!(
            "| `{}` | `{}` | {} | {} | {} | `{}{}` | {} | {} | {} | {} | {} | {} |\n",
            md_cell(&v.id),
            md_cell(&v.config_file),
            if v.overrides.is_empty() {
                "—".into()
            } else {
                md_cell(&v.overrides.join(" "))
            },
            if v.axes.is_empty() {
                "—".into()
            } else {
                md_cell(&v.axes.join(", "))
            },
            v.runs_in_plan,
            md_cell(&p.git_revision),
            if p.git_dirty { "+dirty" } else { "" },
            md_cell(&p.shscale_version),
            md_cell(&p.cpu_model),
            p.threads,
            md_cell(&p.gpu_device),
            crate::manifest::iso8601_utc(v.first_unix_time),
            crate::manifest::iso8601_utc(v.last_unix_time)
        ));
    }
    if let Some(v) = versions.last() {
        let text = v.config_text.trim_end();
        let f = fence_for(text);
        md.push_str(&format!(
            "\n## Config (newest version)\n\n{f}toml\n{text}\n{f}\n"
        ));
    }
    md
}

/// The report as a self-contained page: the summary, every figure inline (SVG) or linked (PNG),
/// the plan and provenance of `md`, and a check the browser test reads.
fn report_html(summary: &str, md: &str, figures: &[Figure]) -> String {
    let name = file_name;
    let title = summary
        .lines()
        .find(|l| l.starts_with("# "))
        .map_or("shscale report".to_string(), |l| l[2..].to_string());
    let mut html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<script>window.shscaleErrors = 0; window.addEventListener('error', function () {{ window.shscaleErrors += 1; }});</script>\n<style>\nbody {{ font-family: sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }}\ntable {{ border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }}\nth, td {{ border: 1px solid #bbb; padding: 0.25em 0.5em; text-align: right; }}\nth {{ background: #eee; }}\nfigure {{ margin: 1.5em 0; }}\nfigure svg, figure img {{ max-width: 100%; height: auto; border: 1px solid #ddd; }}\nfigcaption {{ font-size: 0.9em; color: #444; }}\npre {{ background: #f6f6f6; padding: 0.75em; overflow-x: auto; }}\n</style>\n</head>\n<body>\n",
        esc(&title)
    );
    // The question and the answer, then the figures, then every run (collapsed).
    let (top, runs) = match summary.split_once(EVERY_RUN) {
        Some((top, runs)) => (top, Some(runs)),
        None => (summary, None),
    };
    html.push_str(&markdown_to_html(top));
    html.push_str("<h2>Figures</h2>\n");
    for (i, (cap, f, svg)) in figures.iter().enumerate() {
        html.push_str("<figure>\n");
        match svg {
            Some(s) => {
                let body = s.find("<svg").map_or(s.as_str(), |at| &s[at..]);
                html.push_str(body);
            }
            None => html.push_str(&format!(
                "<img src=\"{}\" alt=\"{}\">",
                esc(&name(f)),
                esc(cap)
            )),
        }
        html.push_str(&format!(
            "\n<figcaption>Figure {}. {}. File: <code>{}</code>.</figcaption>\n</figure>\n",
            i + 1,
            esc(cap),
            esc(&name(f))
        ));
    }
    if let Some(runs) = runs {
        html.push_str("<details>\n<summary>Every run: rows and notes</summary>\n");
        html.push_str(&markdown_to_html(runs));
        html.push_str("</details>\n");
    }
    let tail = md
        .split("## Plan and provenance")
        .nth(1)
        .map(|t| format!("## Plan and provenance{t}"))
        .unwrap_or_default();
    html.push_str(&markdown_to_html(&tail));
    html.push_str(
        "<p id=\"figure-check\">figures: not checked (the page's script did not run)</p>\n<script>\nwindow.addEventListener('load', function () {\n  var svgs = document.querySelectorAll('figure svg');\n  var ok = 0;\n  svgs.forEach(function (s) { var r = s.getBoundingClientRect(); if (r.width > 0 && r.height > 0 && s.querySelector('text')) { ok += 1; } });\n  document.getElementById('figure-check').textContent = 'figures: ' + ok + ' of ' + svgs.length + ' rendered, ' + window.shscaleErrors + ' script errors';\n});\n</script>\n</body>\n</html>\n",
    );
    html
}

/// What [`report`] wrote: the summary text, the kind's discussion in it, and the files.
pub struct Report {
    pub summary: String,
    pub discussion: String,
    pub files: Vec<PathBuf>,
}

/// The summary table and the kind's plots of a results directory's `runs.csv`: one line per
/// run, with every parameter that varies in the CSV and the kind's headline columns. All or
/// nothing: every file (plots, summary, reports) is written to a staging folder first and moved
/// into `dir` only when all succeeded, so a failing report changes no file there.
pub fn report(kind: &dyn DynKind, dir: &Path) -> Result<Report, Error> {
    let staging = shscale_files::atomic::Staging::new(dir)?;
    let staged = report_staged(kind, dir, &staging)?;
    commit_report(staging, staged)
}

/// Rows of another kind than the manifest names: said so, naming both files (they once read as
/// a plot without data).
/// "## The answer": the kind's verdict table ([`crate::kind::Kind::verdict`]), at most
/// [`MAX_VERDICT_LINES`] lines (a longer one is the kind's error); empty without one.
fn answer_section(kind: &dyn DynKind, t: &Results) -> Result<String, Error> {
    let verdict = kind.verdict(t)?;
    let verdict = verdict.trim_end();
    if verdict.trim().is_empty() {
        return Ok(String::new());
    }
    let lines = verdict.lines().count();
    if lines > MAX_VERDICT_LINES {
        return Err(Error::Kind(
            format!(
                "kind {}'s verdict table has {lines} lines, more than the {MAX_VERDICT_LINES} a summary opens with",
                kind.name()
            )
            .into(),
        ));
    }
    let busy = match t.col("contended") {
        Some(c) if !kind.time_columns().is_empty() => {
            let n = t.rows.iter().filter(|r| r[c] == "true").count();
            format!(
                "\n\nTimed on a busy machine: {n} of the {} rows behind the equal-time columns and the speed/accuracy (Pareto) front (`contended`; docs/provenance.md){}.",
                t.rows.len(),
                if n > 0 { " — their times are not comparable; rerun them on a quiet machine" } else { "" }
            )
        }
        _ => String::new(),
    };
    Ok(format!("## The answer\n\n{verdict}{busy}\n\n"))
}

/// A parameter the kind gained after these rows were written (`sphere_order`, say) is read as
/// its default, the value that reproduces the runs made before it existed (a kind adds a
/// parameter only with such a default); it is added as a column of `t`, the file is not
/// touched. Only when the rows hold some of the kind's parameters: rows of another kind are
/// still refused by [`check_kind`].
fn fill_added_parameters(kind: &dyn DynKind, t: &mut Results) {
    let params = kind.param_columns();
    if !params.iter().any(|p| t.col(p).is_some()) {
        return;
    }
    for (key, default) in kind.defaults() {
        if t.col(&key).is_none() {
            t.columns.push(key);
            for row in &mut t.rows {
                row.push(default.clone());
            }
        }
    }
}

fn check_kind(kind: &dyn DynKind, dir: &Path, t: &Results) -> Result<(), Error> {
    let missing: Vec<String> = (kind.param_columns().into_iter())
        .chain(kind.row_columns())
        .filter(|c| t.col(c).is_none())
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(Error::Io {
        path: dir.join("manifest.toml").display().to_string(),
        reason: format!(
            "names experiment {:?}, but {} lacks its column(s) {}: rows of another kind",
            kind.name(),
            dir.join("runs.csv").display(),
            missing
                .iter()
                .take(5)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        ),
    })
}

/// Move a staged report ([`report_staged`]) into its folder, with the other staged files, and
/// remove a `discussion.md` of an earlier, longer discussion that the summary now holds whole.
pub fn commit_report(
    staging: shscale_files::atomic::Staging,
    staged: Report,
) -> Result<Report, Error> {
    let out = staging.target(staging.path());
    // The plots an earlier report wrote and this one does not (an interim report drew the error
    // against the radius before the swept parameter varied, say) are removed after the commit:
    // a stale plot never sits beside the current ones.
    let record = out.join(REPORT_FILES);
    let earlier: Vec<String> = match std::fs::symlink_metadata(&record) {
        Ok(m) if m.is_file() => std::fs::read_to_string(&record)
            .map_err(|e| Error::io(&record, e))?
            .lines()
            .map(str::to_string)
            .collect(),
        _ => Vec::new(),
    };
    let names: Vec<String> = (staged.files.iter())
        .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().to_string()))
        .filter(|n| n != "runs.csv" && n != "manifest.toml")
        .collect();
    let staged_record = staging.path().join(REPORT_FILES);
    write_atomic(&staged_record, &(names.join("\n") + "\n"))?;
    let files = staging.commit(&staged.files)?;
    for name in earlier.iter().filter(|n| !names.contains(n)) {
        // Only plain file names this report itself recorded, never a path.
        let stale = out.join(name);
        let plain = !name.is_empty() && !name.contains(['/', '\\']) && !name.starts_with('.');
        if plain && std::fs::symlink_metadata(&stale).is_ok_and(|m| m.is_file()) {
            std::fs::remove_file(&stale).map_err(|e| Error::io(&stale, e))?;
        }
    }
    let full = out.join("discussion.md");
    if staged.discussion.len() <= MAX_DISCUSSION_BYTES && full.exists() {
        std::fs::remove_file(&full).map_err(|e| Error::io(&full, e))?;
    }
    Ok(Report { files, ..staged })
}

/// The file in a results directory listing what its last report wrote (hidden), so the next
/// report removes what it no longer writes.
pub(crate) const REPORT_FILES: &str = ".report-files";

/// [`report`] of the rows and manifest in `dir`, written into `staging` (named after the
/// staging's target, not the staging folder); nothing moves until [`commit_report`].
pub fn report_staged(
    kind: &dyn DynKind,
    dir: &Path,
    staging: &shscale_files::atomic::Staging,
) -> Result<Report, Error> {
    let csv = dir.join("runs.csv");
    let mut t = Results::read(&csv)?;
    fill_added_parameters(kind, &mut t);
    check_kind(kind, dir, &t)?;
    let varying = t.varying(&kind.param_columns());
    let mut s = summary_head(kind, (dir, staging), &t, &varying);
    let notes = crate::manifest::row_notes(&t, !kind.time_columns().is_empty());
    if !notes.is_empty() {
        s.push_str(&format!("**Provenance.** {}\n\n", notes.join(" ")));
    }
    // The answer first: the kind's discussion of its claim, and the best configuration per row
    // key; every run's row after it (collapsed in the HTML, after the figures).
    s.push_str(&answer_section(kind, &t)?);
    let discussion = kind.discussion(&t)?;
    let out = staging.path();
    if !discussion.trim().is_empty() {
        let (shown, cut) = cap_lines(discussion.trim_end(), MAX_DISCUSSION_BYTES);
        s.push_str(&format!("## Our numbers against the claim\n\n{shown}\n"));
        if cut > 0 {
            s.push_str(&format!(
                "\n… {cut} more line(s) of the discussion (one per run) are in `discussion.md`.\n"
            ));
        }
    }
    if let Some((key, metric)) = kind.best_of() {
        s.push_str(&best_table(&t, &varying, key, metric));
    }
    s.push_str(&format!("\n{EVERY_RUN}\n\n"));
    s.push_str(&every_run(kind, &t, &varying));
    // The kind's figures first (each written as a unit); the texts that describe them — summary,
    // discussion, report.md and report.html — only when every figure succeeded, together.
    let figures = kind.report(out, &t)?;
    t.check_read(&format!("the report of kind {}", kind.name()))?;
    let (md, html) = report_texts(dir, &s, &figures)?;
    let p = out.join("summary.md");
    let (pm, ph, full) = (
        out.join("report.md"),
        out.join("report.html"),
        out.join("discussion.md"),
    );
    let long = format!("# Our numbers against the claim\n\n{discussion}");
    let schema_path = out.join("runs.schema.json");
    let schema = crate::schema::schema_json(kind);
    let mut texts: Vec<(&Path, &str)> =
        vec![(&p, &s), (&pm, &md), (&ph, &html), (&schema_path, &schema)];
    if discussion.len() > MAX_DISCUSSION_BYTES {
        texts.push((&full, &long));
    }
    write_atomic_all(&texts)?;
    let mut files: Vec<PathBuf> = texts.iter().map(|(f, _)| f.to_path_buf()).collect();
    files.extend(figures);
    Ok(Report {
        summary: s,
        discussion,
        files,
    })
}

/// A summary's head: the experiment's title, kind and folder, its claim and question, the
/// rows' count and the parameters that vary.
fn summary_head(
    kind: &dyn DynKind,
    (dir, staging): (&Path, &shscale_files::atomic::Staging),
    t: &Results,
    varying: &[String],
) -> String {
    let (title, claim) = title_and_claim(dir);
    format!(
        "# {}{} — {}\n\n{}{}\n\nRows: {} in `runs.csv`; parameters that vary: {}.\n\n",
        title.map_or(String::new(), |t| format!("{}\n\nExperiment ", md_text(&t))),
        kind.name(),
        md_text(
            &staging
                .target(dir)
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().to_string())
        ),
        claim.map_or(String::new(), |c| format!(
            "**Claim.** {}\n\n**Question.** ",
            md_text(c.trim())
        )),
        kind.question(),
        t.rows.len(),
        if varying.is_empty() {
            "none".to_string()
        } else {
            varying.join(", ")
        }
    )
}

/// The per-run section of a summary: every row (or, beyond `MAX_LISTED_ROWS`, the distributions)
/// in the run id, the varying parameters and the kind's headline columns; a headline column
/// empty in every row (the on-surface error of a run without on-surface samples, say) left out
/// and named; the rows timed concurrently counted.
fn every_run(kind: &dyn DynKind, t: &Results, varying: &[String]) -> String {
    let mut s = String::new();
    let mut cols: Vec<String> = std::iter::once("run_id".to_string())
        .chain(varying.iter().cloned())
        .collect();
    let mut empty = Vec::new();
    for c in kind.summary_columns() {
        if cols.iter().any(|x| x == c) {
            continue;
        }
        if t.col(c).is_some()
            && (0..t.rows.len()).all(|r| t.cell(r, c).is_empty())
            && !t.rows.is_empty()
        {
            empty.push(format!("`{c}`"));
        } else {
            cols.push(c.to_string());
        }
    }
    if !empty.is_empty() {
        s.push_str(&format!(
            "Left out of the table, empty in every row: {}.\n\n",
            empty.join(", ")
        ));
    }
    if t.rows.len() <= MAX_LISTED_ROWS {
        s.push_str(&row_table(t, &cols, 1 + varying.len()));
    } else {
        s.push_str(&distribution_tables(t, varying, kind.summary_columns()));
    }
    let concurrent = (0..t.rows.len())
        .filter(|&r| t.cell(r, "timing_concurrent") == "true")
        .count();
    if concurrent > 0 {
        s.push_str(&format!(
            "\n{concurrent} row(s) were timed while other runs executed (`timing_concurrent`): their times are not comparable and are left out of speed plots.\n"
        ));
    }
    s
}

/// The heading of the per-run section of a summary; `report.html` shows what follows it
/// collapsed, after the figures.
pub(crate) const EVERY_RUN: &str = "## Every run";

/// `## Best per <key>`: for each value of the row key, the row with the lowest `metric` and the
/// varying parameters that gave it (empty when the table lacks either column).
fn best_table(t: &Results, varying: &[String], key: &str, metric: &str) -> String {
    if t.col(key).is_none() || t.col(metric).is_none() || t.rows.is_empty() {
        return String::new();
    }
    let mut best: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for r in 0..t.rows.len() {
        let v = t.num(r, metric);
        if !v.is_finite() {
            continue;
        }
        let e = best.entry(t.cell(r, key).to_string()).or_insert((v, r));
        if v < e.0 {
            *e = (v, r);
        }
    }
    if best.is_empty() {
        return String::new();
    }
    let mut keys: Vec<&String> = best.keys().collect();
    keys.sort_by(|a, b| crate::records::cmp_cells(a, b));
    let params: Vec<&String> = varying.iter().filter(|c| *c != key).collect();
    // The spread over the row's samples beside the mean, when the rows carry it.
    let iqr = metric
        .strip_suffix("_mean")
        .map(|b| (format!("{b}_p25"), format!("{b}_p75")));
    let iqr = iqr.filter(|(lo, hi)| t.col(lo).is_some() && t.col(hi).is_some());
    let mut md = format!(
        "\n## Best per {key}\n\nThe lowest `{metric}` at each `{key}`, and the parameters that gave it.\n\n| {key} | {metric} |{}{}\n|---|---|{}{}\n",
        if iqr.is_some() { " p25 – p75 |" } else { "" },
        params.iter().map(|p| format!(" {p} |")).collect::<String>(),
        if iqr.is_some() { "---|" } else { "" },
        "---|".repeat(params.len())
    );
    for k in keys {
        let (v, r) = best[k];
        let spread = iqr.as_ref().map_or(String::new(), |(lo, hi)| {
            format!(
                " {} – {} |",
                summary_decimal(t.num(r, lo)),
                summary_decimal(t.num(r, hi))
            )
        });
        md.push_str(&format!(
            "| {} | {} |{spread}{}\n",
            md_cell(k),
            summary_decimal(v),
            params
                .iter()
                .map(|p| format!(" {} |", md_cell(t.cell(r, p))))
                .collect::<String>()
        ));
    }
    md
}

/// The most lines of a kind's verdict table ([`crate::kind::Kind::verdict`]): the answer that
/// opens a summary stays on its first screen.
pub const MAX_VERDICT_LINES: usize = 20;

/// The most bytes of a kind's discussion the summary (and so `report.html`) holds: a longer
/// one — a sentence per run at 10⁵ runs is megabytes — is cut at a line and written whole to
/// `discussion.md`.
pub(crate) const MAX_DISCUSSION_BYTES: usize = 32 * 1024;

/// The first lines of `text` within `max` bytes (at least one line), and how many were left out.
/// The cut is at a line end, never inside a character: `max` is first moved down to a character
/// boundary (a multi-byte character straddling it, the kinds' own "α = 45°" say, once panicked).
fn cap_lines(text: &str, max: usize) -> (&str, usize) {
    if text.len() <= max {
        return (text, 0);
    }
    let mut max = max;
    while !text.is_char_boundary(max) {
        max -= 1;
    }
    let end = text[..max]
        .rfind('\n')
        .unwrap_or_else(|| text.find('\n').unwrap_or(text.len()));
    let shown = &text[..end];
    (
        shown,
        text[end..].lines().filter(|l| !l.trim().is_empty()).count(),
    )
}

/// The most rows the summary lists one by one; a larger table is summarised by distributions
/// ([`distribution_tables`]), so `summary.md` and `report.html` stay small at 10⁵ rows.
pub const MAX_LISTED_ROWS: usize = 200;

/// The most values of one parameter the distribution tables list; a parameter with more is
/// summarised over all rows only.
pub const MAX_LISTED_VALUES: usize = 24;

/// A summary cell: small numbers in `e` notation, other decimals to four places.
fn summary_cell(v: &str) -> String {
    match v.parse::<f64>() {
        Ok(x) if v.contains('.') || v.contains('e') => summary_decimal(x),
        _ => v.to_string(),
    }
}

/// A real number of the summary: below 10⁻³ (and not 0) in `e` notation, else four decimals.
fn summary_decimal(x: f64) -> String {
    if x != 0.0 && x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// Every row, the columns `cols`: the first `params` (the run id and the parameters) as the
/// config wrote them (α = 60.0, not 60.0000), the metrics as summary numbers.
fn row_table(t: &Results, cols: &[String], params: usize) -> String {
    let mut s = format!("| {} |\n|{}\n", cols.join(" | "), "---|".repeat(cols.len()));
    for r in 0..t.rows.len() {
        let cells: Vec<String> = (cols.iter().enumerate())
            .map(|(i, c)| {
                let v = t.cell(r, c);
                md_cell(&if i < params {
                    v.to_string()
                } else {
                    summary_cell(v)
                })
            })
            .collect();
        s.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    s
}

/// Count, mean and the 10th, 50th and 90th percentiles of the finite values (nearest rank).
fn distribution(mut v: Vec<f64>) -> Option<(usize, f64, f64, f64, f64)> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    Some((v.len(), mean, q(0.1), q(0.5), q(0.9)))
}

/// The rows summarised: for every numeric headline column, its distribution over all rows and,
/// per varying parameter with at most [`MAX_LISTED_VALUES`] values, per value of it.
fn distribution_tables(t: &Results, varying: &[String], headline: &[&str]) -> String {
    let numeric: Vec<&str> = (headline.iter().copied())
        .filter(|c| (0..t.rows.len()).any(|r| t.num(r, c).is_finite()))
        .collect();
    let mut s = format!(
        "{} rows are too many to list (more than {MAX_LISTED_ROWS}); `runs.csv` has them all. The headline columns' distributions \
(count of finite values, mean, 10th / 50th / 90th percentile):\n\n",
        t.rows.len()
    );
    let head = "| column | count | mean | p10 | median | p90 |\n|---|---:|---:|---:|---:|---:|\n";
    let fmt = summary_decimal;
    let line = |label: &str, rows: &[usize], c: &str| {
        let d = distribution(rows.iter().map(|&r| t.num(r, c)).collect());
        d.map_or(
            format!("| {label} | 0 | — | — | — | — |\n"),
            |(n, m, a, b, z)| {
                format!(
                    "| {label} | {n} | {} | {} | {} | {} |\n",
                    fmt(m),
                    fmt(a),
                    fmt(b),
                    fmt(z)
                )
            },
        )
    };
    let all: Vec<usize> = (0..t.rows.len()).collect();
    s.push_str("All rows:\n\n");
    s.push_str(head);
    for c in &numeric {
        s.push_str(&line(c, &all, c));
    }
    for p in varying {
        let values = t.distinct(p);
        if values.len() > MAX_LISTED_VALUES {
            s.push_str(&format!(
                "\n`{p}` takes {} values (more than {MAX_LISTED_VALUES}): see the plots and `runs.csv`.\n",
                values.len()
            ));
            continue;
        }
        for c in &numeric {
            s.push_str(&format!("\n`{c}` by `{p}`:\n\n| {p} | count | mean | p10 | median | p90 |\n|---|---:|---:|---:|---:|---:|\n"));
            for v in &values {
                let rows: Vec<usize> = all.iter().copied().filter(|&r| t.cell(r, p) == v).collect();
                s.push_str(&line(&md_cell(v), &rows, c));
            }
        }
    }
    s
}

/// `title` and `claim` of the newest config version in `dir/manifest.toml`.
pub fn title_and_claim(dir: &Path) -> (Option<String>, Option<String>) {
    let Some(text) = Manifest::read(dir)
        .ok()
        .flatten()
        .and_then(|m| m.versions.last().map(|v| v.config_text.clone()))
    else {
        return (None, None);
    };
    let t: toml::Table = toml::from_str(&text).unwrap_or_default();
    let get = |k: &str| t.get(k).and_then(|v| v.as_str()).map(String::from);
    (get("title"), get("claim"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cut at every byte of text made of multi-byte characters (2-, 3- and 4-byte ones) and
    /// lines: never a panic, always whole lines within the cap (at least one), the count of the
    /// lines left out exact.
    #[test]
    fn capped_discussions_cut_at_lines_never_inside_a_character() {
        let lines: Vec<String> = (0..40)
            .map(|i| format!("run {i}: α = 45.0°, ∑ = {}, 🦆 ok", i * 7))
            .collect();
        let text = lines.join("\n");
        for max in 0..=text.len() + 1 {
            let (shown, cut) = cap_lines(&text, max);
            let n = shown.lines().count();
            assert!(text.starts_with(shown), "max {max}");
            assert!(n >= 1 && n + cut == lines.len(), "max {max}: {n} + {cut}");
            assert!(
                shown.len() <= max || n == 1,
                "max {max}: {} bytes",
                shown.len()
            );
        }
    }

    #[test]
    fn svg_titles() {
        assert_eq!(
            svg_title("<?xml?><svg><rect/><text x=\"1\">error &amp; k</text><text>y</text></svg>")
                .as_deref(),
            Some("error & k")
        );
        assert_eq!(svg_title("<svg></svg>"), None);
    }
}
