//! SH exponentiation as Ren et al. 2006 define it (`shscale_field::shexp_ol`) against oracles:
//! `exp(log g) = g` for one blocker within the clamp's error, the log table against a direct
//! computation, OL and HYB against the exact exponential over a sweep of magnitudes, the
//! combination against the truncated product chain it approximates and the exact union, and the
//! edges.

mod common;

use common::{occ_rel, sphere};
use glam::DVec3;
use shscale_field::evaluator::VisibilityField;
use shscale_field::metrics::{l2, l2_diff};
use shscale_field::probe::sphere_truth;
use shscale_field::shexp_ol::{
    exp_exact, exp_hyb, exp_ol, zonal_log, Exp, SphereSetShexp, ZonalLogTable, HYB_MAGNITUDE,
    SHEXP_EPS,
};
use shscale_field::sphereset::SphereSetField;
use shscale_field::union::{RingGrid, SphereSetUnion};
use shscale_geometry::Sphere;
use shscale_sh::cap::cap_zonal;
use shscale_sh::rotation::rotate_zonal;
use shscale_sh::{GauntTensor, ShBasis};
use std::f64::consts::PI;

/// A blocker's band-limited visibility, zonal.
fn blocker(n: usize, a: f64) -> Vec<f64> {
    let mut z = cap_zonal(n, a).unwrap();
    z.iter_mut().for_each(|x| *x = -*x);
    z[0] += (4.0 * PI).sqrt();
    z
}

fn full(z: &[f64]) -> Vec<f64> {
    let n = z.len();
    let mut v = vec![0.0; n * n];
    (0..n).for_each(|l| v[l * l + l] = z[l]);
    v
}

/// `exp(log g)` of one blocker against g itself: the clamp's error only, which shrinks as ε
/// does down to a floor set by `M_g`'s negative eigenvalues (caps of 10°–80°, N = 4 and 8;
/// tolerance: ε = 0.005 better than 0.1, every ε below 20 % of the occlusion); the
/// table's interpolated log against a direct computation at angles between its nodes (1e-5 of
/// the constant's norm √(4π)).
#[test]
fn exp_of_log_returns_the_blocker_within_the_clamp() {
    for n in [4, 8] {
        let gaunt = GauntTensor::<f64>::new(n).unwrap();
        let mut by_eps = Vec::new();
        for eps in [0.1, 0.02, 0.005, 0.001] {
            let worst = [10.0f64, 30.0, 55.0, 80.0]
                .iter()
                .map(|deg| {
                    let g = blocker(n, deg.to_radians());
                    let back = exp_exact(&gaunt, &full(&zonal_log(&gaunt, &g, eps)));
                    occ_rel(&back, &full(&g))
                })
                .fold(0.0f64, f64::max);
            by_eps.push(worst);
        }
        println!("N = {n}: exp(log g) vs g, worst over 10°–80°, at ε = 0.1 / 0.02 / 0.005 / 0.001: {by_eps:?}");
        // The floor below ε ≈ 0.005 is M_g's negative eigenvalues (the band-limited cap rings
        // below 0), which no clamp recovers.
        assert!(
            by_eps[2] < by_eps[0] && by_eps.iter().all(|e| *e < 0.2),
            "{by_eps:?}"
        );
        let table = ZonalLogTable::new(&gaunt, SHEXP_EPS);
        let mut worst = 0.0f64;
        for deg in [0.37f64, 12.345, 44.44, 89.9] {
            let a = deg.to_radians();
            let want = zonal_log(&gaunt, &blocker(n, a), SHEXP_EPS);
            let got = table.log_of(a);
            // In units of the constant function's norm √(4π) (the visibility's scale).
            let e = l2_diff(&got, &want) / (4.0 * PI).sqrt();
            println!("  {deg}°: {e:.1e} (‖log‖ {:.2e})", l2(&want));
            worst = worst.max(e);
        }
        println!("N = {n}: the log table against direct logs between its nodes: {worst:.1e}");
        assert!(worst < 1e-5, "{worst}");
    }
}

