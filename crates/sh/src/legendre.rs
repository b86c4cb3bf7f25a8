//! Normalised associated Legendre functions `P̄_l^m(x) = K_l^m · P_l^m(x)` (no Condon–Shortley
//! phase) by the standard normalised three-term recurrences — no factorials anywhere.
//!
//! With `K_l^m = √((2l+1)(l−m)! / (4π (l+m)!))` and `s = sinθ = √(1−x²)` (passed in, so callers
//! that know θ keep full accuracy near the poles):
//!
//! ```text
//! P̄_0^0     = 1/√(4π)
//! P̄_m^m     = √((2m+1)/(2m)) · s · P̄_{m−1}^{m−1}                       (m ≥ 1)
//! P̄_{m+1}^m = √(2m+3) · x · P̄_m^m
//! P̄_l^m     = a_l^m (x P̄_{l−1}^m − b_l^m P̄_{l−2}^m),                    (l ≥ m+2)
//!   a_l^m = √((4l²−1)/(l²−m²)),  b_l^m = √(((l−1)²−m²)/(4(l−1)²−1))
//! ```
//!
//! Source: the recurrences of Holmes & Featherstone (2002, J. Geodesy 76) in the 4π-normalised
//! form, as used by sphericart (Bigi et al. 2023). Valid for `x ∈ [−1, 1]` and any order up to
//! [`crate::MAX_ORDER`]: every intermediate is bounded by `√((2l+1)/4π)·O(1)`, so nothing
//! overflows; `s^m` may underflow to zero for `s ≲ 1e-300^(1/m)`, where the true value is below
//! the smallest normal number anyway.

use crate::error::ShError;

use crate::index::check_order;

use crate::real::Real;

/// Index of `(l, m)`, `0 ≤ m ≤ l`, in a triangular array: `l(l+1)/2 + m`.
#[inline(always)]
pub const fn tri_index(l: usize, m: usize) -> usize {
    l * (l + 1) / 2 + m
}

/// Size of the triangular array for order `N`: `N(N+1)/2`.
#[inline(always)]
pub const fn tri_count(order: usize) -> usize {
    order * (order + 1) / 2
}

/// Precomputed recurrence coefficients for one order, in the precision `T`.
#[derive(Clone, Debug)]
pub struct Legendre<T> {
    order: usize,
    /// `√((2m+1)/(2m))` for m = 1..N−1 (index m; index 0 unused and holds 1).
    pub(crate) diag: Vec<T>,
    /// `√(2m+3)` for m = 0..N−1.
    pub(crate) sub: Vec<T>,
    /// `(a_l^m, a_l^m·b_l^m)` for m = 0..N−1 (outer), l = m+2..N−1 (inner).
    pub(crate) ab: Vec<(T, T)>,
    /// The same coefficients in l-outer order: l = 2..N−1 (outer), m = 0..l−2 (inner).
    pub(crate) ab_l: Vec<(T, T)>,
    /// `Q_m^m = P̄_m^m / sin^m θ`, a constant, with `√2` folded in for m > 0 (SH evaluation).
    pub(crate) qmm: Vec<T>,
}

