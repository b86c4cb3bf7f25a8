//! Oracle tests of the SH core: quadrature orthonormality, the addition theorem, rotation against
//! re-projection, Gaunt coefficients and caps against brute-force quadrature.

use shscale_sh::rotation::mat_mul;
use shscale_sh::*;
use std::f64::consts::PI;

/// Max |⟨Y_i, Y_j⟩ − δ_ij| over rows `i` in `rows` and all `j`, with an exact product quadrature.
fn orthonormality_error_rows<T: Real>(order: usize, rows: &[usize]) -> f64 {
    let basis = ShBasis::<T>::new(order).unwrap();
    let set = DirectionSet::gauss_sphere_for_order(order);
    let nn = order * order;
    let mut gram = vec![0.0f64; rows.len() * nn];
    let mut y = vec![T::zero(); nn];
    let mut y64 = vec![0.0f64; nn];
    for (d, &w) in set.dirs.iter().zip(&set.weights) {
        basis.eval(d.map(T::c), &mut y);
        y64.iter_mut().zip(&y).for_each(|(a, b)| *a = b.f64());
        for (r, &i) in rows.iter().enumerate() {
            let wi = w * y64[i];
            for (g, yj) in gram[r * nn..(r + 1) * nn].iter_mut().zip(&y64) {
                *g += wi * yj;
            }
        }
    }
    let mut worst = 0.0f64;
    for (r, &i) in rows.iter().enumerate() {
        for j in 0..nn {
            let want = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((gram[r * nn + j] - want).abs());
        }
    }
    worst
}

/// Max |⟨Y_i, Y_j⟩ − δ_ij| over all pairs.
fn orthonormality_error<T: Real>(order: usize) -> f64 {
    orthonormality_error_rows::<T>(order, &(0..order * order).collect::<Vec<_>>())
}

#[test]
fn orthonormal_at_order_32_f64_and_f32() {
    const TOL_F64: f64 = 1e-12;
    // f32: values carry ~6e-8 relative error each; sums of ~N² terms of size O(1).
    const TOL_F32: f64 = 1e-4;
    let e64 = orthonormality_error::<f64>(32);
    let e32 = orthonormality_error::<f32>(32);
    println!("orthonormality N=32: f64 max error {e64:.3e}, f32 max error {e32:.3e}");
    assert!(e64 < TOL_F64, "f64 orthonormality error {e64:e}");
    assert!(e32 < TOL_F32, "f32 orthonormality error {e32:e}");
}

#[test]
fn order_64_is_finite_and_orthonormal() {
    const TOL: f64 = 1e-11;
    // All of the top band (the most error-prone) plus every 97th function, against all 4096.
    let order = 64;
    let mut rows: Vec<usize> = ((order - 1) * (order - 1)..order * order).collect();
    rows.extend((0..(order - 1) * (order - 1)).step_by(97));
    let e = orthonormality_error_rows::<f64>(order, &rows);
    println!("orthonormality N=64: f64 max error {e:.3e}");
    assert!(e < TOL, "N=64 orthonormality error {e:e}");
    // At the poles and near them nothing is NaN or infinite, even at the maximum order.
    let b = ShBasis::<f64>::new(MAX_ORDER).unwrap();
    let b32 = ShBasis::<f32>::new(MAX_ORDER).unwrap();
    for d in [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1e-300, 0.0, 1.0],
        [1.0, 0.0, 0.0],
    ] {
        assert!(
            b.values(d).iter().all(|v| v.is_finite()),
            "non-finite at {d:?}"
        );
        assert!(
            b32.values(d.map(|c| c as f32))
                .iter()
                .all(|v| v.is_finite()),
            "f32 non-finite at {d:?}"
        );
    }
    // Exact pole values: only m = 0 survives, Y_l^0(+z) = √((2l+1)/4π), Y_l^0(−z) = (−1)^l √((2l+1)/4π).
    let up = b.values([0.0, 0.0, 1.0]);
    let down = b.values([0.0, 0.0, -1.0]);
    for l in 0..MAX_ORDER {
        let want = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
        for m in -(l as i64)..=(l as i64) {
            let (u, dn) = (up[sh_index(l, m)], down[sh_index(l, m)]);
            if m == 0 {
                let sign = if l % 2 == 0 { 1.0 } else { -1.0 };
                assert!((u - want).abs() < 1e-13 * want, "l={l}: {u} vs {want}");
                assert!((dn - sign * want).abs() < 1e-13 * want, "l={l}: {dn}");
            } else {
                assert_eq!(u, 0.0);
                assert_eq!(dn, 0.0);
            }
        }
    }
}

