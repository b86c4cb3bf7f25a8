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

use crate::error::ShError;

use crate::eval::ShBasis;

use crate::index::{check_coeffs, check_order, coeff_count};

use crate::real::Real;

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
    /// Scratch for the `P` values of one column: `Q₀, Q₁, Q₋₁`, each `2l−1 ≤ 255` long. Fixed
    /// 256-entry arrays indexed by `u8` need no bounds checks in the hot loop.
    scratch: Box<[[T; 256]; 3]>,
}

/// Start of band `l` in the packed block storage: `Σ_{k<l} (2k+1)² = l(4l²−1)/3`.
#[inline(always)]
const fn offset(l: usize) -> usize {
    // As 4l³ − l, which has no negative intermediate at l = 0 (`4l² − 1` underflowed there in
    // builds with overflow checks).
    (4 * l * l * l - l) / 3
}

/// Per-row coefficients of the `U, V, W` terms, with `1/√denom(n)` factored out: entry
/// `D[m][n] = invd[n] · (cu Q₀[a0] + cv1 Q₁[a1] + cv2 Q₋₁[a2] + cw1 Q₁[a3] + cw2 Q₋₁[a4])` where
/// `Q_i[a] = P(i, l, a, n)`; indices are offsets `a + l − 1` into the `Q` arrays (0 where the
/// coefficient is zero, so they stay in range).
#[derive(Clone, Copy, Debug, Default)]
struct RowCoeffs<T> {
    c: [T; 5],
    a: [u8; 5],
}

/// Rotation-independent tables of one order: build `D(R)` for many `R` without recomputing
/// square roots. Building a rotation with it costs `O(N³)` multiply-adds and no allocation.
#[derive(Clone, Debug)]
pub struct ShRotator<T> {
    order: usize,
    /// Band `l ≥ 2`: rows at `rows_off(l)`, `2l+1` entries.
    rows: Vec<RowCoeffs<T>>,
    /// Band `l ≥ 2`: `1/√denom(n)` at `rows_off(l) + n + l`.
    invd: Vec<T>,
}

/// Start of band `l`'s rows: `Σ_{k=2}^{l−1} (2k+1) = l² − 4`.
#[inline(always)]
const fn rows_off(l: usize) -> usize {
    l * l - 4
}

