//! The experiment runner: sweep expansion, config errors at their place, validated resume,
//! shards, atomic CSVs, the manifest of config versions, limits.

use shscale_runner::config::Overrides;
use shscale_runner::{header, load_rows, run_plan, Manifest, Plan};
use shscale_runner::{DynKind, Erased};
use std::collections::HashSet;

static PROBE: Erased<shscale_experiments::probe::Probe> = Erased::new();

fn registry() -> Vec<&'static dyn DynKind> {
    vec![&PROBE]
}

const CONFIG: &str = r#"
experiment = "probe"
mesh = "sphere"
order = 3
layout = "fib:30"
hemisphere_res = 6
k_count = 8
radii = [1.3, 2.0]
timing_repeats = 1
timing_warmup = 0

[sweep]
alpha_deg = [30, 45, 60]
order = [2, 3]
"#;

fn parse(text: &str) -> Result<Plan, String> {
    Plan::parse("c.toml", "c", text, &Overrides::default(), &registry()).map_err(|e| e.to_string())
}

fn tmp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-runner-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ids_in(csv: &std::path::Path) -> Vec<String> {
    let l = load_rows(&PROBE, csv).unwrap();
    assert!(l.rejected.is_empty(), "invalid rows: {:?}", l.rejected);
    l.rows.iter().map(|r| r[0].clone()).collect()
}

#[test]
fn sweeps_expand_deterministically() {
    let a = parse(CONFIG).unwrap();
    let b = parse(CONFIG).unwrap();
    assert_eq!(a.runs.len(), 6);
    let ids: Vec<&str> = a.runs.iter().map(|r| r.id.as_str()).collect();
    assert_eq!(
        ids,
        b.runs.iter().map(|r| r.id.as_str()).collect::<Vec<_>>()
    );
    assert_eq!(
        ids.iter().collect::<HashSet<_>>().len(),
        6,
        "unique run ids"
    );
    assert_eq!(a.name, "c");
    assert!(a
        .runs
        .iter()
        .any(|r| r.canonical.contains("order=2;alpha_deg=60.0")));
    // Every parameter is a column, swept or not.
    let h = header(&PROBE);
    for k in [
        "mesh",
        "order",
        "alpha_deg",
        "layout",
        "on_surface_eps",
        "radii",
        "radius",
    ] {
        assert!(h.iter().any(|c| c == k), "{k} missing from {h:?}");
    }
}

#[test]
fn config_errors_name_file_line_and_field() {
    let cases = [
        (
            CONFIG.replace("k_count = 8", "k_count = 8\nbogus = 1"),
            "c.toml:8: bogus: unknown field",
        ),
        (
            CONFIG.replace("order = [2, 3]", "colour = [2, 3]"),
            "c.toml:14: colour: unknown field",
        ),
        (
            CONFIG.replace("alpha_deg = [30, 45, 60]", "alpha_deg = [\n 30,\n 95,\n]"),
            "c.toml:15: alpha_deg: 95 is outside (0, 90)",
        ),
        (
            CONFIG.replace("alpha_deg = [30, 45, 60]", "alpha_deg = []"),
            "c.toml:13: sweep.alpha_deg: a sweep axis must not be empty",
        ),
        (
            CONFIG.replace("alpha_deg = [30, 45, 60]", "alpha_deg = [30, 45, 30]"),
            "sweep.alpha_deg: value 30 appears twice",
        ),
        (
            CONFIG.replace("\"probe\"", "\"paint\""),
            "c.toml:2: experiment: \"paint\" is not a known experiment kind",
        ),
        (
            CONFIG.replace("radii = [1.3, 2.0]", "radii = [1.3, 2.0, 1.3]"),
            "c.toml:8: radii[2]: radius 1.3 appears twice",
        ),
        (
            CONFIG.replace("hemisphere_res = 6", "hemisphere_res = \"six\""),
            "c.toml:6: hemisphere_res: invalid type",
        ),
        (
            CONFIG.replace("k_count = 8", "k_count = 1000000000"),
            "k_count: 1000000000 is outside 2..=10000",
        ),
        (
            CONFIG.replace("fib:30", "fib:1000000000"),
            "layout: layout \"fib:1000000000\" has 1000000000 samples, more than the limit 1000000",
        ),
        (
            CONFIG.replace("fib:30", "cube:5000000000"),
            "more than the limit",
        ),
        (
            format!("name = \"../x\"\n{CONFIG}"),
            "c.toml:1: name: \"../x\" contains '/'",
        ),
    ];
    for (text, needle) in cases {
        let e = parse(&text).err().expect("must be refused");
        println!("{e}");
        assert!(e.contains(needle), "{e}\n  does not contain\n{needle}");
    }
    // An override names its flag.
    let ov = Overrides {
        set: vec!["hemisphere_res=0".into()],
        ..Default::default()
    };
    let e = Plan::parse("c.toml", "c", CONFIG, &ov, &registry())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("--set hemisphere_res=0: hemisphere_res: 0 is outside"),
        "{e}"
    );
    let ov = Overrides {
        sweep: vec!["on_surface_eps=0.1,x".into()],
        ..Default::default()
    };
    let e = Plan::parse("c.toml", "c", CONFIG, &ov, &registry())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("--sweep on_surface_eps=0.1,x: on_surface_eps: invalid type"),
        "{e}"
    );
}

