//! End-to-end tests of `shscale render` and scene-file errors.

mod common;
use common::*;
use std::path::PathBuf;

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shscale-render-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SCENE: &str = r#"
order = 4
alpha_deg = 45
layout = "fib:60"
hemisphere_res = 16

[[occluder]]
mesh = "sphere"
center = [0, 0, 1.5]
radius = 1.0

[receiver]
center = [0, 0, 0]
size = [6, 6]
resolution = [24, 24]

[light]
kind = "sky"
ambient = 0.3
zenith = 1.0
sun = 10.0
sun_dir = [0, 0, 1]
sun_radius_deg = 10
"#;

#[test]
fn render_all_methods_to_exr_and_png() {
    let d = tmpdir("ok");
    let scene = d.join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let mut images = Vec::new();
    // The vocabulary's names (docs/methods.md), and an earlier spelling the command line still
    // takes.
    for m in [
        "extrapolated",
        "full_field",
        "ray_traced",
        "full_frequency",
        "raytraced-full",
    ] {
        let out = d.join(format!("{m}.exr"));
        let r = shscale(&[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--method",
            m,
            "--out",
            out.to_str().unwrap(),
        ]);
        let text = String::from_utf8_lossy(&r.stdout);
        assert!(
            r.status.success(),
            "{m}: {} {}",
            text,
            String::from_utf8_lossy(&r.stderr)
        );
        assert!(text.contains("total") && text.contains(" ms"), "{text}");
        assert!(out.with_extension("png").exists());
        let (w, h, px) = shscale_present::image::read_exr(&out).unwrap();
        assert_eq!((w, h), (24, 24));
        images.push(px);
    }
    // The sun is overhead: the centre receiver is in the sphere's shadow, the corner is not.
    for px in &images {
        let (centre, corner) = (px[12 * 24 + 12][0], px[0][0]);
        assert!(centre < 0.5 * corner, "centre {centre} vs corner {corner}");
    }
    // Against ray-traced truth: the full field is close, the extrapolation is in the same range.
    let rel = |a: &Vec<[f32; 3]>, b: &Vec<[f32; 3]>| {
        let e: Vec<f64> = a.iter().map(|p| p[0] as f64).collect();
        let t: Vec<f64> = b.iter().map(|p| p[0] as f64).collect();
        let corner = vec![b[0][0] as f64; t.len()];
        shscale_field::shading::shade_rmse_rel(&e, &t, &corner).unwrap()
    };
    let (ex, ff) = (rel(&images[0], &images[2]), rel(&images[1], &images[2]));
    let (ex_full, bl_full) = (rel(&images[0], &images[3]), rel(&images[2], &images[3]));
    println!("shade_rmse_rel vs band-limited truth: extrapolated {ex:.3e}, full field {ff:.3e}");
    println!("shade_rmse_rel vs full-frequency truth: extrapolated {ex_full:.3e}, band-limited truth itself {bl_full:.3e}");
    assert!(ff < 0.05, "full field {ff}");
    assert!(ex < 0.5, "extrapolated {ex}");
    // Band-limiting the visibility to N = 4 costs something, but far less than extrapolating.
    assert!(
        bl_full < 0.2 && bl_full < ex_full,
        "band-limited {bl_full} vs extrapolated {ex_full}"
    );
    // The earlier spelling is the same method: the same image.
    assert_eq!(images[3], images[4], "raytraced-full is full_frequency");
    // --reference prints shade_rmse_rel against the chosen truth.
    let out = d.join("ref.exr");
    let r = shscale(&[
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--reference",
        "raytraced",
    ]);
    let text = String::from_utf8_lossy(&r.stdout).to_string();
    let line = text
        .lines()
        .find(|l| l.starts_with("shade_rmse_rel vs"))
        .unwrap_or_else(|| panic!("{text}"));
    let v: f64 = line.split_whitespace().nth(3).unwrap().parse().unwrap();
    assert!(v > 0.0 && v < 0.5, "{line}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn scene_errors_name_file_line_and_field() {
    let d = tmpdir("bad");
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let out = d.join("x.exr");
    let out = out.to_str().unwrap();
    let unknown = write(
        "unknown.toml",
        &SCENE.replace("hemisphere_res = 16", "hemisphere_res = 16\nbogus = 3"),
    );
    fails(
        &["render", "--scene", &unknown, "--out", out],
        "unknown.toml:6",
    );
    let alpha = write(
        "alpha.toml",
        &SCENE.replace("alpha_deg = 45", "alpha_deg = 95"),
    );
    fails(
        &["render", "--scene", &alpha, "--out", out],
        "alpha.toml:3: alpha_deg",
    );
    let radius = write("radius.toml", &SCENE.replace("radius = 1.0", "radius = -1"));
    fails(&["render", "--scene", &radius, "--out", out], "radius");
    let kind = write(
        "kind.toml",
        &SCENE.replace("kind = \"sky\"", "kind = \"lamp\""),
    );
    fails(&["render", "--scene", &kind, "--out", out], "kind");
    let mesh = write(
        "mesh.toml",
        &SCENE.replace("mesh = \"sphere\"", "mesh = \"nope\""),
    );
    fails(&["render", "--scene", &mesh, "--out", out], "nope");
    let exr = write(
        "exr.toml",
        &SCENE.replace("kind = \"sky\"", "kind = \"exr\"\npath = \"missing.exr\""),
    );
    fails(&["render", "--scene", &exr, "--out", out], "missing.exr");
    fails(
        &["render", "--scene", "/nonexistent/scene.toml", "--out", out],
        "/nonexistent/scene.toml",
    );
    fails(
        &[
            "render",
            "--scene",
            &unknown,
            "--out",
            "/nonexistent/dir/x.exr",
        ],
        "/nonexistent/dir",
    );
    fails(&["render", "--scene", &unknown, "--out", "x.png"], ".exr");
    // Nothing was written under the requested name by the failures.
    assert!(!std::path::Path::new(out).exists());
    std::fs::remove_dir_all(&d).ok();
}

/// `render --format json`: the stage times, the reference's error and the files, for scripts;
/// the reference's error equals the one the text output prints.
#[test]
fn render_prints_json_for_scripts() {
    let d = std::env::temp_dir().join(format!("shscale-render-json-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../configs/scene_sphere.toml"
    );
    let out = d.join("s.exr");
    let v = json(&[
        "render",
        "--scene",
        scene,
        "--out",
        out.to_str().unwrap(),
        "--reference",
        "raytraced",
        "--format",
        "json",
    ]);
    assert_eq!(v["width"], 96);
    assert!(v["stages_ms"]["bsv_sampling"].as_f64().unwrap() > 0.0);
    // Every output says what the full-frequency truth lights with; the extrapolation has no
    // truth error of its own.
    assert_eq!(v["full_frequency_light"], "closed-form sky");
    assert!(v["truth_error_rms"].is_null());
    let rel = v["reference"]["shade_rmse_rel"].as_f64().unwrap();
    assert!(rel.is_finite() && rel > 0.0, "{rel}");
    for f in v["files"].as_array().unwrap() {
        assert!(std::path::Path::new(f.as_str().unwrap()).exists(), "{f}");
    }
    // The labelled false-colour figure: the method and the reference above, their difference
    // below (so taller than wide at two panels a row).
    let fig = d.join("s_figure.png");
    assert!(v["files"]
        .as_array()
        .unwrap()
        .iter()
        .any(|f| f.as_str() == Some(fig.to_str().unwrap())));
    let bytes = std::fs::read(&fig).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let (w, h) = (
        u32::from_be_bytes(bytes[16..20].try_into().unwrap()),
        u32::from_be_bytes(bytes[20..24].try_into().unwrap()),
    );
    assert!(w > 600 && h > 600, "{w}×{h}");
    let text = shscale(&[
        "render",
        "--scene",
        scene,
        "--out",
        out.to_str().unwrap(),
        "--reference",
        "raytraced",
    ]);
    let t = String::from_utf8_lossy(&text.stdout);
    assert!(
        t.contains(&format!("shade_rmse_rel vs ray_traced: {rel:.4e}")),
        "{t} vs {rel}"
    );
    std::fs::remove_dir_all(&d).ok();
}

/// `render --camera`: a camera straight above the receiver plane sees, at a pixel away from the
/// sphere, the plane's irradiance there (bilinear on the receiver grid) × albedo 0.8 / π; a pixel
/// looking at the sphere sees the sphere (diffuse, not the plane); off the plane, the background.
#[test]
fn camera_renders_see_the_plane_with_its_irradiance() {
    let d = std::env::temp_dir().join(format!("shscale-camera-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../configs/scene_sphere.toml"
    ))
    .unwrap();
    let scene = d.join("s.toml");
    std::fs::write(&scene, format!("{base}\n[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov_deg = 40\nresolution = [120, 80]\n")).unwrap();
    let (plane, view) = (d.join("plane.exr"), d.join("view.exr"));
    for (out, extra) in [(&plane, None), (&view, Some("--camera"))] {
        let mut args = vec![
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = shscale(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (gw, gh, e) = shscale_present::image::read_exr(&plane).unwrap();
    let (w, h, v) = shscale_present::image::read_exr(&view).unwrap();
    assert_eq!((w, h), (120, 80));
    // The pixel's ray, as the camera casts it (right = +x, up = +y looking down).
    let tan = 20f64.to_radians().tan();
    let ray = |i: usize, j: usize| {
        let sx = (2.0 * (i as f64 + 0.5) / w as f64 - 1.0) * tan * (w as f64 / h as f64);
        let sy = (1.0 - 2.0 * (j as f64 + 0.5) / h as f64) * tan;
        // Hit of (sx, sy, −1) from z = 10 on z = 0.
        (10.0 * sx, 10.0 * sy)
    };
    let lookup = |x: f64, y: f64| {
        let u = (x + 2.5) / 5.0 * (gw - 1) as f64;
        let vv = (2.5 - y) / 5.0 * (gh - 1) as f64;
        let (i0, j0) = (u.floor() as usize, vv.floor() as usize);
        let (fu, fv) = (u - i0 as f64, vv - j0 as f64);
        let p = |i: usize, j: usize| e[j * gw + i][0] as f64;
        let a = p(i0, j0) * (1.0 - fu) + p(i0 + 1, j0) * fu;
        let b = p(i0, j1(j0, gh)) * (1.0 - fu) + p(i0 + 1, j1(j0, gh)) * fu;
        (a * (1.0 - fv) + b * fv) * 0.8 / std::f64::consts::PI
    };
    fn j1(j: usize, h: usize) -> usize {
        (j + 1).min(h - 1)
    }
    let (i, j) = (40, 40); // left of the sphere
    let (x, y) = ray(i, j);
    assert!(
        x < -1.3 && x > -2.4 && y.abs() < 1.0,
        "pixel ({i}, {j}) hits ({x}, {y})"
    );
    let (got, want) = (v[j * w + i][0] as f64, lookup(x, y));
    println!("camera pixel ({i}, {j}) on the plane at ({x:.3}, {y:.3}): {got:.5}, irradiance × 0.8/π = {want:.5}");
    assert!(
        (got - want).abs() < 1e-4 * want.max(1e-3),
        "{got} vs {want}"
    );
    // Straight down the middle the sphere is in the way: the pixel is the sphere, not the plane.
    let (cx, cy) = (w / 2, h / 2);
    assert!((v[cy * w + cx][0] as f64 - lookup(ray(cx, cy).0, ray(cx, cy).1)).abs() > 1e-3);
    // A corner ray misses the 5 × 5 plane: background, the same in every corner.
    assert_eq!(v[0], v[w - 1]);
    std::fs::remove_dir_all(&d).ok();
}

/// `render --frames` with every budgeted method: per-frame rows with the method's stages and,
/// with `--reference`, each frame's error (JSON); `--gpu` with a method the GPU sequence does
/// not have is refused (exit 2, the flag named) before any work.
#[test]
fn sequences_take_every_method() {
    let d = tmpdir("seq");
    let scene = d.join("flap.toml");
    std::fs::write(
        &scene,
        "order = 4\nlayout = \"fib:40\"\nhemisphere_res = 8\n\n[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n\n[receiver]\ncenter = [0, 0, 0]\nsize = [5, 5]\nresolution = [12, 12]\n\n[light]\nkind = \"sky\"\n",
    )
    .unwrap();
    let out = d.join("s.exr");
    let (scene, out) = (scene.to_str().unwrap(), out.to_str().unwrap());
    for method in [
        "extrapolated",
        "full_field",
        "sub_volumes",
        "sphere_set",
        "ray_traced",
    ] {
        let v = json(&[
            "render",
            "--scene",
            scene,
            "--out",
            out,
            "--method",
            method,
            "--frames",
            "2",
            "--parts",
            "2",
            "--reference",
            "ray_traced",
            "--format",
            "json",
        ]);
        assert_eq!(v["method"], method, "{v}");
        let frames = v["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 2, "{v}");
        for f in frames {
            let e = f["shade_rmse_rel"].as_f64().unwrap();
            // The truth against itself is exact; every other method is off by something.
            if method == "ray_traced" {
                assert_eq!(e, 0.0, "{v}");
            } else {
                assert!(e > 0.0 && e < 1.0, "{method}: {e}");
            }
            assert!(f["seconds"].as_f64().unwrap() > 0.0);
            assert!(!f["stages"].as_object().unwrap().is_empty());
        }
        let cached = v["path"].as_str().unwrap().starts_with("cached");
        assert_eq!(cached, method == "extrapolated", "{v}");
    }
    fails(
        &[
            "render",
            "--scene",
            scene,
            "--out",
            out,
            "--method",
            "full_frequency",
            "--frames",
            "2",
            "--gpu",
        ],
        "--gpu",
    );
    // Pipelined frames are the papers' sequence's only: refused by name for another method,
    // and by the bench with --methods, before any adapter is needed.
    fails(
        &[
            "render",
            "--scene",
            scene,
            "--out",
            out,
            "--method",
            "full_field",
            "--frames",
            "2",
            "--gpu",
            "--pipelined",
        ],
        "--pipelined",
    );
    fails(
        &[
            "bench",
            "--gpu",
            "--pipelined",
            "--methods",
            "full_field",
            "--scene",
            "bird",
        ],
        "--pipelined",
    );
    // Inscribed spheres: sphere sets only (refused by name otherwise), rendered on the CPU.
    fails(
        &[
            "render",
            "--scene",
            scene,
            "--out",
            out,
            "--method",
            "extrapolated",
            "--sphere-fit",
            "inscribed",
        ],
        "--sphere-fit",
    );
    let v = json(&[
        "render",
        "--scene",
        scene,
        "--out",
        out,
        "--method",
        "sphere_set",
        "--parts",
        "8",
        "--sphere-fit",
        "inscribed",
        "--sphere-combine",
        "union",
        "--format",
        "json",
    ]);
    assert_eq!(v["method"], "sphere_set", "{v}");
    // So is the pose on the device (the full field poses on the host).
    fails(
        &[
            "render",
            "--scene",
            scene,
            "--out",
            out,
            "--frames",
            "2",
            "--gpu",
            "--device-pose",
            "--method",
            "full_field",
        ],
        "--device-pose",
    );
    fails(
        &[
            "bench",
            "--gpu",
            "--pipelined",
            "--methods",
            "full_field",
            "--scene",
            "bird",
        ],
        "--pipelined",
    );
    // Sphere sets and the full field have a GPU sequence (where an adapter exists); sphere sets
    // with the area fit are posed and fitted on the device too.
    for (method, title, parts) in [
        (
            "sphere_set",
            "GPU sphere-set sequence",
            &["--parts", "2"][..],
        ),
        (
            "sphere_set",
            "GPU sphere-set (posed and fitted on the device) sequence",
            &["--parts", "2", "--device-pose"][..],
        ),
        ("full_field", "GPU full-field sequence", &[][..]),
        (
            "extrapolated",
            "two frames in flight",
            &["--device-pose", "--pipelined"][..],
        ),
    ] {
        let mut args = vec![
            "render", "--scene", scene, "--out", out, "--method", method, "--frames", "2", "--gpu",
        ];
        args.extend_from_slice(parts);
        let g = shscale(&args);
        let text = String::from_utf8_lossy(&g.stdout);
        if g.status.success() {
            // (The papers' sequence names its shading column `shade_ms`.)
            assert!(
                text.contains(title) && (text.contains("shading_ms") || text.contains("shade_ms")),
                "{text}"
            );
        } else {
            let err = String::from_utf8_lossy(&g.stderr);
            let required = std::env::var("SHSCALE_REQUIRE_GPU").is_ok_and(|v| v == "1");
            assert!(!required && err.contains("--gpu"), "{err}");
            eprintln!("notice: no adapter; the GPU {method} sequence was not run ({err})");
        }
    }
    std::fs::remove_dir_all(&d).ok();
}
