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
                || h.starts_with("git_"))
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