#[test]
fn limits_refuse_huge_plans_with_the_estimate() {
    let big = CONFIG
        .replace("mesh = \"sphere\"", "mesh = \"bunny\"")
        .replace("hemisphere_res = 6", "hemisphere_res = 256")
        .replace("fib:30", "fib:100000");
    let p = parse(&big).unwrap();
    let e = p.check_limits(false).unwrap_err().to_string();
    assert!(
        e.contains("rays") && e.contains("hemisphere_res = 256") && e.contains("--allow-large"),
        "{e}"
    );
    assert!(p.check_limits(true).is_ok());
    assert!(parse(CONFIG).unwrap().check_limits(false).is_ok());
    let d = p.describe(None);
    assert!(
        d.contains("6 run(s) in 2 group(s)") && d.contains("nothing written"),
        "{d}"
    );
}

#[test]
fn runs_resume_validate_rows_and_shards_partition() {
    let plan = parse(CONFIG).unwrap();
    let d = tmp("resume");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((s.ran, s.already_done), (6, 0));
    assert_eq!(ids_in(&s.csv).len(), 12, "two radii per run");
    let m = Manifest::read(&s.dir).unwrap().unwrap();
    assert_eq!(m.versions.len(), 1);
    assert!(!m.versions[0].provenance.cpu_model.is_empty());
    // The Fig. 5 image of every run: truth | extrapolated, one row per radius.
    for r in &plan.runs {
        let exr = s
            .dir
            .join(format!("visibility_truth_vs_extrapolated_{}.exr", r.id));
        let (w, h, _) = shscale_present::image::read_exr(&exr).unwrap();
        assert_eq!((w, h), (512, 256));
    }
    let again = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((again.ran, again.already_done), (0, 6));
    // A truncated last row and a garbage row: both set aside (kept in runs.csv.rejected), the
    // truncated run redone.
    let text = std::fs::read_to_string(&s.csv).unwrap();
    let cut = &text[..text.len() - 20];
    std::fs::write(&s.csv, format!("{cut}\nnot,a,row\n")).unwrap();
    let warns = std::sync::Mutex::new(Vec::new());
    let resumed = run_plan(&plan, &d, None, &|ev| {
        if let shscale_runner::RunEvent::Warn(w) = ev {
            warns.lock().unwrap().push(w.to_string());
        }
    })
    .unwrap();
    assert_eq!(
        (resumed.ran, resumed.already_done, resumed.redone),
        (1, 5, 1)
    );
    let warns = warns.into_inner().unwrap();
    println!("{warns:#?}");
    assert!(warns.iter().any(|w| w.contains("cells, the header has")));
    assert!(warns.iter().any(|w| w.contains("partial")));
    assert_eq!(ids_in(&s.csv).len(), 12);
    let rejected = std::fs::read_to_string(s.dir.join("runs.csv.rejected")).unwrap();
    assert!(rejected.contains("not,a,row"));
    assert!(std::fs::read_dir(&s.dir).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains(".tmp-")));
    // A row whose run id does not match its parameters is set aside too.
    let text = std::fs::read_to_string(&s.csv).unwrap();
    let forged = text.replacen(",0.001,", ",0.002,", 1);
    std::fs::write(&s.csv, &forged).unwrap();
    let l = load_rows(&PROBE, &s.csv).unwrap();
    assert!(
        l.rejected
            .iter()
            .any(|(_, why, _)| why.contains("does not match its parameters")),
        "{:?}",
        l.rejected
    );
    // Shards: disjoint, together everything.
    let d2 = tmp("shards");
    let a = run_plan(&plan, &d2, Some((0, 2)), &|_| {}).unwrap();
    let b = run_plan(&plan, &d2, Some((1, 2)), &|_| {}).unwrap();
    let (ia, ib): (HashSet<String>, HashSet<String>) = (
        ids_in(&a.csv).into_iter().collect(),
        ids_in(&b.csv).into_iter().collect(),
    );
    assert!(ia.is_disjoint(&ib));
    let all: HashSet<String> = plan.runs.iter().map(|r| r.id.clone()).collect();
    assert_eq!(ia.union(&ib).cloned().collect::<HashSet<_>>(), all);
    assert!(run_plan(&plan, &d2, Some((2, 2)), &|_| {}).is_err());
    // A CSV with other columns is never overwritten.
    std::fs::write(&s.csv, "something,else\n1,2\n").unwrap();
    let e = run_plan(&plan, &d, None, &|_| {}).unwrap_err().to_string();
    assert!(e.contains("left untouched"), "{e}");
    assert_eq!(
        std::fs::read_to_string(&s.csv).unwrap(),
        "something,else\n1,2\n"
    );
    std::fs::remove_dir_all(&d).ok();
    std::fs::remove_dir_all(&d2).ok();
}

