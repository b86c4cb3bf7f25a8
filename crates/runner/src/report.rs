//! The report of a results directory: `report.md` and a self-contained `report.html` (every plot
//! embedded as inline SVG, no external file or script needed) with the summary tables, each
//! figure with a caption saying what it shows, the config and its overrides, the plan (axes and
//! runs per config version) and the provenance of every version (revision, machine, GPU, time).
//! Written by [`crate::report`] after every run and by `shscale report DIR`.

use crate::atomic::{write_atomic, write_atomic_all};
use crate::error::Error;
use crate::kind::DynKind;
use crate::manifest::Manifest;
use crate::records::Results;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Escape text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Text from data (a cell of the CSV, a path, a config's title or claim) as Markdown text that
/// shows it as it is: `&`, `<`, `>` as entities (no raw HTML reaches `summary.md`), `\`, `|`,
/// `` ` `` and `*` escaped (no table cell is split, no code span or emphasis opened), and every
/// control character — a newline that would forge a table row, ESC, BEL, CR — written as its
/// escape (`\u{1b}`).
pub fn md_text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '\\' | '|' | '`' | '*' => {
                out.push('\\');
                out.push(c);
            }
            c if c.is_control() => out.push_str(&c.escape_unicode().to_string()),
            c => out.push(c),
        }
    }
    out
}

/// A cell of a Markdown table: [`md_text`] of the value.
fn md_cell(s: &str) -> String {
    md_text(s)
}

/// Inline Markdown of the summaries: `**bold**` and `` `code` ``, escaped; the escapes of
/// [`md_text`] (`\|`, `&lt;`, …) shown as the characters they stand for.
fn inline(s: &str) -> String {
    let mut out = String::new();
    let (mut bold, mut code) = (false, false);
    let mut rest = s;
    while !rest.is_empty() {
        if let Some((c, n)) = md_escape(rest) {
            out.push_str(&esc(&c.to_string()));
            rest = &rest[n..];
        } else if !code && rest.starts_with("**") {
            out.push_str(if bold { "</strong>" } else { "<strong>" });
            bold = !bold;
            rest = &rest[2..];
        } else if rest.starts_with('`') {
            out.push_str(if code { "</code>" } else { "<code>" });
            code = !code;
            rest = &rest[1..];
        } else {
            let c = rest.chars().next().unwrap_or(' ');
            out.push_str(&esc(&c.to_string()));
            rest = &rest[c.len_utf8()..];
        }
    }
    if code {
        out.push_str("</code>");
    }
    if bold {
        out.push_str("</strong>");
    }
    out
}

/// The character an escape of [`md_text`] at the start of `s` stands for, and the escape's length.
fn md_escape(s: &str) -> Option<(char, usize)> {
    for (e, c) in [("&amp;", '&'), ("&lt;", '<'), ("&gt;", '>')] {
        if s.starts_with(e) {
            return Some((c, e.len()));
        }
    }
    let mut it = s.chars();
    match (it.next(), it.next()) {
        (Some('\\'), Some(c @ ('\\' | '|' | '`' | '*'))) => Some((c, 1 + c.len_utf8())),
        _ => None,
    }
}

/// The cells of a Markdown table row: split at every `|` not escaped by `\`.
fn table_cells(row: &str) -> Vec<String> {
    let row = row.trim();
    let row = row.strip_prefix('|').unwrap_or(row);
    let mut cells: Vec<String> = Vec::new();
    let mut cell = String::new();
    let mut chars = row.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => {
                cell.push(c);
                cell.extend(chars.next());
            }
            '|' => cells.push(std::mem::take(&mut cell)),
            c => cell.push(c),
        }
    }
    cells.push(cell);
    // The closing `|` leaves an empty last cell.
    if cells.len() > 1 && cells.last().is_some_and(|l| l.trim().is_empty()) {
        cells.pop();
    }
    cells.into_iter().map(|c| c.trim().to_string()).collect()
}

