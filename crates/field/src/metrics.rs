//! Accuracy metrics, named as in docs/conventions.md §6 (CSV headers use these names).
//!
//! * `vis_rel_l2 = ‖S_ext − S_true‖ / ‖S_true‖` over coefficients — by Parseval the relative L2
//!   error of the band-limited visibility functions;
//! * `occ_rel_l2 = ‖S_ext − S_true‖ / ‖S_occ_true‖`, `S_occ = P_N(1 − V) = √(4π)e₀ − S_true`: the
//!   honest figure, because the constant 1 dominates `‖S_true‖`.
//!
//! Both are `None` when their denominator vanishes (a point that sees nothing, or nothing
//! occluded), so callers can count such points instead of averaging infinities.

/// Euclidean norm of a coefficient vector.
pub fn l2(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `‖a − b‖`.
pub fn l2_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// The occlusion `S_occ = P_N(1 − V) = √(4π)e₀ − S` of visibility coefficients `v`.
pub fn occlusion(v: &[f64]) -> Vec<f64> {
    let mut occ: Vec<f64> = v.iter().map(|x| -x).collect();
    occ[0] += (4.0 * std::f64::consts::PI).sqrt();
    occ
}

/// The occluded fraction of the facing hemisphere of a sample's visibility `v` (entity frame,
/// back hemisphere unoccluded): `(4π − √(4π) v₀) / 2π`.
pub fn facing_occlusion(v: &[f64]) -> f64 {
    let s0 = (4.0 * std::f64::consts::PI).sqrt();
    (4.0 * std::f64::consts::PI - s0 * v[0]) / (2.0 * std::f64::consts::PI)
}

/// `vis_rel_l2`, or `None` when `‖S_true‖` is 0.
pub fn vis_rel_l2(ext: &[f64], truth: &[f64]) -> Option<f64> {
    let d = l2(truth);
    (d > 0.0).then(|| l2_diff(ext, truth) / d)
}

/// `occ_rel_l2`, or `None` when the truth has nothing occluded (`‖S_occ_true‖ ≤ 1e-12`).
pub fn occ_rel_l2(ext: &[f64], truth: &[f64]) -> Option<f64> {
    let d = l2(&occlusion(truth));
    (d > 1e-12).then(|| l2_diff(ext, truth) / d)
}

/// Mean and max of the present values, and how many were present.
pub fn mean_max(values: impl Iterator<Item = Option<f64>>) -> (Option<f64>, Option<f64>, usize) {
    let v: Vec<f64> = values.flatten().collect();
    if v.is_empty() {
        return (None, None, 0);
    }
    (
        Some(v.iter().sum::<f64>() / v.len() as f64),
        Some(v.iter().copied().fold(f64::MIN, f64::max)),
        v.len(),
    )
}

/// The probability levels of [`quantiles`] the probe rows report: p5, p25, median, p75, p95.
pub const QUANTILE_LEVELS: [f64; 5] = [0.05, 0.25, 0.5, 0.75, 0.95];

/// Quantiles of the present values at levels `qs` (each in [0, 1]): linear interpolation between
/// order statistics at position `q·(n − 1)` (Hyndman–Fan type 7, the default of R and NumPy).
/// `None` for every level when no value is present. Domain: finite values (a NaN sorts last by
/// `total_cmp` and would stand for the largest).
pub fn quantiles(values: impl Iterator<Item = Option<f64>>, qs: &[f64]) -> Vec<Option<f64>> {
    let mut v: Vec<f64> = values.flatten().collect();
    if v.is_empty() {
        return vec![None; qs.len()];
    }
    v.sort_by(f64::total_cmp);
    let last = (v.len() - 1) as f64;
    qs.iter()
        .map(|&q| {
            let h = q.clamp(0.0, 1.0) * last;
            let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
            Some(v[lo] + (h - lo as f64) * (v[hi] - v[lo]))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against NumPy's default (`np.quantile(x, q)`, linear): for 1..=5, p5 = 1.2, p25 = 2,
    /// p50 = 3, p75 = 4, p95 = 4.8; one value is every quantile; none gives None; absent values
    /// are skipped; the order of the input does not matter.
    #[test]
    fn quantiles_match_the_linear_rule() {
        let q = |v: &[f64]| quantiles(v.iter().map(|x| Some(*x)), &QUANTILE_LEVELS);
        let got: Vec<f64> = q(&[5.0, 1.0, 4.0, 2.0, 3.0])
            .into_iter()
            .flatten()
            .collect();
        let want = [1.2, 2.0, 3.0, 4.0, 4.8];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{got:?}");
        }
        assert_eq!(q(&[7.0]), vec![Some(7.0); 5]);
        assert_eq!(q(&[]), vec![None; 5]);
        let with_gaps = quantiles([Some(1.0), None, Some(3.0)].into_iter(), &[0.5]);
        assert_eq!(with_gaps, vec![Some(2.0)]);
        assert_eq!(
            quantiles([Some(1.0), Some(3.0)].into_iter(), &[0.0, 1.0]),
            vec![Some(1.0), Some(3.0)]
        );
    }

    #[test]
    fn metrics_on_simple_vectors() {
        let s = (4.0 * std::f64::consts::PI).sqrt();
        let truth = [s - 1.0, 0.5, 0.0, 0.0];
        let ext = [s - 1.0, 0.0, 0.0, 0.0];
        let v = vis_rel_l2(&ext, &truth).unwrap();
        assert!((v - 0.5 / ((s - 1.0).powi(2) + 0.25).sqrt()).abs() < 1e-15);
        let o = occ_rel_l2(&ext, &truth).unwrap();
        assert!((o - 0.5 / (1.0f64 + 0.25).sqrt()).abs() < 1e-15);
        assert!(occ_rel_l2(&ext, &[s, 0.0, 0.0, 0.0]).is_none());
        assert!(vis_rel_l2(&ext, &[0.0; 4]).is_none());
        assert_eq!(
            mean_max([Some(1.0), None, Some(3.0)].into_iter()),
            (Some(2.0), Some(3.0), 2)
        );
    }
}
