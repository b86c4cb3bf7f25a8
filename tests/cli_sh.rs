//! End-to-end tests of `shscale sh eval|cap|rotate`: exact output forms and error handling.

mod common;
use common::*;
use std::f64::consts::PI;

const TOL: f64 = 1e-14;

#[test]
fn eval_normalises_and_matches_closed_forms() {
    let v = json(&["sh", "eval", "--order", "3", "--dir", "0,0,2"]);
    assert_eq!(v["order"], 3);
    let y = values(&v);
    assert_eq!(y.len(), 9);
    let c0 = 0.5 / PI.sqrt();
    let c1 = (3.0 / (4.0 * PI)).sqrt();
    let want = [
        c0,
        0.0,
        c1,
        0.0,
        0.0,
        0.0,
        (5.0 / (16.0 * PI)).sqrt() * 2.0,
        0.0,
        0.0,
    ];
    for (i, (g, w)) in y.iter().zip(want).enumerate() {
        assert!((g - w).abs() < TOL, "index {i}: {g} vs {w}");
    }
    // Y_1^{-1}, Y_1^0, Y_1^1 = √(3/4π)(y, z, x) at a generic direction.
    let v = json(&["sh", "eval", "--order", "2", "--dir=-1,2,-2"]);
    let y = values(&v);
    let (x, yy, z) = (-1.0 / 3.0, 2.0 / 3.0, -2.0 / 3.0);
    for (g, w) in y[1..].iter().zip([c1 * yy, c1 * z, c1 * x]) {
        assert!((g - w).abs() < TOL, "{g} vs {w}");
    }
    let csv = shscale(&[
        "sh", "eval", "--order", "2", "--dir", "1,0,0", "--format", "csv",
    ]);
    let text = String::from_utf8(csv.stdout).unwrap();
    assert_eq!(text.lines().next(), Some("index,l,m,value"));
    assert_eq!(text.lines().count(), 5);
}

#[test]
fn cap_matches_area_formula() {
    let v = json(&["sh", "cap", "--order", "4", "--angle-deg", "60"]);
    assert_eq!(v["order"], 4);
    assert_eq!(v["angle_deg"].as_f64(), Some(60.0));
    let c = values(&v);
    // c_0 = area / √(4π) = 2π(1 − cos 60°)/√(4π) = π/√(4π); c_1^0 = √(3π)·(1 − cos²A)/2 ... via ∫.
    assert!((c[0] - PI / (4.0 * PI).sqrt()).abs() < TOL, "{}", c[0]);
    let c10 = 2.0 * PI * (3.0 / (4.0 * PI)).sqrt() * (1.0 - 0.25) / 2.0;
    assert!((c[2] - c10).abs() < TOL, "{} vs {c10}", c[2]);
    for i in [1, 3, 4, 5, 7, 8] {
        assert_eq!(c[i], 0.0, "m ≠ 0 entry {i}");
    }
}

#[test]
fn rotate_is_active_zyz() {
    // f = Y_1^0 ∝ z; R = Ry(90°) maps +z to +x, so g(ω) = f(R⁻¹ω) ∝ x: all weight on index 3.
    let v = json(&[
        "sh",
        "rotate",
        "--order",
        "2",
        "--coeffs",
        "0,0,1,0",
        "--euler-zyz-deg",
        "0,90,0",
    ]);
    let g = values(&v);
    for (i, w) in [0.0, 0.0, 0.0, 1.0].iter().enumerate() {
        assert!((g[i] - w).abs() < TOL, "index {i}: {}", g[i]);
    }
    // Rz(90°) maps +x to +y: x ↦ y, index 3 → index 1.
    let v = json(&[
        "sh",
        "rotate",
        "--order",
        "2",
        "--coeffs",
        "0,0,0,1",
        "--euler-zyz-deg",
        "90,0,0",
    ]);
    let g = values(&v);
    assert!((g[1] - 1.0).abs() < TOL && g[3].abs() < TOL, "{g:?}");
    // The constant is invariant; the norm of every band is preserved.
    let v = json(&[
        "sh",
        "rotate",
        "--order",
        "3",
        "--coeffs=1,0.3,-0.2,0.5,0.1,0.2,0.3,0.4,-0.5",
        "--euler-zyz-deg=10,-70,33",
    ]);
    let g = values(&v);
    assert!((g[0] - 1.0).abs() < TOL);
    let band2: f64 = g[4..9].iter().map(|x| x * x).sum();
    assert!((band2 - (0.01 + 0.04 + 0.09 + 0.16 + 0.25)).abs() < 1e-13);
}