/// A code fence for `text`: three backticks, or one more than the longest run of backticks in
/// it, so no line of the text closes the block (CommonMark).
fn fence_for(text: &str) -> String {
    let mut longest = 0;
    let mut run = 0;
    for c in text.chars() {
        run = if c == '`' { run + 1 } else { 0 };
        longest = longest.max(run);
    }
    "`".repeat((longest + 1).max(3))
}

/// The Markdown the summaries use — headings, paragraphs, pipe tables, fenced code — as HTML.
pub fn markdown_to_html(md: &str) -> String {
    let mut html = String::new();
    let mut para: Vec<&str> = Vec::new();
    let mut table: Vec<Vec<String>> = Vec::new();
    // An open fence: its backtick count (a line of at least as many backticks closes it).
    let mut fence: Option<(usize, Vec<&str>)> = None;
    let ticks = |l: &str| l.chars().take_while(|c| *c == '`').count();
    for line in md.lines() {
        if let Some((n, block)) = fence.as_mut() {
            if ticks(line) >= *n && line.trim().chars().all(|c| c == '`') {
                html.push_str(&format!("<pre>{}</pre>\n", esc(&block.join("\n"))));
                fence = None;
            } else {
                block.push(line);
            }
            continue;
        }
        let t = line.trim();
        if ticks(t) >= 3 {
            flush_para(&mut para, &mut html);
            flush_table(&mut table, &mut html);
            fence = Some((ticks(t), Vec::new()));
        } else if t.starts_with('|') {
            flush_para(&mut para, &mut html);
            let cells = table_cells(t);
            // The separator row (|---|---:|).
            let rule = |c: &String| c.contains('-') && c.chars().all(|ch| "-: ".contains(ch));
            if !cells.iter().all(rule) {
                table.push(cells);
            }
        } else if t.is_empty() {
            flush_para(&mut para, &mut html);
            flush_table(&mut table, &mut html);
        } else if let Some(level) = (1..=3).find(|&l| t.starts_with(&format!("{} ", "#".repeat(l))))
        {
            flush_para(&mut para, &mut html);
            flush_table(&mut table, &mut html);
            html.push_str(&format!(
                "<h{level}>{}</h{level}>\n",
                inline(&t[level + 1..])
            ));
        } else {
            flush_table(&mut table, &mut html);
            para.push(t);
        }
    }
    flush_para(&mut para, &mut html);
    flush_table(&mut table, &mut html);
    if let Some((_, block)) = fence {
        html.push_str(&format!("<pre>{}</pre>\n", esc(&block.join("\n"))));
    }
    html
}

/// A paragraph of [`markdown_to_html`] into `html`, or a list when its lines start with "- "
/// (each such line an item; other lines continue the item before them); `para` emptied.
fn flush_para(para: &mut Vec<&str>, html: &mut String) {
    if para.is_empty() {
        return;
    }
    if para[0].starts_with("- ") {
        let mut items: Vec<String> = Vec::new();
        for l in para.iter() {
            match l.strip_prefix("- ") {
                Some(item) => items.push(item.to_string()),
                None => {
                    if let Some(last) = items.last_mut() {
                        last.push(' ');
                        last.push_str(l);
                    }
                }
            }
        }
        html.push_str("<ul>\n");
        for i in items {
            html.push_str(&format!("<li>{}</li>\n", inline(&i)));
        }
        html.push_str("</ul>\n");
    } else {
        html.push_str(&format!("<p>{}</p>\n", inline(&para.join(" "))));
    }
    para.clear();
}

/// A table of [`markdown_to_html`] into `html` (the first row the header); `table` emptied.
fn flush_table(table: &mut Vec<Vec<String>>, html: &mut String) {
    if table.is_empty() {
        return;
    }
    html.push_str("<table>\n");
    for (i, row) in table.iter().enumerate() {
        let tag = if i == 0 { "th" } else { "td" };
        html.push_str("<tr>");
        for c in row {
            html.push_str(&format!("<{tag}>{}</{tag}>", inline(c)));
        }
        html.push_str("</tr>\n");
    }
    html.push_str("</table>\n");
    table.clear();
}

