//! The clamped-cosine lobe `max(0, cosθ)` and irradiance from SH lighting.
//!
//! The lobe is zonal; its coefficients are `z_l = 2π √((2l+1)/4π) ∫₀¹ P_l(x) x dx` with
//! `∫₀¹ P_0 x = 1/2`, `∫₀¹ P_1 x = 1/3`, zero for odd `l ≥ 3`, and for even `l ≥ 2`
//! `∫₀¹ P_l x = (−1)^{l/2−1} / ((l+2)(l−1)) · C(l, l/2) / 2^l` (Ramamoorthi & Hanrahan 2001,
//! "An efficient representation for irradiance environment maps", Eq. 8; there `Â_l = 2π·∫`).
//! `C(l, l/2)/2^l` is formed as a running product so nothing overflows at any order.
//! Irradiance at normal `n` under lighting `L`: `E(n) = ∫ L(ω) max(0, n·ω) dω = Σ L_i c_i(n)` with
//! `c(n)` the lobe rotated onto `n` ([`crate::rotation::rotate_zonal`]).

use crate::error::ShError;

use crate::eval::ShBasis;

use crate::index::check_coeffs;

use crate::project::dot;

use crate::real::Real;

use crate::rotation::rotate_zonal;
use std::f64::consts::PI;

/// Zonal coefficients `z_l`, `l = 0..N−1`, of `max(0, cosθ)` about +z.
pub fn clamped_cosine_zonal(order: usize) -> Vec<f64> {
    let mut z = vec![0.0; order];
    // r = C(l, l/2)/2^l for even l, updated by r_{l+2} = r_l (l+1)(l+2) / (4 (l/2+1)²).
    let mut r = 1.0;
    for l in 0..order {
        let integral = match l {
            0 => 0.5,
            1 => 1.0 / 3.0,
            _ if l % 2 == 1 => 0.0,
            _ => {
                let sign = if (l / 2 - 1) % 2 == 0 { 1.0 } else { -1.0 };
                sign * r / (((l + 2) * (l - 1)) as f64)
            }
        };
        z[l] = 2.0 * PI * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * integral;
        if l % 2 == 0 {
            let h = (l / 2) as f64 + 1.0;
            r *= (l as f64 + 1.0) * (l as f64 + 2.0) / (4.0 * h * h);
        }
    }
    z
}

/// The clamped-cosine lobe of one order, ready to be rotated onto normals.
#[derive(Clone, Debug)]
pub struct ClampedCosine<T> {
    basis: ShBasis<T>,
    zonal: Vec<T>,
}

impl<T: Real> ClampedCosine<T> {
    /// Lobe tables for order `N`.
    pub fn new(order: usize) -> Result<Self, ShError> {
        Ok(Self {
            basis: ShBasis::new(order)?,
            zonal: clamped_cosine_zonal(order).into_iter().map(T::c).collect(),
        })
    }

    /// The lobe's coefficients about the unit normal `n`.
    pub fn lobe(&self, n: [T; 3], out: &mut [T]) -> Result<(), ShError> {
        rotate_zonal(&self.basis, &self.zonal, n, out)
    }

    /// `E(n) = Σ L_i c_i(n)`: irradiance at unit normal `n` under lighting coefficients `light`.
    pub fn irradiance(&self, light: &[T], n: [T; 3]) -> Result<T, ShError> {
        check_coeffs(self.basis.order(), light.len())?;
        let mut c = vec![T::zero(); light.len()];
        self.lobe(n, &mut c)?;
        Ok(dot(light, &c))
    }
}

/// One-shot irradiance: `E(n)` for lighting `light` (length `N²`) at unit normal `n`.
pub fn irradiance(light: &[f64], n: [f64; 3]) -> Result<f64, ShError> {
    let order = crate::index::order_of_len(light.len()).ok_or(ShError::CoeffCount {
        order: 0,
        expected: 0,
        got: light.len(),
    })?;
    ClampedCosine::<f64>::new(order)?.irradiance(light, n)
}
