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

/// The Gaussian window of [`ssim`]: 11 × 11 taps, σ = 1.5 pixels (Wang et al. 2004).
const SSIM_RADIUS: usize = 5;
const SSIM_SIGMA: f64 = 1.5;

fn ssim_taps() -> [f64; 2 * SSIM_RADIUS + 1] {
    let mut w = [0.0; 2 * SSIM_RADIUS + 1];
    for (i, v) in w.iter_mut().enumerate() {
        let x = i as f64 - SSIM_RADIUS as f64;
        *v = (-x * x / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let s: f64 = w.iter().sum();
    w.map(|v| v / s)
}

/// Mean structural similarity of image `x` against the reference `y` (row-major, `w × h`,
/// one channel): Wang, Bovik, Sheikh & Simoncelli, "Image quality assessment: from error
/// visibility to structural similarity", IEEE TIP 2004 — local means, variances and covariance
/// under an 11 × 11 Gaussian window (σ = 1.5), `C1 = (0.01 L)²`, `C2 = (0.03 L)²` for the dynamic
/// range `L`, averaged over the windows that lie wholly inside the image (the paper's "valid"
/// region). 1 for identical images, lower for less similar ones (it can be negative).
/// Domain: `w, h ≥ 11`, finite values, `L > 0`; `None` otherwise.
pub fn ssim(x: &[f64], y: &[f64], w: usize, h: usize, range: f64) -> Option<f64> {
    let n = 2 * SSIM_RADIUS + 1;
    if w < n
        || h < n
        || x.len() != w * h
        || y.len() != w * h
        || !(range > 0.0 && range.is_finite())
        || x.iter().chain(y).any(|v| !v.is_finite())
    {
        return None;
    }
    let g = ssim_taps();
    let (c1, c2) = ((0.01 * range).powi(2), (0.03 * range).powi(2));
    // Separable filtering of the five moment images over the valid region.
    let (vw, vh) = (w - n + 1, h - n + 1);
    let moments: [Box<dyn Fn(usize) -> f64>; 5] = [
        Box::new(|i| x[i]),
        Box::new(|i| y[i]),
        Box::new(|i| x[i] * x[i]),
        Box::new(|i| y[i] * y[i]),
        Box::new(|i| x[i] * y[i]),
    ];
    let filtered: Vec<Vec<f64>> = moments
        .iter()
        .map(|f| {
            // Rows first (every row, valid columns), then columns (valid rows).
            let mut rows = vec![0.0; h * vw];
            for r in 0..h {
                for c in 0..vw {
                    rows[r * vw + c] = (0..n).map(|k| g[k] * f(r * w + c + k)).sum();
                }
            }
            let mut out = vec![0.0; vh * vw];
            for r in 0..vh {
                for c in 0..vw {
                    out[r * vw + c] = (0..n).map(|k| g[k] * rows[(r + k) * vw + c]).sum();
                }
            }
            out
        })
        .collect();
    let total: f64 = (0..vw * vh)
        .map(|i| {
            let (mx, my) = (filtered[0][i], filtered[1][i]);
            let (vx, vy, cxy) = (
                filtered[2][i] - mx * mx,
                filtered[3][i] - my * my,
                filtered[4][i] - mx * my,
            );
            ((2.0 * mx * my + c1) * (2.0 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))
        })
        .sum();
    Some(total / (vw * vh) as f64)
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

    #[test]
    fn ssim_matches_its_closed_forms_and_a_direct_window() {
        let (w, h) = (23, 17);
        // Identical images: 1.
        let img: Vec<f64> = (0..w * h)
            .map(|i| ((i * 37 % 101) as f64).sin() + 2.0)
            .collect();
        let same = ssim(&img, &img, w, h, 3.0).unwrap();
        assert!((same - 1.0).abs() < 1e-12, "{same}");
        // Constant images a and b: no variance, so SSIM = (2ab + C1)/(a² + b² + C1).
        let (a, b, l) = (0.4, 0.9, 1.0);
        let c1 = (0.01f64 * l).powi(2);
        let got = ssim(&vec![a; w * h], &vec![b; w * h], w, h, l).unwrap();
        let want = (2.0 * a * b + c1) / (a * a + b * b + c1);
        println!("constant images: {got} vs closed form {want}");
        assert!((got - want).abs() < 1e-12);
        // A different image against a direct (non-separable) evaluation of every window.
        let other: Vec<f64> = (0..w * h)
            .map(|i| ((i * 13 % 29) as f64).cos() + 1.5)
            .collect();
        let g = ssim_taps();
        let (c1, c2) = ((0.01f64 * 3.0).powi(2), (0.03f64 * 3.0).powi(2));
        let mut sum = 0.0;
        let mut count = 0;
        for r in 0..=h - 11 {
            for c in 0..=w - 11 {
                let (mut mx, mut my, mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for i in 0..11 {
                    for j in 0..11 {
                        let wt = g[i] * g[j];
                        let (p, q) = (other[(r + i) * w + c + j], img[(r + i) * w + c + j]);
                        mx += wt * p;
                        my += wt * q;
                        xx += wt * p * p;
                        yy += wt * q * q;
                        xy += wt * p * q;
                    }
                }
                let (vx, vy, cxy) = (xx - mx * mx, yy - my * my, xy - mx * my);
                sum += ((2.0 * mx * my + c1) * (2.0 * cxy + c2))
                    / ((mx * mx + my * my + c1) * (vx + vy + c2));
                count += 1;
            }
        }
        let direct = sum / count as f64;
        let fast = ssim(&other, &img, w, h, 3.0).unwrap();
        println!("ssim {fast} vs direct windows {direct}");
        assert!((fast - direct).abs() < 1e-12 && fast < 0.9);
        // Outside the domain.
        assert!(ssim(&img[..100], &img[..100], 10, 10, 1.0).is_none());
        assert!(ssim(&img, &img, w, h, 0.0).is_none());
        let mut nan = img.clone();
        nan[3] = f64::NAN;
        assert!(ssim(&nan, &img, w, h, 1.0).is_none());
    }
}