/// Legendre polynomial P_l(x) by the unnormalised recurrence (independent of the crate's code).
fn legendre(l: usize, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if l == 0 {
        return 1.0;
    }
    for k in 2..=l {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    p1
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

#[test]
fn addition_theorem() {
    // Σ_m Y_l^m(a) Y_l^m(b) = (2l+1)/(4π) P_l(a·b); tolerance relative to (2l+1)/(4π).
    const TOL: f64 = 1e-12;
    let order = 40;
    let b = ShBasis::<f64>::new(order).unwrap();
    let pairs = [
        ([0.3, -0.4, 0.8], [0.9, 0.1, -0.2]),
        ([0.0, 0.0, 1.0], [0.6, 0.0, 0.8]),
        ([1.0, 1.0, 1.0], [1.0, 1.0, 1.0001]),
        ([-0.2, 0.7, -0.1], [0.3, -0.2, -0.9]),
    ];
    for (a, c) in pairs {
        let (a, c) = (unit(a), unit(c));
        let (ya, yc) = (b.values(a), b.values(c));
        let cosg = a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
        for l in 0..order {
            let s: f64 = (l * l..(l + 1) * (l + 1)).map(|i| ya[i] * yc[i]).sum();
            let want = (2 * l + 1) as f64 / (4.0 * PI) * legendre(l, cosg);
            let scale = (2 * l + 1) as f64 / (4.0 * PI);
            assert!(
                (s - want).abs() < TOL * scale,
                "l={l}: {s} vs {want}, err {:e}",
                (s - want).abs()
            );
        }
    }
}

fn apply3(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2])
}

fn transpose(r: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]))
}

/// A smooth non-symmetric test function.
fn test_fn(d: [f64; 3]) -> f64 {
    (1.3 * d[0] - 0.4 * d[1] * d[2]).exp() + d[0] * d[1] * d[1] + 0.3 * d[2].powi(3)
}

#[test]
fn rotation_matches_reprojection_of_the_rotated_function() {
    // g(ω) = f(R⁻¹ω): project f, rotate, compare with the projection of g. Both are exact
    // projections of band-limited data once f is band-limited, so use f's own projection.
    const TOL: f64 = 1e-12;
    for order in [1usize, 2, 4, 8, 12] {
        let b = ShBasis::<f64>::new(order).unwrap();
        let set = DirectionSet::gauss_sphere_for_order(order);
        let f = project_fn(
            &b,
            &DirectionSet::gauss_sphere_for_order(order + 10),
            test_fn,
        );
        let fb = |d: [f64; 3]| reconstruct(&b, &f, d).unwrap();
        for (a, bb, c) in [
            (0.3, 1.1, -0.7),
            (2.0, 0.0, 0.5),
            (0.0, PI, 0.0),
            (-1.0, 2.5, 3.0),
        ] {
            let r = euler_zyz(a, bb, c);
            let rinv = transpose(&r);
            let want = project_fn(&b, &set, |d| fb(apply3(&rinv, d)));
            let rot = ShRotation::new(order, &r).unwrap();
            let mut got = vec![0.0; order * order];
            rot.apply(&f, &mut got).unwrap();
            let err = got
                .iter()
                .zip(&want)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            assert!(err < TOL, "N={order} euler=({a},{bb},{c}): max err {err:e}");
        }
    }
}