#[test]
fn bad_input_gives_one_line_and_status_2() {
    fails(&["sh", "eval", "--order", "0", "--dir", "0,0,1"], "order");
    fails(&["sh", "eval", "--order", "129", "--dir", "0,0,1"], "order");
    fails(&["sh", "eval", "--order", "4", "--dir", "0,0,0"], "dir");
    fails(&["sh", "eval", "--order", "4", "--dir", "1,2"], "dir");
    fails(&["sh", "eval", "--order", "4", "--dir", "a,b,c"], "dir");
    fails(&["sh", "eval", "--order", "4", "--dir", "nan,0,1"], "dir");
    fails(&["sh", "eval", "--order", "x", "--dir", "0,0,1"], "order");
    fails(
        &["sh", "cap", "--order", "4", "--angle-deg", "200"],
        "angle",
    );
    fails(&["sh", "cap", "--order", "0", "--angle-deg", "20"], "order");
    fails(
        &[
            "sh",
            "rotate",
            "--order",
            "2",
            "--coeffs",
            "1,2,3",
            "--euler-zyz-deg",
            "0,0,0",
        ],
        "coeffs",
    );
    fails(
        &[
            "sh",
            "rotate",
            "--order",
            "2",
            "--coeffs",
            "1,2,3,4",
            "--euler-zyz-deg",
            "0,0",
        ],
        "euler",
    );
    fails(
        &[
            "sh",
            "rotate",
            "--order",
            "2",
            "--coeffs",
            "1,2,3,x",
            "--euler-zyz-deg",
            "0,0,0",
        ],
        "coeffs",
    );
    fails(&["sh", "frobnicate"], "frobnicate");
}

#[test]
fn help_lists_subcommands_with_examples() {
    let out = shscale(&["--help"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "sh",
        "matrix",
        "demo",
        "Example:",
        "shscale sh eval --order 4 --dir 0,0,1",
    ] {
        assert!(text.contains(needle), "--help lacks {needle:?}:\n{text}");
    }
}

/// `--version` names the git revision it was built from; `completions` prints a script for
/// each shell that knows the subcommands and their flags; an unknown shell is one clear line.
#[test]
fn version_and_completions() {
    let v = shscale(&["--version"]);
    let text = String::from_utf8_lossy(&v.stdout).to_string();
    assert!(v.status.success());
    let inner = text
        .split("(git ")
        .nth(1)
        .and_then(|r| r.split([')', ',']).next())
        .unwrap_or_else(|| panic!("no git revision in {text:?}"));
    // The numerical fingerprint the rows carry in `code`, 16 hex digits (or unknown).
    let code = (text.split("numerical code ").nth(1))
        .and_then(|r| r.split(')').next())
        .unwrap_or_else(|| panic!("no numerical code in {text:?}"));
    assert!(
        code == "unknown" || (code.len() == 16 && code.chars().all(|c| c.is_ascii_hexdigit())),
        "{text}"
    );
    assert!(
        inner == "unknown"
            || inner
                .trim_end_matches("+dirty")
                .chars()
                .all(|c| c.is_ascii_hexdigit()),
        "{text:?}"
    );
    for shell in ["bash", "zsh", "fish"] {
        let o = shscale(&["completions", shell]);
        let script = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{shell}");
        for needle in ["probe", "render", "hemisphere-res", "allow-large"] {
            assert!(script.contains(needle), "{shell} completions lack {needle}");
        }
    }
    fails(&["completions", "tcsh"], "tcsh");
}

/// `demo --format json`: the same tables and checks as the text, as one JSON object.
#[test]
fn demo_prints_json() {
    let v = json(&["demo", "--order", "8", "--format", "json"]);
    assert_eq!(v["operator_accuracy"].as_array().unwrap().len(), 5);
    assert_eq!(v["on_surface"].as_array().unwrap().len(), 5);
    for c in v["identities"].as_array().unwrap() {
        assert_eq!(c["ok"], true, "{c}");
    }
    assert!(v["failures"].as_array().unwrap().is_empty());
}
