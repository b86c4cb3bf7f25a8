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
