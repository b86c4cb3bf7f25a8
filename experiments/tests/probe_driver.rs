//! The probe's driver (`shscale_experiments::probe::driver`) against oracles: the analytic
//! sphere's on-surface failure against its closed-form prediction, the probe's columns against
//! their closed forms, and a run on a shared base equal to a fresh one.

use shscale_experiments::probe::driver::{once, probe};
use shscale_field::metrics::{l2, l2_diff, occ_rel_l2};
use shscale_field::probe::ProbeSpec;
use shscale_field::*;
use shscale_geometry::AnalyticSphere;
use shscale_scaling::{Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily};
use std::f64::consts::PI;

#[test]
fn sphere_on_surface_error_matches_the_closed_form_prediction() {
    // Every sample on the sphere's surface sees exactly half of it occluded; the truth at d = k·r
    // is the cap asin(1/k). Prediction: occ_rel_l2 = ‖M_k·cap(π/2) − cap(asin 1/k)‖ / ‖cap(asin 1/k)‖
    // (all zonal in the local frame; M maps the constant to itself, so complements cancel).
    let order = 4;
    let alpha = 45f64.to_radians();
    let spec = ProbeSpec {
        order,
        alpha,
        layout: Layout::parse("fib:60").unwrap(),
        hemisphere_res: 32,
        sampling_radius: 1.0,
        radii: vec![1.3, 2.0],
        k_count: 40,
        k_spacing: shscale_scaling::Spacing::Exp,
        k_interp: shscale_scaling::Interp::Linear,
        on_surface_eps: 1e-6,
        probe_dirs: shscale_field::probe::ProbeDirs::Samples,
        ..Default::default()
    };
    let sphere = AnalyticSphere::unit();
    let res = probe(&sphere, Some(sphere.sphere), &spec).unwrap();
    assert_eq!(res.on_surface_samples, 60);
    // The table's interpolation error enters the probe but not the prediction, so the
    // prediction uses the same table.
    let (k_min, k_max) = shscale_field::probe::table_range(&spec);
    let table = KTable::build(
        TauFamily::Cone { alpha },
        Eta::Plain,
        order,
        40,
        k_min,
        k_max,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap();
    for row in &res.rows {
        let mut m = ScalingMatrix::identity(order).unwrap();
        table.lookup(row.k, &mut m).unwrap();
        let src = shscale_sh::cap_coeffs(order, PI / 2.0).unwrap();
        let want = shscale_sh::cap_coeffs(order, (1.0 / row.k).asin()).unwrap();
        let mut got = vec![0.0; src.len()];
        m.apply(&src, &mut got).unwrap();
        let predicted = l2_diff(&got, &want) / l2(&want);
        let measured = row.occ_rel_l2_mean.unwrap();
        println!(
            "sphere ρ={}: occ_rel_l2 measured {measured:.6}, predicted {predicted:.6}",
            row.radius
        );
        assert_eq!(row.on_surface_count, Some(60));
        assert!(
            (measured - predicted).abs() < 1e-9,
            "ρ={}: {measured} vs {predicted}",
            row.radius
        );
        assert!(
            (row.occ_rel_l2_max.unwrap() - measured).abs() < 1e-9,
            "every sample is alike"
        );
        // The failure is large: this is the case the papers warn about.
        assert!(measured > 0.3);
    }
    // Inflating the sampling sphere is the mitigation: errors drop.
    let inflated = probe(
        &sphere,
        Some(sphere.sphere),
        &ProbeSpec {
            sampling_radius: 1.2,
            radii: vec![1.3, 2.0],
            ..spec.clone()
        },
    )
    .unwrap();
    assert_eq!(inflated.on_surface_samples, 0);
    for (a, b) in res.rows.iter().zip(&inflated.rows) {
        assert!(
            b.occ_rel_l2_mean.unwrap() < a.occ_rel_l2_mean.unwrap(),
            "ρ={}",
            a.radius
        );
    }
    // Inside the sphere the probes are excluded and counted.
    let inside = probe(
        &sphere,
        Some(sphere.sphere),
        &ProbeSpec {
            radii: vec![0.5],
            ..spec
        },
    )
    .unwrap();
    assert_eq!(inside.rows[0].inside_count, 60);
    assert!(inside.rows[0].occ_rel_l2_mean.is_none());
    let _ = occ_rel_l2;
}

/// Sharing the BSV and truth across runs (the runner's groups) changes no number: a run on a
/// shared base equals a run from scratch, for several α and K on one base; a base built for other
/// sampling parameters is refused.
#[test]
fn probe_on_a_shared_base_equals_a_fresh_probe() {
    use shscale_field::probe::probe_base;
    let mesh = shscale_geometry::bundled::load("duck").unwrap();
    let occ =
        shscale_geometry::MeshBvh::build(&mesh, shscale_geometry::ray::UpdateStrategy::Rebuild);
    let spec = |alpha_deg: f64, k_count: usize| ProbeSpec {
        order: 3,
        alpha: alpha_deg.to_radians(),
        layout: Layout::parse("fib:30").unwrap(),
        hemisphere_res: 8,
        sampling_radius: 1.1,
        radii: vec![0.8, 1.6],
        k_count,
        k_spacing: shscale_scaling::Spacing::Exp,
        k_interp: shscale_scaling::Interp::Linear,
        on_surface_eps: 1e-3,
        truth_res: 12,
        ..Default::default()
    };
    let base = probe_base(&occ, None, &spec(30.0, 10)).unwrap();
    for (a, k) in [(30.0, 10), (60.0, 10), (45.0, 25)] {
        let (shared, _) = once(&base, &spec(a, k)).unwrap();
        let fresh = probe(&occ, None, &spec(a, k)).unwrap();
        for (s, f) in shared.rows.iter().zip(&fresh.rows) {
            assert_eq!(
                (
                    s.vis_rel_l2_mean,
                    s.occ_rel_l2_mean,
                    s.occ_rel_l2_max,
                    s.inside_count
                ),
                (
                    f.vis_rel_l2_mean,
                    f.occ_rel_l2_mean,
                    f.occ_rel_l2_max,
                    f.inside_count
                ),
                "α = {a}, K = {k}, radius {}",
                s.radius
            );
        }
        assert_eq!(shared.examples.len(), fresh.examples.len());
    }
    let mut other = spec(30.0, 10);
    other.hemisphere_res = 9;
    assert!(
        once(&base, &other).is_err(),
        "a base for H = 8 used for H = 9"
    );
}

/// The probe's new columns against oracles on the analytic sphere sampled on itself:
/// - random probe directions are not the sample directions, and are reproducible by seed;
/// - the truth is closed-form (error 0), so `truth_limited_count` is 0;
/// - `band_limit_rel` equals the closed form √(1 − ‖P_N cap‖²/Ω) of the cap asin(1/k);
/// - `implausible_count` counts exactly the probes whose extrapolated Ω leaves [0, Ω_max(ρ)];
///   the clamp mitigation leaves none;
/// - α by distance (the law at the effective cap, 90° here) beats 45° at every radius > r up to 2r.
#[test]
fn probe_columns_on_the_sphere_match_their_closed_forms() {
    use shscale_field::extrapolate::Plausibility;
    use shscale_field::probe::{max_occluded_solid_angle, probe_directions, sample_bsv, ProbeDirs};
    let sphere = AnalyticSphere::unit();
    let spec = ProbeSpec {
        order: 4,
        layout: Layout::parse("fib:60").unwrap(),
        hemisphere_res: 16,
        radii: vec![1.3, 2.0],
        on_surface_eps: 1e-6,
        ..Default::default()
    };
    let bsv = sample_bsv(&sphere, &spec).unwrap();
    let dirs = probe_directions(&spec, &bsv);
    let nearest = dirs
        .iter()
        .map(|d| {
            bsv.samples
                .iter()
                .map(|s| s.dir.dot(*d))
                .fold(-1.0, f64::max)
        })
        .fold(-1.0, f64::max);
    assert!(nearest < 1.0 - 1e-9, "a random probe sits on a sample");
    assert_eq!(dirs, probe_directions(&spec, &bsv));
    let other = ProbeSpec {
        probe_dirs: ProbeDirs::Random { seed: 2 },
        ..spec.clone()
    };
    assert_ne!(dirs, probe_directions(&other, &bsv));
    let res = probe(&sphere, Some(sphere.sphere), &spec).unwrap();
    for row in &res.rows {
        assert_eq!(row.truth_rel_err_mean, Some(0.0));
        assert_eq!(row.truth_limited_count, 0);
        let cap = shscale_sh::cap_coeffs(4, (1.0 / row.radius).asin()).unwrap();
        let omega = 2.0 * PI * (1.0 - (1.0 - 1.0 / (row.radius * row.radius)).sqrt());
        let band = (1.0 - cap.iter().map(|c| c * c).sum::<f64>() / omega).sqrt();
        let got = row.band_limit_rel_mean.unwrap();
        println!(
            "ρ = {}: band_limit_rel {got:.6} vs closed form {band:.6}",
            row.radius
        );
        assert!((got - band).abs() < 1e-9, "{got} vs {band}");
        // The 45° extrapolation of the on-surface sphere claims far too much occlusion here.
        let bound = max_occluded_solid_angle(row.radius);
        let max = row.occ_solid_angle_max.unwrap();
        assert_eq!(row.implausible_count > 0, max > bound * (1.0 + 1e-9));
        assert_eq!(
            row.implausible_count, 60,
            "ρ = {}: Ω up to {max} > {bound}",
            row.radius
        );
    }
    let clamped = probe(
        &sphere,
        Some(sphere.sphere),
        &ProbeSpec {
            plausibility: Plausibility::Clamp,
            ..spec.clone()
        },
    )
    .unwrap();
    let fit = probe(
        &sphere,
        Some(sphere.sphere),
        &ProbeSpec {
            alpha_fit: true,
            ..spec.clone()
        },
    )
    .unwrap();
    assert!(
        (res.effective_cap_deg - 90.0).abs() < 0.5,
        "{}",
        res.effective_cap_deg
    );
    for ((a, c), f) in res.rows.iter().zip(&clamped.rows).zip(&fit.rows) {
        assert_eq!(c.implausible_count, 0);
        let (e45, efit) = (a.occ_rel_l2_mean.unwrap(), f.occ_rel_l2_mean.unwrap());
        println!(
            "ρ = {}: 45° {e45:.4}, α(k) = {:.2}° {efit:.4}, clamp {:.4}",
            a.radius,
            f.alpha_used_deg,
            c.occ_rel_l2_mean.unwrap()
        );
        assert!(efit < 0.5 * e45, "ρ = {}", a.radius);
        let law = 0.5 * (1.0 / a.k).acos();
        assert!(
            (f.alpha_used_deg - law.to_degrees()).abs() < 0.3,
            "{}",
            f.alpha_used_deg
        );
    }
}
