//! Sub-volumes against closed forms: a mesh of two separated spheres, split into P = 2 parts,
//! extrapolated per part with the cone law's α (exact for a centred sphere up to the order's
//! truncation) and multiplied, reproduces each sphere's exact cap and the closed form of their
//! product; one part (the whole mesh in one bounding sphere) does not.

use glam::DVec3;
use shscale_field::evaluator::VisibilityField;
use shscale_field::extrapolate::Extrapolator;
use shscale_field::metrics::{l2, l2_diff, occlusion};
use shscale_field::probe::sphere_truth;
use shscale_field::subvolume::SubVolumeField;
use shscale_field::*;
use shscale_geometry::partition::{kmeans_parts, split};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{shapes, Mesh, MeshBvh, Sphere};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
use shscale_sh::{GauntTensor, ShBasis};

/// Unit spheres centred at x = ±2.5 as one mesh.
fn two_spheres() -> (Mesh, [Sphere; 2]) {
    let a = shapes::uv_sphere(1.0, 48, 64);
    let mut m = Mesh {
        name: "two spheres".into(),
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    let mut s = Vec::new();
    for cx in [-2.5, 2.5] {
        let off = m.positions.len() as u32;
        m.positions
            .extend(a.positions.iter().map(|p| *p + DVec3::new(cx, 0.0, 0.0)));
        m.triangles
            .extend(a.triangles.iter().map(|t| t.map(|v| v + off)));
        s.push(Sphere {
            center: DVec3::new(cx, 0.0, 0.0),
            radius: 1.0,
        });
    }
    (m, [s[0], s[1]])
}

/// The parts' fields: per part a BSV on its own bounding sphere and the law's k-table.
fn parts_of(mesh: &Mesh, parts: usize, order: usize) -> (Vec<Bsv>, Vec<KTable>) {
    let labels = kmeans_parts(mesh, parts).unwrap();
    let sampler = VisibilitySampler::new(order, 32).unwrap();
    let bsvs: Vec<Bsv> = split(mesh, &labels, parts)
        .iter()
        .map(|m| {
            let b = MeshBvh::build(m, UpdateStrategy::Rebuild);
            Bsv::sample(
                &b,
                Layout::LatLong { rows: 24, cols: 48 },
                &sampler,
                1.0,
                0.0,
            )
            .unwrap()
        })
        .collect();
    let tables = bsvs
        .iter()
        .map(|b| {
            let theta0 = shscale_field::alpha::effective_cap_angle(b);
            KTable::build(
                TauFamily::ConeFit { theta0 },
                Eta::Plain,
                order,
                80,
                1.01,
                12.0,
                Spacing::Exp,
                Interp::Linear,
            )
            .unwrap()
        })
        .collect();
    (bsvs, tables)
}

#[test]
fn two_spheres_split_in_two_reproduce_their_caps_and_product() {
    let order = 8;
    let (mesh, spheres) = two_spheres();
    let basis = ShBasis::<f64>::new(order).unwrap();
    let gaunt = GauntTensor::<f64>::new(order).unwrap();
    // Receivers 1.3 radii from a sphere's centre, perpendicular to the axis through both
    // centres. From there the two caps never overlap: the near cap's half-angle is 50.3°, the
    // far one's 11.2°, and their axes are 75.4° apart (cos = 1.3 / 5.166). (Points on the far
    // side, away from the other sphere, would see it behind the near one: fully overlapping
    // caps, for which 1 − c₁ − c₂ is not the joint visibility.)
    let pts: Vec<DVec3> = [
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, -0.6, 0.8),
        DVec3::new(0.0, 0.8, -0.6),
    ]
    .iter()
    .flat_map(|d| {
        [
            spheres[0].center + 1.3 * *d,
            spheres[1].center + 1.3 * DVec3::new(-d.x, d.y, d.z),
        ]
    })
    .collect();
    let mean_err = |parts: usize| -> (f64, f64) {
        let (bsvs, tables) = parts_of(&mesh, parts, order);
        let exs: Vec<Extrapolator> = (bsvs.iter().zip(&tables))
            .map(|(b, t)| Extrapolator::new(b, t))
            .collect();
        // The part near each receiver (k = 1.3) against its sphere's exact cap (P = 2 only).
        let mut own = 0.0;
        if parts == 2 {
            for q in &pts {
                for ex in exs
                    .iter()
                    .filter(|e| (*q - e.bsv.sphere.center).length() < 2.0)
                {
                    let s = spheres
                        .iter()
                        .min_by(|a, b| {
                            (a.center - ex.bsv.sphere.center)
                                .length()
                                .total_cmp(&(b.center - ex.bsv.sphere.center).length())
                        })
                        .unwrap();
                    let exact = sphere_truth(&basis, s, *q).unwrap();
                    let mut v = vec![0.0; order * order];
                    VisibilityField::eval(ex, *q, &mut v);
                    own += l2_diff(&v, &exact) / l2(&occlusion(&exact)) / pts.len() as f64;
                }
            }
        }
        let field = SubVolumeField::new(exs, &gaunt);
        let mut err = 0.0;
        for q in &pts {
            // The joint visibility is 1 − c₁ − c₂: its projection in closed form.
            let mut occ: Vec<f64> = occlusion(&sphere_truth(&basis, &spheres[0], *q).unwrap());
            for (o, x) in occ
                .iter_mut()
                .zip(occlusion(&sphere_truth(&basis, &spheres[1], *q).unwrap()))
            {
                *o += x;
            }
            let closed = occlusion(&occ);
            let mut v = vec![0.0; order * order];
            field.eval(*q, &mut v);
            err += l2_diff(&v, &closed) / l2(&occ) / pts.len() as f64;
        }
        (own, err)
    };
    let (own, two) = mean_err(2);
    let (_, one) = mean_err(1);
    println!(
        "N = {order}: the near part against its sphere's exact cap {own:.3}; the product against the closed form {two:.3} (P = 2), {one:.3} (P = 1)"
    );
    // Tolerances: the cone law at N = 8 and k = 1.3 (docs/math.md §7: ≈ 0.08 on the analytic
    // sphere) and the tessellation, for the near part; the product adds the far part's
    // extrapolation to k ≈ 6 and the truncated product (2e-2 at N = 8).
    assert!(own < 0.15, "near part: {own}");
    assert!(two < 0.25, "product: {two}");
    assert!(one > 2.0 * two, "one part {one} vs two {two}");
}

