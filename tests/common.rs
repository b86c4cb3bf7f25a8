//! Helpers shared by the end-to-end tests of the `shscale` binary.

#![allow(dead_code)]

use std::process::{Command, Output};

/// Run the binary with `args`.
pub fn shscale(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shscale"))
        .args(args)
        .output()
        .expect("binary runs")
}

/// Run and parse stdout as JSON, asserting success.
pub fn json(args: &[&str]) -> serde_json::Value {
    let out = shscale(args);
    assert!(
        out.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{args:?}: bad JSON ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// Assert the invocation fails cleanly: exit status 2, exactly one non-empty stderr line that
/// contains `needle`, and no panic.
pub fn fails(args: &[&str], needle: &str) {
    let out = shscale(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{args:?}: status {:?}, stderr {err}",
        out.status.code()
    );
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(
        lines.len(),
        1,
        "{args:?}: expected one stderr line, got {lines:?}"
    );
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    assert!(
        err.to_lowercase().contains(&needle.to_lowercase()),
        "{args:?}: {err:?} does not mention {needle:?}"
    );
}

/// The `values` array of a JSON answer.
pub fn values(v: &serde_json::Value) -> Vec<f64> {
    v["values"]
        .as_array()
        .expect("values array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// The cells of a runs.csv (read with the csv crate), without the columns that legitimately
/// differ between two executions of the same runs (times and their spreads, threads, GPU
/// timings, revision, whether timed concurrently), sorted.
pub fn comparable(csv: &std::path::Path) -> Vec<Vec<String>> {
    let mut r = ::csv::Reader::from_path(csv).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let keep: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| {
            !(h.ends_with("_seconds")
                || h.ends_with("_spread")
                || h.starts_with("timing_")
                || *h == "threads"
                || h.starts_with("gpu_")
                || h.starts_with("git_")
                || matches!(h.as_str(), "other_cpu" | "steal" | "load_1m" | "contended"))
        })
        .map(|(i, _)| i)
        .collect();
    let mut rows: Vec<Vec<String>> = r
        .records()
        .map(|rec| {
            let rec = rec.unwrap();
            keep.iter().map(|&i| rec[i].to_string()).collect()
        })
        .collect();
    rows.sort();
    rows
}

/// The refusal check shared by the hostile-input suites (`hostile.rs`, `hostile_surfaces.rs`):
/// one case is the binary run in a fixture folder with stdin closed; it must exit with status 2
/// within [`refusal::LIMIT`], print exactly one stderr line naming the culprit, never panic, and
/// leave every entry of the folder byte-identical (nothing created, changed or removed).
pub mod refusal {
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};

    /// The longest a refusal may take: they are all checks before work (loading the bunny is the
    /// slowest, well under a second here).
    pub const LIMIT: Duration = Duration::from_secs(60);

    /// Every entry below `d`: a regular file with its bytes, a folder as `dir`, anything else (a
    /// FIFO, a link) by its kind — never opened, never followed. The runner's advisory lock files
    /// (`.lock`, empty), which a results directory keeps once a process has locked it, are left
    /// out.
    pub fn snapshot(d: &Path) -> BTreeMap<PathBuf, String> {
        let mut out = BTreeMap::new();
        let mut stack = vec![d.to_path_buf()];
        while let Some(p) = stack.pop() {
            for e in std::fs::read_dir(&p).unwrap().flatten() {
                let path = e.path();
                if path.file_name().is_some_and(|n| n == ".lock") {
                    continue;
                }
                let m = std::fs::symlink_metadata(&path).unwrap();
                let what = if m.is_dir() {
                    stack.push(path.clone());
                    "dir".to_string()
                } else if m.is_file() {
                    format!("{:?}", std::fs::read(&path).unwrap())
                } else {
                    format!("{:?}", m.file_type())
                };
                out.insert(path, what);
            }
        }
        out
    }

    /// Run one case in `d`; `Err` says what went wrong.
    pub fn check(d: &Path, args: &[String], needle: &str) -> Result<(), String> {
        let before = snapshot(d);
        let t0 = Instant::now();
        let mut child = Command::new(env!("CARGO_BIN_EXE_shscale"))
            .args(args)
            .current_dir(d)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| e.to_string())?;
        while child.try_wait().map_err(|e| e.to_string())?.is_none() {
            if t0.elapsed() > LIMIT {
                let _ = child.kill();
                return Err(format!("ran past {LIMIT:?}"));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let out = child.wait_with_output().map_err(|e| e.to_string())?;
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        if err.contains("panicked") {
            return Err(format!("panicked: {err}"));
        }
        if out.status.code() != Some(2) {
            return Err(format!("status {:?}, stderr {err:?}", out.status.code()));
        }
        if lines.len() != 1 {
            return Err(format!("{} stderr lines: {lines:?}", lines.len()));
        }
        if !lines[0].to_lowercase().contains(&needle.to_lowercase()) {
            return Err(format!("{:?} does not name {needle:?}", lines[0]));
        }
        let after = snapshot(d);
        if after != before {
            let changed: Vec<String> = (after.keys().chain(before.keys()))
                .filter(|k| after.get(*k) != before.get(*k))
                .map(|k| k.display().to_string())
                .collect();
            return Err(format!("files changed or created: {changed:?}"));
        }
        Ok(())
    }

    /// Run every case (`label`, arguments, needle) in `d`, print the tally and assert that there
    /// are at least `at_least` cases and that none failed.
    pub fn check_all(d: &Path, cases: &[(String, Vec<String>, &str)], at_least: usize) {
        let mut failures = Vec::new();
        for (label, args, needle) in cases {
            if let Err(why) = check(d, args, needle) {
                let label: String = label.chars().take(120).collect();
                failures.push(format!("  {label}\n    → {why}"));
            }
        }
        println!("{} hostile cases, {} failed", cases.len(), failures.len());
        assert!(
            cases.len() >= at_least,
            "only {} cases (at least {at_least} expected)",
            cases.len()
        );
        assert!(
            failures.is_empty(),
            "{} of {} cases failed:\n{}",
            failures.len(),
            cases.len(),
            failures.join("\n")
        );
    }
}
