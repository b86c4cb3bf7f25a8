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
        "figure = \"sparsity\"\ntitle = \"Fig. 2 test\"\nclaim = \"44 non-zeros\"\norder = 4\nalpha_deg = [30]\nk = [0.5, 3.0]\nmidrange_k = [0.4]\n",
    )
    .unwrap();
    std::fs::write(
        cfg.join("b_elements.toml"),
        "figure = \"m_elements\"\ntitle = \"Fig. 3 test\"\nclaim = \"smooth\"\norder = 3\nalpha_deg = 45\nk_min = 0.5\nk_max = 4.0\nk_count = 10\nelements = [[2, 2], [3, 3]]\ncurve_points = 12\n",
    )
    .unwrap();
    std::fs::write(
        cfg.join("c_visibility.toml"),
        "figure = \"visibility\"\ntitle = \"Fig. 5 test\"\nclaim = \"resembles\"\nmesh = \"bird\"\norder = 3\nalpha_deg = 45\nlayout = \"fib:40\"\nhemisphere_res = 6\nk_count = 8\nradii = [0.7, 1.3]\n",
    )
    .unwrap();
    let out = d.join("figs");
    let o = common::shscale(&[
        "figs",
        "--configs",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--gpu",
        "off",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "a_sparsity.png",
        "a_sparsity.svg",
        "a_sparsity.txt",
        "b_elements.png",
        "b_elements.csv",
        "c_visibility.png",
        "c_visibility.exr",
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
        "has 44 positions; N(2N²+1)/3 = 44",
        "Confirmed where it matters",
        "![Fig. 5 test](c_visibility.png)",
    ] {
        assert!(index.contains(needle), "index lacks {needle:?}:\n{index}");
    }
    // The pattern text: 16 rows of 16, 41 non-zeros for the plain matrix at N = 4.
    let txt = std::fs::read_to_string(out.join("a_sparsity.txt")).unwrap();
    assert_eq!(txt.lines().count(), 16);
    assert_eq!(txt.matches('X').count(), 41);
    assert_eq!(txt.matches('o').count(), 3);
    // The element CSV: header + 12 points, direct and table columns per element.
    let csv = std::fs::read_to_string(out.join("b_elements.csv")).unwrap();
    assert_eq!(csv.lines().count(), 13);
    assert_eq!(
        csv.lines().next().unwrap(),
        "k,M_2_2_direct,M_2_2_table,M_3_3_direct,M_3_3_table"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_figure_configs_name_file_line_and_field() {
    let d = tmp("bad");
    let cases = [
        (
            "figure = \"sparsity\"\ntitle = \"t\"\nclaim = \"c\"\norder = 4\nalpha_deg = [30]\nk = [2.0]\ncolour = \"red\"\n",
            ":7: unknown field `colour`",
        ),
        (
            "figure = \"m_elements\"\ntitle = \"t\"\nclaim = \"c\"\norder = \"four\"\nalpha_deg = 45\nk_min = 0.5\nk_max = 4.0\nk_count = 10\nelements = [[2, 2]]\ncurve_points = 12\n",
            ":4: order: invalid type: string \"four\", expected usize",
        ),
        (
            "figure = \"histogram\"\ntitle = \"t\"\nclaim = \"c\"\n",
            "figure: unknown kind \"histogram\"",
        ),
        (
            "figure = \"m_elements\"\ntitle = \"t\"\nclaim = \"c\"\norder = 4\nalpha_deg = 45\nk_min = 0.5\nk_max = 4.0\nk_count = 10\nelements = [[2, 3]]\ncurve_points = 12\n",
            "elements: [2, 3] is not a structural non-zero",
        ),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let cfg = d.join(format!("c{i}"));
        std::fs::create_dir_all(&cfg).unwrap();
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
/// quadrature truth; the extremes study finds no failing case).
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
        "experiment = \"extremes\"\ntitle = \"e\"\nclaim = \"c\"\nk = [1e-6, 1.0, 1e6]\nalpha_deg = [1e-4, 45.0, 89.9999]\norders = [4]\nmidrange_k = [-0.999, 0.999999999]\n",
    )
    .unwrap();
    let srf = d.join("srf.toml");
    std::fs::write(
        &srf,
        "experiment = \"srf\"\ntitle = \"s\"\nclaim = \"c\"\norder = 3\nlayout = \"fib:40\"\nhemisphere_res = 8\nalpha_deg = [45]\nhinge_deg = [100]\nradii = [1.5, 2.5]\n",
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
        (&ext, "extremes", "ext", "0 failed (non-finite"),
        (&srf, "srf", "srf", "| 100° | 45° | 1.5 |"),
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
        for f in [
            "summary.md",
            "manifest.toml",
            &format!("{stem}.csv"),
            &format!("{stem}.png"),
        ] {
            assert!(dir.join(f).exists(), "{kind}: {f} missing");
        }
    }
    // Studies are not sharded, and their configs are checked like every other.
    common::fails(
        &[
            "run",
            ext.to_str().unwrap(),
            "--shard",
            "0/2",
            "--out-dir",
            out.to_str().unwrap(),
        ],
        "not yet an experiment kind of the runner",
    );
    std::fs::write(&ext, "experiment = \"extremes\"\ntitle = \"e\"\nclaim = \"c\"\nk = [1.0]\nalpha_deg = [45.0]\norders = [4]\nmidrange_k = []\nspeed = 3\n").unwrap();
    common::fails(
        &[
            "run",
            ext.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ],
        "ext.toml:8: unknown field `speed`",
    );
    std::fs::remove_dir_all(&d).ok();
}
