//! End-to-end tests of `shscale matrix` and `shscale demo`.

mod common;
use common::*;

fn matrix(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v["matrix"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect()
}

#[test]
fn cone_matrix_json_form() {
    let v = json(&[
        "matrix",
        "--order",
        "4",
        "--tau",
        "cone",
        "--alpha-deg",
        "45",
        "--k",
        "2",
    ]);
    assert_eq!(v["order"], 4);
    assert_eq!(v["tau"], "cone");
    assert_eq!(v["alpha_deg"].as_f64(), Some(45.0));
    assert_eq!(v["k"].as_f64(), Some(2.0));
    assert_eq!(v["energy"], false);
    assert_eq!(v["structural_nonzeros"], 44);
    // Column 0 of the plain matrix is e_0 (a constant stays constant): 3 structural zeros.
    assert_eq!(v["nonzeros"], 41);
    let m = matrix(&v);
    assert_eq!(m.len(), 16);
    assert!(m.iter().all(|r| r.len() == 16));
    assert!((m[0][0] - 1.0).abs() < 1e-13);
    // Block structure: M_ij = 0 unless m_i = m_j; the ±1 blocks agree (index 1 ↔ 3, 5 ↔ 7).
    assert_eq!(m[1][2], 0.0);
    assert!((m[1][1] - m[3][3]).abs() < 1e-15 && (m[5][1] - m[7][3]).abs() < 1e-15);
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(|s| s.as_str()).collect();
    assert_eq!(keys.len(), 8, "{keys:?}");
}

#[test]
fn energy_and_midrange_forms() {
    let v = json(&[
        "matrix",
        "--order",
        "3",
        "--tau",
        "cone",
        "--alpha-deg",
        "30",
        "--k",
        "0.5",
        "--energy",
    ]);
    assert_eq!(v["energy"], true);
    let m = matrix(&v);
    assert!((m[0][0] - 1.0).abs() < 1e-13 && m[0][1..].iter().all(|x| x.abs() < 1e-13));
    let v = json(&["matrix", "--order", "3", "--tau", "midrange", "--k=-0.4"]);
    assert_eq!(v["tau"], "midrange");
    assert!(v.get("alpha_deg").is_none());
    assert_eq!(v["structural_nonzeros"], 19);
    let csv = shscale(&[
        "matrix",
        "--order",
        "2",
        "--tau",
        "cone",
        "--alpha-deg",
        "45",
        "--k",
        "1",
        "--format",
        "csv",
    ]);
    let text = String::from_utf8(csv.stdout).unwrap();
    assert_eq!(text.lines().count(), 4);
    let pretty = shscale(&[
        "matrix",
        "--order",
        "2",
        "--tau",
        "cone",
        "--alpha-deg",
        "45",
        "--k",
        "1.5",
        "--format",
        "pretty",
    ]);
    assert!(String::from_utf8(pretty.stdout)
        .unwrap()
        .contains("structural non-zeros"));
}

#[test]
fn table_reports_size_time_and_error() {
    let v = json(&[
        "matrix",
        "--order",
        "4",
        "--tau",
        "cone",
        "--alpha-deg",
        "45",
        "--table",
        "20",
        "--k-range",
        "0.5,4",
    ]);
    assert_eq!(v["k_count"], 20);
    assert_eq!(v["size_bytes"], 20 * 30 * 8);
    let err = v["max_interp_error"].as_f64().unwrap();
    let at = v["max_interp_error_k"].as_f64().unwrap();
    assert!(err > 0.0 && err < 0.1, "{err}");
    assert!((0.5..=4.0).contains(&at));
    assert!(v["build_seconds"].as_f64().unwrap() >= 0.0);
    let c = json(&[
        "matrix",
        "--order",
        "4",
        "--tau",
        "cone",
        "--alpha-deg",
        "45",
        "--table",
        "20",
        "--k-range",
        "0.5,4",
        "--interp",
        "cubic",
        "--spacing",
        "chebyshev",
    ]);
    assert_eq!(c["interp"], "cubic");
    assert_eq!(c["spacing"], "chebyshev");
}

#[test]
fn bad_matrix_input_gives_one_line_and_status_2() {
    let base = [
        "matrix",
        "--order",
        "4",
        "--tau",
        "cone",
        "--alpha-deg",
        "45",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        base.iter().copied().chain(extra.iter().copied()).collect()
    };
    fails(&with(&["--k", "0"]), "k");
    fails(&with(&["--k=-1"]), "k");
    fails(&with(&["--k", "NaN"]), "k");
    fails(&with(&["--k", "inf"]), "k");
    fails(
        &[
            "matrix",
            "--order",
            "4",
            "--tau",
            "cone",
            "--alpha-deg",
            "0",
            "--k",
            "2",
        ],
        "alpha",
    );
    fails(
        &[
            "matrix",
            "--order",
            "4",
            "--tau",
            "cone",
            "--alpha-deg",
            "90",
            "--k",
            "2",
        ],
        "alpha",
    );
    fails(
        &["matrix", "--order", "4", "--tau", "cone", "--k", "2"],
        "alpha",
    );
    fails(
        &["matrix", "--order", "4", "--tau", "midrange", "--k", "1"],
        "k",
    );
    fails(
        &["matrix", "--order", "4", "--tau", "midrange", "--k=-1.5"],
        "k",
    );
    fails(
        &[
            "matrix",
            "--order",
            "0",
            "--tau",
            "cone",
            "--alpha-deg",
            "45",
            "--k",
            "2",
        ],
        "order",
    );
    fails(
        &[
            "matrix",
            "--order",
            "33",
            "--tau",
            "cone",
            "--alpha-deg",
            "45",
            "--k",
            "2",
        ],
        "order",
    );
    fails(&with(&[]), "--k");
    fails(&with(&["--table", "10"]), "k-range");
    fails(
        &with(&["--table", "1", "--k-range", "0.5,2"]),
        "--table: 1 is outside 2..=10000",
    );
    fails(
        &with(&["--table", "100000000", "--k-range", "0.5,2"]),
        "--table: 100000000 is outside 2..=10000",
    );
    fails(&with(&["--table", "10", "--k-range", "2,0.5"]), "range");
    fails(&with(&["--table", "10", "--k-range", "0,2"]), "k");
    fails(
        &[
            "matrix",
            "--order",
            "4",
            "--tau",
            "midrange",
            "--table",
            "10",
            "--k-range=-0.5,0.5",
        ],
        "exponential",
    );
}

#[test]
fn demo_runs_and_checks_pass() {
    let out = shscale(&["demo", "--order", "8"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "demo failed: {text} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("[ok] M at k = 1 equals I"));
    assert!(!text.contains("FAIL"));
}
