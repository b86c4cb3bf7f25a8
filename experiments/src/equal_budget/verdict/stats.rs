//! Means with their 95 % intervals (normal, Student-t, cluster-robust) and the Pareto front.

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

/// Student's t quantile t_{0.975, df} for df = 1..=30 (beyond: 1.96 is within 4 %).
const T975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];

/// Mean of `v` and the half-width of its 95 % Student-t interval (`None` below 2 values).
pub fn mean_t95(v: &[f64]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let ci = (v.len() >= 2).then(|| {
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
        let t = T975.get(v.len() - 2).copied().unwrap_or(1.96);
        t * (var / n).sqrt()
    });
    (Some(m), ci)
}

/// Mean of `(cluster, value)` pairs and the half-width of its 95 % interval clustered by
/// `cluster` (receivers that share a direction are not independent): the cluster-robust
/// variance of the mean, `G/(G−1) · Σ_g (S_g − n_g·m)² / n²` over the G clusters (`S_g` the sum
/// of cluster g's n_g values), times 1.96² — the sandwich estimator of Liang & Zeger (1986) for
/// an intercept-only model, with the usual G/(G−1) small-sample factor; it assumes clusters are
/// independent and G large (here 240 directions). With one value per cluster it is the normal
/// interval with the population variance scaled by n/(n−1), i.e. [`mean_ci95`]'s. `None` for
/// fewer than 2 clusters.
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
        1.96 * (g / (g - 1.0) * ss / (n * n)).sqrt()
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
    fn the_clustered_interval_is_the_normal_one_for_singletons_and_wider_for_shared_clusters() {
        // One value per cluster: the same as the normal interval.
        let v = [1.0, 2.0, 3.0, 7.0];
        let single: Vec<(usize, f64)> = v.iter().enumerate().map(|(i, x)| (i, *x)).collect();
        let (m, ci) = super::mean_ci95_clustered(&single);
        let (m0, ci0) = super::mean_ci95(&v);
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