/// Sphere sets (Ren et al. 2006): one sphere is the closed form, against a brute-force
/// quadrature of its indicator; two spheres fitted to the two-sphere mesh are those spheres,
/// their set is the product of the two exact caps near to far, and that matches the closed
/// form of the union up to the truncated product's own term where the caps are disjoint.
/// Where one sphere hides the other, the union is the near sphere's cap: there the product
/// errs and the set's quadrature does not.
#[test]
fn sphere_sets_reproduce_one_sphere_and_two_spheres_in_closed_form() {
    use shscale_field::sphereset::SphereSetField;
    use shscale_geometry::partition::fit_spheres;
    let order = 6;
    let basis = ShBasis::<f64>::new(order).unwrap();
    let gaunt = GauntTensor::<f64>::new(order).unwrap();
    let one = Sphere {
        center: DVec3::new(0.2, -0.1, 0.3),
        radius: 0.8,
    };
    let set = SphereSetField::new(&[one], &basis, &gaunt);
    // Brute force: midpoint rule on 600 θ × 1200 φ cells of 1 − [the ray meets the sphere].
    let p = DVec3::new(1.5, 1.0, 1.2);
    let (nt, np) = (600, 1200);
    let mut want = vec![0.0; order * order];
    let mut y = vec![0.0; order * order];
    for i in 0..nt {
        let th = std::f64::consts::PI * (i as f64 + 0.5) / nt as f64;
        for j in 0..np {
            let ph = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
            let w = DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            let oc = one.center - p;
            let b = oc.dot(w);
            let hit = b > 0.0 && oc.length_squared() - b * b < one.radius * one.radius;
            if !hit {
                basis.eval(w.to_array(), &mut y);
                let dw = th.sin()
                    * (std::f64::consts::PI / nt as f64)
                    * (std::f64::consts::TAU / np as f64);
                want.iter_mut().zip(&y).for_each(|(o, v)| *o += dw * v);
            }
        }
    }
    let mut got = vec![0.0; order * order];
    set.eval(p, &mut got);
    let err = l2_diff(&got, &want) / l2(&occlusion(&want));
    println!("one sphere against brute force: {err:.2e} (tolerance 5e-3)");
    assert!(err < 5e-3, "{err}");
    // Inside the sphere nothing is visible.
    set.eval(one.center + DVec3::new(0.1, 0.0, 0.0), &mut got);
    assert!(got.iter().all(|v| *v == 0.0));
    // The two-sphere mesh, fitted with P = 2: the spheres themselves; the product against
    // √(4π)e₀ − C₁ − C₂ at points where the caps do not overlap.
    let (mesh, spheres) = two_spheres();
    let labels = kmeans_parts(&mesh, 2).unwrap();
    let fits = fit_spheres(&mesh, &labels, 2);
    for s in &spheres {
        let f = fits
            .iter()
            .min_by(|a, b| {
                (a.center - s.center)
                    .length()
                    .total_cmp(&(b.center - s.center).length())
            })
            .unwrap();
        println!(
            "fitted {:?} r = {} (want {:?} r = {})",
            f.center, f.radius, s.center, s.radius
        );
        assert!((f.center - s.center).length() < 1e-9);
        // Corners on the unit sphere: the RMS distance is 1 to rounding.
        assert!((f.radius - s.radius).abs() < 1e-9);
    }
    let set = SphereSetField::new(&fits, &basis, &gaunt);
    // Receivers 1.3 radii from a centre, perpendicular to the axis (as in the sub-volumes test
    // above: the caps do not overlap, so the union's visibility is 1 − c₁ − c₂).
    let perpendicular = [
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, -0.6, 0.8),
    ];
    let mut worst = 0.0f64;
    for d in perpendicular {
        let q = spheres[0].center + 1.3 * d;
        let (v0, v1) = (
            sphere_truth(&basis, &spheres[0], q).unwrap(),
            sphere_truth(&basis, &spheres[1], q).unwrap(),
        );
        let mut occ = occlusion(&v0);
        for (o, x) in occ.iter_mut().zip(occlusion(&v1)) {
            *o += x;
        }
        let closed = occlusion(&occ);
        set.eval(q, &mut got);
        // The fitted set is the product of the two exact caps, near to far, to rounding.
        let mut exact_product = vec![0.0; order * order];
        shscale_field::subvolume::product_near_to_far(&gaunt, &[v0, v1], &mut exact_product);
        assert!(l2_diff(&got, &exact_product) < 1e-9);
        let e = l2_diff(&got, &closed) / l2(&occ);
        println!("two fitted spheres at {q:?}: against the union's closed form {e:.2e}");
        worst = worst.max(e);
    }
    // The remainder is the truncated product's own term, the projection of C₁·C₂ (zero as a
    // function): measured 1.5e-2 at N = 6 for these receivers (a 50° cap beside an 11° one);
    // it is the method's, not the fit's (the identity above holds to 1e-9).
    assert!(worst < 3e-2, "{worst}");
    // Overlapping caps: from the far side of sphere 0 the other sphere hides entirely behind
    // it, so the union's visibility is sphere 0's alone, in closed form. The truncated product
    // of the two caps misses it by the projection of the hidden cap's product with the
    // visible one; the set's joint visibility by quadrature (no products) only by the
    // quadrature's error.
    let q = spheres[0].center + DVec3::new(-1.3, 0.0, 0.0);
    let exact = sphere_truth(&basis, &spheres[0], q).unwrap();
    let occ = l2(&occlusion(&exact));
    set.eval(q, &mut got);
    let product = l2_diff(&got, &exact) / occ;
    let grid = shscale_field::sphereset::QuadratureGrid::new(&basis, 64);
    shscale_field::sphereset::SphereSetQuadrature::new(&fits, &grid).eval(q, &mut got);
    let quad = l2_diff(&got, &exact) / occ;
    println!("a hidden sphere: the product {product:.2e}, the quadrature (n = 64) {quad:.2e}");
    assert!(quad < 0.5 * product, "{quad} vs {product}");
}

