//! End-to-end tests of the reports: every results directory gets `report.md` and a
//! self-contained `report.html` (plots inline as SVG, the config, the plan, provenance, captions),
//! checked in a real headless browser; `shscale report`, `compare` and `plot` work on existing
//! results without rerunning.

mod common;
use common::*;
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-report-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const TINY: &str = "experiment = \"probe\"\ntitle = \"Tiny sweep\"\nclaim = \"the error grows with alpha\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:12\"\nhemisphere_res = 2\nk_count = 4\nradii = [1.5, 2.0]\nparallel_runs = false\n[sweep]\nalpha_deg = [20, 40, 60]\n";

fn run(d: &Path, extra: &[&str]) -> PathBuf {
    let cfg = d.join("tiny.toml");
    std::fs::write(&cfg, TINY).unwrap();
    let out = d.join("results");
    let mut args = vec![
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let o = shscale(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let name = extra
        .windows(2)
        .find(|w| w[0] == "--name")
        .map_or("tiny", |w| w[1]);
    out.join("probe").join(name)
}

/// A headless Chromium, if one is installed.
fn browser() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|b| {
            std::process::Command::new("which")
                .arg(b)
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()))
        })
}

/// Open `html` in headless Chromium and check its own script's verdict: `svgs` figures rendered,
/// no script error (skipped with a notice without Chromium, unless SHSCALE_REQUIRE_BROWSER=1).
/// Prints how long Chromium took (a measurement, not asserted: machines differ).
fn check_in_browser(html: &Path, svgs: usize) {
    check_in_browser_with(html, svgs, None);
}

/// [`check_in_browser`], and a screenshot of the page's first 1200×2000 pixels into
/// `screenshot` (its path and size printed, so the test output says where to look).
fn check_in_browser_with(html: &Path, svgs: usize, screenshot: Option<&Path>) {
    let Some(chromium) = browser() else {
        assert!(
            std::env::var("SHSCALE_REQUIRE_BROWSER").as_deref() != Ok("1"),
            "SHSCALE_REQUIRE_BROWSER=1 but no chromium is installed"
        );
        eprintln!("notice: no chromium: the report's browser check is skipped (install Debian's chromium, as .ci/run does)");
        return;
    };
    // Headless, sandbox off (CI runs as root), /dev/shm not needed; killed after 120 s.
    let mut child = std::process::Command::new(&chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!("file://{}", html.display()))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("chromium runs");
    // Read the DOM while it is written (it is larger than a pipe's buffer).
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut stdout, &mut s);
        s
    });
    let t0 = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > std::time::Duration::from_secs(120) {
            let _ = child.kill();
            panic!("{chromium:?} did not finish within 120 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let dom = reader.join().unwrap();
    println!(
        "chromium loaded and rendered {} in {:.2} s",
        html.display(),
        t0.elapsed().as_secs_f64()
    );
    if let Some(png) = screenshot {
        let o = std::process::Command::new(&chromium)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--hide-scrollbars",
                "--window-size=1200,2000",
            ])
            .arg(format!("--screenshot={}", png.display()))
            .arg(format!("file://{}", html.display()))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .expect("chromium runs");
        let bytes = std::fs::metadata(png).map(|m| m.len()).unwrap_or(0);
        assert!(
            o.success() && bytes > 10_000,
            "no screenshot ({bytes} bytes) at {}",
            png.display()
        );
        println!(
            "screenshot of the report: {} ({bytes} bytes)",
            png.display()
        );
    }
    let want = format!("figures: {svgs} of {svgs} rendered, 0 script errors");
    assert!(
        dom.contains(&want),
        "{chromium:?} did not report {want:?}: {}",
        dom.lines()
            .filter(|l| l.contains("figure-check"))
            .collect::<Vec<_>>()
            .join(" ")
    );
}

