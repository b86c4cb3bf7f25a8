//! The experiment runner: sweep expansion, config errors, resumption, shards, atomic CSVs.

use shscale_lab::experiment::Plan;
use shscale_lab::runner::{run_plan, COLUMNS};
use std::collections::HashSet;

const CONFIG: &str = r#"
experiment = "probe"
mesh = "sphere"
order = 3
layout = "fib:30"
hemisphere_res = 6
k_count = 8
radii = [1.3, 2.0]

[sweep]
alpha_deg = [30, 45, 60]
order = [2, 3]
"#;

fn tmp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-runner-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ids_in(csv: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(COLUMNS.join(",").as_str()));
    lines
        .map(|l| {
            assert_eq!(
                l.split(',').count(),
                COLUMNS.len(),
                "partial or malformed row: {l}"
            );
            l.split(',').next().unwrap().to_string()
        })
        .collect()
}

#[test]
fn sweeps_expand_deterministically() {
    let a = Plan::parse("c.toml", "c", CONFIG).unwrap();
    let b = Plan::parse("c.toml", "c", CONFIG).unwrap();
    assert_eq!(a.runs.len(), 6);
    let ids: Vec<String> = a.runs.iter().map(|r| r.run_id()).collect();
    assert_eq!(ids, b.runs.iter().map(|r| r.run_id()).collect::<Vec<_>>());
    assert_eq!(
        ids.iter().collect::<HashSet<_>>().len(),
        6,
        "run ids must be unique"
    );
    assert_eq!(a.name, "c");
    assert!(a.runs.iter().any(|r| r.order == 2 && r.alpha_deg == 60.0));
}

#[test]
fn config_errors_name_file_line_and_field() {
    let e = Plan::parse(
        "a.toml",
        "a",
        &CONFIG.replace("k_count = 8", "k_count = 8\nbogus = 1"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("a.toml:8") && e.contains("bogus"), "{e}");
    let e = Plan::parse(
        "b.toml",
        "b",
        &CONFIG.replace("order = [2, 3]", "colour = [2, 3]"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("b.toml:12") && e.contains("colour"), "{e}");
    let e = Plan::parse(
        "c.toml",
        "c",
        &CONFIG.replace("alpha_deg = [30, 45, 60]", "alpha_deg = [30, 95]"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("c.toml:11") && e.contains("alpha_deg") && e.contains("95"),
        "{e}"
    );
    let e = Plan::parse(
        "d.toml",
        "d",
        &CONFIG.replace("alpha_deg = [30, 45, 60]", "alpha_deg = []"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("empty"), "{e}");
    let e = Plan::parse("e.toml", "e", &CONFIG.replace("\"probe\"", "\"paint\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("e.toml:2") && e.contains("paint"), "{e}");
}

#[test]
fn runs_resume_after_interruption_and_shards_partition() {
    let plan = Plan::parse("c.toml", "c", CONFIG).unwrap();
    let d = tmp("resume");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((s.ran, s.already_done), (6, 0));
    let ids = ids_in(&s.csv);
    assert_eq!(ids.len(), 12, "two radii per run");
    assert!(s.dir.join("manifest.toml").exists());
    // The Fig. 5 image of every run: truth | extrapolated, one row per radius (2 × 64 px high).
    for r in &plan.runs {
        let exr = s.dir.join(format!("visibility_{}.exr", r.run_id()));
        let (w, h, px) = shscale_lab::io::read_exr(&exr).unwrap();
        assert_eq!((w, h), (512, 256), "2 × 256 wide, 128 per radius");
        // Left half is a 0/1 ray-traced map with both values present (the sphere is seen).
        let left: Vec<f32> = (0..h)
            .flat_map(|j| (0..w / 2).map(move |i| (j, i)))
            .map(|(j, i)| px[j * w + i][0])
            .collect();
        assert!(
            left.iter().all(|v| *v == 0.0 || *v == 1.0)
                && left.contains(&0.0)
                && left.contains(&1.0)
        );
        assert!(s
            .dir
            .join(format!("visibility_{}.png", r.run_id()))
            .exists());
    }
    // Rerun: nothing to do.
    let again = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((again.ran, again.already_done), (0, 6));
    // Simulate a kill before the last run finished: drop its rows; the rerun redoes exactly it.
    let text = std::fs::read_to_string(&s.csv).unwrap();
    let last = plan.runs[5].run_id();
    let kept: Vec<&str> = text.lines().filter(|l| !l.starts_with(&last)).collect();
    std::fs::write(&s.csv, kept.join("\n") + "\n").unwrap();
    let resumed = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((resumed.ran, resumed.already_done), (1, 5));
    assert_eq!(ids_in(&s.csv).len(), 12);
    // No temporary files are left behind.
    assert!(std::fs::read_dir(&s.dir).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains(".tmp-")));
    // Shards: disjoint, together everything.
    let d2 = tmp("shards");
    let a = run_plan(&plan, &d2, Some((0, 2)), &|_| {}).unwrap();
    let b = run_plan(&plan, &d2, Some((1, 2)), &|_| {}).unwrap();
    let (ia, ib): (HashSet<String>, HashSet<String>) = (
        ids_in(&a.csv).into_iter().collect(),
        ids_in(&b.csv).into_iter().collect(),
    );
    assert!(ia.is_disjoint(&ib));
    let all: HashSet<String> = plan.runs.iter().map(|r| r.run_id()).collect();
    assert_eq!(ia.union(&ib).cloned().collect::<HashSet<_>>(), all);
    assert!(run_plan(&plan, &d2, Some((2, 2)), &|_| {}).is_err());
    // A CSV with other columns is never overwritten.
    std::fs::write(&s.csv, "something,else\n1,2\n").unwrap();
    assert!(run_plan(&plan, &d, None, &|_| {})
        .unwrap_err()
        .to_string()
        .contains("different columns"));
    assert_eq!(
        std::fs::read_to_string(&s.csv).unwrap(),
        "something,else\n1,2\n"
    );
    std::fs::remove_dir_all(&d).ok();
    std::fs::remove_dir_all(&d2).ok();
}

#[test]
fn plots_are_written_as_png_and_svg_with_labelled_axes() {
    let plan = Plan::parse("c.toml", "c", CONFIG).unwrap();
    let d = tmp("plots");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    let files = shscale_lab::plots::probe_plots(&s.dir, &plan.swept).unwrap();
    assert_eq!(
        files.len(),
        6,
        "two numeric axes (α, order) + the Pareto plot, PNG and SVG each"
    );
    for f in &files {
        let len = std::fs::metadata(f).unwrap().len();
        assert!(len > 2000, "{} is only {len} bytes", f.display());
    }
    let svg = std::fs::read_to_string(s.dir.join("occ_rel_l2_vs_alpha_deg.svg")).unwrap();
    assert!(
        svg.contains("alpha_deg") && svg.contains("occ_rel_l2"),
        "axis labels missing"
    );
    let png = std::fs::read(s.dir.join("pareto_time_vs_error.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert!(std::fs::read_dir(&s.dir).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains(".tmp-")));
    std::fs::remove_dir_all(&d).ok();
}
