//! End-to-end tests of `shscale inspect` and `shscale visibility`.

mod common;
use common::*;
use std::f64::consts::PI;

#[test]
fn inspect_bundled_and_sphere() {
    let v = json(&["inspect", "bunny"]);
    assert_eq!(v["vertices"], 1839);
    assert_eq!(v["triangles"], 3674);
    assert_eq!(v["watertight"], true);
    let r = v["bounding_sphere"]["radius"].as_f64().unwrap();
    assert!(r > 6.0 && r < 6.5, "{r}");
    assert_eq!(v["bounding_sphere"]["center"].as_array().unwrap().len(), 3);
    let t = json(&["inspect", "teapot"]);
    assert_eq!(t["watertight"], false);
    assert_eq!(t["boundary_edges"], 256);
    let s = json(&["inspect", "sphere"]);
    assert_eq!(s["bounding_sphere"]["radius"].as_f64(), Some(1.0));
}

#[test]
fn visibility_of_the_analytic_sphere_matches_the_cap() {
    // From (0, 0, 2) the unit sphere hides the cap of half-angle 30° about −z:
    // V = √(4π) δ_i0 − c_l(30°)·(−1)^l at m = 0.
    let h = 64;
    let v = json(&[
        "visibility",
        "--mesh",
        "sphere",
        "--point",
        "0,0,2",
        "--order",
        "3",
        "--quadrature",
        "gauss",
        "--hemisphere-res",
        "64",
    ]);
    assert_eq!(v["order"], 3);
    assert_eq!(v["frame"], "entity");
    assert_eq!(v["quadrature"], "gauss");
    assert_eq!(v["rays"], 2 * h * h);
    assert!(v["seconds"].as_f64().unwrap() >= 0.0);
    let got = values(&v);
    let cap = json(&["sh", "cap", "--order", "3", "--angle-deg", "30"]);
    let c = values(&cap);
    for (i, l) in [(0usize, 0usize), (2, 1), (6, 2)] {
        let sign = if l % 2 == 0 { 1.0 } else { -1.0 };
        let want = if i == 0 {
            (4.0 * PI).sqrt() - c[0]
        } else {
            -sign * c[i]
        };
        // Quadrature bound of a ring-aligned step: (π²/H)·√((2l+1)/4π).
        let bound = PI * PI / h as f64 * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
        assert!(
            (got[i] - want).abs() <= bound,
            "i={i}: {} vs {want} (bound {bound})",
            got[i]
        );
    }
    // Local frame: zonal about +z.
    let loc = json(&[
        "visibility",
        "--mesh",
        "sphere",
        "--point",
        "0,0,2",
        "--order",
        "2",
        "--frame",
        "local",
        "--quadrature",
        "gauss",
    ]);
    assert_eq!(loc["frame"], "local");
    let lv = values(&loc);
    assert!(lv[1].abs() < 1e-12 && lv[3].abs() < 1e-12);
    // The default (stratified, converged) quadrature at order 8 against the closed-form cap,
    // from (0, 0, 2) and from an oblique point: the actual error relative to the occlusion is
    // ≤ 1 %, and the reported estimate is within a factor 3 of it.
    let cap8 = values(&json(&["sh", "cap", "--order", "8", "--angle-deg", "30"]));
    for (point, frame) in [
        ("0,0,2", "entity"),
        ("0,0,2", "local"),
        ("1.2,-1.2,1.0583005244258363", "local"),
    ] {
        let v = json(&[
            "visibility",
            "--mesh",
            "sphere",
            "--point",
            point,
            "--order",
            "8",
            "--frame",
            frame,
        ]);
        assert_eq!(v["quadrature"], "stratified");
        assert_eq!(v["rays"], 4 * 128 * 128);
        let got = values(&v);
        // The cap about −z (entity frame at (0, 0, 2)) or +z (local frame: z toward the centre);
        // (1.2, −1.2, 1.058…) is also 2 from the centre, so its local-frame truth is the same.
        let flip = frame == "entity";
        let mut err2 = 0.0;
        let mut occ2 = 0.0;
        for l in 0..8usize {
            for m in -(l as i64)..=l as i64 {
                let i = l * l + l + m as usize;
                let c = if m == 0 { cap8[l * l + l] } else { 0.0 };
                let sign = if flip && l % 2 == 1 { -1.0 } else { 1.0 };
                let want = if i == 0 {
                    (4.0 * PI).sqrt() - c
                } else {
                    -sign * c
                };
                err2 += (got[i] - want).powi(2);
                occ2 += (sign * c).powi(2);
            }
        }
        let (err, est) = (
            err2.sqrt() / occ2.sqrt(),
            v["rel_error_estimate"].as_f64().unwrap(),
        );
        println!("{point} ({frame}): actual {err:.2e}, estimated {est:.2e}");
        assert!(err < 0.01, "{point}: {err}");
        assert!(
            est < 0.01 && est > err / 3.0 && est < 3.0 * err,
            "{point}: {est} vs {err}"
        );
    }
    // A point far from the bunny sees almost nothing occluded.
    let far = json(&[
        "visibility",
        "--mesh",
        "bunny",
        "--point",
        "0,500,0",
        "--order",
        "1",
        "--hemisphere-res",
        "16",
    ]);
    assert!((values(&far)[0] - (4.0 * PI).sqrt()).abs() < 0.05);
}

#[test]
fn bad_meshes_and_values_fail_cleanly() {
    let dir = std::env::temp_dir().join(format!("shscale-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    let bad_s = bad.to_str().unwrap();
    fails(&["inspect", bad_s], "bad.obj:4");
    fails(
        &[
            "visibility",
            "--mesh",
            bad_s,
            "--point",
            "0,0,2",
            "--order",
            "2",
        ],
        "bad.obj:4",
    );
    let ply = dir.join("bad.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
    )
    .unwrap();
    fails(&["inspect", ply.to_str().unwrap()], "bad.ply");
    fails(
        &["inspect", "/nonexistent/mesh.obj"],
        "/nonexistent/mesh.obj",
    );
    fails(&["inspect", "no_such_name"], "no_such_name");
    fails(
        &[
            "visibility",
            "--mesh",
            "sphere",
            "--point",
            "0,0",
            "--order",
            "2",
        ],
        "point",
    );
    fails(
        &[
            "visibility",
            "--mesh",
            "sphere",
            "--point",
            "0,0,nan",
            "--order",
            "2",
        ],
        "point",
    );
    fails(
        &[
            "visibility",
            "--mesh",
            "sphere",
            "--point",
            "0,0,2",
            "--order",
            "0",
        ],
        "order",
    );
    fails(
        &[
            "visibility",
            "--mesh",
            "sphere",
            "--point",
            "0,0,2",
            "--order",
            "2",
            "--hemisphere-res",
            "0",
        ],
        "hemisphere-res",
    );
    fails(
        &[
            "visibility",
            "--mesh",
            "sphere",
            "--point",
            "0,0,0",
            "--order",
            "2",
            "--frame",
            "local",
        ],
        "point",
    );
    std::fs::remove_dir_all(&dir).ok();
}
