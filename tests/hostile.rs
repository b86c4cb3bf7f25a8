//! The hostile-input suite: bad values thrown at the binary as a careless or hostile user would —
//! CLI values, experiment configs, scene files, OBJ/PLY meshes (binary garbage, truncated and
//! lying headers), EXR maps (truncated, lying headers, NaN/inf/negative pixels), results files
//! (corrupt, truncated, foreign columns) and output paths (a directory, a missing parent, a
//! read-only place). Every case must exit with status 2 within its time limit, print exactly one
//! stderr line that names the culprit (a `needle` of the flag, key, file or value), never panic,
//! and leave every file of the fixture folder byte-identical (nothing created, nothing changed).

mod common;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn write(d: &Path, name: &str, bytes: impl AsRef<[u8]>) {
    let p = d.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(p, bytes).unwrap();
}

fn ply(pts: &[[f64; 3]], faces: &[[i64; 3]]) -> String {
    let mut s = format!("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n", pts.len(), faces.len());
    for p in pts {
        s.push_str(&format!("{:e} {:e} {:e}\n", p[0], p[1], p[2]));
    }
    for f in faces {
        s.push_str(&format!("3 {} {} {}\n", f[0], f[1], f[2]));
    }
    s
}

const TET: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const TET_F: [[i64; 3]; 4] = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];

fn scaled(s: f64) -> Vec<[f64; 3]> {
    TET.iter().map(|p| p.map(|x| x * s)).collect()
}

const SCENE: &str = r#"order = 2
alpha_deg = 45
layout = "fib:20"
hemisphere_res = 4
k_count = 8
sampling_radius = 1.0

[[occluder]]
mesh = "sphere"
center = [0, 0, 1.5]
radius = 1.0

[[occluder]]
mesh = "sphere"
center = [1, 0, 1.5]
radius = 0.5

[receiver]
center = [0, 0, 0]
size = [4, 4]
resolution = [8, 8]

[light]
kind = "sky"
ambient = 0.3
zenith = 1.0
sun = 20.0
sun_dir = [0.3, 0.2, 1]
sun_radius_deg = 5
"#;

fn exr_scene(path: &str, extra: &str) -> String {
    format!(
        "{}[light]\nkind = \"exr\"\npath = \"{path}\"\n{extra}",
        SCENE.split("[light]").next().unwrap()
    )
}

/// A 4×2 EXR with the given pixel (others 1).
fn exr_with(d: &Path, name: &str, bad: (f32, f32, f32)) {
    std::fs::create_dir_all(d.join(name).parent().unwrap()).unwrap();
    exr::prelude::write_rgb_file(d.join(name), 4, 2, |x, y| {
        if (x, y) == (2, 1) {
            bad
        } else {
            (1.0, 1.0, 1.0)
        }
    })
    .unwrap();
}

const CONFIG: &str = "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:10\"\nhemisphere_res = 2\nk_count = 4\nradii = [2.0]\nparallel_runs = false\n[sweep]\nalpha_deg = [30, 60]\n";