/// OL and HYB against the exact exponential, on the sums of S random blockers' logs (S = 1, 2,
/// 4, 16, 64: magnitudes from a single cap's to far beyond the table): OL is good to its fit on
/// single blockers and degrades with the magnitude (sums of logs are not single blockers' logs);
/// HYB's error halves with each halving of its target magnitude (the sweep that fixed
/// `HYB_MAGNITUDE`). Tolerance: HYB never worse than OL; at S = 64 below 10 % of the exact
/// exponential and 5× better than OL.
#[test]
fn ol_and_hyb_against_the_exact_exponential() {
    let n = 4;
    let (basis, gaunt) = (
        ShBasis::<f64>::new(n).unwrap(),
        GauntTensor::<f64>::new(n).unwrap(),
    );
    let table = ZonalLogTable::new(&gaunt, SHEXP_EPS);
    println!("OL table: ‖f̂‖ up to {:.3}", table.max_magnitude());
    let mut uniform = common::Uniform::new(0x2545_f491_4f6c_dd1d);
    let mut rnd = || uniform.next();
    let mut errs = Vec::new();
    for s_count in [1, 2, 4, 16, 64] {
        let (mut ol_sum, mut hyb_sum, mut mag_sum) = (0.0, 0.0, 0.0);
        let targets = [
            table.max_magnitude(),
            2.0,
            1.0,
            0.5,
            0.25,
            0.125,
            0.0625,
            0.03125,
        ];
        let mut hyb = [0.0; 8];
        for _ in 0..8 {
            let mut f = vec![0.0; n * n];
            let mut r = vec![0.0; n * n];
            for _ in 0..s_count {
                let a = (5.0 + 40.0 * rnd()).to_radians();
                let dir = DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
                rotate_zonal(&basis, &table.log_of(a), dir.to_array(), &mut r).unwrap();
                f.iter_mut().zip(&r).for_each(|(x, y)| *x += y);
            }
            let want = exp_exact(&gaunt, &f);
            let scale = l2(&want).max(1e-300);
            ol_sum += l2_diff(&exp_ol(&table, &f), &want) / scale;
            for (k, t) in targets.iter().enumerate() {
                hyb[k] += l2_diff(&exp_hyb(&table, &gaunt, &f, *t), &want) / scale / 8.0;
            }
            hyb_sum += l2_diff(&exp_hyb(&table, &gaunt, &f, HYB_MAGNITUDE), &want) / scale;
            mag_sum += f[1..].iter().map(|x| x * x).sum::<f64>().sqrt();
        }
        println!("S = {s_count}: HYB by target magnitude (table max, 2, 1, 0.5, 0.25, 1/8, 1/16, 1/32): {hyb:?}");
        errs.push((mag_sum / 8.0, ol_sum / 8.0, hyb_sum / 8.0));
    }
    for (s, (m, o, h)) in [1, 2, 4, 16, 64].iter().zip(&errs) {
        println!("S = {s}: mean ‖f̂‖ {m:.2}, relative error OL {o:.2e}, HYB {h:.2e}");
    }
    for (m, o, h) in &errs {
        assert!(*h <= o * 1.000_001 + 1e-12, "{m}: HYB {h} vs OL {o}");
    }
    assert!(
        errs[4].2 < 0.1 && errs[4].2 < 0.2 * errs[4].1,
        "{:?}",
        errs[4]
    );
}

