//! Hostile input, round two: the surfaces added after the first hardening pass — command-line
//! overrides, merge, report, compare, plot, Slurm options, render references — and inputs that
//! are not regular files (FIFOs, devices, symlink loops, dangling links). Every case must exit
//! with status 2 within its time limit, print one stderr line naming the culprit, never panic or
//! hang (a FIFO once blocked `run`, `report` and `compare` forever), and leave every file of the
//! fixture byte-identical.

mod common;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const CONFIG: &str = "experiment = \"sparsity\"\norder = 2\n\n[sweep]\nk = [1.5, 2.0, 3.0]\n";

fn shscale(d: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shscale"))
        .args(args)
        .current_dir(d)
        .output()
        .unwrap()
}

fn mkfifo(p: &Path) -> bool {
    Command::new("mkfifo")
        .arg(p)
        .status()
        .is_ok_and(|s| s.success())
}

/// The fixture: a config, a finished results directory, its shards, and copies of them with a
/// FIFO, a symlink loop or a dangling link where a file should be.
fn fixture(tag: &str) -> Option<PathBuf> {
    let d = std::env::temp_dir().join(format!("shscale-hostile2-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("o")).unwrap();
    std::fs::write(d.join("c.toml"), CONFIG).unwrap();
    let ok = |args: &[&str]| {
        let o = shscale(&d, args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    ok(&["run", "c.toml", "--out-dir", "r"]);
    for i in 0..3 {
        ok(&[
            "run",
            "c.toml",
            "--out-dir",
            "s",
            "--shard",
            &format!("{i}/3"),
        ]);
    }
    if !mkfifo(&d.join("fifo.toml")) {
        return None;
    }
    let copy = |from: &str, to: &str| {
        std::fs::create_dir_all(d.join(to)).unwrap();
        for e in std::fs::read_dir(d.join(from)).unwrap().flatten() {
            if e.path().is_file() {
                std::fs::copy(e.path(), d.join(to).join(e.file_name())).unwrap();
            }
        }
    };
    let r = "r/sparsity/c";
    // A FIFO where runs.csv or manifest.toml should be.
    copy(r, "fc/sparsity/c");
    std::fs::remove_file(d.join("fc/sparsity/c/runs.csv")).unwrap();
    mkfifo(&d.join("fc/sparsity/c/runs.csv"));
    copy(r, "fm/sparsity/c");
    std::fs::remove_file(d.join("fm/sparsity/c/manifest.toml")).unwrap();
    mkfifo(&d.join("fm/sparsity/c/manifest.toml"));
    // runs.csv a symlink loop.
    copy(r, "loop/sparsity/c");
    std::fs::remove_file(d.join("loop/sparsity/c/runs.csv")).unwrap();
    std::os::unix::fs::symlink("runs2.csv", d.join("loop/sparsity/c/runs.csv")).unwrap();
    std::os::unix::fs::symlink("runs.csv", d.join("loop/sparsity/c/runs2.csv")).unwrap();
    // Shards: one missing, one a FIFO, a symlink loop, a dangling link.
    let s = "s/sparsity/c";
    let shard1 = "runs.shard-1-of-3.csv";
    for (to, how) in [
        ("s_missing", 0),
        ("s_fifo", 1),
        ("s_loop", 2),
        ("s_dangling", 3),
    ] {
        copy(s, to);
        let p = d.join(to).join(shard1);
        std::fs::remove_file(&p).unwrap();
        match how {
            1 => assert!(mkfifo(&p)),
            2 => {
                std::os::unix::fs::symlink("runs.shard-1-of-3b.csv", &p).unwrap();
                std::os::unix::fs::symlink(shard1, d.join(to).join("runs.shard-1-of-3b.csv"))
                    .unwrap();
            }
            3 => std::os::unix::fs::symlink("nothing.csv", &p).unwrap(),
            _ => {}
        }
    }
    // A results directory whose runs.csv lacks a headline metric's column.
    copy(r, "nocol/sparsity/c");
    let p = d.join("nocol/sparsity/c/runs.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut rd = csv::Reader::from_reader(text.as_bytes());
    let h = rd.headers().unwrap().clone();
    let at = h.iter().position(|c| c == "nonzeros").unwrap();
    let mut w = csv::Writer::from_path(&p).unwrap();
    let keep = |rec: &csv::StringRecord| -> Vec<String> {
        (rec.iter().enumerate())
            .filter(|(i, _)| *i != at)
            .map(|(_, c)| c.to_string())
            .collect()
    };
    w.write_record(keep(&h)).unwrap();
    for rec in rd.records() {
        w.write_record(keep(&rec.unwrap())).unwrap();
    }
    drop(w);
    // A results directory whose runs.csv is its header alone.
    copy(r, "hdr/sparsity/c");
    let p = d.join("hdr/sparsity/c/runs.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, text.lines().next().unwrap().to_string() + "\n").unwrap();
    // Shards where one holds rows of another numerical code.
    copy(s, "s_mixed");
    let p = d.join("s_mixed").join(shard1);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut rd = csv::Reader::from_reader(text.as_bytes());
    let h = rd.headers().unwrap().clone();
    let at = h.iter().position(|c| c == "code").unwrap();
    let mut w = csv::Writer::from_path(&p).unwrap();
    w.write_record(&h).unwrap();
    for rec in rd.records() {
        let mut cells: Vec<String> = rec.unwrap().iter().map(String::from).collect();
        cells[at] = "0123456789abcdef".into();
        w.write_record(&cells).unwrap();
    }
    drop(w);
    // A plain file where folders are expected; folders of figure configs: empty, one good, one
    // with a FIFO, one with a config that does not parse.
    std::fs::write(d.join("afile"), "not a folder\n").unwrap();
    std::fs::create_dir_all(d.join("empty")).unwrap();
    std::fs::create_dir_all(d.join("cf")).unwrap();
    std::fs::write(d.join("cf/c.toml"), CONFIG).unwrap();
    std::fs::create_dir_all(d.join("cfifo")).unwrap();
    mkfifo(&d.join("cfifo/x.toml"));
    std::fs::create_dir_all(d.join("cbad")).unwrap();
    std::fs::write(d.join("cbad/a.toml"), CONFIG).unwrap();
    std::fs::write(
        d.join("cbad/b.toml"),
        "experiment = \"sparsity\"\norder = 99\n",
    )
    .unwrap();
    // Relative mesh paths: a probe's against the working directory, a scene's against the scene
    // file's folder; a missing one is named as resolved.
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(
        d.join("sub/m.toml"),
        "experiment = \"probe\"\nmesh = \"meshes/nope.obj\"\norder = 2\nlayout = \"fib:10\"\nhemisphere_res = 2\nk_count = 4\nradii = [2.0]\n",
    )
    .unwrap();
    std::fs::write(
        d.join("sub/scene.toml"),
        "[[occluder]]\nmesh = \"x/nope.obj\"\ncenter = [0, 0, 1]\nradius = 1\n[receiver]\ncenter = [0, 0, 0]\nsize = [2, 2]\nresolution = [8, 8]\n[light]\nkind = \"sky\"\n",
    )
    .unwrap();
    // Configs for errors that must name their place.
    std::fs::write(
        d.join("zz.toml"),
        "experiment = \"sparsity\"\norder = 2\n\n[sweep.zip.zip]\nk = [1.5, 2.0]\n",
    )
    .unwrap();
    std::fs::write(
        d.join("p.toml"),
        "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:10\"\nhemisphere_res = 2\nk_count = 4\nradii = [1.5, 2.0]\n",
    )
    .unwrap();
    // A scene file and a mesh that are FIFOs.
    mkfifo(&d.join("scene.toml"));
    std::fs::create_dir_all(d.join("m")).unwrap();
    mkfifo(&d.join("m/fifo.obj"));
    std::fs::write(
        d.join("mesh_fifo.toml"),
        "experiment = \"probe\"\nmesh = \"m/fifo.obj\"\norder = 2\nlayout = \"fib:10\"\nhemisphere_res = 2\nk_count = 4\nradii = [2.0]\n",
    )
    .unwrap();
    ok(&["run", "p.toml", "--out-dir", "pr"]);
    Some(d)
}

/// The cases: arguments (split on `|`) and what the one stderr line must name.
const CASES: &[(&str, &str)] = &[
    // Override keys: dotted names with [N] indices, nothing else, bounded.
    (
        "run|c.toml|--dry-run|--set|order[abc]=3",
        "[abc] is not a list index",
    ),
    ("run|c.toml|--dry-run|--set|.order=3", "is not a name"),
    ("run|c.toml|--dry-run|--set|order.=3", "is not a name"),
    ("run|c.toml|--dry-run|--set|a..b=3", "is not a name"),
    ("run|c.toml|--dry-run|--set|=3", "is not a name"),
    ("run|c.toml|--dry-run|--set|1order=3", "is not a name"),
    ("run|c.toml|--dry-run|--set|or der=3", "is not a name"),
    (
        "run|c.toml|--dry-run|--set|order[1=3",
        "does not end with ']'",
    ),
    (
        "run|c.toml|--dry-run|--set|order[-1]=3",
        "is not a list index",
    ),
    (
        "run|c.toml|--dry-run|--set|order[]=3",
        "is not a list index",
    ),
    (
        "run|c.toml|--dry-run|--set|k[99999999999]=3",
        "is not a list index",
    ),
    ("run|c.toml|--dry-run|--set|a/../b=3", "is not a name"),
    (
        "run|c.toml|--dry-run|--sweep|order[x]=2,3",
        "--sweep order[x]=2,3",
    ),
    ("run|c.toml|--dry-run|--sweep|.k=2,3", "is not a name"),
    (
        "run|c.toml|--dry-run|--set|{DEEP17}=1",
        "more than 16 segments",
    ),
    (
        "run|c.toml|--dry-run|--set|{DEEP30000}=1",
        "more than the limit 256",
    ),
    (
        "run|c.toml|--dry-run|--sweep|{DEEP30000}=1,2",
        "more than the limit 256",
    ),
    // Overrides of every kind of value: each error names the flag.
    ("run|c.toml|--dry-run|--set|order=", "--set order=: order"),
    ("run|c.toml|--dry-run|--set|=", "is not a name"),
    ("run|c.toml|--dry-run|--set|order", "expected key=value"),
    ("run|c.toml|--dry-run|--sweep|k=", "--sweep k=: k"),
    ("run|c.toml|--dry-run|--sweep|k=1,1", "appears twice"),
    ("run|c.toml|--dry-run|--sweep|=1,2", "is not a name"),
    ("run|c.toml|--dry-run|--set|order=-1", "--set order=-1"),
    ("run|c.toml|--dry-run|--set|order=99", "1..=16"),
    (
        "run|c.toml|--dry-run|--set|tau=laser",
        "\"laser\" is not cone or midrange",
    ),
    ("run|c.toml|--dry-run|--name|../x", "no path separators"),
    ("run|c.toml|--dry-run|--name|a/b", "no path separators"),
    (
        "run|c.toml|--dry-run|--name|",
        "must be 1 to 128 characters",
    ),
    (
        "run|c.toml|--dry-run|--set|name=..",
        "must be 1 to 128 characters",
    ),
    ("run|c.toml|--dry-run|--set|timing_repeats=0", "1..=100"),
    (
        "run|c.toml|--dry-run|--set|gpu=maybe",
        "\"maybe\" is not one of",
    ),
    (
        "run|c.toml|--dry-run|--set|nosuch=1",
        "unknown field `nosuch`",
    ),
    (
        "run|c.toml|--dry-run|--sweep|nosuch=1,2",
        "--sweep nosuch=1,2",
    ),
    ("run|c.toml|--dry-run|--set|sweep=3", "--set sweep=3"),
    ("run|c.toml|--dry-run|--set|sweep.k=3", "--set sweep.k=3"),
    (
        "run|c.toml|--dry-run|--set|order=[1,2]",
        "invalid type: sequence",
    ),
    (
        "run|c.toml|--dry-run|--sweep|order=[1],[2]",
        "--sweep order=[1],[2]",
    ),
    (
        "run|c.toml|--dry-run|--set|experiment=probe",
        "unknown field `k`",
    ),
    // Results-directory commands: the culprit named, nothing written.
    (
        "plot|r/sparsity/c|--metric|outside_pattern|--x|k|--log-y",
        "a log y axis needs values > 0",
    ),
    (
        "plot|r/sparsity/c|--metric|nonzeros|--x|nosuch",
        "\"nosuch\" is not a column",
    ),
    (
        "plot|r/sparsity/c|--metric|nonzeros|--x|k|--series|nosuch",
        "\"nosuch\" is not a column",
    ),
    (
        "plot|r/sparsity/c|--metric|eta|--x|k",
        "no row has numbers in both",
    ),
    ("merge|/nonexistent", "/nonexistent"),
    (
        "merge|r/sparsity/c|--out|r/sparsity/c",
        "merge never overwrites",
    ),
    ("report|/nonexistent", "no manifest.toml"),
    ("compare|r/sparsity/c|/nonexistent", "no manifest.toml"),
    // Errors name their place: the flag that set part of a key, the line of a nested zip.
    (
        "run|p.toml|--dry-run|--set|radii[0]=nan",
        "--set radii[0]=nan",
    ),
    (
        "run|p.toml|--dry-run|--set|radii[1]=-1",
        "--set radii[1]=-1",
    ),
    ("run|zz.toml|--dry-run", "zz.toml:4: sweep.zip.zip"),
    // Inputs that are not regular files: refused by name, never read.
    ("run|fifo.toml|--dry-run", "FIFO"),
    ("run|fifo.toml", "FIFO"),
    ("run|/dev/zero|--dry-run", "device"),
    ("run|o|--dry-run", "directory"),
    ("run|c.toml|--out-dir|fc", "FIFO"),
    ("run|c.toml|--out-dir|fm", "FIFO"),
    ("run|c.toml|--out-dir|loop", "symlink loop"),
    ("report|fc/sparsity/c", "FIFO"),
    ("report|fm/sparsity/c", "FIFO"),
    ("report|loop/sparsity/c", "symlink loop"),
    ("compare|r/sparsity/c|fc/sparsity/c|--out|o/cmp", "FIFO"),
    ("compare|fc/sparsity/c|r/sparsity/c|--out|o/cmp", "FIFO"),
    ("plot|fc/sparsity/c|--metric|nonzeros|--x|k", "FIFO"),
    ("render|--scene|scene.toml|--out|o/x.exr", "FIFO"),
    ("run|mesh_fifo.toml", "regular file"),
    ("bench|runner|--config|fifo.toml|--out-dir|o/b", "FIFO"),
    (
        "bench|runner|--runs|10|--out-dir|afile",
        "--out-dir afile: exists and is not a folder",
    ),
    // Merge knows its plan: missing shards and shards that are not files are errors.
    ("merge|s_missing|--out|o/m", "runs.shard-1-of-3.csv"),
    ("merge|s_missing|--out|o/m", "--allow-partial"),
    ("merge|s_fifo|--out|o/m", "FIFO"),
    ("merge|s_loop|--out|o/m", "symlink loop"),
    ("merge|s_dangling|--out|o/m", "link to nothing"),
    // Compare: a metric missing, or without a number, on one side.
    (
        "compare|r/sparsity/c|nocol/sparsity/c|--out|o/cmp",
        "has no column \"nonzeros\"",
    ),
    (
        "compare|nocol/sparsity/c|r/sparsity/c|--out|o/cmp",
        "has no column \"nonzeros\"",
    ),
    // Slurm options.
    (
        "slurm|c.toml|--tasks|2|--cpus-per-task|0",
        "--cpus-per-task",
    ),
    (
        "slurm|c.toml|--tasks|2|--cpus-per-task|5000",
        "--cpus-per-task",
    ),
    ("slurm|c.toml|--tasks|2|--time|", "--time"),
    ("slurm|c.toml|--tasks|2|--time|2 h", "--time"),
    ("slurm|c.toml|--tasks|2|--time|-1", "--time"),
    ("slurm|c.toml|--tasks|2|--time|1:2:3:4", "--time"),
    ("slurm|c.toml|--tasks|2|--time|1-", "--time"),
    ("slurm|c.toml|--tasks|2|--mem|-5G", "--mem"),
    ("slurm|c.toml|--tasks|2|--mem|", "--mem"),
    ("slurm|c.toml|--tasks|2|--mem|8GB", "--mem"),
    ("slurm|c.toml|--tasks|2|--mem|G", "--mem"),
    ("slurm|c.toml|--tasks|2|--binary|", "--binary"),
    ("slurm|c.toml|--tasks|2|--binary|a\u{7}b", "--binary"),
    // An output folder that is a file: named by its flag (was only "Not a directory").
    ("run|c.toml|--out-dir|c.toml", "--out-dir"),
    ("run|c.toml|--out-dir|c.toml/deeper", "--out-dir"),
    ("slurm|c.toml|--tasks|2|--partition|", "--partition"),
    ("slurm|c.toml|--tasks|2|--partition|-x y", "--partition"),
    ("slurm|c.toml|--tasks|2|--account|", "--account"),
    ("slurm|c.toml|--tasks|2|--dependency|", "--dependency"),
    (
        "slurm|c.toml|--tasks|2|--dependency|afterok:1 2",
        "--dependency",
    ),
    ("slurm|c.toml|--tasks|0", "--tasks"),
    ("slurm|fifo.toml|--tasks|2", "FIFO"),
    // Output folders written as a unit: a command that fails creates nothing (compare and figs
    // once created their --out folder, and figs its default paper-figs/, before failing).
    ("compare|r/sparsity/c|r/sparsity/c|--out|afile", "afile"),
    ("compare|r/sparsity/c|r/sparsity/c|--out|afile/sub", "afile"),
    ("compare|r/sparsity/c|afile|--out|o/cmp", "afile"),
    (
        "compare|r/sparsity/c|r/sparsity|--out|o/cmp",
        "no manifest.toml",
    ),
    (
        "compare|r/sparsity/c|pr/probe/p|--out|o/cmp",
        "compare needs one kind",
    ),
    (
        "compare|hdr/sparsity/c|r/sparsity/c|--out|o/cmp",
        "A holds no rows",
    ),
    (
        "compare|r/sparsity/c|hdr/sparsity/c|--out|o/cmp",
        "B holds no rows",
    ),
    ("figs|--configs|/nonexistent|--out|o/f", "/nonexistent"),
    ("figs|--configs|afile|--out|o/f", "afile"),
    ("figs|--configs|empty|--out|o/f", "no *.toml figure configs"),
    ("figs|--configs|cf|--out|afile", "afile"),
    ("figs|--configs|cf|--out|afile/x", "afile"),
    ("figs|--configs|cf|--out|o/f|--runs|afile", "afile"),
    ("figs|--configs|cf|--runs|afile", "afile"),
    ("figs|--configs|cfifo|--out|o/f", "FIFO"),
    ("figs|--configs|cbad|--out|o/f", "cbad/b.toml"),
    ("figs|--configs|cf|--out|o/f|--gpu|maybe", "--gpu"),
    ("figs|--configs|cf|--out|o/f|--format|xml", "--format"),
    // Results-directory commands on a folder that is not one, or a header-only runs.csv.
    ("report|afile", "afile"),
    ("report|empty", "no manifest.toml"),
    ("plot|hdr/sparsity/c|--metric|nonzeros|--x|k", "no row"),
    ("plot|r/sparsity/c|--metric||--x|k", "is not a column"),
    (
        "plot|r/sparsity/c|--metric|nonzeros|--x|k|--log-y|--linear-y",
        "--linear-y",
    ),
    // Merge: outputs that cannot be, inputs that cannot be merged.
    ("merge|s/sparsity/c|--out|afile", "afile"),
    ("merge|r/sparsity/c|pr/probe/p|--out|o/m", "kind"),
    ("merge|empty|--out|o/m", "empty"),
    ("merge|s_mixed|--out|o/m", "numerical code"),
    // Shards and run options.
    ("run|c.toml|--shard|3/3", "--shard"),
    ("run|c.toml|--shard|0/0", "--shard"),
    ("run|c.toml|--shard|a/b", "--shard"),
    ("run|c.toml|--shard|1/2/3", "--shard"),
    ("run|c.toml|--out-dir|afile", "afile"),
    (
        "run|c.toml|--dry-run|--set|order=1e400",
        "--set order=1e400",
    ),
    ("run|c.toml|--dry-run|--sweep|k=inf,2", "--sweep k=inf,2"),
    ("run|c.toml|--dry-run|--sweep|k=nan,2", "--sweep k=nan,2"),
    ("slurm|c.toml|--tasks|-1", "--tasks"),
    ("slurm|c.toml|--tasks|abc", "--tasks"),
    // Paths named as resolved.
    ("run|sub/m.toml|--dry-run", "meshes/nope.obj)"),
    ("run|sub/m.toml|--dry-run", "(looked for /"),
    (
        "render|--scene|sub/scene.toml|--out|o/x.exr",
        "sub/x/nope.obj",
    ),
    // Render: only the truths are references.
    (
        "render|--scene|scene.toml|--out|o/x.exr|--reference|extrapolated",
        "--reference extrapolated",
    ),
    (
        "render|--scene|scene.toml|--out|o/x.exr|--reference|full_field",
        "--reference full_field",
    ),
];

#[test]
fn hostile_surfaces_are_refused_cleanly() {
    let Some(d) = fixture("refused") else {
        eprintln!("notice: no mkfifo: the hostile-surfaces suite is skipped");
        return;
    };
    let deep17 = vec!["a"; 17].join(".");
    let deep = vec!["a"; 30_000].join(".");
    let cases: Vec<(String, Vec<String>, &str)> = (CASES.iter())
        .map(|(line, needle)| {
            let args = (line.split('|'))
                .map(|a| a.replace("{DEEP17}", &deep17).replace("{DEEP30000}", &deep))
                .collect();
            (line.to_string(), args, *needle)
        })
        .collect();
    common::refusal::check_all(&d, &cases, 120);
    std::fs::remove_dir_all(&d).ok();
}

/// Extreme but valid: ±1e308 cells (which once spun the plots' tick search forever) are left out
/// of plots, which still draw the rest; `--tasks` beyond the plan's runs is capped with a notice;
/// `--allow-partial` merges what there is and the manifest says what is missing.
#[test]
fn extreme_cells_partial_merges_and_too_many_tasks_work() {
    let Some(d) = fixture("valid") else {
        eprintln!("notice: no mkfifo: skipped");
        return;
    };
    let dir = d.join("r/sparsity/c");
    let p = dir.join("runs.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut rd = csv::Reader::from_reader(text.as_bytes());
    let h = rd.headers().unwrap().clone();
    let at = h.iter().position(|c| c == "max_abs").unwrap();
    let mut w = csv::Writer::from_path(&p).unwrap();
    w.write_record(&h).unwrap();
    for (i, rec) in rd.records().enumerate() {
        let mut cells: Vec<String> = rec.unwrap().iter().map(String::from).collect();
        cells[at] = ["1e308", "-1e308", "inf", "2.5e-3", "1e-300", "NaN"][i % 6].into();
        w.write_record(&cells).unwrap();
    }
    drop(w);
    let t0 = Instant::now();
    for args in [
        vec!["plot", "r/sparsity/c", "--metric", "max_abs", "--x", "k"],
        vec!["report", "r/sparsity/c"],
    ] {
        let o = shscale(&d, &args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    println!(
        "plot and report of ±1e308 cells: {:.2} s",
        t0.elapsed().as_secs_f64()
    );
    // A results directory without rows yet reports that, and nothing else.
    let o = shscale(&d, &["report", "hdr/sparsity/c"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary = std::fs::read_to_string(d.join("hdr/sparsity/c/summary.md")).unwrap();
    assert!(summary.contains("Rows: 0 in `runs.csv`"), "{summary}");
    // Column names read from a crafted runs.csv are data, never path parts: the plot of a
    // column named `../../pwn` lands inside the results directory.
    let rows = std::fs::read_to_string(&p).unwrap();
    let mut lines = rows.lines();
    let mut crafted = format!("{},../../pwn\n", lines.next().unwrap());
    for l in lines {
        crafted.push_str(&format!("{l},1.5\n"));
    }
    std::fs::write(&p, crafted).unwrap();
    let before: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    let o = shscale(
        &d,
        &["plot", "r/sparsity/c", "--metric", "../../pwn", "--x", "k"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    for line in out.lines() {
        let f = line.trim_start_matches("wrote ");
        let f = std::path::Path::new(f);
        assert_eq!(
            f.parent(),
            Some(std::path::Path::new("r/sparsity/c")),
            "{out}"
        );
        assert!(d.join(f).is_file(), "{out}");
    }
    let after: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert_eq!(before, after, "the plot wrote outside its directory");
    // A directory named like a built-in mesh does not shadow it.
    std::fs::create_dir_all(d.join("sphere")).unwrap();
    let o = shscale(&d, &["run", "p.toml", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = shscale(&d, &["slurm", "c.toml", "--tasks", "99999"]);
    assert!(o.status.success());
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(out.contains("--array=0-2"), "{out}");
    assert!(
        err.contains("notice: --tasks 99999 is more than the plan's 3 run(s)"),
        "{err}"
    );
    let o = shscale(
        &d,
        &[
            "merge",
            "s_missing",
            "--out",
            "o/partial",
            "--allow-partial",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = std::fs::read_to_string(d.join("o/partial/manifest.toml")).unwrap();
    assert!(m.contains("1 of 3 shard files missing"), "{m}");
    std::fs::remove_dir_all(&d).ok();
}

/// A failing `report` or `merge --replace` changes no file. With `summary.md` a directory both
/// fail after their work (exit 2, naming it): the report's plots and the merge's rows were
/// staged, never moved — before, `report` had rewritten the plots and `merge --replace` the
/// merged `runs.csv` and `manifest.toml` by then.
#[test]
fn failing_reports_and_merges_change_no_file() {
    let d = std::env::temp_dir().join(format!("shscale-staged-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(
        d.join("c.toml"),
        "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 4\nradii = [2.0]\ngpu = \"off\"\n[sweep]\nalpha_deg = [20, 40]\n",
    )
    .unwrap();
    assert!(shscale(&d, &["run", "c.toml", "--out-dir", "r"])
        .status
        .success());
    let dir = d.join("r/probe/c");
    assert!(shscale(&d, &["merge", dir.to_str().unwrap()])
        .status
        .success());
    // A stale merged file that `merge --replace` would rewrite, and summaries that are folders.
    let merged = dir.join("merged");
    let rows = std::fs::read_to_string(merged.join("runs.csv")).unwrap();
    let stale: Vec<&str> = rows.lines().take(2).collect();
    std::fs::write(merged.join("runs.csv"), stale.join("\n") + "\n").unwrap();
    for s in [dir.join("summary.md"), merged.join("summary.md")] {
        std::fs::remove_file(&s).unwrap();
        std::fs::create_dir(&s).unwrap();
    }
    let args = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let d_str = dir.to_str().unwrap();
    for (case, needle) in [
        (args(&["report", d_str]), "summary.md"),
        (args(&["merge", d_str, "--replace"]), "summary.md"),
    ] {
        if let Err(why) = common::refusal::check(&d, &case, needle) {
            panic!("{case:?}: {why}");
        }
    }
    std::fs::remove_dir_all(&d).ok();
}

/// `bench runner` holds its plans to the limits `run` does: a `--config` over the ray limit is
/// refused before any work (naming the config, as `run` would), `--runs` takes at most 8 sizes
/// of at most 100 000 runs (naming the flag), and nothing is written.
#[test]
fn bench_runner_plans_are_held_to_the_limits() {
    let d = std::env::temp_dir().join(format!("shscale-bench-limits-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    // 10⁶ samples × 256² rays = 6.6·10¹⁰ rays: over the 10¹⁰ limit.
    std::fs::write(
        d.join("big.toml"),
        "experiment = \"probe\"\nmesh = \"sphere\"\nlayout = \"fib:1000000\"\nhemisphere_res = 256\ngpu = \"off\"\n",
    )
    .unwrap();
    let args = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let out = d.join("o");
    let out = out.to_str().unwrap();
    for (case, needle) in [
        (
            args(&["bench", "runner", "--config", "big.toml", "--out-dir", out]),
            "big.toml",
        ),
        (
            args(&["bench", "runner", "--runs", "100001", "--out-dir", out]),
            "--runs",
        ),
        (
            args(&[
                "bench",
                "runner",
                "--runs",
                "1,2,3,4,5,6,7,8,9",
                "--out-dir",
                out,
            ]),
            "--runs",
        ),
    ] {
        if let Err(why) = common::refusal::check(&d, &case, needle) {
            panic!("{case:?}: {why}");
        }
    }
    std::fs::remove_dir_all(&d).ok();
}

/// Control characters from a file name never reach the terminal raw through an error line: a
/// config whose name holds ESC and BEL is named with their escapes.
#[test]
fn error_lines_show_control_characters_as_escapes() {
    let d = std::env::temp_dir().join(format!("shscale-ctl-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let name = "bad\u{1b}[31m\u{7}.toml";
    std::fs::write(d.join(name), "experiment = \"nosuch\"\n").unwrap();
    let o = shscale(&d, &["run", name]);
    let err = String::from_utf8_lossy(&o.stderr);
    println!("{err:?}");
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains('\u{1b}') && !err.contains('\u{7}'), "{err:?}");
    assert!(err.contains("\\u{1b}"), "{err:?}");
    std::fs::remove_dir_all(&d).ok();
}

/// A `runs.csv` holding its header alone is said to have no rows (it read as "no row has numbers
/// in both …"), and nothing is written.
#[test]
fn a_header_only_results_file_is_named_as_such() {
    let d = std::env::temp_dir().join(format!("shscale-header-only-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("c.toml"), CONFIG).unwrap();
    assert!(shscale(&d, &["run", "c.toml", "--out-dir", "o"])
        .status
        .success());
    let dir = d.join("o/sparsity/c");
    let csv = dir.join("runs.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::write(&csv, format!("{}\n", text.lines().next().unwrap())).unwrap();
    let args: Vec<String> = [
        "plot",
        dir.to_str().unwrap(),
        "--metric",
        "nonzeros",
        "--x",
        "k",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    if let Err(why) = common::refusal::check(&d, &args, "has no rows") {
        panic!("{why}");
    }
    std::fs::remove_dir_all(&d).ok();
}
