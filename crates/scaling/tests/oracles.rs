//! Oracle tests of angular scaling functions, scaling matrices and k-tables.

use shscale_scaling::*;
use shscale_sh::{cap_coeffs, sh_index, sh_lm, GaussLegendre, ShBasis};
use std::f64::consts::PI;

const DEG: f64 = PI / 180.0;

fn cone(k: f64, alpha_deg: f64) -> Cone {
    Cone::new(k, alpha_deg * DEG).unwrap()
}

fn thetas() -> impl Iterator<Item = f64> {
    (0..=200).map(|i| PI * i as f64 / 200.0)
}

#[test]
fn cone_tau_identities() {
    const TOL: f64 = 1e-13;
    for alpha in [1.0, 20.0, 45.0, 70.0, 89.0] {
        let id = cone(1.0, alpha);
        for t in thetas() {
            assert!((id.tau(t) - t).abs() < TOL, "τ_1 ≠ id at α={alpha} θ={t}");
        }
        // Fixed point θ = π − α.
        for k in [1e-3, 0.3, 2.0, 50.0] {
            let f = PI - alpha * DEG;
            assert!(
                (cone(k, alpha).tau(f) - f).abs() < 1e-12,
                "fixed point α={alpha} k={k}"
            );
        }
        // Group law τ_{k1}∘τ_{k2} = τ_{k1 k2} and τ_k⁻¹ = τ_{1/k}; inverse through the trait.
        for (k1, k2) in [(0.5, 3.0), (2.0, 1.7), (0.2, 0.4)] {
            let (a, b, ab) = (cone(k1, alpha), cone(k2, alpha), cone(k1 * k2, alpha));
            for t in thetas() {
                let e = (a.tau(b.tau(t)) - ab.tau(t)).abs();
                assert!(
                    e < 1e-12,
                    "group law α={alpha} k1={k1} k2={k2} θ={t}: {e:e}"
                );
                let inv = a.inverse(a.tau(t));
                assert!((inv - t).abs() < 1e-12, "inverse α={alpha} k={k1} θ={t}");
            }
        }
    }
    // Paper form at α = π/4: tanθ' = k tanθ / (1 + tanθ − k tanθ), θ' < 0 → θ' + π.
    for k in [0.2, 0.5, 2.0, 7.0] {
        let c = cone(k, 45.0);
        for t in thetas().filter(|t| (t - PI / 2.0).abs() > 1e-6 && *t > 0.0 && *t < PI) {
            let tt = t.tan();
            let mut p = (k * tt / (1.0 + tt - k * tt)).atan();
            if p < 0.0 {
                p += PI;
            }
            // The paper's θ' < 0 → θ' + π rule picks the same branch as atan2 everywhere tanθ is
            // defined; atan2 also covers θ = π/2 and the end points.
            let d = (c.tau(t) - p).abs();
            assert!(d < 1e-12, "paper form k={k} θ={t}: {} vs {p}", c.tau(t));
        }
    }
    // α → 90°: flat disc tanθ_r = k tanθ_d; α → 0: needle, a step at θ ≈ 0 to ≈ π.
    let flat = cone(3.0, 90.0 - 1e-4);
    let t: f64 = 0.4;
    assert!(((flat.tau(t)).tan() - 3.0 * t.tan()).abs() < 1e-5);
    let needle = cone(3.0, 1e-4);
    assert!(needle.tau(0.01) > PI - 1e-3, "needle: {}", needle.tau(0.01));
}

#[test]
fn derivatives_match_finite_differences() {
    // Central differences, h = 1e-6: truncation O(h²·τ‴) + round-off O(ε/h) ≈ 1e-9 relative.
    const TOL: f64 = 1e-6;
    let h = 1e-6;
    let mut fns: Vec<Box<dyn AngularScaling>> = vec![
        Box::new(cone(0.4, 30.0)),
        Box::new(cone(2.5, 60.0)),
        Box::new(MidRange::new(0.6).unwrap()),
        Box::new(MidRange::new(-0.8).unwrap()),
    ];
    fns.push(Box::new(Tabulated::sample(&cone(2.0, 45.0), 64).unwrap()));
    for f in &fns {
        for t in thetas().filter(|t| *t > 2.0 * h && *t < PI - 2.0 * h) {
            let fd = (f.tau(t + h) - f.tau(t - h)) / (2.0 * h);
            let d = f.dtau(t);
            assert!(d > 0.0, "{}: τ′ ≤ 0 at {t}", f.name());
            assert!(
                (fd - d).abs() < TOL * d.abs().max(1.0),
                "{} θ={t}: fd {fd} vs {d}",
                f.name()
            );
        }
    }
}