#[test]
fn euler_path_equals_explicit_matrix_including_gimbal_cases() {
    const TOL: f64 = 1e-12;
    for order in [1usize, 2, 4, 9] {
        let er = EulerRotator::<f64>::new(order).unwrap();
        let x: Vec<f64> = (0..order * order)
            .map(|i| ((i * 31) % 13) as f64 / 6.0 - 1.0)
            .collect();
        for (a, b, c) in [
            (0.3, 1.1, -0.7),
            (2.0, 0.0, 0.5),
            (0.4, PI, -1.3),
            (-1.0, 2.5, 3.0),
            (0.0, 1e-13, 0.2),
        ] {
            let r = euler_zyz(a, b, c);
            let mut want = vec![0.0; x.len()];
            ShRotation::new(order, &r)
                .unwrap()
                .apply(&x, &mut want)
                .unwrap();
            let mut got = vec![0.0; x.len()];
            er.apply(&r, &x, &mut got).unwrap();
            let err = got
                .iter()
                .zip(&want)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
            assert!(err < TOL, "N={order} euler=({a},{b},{c}): {err:e}");
        }
    }
}

#[test]
fn rotation_composition_inverse_and_f32() {
    const TOL: f64 = 1e-12;
    const TOL_F32: f64 = 2e-5;
    let order = 10;
    let ra = euler_zyz(0.4, 1.2, -0.3);
    let rb = euler_zyz(-1.0, 0.7, 2.2);
    let da = ShRotation::new(order, &ra).unwrap();
    let db = ShRotation::new(order, &rb).unwrap();
    let dab = ShRotation::new(order, &mat_mul(&ra, &rb)).unwrap();
    let x: Vec<f64> = (0..order * order)
        .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
        .collect();
    let mut t = vec![0.0; x.len()];
    let mut ab = vec![0.0; x.len()];
    let mut direct = vec![0.0; x.len()];
    db.apply(&x, &mut t).unwrap();
    da.apply(&t, &mut ab).unwrap();
    dab.apply(&x, &mut direct).unwrap();
    let err = ab
        .iter()
        .zip(&direct)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(err < TOL, "D(A)D(B) vs D(AB): {err:e}");
    // Inverse: Dᵀ undoes D, and D(Rᵀ) equals Dᵀ.
    let mut back = vec![0.0; x.len()];
    da.apply_inverse(
        &{
            let mut y = vec![0.0; x.len()];
            da.apply(&x, &mut y).unwrap();
            y
        },
        &mut back,
    )
    .unwrap();
    let err = back
        .iter()
        .zip(&x)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(err < TOL, "DᵀD x vs x: {err:e}");
    let dinv = ShRotation::new(order, &transpose(&ra)).unwrap().to_dense();
    let dd = da.to_dense();
    for i in 0..x.len() {
        for j in 0..x.len() {
            assert!(
                (dinv[i][j] - dd[j][i]).abs() < TOL,
                "D(Rᵀ) != D(R)ᵀ at {i},{j}"
            );
        }
    }
    // f32 rotation agrees with f64 within single-precision error.
    let r32 = ra.map(|row| row.map(|v| v as f32));
    let d32 = ShRotation::<f32>::new(order, &r32).unwrap().to_dense();
    let worst = (0..x.len())
        .flat_map(|i| (0..x.len()).map(move |j| (i, j)))
        .map(|(i, j)| (d32[i][j] as f64 - dd[i][j]).abs())
        .fold(0.0, f64::max);
    println!("f32 rotation N={order}: max element error {worst:.3e}");
    assert!(worst < TOL_F32, "f32 rotation error {worst:e}");
}

