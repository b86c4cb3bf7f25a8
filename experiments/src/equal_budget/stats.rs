//! Means with their 95 % intervals (normal, Student-t with its quantile for any degrees of
//! freedom, cluster-robust with t over the clusters) and the Pareto front. Outside `verdict/`
//! because rows are computed with it (`spheres_rows.rs`' clustered intervals): a change here
//! changes the numerical fingerprint (docs/provenance.md), as it changes rows.

use std::collections::BTreeMap;

/// Mean and the half-width of its normal 95 % interval, `1.96·s/√n` (s the sample standard
/// deviation; `None` for fewer than 2 values).
pub fn mean_ci95(v: &[f64]) -> (Option<f64>, Option<f64>) {
    let m = shscale_field::metrics::mean_max(v.iter().map(|x| Some(*x))).0;
    let ci = (v.len() >= 2).then(|| {
        let m = m.unwrap_or(0.0);
        let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
        1.96 * (var / v.len() as f64).sqrt()
    });
    (m, ci)
}

/// Student's t quantile `t_{p, ν}`: the `t` with `P(T ≤ t) = p` for `T` of `ν` degrees of
/// freedom, for any real `ν > 0` and `p` in (0, 1) (NaN outside). Found by bisection on the
/// distribution function (its central part or its tail, whichever is small at `p`) to the last
/// bits of f64, from a bracket widened until it holds `p`. Tested against the closed forms at ν = 1 (Cauchy,
/// `tan(π(p − ½))`) and ν = 2 (`(2p − 1)/√(2p(1 − p))`), the normal quantile as ν → ∞, and the
/// printed tables (e.g. `t_{0.975, 4} = 2.776`, `t_{0.975, 30} = 2.042`).
pub fn t_quantile(p: f64, nu: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && nu > 0.0) {
        return f64::NAN;
    }
    if p == 0.5 {
        return 0.0;
    }
    // Symmetry: solve on the upper half only.
    if p < 0.5 {
        return -t_quantile(1.0 - p, nu);
    }
    // P(|T| ≤ t) = I_y(½, ν/2) with y = t²/(ν + t²) rises from 0; its complement
    // P(|T| > t) = I_x(ν/2, ½) with x = 1 − y falls from 1. Each is solved where it is small, so
    // neither target loses digits to a difference with ½ or with 1.
    let central = 2.0 * p - 1.0;
    let tail = 2.0 * (1.0 - p);
    let below = |t: f64| -> bool {
        let t2 = t * t;
        if central <= 0.5 {
            inc_beta(0.5, 0.5 * nu, t2 / (nu + t2)) < central
        } else {
            inc_beta(0.5 * nu, 0.5, nu / (nu + t2)) > tail
        }
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    while below(hi) {
        lo = hi;
        hi *= 2.0;
        if !hi.is_finite() {
            return f64::INFINITY;
        }
    }
    for _ in 0..2100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The regularized incomplete beta function `I_x(a, b)` for `a, b > 0` and `x` in [0, 1]: the
/// continued fraction of Numerical Recipes §6.4 (modified Lentz), evaluated directly where it
/// converges fast (`x < (a + 1)/(a + b + 2)`) and through `1 − I_{1−x}(b, a)` elsewhere, with
/// `ln Γ` by [`ln_gamma`]; relative accuracy ~1e-14 over the t distribution's range.
fn inc_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// The continued fraction of [`inc_beta`] (modified Lentz, to 1e-16 relative, at most 500
/// terms).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=500 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h
}

/// `ln Γ(x)` for `x > 0`: the Lanczos approximation (Lanczos 1964, SIAM J. Numer. Anal. B 1;
/// Godfrey's coefficients for g = 7, n = 9: `Γ(x + 1) = √(2π) t^(x+½) e^(−t) A_g(x)`,
/// `t = x + g + ½`; relative error ~1e-15 for x ≥ ½), with the reflection
/// `Γ(x)Γ(1 − x) = π / sin(πx)` below ½. Tested at 1, 2, ½, 10, 0.1 and 1e-8.
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut s = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        s += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// Mean of `v` and the half-width of its 95 % Student-t interval (`None` below 2 values).
pub fn mean_t95(v: &[f64]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let ci = (v.len() >= 2).then(|| {
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
        t_quantile(0.975, n - 1.0) * (var / n).sqrt()
    });
    (Some(m), ci)
}