/// The fixture folder: every file a case reads, and the outputs some cases must not touch.
fn fixture() -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-hostile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    // Meshes.
    write(&d, "m/e300.ply", ply(&scaled(1e300), &TET_F));
    write(&d, "m/e60.ply", ply(&scaled(1e60), &TET_F));
    write(&d, "m/tiny.ply", ply(&scaled(1e-60), &TET_F));
    write(
        &d,
        "m/nan.ply",
        ply(&TET, &TET_F).replacen("0e0 0e0 0e0", "nan 0 0", 1),
    );
    write(
        &d,
        "m/inf.ply",
        ply(&TET, &TET_F).replacen("0e0 0e0 0e0", "inf 0 0", 1),
    );
    write(
        &d,
        "m/badidx.ply",
        ply(&TET, &[[0, 1, 7], [0, 1, 3], [0, 2, 3], [1, 2, 3]]),
    );
    write(
        &d,
        "m/negidx.ply",
        ply(&TET, &[[0, 1, -1], [0, 1, 3], [0, 2, 3], [1, 2, 3]]),
    );
    write(&d, "m/degenerate.ply", ply(&[[0.0; 3]; 4], &TET_F));
    write(
        &d,
        "m/flat.ply",
        ply(
            &[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            &TET_F,
        ),
    );
    write(&d, "m/lying.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n");
    let full = ply(&TET, &TET_F);
    write(&d, "m/trunc.ply", &full[..full.len() - 20]);
    let mut garbage = b"ply\n".to_vec();
    garbage.extend((0..=255u8).cycle().take(1024));
    write(&d, "m/garbage.ply", &garbage);
    write(
        &d,
        "m/garbage2.ply",
        (0..=255u8).cycle().take(1024).collect::<Vec<u8>>(),
    );
    let mut binlie = b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    binlie.extend([0u8; 12]);
    write(&d, "m/binlie.ply", binlie);
    write(&d, "m/noface.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
    write(&d, "m/format.ply", full.replace("ascii 1.0", "ascii 2.0"));
    write(
        &d,
        "m/proptype.ply",
        full.replace("property float x", "property quaternion x"),
    );
    write(&d, "m/empty.obj", "");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    write(&d, "m/badf.obj", format!("{tri}f 1/x/y 2 3\n"));
    write(&d, "m/badvn.obj", format!("{tri}vn a b c\nf 1 2 3\n"));
    write(&d, "m/badvt.obj", format!("{tri}vt\nf 1 2 3\n"));
    write(&d, "m/shortv.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write(&d, "m/nanv.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    write(&d, "m/oob.obj", format!("{tri}f 1 2 9\n"));
    write(&d, "m/zero.obj", format!("{tri}f 0 1 2\n"));
    write(&d, "m/twoverts.obj", format!("{tri}f 1 2\n"));
    write(
        &d,
        "m/normal_oob.obj",
        format!("{tri}vn 0 0 1\nf 1//2 2//1 3//1\n"),
    );
    write(&d, "m/extra_slash.obj", format!("{tri}f 1/1/1/1 2 3\n"));
    write(
        &d,
        "m/huge.obj",
        "v 0 0 0\nv 1e60 0 0\nv 0 1e60 0\nf 1 2 3\n",
    );
    let mut bin = b"v 0 0 0\n".to_vec();
    bin.extend((0..=255u8).cycle().take(2048));
    write(&d, "m/bin.obj", bin);
    write(&d, "m/shape.stl", "solid x\nendsolid x\n");
    std::fs::create_dir_all(d.join("m/dir.obj")).unwrap();
    // EXR maps.
    exr_with(&d, "e/good.exr", (1.0, 1.0, 1.0));
    exr_with(&d, "e/bright.exr", (10.0, 1.0, 1.0));
    exr_with(&d, "e/nan.exr", (f32::NAN, 1.0, 1.0));
    exr_with(&d, "e/inf.exr", (1.0, f32::INFINITY, 1.0));
    exr_with(&d, "e/neg.exr", (1.0, 1.0, -1.0));
    let good = std::fs::read(d.join("e/good.exr")).unwrap();
    write(&d, "e/trunc.exr", &good[..good.len() / 2]);
    write(
        &d,
        "e/garbage.exr",
        (0..=255u8).cycle().take(768).collect::<Vec<u8>>(),
    );
    // A 700-byte file whose header claims 100000 × 100000 pixels.
    let mut lie = good.clone();
    let tag = b"dataWindow\0box2i\0";
    let at = lie
        .windows(tag.len())
        .position(|w| w == tag)
        .expect("dataWindow attribute")
        + tag.len()
        + 4;
    for (k, v) in [0i32, 0, 99_999, 99_999].iter().enumerate() {
        lie[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    lie.resize(700, 0);
    write(&d, "e/lie.exr", lie);
    // Scenes.
    write(&d, "s/ok.toml", SCENE);
    let sub = |a: &str, b: &str| {
        assert!(SCENE.contains(a), "{a}");
        SCENE.replacen(a, b, 1)
    };
    let scenes: Vec<(&str, String)> = vec![
        ("sun_huge", sub("sun = 20.0", "sun = 1e308")),
        ("sun_nan", sub("sun = 20.0", "sun = nan")),
        ("sun_inf", sub("sun = 20.0", "sun = inf")),
        ("sun_neg", sub("sun = 20.0", "sun = -1")),
        ("sundir0", sub("sun_dir = [0.3, 0.2, 1]", "sun_dir = [0, 0, 0]")),
        ("sundir2", sub("sun_dir = [0.3, 0.2, 1]", "sun_dir = [0, 1]")),
        ("sunrad0", sub("sun_radius_deg = 5", "sun_radius_deg = 0")),
        ("ambient_huge", sub("ambient = 0.3", "ambient = 1e300")),
        ("res_big", sub("resolution = [8, 8]", "resolution = [5000, 8]")),
        ("res_0", sub("resolution = [8, 8]", "resolution = [0, 8]")),
        ("res_neg", sub("resolution = [8, 8]", "resolution = [-8, 8]")),
        ("size_nan", sub("size = [4, 4]", "size = [nan, 4]")),
        ("size_huge", sub("size = [4, 4]", "size = [1e308, 1e308]")),
        ("recv_inf", sub("center = [0, 0, 0]", "center = [inf, 0, 0]")),
        ("occ_center_huge", sub("center = [0, 0, 1.5]", "center = [0, 0, 1e300]")),
        ("occ_radius_huge", sub("1.5]\nradius = 1.0", "1.5]\nradius = 1e300")),
        ("occ_radius_zero", sub("1.5]\nradius = 1.0", "1.5]\nradius = 0")),
        ("occ2_radius_nan", sub("radius = 0.5", "radius = nan")),
        ("occ_mesh_missing", sub("mesh = \"sphere\"", "mesh = \"nosuch.obj\"")),
        ("occ_mesh_bad", sub("mesh = \"sphere\"", "mesh = \"../m/nan.ply\"")),
        ("order0", sub("order = 2", "order = 0")),
        ("order_huge", sub("order = 2", "order = 1000000")),
        ("order_neg", sub("order = 2", "order = -1")),
        ("order_str", sub("order = 2", "order = \"two\"")),
        ("alpha90", sub("alpha_deg = 45", "alpha_deg = 90")),
        ("hres", sub("hemisphere_res = 4", "hemisphere_res = 100000")),
        ("truthres", sub("hemisphere_res = 4", "hemisphere_res = 4\ntruth_res = 0")),
        ("plaus", sub("hemisphere_res = 4", "hemisphere_res = 4\nplausibility = \"soft\"")),
        ("layout_fib", sub("layout = \"fib:20\"", "layout = \"fib:1000000000\"")),
        ("layout_cube", sub("layout = \"fib:20\"", "layout = \"cube:5000000000\"")),
        ("layout_bogus", sub("layout = \"fib:20\"", "layout = \"spiral:3\"")),
        ("kcount", sub("k_count = 8", "k_count = 1000000000")),
        ("srad", sub("sampling_radius = 1.0", "sampling_radius = 1e308")),
        ("unknown", format!("{SCENE}\nfoo = 1\n")),
        ("unknown_top", format!("colour = 1\n{SCENE}")),
        ("light_kind", sub("kind = \"sky\"", "kind = \"laser\"")),
        ("amount", sub("mesh = \"sphere\"", "mesh = \"bird\"\ndeformer = \"flap\"\namount = 1e9")),
        ("deformer_bad", sub("mesh = \"sphere\"", "mesh = \"bird\"\ndeformer = \"explode\"")),
        ("deform_sphere", sub("1.5]\nradius = 1.0", "1.5]\nradius = 1.0\ndeformer = \"bend\"")),
        ("up_bad", sub("1.5]\nradius = 1.0", "1.5]\nradius = 1.0\nup = \"w\"")),
        ("exr_missing", exr_scene("nosuch.exr", "")),
        ("exr_intensity_nan", exr_scene("../e/good.exr", "intensity = nan\n")),
        ("exr_intensity_huge", exr_scene("../e/good.exr", "intensity = 1e308\n")),
        ("exr_intensity_over", exr_scene("../e/bright.exr", "intensity = 1e12\n")),
        ("exr_trunc", exr_scene("../e/trunc.exr", "")),
        ("exr_lie", exr_scene("../e/lie.exr", "")),
        ("exr_nan", exr_scene("../e/nan.exr", "")),
        ("exr_inf", exr_scene("../e/inf.exr", "")),
        ("exr_neg", exr_scene("../e/neg.exr", "")),
        ("exr_garbage", exr_scene("../e/garbage.exr", "")),
        ("exr_nopath", exr_scene("x", "").replace("path = \"x\"\n", "")),
        ("ls_nan", format!("{SCENE}\n[[light_source]]\nkind = \"quad\"\ncenter = [0, 0, 3]\nsize = 1.0\nintensity = nan\n")),
        ("ls_huge", format!("{SCENE}\n[[light_source]]\nkind = \"quad\"\ncenter = [0, 0, 3]\nsize = 1.0\nintensity = 1e308\n")),
        ("ls_product", format!("{SCENE}\n[[light_source]]\nkind = \"quad\"\ncenter = [0, 0, 3]\nsize = 1.0\nintensity = 1e7\nradiance = [1e6, 1, 1]\n")),
        ("ls_hinge", format!("{SCENE}\n[[light_source]]\nkind = \"hinge\"\ncenter = [0, 0, 3]\nsize = 1.0\nhinge_deg = 400\n")),
        ("ls_kind", format!("{SCENE}\n[[light_source]]\nkind = \"spot\"\ncenter = [0, 0, 3]\n")),
        ("ls_eta", format!("{SCENE}\n[[light_source]]\nkind = \"quad\"\ncenter = [0, 0, 3]\neta = \"both\"\n")),
        ("many_occluders", format!("{}{}", SCENE, "\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 3]\nradius = 0.1\n".repeat(64))),
    ];
    for (name, text) in scenes {
        write(&d, &format!("s/{name}.toml"), text);
    }
    write(&d, "s/binary.toml", (0..=255u8).collect::<Vec<u8>>());
    write(&d, "s/notutf8.toml", b"order = 2\n\xff\xfe\n");
    write(
        &d,
        "s/ff_large.toml",
        SCENE
            .replacen("resolution = [8, 8]", "resolution = [4096, 4096]", 1)
            .replacen("hemisphere_res = 4", "hemisphere_res = 256", 1),
    );
    // Experiment configs.
    write(&d, "c/ok.toml", CONFIG);
    let csub = |a: &str, b: &str| {
        assert!(CONFIG.contains(a), "{a}");
        CONFIG.replacen(a, b, 1)
    };
    let configs: Vec<(&str, String)> = vec![
        ("unknown", format!("{CONFIG}colour = 1\n").replace("[sweep]\nalpha_deg = [30, 60]\ncolour = 1\n", "colour = 1\n[sweep]\nalpha_deg = [30, 60]\n")),
        ("type", csub("order = 2", "order = \"two\"")),
        ("order0", csub("order = 2", "order = 0")),
        ("dup", csub("alpha_deg = [30, 60]", "alpha_deg = [30, 60, 30]")),
        ("empty", csub("alpha_deg = [30, 60]", "alpha_deg = []")),
        ("zip", format!("{CONFIG}[sweep.zip]\norder = [2, 3]\nhemisphere_res = [2]\n")),
        ("blocks_dup", CONFIG.replace("[sweep]\nalpha_deg = [30, 60]\n", "[[sweep]]\nalpha_deg = [30]\n[[sweep]]\nalpha_deg = [30]\n")),
        ("kind", csub("experiment = \"probe\"", "experiment = \"histogram\"")),
        ("noexp", csub("experiment = \"probe\"\n", "")),
        ("name", format!("name = \"../x\"\n{CONFIG}")),
        ("layout", csub("layout = \"fib:10\"", "layout = \"fib:1000000000\"")),
        ("radii", csub("radii = [2.0]", "radii = [2.0, 2.0]")),
        ("radii_neg", csub("radii = [2.0]", "radii = [-1]")),
        ("large", csub("layout = \"fib:10\"\nhemisphere_res = 2", "layout = \"fib:1000000\"\nhemisphere_res = 256")),
        ("repeats", format!("timing_repeats = 0\n{CONFIG}")),
        ("warmup", format!("timing_warmup = 1000\n{CONFIG}")),
        ("gpu", format!("gpu = \"maybe\"\n{CONFIG}")),
        ("parallel", format!("parallel_runs = \"yes\"\n{CONFIG}").replace("parallel_runs = false\n", "")),
        ("kcount", csub("k_count = 4", "k_count = 1000000000")),
        ("eps", csub("k_count = 4", "k_count = 4\non_surface_eps = 2")),
        ("spacing", csub("k_count = 4", "k_count = 4\nk_spacing = \"random\"")),
        ("truth_res", csub("k_count = 4", "k_count = 4\ntruth_res = 0")),
        ("truth_res_big", csub("k_count = 4", "k_count = 4\ntruth_res = 100000")),
        ("probe_dirs", csub("k_count = 4", "k_count = 4\nprobe_dirs = \"grid\"")),
        ("plausibility", csub("k_count = 4", "k_count = 4\nplausibility = \"maybe\"")),
        ("alpha_mode", csub("k_count = 4", "k_count = 4\nalpha_mode = \"auto\"")),
        ("contact", csub("k_count = 4", "k_count = 4\ncontact_occlusion = 1.5")),
        ("k_range", csub("k_count = 4", "k_count = 4\nk_min = 3.0\nk_max = 2.0")),
        ("k_min", csub("k_count = 4", "k_count = 4\nk_min = -1.0")),
        ("alpha_step", "experiment = \"alpha_fit\"\nalpha_step_deg = 0\n".into()),
        ("alpha_fit_truth", "experiment = \"alpha_fit\"\ntruth_res = 0\n".into()),
        ("mesh", csub("mesh = \"sphere\"", "mesh = \"nosuch\"")),
        ("tau", "experiment = \"extremes\"\ntau = \"cube\"\n".into()),
        ("element", "experiment = \"m_elements\"\nrow = 99\n".into()),
        ("timing_scene", "experiment = \"timing\"\nscene = \"moon\"\n".into()),
        ("too_many", format!("{CONFIG}k_count = [4, 5, 6, 7, 8, 9, 10, 11, 12, 13]\non_surface_eps = [0.001, 0.002, 0.003, 0.004, 0.005, 0.006, 0.007, 0.008, 0.009, 0.01]\nsampling_radius = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\nhemisphere_res = [2, 3, 4, 5, 6, 7, 8, 9, 10, 11]\norder = [2, 3, 4, 5, 6, 7, 8, 9, 10, 11]\n")),
        ("sweep_scalar", format!("{CONFIG}radii = 3\n")),
        ("toml", "experiment = \"probe\"\norder = = 2\n".into()),
    ];
    for (name, text) in configs {
        write(&d, &format!("c/{name}.toml"), text);
    }
    write(&d, "c/binary.toml", (0..=255u8).collect::<Vec<u8>>());
    // Results: a real run, then copies with damage.
    let o = common::shscale(&[
        "run",
        d.join("c/ok.toml").to_str().unwrap(),
        "--out-dir",
        d.join("r").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let good_dir = d.join("r/probe/ok");
    let csv = std::fs::read_to_string(good_dir.join("runs.csv")).unwrap();
    let manifest = std::fs::read_to_string(good_dir.join("manifest.toml")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    let damaged = |name: &str, csv: String, manifest: &str| {
        write(&d, &format!("r/{name}/runs.csv"), csv);
        write(&d, &format!("r/{name}/manifest.toml"), manifest);
    };
    damaged(
        "truncated",
        format!("{}\n{}\n", lines[0], &lines[1][..lines[1].len() / 2]),
        &manifest,
    );
    damaged(
        "extra",
        format!("{}\n{},extra\n", lines[0], lines[1]),
        &manifest,
    );
    damaged("foreign", "a,b,c\n1,2,3\n".to_string(), &manifest);
    damaged(
        "badid",
        format!(
            "{}\n{}\n",
            lines[0],
            lines[1].replacen(&lines[1][..4], "ffff", 1)
        ),
        &manifest,
    );
    damaged("bad_manifest", csv.clone(), "this is [not a manifest");
    damaged(
        "other_kind",
        csv.clone(),
        &manifest.replace("experiment = \"probe\"", "experiment = \"midrange\""),
    );
    // A config whose results directory holds another version's columns (refused on run).
    write(
        &d,
        "r2/probe/ok/runs.csv",
        "run_id,experiment,old_column\nx,probe,1\n",
    );
    // Outputs that must survive a failing command.
    write(
        &d,
        "o/keep.exr",
        b"not really an exr, but it must stay as it is",
    );
    std::fs::create_dir_all(d.join("o/keep.png")).unwrap();
    std::fs::create_dir_all(d.join("o/adir.exr")).unwrap();
    write(&d, "o/bench.csv", "existing,bench,rows\n");
    // Ray files in the peers' format: 25 bytes (not whole rays), one ray with a zero
    // direction, two good rays (48 bytes) with a hits file of the wrong length.
    write(&d, "rays/odd.rays.f32", [0u8; 25]);
    let ray = |o: [f32; 3], dir: [f32; 3]| -> Vec<u8> {
        o.iter().chain(&dir).flat_map(|v| v.to_le_bytes()).collect()
    };
    write(
        &d,
        "rays/zero.rays.f32",
        ray([5.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
    );
    let mut two = Vec::new();
    for v in [
        5.0f32, 0.0, 0.0, 0.0, 5.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0,
    ] {
        two.extend(v.to_le_bytes());
    }
    write(&d, "rays/two.rays.f32", two);
    write(&d, "rays/two.hits.bits", [0u8, 0u8]);
    d
}

/// The cases: the command line (`{D}` is the fixture folder, which is also the working
/// directory) and what the one stderr line must name.
const CASES: &[(&str, &str)] = &[
    // CLI values.
    ("sh eval --order -1 --dir 0,0,1", "--order"),
    ("sh eval --order 0 --dir 0,0,1", "order"),
    ("sh eval --order 100000 --dir 0,0,1", "order"),
    ("sh eval --order 4 --dir nan,0,1", "--dir"),
    ("sh eval --order 4 --dir 0,0,0", "--dir"),
    ("sh eval --order 4 --dir 1,2", "--dir"),
    ("sh eval --order 4", "--dir"),
    ("sh eval --order four --dir 0,0,1", "--order"),
    ("sh cap --order 4 --angle-deg nan", "angle"),
    ("sh cap --order 4 --angle-deg -5", "angle"),
    (
        "sh rotate --order 2 --coeffs 1,0,1 --euler-zyz-deg 0,90,0",
        "coeffs",
    ),
    (
        "sh rotate --order 2 --coeffs 1,0,1,nan --euler-zyz-deg 0,90,0",
        "coeffs",
    ),
    (
        "sh rotate --order 2 --coeffs 1,0,1,0 --euler-zyz-deg 0,inf,0",
        "euler",
    ),
    ("sh frobnicate", "frobnicate"),
    ("matrix --order 4 --tau cone --alpha-deg 45 --k -1", "k"),
    ("matrix --order 4 --tau cone --alpha-deg 45 --k nan", "k"),
    (
        "matrix --order 4 --tau cone --alpha-deg 90 --k 2",
        "--alpha-deg",
    ),
    ("matrix --order 4 --tau cone --k 2", "--alpha-deg"),
    ("matrix --order 4 --tau midrange --k 1", "k"),
    (
        "matrix --order 40 --tau cone --alpha-deg 45 --k 2",
        "--order",
    ),
    ("matrix --order 4 --tau laser --k 2", "--tau"),
    (
        "matrix --order 4 --tau cone --alpha-deg 45 --table 100000000 --k-range 0.1,10",
        "--table",
    ),
    (
        "matrix --order 4 --tau cone --alpha-deg 45 --table 1 --k-range 0.1,10",
        "--table",
    ),
    (
        "matrix --order 4 --tau cone --alpha-deg 45 --table 40 --k-range 10,0.1",
        "range",
    ),
    (
        "matrix --order 4 --tau cone --alpha-deg 45 --table 40 --k-range 0.1",
        "--k-range",
    ),
    (
        "matrix --order 4 --tau cone --alpha-deg 45 --table 40",
        "--k-range",
    ),
    (
        "matrix --order 4 --tau cone --alpha-deg 45 --table 40 --k 2",
        "--k",
    ),
    ("inspect nosuch", "nosuch"),
    ("inspect {D}/m/dir.obj", "dir.obj"),
    (
        "visibility --mesh sphere --point 0,0,2 --order 4 --hemisphere-res 100000",
        "--hemisphere-res",
    ),
    (
        "visibility --mesh sphere --point nan,0,2 --order 4",
        "--point",
    ),
    (
        "visibility --mesh sphere --point 1e308,0,2 --order 4",
        "--point",
    ),
    (
        "visibility --mesh sphere --point 0,0,2 --order 4 --frame bogus",
        "--frame",
    ),
    ("visibility --mesh sphere --point 0,0 --order 4", "--point"),
    (
        "visibility --mesh sphere --point 0,0,0 --order 4 --frame local",
        "--point",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --sampling-radius 1e308",
        "--sampling-radius",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --radii -1",
        "--radii",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --radii 1e308",
        "--radii",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --radii nan",
        "--radii",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --radii 1,1",
        "--radii",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --radii 1,x",
        "radii",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --layout fib:1000000000",
        "--layout",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --layout cube:100000",
        "--layout",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --layout cube:5000000000",
        "--layout",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --layout latlong:0x5",
        "--layout",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --layout bogus",
        "--layout",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --k-count 1000000000",
        "--k-count",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --k-count 1",
        "--k-count",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --on-surface-eps -1",
        "--on-surface-eps",
    ),
    (
        "probe --mesh bird --order 4 --alpha-deg 45 --hemisphere-res 0",
        "--hemisphere-res",
    ),
    ("probe --mesh bird --order 4 --alpha-deg 0", "--alpha-deg"),
    ("probe --mesh bird --order -1 --alpha-deg 45", "--order"),
    ("probe --mesh bird --order 17 --alpha-deg 45", "--order"),
    ("probe --mesh bunny", "--order"),
    ("probe --mesh bunny --ordr 4 --alpha-deg 45", "--order"),
    ("probe --mesh moon --order 4 --alpha-deg 45", "moon"),
    (
        "probe --mesh bunny --order 4 --alpha-deg 45 --layout fib:1000000 --hemisphere-res 256",
        "--allow-large",
    ),
    ("bench --warmup 1000000000", "--warmup"),
    ("bench --frames 0", "--frames"),
    ("bench --frames -1", "--frames"),
    ("bench --scene moon", "moon"),
    ("bench --require-gpu", "--gpu"),
    ("bench --frames 10000 --warmup 10000", "--allow-large"),
    (
        "bench --frames 1 --warmup 0 --csv {D}/o/keep.png",
        "keep.png",
    ),
    // Kernel benchmarks.
    ("bench rays --threads 0", "--threads"),
    ("bench rays --threads 100000", "--threads"),
    ("bench rays --min-time 0", "--min-time"),
    ("bench rays --min-time nan", "--min-time"),
    ("bench rays --min-time 1e9", "--min-time"),
    ("bench rays --warmup 101", "--warmup"),
    ("bench rays --workload random --count 0", "--count"),
    ("bench rays --workload random --count 1000000000", "--count"),
    ("bench rays --workload moon", "moon"),
    ("bench rays --mesh sphere", "--mesh"),
    ("bench rays --mesh moon", "moon"),
    ("bench rays --rays {D}/nosuch.rays.f32", "nosuch.rays.f32"),
    ("bench rays --rays {D}/rays/odd.rays.f32", "odd.rays.f32"),
    ("bench rays --rays {D}/rays/zero.rays.f32", "ray 0"),
    (
        "bench rays --rays {D}/rays/two.rays.f32 --hits {D}/rays/two.hits.bits",
        "two.hits.bits",
    ),
    ("bench rays --hits {D}/rays/two.hits.bits", "--rays"),
    (
        "bench rays --rays {D}/rays/two.rays.f32 --workload random",
        "--workload",
    ),
    ("bench bsv --layout latlong:0x4", "--layout"),
    ("bench bsv --hemisphere-res 0", "--hemisphere-res"),
    ("bench bsv --order 0", "--order"),
    ("bench bsv --order 17", "--order"),
    (
        "bench bsv --layout fib:1000000 --hemisphere-res 1024",
        "--allow-large",
    ),
    ("bench sh --order 0", "--order"),
    ("bench sh --precision f16", "f16"),
    ("bench sh --points 0", "--points"),
    ("bench sh --order 64 --points 100000000", "--allow-large"),
    ("frobnicate", "frobnicate"),
    // Runs, merges, Slurm, figures.
    ("run", "config"),
    ("run {D}/nosuch.toml", "nosuch"),
    ("run {D}/c/ok.toml --shard -1/4 --out-dir {D}/x", "--shard"),
    ("run {D}/c/ok.toml --shard 4/4 --out-dir {D}/x", "--shard"),
    ("run {D}/c/ok.toml --shard a/b --out-dir {D}/x", "--shard"),
    (
        "run {D}/c/ok.toml --set order=0 --out-dir {D}/x",
        "--set order=0",
    ),
    ("run {D}/c/ok.toml --set order --out-dir {D}/x", "--set"),
    (
        "run {D}/c/ok.toml --set colour=red --out-dir {D}/x",
        "colour",
    ),
    (
        "run {D}/c/ok.toml --sweep alpha_deg=30,30 --out-dir {D}/x",
        "--sweep",
    ),
    (
        "run {D}/c/ok.toml --sweep alpha_deg --out-dir {D}/x",
        "--sweep",
    ),
    ("run {D}/c/ok.toml --name ../x --out-dir {D}/x", "name"),
    ("run {D}/c/ok.toml --name a/b --out-dir {D}/x", "name"),
    ("run {D}/c/ok.toml --out-dir {D}/r2", "runs.csv"),
    ("merge {D}/nonexistent", "nonexistent"),
    ("merge {D}/r/truncated", "runs.csv:2"),
    ("merge {D}/r/extra", "runs.csv:2"),
    ("merge {D}/r/foreign", "runs.csv"),
    ("merge {D}/r/badid", "runs.csv:2"),
    ("merge {D}/r/bad_manifest", "manifest"),
    ("merge {D}/r/probe/ok {D}/r/other_kind", "midrange"),
    ("merge {D}/r/probe/ok --out {D}/r/probe/ok", "runs.csv"),
    ("slurm {D}/c/ok.toml --tasks 0", "--tasks"),
    ("slurm {D}/c/ok.toml --tasks 100000000", "--tasks"),
    ("slurm {D}/c/order0.toml --tasks 2", "order"),
    ("figs --configs {D}/nothing --out {D}/x", "nothing"),
    ("figs --configs {D}/c --out {D}/x --gpu off", "c/"),
    // Experiment configs.
    ("run {D}/c/unknown.toml --out-dir {D}/x", "colour"),
    ("run {D}/c/type.toml --out-dir {D}/x", "order"),
    ("run {D}/c/order0.toml --out-dir {D}/x", "order"),
    ("run {D}/c/dup.toml --out-dir {D}/x", "dup.toml:10"),
    ("run {D}/c/empty.toml --out-dir {D}/x", "sweep.alpha_deg"),
    ("run {D}/c/zip.toml --out-dir {D}/x", "zip"),
    ("run {D}/c/blocks_dup.toml --out-dir {D}/x", "same run"),
    ("run {D}/c/kind.toml --out-dir {D}/x", "histogram"),
    ("run {D}/c/noexp.toml --out-dir {D}/x", "experiment"),
    ("run {D}/c/name.toml --out-dir {D}/x", "name"),
    ("run {D}/c/layout.toml --out-dir {D}/x", "layout"),
    ("run {D}/c/radii.toml --out-dir {D}/x", "radii"),
    ("run {D}/c/radii_neg.toml --out-dir {D}/x", "radii"),
    ("run {D}/c/large.toml --out-dir {D}/x", "--allow-large"),
    ("run {D}/c/repeats.toml --out-dir {D}/x", "timing_repeats"),
    ("run {D}/c/warmup.toml --out-dir {D}/x", "timing_warmup"),
    ("run {D}/c/gpu.toml --out-dir {D}/x", "gpu"),
    ("run {D}/c/parallel.toml --out-dir {D}/x", "parallel_runs"),
    ("run {D}/c/kcount.toml --out-dir {D}/x", "k_count"),
    ("run {D}/c/eps.toml --out-dir {D}/x", "on_surface_eps"),
    ("run {D}/c/spacing.toml --out-dir {D}/x", "k_spacing"),
    ("run {D}/c/truth_res.toml --out-dir {D}/x", "truth_res"),
    ("run {D}/c/truth_res_big.toml --out-dir {D}/x", "truth_res"),
    ("run {D}/c/probe_dirs.toml --out-dir {D}/x", "probe_dirs"),
    (
        "run {D}/c/plausibility.toml --out-dir {D}/x",
        "plausibility",
    ),
    ("run {D}/c/alpha_mode.toml --out-dir {D}/x", "alpha_mode"),
    (
        "run {D}/c/contact.toml --out-dir {D}/x",
        "contact_occlusion",
    ),
    ("run {D}/c/k_range.toml --out-dir {D}/x", "k_max"),
    ("run {D}/c/k_min.toml --out-dir {D}/x", "k_min"),
    (
        "run {D}/c/alpha_step.toml --out-dir {D}/x",
        "alpha_step_deg",
    ),
    (
        "run {D}/c/alpha_fit_truth.toml --out-dir {D}/x",
        "truth_res",
    ),
    (
        "visibility --mesh sphere --point 0,0,2 --order 4 --truth-res 0",
        "--truth-res",
    ),
    (
        "visibility --mesh sphere --point 0,0,2 --order 4 --truth-res 5000",
        "--truth-res",
    ),
    (
        "visibility --mesh sphere --point 0,0,2 --order 4 --quadrature magic",
        "--quadrature",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --probe-dirs grid",
        "--probe-dirs",
    ),
    (
        "probe --mesh sphere --order 4 --alpha-deg 45 --truth-res 0",
        "--truth-res",
    ),
    ("run {D}/c/mesh.toml --out-dir {D}/x", "mesh"),
    ("run {D}/c/tau.toml --out-dir {D}/x", "tau"),
    ("run {D}/c/element.toml --out-dir {D}/x", "row"),
    ("run {D}/c/timing_scene.toml --out-dir {D}/x", "moon"),
    ("run {D}/c/too_many.toml --out-dir {D}/x", "limit"),
    ("run {D}/c/sweep_scalar.toml --out-dir {D}/x", "radii"),
    ("run {D}/c/toml.toml --out-dir {D}/x", "toml.toml:2"),
    ("run {D}/c/binary.toml --out-dir {D}/x", "binary.toml"),
    // Meshes.
    ("inspect {D}/m/e300.ply", "vertex"),
    ("inspect {D}/m/e60.ply", "1e50"),
    ("inspect {D}/m/tiny.ply", "1e-50"),
    ("inspect {D}/m/nan.ply", "vertex 0"),
    ("inspect {D}/m/inf.ply", "vertex 0"),
    ("inspect {D}/m/badidx.ply", "face 0"),
    ("inspect {D}/m/negidx.ply", "face 0"),
    ("inspect {D}/m/degenerate.ply", "below 1e-50"),
    ("inspect {D}/m/flat.ply", "face 0"),
    ("inspect {D}/m/lying.ply", "lying.ply"),
    ("inspect {D}/m/trunc.ply", "trunc.ply"),
    ("inspect {D}/m/garbage.ply", "garbage.ply"),
    ("inspect {D}/m/garbage2.ply", "garbage2.ply"),
    ("inspect {D}/m/binlie.ply", "binlie.ply"),
    ("inspect {D}/m/noface.ply", "noface.ply"),
    ("inspect {D}/m/format.ply", "format.ply"),
    ("inspect {D}/m/proptype.ply", "proptype.ply"),
    ("inspect {D}/m/empty.obj", "empty.obj"),
    ("inspect {D}/m/badf.obj", "badf.obj:4"),
    ("inspect {D}/m/badvn.obj", "badvn.obj:4"),
    ("inspect {D}/m/badvt.obj", "badvt.obj:4"),
    ("inspect {D}/m/shortv.obj", "shortv.obj:1"),
    ("inspect {D}/m/nanv.obj", "nanv.obj:2"),
    ("inspect {D}/m/oob.obj", "oob.obj:4"),
    ("inspect {D}/m/zero.obj", "zero.obj:4"),
    ("inspect {D}/m/twoverts.obj", "twoverts.obj:4"),
    ("inspect {D}/m/normal_oob.obj", "normal_oob.obj:5"),
    ("inspect {D}/m/extra_slash.obj", "extra_slash.obj:4"),
    ("inspect {D}/m/huge.obj", "1e50"),
    ("inspect {D}/m/bin.obj", "bin.obj:3"),
    ("inspect {D}/m/shape.stl", "shape.stl"),
    (
        "probe --mesh {D}/m/e60.ply --order 2 --alpha-deg 45",
        "1e50",
    ),
    (
        "visibility --mesh {D}/m/garbage.ply --point 0,0,3 --order 2",
        "garbage.ply",
    ),
    // Scenes (rendered; a failing render leaves every output as it was).
    ("render --scene {D}/s/ok.toml --out {D}/o/x.txt", "--out"),
    (
        "render --scene {D}/s/ok.toml --out {D}/nodir/x.exr",
        "nodir",
    ),
    (
        "render --scene {D}/s/ok.toml --out {D}/o/adir.exr",
        "adir.exr",
    ),
    (
        "render --scene {D}/s/ok.toml --out {D}/o/keep.exr",
        "keep.png",
    ),
    (
        "render --scene {D}/s/ok.toml --out /proc/self/shscale.exr",
        "shscale.exr",
    ),
    (
        "render --scene {D}/s/ok.toml --out {D}/o/y.exr --frames 0",
        "--frames",
    ),
    (
        "render --scene {D}/s/ok.toml --out {D}/o/y.exr --frames 1000000000",
        "--frames",
    ),
    // Every method renders sequences on the CPU; the GPU sequence is the papers' method only.
    (
        "render --scene {D}/s/ok.toml --out {D}/o/y.exr --frames 2 --method raytraced --gpu",
        "--gpu",
    ),
    (
        "render --scene {D}/s/ok.toml --out {D}/o/y.exr --gpu",
        "--frames",
    ),
    (
        "render --scene {D}/s/ff_large.toml --out {D}/o/y.exr --method raytraced-full",
        "--allow-large",
    ),
    (
        "render --scene {D}/s/nosuch.toml --out {D}/o/y.exr",
        "nosuch.toml",
    ),
    (
        "render --scene {D}/s/sun_huge.toml --out {D}/o/y.exr",
        "light.sun",
    ),
    (
        "render --scene {D}/s/sun_nan.toml --out {D}/o/y.exr",
        "light.sun",
    ),
    (
        "render --scene {D}/s/sun_inf.toml --out {D}/o/y.exr",
        "light.sun",
    ),
    (
        "render --scene {D}/s/sun_neg.toml --out {D}/o/y.exr",
        "light.sun",
    ),
    (
        "render --scene {D}/s/sundir0.toml --out {D}/o/y.exr",
        "sun_dir",
    ),
    (
        "render --scene {D}/s/sundir2.toml --out {D}/o/y.exr",
        "sun_dir",
    ),
    (
        "render --scene {D}/s/sunrad0.toml --out {D}/o/y.exr",
        "sun_radius_deg",
    ),
    (
        "render --scene {D}/s/ambient_huge.toml --out {D}/o/y.exr",
        "light.ambient",
    ),
    (
        "render --scene {D}/s/res_big.toml --out {D}/o/y.exr",
        "resolution",
    ),
    (
        "render --scene {D}/s/res_0.toml --out {D}/o/y.exr",
        "resolution",
    ),
    (
        "render --scene {D}/s/res_neg.toml --out {D}/o/y.exr",
        "resolution",
    ),
    (
        "render --scene {D}/s/size_nan.toml --out {D}/o/y.exr",
        "receiver.size[0]",
    ),
    (
        "render --scene {D}/s/size_huge.toml --out {D}/o/y.exr",
        "receiver.size[0]",
    ),
    (
        "render --scene {D}/s/recv_inf.toml --out {D}/o/y.exr",
        "receiver.center",
    ),
    (
        "render --scene {D}/s/occ_center_huge.toml --out {D}/o/y.exr",
        "occluder[0].center",
    ),
    (
        "render --scene {D}/s/occ_radius_huge.toml --out {D}/o/y.exr",
        "occluder[0].radius",
    ),
    (
        "render --scene {D}/s/occ_radius_zero.toml --out {D}/o/y.exr",
        "occluder[0].radius",
    ),
    (
        "render --scene {D}/s/occ2_radius_nan.toml --out {D}/o/y.exr",
        "occ2_radius_nan.toml:16: occluder[1].radius",
    ),
    (
        "render --scene {D}/s/occ_mesh_missing.toml --out {D}/o/y.exr",
        "nosuch.obj",
    ),
    (
        "render --scene {D}/s/occ_mesh_bad.toml --out {D}/o/y.exr",
        "nan.ply",
    ),
    (
        "render --scene {D}/s/order0.toml --out {D}/o/y.exr",
        "order",
    ),
    (
        "render --scene {D}/s/order_huge.toml --out {D}/o/y.exr",
        "order",
    ),
    (
        "render --scene {D}/s/order_neg.toml --out {D}/o/y.exr",
        "order",
    ),
    (
        "render --scene {D}/s/order_str.toml --out {D}/o/y.exr",
        "order",
    ),
    (
        "render --scene {D}/s/alpha90.toml --out {D}/o/y.exr",
        "alpha_deg",
    ),
    (
        "render --scene {D}/s/hres.toml --out {D}/o/y.exr",
        "hemisphere_res",
    ),
    (
        "render --scene {D}/s/truthres.toml --out {D}/o/y.exr",
        "truth_res",
    ),
    (
        "render --scene {D}/s/plaus.toml --out {D}/o/y.exr",
        "plausibility",
    ),
    (
        "render --scene {D}/s/layout_fib.toml --out {D}/o/y.exr",
        "layout",
    ),
    (
        "render --scene {D}/s/layout_cube.toml --out {D}/o/y.exr",
        "layout",
    ),
    (
        "render --scene {D}/s/layout_bogus.toml --out {D}/o/y.exr",
        "layout",
    ),
    (
        "render --scene {D}/s/kcount.toml --out {D}/o/y.exr",
        "k_count",
    ),
    (
        "render --scene {D}/s/srad.toml --out {D}/o/y.exr",
        "sampling_radius",
    ),
    ("render --scene {D}/s/unknown.toml --out {D}/o/y.exr", "foo"),
    (
        "render --scene {D}/s/unknown_top.toml --out {D}/o/y.exr",
        "colour",
    ),
    (
        "render --scene {D}/s/light_kind.toml --out {D}/o/y.exr",
        "light.kind",
    ),
    (
        "render --scene {D}/s/amount.toml --out {D}/o/y.exr",
        "occluder[0].amount",
    ),
    (
        "render --scene {D}/s/deformer_bad.toml --out {D}/o/y.exr",
        "occluder[0].deformer",
    ),
    (
        "render --scene {D}/s/deform_sphere.toml --out {D}/o/y.exr",
        "occluder[0].deformer",
    ),
    (
        "render --scene {D}/s/up_bad.toml --out {D}/o/y.exr",
        "occluder[0].up",
    ),
    (
        "render --scene {D}/s/exr_missing.toml --out {D}/o/y.exr",
        "nosuch.exr",
    ),
    (
        "render --scene {D}/s/exr_intensity_nan.toml --out {D}/o/y.exr",
        "light.intensity",
    ),
    (
        "render --scene {D}/s/exr_intensity_huge.toml --out {D}/o/y.exr",
        "light.intensity",
    ),
    (
        "render --scene {D}/s/exr_intensity_over.toml --out {D}/o/y.exr",
        "light.intensity",
    ),
    (
        "render --scene {D}/s/exr_trunc.toml --out {D}/o/y.exr",
        "trunc.exr",
    ),
    (
        "render --scene {D}/s/exr_lie.toml --out {D}/o/y.exr",
        "100000×100000",
    ),
    (
        "render --scene {D}/s/exr_nan.toml --out {D}/o/y.exr",
        "pixel (2, 1)",
    ),
    (
        "render --scene {D}/s/exr_inf.toml --out {D}/o/y.exr",
        "pixel (2, 1)",
    ),
    (
        "render --scene {D}/s/exr_neg.toml --out {D}/o/y.exr",
        "pixel (2, 1)",
    ),
    (
        "render --scene {D}/s/exr_garbage.toml --out {D}/o/y.exr",
        "garbage.exr",
    ),
    (
        "render --scene {D}/s/exr_nopath.toml --out {D}/o/y.exr",
        "light.path",
    ),
    (
        "render --scene {D}/s/ls_nan.toml --out {D}/o/y.exr",
        "light_source[0].intensity",
    ),
    (
        "render --scene {D}/s/ls_huge.toml --out {D}/o/y.exr",
        "light_source[0].intensity",
    ),
    (
        "render --scene {D}/s/ls_product.toml --out {D}/o/y.exr",
        "light_source[0].intensity",
    ),
    (
        "render --scene {D}/s/ls_hinge.toml --out {D}/o/y.exr",
        "light_source[0].hinge_deg",
    ),
    (
        "render --scene {D}/s/ls_kind.toml --out {D}/o/y.exr",
        "light_source[0].kind",
    ),
    (
        "render --scene {D}/s/ls_eta.toml --out {D}/o/y.exr",
        "light_source[0].eta",
    ),
    (
        "render --scene {D}/s/many_occluders.toml --out {D}/o/y.exr",
        "occluder",
    ),
    (
        "render --scene {D}/s/binary.toml --out {D}/o/y.exr",
        "binary.toml",
    ),
    (
        "render --scene {D}/s/notutf8.toml --out {D}/o/y.exr",
        "notutf8.toml",
    ),
];

#[test]
fn hostile_inputs_are_refused_cleanly() {
    let d = fixture();
    let dir = d.to_str().unwrap().to_string();
    let cases: Vec<(String, Vec<String>, &str)> = (CASES.iter())
        .map(|(line, needle)| {
            let args = (line.split_whitespace())
                .map(|a| a.replace("{D}", &dir))
                .collect();
            (line.to_string(), args, *needle)
        })
        .collect();
    common::refusal::check_all(&d, &cases, 120);
    std::fs::remove_dir_all(&d).ok();
}

/// The other side of the bounds: values that are extreme but valid work, and give the same
/// answers as their ordinary counterparts — a mesh scaled by 1e20 or 1e-20 probes exactly like
/// the unit mesh, a point 1e11 radii away sees an unoccluded sphere, a radiance map that rings
/// slightly below 0 renders.
#[test]
fn extreme_but_valid_inputs_work() {
    let d = std::env::temp_dir().join(format!("shscale-extreme-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let probe = |scale: f64| -> Vec<f64> {
        let name = format!("tet{scale:e}.ply");
        write(&d, &name, ply(&scaled(scale), &TET_F));
        let v = common::json(&[
            "probe",
            "--mesh",
            d.join(&name).to_str().unwrap(),
            "--order",
            "4",
            "--alpha-deg",
            "45",
            "--layout",
            "fib:60",
            "--hemisphere-res",
            "8",
        ]);
        v["rows"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["occ_rel_l2_mean"].as_f64().unwrap_or(f64::NAN))
            .collect()
    };
    let unit = probe(1.0);
    for s in [1e20, 1e-20] {
        let other = probe(s);
        let worst = unit
            .iter()
            .zip(&other)
            .map(|(a, b)| (a - b).abs() / a.abs().max(1e-300))
            .fold(0.0, f64::max);
        println!("scale {s:e}: occ_rel_l2 per radius {other:?}, worst relative difference to scale 1: {worst:.1e}");
        assert!(worst < 1e-9, "scale {s:e}: {unit:?} vs {other:?}");
    }
    let far = common::json(&[
        "visibility",
        "--mesh",
        "sphere",
        "--point",
        "1e11,0,0",
        "--order",
        "2",
    ]);
    let dc = far["values"][0].as_f64().unwrap();
    assert!(
        (dc - 2.0 * std::f64::consts::PI.sqrt()).abs() < 1e-9,
        "unoccluded DC {dc}"
    );
    // A map with ringing of −5e-4 × its maximum renders (clamped), and its image is finite.
    std::fs::create_dir_all(d.join("e")).unwrap();
    exr::prelude::write_rgb_file(d.join("e/ring.exr"), 8, 4, |x, _| {
        if x == 3 {
            (-0.005, 1.0, 1.0)
        } else {
            (10.0, 10.0, 10.0)
        }
    })
    .unwrap();
    write(&d, "s/ring.toml", exr_scene("../e/ring.exr", ""));
    let out = d.join("ring.exr");
    let o = common::shscale(&[
        "render",
        "--scene",
        d.join("s/ring.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, _, px) = shscale_present::image::read_exr(&out).unwrap();
    assert!(px.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    std::fs::remove_dir_all(&d).ok();
}

mod vectors {
    //! Property test over command lines: cheap commands with every flag's value drawn from a
    //! set of hostile numbers and strings (NaN, ±inf, 1e308, negative, huge integers, empty,
    //! wrong arity). Every run must end with status 0 or 2 and never panic; a status-2 run
    //! prints one stderr line. Bounded: 96 cases (a second or two).
    use proptest::prelude::*;

    fn value() -> impl Strategy<Value = String> {
        prop::sample::select(vec![
            "nan",
            "inf",
            "-inf",
            "-1",
            "0",
            "1",
            "2",
            "4",
            "17",
            "33",
            "1e308",
            "-1e308",
            "1e-308",
            "18446744073709551616",
            "99999999999",
            "",
            "x",
            "0,0,1",
            "1,2",
            "nan,0,1",
            "0,0,0",
            "1e308,1e308,1e308",
            "1,0,1,0",
            "0,90,0",
            "0.5,2",
            "2,0.5",
            "-0",
            "cone",
            "midrange",
            "0.999999999999",
            "-0.999999999999",
            "1e-7",
            "45",
            "89.9999999",
        ])
        .prop_map(String::from)
    }

    fn command() -> impl Strategy<Value = Vec<String>> {
        let v = value;
        prop_oneof![
            (v(), v()).prop_map(|(o, d)| vec![
                "sh".into(),
                "eval".into(),
                "--order".into(),
                o,
                "--dir".into(),
                d
            ]),
            (v(), v()).prop_map(|(o, a)| vec![
                "sh".into(),
                "cap".into(),
                "--order".into(),
                o,
                "--angle-deg".into(),
                a
            ]),
            (v(), v(), v()).prop_map(|(o, c, e)| vec![
                "sh".into(),
                "rotate".into(),
                "--order".into(),
                o,
                "--coeffs".into(),
                c,
                "--euler-zyz-deg".into(),
                e
            ]),
            (v(), v(), v(), v()).prop_map(|(o, t, a, k)| vec![
                "matrix".into(),
                "--order".into(),
                o,
                "--tau".into(),
                t,
                "--alpha-deg".into(),
                a,
                "--k".into(),
                k
            ]),
            (v(), v(), v()).prop_map(|(p, o, h)| vec![
                "visibility".into(),
                "--mesh".into(),
                "sphere".into(),
                "--point".into(),
                p,
                "--order".into(),
                o,
                "--hemisphere-res".into(),
                h
            ]),
            (v(), v(), v()).prop_map(|(o, a, r)| vec![
                "probe".into(),
                "--mesh".into(),
                "sphere".into(),
                "--order".into(),
                o,
                "--alpha-deg".into(),
                a,
                "--radii".into(),
                r,
                "--layout".into(),
                "fib:12".into(),
                "--hemisphere-res".into(),
                "4".into()
            ]),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

        #[test]
        fn hostile_command_lines_never_panic(args in command()) {
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_shscale")).args(&args).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            prop_assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
            let code = out.status.code();
            prop_assert!(code == Some(0) || code == Some(2), "{args:?}: status {code:?}: {err}");
            if code == Some(2) {
                prop_assert_eq!(err.lines().filter(|l| !l.trim().is_empty()).count(), 1, "{:?}: {}", args, err);
            }
        }
    }
}

/// A reader that closes the pipe early (`shscale demo | head -c 100`) ends the process quietly:
/// no panic message, killed by SIGPIPE like any Unix tool.
#[test]
fn a_closed_pipe_is_not_a_panic() {
    use std::io::Read;
    for args in [
        &["demo"][..],
        &["config-reference"][..],
        &["sh", "eval", "--order", "100", "--dir", "0,0,1"][..],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_shscale"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut first = [0u8; 16];
        child.stdout.take().unwrap().read_exact(&mut first).unwrap();
        // The read end is dropped here: further writes hit a closed pipe.
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}
