//! End-to-end tests of `shscale run`.

mod common;
use common::*;

#[test]
fn run_writes_csv_and_manifest_and_resumes() {
    let d = std::env::temp_dir().join(format!("shscale-cli-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let cfg = d.join("tiny.toml");
    std::fs::write(&cfg, "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 4\nradii = [2.0]\n[sweep]\nalpha_deg = [30, 60]\n").unwrap();
    let out = d.join("out");
    let args = [
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ];
    let r = shscale(&args);
    let text = String::from_utf8_lossy(&r.stdout).to_string();
    assert!(
        r.status.success(),
        "{text} {}",
        String::from_utf8_lossy(&r.stderr)
    );
    assert!(text.contains("ran 2, skipped 0"), "{text}");
    let csv = std::fs::read_to_string(out.join("probe/tiny/runs.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3);
    assert!(csv.lines().next().unwrap().contains("occ_rel_l2_mean"));
    assert!(out.join("probe/tiny/manifest.toml").exists());
    assert!(
        out.join("probe/tiny/occ_rel_l2_vs_alpha_deg.png").exists()
            && out.join("probe/tiny/pareto_time_vs_error.svg").exists()
    );
    assert!(
        text.contains("occ@2r") && text.contains("time_ms"),
        "summary table missing: {text}"
    );
    let again = String::from_utf8_lossy(&shscale(&args).stdout).to_string();
    assert!(again.contains("ran 0, skipped 2"), "{again}");
    let shard = shscale(&[
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
        "--shard",
        "1/2",
    ]);
    assert!(String::from_utf8_lossy(&shard.stdout).contains("of 1 in this shard"));
    // Shards 0/2 and 1/2 into a fresh directory, merged: the same rows as the unsharded run.
    let sharded = d.join("sharded");
    for s in ["0/2", "1/2"] {
        assert!(shscale(&[
            "run",
            cfg.to_str().unwrap(),
            "--out-dir",
            sharded.to_str().unwrap(),
            "--shard",
            s
        ])
        .status
        .success());
    }
    let m = shscale(&["merge", sharded.join("probe/tiny").to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&m.stdout).contains("2 file(s), 2 row(s)"),
        "{}",
        String::from_utf8_lossy(&m.stdout)
    );
    let mut a: Vec<String> = std::fs::read_to_string(sharded.join("probe/tiny/runs.csv"))
        .unwrap()
        .lines()
        .map(|l| l.split(',').take(11).collect::<Vec<_>>().join(","))
        .collect();
    let mut b: Vec<String> = csv
        .lines()
        .map(|l| l.split(',').take(11).collect::<Vec<_>>().join(","))
        .collect();
    a.sort();
    b.sort();
    assert_eq!(a, b);
    fails(&["merge", "/nonexistent/dir"], "/nonexistent/dir");
    // Slurm: an array over the shards and a dependent merge.
    let sl = shscale(&["slurm", cfg.to_str().unwrap(), "--tasks", "4"]);
    let script = String::from_utf8_lossy(&sl.stdout).to_string();
    assert!(
        script.contains("--array=0-3")
            && script.contains("--shard \\$SLURM_ARRAY_TASK_ID/4")
            && script.contains("afterok")
            && script.contains("merge \\\"$DIR"),
        "{script}"
    );
    fails(&["slurm", cfg.to_str().unwrap(), "--tasks", "0"], "tasks");
    fails(&["run", cfg.to_str().unwrap(), "--shard", "2/2"], "shard");
    fails(&["run", cfg.to_str().unwrap(), "--shard", "x"], "shard");
    fails(
        &["run", "/nonexistent/config.toml"],
        "/nonexistent/config.toml",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn run_without_config_explains() {
    let r = shscale(&["run"]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("shscale run CONFIG"));
}

#[test]
fn slurm_script_runs_end_to_end_with_a_stand_in_sbatch() {
    // A stand-in `sbatch` that executes `--wrap` locally (each array index in turn) proves the
    // generated script's quoting, shard arguments and merge step.
    let d = std::env::temp_dir().join(format!("shscale-slurm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("bin")).unwrap();
    let fake = d.join("bin/sbatch");
    std::fs::write(
        &fake,
        "#!/usr/bin/env bash\narray=\"\"; wrap=\"\"\nwhile [ $# -gt 0 ]; do case \"$1\" in --array=*) array=\"${1#--array=}\";; --wrap) shift; wrap=\"$1\";; esac; shift; done\nif [ -n \"$array\" ]; then for i in $(seq ${array%-*} ${array#*-}); do SLURM_ARRAY_TASK_ID=$i bash -c \"$wrap\" >&2; done; echo 4242; else bash -c \"$wrap\" >&2; fi\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    let cfg = d.join("tiny.toml");
    std::fs::write(&cfg, "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 4\nradii = [2.0]\n[sweep]\nalpha_deg = [20, 40, 60]\n").unwrap();
    let out = d.join("out");
    let gen = shscale(&[
        "slurm",
        cfg.to_str().unwrap(),
        "--tasks",
        "2",
        "--binary",
        env!("CARGO_BIN_EXE_shscale"),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    let script = d.join("sweep.sh");
    std::fs::write(&script, &gen.stdout).unwrap();
    let path = format!(
        "{}:{}",
        d.join("bin").display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let r = std::process::Command::new("bash")
        .arg(&script)
        .env("PATH", path)
        .output()
        .unwrap();
    assert!(
        r.status.success(),
        "{} {}",
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr)
    );
    let merged = std::fs::read_to_string(out.join("probe/tiny/runs.csv")).unwrap();
    assert_eq!(
        merged.lines().count(),
        4,
        "header + 3 runs × 1 radius:\n{merged}"
    );
    assert!(
        out.join("probe/tiny/runs.shard-0-of-2.csv").exists()
            && out.join("probe/tiny/runs.shard-1-of-2.csv").exists()
    );
    std::fs::remove_dir_all(&d).ok();
}

/// The cells of a runs.csv, without the columns that legitimately differ between two executions
/// of the same runs (times, thread count, GPU device and timings, revision).
fn comparable(csv: &std::path::Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| {
            !(h.ends_with("_seconds")
                || **h == "threads"
                || h.starts_with("gpu_")
                || **h == "git_revision")
        })
        .map(|(i, _)| i)
        .collect();
    let mut rows: Vec<Vec<String>> = lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            keep.iter().map(|&i| cells[i].to_string()).collect()
        })
        .collect();
    rows.sort();
    rows
}

const SWEEP: &str = "experiment = \"probe\"\nmesh = \"duck\"\norder = 3\nlayout = \"fib:40\"\nhemisphere_res = 6\nk_count = 6\nradii = [0.8, 1.5]\ngpu = \"off\"\n[sweep]\nalpha_deg = [20, 40, 60]\nsampling_radius = [1.0, 1.2]\n";

fn dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn merged_shards_equal_the_unsharded_run() {
    let d = dir("shards");
    let cfg = d.join("sweep.toml");
    std::fs::write(&cfg, SWEEP).unwrap();
    let (full, sharded) = (d.join("full"), d.join("sharded"));
    let run = |out: &std::path::Path, shard: Option<&str>| {
        let mut args = vec![
            "run",
            cfg.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ];
        if let Some(s) = shard {
            args.extend(["--shard", s]);
        }
        let r = shscale(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    run(&full, None);
    run(&sharded, Some("0/2"));
    run(&sharded, Some("1/2"));
    let sdir = sharded.join("probe/sweep");
    let r = shscale(&["merge", sdir.to_str().unwrap()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let a = comparable(&full.join("probe/sweep/runs.csv"));
    let b = comparable(&sdir.join("runs.csv"));
    assert_eq!(a.len(), 12, "6 runs × 2 radii");
    assert_eq!(a, b, "merged shards differ from the unsharded run");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_sweep_killed_mid_run_resumes_to_the_same_rows() {
    use std::process::{Command, Stdio};
    let d = dir("kill");
    let cfg = d.join("sweep.toml");
    // Serial runs and a finer hemisphere: slow enough to be killed between runs.
    std::fs::write(
        &cfg,
        SWEEP
            .replace("hemisphere_res = 6", "hemisphere_res = 24")
            .replace("gpu = \"off\"", "gpu = \"off\"\nparallel_runs = false"),
    )
    .unwrap();
    let (clean, killed) = (d.join("clean"), d.join("killed"));
    let r = shscale(&[
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        clean.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let csv = killed.join("probe/sweep/runs.csv");
    // Kill with SIGKILL once at least one run is on disk (or after a deadline, wherever it is).
    let mut child = Command::new(env!("CARGO_BIN_EXE_shscale"))
        .args([
            "run",
            cfg.to_str().unwrap(),
            "--out-dir",
            killed.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while t0.elapsed().as_secs_f64() < 20.0 {
        if std::fs::read_to_string(&csv).is_ok_and(|t| t.lines().count() > 1) {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let partial = std::fs::read_to_string(&csv)
        .map(|t| t.lines().count() - 1)
        .unwrap_or(0);
    println!("killed after {partial} row(s) of 12 were written");
    // Whatever was on disk is whole rows of whole runs (2 radii each).
    assert_eq!(partial % 2, 0, "a partial run was written");
    let r = shscale(&[
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        killed.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&r.stdout).to_string();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(
        text.contains(&format!("skipped {} already done", partial / 2)),
        "{text}"
    );
    assert_eq!(
        comparable(&clean.join("probe/sweep/runs.csv")),
        comparable(&csv),
        "resumed run differs from the uninterrupted one"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn config_errors_name_the_field_and_line() {
    let d = dir("cfgerr");
    let cases = [
        (
            SWEEP.replace("k_count = 6", "k_count = 6\nbrightness = 2"),
            "sweep.toml:7: unknown field `brightness`",
        ),
        (
            SWEEP.replace("order = 3", "order = \"three\""),
            "sweep.toml:3: order: invalid type",
        ),
        (
            SWEEP.replace("alpha_deg = [20, 40, 60]", "alpha_deg = [20, 95]"),
            "alpha_deg: 95 is outside (0, 90)",
        ),
        (
            SWEEP.replace("mesh = \"duck\"", "mesh = \"unicorn\""),
            "sweep.toml:2: mesh: \"unicorn\" is neither",
        ),
    ];
    for (text, needle) in cases {
        let cfg = d.join("sweep.toml");
        std::fs::write(&cfg, text).unwrap();
        fails(
            &[
                "run",
                cfg.to_str().unwrap(),
                "--out-dir",
                d.join("out").to_str().unwrap(),
            ],
            needle,
        );
    }
    std::fs::remove_dir_all(&d).ok();
}
