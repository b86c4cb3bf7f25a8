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
        text.contains("occ_rel_l2_mean"),
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
