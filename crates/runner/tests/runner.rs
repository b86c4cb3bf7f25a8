//! The runner on a small kind of its own (no numerical crate, no GPU): sweep expansion and run
//! ids, config errors at their place, validation through the kind, resume with rows set aside,
//! shards that partition the plan and their merge, the manifest and its provenance, the summary,
//! the Slurm script, and a kind's error carried through the seam.

use serde::{Deserialize, Serialize};
use shscale_runner::config::Overrides;
use shscale_runner::{
    header, load_rows, merge, run_plan, slurm_script, Cost, Ctx, DynKind, Erased, Error, KeyError,
    Kind, Manifest, MergeOptions, Plan, RunEvent, SlurmOptions,
};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// `value = scale · n` per run, one row per `repeat`; `fail = true` makes the run fail.
struct Product;

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ProductParams {
    scale: f64,
    n: usize,
    label: String,
    repeat: usize,
    fail: bool,
    panic: bool,
    sleep_ms: u64,
}

impl Default for ProductParams {
    fn default() -> Self {
        Self {
            scale: 1.0,
            n: 1,
            label: "a".into(),
            repeat: 1,
            fail: false,
            panic: false,
            sleep_ms: 0,
        }
    }
}

#[derive(Debug, Default, Serialize, Deserialize)]
struct ProductRow {
    index: usize,
    value: f64,
    seconds: f64,
}

/// The kind's own error type, converted at the seam.
#[derive(Debug, thiserror::Error)]
#[error("product failed for n = {0}")]
struct ProductError(usize);

impl From<ProductError> for Error {
    fn from(e: ProductError) -> Self {
        Error::Kind(Box::new(e))
    }
}

impl Kind for Product {
    const NAME: &'static str = "product";
    const QUESTION: &'static str = "What is scale × n?";
    type Params = ProductParams;
    type Shared = f64;
    type Row = ProductRow;
    type Error = ProductError;
    type Spec = ProductParams;

    fn resolve(p: &ProductParams) -> Result<ProductParams, KeyError> {
        if !(p.scale.is_finite() && p.scale > 0.0) {
            return Err(KeyError::new("scale", format!("{} is not > 0", p.scale)));
        }
        if !(1..=4).contains(&p.repeat) {
            return Err(KeyError::new(
                "repeat",
                format!("{} is outside 1..=4", p.repeat),
            ));
        }
        Ok(p.clone())
    }
    fn group_key(p: &ProductParams) -> String {
        format!("scale={}", p.scale)
    }
    fn cost(p: &ProductParams) -> (Cost, Cost) {
        let run = Cost {
            seconds: 1e-6 * p.n as f64,
            drivers: format!("n = {}", p.n),
            // A one-off per label, shared by its runs through a cache (the estimate's test).
            cached_once: (p.label.starts_with("fit")).then(|| (p.label.clone(), 10.0)),
            ..Cost::default()
        };
        (Cost::default(), run)
    }
    fn rows_per_run(p: &ProductParams) -> usize {
        p.repeat
    }
    fn shared(p: &ProductParams, _: &Ctx) -> Result<f64, ProductError> {
        Ok(p.scale)
    }
    fn run(
        p: &ProductParams,
        _: &str,
        shared: &f64,
        ctx: &Ctx,
    ) -> Result<Vec<ProductRow>, ProductError> {
        assert!(ctx.device.is_none(), "the default opens no device");
        std::thread::sleep(std::time::Duration::from_millis(p.sleep_ms));
        if p.fail {
            return Err(ProductError(p.n));
        }
        assert!(!p.panic, "the run of n = {} panics", p.n);
        Ok((0..p.repeat)
            .map(|index| ProductRow {
                index,
                value: shared * p.n as f64,
                seconds: 0.0,
            })
            .collect())
    }
    fn time_columns() -> &'static [&'static str] {
        &["seconds"]
    }
    fn summary_columns() -> &'static [&'static str] {
        &["value"]
    }
    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("scale", "the factor, > 0"),
            ("n", "the count"),
            ("label", "a word"),
            ("repeat", "rows per run, 1..=4"),
            ("fail", "make the run fail"),
            ("panic", "make the run panic"),
            ("sleep_ms", "milliseconds the run sleeps"),
        ]
    }
}

