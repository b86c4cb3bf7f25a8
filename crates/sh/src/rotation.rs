//! Rotation of SH coefficient vectors.
//!
//! Active rotation: for a rotation `R`, the rotated function is `g(ω) = f(R⁻¹ω)`; its coefficients
//! are `g = D(R) f` with `D` block-diagonal, one orthogonal `(2l+1)×(2l+1)` block per band.
//!
//! Method: the real-SH recurrence of Ivanic & Ruedenberg (J. Phys. Chem. 100, 6342, 1996) with the
//! correction published in J. Phys. Chem. A 102, 9099 (1998) (the `V` term for `m < 0`). Band 1 is
//! `R` itself with rows and columns permuted to the basis order `(y, z, x)`; band `l` follows from
//! band `l−1` and band 1 through the `U, V, W` terms. Each band costs `O((2l+1)²)`, the whole
//! construction `O(N³)`, with no trigonometric calls, so building a rotation is cheap enough to do
//! per receiver. Our basis (no Condon–Shortley phase) is the one Ivanic & Ruedenberg use for real
//! orbitals, so no sign fix-ups are needed; the tests check every band against re-projection of
//! the rotated function on an exact quadrature grid.

use crate::{check_coeffs, check_order, coeff_count, Real, ShBasis, ShError};

/// A 3×3 rotation matrix, row-major: `R[row][col]`.
pub type Mat3<T> = [[T; 3]; 3];

