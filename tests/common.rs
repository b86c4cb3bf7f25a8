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