/// The combination: one blocker is the band-limited cap within the clamp's error; several
/// approximate the truncated product chain (what Ren et al. replace), not the union of the caps
/// (the set's joint visibility): for a ring of 4 and 16 spheres the exact and HYB exponentials
/// are within 2 % of the chain (tolerance), while the chain itself is 7–72 % from the union
/// (printed). The edges:
/// no sphere is the constant 1, a point inside a sphere sees 0, 10⁶ radii away the constant 1.
#[test]
fn shexp_combines_like_the_product_chain() {
    let n = 4;
    let (basis, gaunt) = (
        ShBasis::<f64>::new(n).unwrap(),
        GauntTensor::<f64>::new(n).unwrap(),
    );
    let table = ZonalLogTable::new(&gaunt, SHEXP_EPS);
    let rings = RingGrid::new(&basis, 64);
    let p = DVec3::new(0.2, 2.2, 0.4);
    let one = [sphere([0.0, 0.0, 0.0], 0.8)];
    let mut v = vec![0.0; 16];
    SphereSetShexp::new(&one, (&basis, &gaunt), &table, Exp::Exact).eval(p, &mut v);
    let e1 = occ_rel(&v, &sphere_truth(&basis, &one[0], p).unwrap());
    println!("one blocker by SHEXP (exact exp) against its cap: {e1:.2e}");
    assert!(e1 < 0.1, "{e1}");
    for s_count in [4usize, 16] {
        let spheres: Vec<Sphere> = (0..s_count)
            .map(|i| {
                let t = i as f64 / s_count as f64 * std::f64::consts::TAU;
                sphere([0.6 * t.cos(), 0.3 * (2.0 * t).sin(), 0.6 * t.sin()], 0.35)
            })
            .collect();
        let mut chain = vec![0.0; 16];
        SphereSetField::new(&spheres, &basis, &gaunt).eval(p, &mut chain);
        let mut union = vec![0.0; 16];
        SphereSetUnion::new(&spheres, &rings).eval(p, &mut union);
        for (name, exp) in [("exact", Exp::Exact), ("OL", Exp::Ol), ("HYB", Exp::Hyb)] {
            SphereSetShexp::new(&spheres, (&basis, &gaunt), &table, exp).eval(p, &mut v);
            // Exact and HYB reproduce the chain (measured 0.000–0.004); OL only near it.
            if name != "OL" {
                assert!(occ_rel(&v, &chain) < 0.02, "{name} at S = {s_count}");
            }
            println!(
                "S = {s_count}, SHEXP {name}: against the product chain {:.3}, against the union {:.3} (the chain against the union {:.3})",
                occ_rel(&v, &chain),
                occ_rel(&v, &union),
                occ_rel(&chain, &union)
            );
        }
    }
    let set = |s: &[Sphere], q: DVec3| {
        let mut v = vec![0.0; 16];
        SphereSetShexp::new(s, (&basis, &gaunt), &table, Exp::Hyb).eval(q, &mut v);
        v
    };
    let c = (4.0 * PI).sqrt();
    let empty = set(&[], p);
    assert!((empty[0] - c).abs() < 1e-12 && empty[1..].iter().all(|x| x.abs() < 1e-12));
    assert!(set(&one, DVec3::new(0.1, 0.0, 0.0))
        .iter()
        .all(|x| *x == 0.0));
    let far = set(&one, DVec3::new(1e6, 0.0, 0.0));
    assert!((far[0] - c).abs() < 1e-6, "{}", far[0] - c);
}

/// The log of a sampled visibility: where no eigenvalue of `M_v` reaches the floor (a half-dark
/// cap, `v = 1 − ½·cap(30°)`), `exp(log v) = v` to 1e-5 (the truncated product's non-closure:
/// `M_{log v} ≠ log M_v`) and the log commutes with rotation to 1e-10
/// (the general N² × N² path against the zonal table's N × N one, rotated); a fully blocked
/// sample's log is `ln ε · 1` exactly, whose exponential is `ε · 1`.
#[test]
fn log_of_a_sampled_visibility_inverts_and_rotates() {
    use shscale_field::shexp_ol::log_visibility;
    let n = 4;
    let (basis, gaunt) = (
        ShBasis::<f64>::new(n).unwrap(),
        GauntTensor::<f64>::new(n).unwrap(),
    );
    let mut z = cap_zonal(n, 30f64.to_radians()).unwrap();
    z.iter_mut().for_each(|x| *x *= -0.5);
    z[0] += (4.0 * PI).sqrt();
    let axis = DVec3::new(0.3, -0.5, 0.8).normalize();
    let mut v = vec![0.0; 16];
    rotate_zonal(&basis, &z, axis.to_array(), &mut v).unwrap();
    let log = log_visibility(&gaunt, &v, SHEXP_EPS);
    let back = exp_exact(&gaunt, &log);
    let e_inv = l2_diff(&back, &v) / l2(&v);
    let mut rotated = vec![0.0; 16];
    rotate_zonal(
        &basis,
        &zonal_log(&gaunt, &z, SHEXP_EPS),
        axis.to_array(),
        &mut rotated,
    )
    .unwrap();
    let e_rot = l2_diff(&log, &rotated) / l2(&rotated);
    println!("exp(log v) vs v {e_inv:.1e}; log(R v) vs R log v {e_rot:.1e}");
    // exp(M_f)·1 with f = log(M_v)·1 is not exactly v: M_f is not log(M_v), the truncated
    // product being no associative algebra (9e-7 here); the rotation is exact.
    assert!(e_inv < 1e-5 && e_rot < 1e-10, "{e_inv} {e_rot}");
    let dark = log_visibility(&gaunt, &[0.0; 16], SHEXP_EPS);
    let want = SHEXP_EPS.ln() * (4.0 * PI).sqrt();
    assert!((dark[0] - want).abs() < 1e-12 && dark[1..].iter().all(|x| x.abs() < 1e-12));
    let e = exp_exact(&gaunt, &dark);
    assert!((e[0] - SHEXP_EPS * (4.0 * PI).sqrt()).abs() < 1e-12);
}