/// Whether `s` holds a time like `2026-12-04T05:35:53Z`.
fn regex_free_iso(s: &str) -> bool {
    let b = s.as_bytes();
    b.windows(20).any(|w| {
        w.iter().enumerate().all(|(i, c)| match i {
            4 | 7 => *c == b'-',
            10 => *c == b'T',
            13 | 16 => *c == b':',
            19 => *c == b'Z',
            _ => c.is_ascii_digit(),
        })
    })
}

#[test]
fn every_run_writes_a_report_that_renders_in_a_browser() {
    let d = tmp("html");
    let dir = run(&d, &[]);
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    for needle in [
        "# Tiny sweep",
        "**Claim.** the error grows with alpha",
        "## Figures",
        "Figure 1. ",
        "## Plan and provenance",
        "## Config (newest version)",
        "alpha_deg = [20, 40, 60]",
    ] {
        assert!(md.contains(needle), "report.md lacks {needle:?}:\n{md}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let svgs = html.matches("<svg").count();
    let figures = md.matches("\nFigure ").count();
    assert!(
        svgs >= 2 && svgs == figures,
        "{svgs} inline SVGs for {figures} figures"
    );
    assert!(
        !html.contains("src=\"http"),
        "the report must not load anything from outside"
    );
    // Reading order: the question, the answer (the discussion, the best per radius), the
    // figures, then every run's row collapsed; times in ISO 8601.
    let at = |s: &str| {
        html.find(s)
            .unwrap_or_else(|| panic!("report.html lacks {s:?}"))
    };
    assert!(at("Our numbers against the claim") < at("Best per radius"));
    assert!(at("Best per radius") < at("<h2>Figures</h2>"));
    assert!(at("<h2>Figures</h2>") < at("<details>"));
    assert!(at("<details>") < at("Plan and provenance"));
    let iso = regex_free_iso(&html);
    assert!(iso, "no ISO 8601 time in the provenance");
    let shot = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    check_in_browser_with(&dir.join("report.html"), svgs, Some(&shot));
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_report_of_100k_rows_stays_small_and_renders_in_a_browser() {
    // The tiny sweep's rows dealt out to 10⁵ rows (5·10⁴ runs: 500 cone angles × 100 radii), as a
    // large sweep would leave them; `report` regenerates everything from the CSV alone.
    let d = tmp("big");
    let dir = run(&d, &[]);
    let csv = dir.join("runs.csv");
    let mut r = csv::Reader::from_path(&csv).unwrap();
    let header = r.headers().unwrap().clone();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    let col = |name: &str| header.iter().position(|c| c == name).unwrap();
    let (id, alpha, radius) = (col("run_id"), col("alpha_deg"), col("radius"));
    let mut w = csv::Writer::from_path(&csv).unwrap();
    w.write_record(&header).unwrap();
    const ROWS: usize = 100_000;
    for n in 0..ROWS {
        let mut cells: Vec<String> = rows[n % rows.len()].iter().map(String::from).collect();
        cells[id] = format!("{:016x}", n / 2);
        cells[alpha] = format!("{}", 1.0 + (n / 200) as f64 * 0.17);
        cells[radius] = format!("{}", 1.1 + (n % 100) as f64 * 0.03);
        w.write_record(&cells).unwrap();
    }
    w.flush().unwrap();
    drop(w);
    let t0 = std::time::Instant::now();
    let o = shscale(&["report", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    println!("report of {ROWS} rows: {:.2} s", t0.elapsed().as_secs_f64());
    let size = |f: &str| std::fs::metadata(dir.join(f)).unwrap().len();
    // Bounds (bytes): the summary aggregates, the discussion's sentence per run goes to its own
    // file, and each plot draws at most MAX_POINTS points.
    const HTML_MAX: u64 = 3 << 20;
    const SUMMARY_MAX: u64 = 128 << 10;
    const SVG_MAX: u64 = 1 << 20;
    let (html, summary) = (size("report.html"), size("summary.md"));
    println!(
        "report.html {html} B, summary.md {summary} B, discussion.md {} B",
        size("discussion.md")
    );
    assert!(
        html <= HTML_MAX,
        "report.html is {html} bytes at {ROWS} rows"
    );
    assert!(summary <= SUMMARY_MAX, "summary.md is {summary} bytes");
    let text = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(
        text.contains("100000 rows are too many to list"),
        "{}",
        &text[..text.len().min(2000)]
    );
    assert!(text.contains("more line(s) of the discussion (one per run) are in `discussion.md`"));
    for f in std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()) {
        if f.extension().is_some_and(|e| e == "svg") {
            let n = std::fs::metadata(&f).unwrap().len();
            assert!(n <= SVG_MAX, "{} is {n} bytes", f.display());
        }
    }
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let svgs = std::fs::read_to_string(dir.join("report.html"))
        .unwrap()
        .matches("<svg")
        .count();
    assert_eq!(svgs, md.matches("\nFigure ").count());
    check_in_browser(&dir.join("report.html"), svgs);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn report_compare_and_plot_work_on_existing_results() {
    let d = tmp("cmp");
    let a = run(&d, &[]);
    let b = run(&d, &["--set", "order=3", "--name", "order3"]);
    // `report` regenerates every file from the CSV alone.
    std::fs::remove_file(a.join("report.html")).unwrap();
    let o = shscale(&["report", a.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(a.join("report.html").exists());
    // `compare`: the parameter fixed at different values is named, rows matched per α and radius.
    let out = d.join("cmp");
    let o = shscale(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("order (A: 2, B: 3)"), "{text}");
    assert!(
        text.contains("Rows matched on: alpha_deg, radius"),
        "{text}"
    );
    assert!(
        text.contains("6 matched row group(s); 0 only in A, 0 only in B"),
        "{text}"
    );
    assert!(out.join("compare.md").exists() && out.join("compare_occ_rel_l2_mean.svg").exists());
    // Its plots split per probe radius, as the report's do: one panel per radius, whose series
    // no longer repeat the radius; and the kind's stage times are compared, not only the
    // headline columns.
    let svg = std::fs::read_to_string(out.join("compare_occ_rel_l2_mean.svg")).unwrap();
    let radii = text
        .lines()
        .filter_map(|l| l.strip_prefix("| 20.0 | "))
        .count();
    assert!(radii >= 2, "{text}");
    assert_eq!(
        svg.matches("probe radius ρ = ").count(),
        radii,
        "one panel title per radius"
    );
    assert!(
        !svg.contains(", radius = "),
        "a series repeats the facet's radius"
    );
    for t in ["bsv_sampling_seconds", "extrapolation_seconds"] {
        assert!(
            text.contains(&format!("{t} B − A")),
            "{t} not compared: {text}"
        );
        assert!(out.join(format!("compare_{t}.svg")).exists());
    }
    assert!(
        !text.contains("bsv_sampling_spread"),
        "a spread is not a time: {text}"
    );
    // The differences are B − A of the two CSVs' own numbers.
    let row = text
        .lines()
        .find(|l| l.starts_with("| 20.0 | 1.5 |"))
        .unwrap_or_else(|| panic!("no row for α = 20, r = 1.5 in {text}"));
    let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
    let (x, y, dxy): (f64, f64, f64) = (
        cells[2].parse().unwrap(),
        cells[3].parse().unwrap(),
        cells[4].parse().unwrap(),
    );
    assert!((y - x - dxy).abs() < 2e-4, "{row}");
    // `plot` any column, and errors that name the culprit.
    let o = shscale(&[
        "plot",
        a.to_str().unwrap(),
        "--metric",
        "occ_rel_l2_mean",
        "--x",
        "alpha_deg",
        "--series",
        "radius",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(a
        .join("plot_occ_rel_l2_mean_vs_alpha_deg_series_radius.svg")
        .exists());
    fails(
        &[
            "plot",
            a.to_str().unwrap(),
            "--metric",
            "nosuch",
            "--x",
            "alpha_deg",
        ],
        "\"nosuch\" is not a column",
    );
    fails(&["report", d.to_str().unwrap()], "no manifest.toml");
    fails(
        &["compare", a.to_str().unwrap(), d.to_str().unwrap()],
        "no manifest.toml",
    );
    std::fs::remove_dir_all(&d).ok();
}

/// `shscale plot` beyond one series: a line through rows that differ in a key at one x (here the
/// probe radius) is refused naming it; `--where` filters it to one line with its interquartile
/// band (the probe rows' p25/p75); `--facet` draws a panel per value; `--log-x` labels a narrow
/// log axis with values.
#[test]
fn plot_refuses_zigzags_and_filters_facets_and_bands() {
    let d = tmp("plotflags");
    let a = run(&d, &[]);
    let dir = a.to_str().unwrap();
    let base = [
        "plot",
        dir,
        "--metric",
        "occ_rel_l2_mean",
        "--x",
        "alpha_deg",
    ];
    fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        base.iter().chain(extra).copied().collect()
    }
    fails(
        &with(&base, &["--series", "order"]),
        "differ in \"radius\" at the same x",
    );
    fails(
        &with(&base, &["--where", "radius"]),
        "--where radius: expected COLUMN=VALUE",
    );
    fails(
        &with(&base, &["--where", "radius=7"]),
        "no row matches --where radius=7",
    );
    fails(
        &with(&base, &["--facet", "nosuch"]),
        "\"nosuch\" is not a column",
    );
    let o = shscale(&with(
        &base,
        &["--series", "order", "--where", "radius=1.5"],
    ));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let named = "plot_occ_rel_l2_mean_vs_alpha_deg_series_order_where_radius-1.5.svg";
    let svg = std::fs::read_to_string(a.join(named)).unwrap();
    // Another filter draws other rows: another file, the first one kept.
    let o = shscale(&with(
        &base,
        &["--series", "order", "--where", "radius=2.0"],
    ));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(a
        .join("plot_occ_rel_l2_mean_vs_alpha_deg_series_order_where_radius-2.0.svg")
        .exists());
    assert_eq!(
        std::fs::read_to_string(a.join(named)).unwrap(),
        svg,
        "the first plot was replaced"
    );
    assert!(
        svg.contains("interquartile range over probes"),
        "no band named"
    );
    assert!(svg.contains("<polygon"), "no band drawn");
    let o = shscale(&with(&base, &["--facet", "radius", "--log-x"]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg =
        std::fs::read_to_string(a.join("plot_occ_rel_l2_mean_vs_alpha_deg_by_radius.svg")).unwrap();
    let panels = svg.matches("probe radius ρ = ").count();
    assert_eq!(panels, 2, "one panel per radius");
    assert!(svg.contains("log scale"));
    std::fs::remove_dir_all(&d).ok();
}

/// `docs/config-reference.md` is what `shscale config-reference` prints (regenerate it with
/// `shscale config-reference > docs/config-reference.md`); every parameter of every kind is
/// described and every description names a real parameter; the scene keys listed are exactly
/// the schema's (read from the parser's own "expected one of" list, table by table).
#[test]
fn the_config_reference_matches_the_code() {
    let o = shscale(&["config-reference"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    let committed = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../docs/config-reference.md"
    ))
    .unwrap();
    assert!(
        text == committed,
        "docs/config-reference.md is stale: regenerate it with `shscale config-reference > docs/config-reference.md`"
    );
    for kind in shscale_experiments::registry() {
        let missing = shscale_runner::reference::undescribed(kind);
        assert!(
            missing.is_empty(),
            "{}: undescribed keys {missing:?}",
            kind.name()
        );
        let keys: Vec<String> = kind.defaults().into_iter().map(|(k, _)| k).collect();
        for (k, _) in kind.describe() {
            assert!(
                keys.iter().any(|x| x == k),
                "{}: {k} is described but not a parameter",
                kind.name()
            );
        }
    }
    // The scene schema, table by table.
    let base = "order = 2\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 1.5]\nradius = 1.0\n[receiver]\ncenter = [0, 0, 0]\nsize = [4, 4]\nresolution = [8, 8]\n[light]\nkind = \"sky\"\n[[light_source]]\nkind = \"quad\"\ncenter = [0, 0, 3]\n[camera]\nposition = [0, -5, 4]\nlook_at = [0, 0, 0]\n";
    let expected = |table: &str| -> Vec<String> {
        let text = match table {
            "" => format!("zz_unknown = 1\n{base}"),
            t => base.replacen(&format!("[{t}]\n"), &format!("[{t}]\nzz_unknown = 1\n"), 1),
        };
        let e = match shscale_scene::scene::Scene::parse("s.toml", &text, std::path::Path::new("."))
        {
            Ok(_) => panic!("{table}: an unknown key was accepted"),
            Err(e) => e.to_string(),
        };
        let list = e
            .split("expected one of")
            .nth(1)
            .unwrap_or_else(|| panic!("{e}"));
        list.split('`')
            .skip(1)
            .step_by(2)
            .map(String::from)
            .collect()
    };
    let listed = |prefix: &str| -> Vec<String> {
        let mut v: Vec<String> = shscale_scene::scene::SCENE_KEYS
            .iter()
            .filter_map(|(k, ..)| {
                if prefix.is_empty() {
                    (!k.contains('.')).then(|| k.to_string())
                } else {
                    k.strip_prefix(prefix).map(String::from)
                }
            })
            .collect();
        v.sort();
        v
    };
    for (table, prefix) in [
        ("", ""),
        ("[occluder]", "occluder[i]."),
        ("receiver", "receiver."),
        ("light", "light."),
        ("[light_source]", "light_source[i]."),
        ("camera", "camera."),
    ] {
        let mut schema = expected(table);
        schema.retain(|k| {
            !["occluder", "receiver", "light", "light_source", "camera"].contains(&k.as_str())
        });
        schema.sort();
        assert_eq!(schema, listed(prefix), "scene table {table:?}");
    }
}

/// Every file of `dir` (name → bytes).
fn snapshot(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().to_string(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_report_that_fails_changes_nothing_and_leaves_no_temporary() {
    // The report's last file cannot be written (`report.html` is a folder): it fails after the
    // plots and the summary were drawn. Before, summary.md and the plots had already been
    // rewritten (and once a `.name.tmp-PID.png` was left behind); now all of them are staged and
    // none moves. Every metric cell not a number makes the plots empty (nothing to draw), which
    // is a result the report states, not a failure.
    let d = tmp("fail");
    let dir = run(&d, &[]);
    let csv = dir.join("runs.csv");
    let mut r = csv::Reader::from_path(&csv).unwrap();
    let header = r.headers().unwrap().clone();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    let metric = header.iter().position(|c| c == "occ_rel_l2_mean").unwrap();
    let mut w = csv::Writer::from_path(&csv).unwrap();
    w.write_record(&header).unwrap();
    for row in &rows {
        let mut cells: Vec<&str> = row.iter().collect();
        cells[metric] = "NaN";
        w.write_record(&cells).unwrap();
    }
    drop(w);
    std::fs::remove_file(dir.join("report.html")).unwrap();
    std::fs::create_dir(dir.join("report.html")).unwrap();
    let before = snapshot(&dir);
    let o = shscale(&["report", dir.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("report.html") && err.contains("is a directory"),
        "{err}"
    );
    let after = snapshot(&dir);
    let changed: Vec<&String> = (before.keys().chain(after.keys()))
        .filter(|k| before.get(*k) != after.get(*k))
        .collect();
    assert!(changed.is_empty(), "a failed report changed {changed:?}");
    let left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.contains("staging") || n.contains(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
    // With the folder gone, the same rows report: nothing to plot, said so.
    std::fs::remove_dir(dir.join("report.html")).unwrap();
    let o = shscale(&["report", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_column_name_is_data_never_a_path() {
    // A crafted runs.csv column `../../escape`: once the plot's PNG and SVG were written two
    // levels above the results directory.
    let d = tmp("escape");
    let dir = run(&d, &[]);
    let csv = dir.join("runs.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::write(&csv, text.replacen("occ_rel_l2_mean", "../../escape", 1)).unwrap();
    let o = shscale(&[
        "plot",
        dir.to_str().unwrap(),
        "--metric",
        "../../escape",
        "--x",
        "alpha_deg",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("plot_.._.._escape_vs_alpha_deg.svg").exists());
    let up = dir.parent().unwrap().parent().unwrap();
    for f in ["escape_vs_alpha_deg.png", "escape_vs_alpha_deg.svg"] {
        assert!(!up.join(f).exists(), "{f} escaped to {}", up.display());
    }
    std::fs::remove_dir_all(&d).ok();
}

/// A manifest whose kind does not match its rows is named as such (it once read as a plot
/// without data), and nothing is written.
#[test]
fn a_manifest_of_another_kind_than_its_rows_is_named() {
    let d = tmp("kind-mismatch");
    let dir = run(&d, &[]);
    let m = dir.join("manifest.toml");
    let text = std::fs::read_to_string(&m).unwrap();
    std::fs::write(
        &m,
        text.replacen("experiment = \"probe\"", "experiment = \"sparsity\"", 1),
    )
    .unwrap();
    let before = snapshot(&dir);
    let o = shscale(&["report", dir.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    println!("{err}");
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("manifest.toml") && err.contains("rows of another kind"),
        "{err}"
    );
    assert_eq!(snapshot(&dir), before, "a refused report changed files");
    std::fs::remove_dir_all(&d).ok();
}

/// The summary shows parameters as the config wrote them (α = 60.0, not 60.0000) and metrics as
/// summary numbers.
#[test]
fn the_summary_shows_parameters_as_written() {
    let d = tmp("as-written");
    let dir = run(&d, &[]);
    let text = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    let rows: Vec<&str> = (text.lines())
        .filter(|l| l.starts_with("| ") && l.contains(" | 60.0 |"))
        .collect();
    println!("{rows:?}");
    assert!(!rows.is_empty(), "no row shows α = 60.0:\n{text}");
    assert!(!text.contains("| 60.0000 |"), "{text}");
    std::fs::remove_dir_all(&d).ok();
}

/// A plot an earlier report wrote and a later one does not is removed with the later report (an
/// interim report drew the error against the radius before α varied, and that stale plot stayed
/// beside the current ones); files the reports never wrote are left alone.
#[test]
fn a_later_report_removes_the_plots_it_no_longer_draws() {
    let d = tmp("stale-plots");
    let dir = run(&d, &[]);
    let by_alpha = dir.join("occ_rel_l2_vs_alpha_deg.svg");
    assert!(by_alpha.exists(), "the sweep's plot against α");
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    // Keep the rows of one α: α no longer varies, the report draws the error against the radius.
    let csv = dir.join("runs.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let alpha = header.split(',').position(|c| c == "alpha_deg").unwrap();
    let kept: Vec<&str> = lines
        .filter(|l| l.split(',').nth(alpha) == Some("20.0"))
        .collect();
    assert!(!kept.is_empty());
    std::fs::write(&csv, format!("{header}\n{}\n", kept.join("\n"))).unwrap();
    let o = shscale(&["report", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("occ_rel_l2_vs_radius.svg").exists());
    assert!(
        !by_alpha.exists(),
        "the stale plot against α is still there"
    );
    assert!(
        dir.join("notes.txt").exists(),
        "a file the reports never wrote was removed"
    );
    std::fs::remove_dir_all(&d).ok();
}