#[test]
fn zonal_fast_path_equals_full_rotation() {
    const TOL: f64 = 1e-13;
    let order = 9;
    let b = ShBasis::<f64>::new(order).unwrap();
    let zonal: Vec<f64> = (0..order).map(|l| 1.0 / (1.0 + l as f64)).collect();
    let mut full = vec![0.0; order * order];
    for (l, z) in zonal.iter().enumerate() {
        full[sh_index(l, 0)] = *z;
    }
    // Rz(φ)·Ry(θ) maps +z onto the axis (θ, φ).
    let (theta, phi) = (1.1, -0.6);
    let r = euler_zyz(phi, theta, 0.0);
    let axis = apply3(&r, [0.0, 0.0, 1.0]);
    let mut want = vec![0.0; order * order];
    ShRotation::new(order, &r)
        .unwrap()
        .apply(&full, &mut want)
        .unwrap();
    let mut got = vec![0.0; order * order];
    rotate_zonal(&b, &zonal, axis, &mut got).unwrap();
    let err = got
        .iter()
        .zip(&want)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(err < TOL, "zonal fast path: {err:e}");
}

#[test]
fn gaunt_matches_brute_force_quadrature() {
    const TOL: f64 = 1e-13;
    for order in [2usize, 4, 6] {
        let g = GauntTensor::<f64>::new(order).unwrap();
        let b = ShBasis::<f64>::new(order).unwrap();
        // Brute force: product quadrature exact for degree 3(N−1), on a grid in θ (not cosθ) —
        // a different rule: Gauss–Legendre in cosθ with many nodes over the full triple sum.
        let set = DirectionSet::gauss_sphere(3 * order + 2, 3 * order + 2);
        let nn = order * order;
        let mut brute = vec![0.0; nn * nn * nn];
        let mut y = vec![0.0; nn];
        for (d, &w) in set.dirs.iter().zip(&set.weights) {
            b.eval(*d, &mut y);
            for i in 0..nn {
                for j in 0..nn {
                    let wij = w * y[i] * y[j];
                    for k in 0..nn {
                        brute[(i * nn + j) * nn + k] += wij * y[k];
                    }
                }
            }
        }
        let mut worst = 0.0f64;
        for i in 0..nn {
            for j in 0..nn {
                for k in 0..nn {
                    worst = worst.max((g.get(i, j, k) - brute[(i * nn + j) * nn + k]).abs());
                }
            }
        }
        println!(
            "Gaunt N={order}: {} stored entries, max error vs brute force {worst:.3e}",
            g.entries().len()
        );
        assert!(worst < TOL, "Gaunt N={order}: {worst:e}");
        // G_{0jk} = δ_jk / √(4π).
        assert!((g.get(0, 3, 3) - 0.5 / PI.sqrt()).abs() < 1e-15);
    }
}

#[test]
fn triple_product_matches_projection_of_the_pointwise_product() {
    const TOL: f64 = 1e-12;
    let order = 5;
    let b = ShBasis::<f64>::new(order).unwrap();
    let fine = DirectionSet::gauss_sphere_for_order(order + 8);
    let f = project_fn(&b, &fine, test_fn);
    let h = project_fn(&b, &fine, |d| 1.0 + d[2] - d[0] * d[1]);
    let g = GauntTensor::<f64>::new(order).unwrap();
    let mut got = vec![0.0; order * order];
    g.product(&f, &h, &mut got).unwrap();
    let want = project_fn(&b, &DirectionSet::gauss_sphere_for_order(2 * order), |d| {
        reconstruct(&b, &f, d).unwrap() * reconstruct(&b, &h, d).unwrap()
    });
    let err = got
        .iter()
        .zip(&want)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(err < TOL, "triple product: {err:e}");
}

/// ∫ g(θ) sinθ dθ over [a, b] by composite Gauss–Legendre in θ (independent of the crate).
fn integrate_theta(mut g: impl FnMut(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let gl = GaussLegendre::new(20);
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|p| {
            gl.on(a + p as f64 * h, a + (p + 1) as f64 * h)
                .map(|(t, w)| w * g(t) * t.sin())
                .sum::<f64>()
        })
        .sum()
}

