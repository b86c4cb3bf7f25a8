//! Coefficient indexing: `i = l·l + l + m` for band `l` and `m = -l..=l` (docs/conventions.md §1).

use crate::error::ShError;

/// Largest order accepted by the public API. Evaluation, projection and rotation are tested to be
/// orthonormal at `N = 64` and finite at this bound; above it the Gaunt tensor and rotation
/// matrices grow past what any experiment here needs.
pub const MAX_ORDER: usize = 128;

/// Index of coefficient `(l, m)`: `l·l + l + m`. Domain: `|m| ≤ l`.
#[inline(always)]
pub const fn sh_index(l: usize, m: i64) -> usize {
    ((l * l + l) as i64 + m) as usize
}

/// Inverse of [`sh_index`]: band `l` and order `m` of coefficient `i`.
#[inline]
pub fn sh_lm(i: usize) -> (usize, i64) {
    let mut l = (i as f64).sqrt() as usize;
    // Guard against rounding of the square root for large i.
    while l * l > i {
        l -= 1;
    }
    while (l + 1) * (l + 1) <= i {
        l += 1;
    }
    (l, i as i64 - (l * l + l) as i64)
}

/// Number of coefficients of order `N`: `N²`.
#[inline(always)]
pub const fn coeff_count(order: usize) -> usize {
    order * order
}

/// Check `1 ≤ order ≤ MAX_ORDER`.
pub fn check_order(order: usize) -> Result<(), ShError> {
    if order == 0 || order > MAX_ORDER {
        Err(ShError::Order {
            order,
            max: MAX_ORDER,
        })
    } else {
        Ok(())
    }
}

/// Check that `coeffs.len() == order²`.
pub fn check_coeffs(order: usize, len: usize) -> Result<(), ShError> {
    if len != coeff_count(order) {
        Err(ShError::CoeffCount {
            order,
            expected: coeff_count(order),
            got: len,
        })
    } else {
        Ok(())
    }
}

/// Order `N` such that `N² == len`, if `len` is a perfect square ≥ 1.
pub fn order_of_len(len: usize) -> Option<usize> {
    let (l, m) = sh_lm(len.checked_sub(1)?);
    (m == l as i64).then_some(l + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_roundtrip_and_order_of_len() {
        let mut i = 0;
        for l in 0..200usize {
            for m in -(l as i64)..=(l as i64) {
                assert_eq!(sh_index(l, m), i);
                assert_eq!(sh_lm(i), (l, m));
                i += 1;
            }
            assert_eq!(order_of_len((l + 1) * (l + 1)), Some(l + 1));
            if l > 0 {
                assert_eq!(order_of_len((l + 1) * (l + 1) - 1), None);
            }
        }
        assert_eq!(order_of_len(0), None);
        assert!(check_order(0).is_err());
        assert!(check_order(MAX_ORDER + 1).is_err());
        assert!(check_order(MAX_ORDER).is_ok());
    }
}