#[test]
fn plots_are_written_as_png_and_svg_with_labelled_axes() {
    let plan = parse(&CONFIG.replace("[sweep]", "parallel_runs = false\n[sweep]")).unwrap();
    let d = tmp("plots");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    let r = shscale_runner::report(&PROBE, &s.dir).unwrap();
    let pngs: Vec<_> = r
        .files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
        .collect();
    assert_eq!(
        pngs.len(),
        4,
        "two numeric axes (α, order), their heat map and the Pareto plot: {:?}",
        r.files
    );
    for f in &r.files {
        let len = std::fs::metadata(f).unwrap().len();
        assert!(len > 1000, "{} is only {len} bytes", f.display());
    }
    let svg = std::fs::read_to_string(s.dir.join("occ_rel_l2_vs_alpha_deg.svg")).unwrap();
    assert!(
        svg.contains("cone angle α (°)") && svg.contains("SH order N = 2"),
        "axis label or series missing"
    );
    assert!(
        r.summary.contains("parameters that vary: order, alpha_deg"),
        "{}",
        r.summary
    );
    std::fs::remove_dir_all(&d).ok();
}

/// Files written together (rows + manifest) are a unit: when the second cannot be written, the
/// first keeps its old bytes and no temporary is left behind.
#[test]
fn files_written_together_are_a_unit() {
    use shscale_runner::write_atomic_all;
    let d = std::env::temp_dir().join(format!("shscale-unit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let (a, b) = (d.join("runs.csv"), d.join("manifest.toml"));
    std::fs::write(&a, "old rows").unwrap();
    std::fs::write(&b, "old manifest").unwrap();
    // The second file's temporary is blocked by a directory: its write fails.
    let blocker = shscale_files::atomic::tmp_path(&b);
    std::fs::create_dir(&blocker).unwrap();
    assert!(write_atomic_all(&[(&a, "new rows"), (&b, "new manifest")]).is_err());
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "old rows");
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "old manifest");
    std::fs::remove_dir(&blocker).unwrap();
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left.len(), 2, "temporaries left: {left:?}");
    // A directory at a target is refused before anything is written.
    let e = write_atomic_all(&[(&a, "new rows"), (&d, "x")])
        .unwrap_err()
        .to_string();
    assert!(e.contains("directory"), "{e}");
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "old rows");
    write_atomic_all(&[(&a, "new rows"), (&b, "new manifest")]).unwrap();
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "new manifest");
    std::fs::remove_dir_all(&d).ok();
}

/// The `--dry-run` ray count against the rays the runs record: per group the BSV (`bsv_rays`,
/// one timed call) and per probe radius the truth (`probes × truth_rays`), plus the one stage the
/// rows do not record, the decomposition's converged truth at the probe directions on the
/// sampling sphere (one more truth per probe), and the BSV at the probe directions. A mesh, so the truths are ray traced; two groups
/// (sampling radii) and two runs each (α), so shared work must be counted once per group.
#[test]
fn the_estimated_ray_count_is_the_rays_the_runs_record() {
    let text = r#"
experiment = "probe"
mesh = "bunny"
order = 2
layout = "fib:24"
hemisphere_res = 4
truth_res = 8
k_count = 4
radii = [0.9, 2.0]
timing_repeats = 1
timing_warmup = 0

[sweep]
alpha_deg = [30, 60]
sampling_radius = [1.0, 1.1]
"#;
    let plan = parse(text).unwrap();
    let d = tmp("rays");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    let t = shscale_runner::records::Results::read(&s.csv).unwrap();
    let mut groups = std::collections::BTreeMap::new();
    let mut truths = std::collections::BTreeMap::new();
    for i in 0..t.rows.len() {
        let (g, rad) = (t.cell(i, "sampling_radius"), t.cell(i, "radius"));
        let truth = t.num(i, "probes") * t.num(i, "truth_rays");
        groups.insert(g.to_string(), (t.num(i, "bsv_rays"), truth));
        truths.insert((g.to_string(), rad.to_string()), truth);
    }
    assert_eq!((groups.len(), truths.len()), (2, 4));
    let decomposition: f64 = groups.values().map(|(_, t)| t).sum();
    let recorded: f64 = groups.values().map(|(b, _)| b).sum::<f64>() + truths.values().sum::<f64>();
    // And the BSV at the probe directions (for the decomposition's exact-direction term): as
    // many probes as samples, H² rays each, so the count of the sample BSV again.
    let direct: f64 = groups.values().map(|(b, _)| b).sum();
    let expected = recorded + decomposition + direct;
    let rel = (plan.estimate().rays - expected).abs() / expected;
    println!(
        "estimated {:.6e} rays, recorded {recorded:.6e} + decomposition {decomposition:.6e} + direct {direct:.6e}: relative difference {rel:.2e}",
        plan.estimate().rays
    );
    assert!(
        rel < 1e-12,
        "estimate {} vs {expected}",
        plan.estimate().rays
    );
    std::fs::remove_dir_all(&d).ok();
}
