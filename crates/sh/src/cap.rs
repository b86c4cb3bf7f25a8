//! Closed-form SH coefficients of a spherical cap: the indicator of `θ ≤ A` about +z.
//!
//! The cap is zonal: `c_l^0 = 2π K_l ∫_{cos A}^1 P_l(x) dx`, `K_l = √((2l+1)/4π)`, all `m ≠ 0` zero.
//! With `∫_x^1 P_0 = 1 − x` and, for `l ≥ 1`, `∫_x^1 P_l = (P_{l−1}(x) − P_{l+1}(x)) / (2l+1)`
//! (from `(2l+1) P_l = P'_{l+1} − P'_{l−1}`). To stay accurate for tiny caps, where both Legendre
//! values are ≈ 1, the recurrence is run on `E_l = 1 − P_l(x)` with `t = 1 − x = 2 sin²(A/2)`:
//!
//! ```text
//! E_0 = 0, E_1 = t,  E_{l+1} = ((2l+1)(t + (1−t) E_l) − l E_{l−1}) / (l+1)
//! ∫_x^1 P_l = (E_{l+1} − E_{l−1}) / (2l+1)
//! ```
//!
//! which has no cancellation of O(1) terms, so the coefficients keep ~full *relative* accuracy
//! down to `A = 1e-6` rad and below. Domain: `A ∈ [0, π]` (A = π is the full sphere, `c_0 = √(4π)`).

use crate::error::ShError;

use crate::index::{check_order, coeff_count, sh_index};
use std::f64::consts::PI;

/// Zonal coefficients `c_l^0`, `l = 0..N−1`, of the cap of half-angle `angle` (radians).
pub fn cap_zonal(order: usize, angle: f64) -> Result<Vec<f64>, ShError> {
    check_order(order)?;
    if !(0.0..=PI).contains(&angle) {
        return Err(ShError::Domain {
            name: "cap angle (rad)",
            value: angle,
            domain: "[0, π]",
        });
    }
    let t = 2.0 * (0.5 * angle).sin().powi(2);
    // E_0 .. E_N.
    let mut e = vec![0.0; order + 1];
    if order >= 1 {
        e[1] = t;
    }
    for l in 1..order {
        let lf = l as f64;
        e[l + 1] = ((2.0 * lf + 1.0) * (t + (1.0 - t) * e[l]) - lf * e[l - 1]) / (lf + 1.0);
    }
    Ok((0..order)
        .map(|l| {
            let integral = if l == 0 {
                t
            } else {
                (e[l + 1] - e[l - 1]) / (2 * l + 1) as f64
            };
            2.0 * PI * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * integral
        })
        .collect())
}

/// All `N²` coefficients (index order) of the cap of half-angle `angle` (radians) about +z.
pub fn cap_coeffs(order: usize, angle: f64) -> Result<Vec<f64>, ShError> {
    let z = cap_zonal(order, angle)?;
    let mut c = vec![0.0; coeff_count(order)];
    for (l, v) in z.into_iter().enumerate() {
        c[sh_index(l, 0)] = v;
    }
    Ok(c)
}