#[test]
fn cap_coefficients_match_quadrature_and_extremes() {
    const TOL: f64 = 1e-13;
    let order = 24;
    let leg = shscale_sh::legendre::Legendre::<f64>::new(order).unwrap();
    let mut p = vec![0.0; order * (order + 1) / 2];
    for deg in [0.0f64, 1e-4, 5.0, 30.0, 89.0, 90.0, 135.0, 180.0] {
        let a = deg.to_radians();
        let c = cap_coeffs(order, a).unwrap();
        for l in 0..order {
            // c_l = 2π ∫_0^A P̄_l^0(cosθ) sinθ dθ.
            let want = if a == 0.0 {
                0.0
            } else {
                2.0 * PI
                    * integrate_theta(
                        |t| {
                            leg.eval_theta(t, &mut p);
                            p[l * (l + 1) / 2]
                        },
                        0.0,
                        a,
                        64,
                    )
            };
            let got = c[sh_index(l, 0)];
            let scale = want.abs().max(1e-300);
            let err = (got - want).abs();
            assert!(
                err < TOL || err / scale < 1e-9,
                "cap A={deg}° l={l}: {got} vs {want}"
            );
        }
    }
    // Full sphere: √(4π) and zeros; tiny cap: c_l ≈ K_l · area with area = 2π(1−cos A).
    let full = cap_coeffs(order, PI).unwrap();
    assert!((full[0] - (4.0 * PI).sqrt()).abs() < 1e-14);
    assert!(full[1..].iter().all(|v| v.abs() < 1e-13));
    let a: f64 = 1e-6;
    let tiny = cap_zonal_rel(order, a);
    assert!(tiny < 1e-9, "tiny cap relative error {tiny:e}");
    assert!(cap_coeffs(order, -0.1).is_err());
    assert!(cap_coeffs(order, 3.2).is_err());
    assert!(cap_coeffs(0, 1.0).is_err());
}

/// Worst relative deviation of a tiny cap's coefficients from the small-angle limit
/// `c_l ≈ √((2l+1)/4π) · 2π(1 − cos A) · (1 − l(l+1)A²/8)`.
fn cap_zonal_rel(order: usize, a: f64) -> f64 {
    let z = shscale_sh::cap::cap_zonal(order, a).unwrap();
    let area = 4.0 * PI * (0.5 * a).sin().powi(2);
    (0..order)
        .map(|l| {
            let lf = l as f64;
            let want = ((2.0 * lf + 1.0) / (4.0 * PI)).sqrt()
                * area
                * (1.0 - lf * (lf + 1.0) * a * a / 8.0);
            ((z[l] - want) / want).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn clamped_cosine_matches_quadrature_and_irradiance_of_constant() {
    const TOL: f64 = 1e-13;
    let order = 16;
    let z = clamped_cosine_zonal(order);
    let leg = shscale_sh::legendre::Legendre::<f64>::new(order).unwrap();
    let mut p = vec![0.0; order * (order + 1) / 2];
    for l in 0..order {
        let want = 2.0
            * PI
            * integrate_theta(
                |t| {
                    leg.eval_theta(t, &mut p);
                    p[l * (l + 1) / 2] * t.cos()
                },
                0.0,
                PI / 2.0,
                32,
            );
        assert!((z[l] - want).abs() < TOL, "lobe l={l}: {} vs {want}", z[l]);
    }
    // Constant radiance 1: E = π for any normal. Radiance (1 + z): E(+z) = π + 2π/3.
    let mut light = vec![0.0; 16];
    light[0] = (4.0 * PI).sqrt();
    let e = irradiance(&light, unit([0.2, -0.5, 0.3])).unwrap();
    assert!((e - PI).abs() < 1e-13, "E = {e}");
    light[2] = (4.0 * PI / 3.0).sqrt();
    let e = irradiance(&light, [0.0, 0.0, 1.0]).unwrap();
    assert!((e - (PI + 2.0 * PI / 3.0)).abs() < 1e-13, "E = {e}");
}