/// `R = Rz(a) · Ry(b) · Rz(c)` for angles in radians.
pub fn euler_zyz(a: f64, b: f64, c: f64) -> Mat3<f64> {
    let rz = |t: f64| {
        [
            [t.cos(), -t.sin(), 0.0],
            [t.sin(), t.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ]
    };
    let ry = |t: f64| {
        [
            [t.cos(), 0.0, t.sin()],
            [0.0, 1.0, 0.0],
            [-t.sin(), 0.0, t.cos()],
        ]
    };
    mat_mul(&mat_mul(&rz(a), &ry(b)), &rz(c))
}

/// `A·B` for 3×3 matrices.
pub fn mat_mul(a: &Mat3<f64>, b: &Mat3<f64>) -> Mat3<f64> {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// The block-diagonal SH rotation matrix `D(R)` of one order.
#[derive(Clone, Debug)]
pub struct ShRotation<T> {
    order: usize,
    /// Band `l` block at `offset(l)`, row-major, `(2l+1)²` entries, row/col index `m + l`.
    data: Vec<T>,
}

/// Start of band `l` in the packed block storage: `Σ_{k<l} (2k+1)² = l(4l²−1)/3`.
#[inline(always)]
const fn offset(l: usize) -> usize {
    l * (4 * l * l - 1) / 3
}

impl<T: Real> ShRotation<T> {
    /// Build `D(R)` for order `N` from a proper rotation matrix `r` (orthonormal, det +1; not
    /// checked beyond a debug assertion — a reflection would give a meaningless result).
    pub fn new(order: usize, r: &Mat3<T>) -> Result<Self, ShError> {
        check_order(order)?;
        let mut data = vec![T::zero(); offset(order)];
        data[0] = T::one();
        if order > 1 {
            // Basis order (y, z, x) ↔ m = −1, 0, 1.
            const P: [usize; 3] = [1, 2, 0];
            for i in 0..3 {
                for j in 0..3 {
                    data[offset(1) + i * 3 + j] = r[P[i]][P[j]];
                }
            }
        }
        for l in 2..order {
            let (prev, cur) = data.split_at_mut(offset(l));
            let r1 = &prev[offset(1)..offset(2)];
            let rl1 = &prev[offset(l - 1)..];
            band(l, r1, rl1, &mut cur[..(2 * l + 1) * (2 * l + 1)]);
        }
        Ok(Self { order, data })
    }

    /// The order `N`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Entry `D^l_{m,n}` of band `l`.
    pub fn get(&self, l: usize, m: i64, n: i64) -> T {
        let w = 2 * l + 1;
        self.data[offset(l) + (m + l as i64) as usize * w + (n + l as i64) as usize]
    }

    /// `out = D · input` (the coefficients of the rotated function). Both of length `N²`.
    pub fn apply(&self, input: &[T], out: &mut [T]) -> Result<(), ShError> {
        check_coeffs(self.order, input.len())?;
        check_coeffs(self.order, out.len())?;
        self.apply_impl(input, out, false);
        Ok(())
    }

    /// `out = Dᵀ · input` (rotation by `R⁻¹`; `D` is orthogonal).
    pub fn apply_inverse(&self, input: &[T], out: &mut [T]) -> Result<(), ShError> {
        check_coeffs(self.order, input.len())?;
        check_coeffs(self.order, out.len())?;
        self.apply_impl(input, out, true);
        Ok(())
    }

    #[inline]
    fn apply_impl(&self, input: &[T], out: &mut [T], transpose: bool) {
        for l in 0..self.order {
            let w = 2 * l + 1;
            let base = l * l;
            let blk = &self.data[offset(l)..offset(l) + w * w];
            let x = &input[base..base + w];
            for i in 0..w {
                let mut acc = T::zero();
                for j in 0..w {
                    let d = if transpose {
                        blk[j * w + i]
                    } else {
                        blk[i * w + j]
                    };
                    acc = acc + d * x[j];
                }
                out[base + i] = acc;
            }
        }
    }

    /// The dense `N²×N²` matrix (tests and inspection).
    pub fn to_dense(&self) -> Vec<Vec<T>> {
        let nn = coeff_count(self.order);
        let mut m = vec![vec![T::zero(); nn]; nn];
        for l in 0..self.order {
            for a in 0..(2 * l + 1) {
                for b in 0..(2 * l + 1) {
                    m[l * l + a][l * l + b] = self.get(l, a as i64 - l as i64, b as i64 - l as i64);
                }
            }
        }
        m
    }
}

/// Fill band `l ≥ 2` from band 1 (`r1`, 3×3) and band `l−1` (`rl1`, packed from its start).
fn band<T: Real>(l: usize, r1: &[T], rl1: &[T], out: &mut [T]) {
    let li = l as i64;
    let wp = 2 * l - 1; // width of band l−1
    let r1at = |i: i64, j: i64| r1[((i + 1) * 3 + (j + 1)) as usize];
    let rlat = |a: i64, b: i64| rl1[((a + li - 1) as usize) * wp + (b + li - 1) as usize];
    // Ivanic & Ruedenberg's P function.
    let p = |i: i64, a: i64, b: i64| -> T {
        if b == li {
            r1at(i, 1) * rlat(a, li - 1) - r1at(i, -1) * rlat(a, -li + 1)
        } else if b == -li {
            r1at(i, 1) * rlat(a, -li + 1) + r1at(i, -1) * rlat(a, li - 1)
        } else {
            r1at(i, 0) * rlat(a, b)
        }
    };
    let w = 2 * l + 1;
    for m in -li..=li {
        for n in -li..=li {
            let d = (m == 0) as i64 as f64;
            let denom = if n.abs() == li {
                (2 * li * (2 * li - 1)) as f64
            } else {
                ((li + n) * (li - n)) as f64
            };
            let am = m.abs();
            let u = (((li + m) * (li - m)) as f64 / denom).sqrt();
            let v = 0.5
                * ((1.0 + d) * ((li + am - 1) * (li + am)) as f64 / denom).sqrt()
                * (1.0 - 2.0 * d);
            let wc = -0.5 * (((li - am - 1) * (li - am)) as f64 / denom).sqrt() * (1.0 - d);
            let mut acc = T::zero();
            if u != 0.0 {
                acc = acc + T::c(u) * p(0, m, n);
            }
            if v != 0.0 {
                let vv = if m == 0 {
                    p(1, 1, n) + p(-1, -1, n)
                } else if m > 0 {
                    let d1 = (m == 1) as i64 as f64;
                    p(1, m - 1, n) * T::c((1.0 + d1).sqrt()) - p(-1, -m + 1, n) * T::c(1.0 - d1)
                } else {
                    let d1 = (m == -1) as i64 as f64;
                    p(1, m + 1, n) * T::c(1.0 - d1) + p(-1, -m - 1, n) * T::c((1.0 + d1).sqrt())
                };
                acc = acc + T::c(v) * vv;
            }
            if wc != 0.0 {
                let ww = if m > 0 {
                    p(1, m + 1, n) + p(-1, -m - 1, n)
                } else {
                    p(1, m - 1, n) - p(-1, -m + 1, n)
                };
                acc = acc + T::c(wc) * ww;
            }
            out[(m + li) as usize * w + (n + li) as usize] = acc;
        }
    }
}

/// Rotate a zonal function onto an axis: given zonal coefficients `z_l` (the `m = 0` coefficients
/// of a function symmetric about +z, `l = 0..N−1`), the coefficients of the same function
/// symmetric about the unit vector `axis` are `c_l^m = √(4π/(2l+1)) · z_l · Y_l^m(axis)`
/// (Sloan, Luna & Snyder 2005, zonal harmonics). `O(N²)`, much cheaper than a full rotation.
pub fn rotate_zonal<T: Real>(
    basis: &ShBasis<T>,
    zonal: &[T],
    axis: [T; 3],
    out: &mut [T],
) -> Result<(), ShError> {
    let n = basis.order();
    if zonal.len() != n {
        return Err(ShError::Length {
            what: "rotate_zonal: zonal coefficients vs order",
            a: zonal.len(),
            b: n,
        });
    }
    check_coeffs(n, out.len())?;
    basis.eval(axis, out);
    for l in 0..n {
        let f = T::c((4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt()) * zonal[l];
        for o in &mut out[l * l..(l + 1) * (l + 1)] {
            *o = *o * f;
        }
    }
    Ok(())
}