#[test]
fn midrange_matches_law_of_sines_and_inverse() {
    const TOL: f64 = 1e-13;
    for k in [-0.99, -0.5, 0.0, 0.3, 0.9, 1.0 - 1e-9] {
        let f = MidRange::new(k).unwrap();
        for t in thetas() {
            let want = t - (k * t.sin()).asin();
            assert!(
                (f.tau(t) - want).abs() < TOL,
                "k={k} θ={t}: {} vs {want}",
                f.tau(t)
            );
            let back = f.inverse(f.tau(t));
            // The inverse is ill-conditioned where τ′ is tiny (k → 1, θ small): compare in τ.
            assert!(
                (f.tau(back) - f.tau(t)).abs() < 1e-12,
                "inverse k={k} θ={t}"
            );
        }
        assert!((f.dtau(0.0) - (1.0 - k)).abs() < 1e-15);
        assert!((f.tau(PI) - PI).abs() < 1e-15);
    }
    assert!(
        MidRange::new(1.0).is_err()
            && MidRange::new(-1.0).is_err()
            && MidRange::new(f64::NAN).is_err()
    );
}

#[test]
fn domain_errors_are_typed() {
    for k in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(Cone::new(k, 0.5).is_err(), "k={k}");
    }
    for a in [0.0, PI / 2.0, -0.1, 2.0, f64::NAN] {
        assert!(Cone::new(1.0, a).is_err(), "α={a}");
    }
    assert!(Tabulated::new(vec![0.0, 1.0, PI], vec![0.0, 2.0, 1.5]).is_err());
    assert!(Tabulated::new(vec![0.1, PI], vec![0.0, PI]).is_err());
    assert!(Tabulated::new(vec![0.0], vec![0.0]).is_err());
    assert!(ScalingMatrix::compute(&Identity, Eta::Plain, 0).is_err());
}

/// Independent dense computation: 2-D quadrature of `Y_j(τ(θ), φ) Y_i(θ, φ) η(θ)` with the
/// Cartesian SH evaluator, composite Gauss–Legendre in θ on `panels` uniform panels and the exact
/// trapezoid rule in φ.
fn brute_force(tau: &dyn AngularScaling, eta: Eta, order: usize, panels: usize) -> Vec<Vec<f64>> {
    let nn = order * order;
    let b = ShBasis::<f64>::new(order).unwrap();
    let gl = GaussLegendre::new(16);
    let nphi = 2 * order + 1;
    let mut m = vec![vec![0.0; nn]; nn];
    let (mut yi, mut yj) = (vec![0.0; nn], vec![0.0; nn]);
    for p in 0..panels {
        let (a, c) = (
            PI * p as f64 / panels as f64,
            PI * (p + 1) as f64 / panels as f64,
        );
        for (t, w) in gl.on(a, c) {
            let tt = tau.tau(t);
            let eta_v = match eta {
                Eta::Plain => t.sin(),
                Eta::Energy => tt.sin() * tau.dtau(t),
            };
            for q in 0..nphi {
                let phi = 2.0 * PI * q as f64 / nphi as f64;
                b.eval_theta_phi(t, phi, &mut yi);
                b.eval_theta_phi(tt, phi, &mut yj);
                let ww = w * eta_v * 2.0 * PI / nphi as f64;
                for i in 0..nn {
                    for j in 0..nn {
                        m[i][j] += ww * yi[i] * yj[j];
                    }
                }
            }
        }
    }
    m
}