impl<T: Real> ShRotator<T> {
    /// Tables for order `N`.
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order(order)?;
        let count = if order > 2 { rows_off(order) } else { 0 };
        let mut rows = vec![RowCoeffs::default(); count];
        let mut invd = vec![T::zero(); count];
        for l in 2..order {
            let li = l as i64;
            for n in -li..=li {
                let denom = if n.abs() == li {
                    (2 * li * (2 * li - 1)) as f64
                } else {
                    ((li + n) * (li - n)) as f64
                };
                invd[rows_off(l) + (n + li) as usize] = T::c(1.0 / denom.sqrt());
            }
            let idx = |a: i64| (a + li - 1) as u8;
            for m in -li..=li {
                let d = (m == 0) as i64 as f64;
                let am = m.abs();
                let cu = (((li + m) * (li - m)) as f64).sqrt();
                let cvb =
                    0.5 * ((1.0 + d) * ((li + am - 1) * (li + am)) as f64).sqrt() * (1.0 - 2.0 * d);
                let cwb = -0.5 * (((li - am - 1).max(0) * (li - am)) as f64).sqrt() * (1.0 - d);
                let mut c = [0.0; 5];
                let mut a = [0u8; 5];
                if cu != 0.0 {
                    c[0] = cu;
                    a[0] = idx(m);
                }
                if m == 0 {
                    c[1] = cvb;
                    a[1] = idx(1);
                    c[2] = cvb;
                    a[2] = idx(-1);
                } else if m > 0 {
                    let d1 = (m == 1) as i64 as f64;
                    c[1] = cvb * (1.0 + d1).sqrt();
                    a[1] = idx(m - 1);
                    c[2] = -cvb * (1.0 - d1);
                    a[2] = idx(-m + 1);
                } else {
                    let d1 = (m == -1) as i64 as f64;
                    c[1] = cvb * (1.0 - d1);
                    a[1] = idx(m + 1);
                    c[2] = cvb * (1.0 + d1).sqrt();
                    a[2] = idx(-m - 1);
                }
                if cwb != 0.0 {
                    if m > 0 {
                        c[3] = cwb;
                        a[3] = idx(m + 1);
                        c[4] = cwb;
                        a[4] = idx(-m - 1);
                    } else {
                        c[3] = cwb;
                        a[3] = idx(m - 1);
                        c[4] = -cwb;
                        a[4] = idx(-m + 1);
                    }
                }
                rows[rows_off(l) + (m + li) as usize] = RowCoeffs { c: c.map(T::c), a };
            }
        }
        Ok(Self { order, rows, invd })
    }

    /// The order `N`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// A zeroed rotation of this order, to be filled by [`ShRotator::build_into`].
    pub fn empty(&self) -> ShRotation<T> {
        ShRotation {
            order: self.order,
            data: vec![T::zero(); offset(self.order)],
            scratch: Box::new([[T::zero(); 256]; 3]),
        }
    }

    /// Fill `out` (same order) with `D(r)` for a proper rotation matrix `r` (orthonormal,
    /// det +1; not checked — a reflection gives a meaningless result).
    pub fn build_into(&self, r: &Mat3<T>, out: &mut ShRotation<T>) {
        assert_eq!(out.order, self.order, "rotation order mismatch");
        let data = &mut out.data;
        data[0] = T::one();
        if self.order < 2 {
            return;
        }
        // Basis order (y, z, x) ↔ m = −1, 0, 1.
        const P: [usize; 3] = [1, 2, 0];
        for i in 0..3 {
            for j in 0..3 {
                data[offset(1) + i * 3 + j] = r[P[i]][P[j]];
            }
        }
        let r1: [T; 9] = std::array::from_fn(|e| data[offset(1) + e]);
        let r1at = |i: usize, j: usize| r1[i * 3 + j]; // i, j ∈ {0, 1, 2} ↔ {−1, 0, 1}
        for l in 2..self.order {
            let (prev, cur) = data.split_at_mut(offset(l));
            let wp = 2 * l - 1;
            let rl1 = &prev[offset(l - 1)..offset(l - 1) + wp * wp];
            let w = 2 * l + 1;
            let cur = &mut cur[..w * w];
            let rows = &self.rows[rows_off(l)..rows_off(l) + w];
            let invd = &self.invd[rows_off(l)..rows_off(l) + w];
            let [q0, qp, qm] = &mut *out.scratch;
            for nn in 0..w {
                // Q_i[a] = P(i, l, a, n) for n = nn − l.
                if nn == 0 || nn == w - 1 {
                    // n = −l: r1[i][1]·rl1[a][−l+1] + r1[i][−1]·rl1[a][l−1]
                    // n = +l: r1[i][1]·rl1[a][l−1] − r1[i][−1]·rl1[a][−l+1]
                    let (lo, hi) = (0, wp - 1);
                    for a in 0..wp {
                        let (x_lo, x_hi) = (rl1[a * wp + lo], rl1[a * wp + hi]);
                        let f = |i: usize| {
                            if nn == 0 {
                                r1at(i, 2) * x_lo + r1at(i, 0) * x_hi
                            } else {
                                r1at(i, 2) * x_hi - r1at(i, 0) * x_lo
                            }
                        };
                        q0[a] = f(1);
                        qp[a] = f(2);
                        qm[a] = f(0);
                    }
                } else {
                    let (c0, cp, cm) = (r1at(1, 1), r1at(2, 1), r1at(0, 1));
                    for a in 0..wp {
                        let x = rl1[a * wp + nn - 1];
                        q0[a] = c0 * x;
                        qp[a] = cp * x;
                        qm[a] = cm * x;
                    }
                }
                let s = invd[nn];
                for (m, rc) in rows.iter().enumerate() {
                    let (c, a) = (&rc.c, &rc.a);
                    let v = c[0] * q0[a[0] as usize]
                        + c[1] * qp[a[1] as usize]
                        + c[2] * qm[a[2] as usize]
                        + c[3] * qp[a[3] as usize]
                        + c[4] * qm[a[4] as usize];
                    cur[m * w + nn] = s * v;
                }
            }
        }
    }
}

