//! End-to-end tests of `shscale figs`: figure configs run into an output folder with an index
//! whose numbers come from the run, and bad figure configs fail naming the file, line and field.

mod common;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-figs-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn figures_and_their_index_are_regenerated() {
    let d = tmp("ok");
    let cfg = d.join("configs");
    std::fs::create_dir_all(&cfg).unwrap();
    std::fs::write(
        cfg.join("a_sparsity.toml"),
        "experiment = \"sparsity\"\ntitle = \"Fig. 2 test\"\nclaim = \"44 non-zeros\"\norder = 4\n[[sweep]]\ntau = [\"cone\"]\nalpha_deg = [30]\nk = [0.5, 3.0]\n[[sweep]]\ntau = [\"midrange\"]\nk = [0.4]\n",
    )
    .unwrap();
    std::fs::write(
        cfg.join("b_elements.toml"),
        "experiment = \"m_elements\"\ntitle = \"Fig. 3 test\"\nclaim = \"smooth\"\norder = 3\nalpha_deg = 45\nk_min = 0.5\nk_max = 4.0\nk_count = 10\ncurve_points = 12\n[sweep.zip]\nrow = [2, 3]\ncol = [2, 3]\n",
    )
    .unwrap();
    std::fs::write(
        cfg.join("c_visibility.toml"),
        "experiment = \"probe\"\ntitle = \"Fig. 5 test\"\nclaim = \"resembles\"\nmesh = \"bird\"\norder = 3\nalpha_deg = 45\nlayout = \"fib:40\"\nhemisphere_res = 6\nk_count = 8\nradii = [0.7, 1.3]\n",
    )
    .unwrap();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../configs/scene_sphere.toml"
    );
    std::fs::write(
        cfg.join("d_shadows.toml"),
        format!("experiment = \"shadows\"\ntitle = \"Fig. 7 test\"\nclaim = \"consistent\"\nscene = \"{scene}\"\norder = 2\nhemisphere_res = 4\ntiming_warmup = 0\ntiming_repeats = 1\n"),
    )
    .unwrap();
    let out = d.join("figs");
    let runs = d.join("runs");
    let figs = |extra: &[&str]| {
        let mut args = vec![
            "figs",
            "--configs",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--gpu",
            "off",
        ];
        args.extend(extra);
        let o = common::shscale(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let first = figs(&["--runs", runs.to_str().unwrap()]);
    for f in [
        "a_sparsity.png",
        "a_sparsity.svg",
        "a_sparsity.txt",
        "a_sparsity.csv",
        "b_elements.png",
        "b_elements.csv",
        "c_visibility.png",
        "c_visibility.exr",
        "c_visibility.csv",
        "d_shadows.png",
        "d_shadows_camera.png",
        "d_shadows.exr",
        "d_shadows.csv",
        "README.md",
    ] {
        let len = std::fs::metadata(out.join(f))
            .unwrap_or_else(|_| panic!("{f} missing"))
            .len();
        assert!(len > 100, "{f}: {len} bytes");
    }
    let index = std::fs::read_to_string(out.join("README.md")).unwrap();
    for needle in [
        "## Fig. 2 test",
        "## Fig. 3 test",
        "## Fig. 5 test",
        "**Paper.** 44 non-zeros",
        "has 44 positions; N(2N²+1)/3 = 44",
        "Over 6 matrices (3 τ × plain and energy η)",
        "Confirmed where it matters",
        "![Fig. 5 test](c_visibility.png)",
        "![Fig. 7 test](d_shadows.png)",
        "| extrapolated |",
        "| 0.7 |",
    ] {
        assert!(index.contains(needle), "index lacks {needle:?}:\n{index}");
    }
    // The shadows rows say which light the full-frequency truth uses and carry both truths' own
    // errors (a single occluder: both are estimated), small against the extrapolation's error.
    let mut r = ::csv::Reader::from_path(out.join("d_shadows.csv")).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let col = |n: &str| {
        h.iter()
            .position(|x| x == n)
            .unwrap_or_else(|| panic!("{n} not in {h:?}"))
    };
    for rec in r.records() {
        let rec = rec.unwrap();
        assert_eq!(&rec[col("truth_light")], "closed-form sky");
        let (bl, ff) = (
            rec[col("band_limited_truth_err")].parse::<f64>().unwrap(),
            rec[col("full_frequency_truth_err")].parse::<f64>().unwrap(),
        );
        assert!(bl > 0.0 && ff > 0.0 && bl < 0.05 && ff < 0.05, "{bl} {ff}");
        if &rec[col("method")] == "extrapolated" {
            let e = rec[col("rmse_vs_full_frequency")].parse::<f64>().unwrap();
            assert!(e > ff, "{e} vs the truth's own {ff}");
        }
    }
    // The pattern text: 16 rows of 16, 41 non-zeros for the plain matrix at N = 4.
    let txt = std::fs::read_to_string(out.join("a_sparsity.txt")).unwrap();
    assert_eq!(txt.lines().count(), 16);
    assert_eq!(txt.matches('X').count(), 41);
    assert_eq!(txt.matches('o').count(), 3);
    // The rows behind Fig. 3: two elements × 12 curve points, every parameter a column.
    let mut r = ::csv::Reader::from_path(out.join("b_elements.csv")).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    for c in [
        "run_id", "row", "col", "k", "direct", "table", "abs_err", "k_count",
    ] {
        assert!(h.iter().any(|x| x == c), "{c} not in {h:?}");
    }
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(rows.len(), 24);
    // Linear interpolation reproduces the table's own nodes: at k_min the element is exact.
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    let e0: f64 = rows[0][col("abs_err")].parse().unwrap();
    assert!(e0 < 1e-12, "abs_err at k_min = {e0}");
    // The runs were kept under --runs; a second figs resumes them (nothing recomputed), and the
    // default (no --runs) recomputes in a temporary folder it removes.
    assert!(runs.join("m_elements/b_elements/runs.csv").exists());
    assert!(first.contains("(2 run(s), 0 already done)"), "{first}");
    let again = figs(&["--runs", runs.to_str().unwrap()]);
    assert!(again.contains("(0 run(s), 2 already done)"), "{again}");
    let fresh = figs(&[]);
    assert!(fresh.contains("(2 run(s), 0 already done)"), "{fresh}");
    // The figure images are labelled pictures, wider than the raw side-by-side values.
    let png_width = |f: &str| {
        let b = std::fs::read(out.join(f)).unwrap();
        u32::from_be_bytes([b[16], b[17], b[18], b[19]])
    };
    assert!(
        png_width("d_shadows.png") >= 1000,
        "{}",
        png_width("d_shadows.png")
    );
    assert!(
        png_width("c_visibility.png") >= 800,
        "{}",
        png_width("c_visibility.png")
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_figure_configs_name_file_line_and_field() {
    let d = tmp("bad");
    let cases = [
        (
            "experiment = \"sparsity\"\ntitle = \"t\"\nclaim = \"c\"\norder = 4\nalpha_deg = 30\nk = 2.0\ncolour = \"red\"\n",
            ":7: colour: unknown field `colour`",
        ),
        (
            "experiment = \"m_elements\"\ntitle = \"t\"\nclaim = \"c\"\norder = \"four\"\n",
            ":4: order: invalid type: string \"four\", expected usize",
        ),
        (
            "experiment = \"histogram\"\ntitle = \"t\"\nclaim = \"c\"\n",
            "\"histogram\" is not a known experiment kind",
        ),
        (
            "experiment = \"m_elements\"\ntitle = \"t\"\nclaim = \"c\"\norder = 4\nrow = 2\ncol = 3\n",
            ":6: col: (2, 3) is not a structural non-zero",
        ),
        (
            "experiment = \"sparsity\"\norder = 4\n[[sweep]]\ntau = [\"cone\"]\n[[sweep]]\ntau = [\"midrange\"]\nk = [0.5, 1.5]\n",
            ":7: k: ",
        ),
        (
            "experiment = \"extremes\"\ntau = \"cube\"\n",
            ":2: tau: \"cube\" is not cone or midrange",
        ),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let cfg = d.join(format!("c{i}"));
        std::fs::create_dir_all(&cfg).unwrap();
        // A good config sorted first: nothing is run or written while another is bad.
        std::fs::write(
            cfg.join("a_good.toml"),
            "experiment = \"sparsity\"\norder = 2\n",
        )
        .unwrap();
        std::fs::write(cfg.join("fig.toml"), text).unwrap();
        common::fails(
            &[
                "figs",
                "--configs",
                cfg.to_str().unwrap(),
                "--out",
                d.join("out").to_str().unwrap(),
                "--gpu",
                "off",
            ],
            needle,
        );
        assert!(!d.join("out").exists(), "case {i}: output written");
    }
    common::fails(
        &[
            "figs",
            "--configs",
            d.join("nothing").to_str().unwrap(),
            "--gpu",
            "off",
        ],
        "nothing",
    );
    std::fs::remove_dir_all(&d).ok();
}

/// Studies (`experiment = "midrange" | "srf" | "extremes"`) run through `shscale run` into
/// results/<kind>/<stem>/ with a summary, a manifest, a CSV and a plot; their verdicts come from
/// the numbers (mid-range scaling beats the distant assumption — checked against a ray-exit
/// quadrature truth; the extremes study finds no failing case). They shard like every kind.
#[test]
fn studies_run_through_shscale_run() {
    let d = tmp("studies");
    let mid = d.join("mid.toml");
    std::fs::write(
        &mid,
        "experiment = \"midrange\"\norder = 6\npoints = 4\nnormals = 3\nsun = 8.0\nsun_dir = [0.6, 0.0, 0.8]\nsun_radius_deg = 20\n[sweep]\nk = [0.0, 0.5, 0.85]\n",
    )
    .unwrap();
    let ext = d.join("ext.toml");
    std::fs::write(
        &ext,
        "experiment = \"extremes\"\ntitle = \"e\"\nclaim = \"c\"\n[[sweep]]\ntau = [\"cone\"]\nk = [1e-6, 1.0, 1e6]\nalpha_deg = [1e-4, 45.0, 89.9999]\n[[sweep]]\ntau = [\"midrange\"]\nk = [-0.999, 0.999999999]\n",
    )
    .unwrap();
    let srf = d.join("srf.toml");
    std::fs::write(
        &srf,
        "experiment = \"srf\"\ntitle = \"s\"\nclaim = \"c\"\norder = 3\nlayout = \"fib:40\"\nhemisphere_res = 8\nalpha_deg = 45\nhinge_deg = 100\nradii = [1.5, 2.5]\n",
    )
    .unwrap();
    let out = d.join("results");
    // midrange is a kind of the runner: rows with ids, summary, plots.
    let o = common::shscale(&[
        "run",
        mid.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "midrange: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        text.contains("| run_id | k | scaled_rel_err_mean"),
        "{text}"
    );
    for f in [
        "summary.md",
        "manifest.toml",
        "runs.csv",
        "midrange_error_vs_k.png",
    ] {
        assert!(
            out.join("midrange/mid").join(f).exists(),
            "midrange: {f} missing"
        );
    }
    // Scaling beats the distant assumption at every k > 0 (the study's finding), read back from
    // the CSV: an oracle-free but falsifiable check of the kind's rows.
    let mut r = ::csv::Reader::from_path(out.join("midrange/mid/runs.csv")).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    for rec in r.records() {
        let rec = rec.unwrap();
        let k: f64 = rec[col("k")].parse().unwrap();
        let (s, d): (f64, f64) = (
            rec[col("scaled_rel_err_mean")].parse().unwrap(),
            rec[col("distant_rel_err_mean")].parse().unwrap(),
        );
        println!("k = {k}: scaled {s:.3e}, distant {d:.3e}");
        assert!(k == 0.0 || s < d, "k = {k}: scaled {s} ≥ distant {d}");
    }
    for (cfg, kind, stem, needle) in [
        (&ext, "extremes", "ext", "22 matrices"),
        (&srf, "srf", "srf", "| 100.0° | 45.0° | 1.5 |"),
    ] {
        let o = common::shscale(&[
            "run",
            cfg.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ]);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{kind}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(text.contains(needle), "{kind}: {needle:?} not in\n{text}");
        let dir = out.join(kind).join(stem);
        for f in ["summary.md", "manifest.toml", "runs.csv"] {
            assert!(dir.join(f).exists(), "{kind}: {f} missing");
        }
    }
    // Every extremes case passes (its own verdict), and the summary says so.
    let summary = std::fs::read_to_string(out.join("extremes/ext/summary.md")).unwrap();
    assert!(summary.contains("0 failed"), "{summary}");
    assert!(summary.contains("**Claim.** c"), "{summary}");
    // Studies shard like every kind: two shards cover the 11 runs.
    for i in 0..2 {
        let o = common::shscale(&[
            "run",
            ext.to_str().unwrap(),
            "--shard",
            &format!("{i}/2"),
            "--name",
            "ext_sharded",
            "--out-dir",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let rows = |f: &str| {
        ::csv::Reader::from_path(out.join("extremes/ext_sharded").join(f))
            .unwrap()
            .records()
            .count()
    };
    assert_eq!(
        rows("runs.shard-0-of-2.csv") + rows("runs.shard-1-of-2.csv"),
        22
    );
    std::fs::write(&ext, "experiment = \"extremes\"\ntitle = \"e\"\nclaim = \"c\"\nk = 1.0\nalpha_deg = 45.0\norder = 4\ntau = \"cone\"\nspeed = 3\n").unwrap();
    common::fails(
        &[
            "run",
            ext.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ],
        "ext.toml:8: speed: unknown field `speed`",
    );
    std::fs::remove_dir_all(&d).ok();
}

/// The committed figures are current: the cheap ones (Fig. 2, Fig. 3 and Fig. 5, seconds on the
/// development VM) regenerated by this binary from `configs/paper/` equal `paper-figs/<stem>.csv`
/// in every deterministic cell — every column but the provenance columns (machine, timing
/// procedure, code and revision, contention), the kind's time columns and the GPU path's
/// adapter and times (run here with `--gpu off`) — so a change to the
/// numbers shows up here, not in a reader's copy. A committed CSV without a column the
/// regenerated one has (or with a different number of rows) fails too.
#[test]
fn the_committed_cheap_figures_regenerate_cell_for_cell() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let d = tmp("current");
    let cfg = d.join("configs");
    std::fs::create_dir_all(&cfg).unwrap();
    let stems = ["fig2_sparsity", "fig3_m_elements", "fig5_visibility"];
    for s in stems {
        std::fs::copy(
            root.join(format!("configs/paper/{s}.toml")),
            cfg.join(format!("{s}.toml")),
        )
        .unwrap();
    }
    let out = d.join("figs");
    let r = common::shscale(&[
        "figs",
        "--configs",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--gpu",
        "off",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let volatile = [
        "threads",
        "timing_concurrent",
        "timing_warmup",
        "timing_repeats",
        "code",
        "other_cpu",
        "steal",
        "load_1m",
        "contended",
        "git_revision",
        "git_dirty",
    ];
    let read = |p: &std::path::Path| {
        let mut rd = csv::Reader::from_path(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let h: Vec<String> = rd.headers().unwrap().iter().map(String::from).collect();
        let rows: Vec<Vec<String>> = (rd.records())
            .map(|x| x.unwrap().iter().map(String::from).collect())
            .collect();
        (h, rows)
    };
    let mut compared = 0;
    for s in stems {
        let (hn, new) = read(&out.join(format!("{s}.csv")));
        let (ho, old) = read(&root.join(format!("paper-figs/{s}.csv")));
        assert_eq!(hn, ho, "{s}: the committed CSV has other columns");
        assert_eq!(new.len(), old.len(), "{s}: row counts");
        for (i, c) in hn.iter().enumerate() {
            // Times (the kinds' time columns follow these names: `*_seconds`, `*_seconds_lo`,
            // `*_spread`, `*_ms`, `fps`) and the GPU path's columns (its adapter and times: the
            // figures here run with `--gpu off`).
            let time = c.contains("_seconds")
                || c.starts_with("gpu_")
                || c.ends_with("_spread")
                || c.ends_with("_ms")
                || c == "fps";
            if volatile.contains(&c.as_str()) || time {
                continue;
            }
            for (r, (a, b)) in new.iter().zip(&old).enumerate() {
                assert_eq!(
                    a[i],
                    b[i],
                    "{s}.csv row {} column {c}: regenerated vs committed",
                    r + 2
                );
                compared += 1;
            }
        }
    }
    println!("{compared} deterministic cells equal the committed ones");
    assert!(compared > 100);
    std::fs::remove_dir_all(&d).ok();
}