/// The caption of a plot: the title plotters drew first in its SVG (its first `<text>`).
pub fn svg_title(svg: &str) -> Option<String> {
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
    let mut plots: Vec<BTreeMap<String, Vec<(f64, f64)>>> = vec![BTreeMap::new(); m.metrics.len()];
    for (k, va) in &ma {
        let Some(vb) = mb.get(k) else { continue };
        matched += 1;
        let mut cells: Vec<String> = k.iter().map(|c| md_cell(c)).collect();
        for i in 0..m.metrics.len() {
            let (x, y) = (avg(va[i]), avg(vb[i]));
            cells.extend([compare_cell(x), compare_cell(y), compare_cell(y - x)]);
            if let Some(xv) = k.first().and_then(|s| s.parse::<f64>().ok()) {
                let rest = m.rest_of(k);
                let series = &mut plots[i];
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
    // Everything goes to a staging folder first: a comparison that fails creates nothing.
    let staging = crate::atomic::Staging::new(out)?;
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

/// A plot per metric of the matched rows, A against B over the first key, into `dir`.
fn compare_plots(
    dir: &Path,
    m: &Matching,
    plots: &[BTreeMap<String, Vec<(f64, f64)>>],
) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for (i, c) in m.metrics.iter().enumerate() {
        if plots[i].is_empty() || m.keys.is_empty() {
            continue;
        }
        let title = format!("{c}: A vs B");
        let (x_words, y_words) = (crate::plots::words(&m.keys[0]), crate::plots::words(c));
        let labels = crate::plots::Labels {
            title: &title,
            x: &x_words,
            y: &y_words,
        };
        let stem = format!("compare_{c}");
        files.extend(crate::plots::write_both(
            dir,
            &stem,
            &labels,
            &plots[i],
            false,
            &[],
        )?);
    }
    Ok(files)
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
        let mut metrics: Vec<&str> = summary.to_vec();
        if let Some(first) = summary.first() {
            if !params.iter().any(|p| p == first)
                && distinct(ta, first) == distinct(tb, first)
                && distinct(ta, first).len() <= 64
            {
                keys.push(first.to_string());
                metrics.retain(|m| m != first);
            }
        }
        metrics.retain(|m| {
            !keys.iter().any(|k| k == m) && (0..ta.rows.len()).any(|r| ta.num(r, m).is_finite())
        });
        Self {
            keys,
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

    /// `, key = value, …` of a key's values after the first (a series' name).
    fn rest_of(&self, k: &[String]) -> String {
        if k.len() <= 1 {
            return String::new();
        }
        let pairs: Vec<String> = (self.keys[1..].iter().zip(&k[1..]))
            .map(|(n, v)| format!("{n} = {v}"))
            .collect();
        format!(", {}", pairs.join(", "))
    }
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
    let staging = crate::atomic::Staging::new(dir)?;
    let staged = report_staged(kind, dir, &staging)?;
    commit_report(staging, staged)
}

/// Rows of another kind than the manifest names: said so, naming both files (they once read as
/// a plot without data).
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
pub fn commit_report(staging: crate::atomic::Staging, staged: Report) -> Result<Report, Error> {
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
pub const REPORT_FILES: &str = ".report-files";

/// [`report`] of the rows and manifest in `dir`, written into `staging` (named after the
/// staging's target, not the staging folder); nothing moves until [`commit_report`].
pub fn report_staged(
    kind: &dyn DynKind,
    dir: &Path,
    staging: &crate::atomic::Staging,
) -> Result<Report, Error> {
    let csv = dir.join("runs.csv");
    let t = Results::read(&csv)?;
    check_kind(kind, dir, &t)?;
    let varying = t.varying(&kind.param_columns());
    let (title, claim) = title_and_claim(dir);
    let mut s = format!(
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
    );
    // The answer first: the kind's discussion of its claim, and the best configuration per row
    // key; every run's row after it (collapsed in the HTML, after the figures).
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
    let (md, html) = report_texts(dir, &s, &figures)?;
    let p = out.join("summary.md");
    let (pm, ph, full) = (
        out.join("report.md"),
        out.join("report.html"),
        out.join("discussion.md"),
    );
    let long = format!("# Our numbers against the claim\n\n{discussion}");
    let mut texts: Vec<(&Path, &str)> = vec![(&p, &s), (&pm, &md), (&ph, &html)];
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
pub const EVERY_RUN: &str = "## Every run";

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

/// The most bytes of a kind's discussion the summary (and so `report.html`) holds: a longer
/// one — a sentence per run at 10⁵ runs is megabytes — is cut at a line and written whole to
/// `discussion.md`.
pub const MAX_DISCUSSION_BYTES: usize = 32 * 1024;

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

    /// Text from data through `md_text` into a table, then to HTML: whatever the text (pipes,
    /// backslashes, backticks, stars, `<script>`, newlines, ESC, BEL, CR, multi-byte
    /// characters), the row keeps its cells and each shows the text itself, control characters
    /// as their escapes — over 2,000 seeded strings.
    #[test]
    fn cells_and_text_from_data_cannot_break_out_of_their_place() {
        let alphabet: Vec<char> = "ab|\\`*<>&\"' \n\r\t\u{1b}\u{7}é∑🦆#-_:.".chars().collect();
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let shown = |x: &str| -> String {
            x.chars()
                .map(|c| {
                    if c.is_control() {
                        c.escape_unicode().to_string()
                    } else {
                        c.to_string()
                    }
                })
                .collect()
        };
        for _ in 0..2000 {
            let mut word = || -> String {
                let n = (next() % 12) as usize;
                (0..n)
                    .map(|_| alphabet[(next() % alphabet.len() as u64) as usize])
                    .collect()
            };
            let (a, b) = (word(), word());
            let md = format!(
                "| h1 | h2 |\n|---|---|\n| {} | {} |\n",
                md_cell(&a),
                md_cell(&b)
            );
            assert_eq!(md.lines().count(), 3, "a cell forged a row: {md:?}");
            let html = markdown_to_html(&md);
            // (A cell's spaces at its ends are not part of it, in Markdown as here.)
            let want = format!(
                "<tr><td>{}</td><td>{}</td></tr>",
                esc(shown(&a).trim()),
                esc(shown(&b).trim())
            );
            assert!(html.contains(&want), "{a:?} {b:?}: {html}");
            assert!(!md.contains("<script") && !html.contains("<script"), "{md}");
        }
        // A code block holds any text: its fence is longer than the text's backtick runs.
        let text = "title = \"```\"\n````\nk = 1";
        let f = fence_for(text);
        assert_eq!(f, "`````");
        let html = markdown_to_html(&format!("{f}toml\n{text}\n{f}\nafter\n"));
        assert_eq!(html, format!("<pre>{}</pre>\n<p>after</p>\n", esc(text)));
    }

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
    fn markdown_subset_to_html() {
        let h = markdown_to_html("# T <x>\n\nSome **bold** and `code`.\n\n| a | b |\n|---|---:|\n| 1 | 2 |\n\n```toml\nk = \"<v>\"\n```\n");
        assert!(h.contains("<h1>T &lt;x&gt;</h1>"), "{h}");
        assert!(
            h.contains("<strong>bold</strong>") && h.contains("<code>code</code>"),
            "{h}"
        );
        assert!(
            h.contains("<tr><th>a</th><th>b</th></tr>") && h.contains("<td>2</td>"),
            "{h}"
        );
        assert!(!h.contains("---"), "{h}");
        assert!(h.contains("<pre>k = &quot;&lt;v&gt;&quot;</pre>"), "{h}");
        // A list: one item per "- " line, a following line continuing the item.
        let l = markdown_to_html("- one `a`\n- two\n  more\n\nafter\n");
        assert_eq!(
            l,
            "<ul>\n<li>one <code>a</code></li>\n<li>two more</li>\n</ul>\n<p>after</p>\n"
        );
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