/// Mean of `(cluster, value)` pairs and the half-width of its 95 % interval clustered by
/// `cluster` (receivers that share a direction are not independent): the cluster-robust
/// variance of the mean, `G/(G−1) · Σ_g (S_g − n_g·m)² / n²` over the G clusters (`S_g` the sum
/// of cluster g's n_g values) — the sandwich estimator of Liang & Zeger (1986) for an
/// intercept-only model, with the usual G/(G−1) small-sample factor — times `t²_{0.975, G−1}`
/// (the t quantile over the number of clusters, as Cameron & Miller 2015 recommend for few
/// clusters: 1.970 at the 240 directions of a grid, 12.71 at 2 clusters). With one value per
/// cluster it is the Student-t interval of the values ([`mean_t95`]'s). `None` for fewer than
/// 2 clusters.
pub fn mean_ci95_clustered(v: &[(usize, f64)]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().map(|x| x.1).sum::<f64>() / n;
    let mut clusters: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for &(c, x) in v {
        let e = clusters.entry(c).or_insert((0.0, 0.0));
        e.0 += x;
        e.1 += 1.0;
    }
    let g = clusters.len() as f64;
    let ci = (clusters.len() >= 2).then(|| {
        let ss: f64 = clusters.values().map(|(s, k)| (s - k * m).powi(2)).sum();
        t_quantile(0.975, g - 1.0) * (g / (g - 1.0) * ss / (n * n)).sqrt()
    });
    (Some(m), ci)
}

/// The lower-left Pareto front of `(x, y)` points: sorted by x, each with a lower y than all
/// before it.
pub fn pareto(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut best = f64::INFINITY;
    p.into_iter()
        .filter(|&(_, y)| {
            let keep = y < best;
            best = best.min(y);
            keep
        })
        .collect()
}

#[cfg(test)]
mod tests {
    /// Student's t distribution function `P(T ≤ t)` for `ν > 0` degrees of freedom:
    /// `½ + ½ I_y(½, ν/2)` with `y = t²/(ν + t²)` for `t ≥ 0` (and by symmetry below), `I` the
    /// regularized incomplete beta function ([`inc_beta`]).
    fn t_cdf(t: f64, nu: f64) -> f64 {
        let t2 = t * t;
        let half = if t2 < nu {
            0.5 * super::inc_beta(0.5, 0.5 * nu, t2 / (nu + t2))
        } else {
            0.5 - 0.5 * super::inc_beta(0.5 * nu, 0.5, nu / (nu + t2))
        };
        if t >= 0.0 {
            0.5 + half
        } else {
            0.5 - half
        }
    }

