//! End to end: rows know what made them (docs/provenance.md). Editing a mesh, a scene's mesh or
//! an environment map re-runs exactly the runs that read it; rows of another numerical code are
//! stale — re-run and set aside by default, refused with `--stale refuse` — and `merge` and the
//! summary name them.

mod common;
use common::*;
use std::path::{Path, PathBuf};

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-prov-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// An octahedron of circumradius `r` as OBJ text.
fn octahedron(r: f64) -> String {
    let mut s = String::new();
    for v in [
        [r, 0.0, 0.0],
        [-r, 0.0, 0.0],
        [0.0, r, 0.0],
        [0.0, -r, 0.0],
        [0.0, 0.0, r],
        [0.0, 0.0, -r],
    ] {
        s.push_str(&format!("v {} {} {}\n", v[0], v[1], v[2]));
    }
    for f in [
        [1, 3, 5],
        [3, 2, 5],
        [2, 4, 5],
        [4, 1, 5],
        [3, 1, 6],
        [2, 3, 6],
        [4, 2, 6],
        [1, 4, 6],
    ] {
        s.push_str(&format!("f {} {} {}\n", f[0], f[1], f[2]));
    }
    s
}

struct Ran {
    stdout: String,
    stderr: String,
    code: Option<i32>,
}

fn run(cfg: &Path, out: &Path, extra: &[&str]) -> Ran {
    let mut args = vec![
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let r = shscale(&args);
    Ran {
        stdout: String::from_utf8_lossy(&r.stdout).to_string(),
        stderr: String::from_utf8_lossy(&r.stderr).to_string(),
        code: r.status.code(),
    }
}

/// `ran N` of a run's last line.
fn ran(r: &Ran) -> usize {
    assert_eq!(r.code, Some(0), "{}\n{}", r.stdout, r.stderr);
    let at = r
        .stdout
        .find("\nran ")
        .map(|i| i + 5)
        .expect("a `ran` line");
    r.stdout[at..]
        .split(',')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

/// The `(run_id, column)` cells of a results file.
fn cells(csv: &Path, column: &str) -> Vec<(String, String)> {
    let mut r = ::csv::Reader::from_path(csv).unwrap();
    let c = r
        .headers()
        .unwrap()
        .iter()
        .position(|h| h == column)
        .unwrap();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            (rec[0].to_string(), rec[c].to_string())
        })
        .collect()
}

/// Two mesh files and the analytic sphere swept in one probe plan: editing one file re-runs
/// exactly its run (its old rows set aside in `runs.csv.stale`, valid CSV), the others are
/// reused; an edit back to the old bytes is another content change, re-run again.
#[test]
fn editing_a_mesh_reruns_exactly_the_runs_that_read_it() {
    let d = scratch("mesh");
    let (a, b) = (d.join("a.obj"), d.join("b.obj"));
    std::fs::write(&a, octahedron(1.0)).unwrap();
    std::fs::write(&b, octahedron(1.0)).unwrap();
    let cfg = d.join("meshes.toml");
    std::fs::write(
        &cfg,
        format!(
            "experiment = \"probe\"\norder = 2\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 4\nradii = [2.0]\nparallel_runs = false\n[sweep]\nmesh = [{:?}, {:?}, \"sphere\"]\n",
            a.display().to_string(),
            b.display().to_string()
        ),
    )
    .unwrap();
    let out = d.join("out");
    let csv = out.join("probe/meshes/runs.csv");
    assert_eq!(ran(&run(&cfg, &out, &[])), 3);
    let before = cells(&csv, "inputs");
    assert_eq!(
        ran(&run(&cfg, &out, &[])),
        0,
        "nothing changed: every row reused"
    );
    // A thicker a.obj (bounding radius 1 → 1.5).
    std::fs::write(&a, octahedron(1.5)).unwrap();
    let r = run(&cfg, &out, &[]);
    println!("{}\n{}", r.stdout, r.stderr);
    assert_eq!(ran(&r), 1, "only the run that reads a.obj");
    assert!(
        r.stderr
            .contains("1 of the 3 finished run(s) of this plan are stale")
            && r.stderr.contains("1 read inputs whose content changed")
            && r.stderr.contains("a.obj"),
        "{}",
        r.stderr
    );
    assert!(r.stdout.contains("1 after stale rows"), "{}", r.stdout);
    let after = cells(&csv, "inputs");
    let changed: Vec<_> = (after.iter()).filter(|x| !before.contains(x)).collect();
    assert_eq!(changed.len(), 1, "{changed:?}");
    let sphere = (after.iter()).find(|(_, i)| i == "none");
    assert!(
        sphere.is_some(),
        "the analytic sphere reads no file: {after:?}"
    );
    // The old rows, set aside as CSV under the results file's header.
    let stale = std::fs::read_to_string(out.join("probe/meshes/runs.csv.stale")).unwrap();
    let lines: Vec<&str> = stale.lines().collect();
    assert!(
        lines[0].starts_with("set_aside_line,set_aside_reason,run_id,"),
        "{}",
        lines[0]
    );
    assert_eq!(lines.len(), 2, "{stale}");
    assert!(lines[1].contains("stale: inputs"), "{}", lines[1]);
    std::fs::remove_dir_all(&d).ok();
}

