//! Oracles for the extrapolated field: a configuration where the cone model is exact, and the
//! analytic sphere's on-surface failure against its closed-form prediction.

use glam::DVec3;
use shscale_field::extrapolate::{ExtrapolationKind, Extrapolator};
use shscale_field::metrics::{l2, l2_diff};
use shscale_field::*;
use shscale_geometry::{ray::UpdateStrategy, AnalyticSphere, Mesh, MeshBvh};
use shscale_scaling::{
    AngularScaling, Cone, Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily,
};
use shscale_sh::{cap_zonal, rotate_zonal, ShBasis};
use std::f64::consts::PI;

/// A flat disc of radius `a` in the plane z = 0 (a two-sided 512-gon fan).
fn disc(a: f64, n: usize) -> Mesh {
    let mut p = vec![DVec3::ZERO];
    for i in 0..n {
        let t = 2.0 * PI * i as f64 / n as f64;
        p.push(DVec3::new(a * t.cos(), a * t.sin(), 0.0));
    }
    let mut tris = Vec::new();
    for i in 0..n as u32 {
        tris.push([0, 1 + i, 1 + (i + 1) % n as u32]);
    }
    Mesh::new("disc", p, tris, false).unwrap()
}

/// Coefficients of `√(4π)e₀ − cap(A)` about the unit axis (entity frame).
fn complement_cap(basis: &ShBasis<f64>, angle: f64, axis: DVec3) -> Vec<f64> {
    let n = basis.order();
    let cap = cap_zonal(n, angle).unwrap();
    let mut v = vec![0.0; n * n];
    rotate_zonal(basis, &cap, axis.to_array(), &mut v).unwrap();
    v.iter_mut().for_each(|x| *x = -*x);
    v[0] += (4.0 * PI).sqrt();
    v
}

#[test]
fn cone_model_is_exact_for_a_disc_seen_along_its_axis() {
    // A disc of radius a centred at c, seen from its axis: the rim is the silhouette from every
    // distance, and it lies on the cone of half-angle α = 90° about the axis through c (the flat
    // disc limit tanθ_r = k tanθ_d of docs/conventions.md §3.1). So with α → 90° scaling is exact in
    // function space, and the extrapolated visibility differs from the truth only by (1) the
    // band-limiting of the sampled input (closed-form prediction below) and (2) the BSV quadrature.
    let order = 6;
    let a = 1.0;
    let mesh = disc(a, 512);
    let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
    assert!((bvh.bounding_sphere().radius - a).abs() < 1e-12);
    let h = 64;
    let sampler = VisibilitySampler::new(order, h).unwrap();
    // Samples: the +z axis (the one we probe) plus a few others for the triangulation.
    let dirs = vec![
        DVec3::Z,
        DVec3::X,
        DVec3::Y,
        -DVec3::X,
        -DVec3::Y,
        -DVec3::Z,
    ];
    let bsv = Bsv::sample_dirs(&bvh, Layout::Fibonacci { p: 6 }, dirs, &sampler, 1.0, 0.0).unwrap();
    let alpha = 90f64.to_radians() - 1e-7;
    let table = KTable::build(
        TauFamily::Cone { alpha },
        Eta::Plain,
        order,
        60,
        0.3,
        5.0,
        Spacing::Exp,
        Interp::Cubic,
    )
    .unwrap();
    let ex = Extrapolator::new(&bsv, &table);
    let basis = ShBasis::<f64>::new(order).unwrap();
    let mut m = ScalingMatrix::identity(order).unwrap();
    for k in [0.5, 0.8, 1.5, 3.0] {
        let p = DVec3::new(0.0, 0.0, k * a);
        let mut ext = vec![0.0; order * order];
        assert_eq!(ex.eval(p, &mut m, &mut ext), ExtrapolationKind::Scaled);
        // Truth: the disc hides the cap of half-angle atan(a/d) about −z.
        let truth = complement_cap(&basis, (a / (k * a)).atan(), -DVec3::Z);
        // Prediction of the band-limiting error alone: M_k applied to the exact projected input.
        let tau = Cone::new(k, alpha).unwrap();
        let m_exact = ScalingMatrix::compute(&tau, Eta::Plain, order).unwrap();
        let input = complement_cap(&basis, PI / 4.0, -DVec3::Z);
        // (The input cap angle π/4 maps to τ_k⁻¹(π/4) = atan(1/k): exact in function space.)
        assert!((tau.inverse(PI / 4.0) - (1.0 / k).atan()).abs() < 1e-6);
        let f = LocalFrame::toward(p, DVec3::ZERO);
        let rot = shscale_sh::ShRotation::new(order, &f.matrix()).unwrap();
        let mut local = vec![0.0; input.len()];
        rot.apply_inverse(&input, &mut local).unwrap();
        let mut scaled = vec![0.0; input.len()];
        m_exact.apply(&local, &mut scaled).unwrap();
        let mut predicted = vec![0.0; input.len()];
        rot.apply(&scaled, &mut predicted).unwrap();
        let band_limit = l2_diff(&predicted, &truth);
        // BSV error, measured against the exact input; it reaches the output through the table's
        // M (the Frobenius norm bounds the spectral norm; rotations are orthogonal). The table's
        // interpolation error enters as (M_table − M_exact)·input, computed exactly.
        let bsv_err = l2_diff(&bsv.samples[0].coeffs, &input);
        let mut m_table = ScalingMatrix::identity(order).unwrap();
        table.lookup(k, &mut m_table).unwrap();
        let m_norm = l2(m_table.values()) * 2f64.sqrt();
        let mut via_table = vec![0.0; input.len()];
        m_table.apply(&local, &mut via_table).unwrap();
        let table_err = l2_diff(&via_table, &scaled);
        let err = l2_diff(&ext, &truth);
        let bound = band_limit + m_norm * bsv_err + table_err;
        println!("disc k={k}: ‖ext − truth‖ = {err:.4e} ≤ band-limiting {band_limit:.4e} + BSV {:.2e} + table {table_err:.1e}", m_norm * bsv_err);
        assert!(err <= bound, "k={k}: {err:e} > {bound:e}");
        assert!(
            err >= band_limit - m_norm * bsv_err - table_err,
            "k={k}: below the band-limiting floor"
        );
        assert!(err < 0.5 * l2(&truth), "k={k}: not even close");
    }
}