/// The sphere set at a higher internal order M (products kept to band M, truncated to N once)
/// against closed forms the truncated product misses at M = N: where one sphere hides the
/// other the union is the near sphere's cap alone; where the caps are disjoint the union is
/// `√(4π)e₀ − C₁ − C₂`. Both are band-limited to N exactly, so the error left is the method's.
/// At M = N the set is the order-N product it always was (to rounding); the error falls as M
/// grows. Then many overlapping spheres — the bunny's 16 fitted spheres — against the set's
/// joint visibility by quadrature (n = 512; its change from n = 256 printed, under a fifth of
/// the error it measures):
/// M = 12 must land well under M = N there too.
#[test]
fn a_higher_internal_order_closes_the_truncated_products_gap() {
    use shscale_field::sphereset::{QuadratureGrid, SphereSetField, SphereSetQuadrature};
    let n = 4;
    let nn = n * n;
    let (_, spheres) = two_spheres();
    let near = |m: usize| {
        let basis = ShBasis::<f64>::new(m).unwrap();
        let gaunt = GauntTensor::<f64>::new(m).unwrap();
        (basis, gaunt)
    };
    let (basis_n, gaunt_n) = near(n);
    // Hidden: from the far side of sphere 0, sphere 1 is entirely behind it.
    let q_hidden = spheres[0].center + DVec3::new(-1.3, 0.0, 0.0);
    let hidden = sphere_truth(&basis_n, &spheres[0], q_hidden).unwrap();
    // Disjoint caps: perpendicular to the axis.
    let q_apart = spheres[0].center + 1.3 * DVec3::new(0.0, 1.0, 0.0);
    let (c0, c1) = (
        occlusion(&sphere_truth(&basis_n, &spheres[0], q_apart).unwrap()),
        occlusion(&sphere_truth(&basis_n, &spheres[1], q_apart).unwrap()),
    );
    let apart = occlusion(&c0.iter().zip(&c1).map(|(a, b)| a + b).collect::<Vec<_>>());
    let mut errs = Vec::new();
    for m in [n, 6, 8, 12, 16] {
        let (basis, gaunt) = near(m);
        let set = SphereSetField::new(&spheres, &basis, &gaunt);
        assert_eq!(set.internal_order(), m);
        let mut got = vec![0.0; nn];
        set.eval(q_hidden, &mut got);
        let e_hidden = l2_diff(&got, &hidden) / l2(&occlusion(&hidden));
        set.eval(q_apart, &mut got);
        let e_apart = l2_diff(&got, &apart) / l2(&occlusion(&apart));
        println!(
            "M = {m:2}: hidden sphere {e_hidden:.2e}, disjoint caps {e_apart:.2e}; a product's work: {} Gaunt entries",
            gaunt.entries().len()
        );
        errs.push((m, e_hidden, e_apart));
    }
    // M = N is the plain order-N product.
    let plain = SphereSetField::new(&spheres, &basis_n, &gaunt_n);
    let (basis4, gaunt4) = near(n);
    let again = SphereSetField::new(&spheres, &basis4, &gaunt4);
    let (mut a, mut b) = (vec![0.0; nn], vec![0.0; nn]);
    plain.eval(q_hidden, &mut a);
    again.eval(q_hidden, &mut b);
    assert!(l2_diff(&a, &b) < 1e-15);
    // The hidden sphere's error falls with every step of M (slowly: the caps are indicators,
    // whose band-limited products converge like their edges, measured 1.4e-2 at M = 4 and
    // 3.6e-3 at M = 16); the disjoint caps' falls 10× by M = 16 (not monotonically: 2.8e-3 at
    // M = 6, 4.7e-3 at 8).
    let at = |m: usize| errs.iter().find(|e| e.0 == m).unwrap();
    assert!(errs.windows(2).all(|w| w[1].1 < w[0].1), "{errs:?}");
    assert!(
        at(16).1 < 0.35 * at(4).1 && at(16).2 < 0.1 * at(4).2,
        "{errs:?}"
    );

    // Many overlapping spheres: the bunny's 16 fitted spheres.
    let mesh = shscale_geometry::bundled::load("bunny").unwrap();
    let labels = kmeans_parts(&mesh, 16).unwrap();
    let fits = shscale_geometry::partition::fit_spheres(&mesh, &labels, 16);
    let bs = mesh.bounding_sphere();
    let points: Vec<DVec3> = [
        DVec3::new(1.0, 0.2, 0.1),
        DVec3::new(-0.3, 1.0, 0.4),
        DVec3::new(0.2, -0.5, -1.0),
        DVec3::new(-1.0, -0.2, 0.3),
    ]
    .iter()
    .map(|d| bs.center + d.normalize() * 1.3 * bs.radius)
    .collect();
    let (g512, g256) = (
        QuadratureGrid::new(&basis_n, 512),
        QuadratureGrid::new(&basis_n, 256),
    );
    let (truth, coarse) = (
        SphereSetQuadrature::new(&fits, &g512),
        SphereSetQuadrature::new(&fits, &g256),
    );
    let (b12, g12) = near(12);
    let high = SphereSetField::new(&fits, &b12, &g12);
    let low = SphereSetField::new(&fits, &basis_n, &gaunt_n);
    let (mut t, mut c, mut h, mut l) = (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
    let (mut e_truth, mut e_low, mut e_high) = (0.0f64, 0.0f64, 0.0f64);
    for p in points {
        truth.eval(p, &mut t);
        coarse.eval(p, &mut c);
        low.eval(p, &mut l);
        high.eval(p, &mut h);
        let norm = l2(&occlusion(&t));
        e_truth = e_truth.max(l2_diff(&c, &t) / norm);
        e_low = e_low.max(l2_diff(&l, &t) / norm);
        e_high = e_high.max(l2_diff(&h, &t) / norm);
    }
    println!(
        "bunny, 16 spheres, 1.3r: products at M = 4 {e_low:.3}, at M = 12 {e_high:.3}; the quadrature truth's own change from n = 256 to 512 {e_truth:.1e}"
    );
    assert!(
        e_truth < 0.2 * e_high,
        "truth not converged below the error it measures: {e_truth} vs {e_high}"
    );
    assert!(e_high < 0.5 * e_low, "{e_high} vs {e_low}");
}

/// Measurement (ignored: about a minute): sphere sets combined in log space with the exact
/// exponential (`shexp::SphereSetLog`, the accuracy bound of SH exponentiation) against the
/// product chain at internal orders M = 4, 8, 12, on the bunny's and duck's fitted spheres,
/// S = 1, 2, 4, 16, 64, N = 4, 48 seeded directions × 1.1r, 1.3r, 2r, 3r; truth: the set's
/// joint visibility by quadrature (n = 256, its mean change from n = 128 printed). Mean
/// `occ_rel_l2` per cell and µs per receiver. `cargo test --release -p shscale-field --test
/// subvolumes -- --ignored --nocapture log_space`.
#[test]
#[ignore]
fn log_space_combination_against_products() {
    use shscale_field::shexp::{SphereSetLog, Window};
    use shscale_field::sphereset::{QuadratureGrid, SphereSetField, SphereSetQuadrature};
    let n = 4;
    let nn = n * n;
    let sh = |m: usize| {
        (
            ShBasis::<f64>::new(m).unwrap(),
            GauntTensor::<f64>::new(m).unwrap(),
        )
    };
    let (b4, g4) = sh(4);
    let (b8, g8) = sh(8);
    let (b12, g12) = sh(12);
    let (t256, t128) = (QuadratureGrid::new(&b4, 256), QuadratureGrid::new(&b4, 128));
    let (q4, q8) = (QuadratureGrid::new(&b4, 64), QuadratureGrid::new(&b8, 64));
    let mut rng = 0x5EEDu64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let dirs: Vec<DVec3> = (0..48)
        .map(|_| {
            let z = 2.0 * next() - 1.0;
            let phi = std::f64::consts::TAU * next();
            let s = (1.0 - z * z).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect();
    println!("| mesh | S | truth's mean change 128→256 | products M=4 | M=8 | M=12 | log M=4 ε=0.1 | ε=0.01 | ε=0.001 | log M=8 ε=0.1 | ε=0.01 | ε=0.001 | Hann M=8 ε=0.1 | ε=0.01 | Lanczos M=8 ε=0.1 | ε=0.01 | µs/receiver: products M=4, M=12, log M=8 |");
    for mesh_name in ["bunny", "duck"] {
        let mesh = shscale_geometry::bundled::load(mesh_name).unwrap();
        let bs = mesh.bounding_sphere();
        let points: Vec<DVec3> = [1.1, 1.3, 2.0, 3.0]
            .iter()
            .flat_map(|r| dirs.iter().map(move |d| bs.center + *d * r * bs.radius))
            .collect();
        for s in [1usize, 2, 4, 16, 64] {
            let fits = if s == 1 {
                vec![bs]
            } else {
                let labels = kmeans_parts(&mesh, s).unwrap();
                shscale_geometry::partition::fit_spheres(&mesh, &labels, s)
            };
            let truth = SphereSetQuadrature::new(&fits, &t256);
            let coarse = SphereSetQuadrature::new(&fits, &t128);
            let mut methods: Vec<(String, Box<dyn VisibilityField>)> = vec![
                ("p4".into(), Box::new(SphereSetField::new(&fits, &b4, &g4))),
                ("p8".into(), Box::new(SphereSetField::new(&fits, &b8, &g8))),
                (
                    "p12".into(),
                    Box::new(SphereSetField::new(&fits, &b12, &g12)),
                ),
            ];
            for (b, q, m) in [(&b4, &q4, 4), (&b8, &q8, 8)] {
                for eps in [0.1, 0.01, 0.001] {
                    methods.push((
                        format!("l{m}:{eps}"),
                        Box::new(SphereSetLog::new(&fits, b, q, eps)),
                    ));
                }
            }
            for w in [Window::Hann, Window::Lanczos] {
                for eps in [0.1, 0.01] {
                    methods.push((
                        format!("l8:{eps}:{w:?}"),
                        Box::new(SphereSetLog::new(&fits, &b8, &q8, eps).with_window(w)),
                    ));
                }
            }
            let mut sums = vec![0.0; methods.len()];
            let mut secs = vec![0.0; methods.len()];
            let (mut t, mut c, mut v) = (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
            let mut change = 0.0f64;
            let mut counted = 0;
            for p in &points {
                truth.eval(*p, &mut t);
                let norm = l2(&occlusion(&t));
                if norm == 0.0 {
                    continue;
                }
                coarse.eval(*p, &mut c);
                change += l2_diff(&c, &t) / norm;
                counted += 1;
                for (i, (_, f)) in methods.iter().enumerate() {
                    let t0 = std::time::Instant::now();
                    f.eval(*p, &mut v);
                    secs[i] += t0.elapsed().as_secs_f64();
                    sums[i] += l2_diff(&v, &t) / norm;
                }
            }
            let m: Vec<String> = sums
                .iter()
                .map(|x| format!("{:.3}", x / counted as f64))
                .collect();
            let us = |i: usize| 1e6 * secs[i] / counted as f64;
            println!(
                "| {mesh_name} | {s} | {:.1e} | {} | {:.1}, {:.1}, {:.1} |",
                change / counted as f64,
                m.join(" | "),
                us(0),
                us(2),
                us(8)
            );
        }
    }
}
