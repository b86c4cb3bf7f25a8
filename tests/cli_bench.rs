//! End-to-end tests of `shscale bench` (Table 1) and of the GPU settings: CSV/JSON rows with the
//! declared columns, the GPU path beside the CPU path where an adapter exists, and the no-adapter
//! behaviour (notice and CPU path for `auto`, exit 2 for `required`). "No adapter" is forced with
//! `WGPU_BACKEND=dx12`, a backend that does not exist on Linux.

mod common;
use std::process::{Command, Output};

fn run(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_shscale"));
    c.args(args);
    for (k, v) in envs {
        c.env(k, v);
    }
    c.output().expect("binary runs")
}

fn require_gpu() -> bool {
    std::env::var("SHSCALE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

const NO_ADAPTER: (&str, &str) = ("WGPU_BACKEND", "dx12");

#[test]
fn cpu_bench_prints_csv_rows_with_the_declared_columns() {
    let out = run(
        &[
            "bench", "--scene", "egg", "--frames", "2", "--warmup", "0", "--format", "csv",
        ],
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let mut reader = ::csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(header.join(","), shscale_scene::bench::CSV_COLUMNS);
    let rows: Vec<::csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 1, "{text}");
    let cells: Vec<String> = rows[0].iter().map(String::from).collect();
    assert_eq!(cells.len(), header.len(), "{cells:?}");
    let col = |name: &str| cells[header.iter().position(|h| h == name).unwrap()].as_str();
    assert_eq!(col("scene"), "egg");
    assert_eq!(col("path"), "cpu");
    assert_eq!(col("receivers"), "25600");
    assert_eq!(col("samples"), "240", "12×20 lat-long, as the TR");
    assert_eq!(
        col("sh_conversion_ms"),
        "",
        "inside BSV sampling on the CPU"
    );
    let fps: f64 = col("fps").parse().unwrap();
    let frame: f64 = col("frame_ms").parse().unwrap();
    assert!(
        fps > 0.0 && (fps * frame / 1e3 - 1.0).abs() < 1e-2,
        "fps {fps}, frame {frame} ms"
    );
}

#[test]
fn gpu_bench_runs_beside_the_cpu_or_explains_why_not() {
    let out = run(
        &[
            "bench", "--gpu", "--scene", "bird", "--frames", "2", "--warmup", "1", "--format",
            "json",
        ],
        &[],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    if err.contains("notice: no GPU adapter") {
        assert!(!require_gpu(), "SHSCALE_REQUIRE_GPU=1 but: {err}");
        eprintln!("SKIPPED GPU half (no adapter)");
        assert_eq!(rows.len(), 1);
        return;
    }
    assert_eq!(rows.len(), 2, "{rows:?}");
    let gpu = &rows[1];
    assert_eq!(gpu["path"], "gpu");
    assert!(!gpu["device"].as_str().unwrap().is_empty());
    for key in [
        "bsv_sampling_ms",
        "sh_conversion_ms",
        "shadowing_ms",
        "frame_ms",
        "fps",
    ] {
        let v = gpu[key].as_f64().unwrap_or_else(|| panic!("{key}: {gpu}"));
        assert!(v > 0.0, "{key} = {v}");
    }
    // Same scene description on both rows.
    for key in [
        "vertices",
        "triangles",
        "samples",
        "rays_per_sample",
        "receivers",
    ] {
        assert_eq!(rows[0][key], gpu[key], "{key}");
    }
}

#[test]
fn without_an_adapter_auto_goes_on_and_required_fails() {
    let out = run(
        &[
            "bench", "--gpu", "--scene", "egg", "--frames", "1", "--warmup", "0", "--format", "csv",
        ],
        &[NO_ADAPTER],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let notices: Vec<&str> = err.lines().filter(|l| l.starts_with("notice:")).collect();
    assert_eq!(notices.len(), 1, "{err}");
    assert!(notices[0].contains("no GPU adapter"), "{err}");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().count(),
        2,
        "header + CPU row"
    );

    let out = run(
        &[
            "bench",
            "--gpu",
            "--require-gpu",
            "--scene",
            "egg",
            "--frames",
            "1",
        ],
        &[NO_ADAPTER],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("error: gpu = \"required\": no GPU adapter"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn experiment_gpu_setting_is_validated_and_enforced() {
    let dir = std::env::temp_dir().join(format!("shscale-gpu-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = "experiment = \"probe\"\nmesh = \"duck\"\norder = 2\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 4\nradii = [2.0]\n";
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, format!("{base}gpu = \"sometimes\"\n")).unwrap();
    common::fails(
        &["run", bad.to_str().unwrap()],
        "bad.toml:8: gpu: \"sometimes\" is not one of",
    );

    let req = dir.join("req.toml");
    std::fs::write(&req, format!("{base}gpu = \"required\"\n")).unwrap();
    let out = run(
        &[
            "run",
            req.to_str().unwrap(),
            "--out-dir",
            dir.join("out").to_str().unwrap(),
        ],
        &[NO_ADAPTER],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("gpu = \"required\": no GPU adapter"), "{err}");

    // With an adapter (lavapipe in CI) the run records GPU timings and the device.
    let auto = dir.join("auto.toml");
    std::fs::write(&auto, base).unwrap();
    let out = run(
        &[
            "run",
            auto.to_str().unwrap(),
            "--out-dir",
            dir.join("out").to_str().unwrap(),
        ],
        &[],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let csv = std::fs::read_to_string(dir.join("out/probe/auto/runs.csv")).unwrap();
    let mut reader = ::csv::Reader::from_reader(csv.as_bytes());
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let row = reader.records().next().unwrap().unwrap();
    let i = header
        .iter()
        .position(|h| h == "gpu_bsv_sampling_seconds")
        .unwrap();
    let cell = &row[i];
    if err.contains("notice: no GPU adapter") {
        assert!(!require_gpu(), "SHSCALE_REQUIRE_GPU=1 but: {err}");
        assert_eq!(cell, "");
    } else {
        let t: f64 = cell.parse().unwrap_or_else(|_| panic!("{row:?}"));
        assert!(t > 0.0, "{row:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn gpu_sequence_image_matches_the_cpu_sequence() {
    let dir = std::env::temp_dir().join(format!("shscale-gpu-img-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/scene_bird.toml");
    let (cpu, gpu) = (dir.join("cpu.exr"), dir.join("gpu.exr"));
    let out = run(
        &[
            "render",
            "--scene",
            scene,
            "--frames",
            "3",
            "--out",
            cpu.to_str().unwrap(),
        ],
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = run(
        &[
            "render",
            "--scene",
            scene,
            "--frames",
            "3",
            "--gpu",
            "--out",
            gpu.to_str().unwrap(),
        ],
        &[],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() && err.contains("no GPU adapter") && !require_gpu() {
        eprintln!("SKIPPED (no GPU adapter)");
        return;
    }
    assert!(out.status.success(), "{err}");
    let (w, h, a) = shscale_present::image::read_exr(&cpu).unwrap();
    let (w2, h2, b) = shscale_present::image::read_exr(&gpu).unwrap();
    assert_eq!((w, h), (w2, h2));
    let max = a.iter().flatten().fold(0f32, |m, v| m.max(*v)) as f64;
    let rmse = (a
        .iter()
        .zip(&b)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] as f64 - q[c] as f64).powi(2)))
        .sum::<f64>()
        / (3 * a.len()) as f64)
        .sqrt();
    // Differences come only from grazing rays and f32 rounding (see crates/gpu/tests/parity.rs).
    println!("GPU vs CPU sequence image: RMSE {rmse:.2e}, max irradiance {max:.3}");
    assert!(rmse <= 1e-3 * max, "RMSE {rmse:.2e} vs max {max:.3}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `bench rays|bsv|sh --format json`: the fields the issue names, values that agree with the
/// workload (ray and point counts, order, precision, threads), and on a ray file with its
/// answers the disagreement count — zero against answers computed here by brute force, and
/// exactly the flipped bits when some answers are flipped.
#[test]
fn kernel_benchmarks_report_their_workload() {
    let quick = ["--min-time", "0.01", "--warmup", "0", "--format", "json"];
    let with = |args: &[&str]| -> Vec<String> {
        args.iter()
            .chain(quick.iter())
            .map(|s| s.to_string())
            .collect()
    };
    let json = |args: Vec<String>| {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        common::json(&a)
    };
    let r = json(with(&[
        "bench",
        "rays",
        "--workload",
        "random",
        "--count",
        "3000",
    ]));
    assert_eq!(r["rays"], 3000);
    assert_eq!(r["threads"], 1);
    assert!(r["rays_per_second"].as_f64().unwrap() > 0.0);
    assert!(r["median_seconds"].as_f64().unwrap() > 0.0);
    assert!(
        ["portable", "avx2+fma", "avx512"].contains(&r["simd"].as_str().unwrap()),
        "{r}"
    );
    let r = json(with(&[
        "bench",
        "rays",
        "--workload",
        "bsv",
        "--threads",
        "2",
    ]));
    assert_eq!(r["rays"], 12 * 20 * 32 * 32);
    assert_eq!(r["threads"], 2);
    let r = json(with(&[
        "bench",
        "bsv",
        "--layout",
        "latlong:4x6",
        "--hemisphere-res",
        "8",
        "--order",
        "3",
    ]));
    assert_eq!(r["rays"], 4 * 6 * 8 * 8);
    assert_eq!(r["kernel"], "bsv");
    let r = json(with(&[
        "bench",
        "sh",
        "--order",
        "5",
        "--precision",
        "f32",
        "--points",
        "1001",
    ]));
    assert_eq!(r["order"], 5);
    assert_eq!(r["precision"], "f32");
    assert_eq!(r["points"], 1001);
    assert!(r["ns_per_point"].as_f64().unwrap() > 0.0);

    // A ray file against the bunny with answers from the f64 brute force.
    use shscale_geometry::{bundled, BruteForce, DVec3, Occluder};
    let mesh = bundled::load("bunny").unwrap();
    let s = mesh.bounding_sphere();
    let brute = BruteForce::new(&mesh);
    let n = 200;
    let (mut os, mut ds, mut hits) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let a = i as f64 * 2.399963;
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let dir = DVec3::new(
            (1.0 - z * z).sqrt() * a.cos(),
            (1.0 - z * z).sqrt() * a.sin(),
            z,
        );
        let o = s.center + 1.5 * s.radius * dir;
        let target = s.center + 0.4 * s.radius * DVec3::new(a.sin(), (2.0 * a).cos(), 0.3);
        let d = (target - o).normalize();
        os.push(o.as_vec3());
        ds.push(d.as_vec3());
        hits.push(brute.occluded(o, d, 0.0, f64::INFINITY));
    }
    let mut bytes = Vec::new();
    for v in os.iter().chain(&ds) {
        for c in v.to_array() {
            bytes.extend(c.to_le_bytes());
        }
    }
    let dir = std::env::temp_dir().join(format!("shscale-rays-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rays = dir.join("t.rays.f32");
    std::fs::write(&rays, &bytes).unwrap();
    let pack = |h: &[bool]| {
        let mut b = vec![0u8; h.len().div_ceil(8)];
        for (i, &x) in h.iter().enumerate() {
            b[i / 8] |= u8::from(x) << (i % 8);
        }
        b
    };
    let bits = dir.join("t.hits.bits");
    std::fs::write(&bits, pack(&hits)).unwrap();
    let args = |b: &std::path::Path| {
        with(&[
            "bench",
            "rays",
            "--rays",
            rays.to_str().unwrap(),
            "--hits",
            b.to_str().unwrap(),
        ])
    };
    let r = json(args(&bits));
    let want_hits = hits.iter().filter(|h| **h).count();
    println!("{want_hits} of {n} rays hit");
    assert!(want_hits > 20 && want_hits < n - 20, "{want_hits}");
    assert_eq!(r["rays"], n);
    assert_eq!(r["hits"], want_hits);
    assert_eq!(r["mismatches"], 0);
    // Flip 7 answers: 7 disagreements.
    let mut flipped = hits.clone();
    for i in [0, 3, 50, 51, 120, 198, 199] {
        flipped[i] = !flipped[i];
    }
    let bad = dir.join("f.hits.bits");
    std::fs::write(&bad, pack(&flipped)).unwrap();
    assert_eq!(json(args(&bad))["mismatches"], 7);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An unknown `SHSCALE_SIMD` is refused before any work (exit 2, the variable named); `portable`
/// is reported by the benchmarks.
#[test]
fn simd_setting_is_checked_and_reported() {
    let out = run(
        &["sh", "eval", "--order", "2", "--dir", "0,0,1"],
        &[("SHSCALE_SIMD", "avx9")],
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("SHSCALE_SIMD") && err.contains("avx9"),
        "{err}"
    );
    let out = run(
        &[
            "bench",
            "sh",
            "--order",
            "4",
            "--points",
            "100",
            "--min-time",
            "0.01",
            "--format",
            "json",
        ],
        &[("SHSCALE_SIMD", "portable")],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["simd"], "portable");
    // The row names its CPU, and the CPU's best level is not capped by the setting.
    let cpu = &v["cpu"];
    for k in ["vendor", "microarchitecture", "summary", "simd_detected"] {
        assert!(cpu[k].as_str().is_some_and(|s| !s.is_empty()), "{k}: {v}");
    }
    assert!(cpu["family"].as_u64().is_some(), "{v}");
    let detected = shscale_sh::simd::detected().name();
    assert_eq!(cpu["simd_detected"], detected, "{v}");
    assert!(cpu["summary"].as_str().unwrap().contains(detected), "{v}");
}

/// `scripts/bench-peers` refuses a kit folder without the kit's files, and a bad level, with
/// exit 2 naming the culprit, before measuring anything.
#[test]
fn peers_driver_refuses_bad_arguments() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let script = root.join("scripts/bench-peers");
    let kit = std::env::temp_dir().join(format!("shscale-no-kit-{}", std::process::id()));
    std::fs::create_dir_all(&kit).unwrap();
    let out = Command::new("python3")
        .arg(&script)
        .arg(&kit)
        .arg(&kit)
        .env("SHSCALE_BIN", env!("CARGO_BIN_EXE_shscale"))
        .output()
        .expect("python3 runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("KIT") && err.contains("bench_rays.py"),
        "{err}"
    );
    // A complete-looking kit and meshes folder, then a level that does not exist.
    for f in [
        "bench_rays.py",
        "bench_sh.py",
        "build/embree_direct",
        ".venv/bin/python",
        "workloads/workloads.json",
        "bunny.obj",
        "dragon_19k.obj",
    ] {
        let p = kit.join(f);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, "").unwrap();
    }
    let out = Command::new("python3")
        .arg(&script)
        .args([&kit, &kit])
        .args(["--levels", "auto,avx9"])
        .env("SHSCALE_BIN", env!("CARGO_BIN_EXE_shscale"))
        .output()
        .expect("python3 runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--levels") && err.contains("avx9"), "{err}");
    let _ = std::fs::remove_dir_all(&kit);
}

/// `bench --methods`: one row per scene and variant with the variant's path, its stages and,
/// with `--errors`, the error against each measured frame's band-limited truth; the papers'
/// method is the cached path and the other methods per-frame; a bad variant refused.
#[test]
fn table1_per_method_rows() {
    let v = common::json(&[
        "bench",
        "--scene",
        "egg",
        "--methods",
        "extrapolated,sphere_set:parts=2",
        "--errors",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--format",
        "json",
    ]);
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 2, "{v}");
    assert_eq!(
        (rows[0]["method"].as_str(), rows[0]["path"].as_str()),
        (Some("extrapolated"), Some("cached"))
    );
    assert_eq!(
        (rows[1]["method"].as_str(), rows[1]["path"].as_str()),
        (Some("sphere_set:parts=2"), Some("per-frame"))
    );
    for r in rows {
        let e = r["error_mean"].as_f64().unwrap();
        assert!(
            e > 0.0 && e < 1.0 && r["error_max"].as_f64() == Some(e),
            "{r}"
        );
        let stages = r["stages_ms"].as_object().unwrap();
        let sum: f64 = stages.values().map(|x| x.as_f64().unwrap()).sum();
        // One frame: the frame is the sum of its stages.
        assert!((sum - r["frame_ms"].as_f64().unwrap()).abs() < 1e-6, "{r}");
    }
    assert!(rows[1]["stages_ms"]["sphere_fit"].as_f64().is_some(), "{v}");
    common::fails(&["bench", "--methods", "sphere_set:s=2"], "sphere_set");
}

/// `bench bsv --write-rays`: the sampling's exact rays in the peer kit's format, our answers and
/// the mesh; traced again from the files by `bench rays`, they give the same answers (0
/// disagreements) — the files are what Embree is timed on.
#[test]
fn bsv_rays_are_written_for_a_peer() {
    let d = std::env::temp_dir().join(format!("shscale-bsv-rays-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let prefix = d.join("bsv");
    let v = common::json(&[
        "bench",
        "bsv",
        "--mesh",
        "bunny",
        "--layout",
        "latlong:4x6",
        "--hemisphere-res",
        "8",
        "--order",
        "4",
        "--threads",
        "1",
        "--min-time",
        "0.01",
        "--warmup",
        "0",
        "--write-rays",
        prefix.to_str().unwrap(),
        "--format",
        "json",
    ]);
    let w = &v["written"];
    let n = w["count"].as_u64().unwrap() as usize;
    assert_eq!(n, 24 * 64, "{v}");
    assert_eq!(
        std::fs::metadata(w["rays"].as_str().unwrap())
            .unwrap()
            .len() as usize,
        24 * n
    );
    assert_eq!(
        std::fs::metadata(w["hits"].as_str().unwrap())
            .unwrap()
            .len() as usize,
        n.div_ceil(8)
    );
    let hf = w["hit_fraction"].as_f64().unwrap();
    assert!(hf > 0.0 && hf < 1.0, "{v}");
    let r = common::json(&[
        "bench",
        "rays",
        "--mesh",
        w["mesh"].as_str().unwrap(),
        "--rays",
        w["rays"].as_str().unwrap(),
        "--hits",
        w["hits"].as_str().unwrap(),
        "--threads",
        "1",
        "--min-time",
        "0.01",
        "--warmup",
        "0",
        "--format",
        "json",
    ]);
    assert_eq!(r["rays"].as_u64(), Some(n as u64));
    assert_eq!(r["mismatches"].as_u64(), Some(0), "{r}");
    common::fails(
        &[
            "bench",
            "bsv",
            "--write-rays",
            d.join("no/such/dir/x").to_str().unwrap(),
        ],
        "--write-rays",
    );
    std::fs::remove_dir_all(&d).ok();
}

/// `bench --methods --gpu`: a GPU row beside the CPU row for a method with a GPU form; the GPU
/// sphere set's per-frame error equals the CPU's within f32 rounding (the same spheres, the same
/// caps and products — or the same union of the caps), and the GPU full field's, clearance
/// radii's and sub-volumes' the CPU's (the same shells', samples' or parts' rays). Without an adapter the CPU rows alone (a notice), unless
/// `SHSCALE_REQUIRE_GPU=1`.
#[test]
fn table1_per_method_gpu_rows() {
    let v = common::json(&[
        "bench",
        "--scene",
        "egg",
        "--methods",
        "sphere_set:parts=2,sphere_set:parts=2,combine=union,full_field,extrapolated:clearance=0.1,sub_volumes:parts=2",
        "--errors",
        "--gpu",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--format",
        "json",
    ]);
    let rows = v.as_array().unwrap();
    if rows.len() == 5 {
        assert!(!require_gpu(), "no GPU row: {v}");
        eprintln!("notice: no adapter; the GPU rows were not measured");
        return;
    }
    assert_eq!(rows.len(), 10, "{v}");
    for pair in rows.chunks(2) {
        assert_eq!(pair[1]["path"], "gpu", "{v}");
        assert_eq!(pair[0]["method"], pair[1]["method"], "{v}");
        let (c, g) = (
            pair[0]["error_mean"].as_f64().unwrap(),
            pair[1]["error_mean"].as_f64().unwrap(),
        );
        println!(
            "egg, {}: CPU error {c:.6}, GPU error {g:.6}",
            pair[0]["method"]
        );
        assert!((c - g).abs() < 1e-4 * c.max(1e-3), "{c} vs {g}");
    }
    // The union is not the chain: the two variants' errors differ.
    let (chain, union) = (
        rows[0]["error_mean"].as_f64(),
        rows[2]["error_mean"].as_f64(),
    );
    assert_ne!(chain, union, "{v}");
}

/// `bench --methods … --gpu --device-pose`: a `gpu-device` row for each method the device
/// poses — sphere sets with the area fit (posed and fitted on the device, no read-back among
/// its stages) and the papers' sequence — and none for the full field (posed on the host); the
/// device-fitted spheres score as the host-fitted ones within the fit's f32 rounding.
#[test]
fn table1_per_method_device_posed_rows() {
    let v = common::json(&[
        "bench",
        "--scene",
        "bird",
        "--methods",
        "sphere_set:parts=4,full_field,extrapolated",
        "--errors",
        "--gpu",
        "--device-pose",
        "--frames",
        "1",
        "--warmup",
        "1",
        "--format",
        "json",
    ]);
    let rows = v.as_array().unwrap();
    if rows.len() == 3 {
        assert!(!require_gpu(), "no GPU row: {v}");
        eprintln!("notice: no adapter; the GPU rows were not measured");
        return;
    }
    let paths: Vec<(String, String)> = (rows.iter())
        .map(|r| {
            (
                r["method"].as_str().unwrap().to_string(),
                r["path"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    println!("{paths:?}");
    let device: Vec<&serde_json::Value> = (rows.iter())
        .filter(|r| r["path"] == "gpu-device")
        .collect();
    assert_eq!(device.len(), 2, "{v}");
    assert_eq!(device[0]["method"], "sphere_set:parts=4", "{v}");
    assert_eq!(device[1]["method"], "extrapolated", "{v}");
    let stages = device[0]["stages_ms"].as_object().unwrap();
    let names: Vec<&String> = stages.keys().collect();
    assert_eq!(names, ["deform", "sphere_fit", "upload", "shading"], "{v}");
    let host = (rows.iter())
        .find(|r| r["path"] == "gpu" && r["method"] == "sphere_set:parts=4")
        .unwrap();
    let (h, d) = (
        host["error_mean"].as_f64().unwrap(),
        device[0]["error_mean"].as_f64().unwrap(),
    );
    println!("bird, 4 spheres: host-fitted error {h:.6}, device-fitted {d:.6}");
    assert!((h - d).abs() < 1e-3 * h, "{h} vs {d}");
}

/// `scripts/device-targets.py` reads device-check's JSON and states each target from it: a
/// synthetic run where the bird meets 1,000 FPS and 5× its CPU frame and the sponge meets
/// neither, one sphere set at 6,000 FPS and one at 4,000; a missing file is refused with exit 2
/// naming it.
#[test]
fn device_targets_are_read_from_the_device_checks_rows() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = std::env::temp_dir().join(format!("shscale-targets-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let row = |scene: &str, path: &str, ms: f64| {
        format!(
            r#"{{"scene": "{scene}", "path": "{path}", "device": "{}", "frame_ms": {ms}, "fps": {}}}"#,
            if path == "cpu" { "cpu" } else { "Test GPU" },
            1e3 / ms
        )
    };
    let table1 = [
        row("bird", "cpu", 2.0),
        row("bird", "gpu", 0.5),
        row("bird", "gpu-device", 0.25),
        row("sponge", "cpu", 5.0),
        row("sponge", "gpu", 2.84),
    ];
    std::fs::write(dir.join("table1.json"), format!("[{}]", table1.join(","))).unwrap();
    let set = |method: &str, path: &str, ms: f64| {
        format!(
            r#"{{"scene": "egg", "method": "{method}", "path": "{path}", "device": "Test GPU", "frame_ms": {ms}, "fps": {}, "error_mean": 0.03}}"#,
            1e3 / ms
        )
    };
    let methods = [
        set("sphere_set:parts=4", "per-frame", 20.0),
        set("sphere_set:parts=4", "gpu", 0.3),
        set("sphere_set:parts=4", "gpu-device", 1.0 / 6.0),
        set("sphere_set:parts=16", "gpu", 0.25),
        set("extrapolated", "gpu", 0.1),
    ];
    std::fs::write(dir.join("methods.json"), format!("[{}]", methods.join(","))).unwrap();
    let run = |d: &std::path::Path| {
        std::process::Command::new("python3")
            .arg(root.join("scripts/device-targets.py"))
            .arg(d)
            .output()
            .expect("python3")
    };
    let o = run(&dir);
    let text = String::from_utf8_lossy(&o.stdout);
    println!("{text}");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let line = |start: &str| {
        text.lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no line {start:?} in {text}"))
            .to_string()
    };
    let bird = line("| bird |");
    assert!(
        bird.contains("gpu-device | 4000 | met") && bird.contains("8.00× | met"),
        "{bird}"
    );
    let sponge = line("| sponge |");
    assert!(
        sponge.contains("| 352 | **not met**") && sponge.contains("1.76× | **not met**"),
        "{sponge}"
    );
    let four = line("| egg | sphere_set:parts=4 |");
    assert!(four.contains("gpu-device | 6000 | met | 0.0300"), "{four}");
    let sixteen = line("| egg | sphere_set:parts=16 |");
    assert!(sixteen.contains("gpu | 4000 | **not met**"), "{sixteen}");
    assert!(!text.contains("extrapolated"), "{text}");
    std::fs::remove_file(dir.join("methods.json")).unwrap();
    let o = run(&dir);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("methods.json"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `scripts/device-check` writes each file through a temporary renamed on success: a bench that
/// fails (here a binary that exits 1 at once) leaves the previous sitting's `table1.json` whole
/// and no temporary behind, and the script fails naming the file.
#[test]
fn a_failing_device_check_keeps_the_previous_sittings_files() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = std::env::temp_dir().join(format!("shscale-devcheck-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let old = r#"[{"scene": "bird", "path": "gpu", "frame_ms": 0.5}]"#;
    std::fs::write(dir.join("table1.json"), old).unwrap();
    let out = std::process::Command::new("bash")
        .arg(root.join("scripts/device-check"))
        .env("OUT", &dir)
        .env("SHSCALE_BIN", "/bin/false")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    println!("{err}");
    assert!(!out.status.success());
    assert!(err.contains("table1.json left as it was"), "{err}");
    assert_eq!(
        std::fs::read_to_string(dir.join("table1.json")).unwrap(),
        old
    );
    let left: Vec<String> = (std::fs::read_dir(&dir).unwrap().flatten())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `scripts/device-targets.py` on hostile rows: a row without `device`, `frame_ms = 0`, a string
/// `fps`, a list as `scene`, a non-string `path`, a boolean `fps`, a non-list file and a FIFO
/// each exit 2 with one line naming the file (and the row and key), never a traceback or a
/// hang; a scene named `x | <script>` is escaped in its Markdown cell. `scripts/device-check`
/// with `OUT` at a file exits 2 naming it.
#[test]
fn device_targets_refuse_hostile_rows_and_escape_their_text() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = std::env::temp_dir().join(format!("shscale-targets-hostile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let good =
        r#"{"scene": "bird", "path": "gpu", "device": "Test GPU", "frame_ms": 0.5, "fps": 2000}"#;
    let run = |table1: &str| {
        std::fs::write(dir.join("table1.json"), table1).unwrap();
        std::fs::write(dir.join("methods.json"), format!("[{good}]")).unwrap();
        let out = std::process::Command::new("timeout")
            .args(["20", "python3"])
            .arg(root.join("scripts/device-targets.py"))
            .arg(&dir)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).to_string(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    for (row, key) in [
        (
            r#"{"scene": "bird", "path": "gpu", "frame_ms": 0.5, "fps": 2000}"#,
            "'device'",
        ),
        (
            r#"{"scene": "bird", "path": "gpu", "device": "d", "frame_ms": 0, "fps": 2000}"#,
            "'frame_ms'",
        ),
        (
            r#"{"scene": "bird", "path": "gpu", "device": "d", "frame_ms": 0.5, "fps": "fast"}"#,
            "'fps'",
        ),
        (
            r#"{"scene": ["bird"], "path": "gpu", "device": "d", "frame_ms": 0.5, "fps": 2000}"#,
            "'scene'",
        ),
        (
            r#"{"scene": "bird", "path": 3, "device": "d", "frame_ms": 0.5, "fps": 2000}"#,
            "'path'",
        ),
        (
            r#"{"scene": "bird", "path": "gpu", "device": "d", "frame_ms": 0.5, "fps": true}"#,
            "'fps'",
        ),
        (r#""a string""#, "row 1: not an object"),
    ] {
        let (code, _, err) = run(&format!("[{good}, {row}]"));
        println!("{err}");
        assert_eq!(code, Some(2), "{row}: {err}");
        assert!(
            !err.contains("Traceback") && err.lines().count() == 1,
            "{err}"
        );
        assert!(
            err.contains("table1.json") && err.contains(key),
            "{row}: {err}"
        );
    }
    let (code, _, err) = run(r#"{"rows": []}"#);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("not a list"), "{err}");
    let (code, md, err) = run(&format!(
        r#"[{good}, {{"scene": "x | <script>", "path": "gpu", "device": "d", "frame_ms": 1.0, "fps": 1000}}]"#
    ));
    assert_eq!(code, Some(0), "{err}");
    assert!(
        md.contains(r"x \| &lt;script&gt;") && !md.contains("<script>"),
        "{md}"
    );
    // A FIFO where table1.json should be: refused at once, not read.
    let _ = std::fs::remove_file(dir.join("table1.json"));
    if std::process::Command::new("mkfifo")
        .arg(dir.join("table1.json"))
        .status()
        .is_ok_and(|s| s.success())
    {
        let out = std::process::Command::new("timeout")
            .args(["20", "python3"])
            .arg(root.join("scripts/device-targets.py"))
            .arg(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("not a regular file"), "{err}");
    }
    // device-check with OUT at a file.
    let f = dir.join("a-file");
    std::fs::write(&f, "x").unwrap();
    let out = std::process::Command::new("bash")
        .arg(root.join("scripts/device-check"))
        .env("OUT", &f)
        .env("SHSCALE_BIN", "/bin/true")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("is not a folder") && err.contains("a-file"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&f).unwrap(), "x");
    std::fs::remove_dir_all(&dir).ok();
}