/// A scene whose occluder is a mesh file and whose light an environment map, beside a scene of
/// the analytic sphere under a sky: editing the mesh, then the map, re-runs exactly the first
/// scene's runs each time.
#[test]
fn editing_a_scenes_mesh_or_environment_map_reruns_its_runs_only() {
    let d = scratch("scene");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    std::fs::write(d.join("m.obj"), octahedron(1.0)).unwrap();
    std::fs::copy(root.join("assets/envmaps/studio.exr"), d.join("env.exr")).unwrap();
    let plane = "[receiver]\ncenter = [0, 0, 0]\nsize = [3, 3]\nresolution = [12, 12]\n";
    std::fs::write(
        d.join("s1.toml"),
        format!("order = 2\ntruth_res = 6\n[[occluder]]\nmesh = \"m.obj\"\ncenter = [0, 0, 1.2]\nradius = 1.0\n{plane}[light]\nkind = \"exr\"\npath = \"env.exr\"\n"),
    )
    .unwrap();
    std::fs::write(
        d.join("s2.toml"),
        format!("order = 2\ntruth_res = 6\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 1.2]\nradius = 1.0\n{plane}[light]\nkind = \"sky\"\n"),
    )
    .unwrap();
    let cfg = d.join("scenes.toml");
    std::fs::write(
        &cfg,
        "experiment = \"budget_plane\"\ngpu = \"off\"\ntiming_repeats = 1\ntiming_warmup = 0\nlayout = \"latlong:4x8\"\nhemisphere_res = 4\n[sweep]\nscene = [\"s1.toml\", \"s2.toml\"]\nmethod = [\"extrapolated\", \"full_field\"]\n",
    )
    .unwrap();
    let out = d.join("out");
    assert_eq!(ran(&run(&cfg, &out, &[])), 4);
    assert_eq!(ran(&run(&cfg, &out, &[])), 0);
    std::fs::write(d.join("m.obj"), octahedron(0.8)).unwrap();
    let r = run(&cfg, &out, &[]);
    println!("mesh edited: {}", r.stderr);
    assert_eq!(ran(&r), 2, "the two runs of s1.toml");
    assert!(r.stderr.contains("m.obj"), "{}", r.stderr);
    std::fs::copy(root.join("assets/envmaps/courtyard.exr"), d.join("env.exr")).unwrap();
    let r = run(&cfg, &out, &[]);
    println!("map edited: {}", r.stderr);
    assert_eq!(ran(&r), 2, "the two runs of s1.toml again");
    assert!(r.stderr.contains("env.exr"), "{}", r.stderr);
    // The manifest lists every input with its content hash.
    let m = std::fs::read_to_string(out.join("budget_plane/scenes/manifest.toml")).unwrap();
    assert!(
        m.contains("env.exr") && m.contains("m.obj") && m.contains("s2.toml"),
        "{m}"
    );
    std::fs::remove_dir_all(&d).ok();
}

/// Rows whose `code` is not this binary's (as a binary of other numerical code writes them) are
/// stale: `--stale refuse` stops with exit 2 naming both ways on and moves nothing; the default
/// re-runs exactly them and says so with counts and codes. `merge` of a folder whose rows are
/// all of another code merges them and names them stale; the summary says so too.
#[test]
fn rows_of_another_numerical_code_are_stale_and_said_so() {
    let d = scratch("code");
    let cfg = d.join("tiny.toml");
    std::fs::write(&cfg, "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 4\nradii = [2.0]\nparallel_runs = false\n[sweep]\nalpha_deg = [30, 45, 60]\n").unwrap();
    let out = d.join("out");
    let csv = out.join("probe/tiny/runs.csv");
    assert_eq!(ran(&run(&cfg, &out, &[])), 3);
    // One run's rows as another code wrote them.
    let text = std::fs::read_to_string(&csv).unwrap();
    let ours = cells(&csv, "code")[0].1.clone();
    let other = "0123456789abcdef";
    let first_id = cells(&csv, "code")[0].0.clone();
    let edited: String = (text.lines())
        .map(|l| {
            if l.starts_with(&first_id) {
                l.replace(&ours, other)
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    std::fs::write(&csv, &edited).unwrap();
    let r = run(&cfg, &out, &["--stale", "refuse"]);
    println!("{}", r.stderr);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(
        r.stderr.contains("--stale rerun") && r.stderr.contains("--name"),
        "{}",
        r.stderr
    );
    assert!(
        r.stderr.contains(other) && r.stderr.contains(&ours),
        "{}",
        r.stderr
    );
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        edited,
        "refusing moved rows"
    );
    let r = run(&cfg, &out, &[]);
    println!("{}", r.stderr);
    assert_eq!(ran(&r), 1);
    assert!(
        r.stderr.contains(&format!(
            "1 computed by numerical code {other} (this binary's is {ours})"
        )),
        "{}",
        r.stderr
    );
    // Every row of another code: merge names them stale, and so does the merged summary.
    let all = std::fs::read_to_string(&csv).unwrap().replace(&ours, other);
    std::fs::write(&csv, all).unwrap();
    let merged = d.join("merged");
    let m = shscale(&[
        "merge",
        out.join("probe/tiny").to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&m.stderr);
    println!("{err}");
    assert!(m.status.success(), "{err}");
    assert!(
        err.contains(&format!(
            "stale: all 3 rows were computed by numerical code {other}"
        )),
        "{err}"
    );
    let summary = std::fs::read_to_string(merged.join("summary.md")).unwrap();
    assert!(
        summary.contains("**Provenance.** stale: all 3 rows"),
        "{summary}"
    );
    // A schema beside the rows: run_id a string, contended a bool.
    let schema = std::fs::read_to_string(merged.join("runs.schema.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&schema).unwrap();
    let ty = |n: &str| {
        (v["columns"].as_array().unwrap().iter())
            .find(|c| c["name"] == n)
            .map(|c| c["type"].as_str().unwrap().to_string())
    };
    assert_eq!(ty("run_id").as_deref(), Some("string"));
    assert_eq!(ty("contended").as_deref(), Some("bool"));
    assert_eq!(ty("radii").as_deref(), Some("list"));
    std::fs::remove_dir_all(&d).ok();
}