#[test]
fn matrix_matches_independent_brute_force_and_block_structure() {
    // Brute force on 600 uniform panels × 16 nodes: smooth integrands at these k, error ≪ 1e-12.
    const TOL: f64 = 1e-10;
    let order = 5;
    let cases: Vec<(Box<dyn AngularScaling>, Eta)> = vec![
        (Box::new(cone(2.0, 45.0)), Eta::Plain),
        (Box::new(cone(0.6, 30.0)), Eta::Energy),
        (Box::new(cone(1.3, 70.0)), Eta::Energy),
        (Box::new(MidRange::new(0.5).unwrap()), Eta::Plain),
        (Box::new(MidRange::new(-0.4).unwrap()), Eta::Energy),
    ];
    for (tau, eta) in &cases {
        let m = ScalingMatrix::compute(tau.as_ref(), *eta, order)
            .unwrap()
            .to_dense();
        let bf = brute_force(tau.as_ref(), *eta, order, 600);
        let mut worst = 0.0f64;
        for i in 0..order * order {
            for j in 0..order * order {
                worst = worst.max((m[i][j] - bf[i][j]).abs());
                // Block structure holds in the brute force itself: zero unless m_i = m_j.
                if sh_lm(i).1 != sh_lm(j).1 {
                    assert!(
                        bf[i][j].abs() < 1e-12,
                        "brute force ({i},{j}) = {}",
                        bf[i][j]
                    );
                }
            }
        }
        // −m block equals +m block in the brute force.
        for i in 0..order * order {
            for j in 0..order * order {
                let ((li, mi), (lj, mj)) = (sh_lm(i), sh_lm(j));
                if mi == mj && mi > 0 {
                    let (a, c) = (bf[i][j], bf[sh_index(li, -mi)][sh_index(lj, -mj)]);
                    assert!(
                        (a - c).abs() < 1e-12,
                        "±m blocks differ at l'={li} l={lj} m={mi}"
                    );
                }
            }
        }
        println!(
            "{} {:?}: max |M − brute force| = {worst:.2e}",
            tau.name(),
            eta
        );
        assert!(worst < TOL, "{} {eta:?}: {worst:e}", tau.name());
    }
}

#[test]
fn nonzero_pattern_and_count_for_orders_1_to_12() {
    const ZERO: f64 = 1e-12;
    for order in 1..=12 {
        for (eta, k) in [
            (Eta::Plain, 1.7),
            (Eta::Energy, 1.7),
            (Eta::Plain, 0.45),
            (Eta::Energy, 0.45),
        ] {
            let m = ScalingMatrix::compute(&cone(k, 45.0), eta, order).unwrap();
            let nz = m.nonzeros(ZERO);
            let expect = structural_nonzeros(order) - (order - 1);
            assert_eq!(nz, expect, "N={order} {eta:?} k={k}: {nz} non-zeros");
            let d = m.to_dense();
            // The zeros are exactly: plain → column 0 below row 0; energy → row 0 right of col 0.
            for l in 1..order {
                let i = sh_index(l, 0);
                match eta {
                    Eta::Plain => assert!(d[i][0].abs() < ZERO && d[0][i].abs() > ZERO),
                    Eta::Energy => assert!(d[0][i].abs() < ZERO && d[i][0].abs() > ZERO),
                }
            }
        }
        assert_eq!(
            distinct_count(order),
            (0..order).map(|m| (order - m) * (order - m)).sum::<usize>()
        );
    }
    assert_eq!(structural_nonzeros(4), 44);
    assert_eq!(distinct_count(4), 30);
}