static PRODUCT: Erased<Product> = Erased::new();

fn registry() -> Vec<&'static dyn DynKind> {
    vec![&PRODUCT]
}

const CONFIG: &str = r#"
experiment = "product"
scale = 2.0
repeat = 2
timing_repeats = 1

[sweep]
n = [1, 2, 3]
label = ["a", "b"]
"#;

fn parse(text: &str) -> Result<Plan, String> {
    Plan::parse("c.toml", "c", text, &Overrides::default(), &registry()).map_err(|e| e.to_string())
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-runner-own-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ids_in(csv: &Path) -> Vec<String> {
    let l = load_rows(&PRODUCT, csv).unwrap();
    assert!(l.rejected.is_empty(), "invalid rows: {:?}", l.rejected);
    l.rows.iter().map(|r| r[0].clone()).collect()
}

#[test]
fn sweeps_expand_into_unique_deterministic_ids_and_every_parameter_is_a_column() {
    let (a, b) = (parse(CONFIG).unwrap(), parse(CONFIG).unwrap());
    assert_eq!(a.runs.len(), 6);
    let ids: Vec<&str> = a.runs.iter().map(|r| r.id.as_str()).collect();
    assert_eq!(
        ids,
        b.runs.iter().map(|r| r.id.as_str()).collect::<Vec<_>>()
    );
    assert_eq!(ids.iter().collect::<HashSet<_>>().len(), 6);
    // Axes in the order the runner expands them (sorted keys).
    assert_eq!(a.axes, ["label", "n"]);
    let h = header(&PRODUCT);
    for k in [
        "run_id",
        "experiment",
        "scale",
        "n",
        "label",
        "repeat",
        "fail",
        "value",
        "git_revision",
    ] {
        assert!(h.iter().any(|c| c == k), "{k} missing from {h:?}");
    }
    // One group: every run shares `scale`.
    assert_eq!(a.groups().len(), 1);
    // An override changes the ids (the fixed key is part of every run's parameters).
    let ov = Overrides {
        set: vec!["scale=3".into()],
        ..Overrides::default()
    };
    let c = Plan::parse("c.toml", "c", CONFIG, &ov, &registry()).unwrap();
    assert!(c.runs.iter().all(|r| !ids.contains(&r.id.as_str())));
}

#[test]
fn config_errors_name_file_line_and_key() {
    let cases = [
        (
            CONFIG.replace("repeat = 2", "repeat = 2\nbogus = 1"),
            "c.toml:5: bogus: unknown field",
        ),
        (
            CONFIG.replace("repeat = 2", "repeat = 9"),
            "c.toml:4: repeat: 9 is outside 1..=4",
        ),
        (
            CONFIG.replace("scale = 2.0", "scale = -1.0"),
            "c.toml:3: scale: -1 is not > 0",
        ),
        (
            CONFIG.replace("n = [1, 2, 3]", "n = [1, 2, 1]"),
            "sweep.n: value 1 appears twice",
        ),
        (
            CONFIG.replace("\"product\"", "\"paint\""),
            "c.toml:2: experiment: \"paint\" is not a known experiment kind",
        ),
        (
            CONFIG.replace("n = [1, 2, 3]", "n = [\"x\"]"),
            "c.toml:8: n: invalid type",
        ),
    ];
    for (text, want) in cases {
        let e = parse(&text).err().unwrap_or_default();
        println!("{e}");
        assert!(e.contains(want), "want {want:?}, got {e:?}");
    }
}

/// The place of a config error reaches the caller as a value (file, line, key), not only as
/// words: a tool (an editor, the Python client) can point at the line.
#[test]
fn config_errors_keep_their_place_as_a_value() {
    use shscale_runner::config::Place;
    let text = CONFIG.replace("repeat = 2", "repeat = 9");
    let e = Plan::parse("c.toml", "c", &text, &Overrides::default(), &registry())
        .err()
        .expect("repeat = 9 is refused");
    println!("{e:?}");
    match e {
        shscale_runner::Error::Place(c) => {
            assert_eq!(c.key, "repeat");
            assert_eq!(
                c.place,
                Place::Line {
                    file: "c.toml".into(),
                    line: 4
                }
            );
        }
        other => panic!("want a placed config error, got {other:?}"),
    }
    let e = Plan::parse(
        "c.toml",
        "c",
        CONFIG,
        &Overrides {
            set: vec!["scale=-1".to_string()],
            ..Overrides::default()
        },
        &registry(),
    )
    .err()
    .expect("--set scale=-1 is refused");
    println!("{e}");
    match e {
        shscale_runner::Error::Place(c) => {
            assert!(
                matches!(c.place, Place::Flag(ref f) if f.contains("scale=-1")),
                "{c:?}"
            );
        }
        other => panic!("want a placed config error, got {other:?}"),
    }
}

#[test]
fn resume_sets_bad_rows_aside_and_redoes_their_runs() {
    let plan = parse(CONFIG).unwrap();
    let d = tmp("resume");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((s.ran, s.already_done), (6, 0));
    assert_eq!(ids_in(&s.csv).len(), 12, "two rows per run");
    let m = Manifest::read(&s.dir).unwrap().unwrap();
    assert_eq!((m.experiment.as_str(), m.versions.len()), ("product", 1));
    assert_eq!(m.versions[0].provenance.gpu_device, "none");
    let again = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!((again.ran, again.already_done), (0, 6));
    // A torn last line and a garbage row: both set aside, the torn run redone.
    let text = std::fs::read_to_string(&s.csv).unwrap();
    std::fs::write(&s.csv, format!("{}\nnot,a,row\n", &text[..text.len() - 8])).unwrap();
    let warns = std::sync::Mutex::new(Vec::new());
    let r = run_plan(&plan, &d, None, &|ev| {
        if let RunEvent::Warn(w) = ev {
            warns.lock().unwrap().push(w.to_string());
        }
    })
    .unwrap();
    assert_eq!((r.ran, r.already_done, r.redone), (1, 5, 1));
    let warns = warns.into_inner().unwrap();
    assert!(
        warns.iter().any(|w| w.contains("cells, the header has")),
        "{warns:?}"
    );
    assert_eq!(ids_in(&s.csv).len(), 12);
    let rejected = std::fs::read_to_string(s.dir.join("runs.csv.rejected")).unwrap();
    assert!(rejected.contains("not,a,row"));
    // A row whose cells no longer reproduce its run id is set aside.
    let text = std::fs::read_to_string(&s.csv).unwrap();
    std::fs::write(&s.csv, text.replacen(",2.0,", ",5.0,", 1)).unwrap();
    let l = load_rows(&PRODUCT, &s.csv).unwrap();
    assert!(
        l.rejected
            .iter()
            .any(|(_, why, _)| why.contains("does not match its parameters")),
        "{:?}",
        l.rejected
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn shards_partition_the_plan_and_merge_joins_them() {
    let plan = parse(CONFIG).unwrap();
    let d = tmp("shards");
    // As the Slurm array runs them: every shard into the same directory, a file each.
    let shards: Vec<_> = (0..3)
        .map(|i| run_plan(&plan, &d, Some((i, 3)), &|_| {}).unwrap())
        .collect();
    let sets: Vec<HashSet<String>> = shards
        .iter()
        .map(|s| ids_in(&s.csv).into_iter().collect())
        .collect();
    for i in 0..3 {
        for j in i + 1..3 {
            assert!(sets[i].is_disjoint(&sets[j]), "shards {i} and {j} overlap");
        }
    }
    let all: HashSet<String> = plan.runs.iter().map(|r| r.id.clone()).collect();
    assert_eq!(sets.iter().flatten().cloned().collect::<HashSet<_>>(), all);
    assert!(run_plan(&plan, &d, Some((3, 3)), &|_| {}).is_err());
    let dirs = vec![shards[0].dir.clone()];
    let out = d.join("merged");
    let m = merge(&dirs, Some(&out), &registry(), MergeOptions::default()).unwrap();
    assert_eq!((m.files, m.rows), (3, 12));
    assert_eq!(
        ids_in(&out.join("runs.csv"))
            .into_iter()
            .collect::<HashSet<_>>(),
        all
    );
    // A merge never overwrites its output.
    let e = merge(&dirs, Some(&out), &registry(), MergeOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("runs.csv"), "{e}");
    // A merge knows its plan: a missing shard file (or runs without rows) is refused, naming
    // it, unless --allow-partial, which records what is missing in the manifest. Before, the
    // merge exited 0 with 8 of 12 rows.
    std::fs::remove_file(shards[1].csv.clone()).unwrap();
    let out2 = d.join("merged2");
    let e = merge(&dirs, Some(&out2), &registry(), MergeOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("1 of 3 shard files missing (runs.shard-1-of-3.csv)")
            && e.contains("2 of the plan's 6 runs have no rows")
            && e.contains("--allow-partial"),
        "{e}"
    );
    assert!(!out2.exists(), "a refused merge writes nothing");
    let partial = MergeOptions {
        allow_partial: true,
        ..MergeOptions::default()
    };
    let m = merge(&dirs, Some(&out2), &registry(), partial).unwrap();
    assert_eq!(m.rows, 8);
    let manifest = Manifest::read(&out2).unwrap().unwrap();
    assert_eq!(manifest.missing.len(), 2, "{:?}", manifest.missing);
    // A shard whose runs are all there but whose file lost a run's rows: refused too.
    let text = std::fs::read_to_string(&shards[2].csv).unwrap();
    let kept: Vec<&str> = text.lines().take(text.lines().count() - 2).collect();
    std::fs::write(&shards[2].csv, kept.join("\n") + "\n").unwrap();
    run_plan(&plan, &d, Some((1, 3)), &|_| {}).unwrap();
    let e = merge(
        &dirs,
        Some(&d.join("merged3")),
        &registry(),
        MergeOptions::default(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("1 of the plan's 6 runs have no rows"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn merge_refuses_mixed_versions_and_revisions_and_replaces_only_when_asked() {
    let plan = parse(CONFIG).unwrap();
    let d = tmp("mixed");
    for i in 0..2 {
        run_plan(&plan, &d, Some((i, 2)), &|_| {}).unwrap();
    }
    let dir = d.join("product").join("c");
    let out = d.join("merged");
    let dirs = vec![dir.clone()];
    let replace = MergeOptions {
        replace: true,
        ..MergeOptions::default()
    };
    // The merge a script owns replaces its own output, atomically and with the same rows.
    merge(&dirs, Some(&out), &registry(), MergeOptions::default()).unwrap();
    let first = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    let m = merge(&dirs, Some(&out), &registry(), replace).unwrap();
    assert_eq!(m.rows, 12);
    assert_eq!(
        std::fs::read_to_string(out.join("runs.csv")).unwrap(),
        first
    );
    // Rows of another numerical code in one shard: refused, naming both files.
    let shard = dir.join("runs.shard-1-of-2.csv");
    let text = std::fs::read_to_string(&shard).unwrap();
    let rev = &load_rows(&PRODUCT, &shard).unwrap().rows[0];
    let at = header(&PRODUCT).iter().position(|c| c == "code").unwrap();
    let other = text.replace(&format!(",{},", rev[at]), ",0123456789abcdef,");
    assert_ne!(other, text, "the code cell was not found to change");
    std::fs::write(&shard, other).unwrap();
    let e = merge(&dirs, Some(&out), &registry(), replace)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("numerical code 0123456789abcdef")
            && e.contains("runs.shard-1-of-2.csv")
            && e.contains("runs.shard-0-of-2.csv"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("runs.csv")).unwrap(),
        first,
        "a refused merge changes nothing"
    );
    let mixed = MergeOptions {
        replace: true,
        allow_mixed: true,
        ..MergeOptions::default()
    };
    assert_eq!(
        merge(&dirs, Some(&out), &registry(), mixed).unwrap().rows,
        12
    );
    std::fs::write(&shard, text).unwrap();
    // A second config version in the same directory (an edited fixed key): refused.
    let edited = parse(&CONFIG.replace("scale = 2.0", "scale = 3.0")).unwrap();
    run_plan(&edited, &d, None, &|_| {}).unwrap();
    let e = merge(&dirs, Some(&out), &registry(), replace)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("2 config versions") && e.contains("--allow-mixed"),
        "{e}"
    );
    assert_eq!(
        merge(&dirs, Some(&out), &registry(), mixed).unwrap().rows,
        24
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_kinds_error_reaches_the_caller_and_no_row_is_written_for_it() {
    let plan = parse(&CONFIG.replace("repeat = 2", "repeat = 2\nfail = true")).unwrap();
    let d = tmp("fail");
    let e = run_plan(&plan, &d, None, &|_| {}).unwrap_err();
    assert!(matches!(e, Error::Kind(_)), "{e:?}");
    assert!(e.to_string().starts_with("product failed for n = "), "{e}");
    let csv = d.join("product").join("c").join("runs.csv");
    assert!(!csv.exists() || ids_in(&csv).is_empty());
    std::fs::remove_dir_all(&d).ok();
}

/// A run that panics (a bug: kinds return errors) ends `run_plan` with that panic instead of
/// leaving it waiting on the commit timer (which once kept a process running with only its
/// lock left), and the runs finished before it are committed.
#[test]
fn a_panicking_run_ends_the_plan_and_keeps_the_finished_runs() {
    let text = "experiment = \"product\"\nparallel_runs = false\n\n[[sweep]]\nn = [1, 2]\n\n[[sweep]]\nn = [3]\npanic = [true]\n";
    let plan = parse(text).unwrap();
    let d = tmp("panic");
    let (tx, rx) = std::sync::mpsc::channel();
    let d2 = d.clone();
    std::thread::spawn(move || {
        let plan = parse(text).unwrap();
        let quiet = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            run_plan(&plan, &d2, None, &|_| {}).map(|_| ())
        }));
        tx.send(quiet.is_err()).ok();
    });
    let panicked = rx
        .recv_timeout(std::time::Duration::from_secs(30))
        .expect("run_plan returned within 30 s of its run's panic");
    assert!(panicked, "the run's panic reached the caller");
    let csv = d.join("product").join("c").join("runs.csv");
    let want: Vec<String> = plan.runs[..2].iter().map(|r| r.id.clone()).collect();
    assert_eq!(ids_in(&csv), want, "the two finished runs kept");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn runs_finished_before_an_error_are_committed_not_lost() {
    // Sequential fast runs wait for the next group commit (100 ms); the fourth fails, and the
    // three before it must still reach the file, whole and valid.
    let text = "experiment = \"product\"\nparallel_runs = false\n\n[[sweep]]\nn = [1, 2, 3]\n\n[[sweep]]\nn = [4]\nfail = [true]\n";
    let plan = parse(text).unwrap();
    let d = tmp("commit-on-error");
    let e = run_plan(&plan, &d, None, &|_| {}).unwrap_err();
    assert!(e.to_string().starts_with("product failed for n = 4"), "{e}");
    let csv = d.join("product").join("c").join("runs.csv");
    let ids = ids_in(&csv);
    let want: Vec<String> = plan.runs[..3].iter().map(|r| r.id.clone()).collect();
    assert_eq!(ids, want, "the three finished runs, once each");
    // A resume redoes only the failed run (and fails again), adding nothing twice.
    let e = run_plan(&plan, &d, None, &|_| {}).unwrap_err();
    assert!(e.to_string().starts_with("product failed for n = 4"), "{e}");
    assert_eq!(ids_in(&csv), want);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_run_finished_before_a_long_one_is_committed_while_the_long_one_runs() {
    // The first run finishes at once, within the commit window of the plan's start; the second
    // sleeps 2 s. The first run's row must reach the file by the commit timer (within
    // COMMIT_INTERVAL, 100 ms, of finishing), not wait for the second run to finish: a SIGKILL
    // during the long run would otherwise lose it.
    let text = "experiment = \"product\"\nparallel_runs = false\n\n[sweep.zip]\nn = [1, 2]\nsleep_ms = [0, 2000]\n";
    let plan = parse(text).unwrap();
    let d = tmp("commit-timer");
    let csv = d.join("product").join("c").join("runs.csv");
    std::thread::scope(|s| {
        let run = s.spawn(|| run_plan(&plan, &d, None, &|_| {}));
        let t0 = std::time::Instant::now();
        let mut seen = None;
        while t0.elapsed() < std::time::Duration::from_millis(1500) {
            if csv.exists() && ids_in(&csv).contains(&plan.runs[0].id) {
                seen = Some(t0.elapsed());
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        let seen = seen.expect("the finished run's row was not committed while the long run ran");
        println!(
            "the first run's row was in the file {} ms after the plan started",
            seen.as_millis()
        );
        assert!(!run.is_finished(), "the long run was still running");
        run.join().unwrap().unwrap();
    });
    assert_eq!(ids_in(&csv).len(), 2);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_long_plan_writes_its_report_while_it_runs_never_per_run_when_fast() {
    // Runs of 150 ms are each committed at once; with the interim interval at zero, the summary
    // of the rows so far follows each commit, and says how many rows it saw.
    let text = "experiment = \"product\"\nparallel_runs = false\nsleep_ms = 150\n\n[sweep]\nn = [1, 2, 3]\n";
    let mut plan = parse(text).unwrap();
    plan.interim_report = Some(std::time::Duration::ZERO);
    let d = tmp("interim");
    let dir = d.join("product").join("c");
    let seen = std::sync::Mutex::new(Vec::new());
    run_plan(&plan, &d, None, &|ev| {
        if let RunEvent::Interim(p) = ev {
            assert_eq!(p, dir);
            let s = std::fs::read_to_string(p.join("summary.md")).unwrap();
            let rows = s
                .split("Rows: ")
                .nth(1)
                .and_then(|t| t.split(' ').next())
                .and_then(|n| n.parse::<usize>().ok())
                .unwrap_or_else(|| panic!("no row count in {s}"));
            assert!(p.join("report.html").exists());
            seen.lock().unwrap().push(rows);
        }
    })
    .unwrap();
    let seen = seen.into_inner().unwrap();
    println!("interim reports saw {seen:?} rows");
    assert_eq!(
        seen,
        [1, 2, 3],
        "one interim report after each run's commit"
    );
    // Fast runs are committed together and the default interval (30 s) is never reached: no
    // interim report.
    let fast = parse(&text.replace("sleep_ms = 150", "sleep_ms = 0")).unwrap();
    let d2 = tmp("interim-fast");
    let n = std::sync::atomic::AtomicUsize::new(0);
    run_plan(&fast, &d2, None, &|ev| {
        if matches!(ev, RunEvent::Interim(_)) {
            n.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    })
    .unwrap();
    assert_eq!(n.into_inner(), 0);
    assert!(!d2.join("product").join("c").join("summary.md").exists());
    std::fs::remove_dir_all(&d).ok();
    std::fs::remove_dir_all(&d2).ok();
}

#[test]
fn summary_and_slurm_script_of_a_plan() {
    let plan = parse(CONFIG).unwrap();
    let d = tmp("report");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    let r = shscale_runner::report(&PRODUCT, &s.dir).unwrap();
    // The kind's rows as computed: value = scale · n.
    assert!(r.summary.contains("| 3 | b | 6.0000 |"), "{}", r.summary);
    assert!(
        r.summary.contains("parameters that vary: n, label"),
        "{}",
        r.summary
    );
    assert!(s.dir.join("report.html").exists() && s.dir.join("summary.md").exists());
    let script = slurm_script(
        Path::new("my configs/c.toml"),
        &plan,
        3,
        "shscale",
        &d,
        &SlurmOptions::default(),
    )
    .unwrap();
    assert!(script.contains("--array=0-2"), "{script}");
    assert!(
        script.contains("'my configs/c.toml'"),
        "the path is shell-quoted: {script}"
    );
    assert!(slurm_script(
        Path::new("c.toml"),
        &plan,
        0,
        "shscale",
        &d,
        &SlurmOptions::default()
    )
    .is_err());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn large_results_are_summarised_by_distributions_not_listed() {
    // 300 runs (one row each): more than the summary lists one by one.
    let ns: Vec<String> = (1..=300).map(|n| n.to_string()).collect();
    let text = format!(
        "experiment = \"product\"\nscale = 2.0\n[sweep]\nn = [{}]\n",
        ns.join(", ")
    );
    let plan = parse(&text).unwrap();
    let d = tmp("large");
    let s = run_plan(&plan, &d, None, &|_| {}).unwrap();
    assert_eq!(s.ran, 300);
    let r = shscale_runner::report(&PRODUCT, &s.dir).unwrap();
    println!("{}", r.summary);
    assert!(
        r.summary.contains("300 rows are too many to list"),
        "{}",
        r.summary
    );
    // value = 2n for n = 1..=300: mean 301, nearest-rank median 2·151, p10 2·31, p90 2·270.
    assert!(
        r.summary
            .contains("| value | 300 | 301.0000 | 62.0000 | 302.0000 | 540.0000 |"),
        "{}",
        r.summary
    );
    assert!(r.summary.contains("`n` takes 300 values"), "{}", r.summary);
    assert!(r.summary.len() < 4_000, "{} bytes", r.summary.len());
    // Rows are still one per run in runs.csv, in plan order.
    let ids = ids_in(&s.csv);
    let want: Vec<String> = plan.runs.iter().map(|r| r.id.clone()).collect();
    assert_eq!(ids, want);
    std::fs::remove_dir_all(&d).ok();
}

/// `--set KEY=V` reaches every sweep block that sweeps KEY (it was silently overridden by the
/// blocks' own lists): the blocks keep their other axes; where that makes two blocks' runs the
/// same, the error names both blocks and the flag.
#[test]
fn set_overrides_reach_every_sweep_block() {
    let text = "experiment = \"product\"\n\n[[sweep]]\nn = [1, 2]\nlabel = [\"a\"]\n\n[[sweep]]\nlabel = [\"b\"]\n[sweep.zip]\nn = [3, 4]\nscale = [1.0, 2.0]\n";
    let set = |v: &str| Overrides {
        set: vec![v.to_string()],
        ..Overrides::default()
    };
    let plan = Plan::parse("c.toml", "c", text, &set("n=5"), &registry()).unwrap();
    let cells: Vec<(String, String)> = (plan.runs.iter())
        .map(|r| {
            let col = |name: &str| {
                let i = plan
                    .kind
                    .param_columns()
                    .iter()
                    .position(|c| c == name)
                    .unwrap();
                r.cells[i].clone()
            };
            (col("n"), col("label"))
        })
        .collect();
    println!("{cells:?}");
    // Block 1: n = [5] × label a; block 2: the zip's n set to 5 in both entries (scale 1, 2).
    assert_eq!(cells.len(), 3);
    assert!(cells.iter().all(|(n, _)| n == "5"), "{cells:?}");
    // Two blocks alike after the override: named, with the flag.
    let alike = "experiment = \"product\"\n\n[[sweep]]\nn = [1, 2]\n\n[[sweep]]\nn = [3]\n";
    let e = Plan::parse("c.toml", "c", alike, &set("n=5"), &registry())
        .err()
        .unwrap()
        .to_string();
    println!("{e}");
    assert!(
        e.contains("block 1") && e.contains("block 2") && e.contains("--set n=5"),
        "{e}"
    );
}

/// Work runs share through a cache (`Cost::cached_once`) is counted once per key in the plan's
/// estimate: 3 × 2 runs over two fitted labels add two fits' seconds, not six.
#[test]
fn cached_work_is_estimated_once_per_key() {
    let seconds = |labels: &str| {
        let text =
            format!("experiment = \"product\"\n[[sweep]]\nn = [1, 2, 3]\nlabel = [{labels}]\n");
        let plan = parse(&text).unwrap();
        let speed = shscale_runner::timing::machine_speed().unwrap_or(1.0);
        plan.estimate().seconds * speed
    };
    let plain = seconds("\"a\", \"b\"");
    let fitted = seconds("\"fit-a\", \"fit-b\"");
    println!("estimate {plain:.4} s without, {fitted:.4} s with two cached fits of 10 s");
    assert!((fitted - plain - 20.0).abs() < 1e-9, "{plain} {fitted}");
}

/// A timed row measured while one spinning process per CPU keeps every core busy (processes
/// this test starts) is flagged `contended`, with `other_cpu` near the CPU count; the same plan
/// run after the load stopped is not. Runs of 300 ms, so each row's window is its own.
#[test]
fn a_row_timed_under_load_is_flagged_and_a_quiet_one_is_not() {
    if !Path::new("/proc/stat").exists() {
        eprintln!("notice: no /proc: contention is not measured here; skipped");
        return;
    }
    let flagged = |tag: &str, load: bool| -> Vec<(String, String)> {
        let d = tmp(tag);
        let plan = parse("experiment = \"product\"\nsleep_ms = 300\nparallel_runs = false\n[sweep]\nn = [1, 2]\n")
            .unwrap();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let mut spinners: Vec<std::process::Child> = if load {
            (0..cpus)
                .filter_map(|_| {
                    std::process::Command::new("sh")
                        .args(["-c", "while :; do :; done"])
                        .spawn()
                        .ok()
                })
                .collect()
        } else {
            Vec::new()
        };
        std::thread::sleep(std::time::Duration::from_millis(300));
        let r = run_plan(&plan, &d, None, &|_| {});
        for s in &mut spinners {
            let _ = s.kill();
            let _ = s.wait();
        }
        r.unwrap();
        let (h, rows) = shscale_runner::records::read_raw(&d.join("product/c/runs.csv")).unwrap();
        let at = |c: &str| h.iter().position(|x| x == c).unwrap();
        let (oc, ct) = (at("other_cpu"), at("contended"));
        std::fs::remove_dir_all(&d).ok();
        rows.into_iter()
            .map(|(_, r)| (r[oc].clone(), r[ct].clone()))
            .collect()
    };
    let busy = flagged("busy", true);
    println!("under load (other_cpu, contended): {busy:?}");
    assert!(busy.iter().all(|(_, c)| c == "true"), "{busy:?}");
    std::thread::sleep(std::time::Duration::from_millis(500));
    // A shared machine may be busy by itself now and then: up to three quiet attempts.
    let mut quiet = flagged("quiet", false);
    for _ in 0..2 {
        if quiet.iter().all(|(_, c)| c == "false") {
            break;
        }
        println!("busy by itself: {quiet:?}; again");
        std::thread::sleep(std::time::Duration::from_millis(500));
        quiet = flagged("quiet", false);
    }
    println!("quiet: {quiet:?}");
    assert!(quiet.iter().all(|(_, c)| c == "false"), "{quiet:?}");
}