impl<T: Real> ShRotation<T> {
    /// Build `D(R)` for order `N` from a proper rotation matrix `r` (convenience: builds the
    /// order's tables too; use [`ShRotator`] to build many rotations).
    pub fn new(order: usize, r: &Mat3<T>) -> Result<Self, ShError> {
        let rot = ShRotator::new(order)?;
        let mut out = rot.empty();
        rot.build_into(r, &mut out);
        Ok(out)
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
            let y = &mut out[base..base + w];
            if transpose {
                y.iter_mut().for_each(|v| *v = T::zero());
                for (row, &xj) in blk.chunks_exact(w).zip(x) {
                    for (yi, &d) in y.iter_mut().zip(row) {
                        *yi = *yi + d * xj;
                    }
                }
            } else {
                for (yi, row) in y.iter_mut().zip(blk.chunks_exact(w)) {
                    *yi = row
                        .iter()
                        .zip(x)
                        .fold(T::zero(), |acc, (&d, &xj)| acc + d * xj);
                }
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

/// Rotation applied through Euler angles without forming `D(R)`: with
/// `R = Rz(α)·Ry(β)·Rz(γ)` and `Ry(β) = Rx(−90°)·Rz(β)·Rx(90°)`,
///
/// ```text
/// D(R) = D(Rz(α)) · D(Rx(90°))ᵀ · D(Rz(β)) · D(Rx(90°)) · D(Rz(γ))
/// ```
///
/// where `D(Rz(φ))` mixes only the `±m` pair of each band
/// (`c'_m = c_m cos mφ − c_{−m} sin mφ`, `c'_{−m} = c_{−m} cos mφ + c_m sin mφ`) and `D(Rx(90°))` is
/// a fixed matrix built once per order (by [`ShRotator`]). The Euler angles are never formed:
/// `cos β = R₂₂` and the `(cos, sin)` of α and γ come from `R`'s third column and row, and the
/// multiples `mα` by complex recurrence — no trigonometric calls. The ZXZXZ factorisation is the
/// standard one for SH rotation (e.g. Kautz, Sloan & Snyder 2002; Pinchon & Hoggan 2007). It
/// costs ~2·Σ(2l+1)² multiply-adds per vector, which beats building `D(R)` when each rotation is
/// applied once (per-receiver frames); build `D(R)` with [`ShRotator`] to rotate many vectors.
#[derive(Clone, Debug)]
pub struct EulerRotator<T> {
    order: usize,
    /// `D(Rx(90°))`, packed like [`ShRotation`].
    x90: ShRotation<T>,
    /// Its transpose `D(Rx(−90°))`, so both products are row-times-vector dot products.
    x90t: ShRotation<T>,
}

impl<T: Real> EulerRotator<T> {
    /// Tables for order `N`.
    pub fn new(order: usize) -> Result<Self, ShError> {
        let rx90 =
            [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]].map(|r: [f64; 3]| r.map(T::c));
        let rx90t =
            [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]].map(|r: [f64; 3]| r.map(T::c));
        Ok(Self {
            order,
            x90: ShRotation::new(order, &rx90)?,
            x90t: ShRotation::new(order, &rx90t)?,
        })
    }

    /// The order `N`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// `y = D(r)·x` for a proper rotation matrix `r`. Both of length `N²`.
    pub fn apply(&self, r: &Mat3<T>, x: &[T], y: &mut [T]) -> Result<(), ShError> {
        check_coeffs(self.order, x.len())?;
        check_coeffs(self.order, y.len())?;
        // (cos, sin) of α, β, γ from R = Rz(α)Ry(β)Rz(γ).
        let cb = r[2][2];
        let sb = (r[0][2] * r[0][2] + r[1][2] * r[1][2]).sqrt();
        let tiny = T::c(1e-12);
        let (ca, sa, cg, sg) = if sb > tiny {
            (r[0][2] / sb, r[1][2] / sb, -r[2][0] / sb, r[2][1] / sb)
        } else {
            // β ≈ 0 or π: only α ± γ is defined; put it all in α (γ = 0).
            let s = if cb > T::zero() { T::one() } else { -T::one() };
            let (c, si) = (r[0][0] * s, r[1][0] * s);
            let n = (c * c + si * si).sqrt();
            (c / n, si / n, T::one(), T::zero())
        };
        let ang = [(ca, sa), (cb, sb), (cg, sg)];
        // Literal orders let the compiler unroll the small bands completely.
        match self.order {
            2 => self.apply_cap::<8>(2, x, y, ang),
            3 => self.apply_cap::<8>(3, x, y, ang),
            4 => self.apply_cap::<8>(4, x, y, ang),
            n if n <= 4 => self.apply_cap::<8>(n, x, y, ang),
            n if n <= 8 => self.apply_cap::<16>(n, x, y, ang),
            n if n <= 32 => self.apply_cap::<64>(n, x, y, ang),
            n => self.apply_cap::<256>(n, x, y, ang),
        }
        Ok(())
    }

    #[inline(always)]
    fn apply_cap<const CAP: usize>(&self, n: usize, x: &[T], y: &mut [T], angles: [(T, T); 3]) {
        // cos(mφ), sin(mφ) for m < N and the three angles.
        let mut cs = [[T::zero(); CAP]; 3];
        let mut sn = [[T::zero(); CAP]; 3];
        for (k, &(c, s)) in angles.iter().enumerate() {
            cs[k][0] = T::one();
            for m in 1..n {
                cs[k][m] = cs[k][m - 1] * c - sn[k][m - 1] * s;
                sn[k][m] = sn[k][m - 1] * c + cs[k][m - 1] * s;
            }
        }
        let zrot = |v: &mut [T], l: usize, k: usize| {
            for m in 1..=l {
                let (p, q) = (v[l + m], v[l - m]);
                v[l + m] = p * cs[k][m] - q * sn[k][m];
                v[l - m] = q * cs[k][m] + p * sn[k][m];
            }
        };
        let mut t = [T::zero(); CAP];
        for l in 0..n {
            let w = 2 * l + 1;
            let (xb, yb) = (&x[l * l..l * l + w], &mut y[l * l..l * l + w]);
            let blk = &self.x90.data[offset(l)..offset(l) + w * w];
            let blk_t = &self.x90t.data[offset(l)..offset(l) + w * w];
            yb.copy_from_slice(xb);
            zrot(yb, l, 2);
            let t = &mut t[..w];
            for (ti, row) in t.iter_mut().zip(blk.chunks_exact(w)) {
                *ti = row
                    .iter()
                    .zip(yb.iter())
                    .fold(T::zero(), |acc, (&d, &v)| acc + d * v);
            }
            zrot(t, l, 1);
            for (yi, row) in yb.iter_mut().zip(blk_t.chunks_exact(w)) {
                *yi = row
                    .iter()
                    .zip(t.iter())
                    .fold(T::zero(), |acc, (&d, &v)| acc + d * v);
            }
            zrot(yb, l, 0);
        }
    }
}

#[cfg(test)]
mod offset_tests {
    /// The packed block offsets against their sum, from band 0 (whose closed form once
    /// underflowed in builds with overflow checks) to band 40.
    #[test]
    fn block_offsets_are_the_sums_of_the_blocks_before() {
        let mut sum = 0;
        for l in 0..=40 {
            assert_eq!(super::offset(l), sum, "band {l}");
            sum += (2 * l + 1) * (2 * l + 1);
        }
    }
}