#[test]
fn identity_at_k1_energy_row_and_transposition() {
    const TOL: f64 = 1e-12;
    for order in [4, 8] {
        for alpha in [20.0, 45.0, 80.0] {
            for eta in [Eta::Plain, Eta::Energy] {
                let m = ScalingMatrix::compute(&cone(1.0, alpha), eta, order).unwrap();
                let e = m.max_abs_diff(&ScalingMatrix::identity(order).unwrap());
                assert!(e < TOL, "M(k=1) vs I: {e:e}");
            }
            for k in [0.1, 0.5, 2.0, 10.0, 300.0] {
                // The default energy matrix *is* M_plain(τ⁻¹)ᵀ by construction (substitution
                // u = τ(θ)); the identity is tested against the direct θ-integral with
                // η = sin τ · τ′, a different integrand.
                let direct = QuadOptions {
                    energy_form: EnergyForm::Direct,
                    ..Default::default()
                };
                let (energy_direct, rep) =
                    ScalingMatrix::compute_with(&cone(k, alpha), Eta::Energy, order, &direct)
                        .unwrap();
                assert!(rep.converged, "direct energy form: {rep:?}");
                let energy = ScalingMatrix::compute(&cone(k, alpha), Eta::Energy, order).unwrap();
                let plain_inv =
                    ScalingMatrix::compute(&cone(1.0 / k, alpha), Eta::Plain, order).unwrap();
                let e = energy_direct.max_abs_diff(&plain_inv.transpose());
                assert!(
                    e < TOL,
                    "M_energy(k) vs M_plain(1/k)ᵀ at N={order} α={alpha} k={k}: {e:e}"
                );
                assert!(energy.max_abs_diff(&energy_direct) < TOL);
                // Energy preservation: the l = 0 coefficient of any input is kept (row 0 = e_0ᵀ).
                let d = energy.to_dense();
                assert!(
                    (d[0][0] - 1.0).abs() < TOL && d[0][1..].iter().all(|v| v.abs() < TOL),
                    "energy row 0"
                );
                // Plain: a constant stays that constant (column 0 = e_0).
                let p = plain_inv.to_dense();
                assert!(
                    (p[0][0] - 1.0).abs() < TOL && (1..order * order).all(|i| p[i][0].abs() < TOL)
                );
            }
        }
    }
}

#[test]
fn group_law_of_matrices_is_broken_by_band_limiting() {
    // Measured, not asserted to vanish: ‖M_{k1} M_{k2} − M_{k1 k2}‖_max for k1 = 2, k2 = 1.5, α = 45°.
    println!("N   max|M(2)M(1.5) − M(3)| plain   energy");
    let mut first = 0.0;
    for order in [2usize, 4, 8, 12, 16] {
        let mut row = Vec::new();
        for eta in [Eta::Plain, Eta::Energy] {
            let a = ScalingMatrix::compute(&cone(2.0, 45.0), eta, order).unwrap();
            let b = ScalingMatrix::compute(&cone(1.5, 45.0), eta, order).unwrap();
            let ab = ScalingMatrix::compute(&cone(3.0, 45.0), eta, order).unwrap();
            row.push(a.mul(&b).max_abs_diff(&ab));
        }
        println!(
            "{order:<3} {:.3e}                    {:.3e}",
            row[0], row[1]
        );
        if order == 2 {
            first = row[0];
        }
        assert!(row.iter().all(|v| v.is_finite()));
    }
    // Far more than rounding at low order: the claim of docs/conventions.md §3.1.
    assert!(first > 1e-3, "group-law defect at N=2 is only {first:e}");
}

#[test]
fn scaled_cap_converges_to_the_analytic_cap() {
    // F_r = cap(A) ⇒ F_d = F_r∘τ = cap(τ⁻¹(A)) exactly; M·P_N(cap A) differs from P_N(cap τ⁻¹(A))
    // only through band-limiting of the input. Measure the L2 error (Parseval) as N grows.
    let a = 50.0 * DEG;
    println!("N   k     ‖M·cap(A) − cap(τ⁻¹A)‖₂ / ‖cap(τ⁻¹A)‖₂");
    for k in [0.7, 2.0] {
        let tau = cone(k, 45.0);
        let target_angle = tau.inverse(a);
        let mut errs = Vec::new();
        for order in [2usize, 4, 8, 16, 32] {
            let m = ScalingMatrix::compute(&tau, Eta::Plain, order).unwrap();
            let src = cap_coeffs(order, a).unwrap();
            let want = cap_coeffs(order, target_angle).unwrap();
            let mut got = vec![0.0; order * order];
            m.apply(&src, &mut got).unwrap();
            let num: f64 = got
                .iter()
                .zip(&want)
                .map(|(g, w)| (g - w).powi(2))
                .sum::<f64>()
                .sqrt();
            let den: f64 = want.iter().map(|w| w * w).sum::<f64>().sqrt();
            errs.push(num / den);
            println!("{order:<3} {k:<5} {:.3e}", num / den);
        }
        // Decay: the discontinuous cap converges slowly and not monotonically (Gibbs ringing of
        // the input's truncation is itself scaled); demand a factor 2 between N = 2 and N = 32
        // and that N = 32 beats N = 4.
        assert!(errs[4] < 0.5 * errs[0], "k={k}: {errs:?}");
        assert!(errs[4] < errs[1], "k={k}: {errs:?}");
    }
}

