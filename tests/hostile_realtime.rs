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