    #[test]
    fn the_mean_interval_is_the_normal_one_and_needs_two_values() {
        // [1, 2, 3]: mean 2, sample s.d. 1, so 1.96/√3.
        let (m, ci) = super::mean_ci95(&[1.0, 2.0, 3.0]);
        assert_eq!(m, Some(2.0));
        assert!((ci.unwrap() - 1.96 / 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(super::mean_ci95(&[4.0]), (Some(4.0), None));
        assert_eq!(super::mean_ci95(&[]), (None, None));
        // Equal values: no spread.
        assert_eq!(super::mean_ci95(&[0.5; 4]).1, Some(0.0));
    }

    #[test]
    fn the_clustered_interval_is_the_t_one_for_singletons_and_wider_for_shared_clusters() {
        // One value per cluster: the same as the Student-t interval of the values.
        let v = [1.0, 2.0, 3.0, 7.0];
        let single: Vec<(usize, f64)> = v.iter().enumerate().map(|(i, x)| (i, *x)).collect();
        let (m, ci) = super::mean_ci95_clustered(&single);
        let (m0, ci0) = super::mean_t95(&v);
        assert_eq!(m, m0);
        assert!((ci.unwrap() - ci0.unwrap()).abs() < 1e-12, "{ci:?} {ci0:?}");
        // Each value repeated five times in its cluster (five radii on one direction): the
        // independent interval shrinks by √5, the clustered one stays that of the four clusters.
        let rep: Vec<(usize, f64)> = single.iter().flat_map(|&p| [p; 5]).collect();
        let flat: Vec<f64> = rep.iter().map(|p| p.1).collect();
        let (_, naive) = super::mean_ci95(&flat);
        let (mr, clustered) = super::mean_ci95_clustered(&rep);
        assert_eq!(mr, m0);
        // 4 clusters: G/(G−1)·Σ(5(x−m))²/20² = (4/3)·Σ(x−m)²/16 — the singletons' value.
        assert!((clustered.unwrap() - ci0.unwrap()).abs() < 1e-12);
        assert!(
            naive.unwrap() < 0.5 * clustered.unwrap(),
            "{naive:?} {clustered:?}"
        );
        // Degenerate inputs: nothing, and one cluster.
        assert_eq!(super::mean_ci95_clustered(&[]), (None, None));
        assert_eq!(super::mean_ci95_clustered(&[(3, 1.0), (3, 2.0)]).1, None);
    }

    /// The t quantile against its closed forms (ν = 1: `tan(π(p − ½))`; ν = 2:
    /// `(2p − 1)/√(2p(1 − p))`), the printed table at 0.975 (three decimals, ν = 1..=30 and
    /// 60, 120), the normal quantile 1.959964 as ν → ∞, symmetry, the median and the edges of
    /// its domain; the worst errors are printed.
    #[test]
    fn the_t_quantile_matches_its_closed_forms_and_the_table() {
        use super::t_quantile;
        let mut worst: f64 = 0.0;
        for p in [
            0.5000001, 0.6, 0.75, 0.9, 0.95, 0.975, 0.99, 0.999, 0.999999,
        ] {
            let cauchy = (std::f64::consts::PI * (p - 0.5)).tan();
            let two = (2.0 * p - 1.0) / (2.0 * p * (1.0 - p)).sqrt();
            for (got, want) in [(t_quantile(p, 1.0), cauchy), (t_quantile(p, 2.0), two)] {
                let rel = ((got - want) / want).abs();
                worst = worst.max(rel);
                assert!(rel < 1e-9, "p = {p}: {got} vs {want}");
            }
            assert_eq!(t_quantile(1.0 - p, 5.0), -t_quantile(p, 5.0));
            // The quantile inverts the distribution function.
            assert!((t_cdf(t_quantile(p, 7.5), 7.5) - p).abs() < 1e-12);
        }
        println!(
            "t quantile against the closed forms at ν = 1, 2: worst relative error {worst:.1e}"
        );
        let table = [
            12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
            2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
            2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
        ];
        for (i, want) in table.iter().enumerate() {
            let got = t_quantile(0.975, (i + 1) as f64);
            assert!((got - want).abs() <= 5e-4, "ν = {}: {got} vs {want}", i + 1);
        }
        assert!((t_quantile(0.975, 60.0) - 2.000).abs() <= 5e-4);
        assert!((t_quantile(0.975, 120.0) - 1.980).abs() <= 5e-4);
        assert!((t_quantile(0.975, 1e9) - 1.959_963_985).abs() < 1e-6);
        assert_eq!(t_quantile(0.5, 3.0), 0.0);
        for (p, nu) in [
            (0.0, 3.0),
            (1.0, 3.0),
            (0.9, 0.0),
            (0.9, -1.0),
            (f64::NAN, 3.0),
        ] {
            assert!(t_quantile(p, nu).is_nan(), "p = {p}, ν = {nu}");
        }
        // Beyond the old table's df = 30 the 1.96 it used was 1–4 % narrow.
        assert!(t_quantile(0.975, 31.0) > 1.96 * 1.03);
    }

    /// `ln Γ` and the regularized incomplete beta at their known values and edges: Γ(1) = Γ(2)
    /// = 1, Γ(½) = √π, Γ(10) = 9!, Γ(0.1) (the reflection), Γ(ε) ≈ 1/ε − γ; `I_0 = 0`,
    /// `I_1 = 1`, `I_x(1, 1) = x`, `I_x(a, 1) = x^a`, `I_x(1, b) = 1 − (1 − x)^b`, and the
    /// symmetry `I_x(a, b) = 1 − I_{1−x}(b, a)` on both sides of the fraction's switch.
    #[test]
    fn ln_gamma_and_the_incomplete_beta_at_their_closed_forms() {
        use super::{inc_beta, ln_gamma};
        let close = |a: f64, b: f64, tol: f64| {
            assert!((a - b).abs() <= tol * b.abs().max(1.0), "{a} vs {b}")
        };
        close(ln_gamma(1.0), 0.0, 1e-14);
        close(ln_gamma(2.0), 0.0, 1e-14);
        close(ln_gamma(0.5), 0.5 * std::f64::consts::PI.ln(), 1e-14);
        close(ln_gamma(10.0), 362_880f64.ln(), 1e-14);
        close(ln_gamma(0.1), 9.513_507_698_668_732f64.ln(), 1e-13);
        let eps = 1e-8;
        close(
            ln_gamma(eps),
            (1.0 / eps - 0.577_215_664_901_532_9).ln(),
            1e-12,
        );
        for x in [1e-12, 0.1, 0.37, 0.5, 0.8, 0.999_999] {
            assert_eq!(inc_beta(2.5, 0.5, 0.0), 0.0);
            assert_eq!(inc_beta(2.5, 0.5, 1.0), 1.0);
            close(inc_beta(1.0, 1.0, x), x, 1e-13);
            close(inc_beta(3.5, 1.0, x), x.powf(3.5), 1e-12);
            close(inc_beta(1.0, 4.0, x), 1.0 - (1.0 - x).powi(4), 1e-12);
            close(
                inc_beta(2.5, 0.5, x),
                1.0 - inc_beta(0.5, 2.5, 1.0 - x),
                1e-12,
            );
        }
    }

    #[test]
    fn the_pareto_front_keeps_strict_improvements_in_order() {
        let f = super::pareto(
            [
                (3.0, 1.0),
                (1.0, 5.0),
                (2.0, 5.0),
                (0.0, 9.0),
                (4.0, f64::NAN),
            ]
            .into_iter(),
        );
        assert_eq!(f, vec![(0.0, 9.0), (1.0, 5.0), (3.0, 1.0)]);
    }
}