#[test]
fn extremes_are_finite_and_documented() {
    // k ∈ {1e-6, 1e-3, 1e3, 1e6}, α ∈ {1e-4°, 90° − 1e-4°}, mid-range k = 1 − 1e-9, N up to 32.
    for &alpha in &[1e-4, 45.0, 90.0 - 1e-4] {
        for &k in &[1e-6, 1e-3, 1e3, 1e6] {
            for eta in [Eta::Plain, Eta::Energy] {
                let tau = cone(k, alpha);
                let (m, rep) =
                    ScalingMatrix::compute_with(&tau, eta, 8, &QuadOptions::default()).unwrap();
                assert!(
                    m.values().iter().all(|v| v.is_finite()),
                    "NaN at α={alpha} k={k}"
                );
                assert!(
                    rep.converged,
                    "not converged α={alpha} k={k} {eta:?}: {rep:?}"
                );
                // The invariants survive: energy row 0 = e_0, plain column 0 = e_0.
                let d = m.to_dense();
                match eta {
                    Eta::Energy => assert!(
                        (d[0][0] - 1.0).abs() < 1e-10,
                        "α={alpha} k={k}: {}",
                        d[0][0]
                    ),
                    Eta::Plain => assert!(
                        (d[0][0] - 1.0).abs() < 1e-10,
                        "α={alpha} k={k}: {}",
                        d[0][0]
                    ),
                }
            }
        }
    }
    let mr = MidRange::new(1.0 - 1e-9).unwrap();
    for eta in [Eta::Plain, Eta::Energy] {
        let m = ScalingMatrix::compute(&mr, eta, 8).unwrap();
        assert!(m.values().iter().all(|v| v.is_finite()));
    }
    let m = ScalingMatrix::compute(&cone(5.0, 45.0), Eta::Plain, 32).unwrap();
    assert!(m.values().iter().all(|v| v.is_finite()));
}

#[test]
fn apply_batch_f32_and_dense_agree() {
    let m = ScalingMatrix::compute(&cone(1.8, 45.0), Eta::Plain, 6).unwrap();
    let d = m.to_dense();
    let x: Vec<f64> = (0..36)
        .map(|i| ((i * 37) % 11) as f64 / 5.0 - 1.0)
        .collect();
    let mut y = vec![0.0; 36];
    m.apply(&x, &mut y).unwrap();
    for i in 0..36 {
        let want: f64 = (0..36).map(|j| d[i][j] * x[j]).sum();
        assert!((y[i] - want).abs() < 1e-14);
    }
    let m32 = m.cast::<f32>();
    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    let mut y32 = vec![0.0f32; 36];
    m32.apply(&x32, &mut y32).unwrap();
    let e = y32
        .iter()
        .zip(&y)
        .map(|(a, b)| (*a as f64 - b).abs())
        .fold(0.0, f64::max);
    println!("f32 apply max error vs f64: {e:.2e}");
    assert!(e < 1e-5);
    let xs: Vec<f64> = x.iter().chain(x.iter().rev()).copied().collect();
    let mut ys = vec![0.0; 72];
    m.apply_batch(&xs, &mut ys).unwrap();
    assert_eq!(&ys[..36], &y[..]);
    assert!(m.apply(&x[..35], &mut y).is_err());
}

