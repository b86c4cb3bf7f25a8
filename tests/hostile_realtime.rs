//! Hostile input, round four: the inscribed fit, the real-time path and the scripts. Each case
//! once panicked, hung, fell back silently or recorded a result of another computation; each is
//! now refused by name (exit status 2, one line) or reported.

mod common;
use common::{fails, shscale};
use std::path::{Path, PathBuf};

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-h4-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// A scene of one occluder `mesh` over a small receiver plane.
fn scene(mesh: &str) -> String {
    format!("order = 3\ntruth_res = 4\n[[occluder]]\nmesh = \"{mesh}\"\ncenter = [0, 0, 1.1]\nradius = 1.0\n[receiver]\ncenter = [0, 0, 0]\nsize = [3, 3]\nresolution = [8, 8]\n[light]\nkind = \"sky\"\n")
}

/// The inscribed fit of a mesh with no inside (the bundled `plane`, an open fan; an OBJ of one
/// triangle) once panicked in a run (`a sphere set needs a sphere`) and left the process
/// waiting forever; `budget_plane` exited 0 and the CPU render wrote an unshadowed image. Every
/// path refuses it before any work, naming `sphere_fit` and the mesh, and writes nothing.
#[test]
fn an_inscribed_fit_of_a_mesh_without_inside_is_refused_on_every_path() {
    let d = tmp("inscribed");
    let tri = write(&d, "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let out = d.join("out");
    for mesh in ["plane", tri.as_str()] {
        let budget = write(
            &d,
            "budget.toml",
            &format!("experiment = \"budget\"\nmesh = \"{mesh}\"\nmethod = \"sphere_set\"\nsphere_fit = \"inscribed\"\norder = 2\nreceivers = 4\ntruth_res = 4\nradii = [2.0]\n"),
        );
        for extra in [&[][..], &["--dry-run"][..]] {
            let mut args = vec!["run", budget.as_str(), "--out-dir", out.to_str().unwrap()];
            args.extend_from_slice(extra);
            fails(&args, "sphere_fit");
            fails(&args, &format!("mesh \"{mesh}\""));
            fails(&args, "no inside");
        }
        let s = write(&d, "s.toml", &scene(mesh));
        let plane = write(
            &d,
            "plane.toml",
            "experiment = \"budget_plane\"\nscene = \"s.toml\"\ngpu = \"off\"\nmethod = \"sphere_set\"\nsphere_fit = \"inscribed\"\n",
        );
        fails(
            &["run", &plane, "--out-dir", out.to_str().unwrap()],
            "sphere_fit = \"inscribed\" on mesh",
        );
        let exr = d.join("r.exr");
        for gpu in [false, true] {
            let mut args = vec![
                "render",
                "--scene",
                s.as_str(),
                "--method",
                "sphere_set",
                "--sphere-fit",
                "inscribed",
                "--out",
                exr.to_str().unwrap(),
            ];
            if gpu {
                args.extend(["--gpu", "--frames", "2"]);
            }
            fails(&args, "no inside");
            assert!(!exr.exists(), "no image written");
        }
    }
    assert!(!out.join("budget").join("budget").join("runs.csv").exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// A solid mesh's fit is priced by its size: the estimate grows with the triangles, and a mesh
/// over the fit's bound is refused at plan time by name.
#[test]
fn the_inscribed_fit_is_priced_by_the_mesh() {
    let d = tmp("priced");
    let estimate = |mesh: &str| -> f64 {
        let cfg = write(&d, "e.toml", &format!("experiment = \"budget\"\nmesh = \"{mesh}\"\nmethod = \"sphere_set\"\nsphere_fit = \"inscribed\"\norder = 2\nreceivers = 4\ntruth_res = 4\nradii = [2.0]\n"));
        let o = shscale(&[
            "run",
            &cfg,
            "--dry-run",
            "--out-dir",
            d.join("o").to_str().unwrap(),
        ]);
        let text =
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{text}");
        let line = text
            .lines()
            .find(|l| l.contains("estimated:"))
            .expect("an estimate");
        let secs: f64 = line
            .split(" s on this machine")
            .next()
            .unwrap()
            .rsplit(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let speed: f64 = line
            .split("(at ")
            .nth(1)
            .unwrap()
            .split('×')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        println!("{mesh}: {line}");
        secs * speed
    };
    // A UV sphere of 2·24·48 and of 2·96·192 triangles: the second's fit has 16× the winding
    // numbers (the same grid).
    let sphere = |rings: usize| {
        let mut t = String::new();
        let seg = 2 * rings;
        t.push_str("v 0 0 1\n");
        for i in 1..rings {
            let th = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..seg {
                let ph = std::f64::consts::TAU * j as f64 / seg as f64;
                t.push_str(&format!(
                    "v {} {} {}\n",
                    th.sin() * ph.cos(),
                    th.sin() * ph.sin(),
                    th.cos()
                ));
            }
        }
        t.push_str("v 0 0 -1\n");
        let at = |i: usize, j: usize| 2 + (i - 1) * seg + j % seg;
        let last = 2 + (rings - 1) * seg;
        for j in 0..seg {
            t.push_str(&format!("f 1 {} {}\n", at(1, j), at(1, j + 1)));
            t.push_str(&format!(
                "f {last} {} {}\n",
                at(rings - 1, j + 1),
                at(rings - 1, j)
            ));
        }
        for i in 1..rings - 1 {
            for j in 0..seg {
                let (a, b, c, e) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
                t.push_str(&format!("f {a} {c} {e}\nf {a} {e} {b}\n"));
            }
        }
        write(&d, &format!("s{rings}.obj"), &t)
    };
    let (small, large) = (estimate(&sphere(24)), estimate(&sphere(96)));
    // Reference seconds without the truths and frames, which do not change: the fit's share
    // grows 16× in its winding numbers.
    assert!(large > small + 10.0, "{small} → {large}");
    let huge = sphere(400);
    let cfg = write(&d, "h.toml", &format!("experiment = \"budget\"\nmesh = \"{huge}\"\nmethod = \"sphere_set\"\nsphere_fit = \"inscribed\"\norder = 2\nreceivers = 4\ntruth_res = 4\nradii = [2.0]\n"));
    fails(
        &[
            "run",
            &cfg,
            "--dry-run",
            "--out-dir",
            d.join("o").to_str().unwrap(),
        ],
        "above the limit",
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Every method key of `budget_plane` with a value other than its default, on every method:
/// with `device = "gpu"` each is either refused at plan time naming `device` and the key, or
/// carried out by the method's GPU form — which the GPU run then shows, its image matching the
/// CPU's (where an adapter is open; `SHSCALE_REQUIRE_GPU=1` makes one required). The keys come
/// from the plan's own run line, so a key added to the vocabulary without a value here fails
/// this test, and one without a GPU form is refused by the vocabulary's rule
/// (`shscale_scene::gpu_methods::unhonoured`), not by a new case.
#[test]
fn every_method_key_is_carried_out_or_refused_by_the_gpu_form() {
    let d = tmp("gpu-keys");
    write(
        &d,
        "d.toml",
        &scene("duck").replace("resolution = [8, 8]", "resolution = [10, 10]"),
    );
    // A value other than the default of every method key (scene order 3, truth_res 4).
    let alternatives: &[(&str, &str)] = &[
        ("parts", "2"),
        ("layout", "\"latlong:8x14\""),
        ("hemisphere_res", "6"),
        ("shells", "4"),
        ("shell_max", "4.0"),
        ("shell_spacing", "\"exp\""),
        ("field_interp", "\"barycentric\""),
        ("rt_res", "2"),
        ("alpha_deg", "30.0"),
        ("plausibility", "\"clamp\""),
        ("sampling_radius", "1.2"),
        ("radial", "\"clearance\""),
        ("radial_delta", "0.3"),
        ("sphere_combine", "\"union\""),
        ("sphere_fit", "\"inscribed\""),
        ("sphere_order", "4"),
        ("part_combine", "\"shexp\""),
    ];
    let not_method = [
        "scene",
        "order",
        "frames",
        "method",
        "save_image",
        "placement_seed",
        "device",
    ];
    let base = |method: &str| {
        let fast = match method {
            "extrapolated" | "sub_volumes" | "full_field" => {
                "layout = \"latlong:6x10\"\nhemisphere_res = 8\n"
            }
            _ => "",
        };
        format!("experiment = \"budget_plane\"\nscene = \"d.toml\"\ntiming_repeats = 1\ntiming_warmup = 0\nparallel_runs = false\nmethod = \"{method}\"\n{fast}")
    };
    let dry = |text: &str| {
        let cfg = write(&d, "k.toml", text);
        shscale(&[
            "run",
            &cfg,
            "--dry-run",
            "--out-dir",
            d.join("o").to_str().unwrap(),
        ])
    };
    // The run line names every parameter: each method key must have a value above.
    let o = dry(&(base("extrapolated") + "device = \"gpu\"\ngpu = \"off\"\n"));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("run "))
        .expect("a run line");
    let params = line.split_whitespace().nth(3).unwrap();
    for kv in params.split(';') {
        let key = kv.split('=').next().unwrap();
        assert!(
            not_method.contains(&key) || alternatives.iter().any(|(k, _)| *k == key),
            "method key {key} has no value in this test's table: add one"
        );
    }
    let mut carried = Vec::new();
    let mut refused = 0;
    for method in [
        "extrapolated",
        "full_field",
        "ray_traced",
        "sub_volumes",
        "sphere_set",
    ] {
        for (key, value) in alternatives {
            let mut text = base(method);
            if text.contains(&format!("\n{key} = ")) {
                text = text
                    .lines()
                    .filter(|l| !l.starts_with(&format!("{key} = ")))
                    .collect::<Vec<_>>()
                    .join("\n")
                    + "\n";
            }
            let extra = if *key == "radial_delta" {
                "radial = \"clearance\"\n"
            } else {
                ""
            };
            text.push_str(&format!("{extra}{key} = {value}\n"));
            let cpu = dry(&(text.clone() + "device = \"cpu\"\n"));
            if !cpu.status.success() {
                // Not read by this method (the unread-key rule) or outside its domain on the CPU
                // too: not a question for the GPU form.
                continue;
            }
            let o = dry(&(text.clone() + "device = \"gpu\"\ngpu = \"off\"\n"));
            let err = String::from_utf8_lossy(&o.stderr).to_string();
            if o.status.success() {
                println!("{method} {key} = {value}: carried out on the GPU");
                carried.push((method, text));
            } else {
                assert_eq!(o.status.code(), Some(2), "{method} {key}: {err}");
                assert!(err.contains("device"), "{method} {key}: {err}");
                assert!(!err.contains("panicked"), "{err}");
                println!("{method} {key} = {value}: refused: {}", err.trim());
                refused += 1;
            }
        }
    }
    println!("{} carried out, {refused} refused", carried.len());
    assert!(
        refused >= 5 && carried.len() >= 10,
        "{} carried, {refused} refused",
        carried.len()
    );
    // The carried-out ones on the GPU: the image must be the CPU's (the band-limited
    // ray-traced reference is another quadrature on the GPU, its own tolerance elsewhere).
    let required = std::env::var("SHSCALE_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let mut all = String::new();
    for (i, (method, text)) in carried.iter().enumerate() {
        if *method == "ray_traced" {
            continue;
        }
        let cfg = write(
            &d,
            &format!("g{i}.toml"),
            &(text.clone() + "device = \"auto\"\n"),
        );
        let out = d.join(format!("g{i}"));
        let o = shscale(&["run", &cfg, "--out-dir", out.to_str().unwrap()]);
        assert!(
            o.status.success(),
            "{text}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let csv = out
            .join("budget_plane")
            .join(format!("g{i}"))
            .join("runs.csv");
        let mut rd = csv::Reader::from_path(&csv).unwrap();
        let head = rd.headers().unwrap().clone();
        let col = |n: &str| head.iter().position(|h| h == n).unwrap();
        let r = rd.records().next().unwrap().unwrap();
        if r[col("gpu_adapter")].starts_with("none") {
            assert!(
                !required,
                "no adapter under SHSCALE_REQUIRE_GPU=1: {}",
                &r[col("gpu_adapter")]
            );
            eprintln!(
                "notice: no adapter; the GPU images of the carried-out keys were not compared"
            );
            break;
        }
        let diff: f64 = r[col("gpu_max_diff")].parse().unwrap();
        println!(
            "{method}: {} → GPU image {diff:.2e} from the CPU's",
            text.lines().last().unwrap()
        );
        all.push_str(&format!(
            "{method} {}: {diff:.2e}\n",
            text.lines().last().unwrap()
        ));
        assert!(
            diff < 1e-4,
            "{method} {}: the GPU computed something else ({diff:.3e})",
            text.lines().last().unwrap()
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

mod budget_keys {
    use super::*;
    use proptest::prelude::*;

    /// Degenerate meshes beside the bundled ones: open, flat, one triangle, no inside, a
    /// needle; written once per process.
    fn meshes() -> Vec<String> {
        let d = std::env::temp_dir().join(format!("shscale-h4-meshes-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let mut v: Vec<String> = ["sphere", "bunny", "plane", "knot"]
            .map(String::from)
            .to_vec();
        for (name, text) in [
            ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            ("flat.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n"),
            ("fan.obj", "v 0 0 0.3\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\nf 1 4 5\nf 1 5 2\n"),
            ("needle.obj", "v 0 0 0\nv 1e-9 0 0\nv 0 1e-9 0\nv 0 0 5\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"),
        ] {
            let p = d.join(name);
            std::fs::write(&p, text).unwrap();
            v.push(p.to_str().unwrap().to_string());
        }
        v
    }

    fn config() -> impl Strategy<Value = String> {
        let meshes = meshes();
        (
            prop::sample::select(meshes),
            prop::sample::select(vec!["extrapolated", "full_field", "ray_traced", "sub_volumes", "sphere_set"]),
            prop::sample::select(vec![1usize, 2, 3, 64, 65]),
            prop::sample::select(vec!["area", "inscribed"]),
            prop::sample::select(vec!["product", "union", "shexp", "quadrature"]),
            prop::sample::select(vec!["uniform", "clearance", "occlusion"]),
            prop::sample::select(vec![1usize, 2, 3, 9]),
            prop::sample::select(vec!["grid", "continuous"]),
        )
            .prop_map(|(mesh, method, parts, fit, combine, radial, order, layout)| {
                let mut t = format!("experiment = \"budget\"\nmesh = \"{mesh}\"\nmethod = \"{method}\"\norder = {order}\nreceivers = 2\ntruth_res = 2\ntiming_repeats = 1\ntiming_warmup = 0\nreceiver_layout = \"{layout}\"\n");
                // Only the keys the method reads (the others must keep their defaults).
                match method {
                    "extrapolated" | "sub_volumes" => t.push_str("layout = \"latlong:4x6\"\nhemisphere_res = 2\n"),
                    "full_field" => t.push_str("layout = \"latlong:4x6\"\nhemisphere_res = 2\nshells = 2\n"),
                    "ray_traced" => t.push_str("rt_res = 2\n"),
                    _ => {}
                }
                if layout == "grid" {
                    t.push_str("radii = [1.5]\n");
                }
                if matches!(method, "sub_volumes" | "sphere_set") {
                    t.push_str(&format!("parts = {parts}\n"));
                }
                if method == "sphere_set" {
                    t.push_str(&format!("sphere_fit = \"{fit}\"\nsphere_combine = \"{combine}\"\n"));
                }
                if matches!(method, "extrapolated" | "sub_volumes") {
                    t.push_str(&format!("radial = \"{radial}\"\n"));
                }
                t
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// A run of any combination of the budget kind's method keys on any of these meshes
        /// finishes (exit 0) or is refused in one line (exit 2): no panic, no hang (each run
        /// is given 120 s; a tiny one takes well under one).
        #[test]
        fn budget_keys_on_degenerate_meshes_never_panic(text in config()) {
            let d = tmp("prop");
            let cfg = write(&d, "p.toml", &text);
            let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_shscale"))
                .args(["run", &cfg, "--out-dir", d.join("o").to_str().unwrap()])
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap();
            let t0 = std::time::Instant::now();
            while child.try_wait().unwrap().is_none() {
                if t0.elapsed().as_secs() > 120 {
                    child.kill().ok();
                    prop_assert!(false, "still running after 120 s: {text}");
                }
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            let out = child.wait_with_output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            prop_assert!(!err.contains("panicked"), "{text} panicked: {err}");
            let code = out.status.code();
            prop_assert!(code == Some(0) || code == Some(2), "{text}: status {code:?}: {err}");
            if code == Some(2) {
                let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty() && !l.starts_with("progress:")).collect();
                prop_assert_eq!(lines.len(), 1, "{}: {}", text, err);
            }
            let _ = std::fs::remove_dir_all(&d);
        }
    }
}

/// `device = "gpu"` under `gpu = "auto"` on a machine without an adapter (here: no Vulkan
/// driver found) is refused before any work in one line naming the run and `device`, instead
/// of a "continuing with the CPU path" notice followed by the error.
#[test]
fn a_gpu_timing_without_adapter_is_one_line() {
    let d = tmp("no-adapter");
    write(&d, "d.toml", &scene("duck"));
    let cfg = write(&d, "g.toml", "experiment = \"budget_plane\"\nscene = \"d.toml\"\ndevice = \"gpu\"\nmethod = \"extrapolated\"\n");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_shscale"))
        .args(["run", &cfg, "--out-dir", d.join("o").to_str().unwrap()])
        .env("VK_ICD_FILENAMES", "/nonexistent.json")
        .env("VK_DRIVER_FILES", "/nonexistent.json")
        .env_remove("WGPU_BACKEND")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    println!("{err}");
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(
        err.contains("device = \"gpu\"") && err.contains("no adapter"),
        "{err}"
    );
    assert!(!d.join("o/budget_plane/g/runs.csv").exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// Ctrl-C before any run finished says that nothing was saved (not "the runs finished so far
/// are saved in …/runs.csv", a file that does not exist); after a run finished, it names the
/// file, which holds it.
#[test]
fn ctrl_c_says_what_was_saved() {
    let d = tmp("sigint");
    let cfg = write(&d, "s.toml", "experiment = \"probe\"\nmesh = \"bunny\"\nlayout = \"latlong:12x20\"\nhemisphere_res = 32\ntruth_res = 48\nparallel_runs = false\n[sweep]\nalpha_deg = [20.0, 30.0, 40.0, 50.0, 60.0, 70.0]\n");
    let out = d.join("o");
    let csv = out.join("probe/s/runs.csv");
    let interrupt = |after_a_row: bool| {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_shscale"))
            .args(["run", &cfg, "--out-dir", out.to_str().unwrap()])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let t0 = std::time::Instant::now();
        if after_a_row {
            while !std::fs::read_to_string(&csv).is_ok_and(|t| t.lines().count() > 1) {
                assert!(t0.elapsed().as_secs() < 120, "no row after 120 s");
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
        } else {
            // The plan's first line comes after the handler is installed (a signal before it
            // would kill the process unexplained, as any program's would).
            use std::io::BufRead;
            let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
            assert!(
                lines.any(|l| l.is_ok_and(|l| l.contains("run(s) to do"))),
                "no plan line"
            );
        }
        // SAFETY: signalling a child of this process by its pid.
        unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
        let o = child.wait_with_output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let (code, err) = interrupt(false);
    println!("{err}");
    assert_eq!(code, Some(130), "{err}");
    if !csv.exists() {
        assert!(err.contains("nothing was saved"), "{err}");
    }
    let (code, err) = interrupt(true);
    println!("{err}");
    assert_eq!(code, Some(130), "{err}");
    assert!(
        err.contains("the runs finished so far are saved in") && csv.exists(),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
