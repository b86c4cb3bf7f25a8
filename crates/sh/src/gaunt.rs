//! The SH triple product through Gaunt coefficients, stored as a sparse tensor.
//!
//! `G_ijk = ∫ Y_i Y_j Y_k dω`; the product of two order-`N` functions, projected back to order
//! `N`, is `c_k = Σ_ij G_ijk a_i b_j` (Ng, Ramamoorthi & Hanrahan 2004; Snyder 2006, "Code
//! generation and factoring for fast evaluation of low-order spherical harmonic products").
//!
//! Each coefficient factors as `Φ(m_i, m_j, m_k) · Θ`, with the azimuthal integral
//! `Φ = ∫₀^{2π} S_{m_i} S_{m_j} S_{m_k} dφ` (`S_m = √2 cos mφ`, `√2 sin|m|φ` or 1) evaluated exactly by
//! the trapezoid rule on `2(|m_i|+|m_j|+|m_k|)+2` points (exact for trigonometric polynomials of
//! that degree), and the polar integral `Θ = ∫ P̄_{l_i}^{|m_i|} P̄_{l_j}^{|m_j|} P̄_{l_k}^{|m_k|} dx`
//! evaluated exactly by Gauss–Legendre with `⌈3N/2⌉+1` nodes (the integrand is a polynomial of
//! degree `≤ 3(N−1)` because the surviving `m` satisfy `|m_i|+|m_j|+|m_k|` even). Selection rules
//! (triangle inequality, even `l_i+l_j+l_k`, `|m_k| ∈ {|m_i|+|m_j|, ||m_i|−|m_j||}`) skip the zeros.
//! Entries are kept with `i ≤ j` only (the tensor is symmetric).

use crate::error::ShError;
use crate::index::{check_coeffs, check_order, coeff_count, sh_lm};
use crate::legendre::{tri_count, tri_index, Legendre};
use crate::quadrature::GaussLegendre;
use crate::real::Real;
use std::f64::consts::PI;

/// Sparse Gaunt tensor of one order; entries with `i ≤ j`, sorted by `k`.
#[derive(Clone, Debug)]
pub struct GauntTensor<T> {
    order: usize,
    entries: Vec<(u32, u32, u32, T)>,
}

/// Magnitude below which a computed coefficient is treated as a structural zero.
pub(crate) const GAUNT_ZERO: f64 = 1e-14;

impl<T: Real> GauntTensor<T> {
    /// Build the tensor for order `N` (`1 ≤ N ≤ 32`; the entry count grows like `N⁵`).
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order(order)?;
        if order > 32 {
            return Err(ShError::Order { order, max: 32 });
        }
        let gl = GaussLegendre::new(3 * order / 2 + 2);
        let leg = Legendre::<f64>::new(order)?;
        let tc = tri_count(order);
        // Polar parts at every node.
        let mut table = vec![0.0; gl.nodes.len() * tc];
        for (q, &x) in gl.nodes.iter().enumerate() {
            leg.eval(x, (1.0 - x * x).sqrt(), &mut table[q * tc..(q + 1) * tc]);
        }
        let nn = coeff_count(order);
        let lm: Vec<(usize, i64)> = (0..nn).map(sh_lm).collect();
        let mut entries = Vec::new();
        for k in 0..nn {
            let (lk, mk) = lm[k];
            for i in 0..nn {
                let (li, mi) = lm[i];
                for j in i..nn {
                    let (lj, mj) = lm[j];
                    if lk < li.abs_diff(lj) || lk > li + lj || (li + lj + lk) % 2 == 1 {
                        continue;
                    }
                    let (ai, aj, ak) = (mi.unsigned_abs(), mj.unsigned_abs(), mk.unsigned_abs());
                    if ak != ai + aj && ak != ai.abs_diff(aj) {
                        continue;
                    }
                    let phi = azimuthal(mi, mj, mk);
                    if phi.abs() < GAUNT_ZERO {
                        continue;
                    }
                    let (ti, tj, tk) = (
                        tri_index(li, ai as usize),
                        tri_index(lj, aj as usize),
                        tri_index(lk, ak as usize),
                    );
                    let theta: f64 = gl
                        .weights
                        .iter()
                        .enumerate()
                        .map(|(q, w)| {
                            w * table[q * tc + ti] * table[q * tc + tj] * table[q * tc + tk]
                        })
                        .sum();
                    let v = phi * theta;
                    if v.abs() > GAUNT_ZERO {
                        entries.push((i as u32, j as u32, k as u32, T::c(v)));
                    }
                }
            }
        }
        Ok(Self { order, entries })
    }

    /// The order `N`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Stored entries `(i, j, k, G_ijk)` with `i ≤ j`.
    pub fn entries(&self) -> &[(u32, u32, u32, T)] {
        &self.entries
    }

    /// `G_ijk` for any `i, j, k < N²` (linear search; for tests and inspection).
    pub fn get(&self, i: usize, j: usize, k: usize) -> T {
        let (i, j) = (i.min(j), i.max(j));
        self.entries
            .iter()
            .find(|e| e.0 as usize == i && e.1 as usize == j && e.2 as usize == k)
            .map_or(T::zero(), |e| e.3)
    }

    /// The projected product `c = P_N(f·g)` of two order-`N` coefficient vectors.
    pub fn product(&self, a: &[T], b: &[T], out: &mut [T]) -> Result<(), ShError> {
        check_coeffs(self.order, a.len())?;
        check_coeffs(self.order, b.len())?;
        check_coeffs(self.order, out.len())?;
        out.iter_mut().for_each(|o| *o = T::zero());
        for &(i, j, k, g) in &self.entries {
            let (i, j) = (i as usize, j as usize);
            let ab = if i == j {
                a[i] * b[i]
            } else {
                a[i] * b[j] + a[j] * b[i]
            };
            out[k as usize] = out[k as usize] + g * ab;
        }
        Ok(())
    }
}

/// `∫₀^{2π} S_a S_b S_c dφ` by the exact trapezoid rule.
fn azimuthal(a: i64, b: i64, c: i64) -> f64 {
    let s = |m: i64, phi: f64| -> f64 {
        match m.signum() {
            1 => std::f64::consts::SQRT_2 * (m as f64 * phi).cos(),
            -1 => std::f64::consts::SQRT_2 * (-m as f64 * phi).sin(),
            _ => 1.0,
        }
    };
    let n = 2 * (a.abs() + b.abs() + c.abs()) as usize + 2;
    let h = 2.0 * PI / n as f64;
    (0..n)
        .map(|q| q as f64 * h)
        .map(|p| s(a, p) * s(b, p) * s(c, p))
        .sum::<f64>()
        * h
}