#[test]
fn tables_interpolate_exactly_at_samples_and_converge() {
    let fam = TauFamily::Cone { alpha: 45.0 * DEG };
    let t = KTable::build(
        fam,
        Eta::Plain,
        4,
        10,
        0.25,
        8.0,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap();
    let mut out = ScalingMatrix::identity(4).unwrap();
    for (k, m) in t.ks().iter().zip(t.matrices()) {
        assert_eq!(t.lookup(*k, &mut out).unwrap(), KLookup::Interior);
        assert!(out.max_abs_diff(m) < 1e-15);
    }
    assert_eq!(
        t.lookup(0.1, &mut out).unwrap(),
        KLookup::BelowMin { k_min: 0.25 }
    );
    assert!(out.max_abs_diff(&t.matrices()[0]) == 0.0);
    assert_eq!(
        t.lookup(9.0, &mut out).unwrap(),
        KLookup::AboveMax { k_max: 8.0 }
    );
    assert!(t.lookup(f64::NAN, &mut out).is_err());
    assert!(t.lookup(-1.0, &mut out).is_err());
    // Linear interpolation error is O(h²): doubling K (halving h in ln k) cuts it ~4×.
    let e10 = t.max_interp_error(3).unwrap().0;
    let t20 = KTable::build(
        fam,
        Eta::Plain,
        4,
        19,
        0.25,
        8.0,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap();
    let e20 = t20.max_interp_error(3).unwrap().0;
    let c20 = KTable::build(
        fam,
        Eta::Plain,
        4,
        19,
        0.25,
        8.0,
        Spacing::Exp,
        Interp::Cubic,
    )
    .unwrap();
    let ec = c20.max_interp_error(3).unwrap().0;
    println!("interp error K=10 linear {e10:.3e}, K=19 linear {e20:.3e} (ratio {:.2}), K=19 cubic {ec:.3e}", e10 / e20);
    assert!(e10 / e20 > 3.0 && e10 / e20 < 5.5, "ratio {}", e10 / e20);
    assert!(ec < 0.2 * e20, "cubic {ec:e} vs linear {e20:e}");
    // Chebyshev and uniform spacings hit both ends; mid-range tables interpolate in k.
    for sp in [Spacing::Uniform, Spacing::Chebyshev] {
        let t = KTable::build(fam, Eta::Energy, 3, 7, 0.5, 4.0, sp, Interp::Linear).unwrap();
        assert_eq!(t.ks()[0], 0.5);
        assert_eq!(t.ks()[6], 4.0);
        assert!(t.ks().windows(2).all(|w| w[1] > w[0]));
    }
    let mr = KTable::build(
        TauFamily::MidRange,
        Eta::Energy,
        4,
        9,
        -0.8,
        0.8,
        Spacing::Uniform,
        Interp::Cubic,
    )
    .unwrap();
    assert_eq!(mr.lookup(0.1, &mut out).unwrap(), KLookup::Interior);
    assert!(KTable::build(
        TauFamily::MidRange,
        Eta::Plain,
        4,
        9,
        -0.8,
        0.8,
        Spacing::Exp,
        Interp::Linear
    )
    .is_err());
    assert!(KTable::build(fam, Eta::Plain, 4, 3, 0.5, 2.0, Spacing::Exp, Interp::Cubic).is_err());
    assert!(KTable::build(
        fam,
        Eta::Plain,
        4,
        1,
        0.5,
        2.0,
        Spacing::Exp,
        Interp::Linear
    )
    .is_err());
    assert!(KTable::build(
        fam,
        Eta::Plain,
        4,
        5,
        2.0,
        0.5,
        Spacing::Exp,
        Interp::Linear
    )
    .is_err());
}

#[test]
fn extreme_k_limits_match_closed_forms() {
    // k → ∞ (plain): τ ≡ π − α away from layers of width O(1/k), so F_d(θ, φ) = F_r(π − α, φ):
    //   M_{(l',m),(l,m)} → 2π P̄_l^m(cos(π − α)) ∫₀^π P̄_{l'}^m(cosθ) sinθ dθ.
    // k → 0 (plain): τ ≡ 0 on [0, π − α) and ≡ π beyond, so F_d = F_r(+z)·cap(π − α) +
    //   F_r(−z)·(1 − cap(π − α)): M_{(l',0),(l,0)} → Y_l^0(+z) c_l' + Y_l^0(−z)(√(4π)δ_l'0 − c_l'),
    //   blocks m > 0 → 0 (P̄_l^m(±1) = 0).
    // Both limits are approached at rate O(1/k) resp. O(k log(1/k)) (layer widths ~tan α/k; for
    // small k the deviation of τ from π decays like k/(θ − (π − α)), whose integral has the log):
    // tolerance 1e-4 at k = 1e6 and 1e-6, α = 45°.
    const TOL: f64 = 1e-4;
    let order = 6;
    let alpha = 45.0 * DEG;
    let leg = shscale_sh::legendre::Legendre::<f64>::new(order).unwrap();
    let tri = |l: usize, m: usize| l * (l + 1) / 2 + m;
    let mut p = vec![0.0; order * (order + 1) / 2];
    leg.eval_theta(PI - alpha, &mut p);
    let p_alpha = p.clone();
    // ∫₀^π P̄_{l'}^m(cosθ) sinθ dθ by composite Gauss–Legendre in θ (smooth integrand).
    let gl = GaussLegendre::new(20);
    let mut integral = vec![0.0; p.len()];
    for q in 0..64 {
        for (t, w) in gl.on(PI * q as f64 / 64.0, PI * (q + 1) as f64 / 64.0) {
            leg.eval_theta(t, &mut p);
            integral
                .iter_mut()
                .zip(&p)
                .for_each(|(a, v)| *a += w * v * t.sin());
        }
    }
    let ylm0 = |l: usize, sign: f64| sign.powi(l as i32) * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
    let big = ScalingMatrix::compute(&cone(1e6, 45.0), Eta::Plain, order)
        .unwrap()
        .to_dense();
    let small = ScalingMatrix::compute(&cone(1e-6, 45.0), Eta::Plain, order)
        .unwrap()
        .to_dense();
    let cap = cap_coeffs(order, PI - alpha).unwrap();
    let (mut worst_big, mut worst_small) = (0.0f64, 0.0f64);
    for i in 0..order * order {
        for j in 0..order * order {
            let ((lo, mo), (li, mi)) = (sh_lm(i), sh_lm(j));
            let m = mi.unsigned_abs() as usize;
            let want_big = if mo == mi {
                2.0 * PI * p_alpha[tri(li, m)] * integral[tri(lo, m)]
            } else {
                0.0
            };
            let want_small = if mo == 0 && mi == 0 {
                let full = if lo == 0 { (4.0 * PI).sqrt() } else { 0.0 };
                ylm0(li, 1.0) * cap[i] + ylm0(li, -1.0) * (full - cap[i])
            } else {
                0.0
            };
            worst_big = worst_big.max((big[i][j] - want_big).abs());
            worst_small = worst_small.max((small[i][j] - want_small).abs());
        }
    }
    println!("extreme-k limits: k=1e6 max deviation {worst_big:.2e}, k=1e-6 {worst_small:.2e}");
    assert!(
        worst_big < TOL && worst_small < TOL,
        "extreme-k limits: {worst_big:e} {worst_small:e}"
    );
}

#[test]
fn soa_batch_equals_per_vector_apply() {
    let m = ScalingMatrix::compute(&cone(0.8, 35.0), Eta::Energy, 5).unwrap();
    let count = 7;
    let aos: Vec<f64> = (0..25 * count)
        .map(|i| ((i * 13) % 17) as f64 / 8.0 - 1.0)
        .collect();
    let mut soa = vec![0.0; aos.len()];
    for b in 0..count {
        for i in 0..25 {
            soa[i * count + b] = aos[b * 25 + i];
        }
    }
    let mut y_aos = vec![0.0; aos.len()];
    m.apply_batch(&aos, &mut y_aos).unwrap();
    let mut y_soa = vec![0.0; aos.len()];
    m.apply_batch_soa(&soa, &mut y_soa, count).unwrap();
    for b in 0..count {
        for i in 0..25 {
            assert!((y_soa[i * count + b] - y_aos[b * 25 + i]).abs() < 1e-14);
        }
    }
    assert!(m.apply_batch_soa(&soa, &mut y_soa, count + 1).is_err());
}

#[test]
fn lookups_within_rounding_of_the_ends_are_interior() {
    let t = KTable::build(
        TauFamily::Cone { alpha: 45.0 * DEG },
        Eta::Plain,
        3,
        5,
        0.5,
        2.0,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap();
    let mut out = ScalingMatrix::identity(3).unwrap();
    assert_eq!(
        t.lookup(0.5 * (1.0 - 4e-16), &mut out).unwrap(),
        KLookup::Interior
    );
    assert_eq!(
        t.lookup(2.0 * (1.0 + 4e-16), &mut out).unwrap(),
        KLookup::Interior
    );
    assert_eq!(
        t.lookup(0.5 * (1.0 - 1e-9), &mut out).unwrap(),
        KLookup::BelowMin { k_min: 0.5 }
    );
    assert_eq!(
        t.lookup(2.0 * (1.0 + 1e-9), &mut out).unwrap(),
        KLookup::AboveMax { k_max: 2.0 }
    );
}
