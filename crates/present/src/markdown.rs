//! The Markdown of the summaries and reports — headings, paragraphs, lists, pipe tables, fenced
//! code, `**bold**` and `` `code` `` — and how text from data enters it ([`md_text`]: escaped so
//! a cell or a title cannot break out of its place), with its conversion to HTML
//! ([`markdown_to_html`]) for `report.html`.

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
pub fn md_cell(s: &str) -> String {
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
pub fn fence_for(text: &str) -> String {
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
}
