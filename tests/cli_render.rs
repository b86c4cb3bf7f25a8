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
    for m in ["extrapolated", "full-field", "raytraced", "raytraced-full"] {
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
        let (w, h, px) = shscale_lab::io::read_exr(&out).unwrap();
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
    let rel = v["reference"]["shade_rmse_rel"].as_f64().unwrap();
    assert!(rel.is_finite() && rel > 0.0, "{rel}");
    for f in v["files"].as_array().unwrap() {
        assert!(std::path::Path::new(f.as_str().unwrap()).exists(), "{f}");
    }
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
        t.contains(&format!("shade_rmse_rel vs Raytraced: {rel:.4e}")),
        "{t} vs {rel}"
    );
    std::fs::remove_dir_all(&d).ok();
}