impl<T: Real> Legendre<T> {
    /// Build the recurrence tables for order `N` (`1 ≤ N ≤ MAX_ORDER`).
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order(order)?;
        let mut diag = vec![T::one(); order];
        let mut sub = vec![T::zero(); order];
        let mut ab = Vec::with_capacity(tri_count(order));
        for m in 0..order {
            if m > 0 {
                let mf = m as f64;
                diag[m] = T::c(((2.0 * mf + 1.0) / (2.0 * mf)).sqrt());
            }
            sub[m] = T::c((2.0 * m as f64 + 3.0).sqrt());
            for l in (m + 2)..order {
                let (lf, mf) = (l as f64, m as f64);
                let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                let lm1 = lf - 1.0;
                let b = ((lm1 * lm1 - mf * mf) / (4.0 * lm1 * lm1 - 1.0)).sqrt();
                ab.push((T::c(a), T::c(a * b)));
            }
        }
        let mut ab_l = Vec::with_capacity(tri_count(order));
        for l in 2..order {
            for m in 0..=(l - 2) {
                let (lf, mf) = (l as f64, m as f64);
                let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                let lm1 = lf - 1.0;
                let b = ((lm1 * lm1 - mf * mf) / (4.0 * lm1 * lm1 - 1.0)).sqrt();
                ab_l.push((T::c(a), T::c(a * b)));
            }
        }
        let mut q = 0.5 / std::f64::consts::PI.sqrt();
        let mut qmm = Vec::with_capacity(order);
        for m in 0..order {
            if m > 0 {
                let mf = m as f64;
                q *= ((2.0 * mf + 1.0) / (2.0 * mf)).sqrt();
            }
            qmm.push(T::c(if m == 0 {
                q
            } else {
                q * std::f64::consts::SQRT_2
            }));
        }
        Ok(Self {
            order,
            diag,
            sub,
            ab,
            ab_l,
            qmm,
        })
    }

    /// The order `N` these tables serve.
    pub fn order(&self) -> usize {
        self.order
    }

    /// All `P̄_l^m(x)` for `0 ≤ m ≤ l < N`, written to `out[tri_index(l, m)]`.
    ///
    /// `x = cosθ`, `s = sinθ ≥ 0`; pass both so that values near the poles keep full relative
    /// accuracy (`s` computed as `√(1−x²)` loses half the digits there). Domain: `x² + s² = 1`.
    pub fn eval(&self, x: T, s: T, out: &mut [T]) {
        let n = self.order;
        assert!(out.len() >= tri_count(n), "output slice too short");
        let mut pmm = T::c(0.5 / std::f64::consts::PI.sqrt()); // 1/√(4π)
        let mut k = 0;
        for m in 0..n {
            if m > 0 {
                pmm = pmm * self.diag[m] * s;
            }
            out[tri_index(m, m)] = pmm;
            if m + 1 < n {
                let mut p2 = pmm;
                let mut p1 = self.sub[m] * x * pmm;
                out[tri_index(m + 1, m)] = p1;
                for l in (m + 2)..n {
                    let (a, ab) = self.ab[k];
                    k += 1;
                    let p = a * x * p1 - ab * p2;
                    out[tri_index(l, m)] = p;
                    p2 = p1;
                    p1 = p;
                }
            }
        }
    }

    /// Convenience: `P̄_l^m(cosθ)` for all `(l, m)` at polar angle `θ ∈ [0, π]`.
    pub fn eval_theta(&self, theta: T, out: &mut [T]) {
        self.eval(theta.cos(), theta.sin(), out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms of `K_l^m P_l^m(x)` (no Condon–Shortley phase) for l ≤ 3.
    fn closed(l: usize, m: usize, x: f64) -> f64 {
        let s = (1.0 - x * x).sqrt();
        let pi = std::f64::consts::PI;
        match (l, m) {
            (0, 0) => (1.0 / (4.0 * pi)).sqrt(),
            (1, 0) => (3.0 / (4.0 * pi)).sqrt() * x,
            (1, 1) => (3.0 / (8.0 * pi)).sqrt() * s,
            (2, 0) => (5.0 / (4.0 * pi)).sqrt() * 0.5 * (3.0 * x * x - 1.0),
            (2, 1) => (5.0 / (24.0 * pi)).sqrt() * 3.0 * x * s,
            (2, 2) => (5.0 / (96.0 * pi)).sqrt() * 3.0 * s * s,
            (3, 0) => (7.0 / (4.0 * pi)).sqrt() * 0.5 * (5.0 * x * x * x - 3.0 * x),
            (3, 1) => (7.0 / (48.0 * pi)).sqrt() * 1.5 * (5.0 * x * x - 1.0) * s,
            (3, 2) => (7.0 / (480.0 * pi)).sqrt() * 15.0 * x * s * s,
            (3, 3) => (7.0 / (2880.0 * pi)).sqrt() * 15.0 * s * s * s,
            _ => unreachable!(),
        }
    }

    #[test]
    fn matches_closed_forms_to_l3() {
        const TOL: f64 = 1e-14;
        let leg = Legendre::<f64>::new(4).unwrap();
        let mut out = vec![0.0; tri_count(4)];
        for i in 0..=40 {
            let theta = std::f64::consts::PI * i as f64 / 40.0;
            leg.eval_theta(theta, &mut out);
            for l in 0..4 {
                for m in 0..=l {
                    let want = closed(l, m, theta.cos());
                    let err = (out[tri_index(l, m)] - want).abs();
                    assert!(
                        err < TOL,
                        "l={l} m={m} θ={theta}: got {} want {want} err {err:e}",
                        out[tri_index(l, m)]
                    );
                }
            }
        }
    }
}
