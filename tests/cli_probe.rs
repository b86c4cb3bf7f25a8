//! End-to-end tests of `shscale probe`.

mod common;
use common::*;

#[test]
fn probe_json_form_and_on_surface_sphere() {
    let v = json(&[
        "probe",
        "--mesh",
        "sphere",
        "--order",
        "4",
        "--alpha-deg",
        "45",
        "--layout",
        "fib:40",
        "--radii",
        "1.3,2",
        "--probe-dirs",
        "samples",
    ]);
    assert_eq!(v["mesh"], "sphere");
    assert_eq!(v["probe_dirs"], "samples");
    assert_eq!(
        v["truth_rays_per_probe"], 0,
        "the sphere's truth is closed-form"
    );
    assert_eq!(v["order"], 4);
    assert_eq!(v["alpha_deg"].as_f64(), Some(45.0));
    assert_eq!(v["samples"], 40);
    assert_eq!(v["on_surface_samples"], 40);
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for (row, radius) in rows.iter().zip([1.3, 2.0]) {
        assert_eq!(row["radius"].as_f64(), Some(radius));
        for key in [
            "vis_rel_l2_mean",
            "occ_rel_l2_mean",
            "occ_rel_l2_max",
            "on_surface_count",
            "occ_rel_l2_on_surface_mean",
            "extrapolation_seconds",
            "truth_seconds",
            "truth_rel_err_mean",
            "occ_rel_l2_exact_k_mean",
            "occ_rel_l2_model_mean",
            "band_limit_rel_mean",
            "occ_solid_angle_max",
            "k_node_offset",
        ] {
            assert!(!row[key].is_null(), "{key} missing in {row}");
        }
        assert_eq!(row["on_surface_count"], 40);
        // Every sample of the sphere is alike: mean = max.
        let (m, x) = (
            row["occ_rel_l2_mean"].as_f64().unwrap(),
            row["occ_rel_l2_max"].as_f64().unwrap(),
        );
        assert!((m - x).abs() < 1e-9 && m > 0.3, "{m} {x}");
        // The truth is exact; on the sample directions the BSV at the probe's direction is the
        // sample itself, so replacing the interpolation changes nothing.
        assert_eq!(row["truth_rel_err_mean"].as_f64(), Some(0.0));
        assert_eq!(
            row["occ_rel_l2_exact_k_mean"],
            row["occ_rel_l2_exact_dir_mean"]
        );
        // The widened table range keeps both radii off the end nodes.
        let off = row["k_node_offset"].as_f64().unwrap();
        assert!(off > 0.0 && off <= 0.5, "{off}");
    }
    // The closed-form prediction at 1.3 r, α = 45°, N = 4 (crates/field/tests/extrapolation.rs).
    assert!((rows[0]["occ_rel_l2_mean"].as_f64().unwrap() - 0.804259).abs() < 1e-5);
    // Sampling on an inflated sphere removes the on-surface samples and the error drops.
    let w = json(&[
        "probe",
        "--mesh",
        "sphere",
        "--order",
        "4",
        "--alpha-deg",
        "45",
        "--layout",
        "fib:40",
        "--radii",
        "1.3,2",
        "--sampling-radius",
        "1.2",
    ]);
    assert_eq!(w["on_surface_samples"], 0);
    assert!(
        w["rows"][0]["occ_rel_l2_mean"].as_f64().unwrap()
            < rows[0]["occ_rel_l2_mean"].as_f64().unwrap()
    );
    assert!(w["rows"][0]["occ_rel_l2_on_surface_mean"].is_null());
}

#[test]
fn probe_on_a_mesh_and_csv() {
    let v = json(&[
        "probe",
        "--mesh",
        "duck",
        "--order",
        "3",
        "--alpha-deg",
        "30",
        "--layout",
        "cube:4",
        "--hemisphere-res",
        "12",
    ]);
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for r in rows {
        assert_eq!(r["probes"], 96);
        let inside = r["inside_count"].as_u64().unwrap();
        if inside < 96 {
            assert!(r["vis_rel_l2_mean"].as_f64().unwrap().is_finite());
        }
    }
    let out = shscale(&[
        "probe",
        "--mesh",
        "duck",
        "--order",
        "2",
        "--alpha-deg",
        "45",
        "--layout",
        "fib:20",
        "--hemisphere-res",
        "8",
        "--format",
        "csv",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert!(
        header.starts_with(
            "mesh,order,alpha_deg,layout,hemisphere_res,sampling_radius,k_count,radius,k,"
        ),
        "{header}"
    );
    assert!(header.contains("occ_rel_l2_mean") && header.contains("vis_rel_l2_mean"));
    assert_eq!(lines.count(), 5);
}

#[test]
fn bad_probe_input_fails_cleanly() {
    let base = [
        "probe",
        "--mesh",
        "sphere",
        "--order",
        "4",
        "--alpha-deg",
        "45",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        base.iter().copied().chain(extra.iter().copied()).collect()
    };
    fails(&with(&["--layout", "hex:3"]), "layout");
    fails(&with(&["--sampling-radius", "0.5"]), "sampling-radius");
    fails(&with(&["--radii", "1,-2"]), "radii");
    fails(&with(&["--radii", "1,x"]), "radii");
    fails(&with(&["--k-count", "1"]), "k-count");
    fails(&with(&["--hemisphere-res", "0"]), "hemisphere-res");
    fails(
        &[
            "probe",
            "--mesh",
            "sphere",
            "--order",
            "4",
            "--alpha-deg",
            "90",
        ],
        "alpha",
    );
    fails(
        &[
            "probe",
            "--mesh",
            "sphere",
            "--order",
            "0",
            "--alpha-deg",
            "45",
        ],
        "order",
    );
    fails(
        &[
            "probe",
            "--mesh",
            "nothing_here",
            "--order",
            "4",
            "--alpha-deg",
            "45",
        ],
        "nothing_here",
    );
}

#[test]
fn probe_pretty_is_a_table_not_csv() {
    let o = shscale(&[
        "probe",
        "--mesh",
        "sphere",
        "--order",
        "4",
        "--alpha-deg",
        "45",
        "--layout",
        "fib:40",
        "--radii",
        "1.3,2",
        "--format",
        "pretty",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].starts_with("probe: sphere, order 4, α = 45°"),
        "{text}"
    );
    assert!(
        lines[1].contains("radius (×r)") && lines[1].contains("occ err mean"),
        "{text}"
    );
    // One aligned line per radius, no commas: a table, not CSV.
    let body: Vec<&&str> = lines[2..].iter().filter(|l| !l.starts_with('(')).collect();
    assert_eq!(body.len(), 2, "{text}");
    let width = |l: &str| l.chars().count();
    assert!(
        body.iter()
            .all(|l| !l.contains(',') && width(l) == width(lines[1])),
        "{text}"
    );
    assert!(body[0].trim_start().starts_with("1.3"), "{text}");
}