/// Scaling in log space on the analytic sphere (closed-form truth): the base-sphere samples'
/// logs — product-algebra (SHEXP's) and pointwise (`ln max(ε, v)` by quadrature) — extrapolated
/// and exponentiated, against the papers' extrapolation of the visibilities, at 1.3, 2 and 3
/// radii (sampled at 1.2r, α = 45°, N = 4, ε = 0.02); at the samples themselves (k = 1) the log
/// path returns the samples within the clamp's error (6e-2, tolerance 0.15).
#[test]
fn scaling_in_log_space_on_the_analytic_sphere() {
    use shscale_field::extrapolate::Extrapolator;
    use shscale_field::shexp_ol::{log_bsv, SubVolumeLog};
    use shscale_field::{Bsv, Layout, VisibilitySampler};
    use shscale_geometry::AnalyticSphere;
    use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
    let n = 4;
    let (basis, gaunt) = (
        ShBasis::<f64>::new(n).unwrap(),
        GauntTensor::<f64>::new(n).unwrap(),
    );
    let occ = AnalyticSphere::unit();
    let sampler = VisibilitySampler::new(n, 16).unwrap();
    let bsv = Bsv::sample(&occ, Layout::Fibonacci { p: 120 }, &sampler, 1.2, 0.0).unwrap();
    let logs = log_bsv(&bsv, &gaunt, SHEXP_EPS);
    let alpha = 45f64.to_radians();
    let table = KTable::build(
        TauFamily::Cone { alpha },
        Eta::Plain,
        n,
        40,
        0.9,
        3.0,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap();
    let shexp = ZonalLogTable::new(&gaunt, SHEXP_EPS);
    let plain = Extrapolator::new(&bsv, &table);
    let log_parts = [Extrapolator::new(&logs, &table)];
    let log_field = SubVolumeLog::new(&log_parts, &gaunt, &shexp);
    // The pointwise reading: each sample's ln max(ε, v) by quadrature, scaled, exp by quadrature.
    let grid = shscale_field::sphereset::QuadratureGrid::new(&basis, 64);
    let mut pointwise = bsv.clone();
    for s in &mut pointwise.samples {
        let v = s.coeffs.clone();
        shscale_field::shexp::log_by_quadrature(&grid, &v, SHEXP_EPS, &mut s.coeffs);
    }
    let pw = Extrapolator::new(&pointwise, &table);
    let mut c = vec![0.0; 16];
    let unit = Sphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    let (mut a, mut b) = (vec![0.0; 16], vec![0.0; 16]);
    let mut errs = Vec::new();
    for rho in [1.3, 2.0, 3.0] {
        let (mut ep, mut el, mut ew) = (0.0, 0.0, 0.0);
        for k in 0..16 {
            let t = k as f64 * 0.77;
            let dir =
                DVec3::new(t.cos() * 0.8, t.sin() * 0.8, 0.6 * (k as f64 / 8.0 - 1.0)).normalize();
            let p = rho * dir;
            let truth = sphere_truth(&basis, &unit, p).unwrap();
            VisibilityField::eval(&plain, p, &mut a);
            log_field.eval(p, &mut b);
            let mut f = vec![0.0; 16];
            VisibilityField::eval(&pw, p, &mut f);
            shscale_field::shexp::exp_by_quadrature(&grid, &f, &mut c);
            ep += occ_rel(&a, &truth) / 16.0;
            el += occ_rel(&b, &truth) / 16.0;
            ew += occ_rel(&c, &truth) / 16.0;
        }
        println!(
            "ρ = {rho}: papers' extrapolation {ep:.3}, in log space: product-algebra {el:.3}, pointwise {ew:.3}"
        );
        errs.push((ep, el, ew));
    }
    // The finding this pins: beyond k ≈ 1 both log-space readings are far worse than scaling
    // the visibility (ρ = 2 and 3: 0.78–1.55 against 0.10–0.27) — the clamped log of a blocked
    // cap is deep and hard-edged, and its scaled band limit rings through the exponential.
    for (ep, el, ew) in &errs[1..] {
        assert!(*el > 2.0 * ep && *ew > 2.0 * ep, "{ep} {el} {ew}");
    }
    let s0 = &bsv.samples[0];
    log_field.eval(s0.pos, &mut b);
    let e = occ_rel(&b, &s0.coeffs);
    println!("at a sample (k = 1): {e:.2e}");
    assert!(e < 0.15, "{e}");
}
