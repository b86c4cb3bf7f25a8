//! Projection of sampled values or of a closure onto SH, reconstruction, and the dot product.
//!
//! `c_i = Σ_j w_j f(ω_j) Y_i(ω_j)` approximates `∫ f Y_i dω` (exact for band-limited `f` on a
//! [`DirectionSet::gauss_sphere_for_order`] set); `f(ω) ≈ Σ_i c_i Y_i(ω)`; by orthonormality
//! `∫ f g dω = Σ_i f_i g_i` for band-limited `f, g` (Parseval).

use crate::error::ShError;

use crate::eval::ShBasis;

use crate::index::check_coeffs;

use crate::quadrature::DirectionSet;

use crate::real::Real;

/// Project sampled values `values[j] = f(set.dirs[j])` onto order `basis.order()`.
pub fn project_samples<T: Real>(
    basis: &ShBasis<T>,
    set: &DirectionSet,
    values: &[T],
) -> Result<Vec<T>, ShError> {
    if values.len() != set.len() {
        return Err(ShError::Length {
            what: "project_samples: values vs directions",
            a: values.len(),
            b: set.len(),
        });
    }
    let nn = basis.len();
    let mut out = vec![T::zero(); nn];
    let mut y = vec![T::zero(); nn];
    for ((d, &w), &f) in set.dirs.iter().zip(&set.weights).zip(values) {
        if f == T::zero() {
            continue;
        }
        basis.eval(d.map(T::c), &mut y);
        let wf = T::c(w) * f;
        for (o, yi) in out.iter_mut().zip(&y) {
            *o = *o + wf * *yi;
        }
    }
    Ok(out)
}

/// Project the function `f` onto order `basis.order()` with the quadrature `set`.
pub fn project_fn<T: Real>(
    basis: &ShBasis<T>,
    set: &DirectionSet,
    mut f: impl FnMut([f64; 3]) -> T,
) -> Vec<T> {
    let values: Vec<T> = set.dirs.iter().map(|d| f(*d)).collect();
    project_samples(basis, set, &values).expect("lengths agree by construction")
}

/// `Σ_i c_i Y_i(d)` at the unit direction `d`.
pub fn reconstruct<T: Real>(basis: &ShBasis<T>, coeffs: &[T], d: [T; 3]) -> Result<T, ShError> {
    check_coeffs(basis.order(), coeffs.len())?;
    let y = basis.values(d);
    Ok(dot(coeffs, &y))
}

/// `Σ_i a_i b_i` over the common length: the integral of the product of two band-limited
/// functions.
#[inline]
pub fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    a.iter().zip(b).fold(T::zero(), |acc, (x, y)| acc + *x * *y)
}