#[test]
fn full_field_converges_to_the_truth_as_shells_and_samples_increase() {
    use shscale_field::evaluator::{
        FieldInterp, FullField, RayTraced, ShellSpacing, Shells, VisibilityField,
    };
    use shscale_field::probe::sphere_truth;
    let order = 4;
    let sphere = AnalyticSphere::unit();
    let sampler = VisibilitySampler::new(order, 32).unwrap();
    let basis = ShBasis::<f64>::new(order).unwrap();
    // Query points off the shells and off the sample directions.
    let pts: Vec<DVec3> = shscale_sh::DirectionSet::fibonacci_sphere(37)
        .dirs
        .iter()
        .enumerate()
        .map(|(i, d)| DVec3::from_array(*d) * (1.15 + 5.0 * ((i * 7919) % 37) as f64 / 37.0))
        .collect();
    let mean_err = |f: &dyn VisibilityField| {
        let mut out = vec![0.0; order * order];
        pts.iter()
            .map(|p| {
                f.eval(*p, &mut out);
                l2_diff(&out, &sphere_truth(&basis, &sphere.sphere, *p).unwrap())
            })
            .sum::<f64>()
            / pts.len() as f64
    };
    let shells = |count| Shells {
        count,
        spacing: ShellSpacing::Exp,
        interp: FieldInterp::Barycentric,
        ..Shells::PAPERS
    };
    let coarse =
        FullField::build(&sphere, Layout::Fibonacci { p: 30 }, &sampler, &shells(4)).unwrap();
    let medium =
        FullField::build(&sphere, Layout::Fibonacci { p: 120 }, &sampler, &shells(8)).unwrap();
    let fine =
        FullField::build(&sphere, Layout::Fibonacci { p: 480 }, &sampler, &shells(16)).unwrap();
    let (ec, em, ef) = (mean_err(&coarse), mean_err(&medium), mean_err(&fine));
    let rt = mean_err(&RayTraced {
        occ: &sphere,
        sampler: &sampler,
    });
    println!("full field mean ‖err‖: 4×30 {ec:.3e}, 8×120 {em:.3e}, 16×480 {ef:.3e}; ray traced {rt:.3e}");
    assert!(em < ec && ef < em, "no convergence: {ec} {em} {ef}");
    // The papers' construction (uniform shells over [1, 8], trilinear on a lat-long grid)
    // converges too.
    let papers = |rows, count| {
        let shells = Shells {
            count,
            ..Shells::PAPERS
        };
        let l = Layout::LatLong {
            rows,
            cols: 2 * rows,
        };
        mean_err(&FullField::build(&sphere, l, &sampler, &shells).unwrap())
    };
    let (pc, pm, pf) = (papers(6, 4), papers(12, 8), papers(24, 16));
    println!("papers' field mean ‖err‖: 4×6x12 {pc:.3e}, 8×12x24 {pm:.3e}, 16×24x48 {pf:.3e}");
    assert!(pm < pc && pf < pm, "no convergence: {pc} {pm} {pf}");
    // The fine full field approaches the ray tracer's own quadrature error.
    assert!(
        ef < 4.0 * rt.max(1e-3),
        "fine field {ef} vs ray traced {rt}"
    );
    // Beyond the outermost shell: unoccluded.
    let mut out = vec![0.0; order * order];
    fine.eval(DVec3::new(0.0, 0.0, 9.0), &mut out);
    assert!((out[0] - (4.0 * PI).sqrt()).abs() < 1e-15 && out[1..].iter().all(|v| *v == 0.0));
    assert_eq!(fine.shells(), 16);
}

#[test]
fn queries_at_the_centre_are_clamped_not_panicking() {
    let order = 3;
    let sphere = AnalyticSphere::unit();
    let sampler = VisibilitySampler::new(order, 8).unwrap();
    let bsv = Bsv::sample(&sphere, Layout::Fibonacci { p: 30 }, &sampler, 1.2, 0.0).unwrap();
    let table = KTable::build(
        TauFamily::Cone { alpha: 0.7 },
        Eta::Plain,
        order,
        5,
        0.5,
        2.0,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap();
    let ex = Extrapolator::new(&bsv, &table);
    let mut m = ScalingMatrix::identity(order).unwrap();
    let mut out = vec![0.0; order * order];
    assert_eq!(
        ex.eval(DVec3::ZERO, &mut m, &mut out),
        ExtrapolationKind::ClampedBelow
    );
    assert!(out.iter().all(|v| v.is_finite()));
    assert_eq!(
        ex.eval(DVec3::new(0.0, 0.0, 1e-300), &mut m, &mut out),
        ExtrapolationKind::ClampedBelow
    );
    assert!(out.iter().all(|v| v.is_finite()));
}
