//! Evaluation of all `N²` real SH at a direction, by the normalised Legendre recurrence in
//! Cartesian form (no trigonometric calls, exact at the poles).
//!
//! For a unit vector `(x, y, z)` with `z = cosθ`, `sinθ^m cos(mφ) = Re (x + iy)^m` and
//! `sinθ^m sin(mφ) = Im (x + iy)^m`. The recurrence of [`crate::legendre`] is run on the
//! polynomial part `Q_l^m = P̄_l^m / sinθ^m` (same recurrence with `s = 1` on the diagonal), and
//!
//! ```text
//! Y_l^0  = Q_l^0(z)
//! Y_l^m  = √2 · Q_l^m(z) · Re (x+iy)^m      (m > 0)
//! Y_l^-m = √2 · Q_l^m(z) · Im (x+iy)^m      (m > 0)
//! ```
//!
//! (docs/conventions.md §1; the papers' appendix; the Cartesian trick as in sphericart, Bigi et al. 2023.)
//! Domain: unit directions (callers with raw vectors use [`ShBasis::eval_dir`], which normalises
//! and rejects zero or non-finite input), any order up to [`crate::MAX_ORDER`].

use crate::legendre::Legendre;
use crate::{check_order, coeff_count, Real, ShError};

/// Evaluator of the real SH basis of one order, holding its recurrence tables.
#[derive(Clone, Debug)]
pub struct ShBasis<T> {
    leg: Legendre<T>,
}

impl<T: Real> ShBasis<T> {
    /// Tables for order `N` (`1 ≤ N ≤ MAX_ORDER`).
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order(order)?;
        Ok(Self {
            leg: Legendre::new(order)?,
        })
    }

    /// The order `N`.
    pub fn order(&self) -> usize {
        self.leg.order()
    }

    /// Number of coefficients `N²`.
    pub fn len(&self) -> usize {
        coeff_count(self.order())
    }

    /// Always false: an order is at least 1.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// All `N²` values at the **unit** direction `d`, into `out[0..N²]` in index order.
    /// The direction is not normalised here (see [`ShBasis::eval_dir`]).
    #[inline]
    pub fn eval(&self, d: [T; 3], out: &mut [T]) {
        // Literal orders let the compiler unroll the recurrences and drop bounds checks.
        let leg = &self.leg;
        match self.order() {
            1 => eval_kernel::<T, 8>(leg, 1, d, out),
            2 => eval_kernel::<T, 8>(leg, 2, d, out),
            3 => eval_kernel::<T, 8>(leg, 3, d, out),
            4 => eval_kernel::<T, 8>(leg, 4, d, out),
            5 => eval_kernel::<T, 8>(leg, 5, d, out),
            6 => eval_kernel::<T, 8>(leg, 6, d, out),
            8 => eval_kernel::<T, 8>(leg, 8, d, out),
            n if n <= 8 => eval_kernel::<T, 8>(leg, n, d, out),
            n if n <= 16 => eval_kernel::<T, 16>(leg, n, d, out),
            n if n <= 32 => eval_kernel::<T, 32>(leg, n, d, out),
            n => eval_kernel::<T, { crate::MAX_ORDER }>(leg, n, d, out),
        }
    }

    /// All values at the direction `v`, normalised first. Errors on a zero, denormal-length or
    /// non-finite vector.
    pub fn eval_dir(&self, v: [T; 3], out: &mut [T]) -> Result<(), ShError> {
        let d = normalize(v)?;
        self.eval(d, out);
        Ok(())
    }

    /// All values at polar angle `θ ∈ [0, π]` and azimuth `φ` (any real).
    pub fn eval_theta_phi(&self, theta: T, phi: T, out: &mut [T]) {
        let st = theta.sin();
        self.eval([st * phi.cos(), st * phi.sin(), theta.cos()], out)
    }

    /// Batched evaluation: `out[j·N² .. (j+1)·N²]` receives the values at `dirs[j]` (unit).
    ///
    /// Directions are taken [`LANES`] at a time in structure-of-arrays form, so the recurrence
    /// runs on SIMD lanes (AVX2 + FMA when the CPU has them, chosen at run time by
    /// [`crate::simd::level`]; the portable path otherwise). The portable path performs exactly
    /// the operations of [`ShBasis::eval`] and agrees with it bit for bit; the FMA path rounds
    /// each fused multiply-add once and agrees to a few ulps (tested).
    pub fn eval_batch(&self, dirs: &[[T; 3]], out: &mut [T]) {
        self.eval_batch_with(crate::simd::level(), dirs, out)
    }

    /// As [`ShBasis::eval_batch`] with an explicit instruction set (for tests and benchmarks; a
    /// level the CPU lacks falls back to the portable path).
    pub fn eval_batch_with(&self, level: crate::simd::Level, dirs: &[[T; 3]], out: &mut [T]) {
        let nn = self.len();
        assert_eq!(out.len(), dirs.len() * nn, "eval_batch: output length");
        #[cfg(target_arch = "x86_64")]
        if level.usable() == crate::simd::Level::Avx2Fma {
            // SAFETY: the CPU supports AVX2 and FMA (`usable` checked it).
            unsafe { batch_avx2(&self.leg, dirs, out) };
            return;
        }
        let _ = level;
        batch_dispatch::<T, false>(&self.leg, dirs, out);
    }

    /// Allocating convenience: the `N²` values at the unit direction `d`.
    pub fn values(&self, d: [T; 3]) -> Vec<T> {
        let mut v = vec![T::zero(); self.len()];
        self.eval(d, &mut v);
        v
    }
}

/// The recurrence of the module docs for order `n ≤ CAP`, writing `out[0..n²]`.
///
/// Runs band by band (l outer, m inner) so the updates of different m are independent and
/// pipeline well; `Q_m^m` is a constant (no dependence on the direction) taken from the table,
/// and `√2` is folded into it for m > 0. `p1[m]`, `p2[m]` hold `Q_{l−1}^m`, `Q_{l−2}^m`.
#[inline(always)]
fn eval_kernel<T: Real, const CAP: usize>(leg: &Legendre<T>, n: usize, d: [T; 3], out: &mut [T]) {
    let out = &mut out[..n * n];
    let [x, y, z] = d;
    // (Re, Im) of (x + iy)^m.
    let mut cs = [T::zero(); CAP];
    let mut sn = [T::zero(); CAP];
    cs[0] = T::one();
    for m in 1..n {
        cs[m] = x * cs[m - 1] - y * sn[m - 1];
        sn[m] = x * sn[m - 1] + y * cs[m - 1];
    }
    let mut p1 = [T::zero(); CAP];
    let mut p2 = [T::zero(); CAP];
    let ab = &leg.ab_l[..];
    let (qmm, sub) = (&leg.qmm[..n], &leg.sub[..n]);
    let mut k = 0;
    out[0] = qmm[0];
    p1[0] = qmm[0];
    for l in 1..n {
        // The three-term recurrence for m ≤ l − 2 (independent in m).
        let row = &ab[k..k + l.saturating_sub(1)];
        k += row.len();
        for (m, &(a, b)) in row.iter().enumerate() {
            let q = (a * z) * p1[m] - b * p2[m];
            p2[m] = p1[m];
            p1[m] = q;
        }
        p2[l - 1] = p1[l - 1];
        p1[l - 1] = sub[l - 1] * z * qmm[l - 1];
        p1[l] = qmm[l];
        let c = l * l + l;
        out[c] = p1[0];
        let band = &mut out[c - l..=c + l];
        for m in 1..=l {
            band[l + m] = p1[m] * cs[m];
            band[l - m] = p1[m] * sn[m];
        }
    }
}

/// Directions per SIMD batch of [`ShBasis::eval_batch`].
pub const LANES: usize = 8;

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn batch_avx2<T: Real>(leg: &Legendre<T>, dirs: &[[T; 3]], out: &mut [T]) {
    batch_dispatch::<T, true>(leg, dirs, out)
}

/// Whole batches of [`LANES`] directions through the lane kernel (literal orders unrolled), the
/// remainder through the one-direction kernel.
#[inline(always)]
fn batch_dispatch<T: Real, const FMA: bool>(leg: &Legendre<T>, dirs: &[[T; 3]], out: &mut [T]) {
    let n = leg.order();
    let nn = n * n;
    let whole = dirs.len() / LANES * LANES;
    let (head, tail) = dirs.split_at(whole);
    let (out_head, out_tail) = out.split_at_mut(whole * nn);
    macro_rules! run {
        ($cap:expr, $n:expr) => {
            for (d, o) in head
                .chunks_exact(LANES)
                .zip(out_head.chunks_exact_mut(LANES * nn))
            {
                lane_kernel::<T, $cap, FMA>(leg, $n, d, o)
            }
        };
    }
    macro_rules! fixed {
        ($n:literal, $nn:literal) => {{
            // Long rows of f64 in half batches: the tile then stays in the first-level cache.
            if std::mem::size_of::<T>() == 8 && $nn >= 256 {
                for (d, o) in head
                    .chunks_exact(LANES / 2)
                    .zip(out_head.chunks_exact_mut(LANES / 2 * nn))
                {
                    lane_kernel_fixed::<T, $n, $nn, { LANES / 2 }, FMA>(leg, d, o)
                }
            } else {
                for (d, o) in head
                    .chunks_exact(LANES)
                    .zip(out_head.chunks_exact_mut(LANES * nn))
                {
                    lane_kernel_fixed::<T, $n, $nn, LANES, FMA>(leg, d, o)
                }
            }
        }};
    }
    match n {
        1 => run!(8, 1),
        2 => fixed!(2, 4),
        3 => fixed!(3, 9),
        4 => fixed!(4, 16),
        5 => fixed!(5, 25),
        6 => fixed!(6, 36),
        8 => fixed!(8, 64),
        n if n <= 8 => run!(8, n),
        12 => fixed!(12, 144),
        16 => fixed!(16, 256),
        n if n <= 16 => run!(16, n),
        n if n <= 32 => run!(32, n),
        n => run!({ crate::MAX_ORDER }, n),
    }
    for (d, o) in tail.iter().zip(out_tail.chunks_exact_mut(nn)) {
        if FMA {
            eval_kernel_fma::<T, { crate::MAX_ORDER }, FMA>(leg, n, *d, o)
        } else {
            eval_kernel::<T, { crate::MAX_ORDER }>(leg, n, *d, o)
        }
    }
}

/// `a·b + c`, fused (one rounding) when `FMA`.
#[inline(always)]
fn madd<T: Real, const FMA: bool>(a: T, b: T, c: T) -> T {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// The recurrence of [`eval_kernel`] on [`LANES`] directions at once: every quantity is a lane
/// array, so each step is one SIMD operation. With `FMA = false` the operations (and so the
/// results) are those of [`eval_kernel`]; the output is written point by point (`N²` each).
#[inline(always)]
fn lane_kernel<T: Real, const CAP: usize, const FMA: bool>(
    leg: &Legendre<T>,
    n: usize,
    d: &[[T; 3]],
    out: &mut [T],
) {
    const W: usize = LANES;
    let nn = n * n;
    let out = &mut out[..W * nn];
    let (mut x, mut y, mut z) = ([T::zero(); W], [T::zero(); W], [T::zero(); W]);
    for j in 0..W {
        [x[j], y[j], z[j]] = d[j];
    }
    let mut cs = [[T::zero(); W]; CAP];
    let mut sn = [[T::zero(); W]; CAP];
    cs[0] = [T::one(); W];
    for m in 1..n {
        for j in 0..W {
            let (c, s) = (cs[m - 1][j], sn[m - 1][j]);
            cs[m][j] = madd::<T, FMA>(x[j], c, -(y[j] * s));
            sn[m][j] = madd::<T, FMA>(x[j], s, y[j] * c);
        }
    }
    let mut p1 = [[T::zero(); W]; CAP];
    let mut p2 = [[T::zero(); W]; CAP];
    let ab = &leg.ab_l[..];
    let (qmm, sub) = (&leg.qmm[..n], &leg.sub[..n]);
    let mut k = 0;
    p1[0] = [qmm[0]; W];
    for j in 0..W {
        out[j * nn] = qmm[0];
    }
    // The band in lanes: cosine parts (index l + m) and sine parts (index l − m).
    let mut pos = [[T::zero(); W]; CAP];
    let mut neg = [[T::zero(); W]; CAP];
    for l in 1..n {
        let row = &ab[k..k + l.saturating_sub(1)];
        k += row.len();
        for (m, &(a, b)) in row.iter().enumerate() {
            for j in 0..W {
                let q = madd::<T, FMA>(a * z[j], p1[m][j], -(b * p2[m][j]));
                p2[m][j] = p1[m][j];
                p1[m][j] = q;
            }
        }
        for j in 0..W {
            p2[l - 1][j] = p1[l - 1][j];
            p1[l - 1][j] = sub[l - 1] * z[j] * qmm[l - 1];
        }
        p1[l] = [qmm[l]; W];
        pos[0] = p1[0];
        for m in 1..=l {
            for j in 0..W {
                pos[m][j] = p1[m][j] * cs[m][j];
                neg[m][j] = p1[m][j] * sn[m][j];
            }
        }
        let c = l * l + l;
        for j in 0..W {
            let o = &mut out[j * nn + c - l..=j * nn + c + l];
            for m in 0..=l {
                o[l + m] = pos[m][j];
            }
            for m in 1..=l {
                o[l - m] = neg[m][j];
            }
        }
    }
}

/// [`lane_kernel`] for a compile-time order `N` (`NN = N²`): every loop has a constant trip
/// count, so the recurrence is unrolled into straight-line SIMD code on a tile of `NN × LANES`
/// values, which is then written out point by point. The same operations as [`lane_kernel`].
#[inline(always)]
fn lane_kernel_fixed<T: Real, const N: usize, const NN: usize, const W: usize, const FMA: bool>(
    leg: &Legendre<T>,
    d: &[[T; 3]],
    out: &mut [T],
) {
    let out = &mut out[..W * NN];
    let d = &d[..W];
    let (mut x, mut y, mut z) = ([T::zero(); W], [T::zero(); W], [T::zero(); W]);
    for j in 0..W {
        [x[j], y[j], z[j]] = d[j];
    }
    let mut cs = [[T::zero(); W]; N];
    let mut sn = [[T::zero(); W]; N];
    cs[0] = [T::one(); W];
    for m in 1..N {
        for j in 0..W {
            let (c, s) = (cs[m - 1][j], sn[m - 1][j]);
            cs[m][j] = madd::<T, FMA>(x[j], c, -(y[j] * s));
            sn[m][j] = madd::<T, FMA>(x[j], s, y[j] * c);
        }
    }
    let ab = &leg.ab_l[..(N.saturating_sub(1)) * (N.saturating_sub(2)) / 2];
    let qmm = &leg.qmm[..N];
    let sub = &leg.sub[..N];
    let mut p1 = [[T::zero(); W]; N];
    let mut p2 = [[T::zero(); W]; N];
    let mut tile = [[T::zero(); W]; NN];
    p1[0] = [qmm[0]; W];
    tile[0] = p1[0];
    let mut k = 0;
    for l in 1..N {
        for m in 0..l.saturating_sub(1) {
            let (a, b) = ab[k + m];
            for j in 0..W {
                let q = madd::<T, FMA>(a * z[j], p1[m][j], -(b * p2[m][j]));
                p2[m][j] = p1[m][j];
                p1[m][j] = q;
            }
        }
        k += l.saturating_sub(1);
        for j in 0..W {
            p2[l - 1][j] = p1[l - 1][j];
            p1[l - 1][j] = sub[l - 1] * z[j] * qmm[l - 1];
        }
        p1[l] = [qmm[l]; W];
        let c = l * l + l;
        tile[c] = p1[0];
        for m in 1..=l {
            for j in 0..W {
                tile[c + m][j] = p1[m][j] * cs[m][j];
                tile[c - m][j] = p1[m][j] * sn[m][j];
            }
        }
    }
    // Measured (docs/BENCHMARKS.md): whole-vector transposed stores win for f32 at N ≤ 4
    // (about 0.56× the time) and lose elsewhere, where the compiler's scalar stores straight
    // from registers beat materialising the tile.
    #[cfg(target_arch = "x86_64")]
    if FMA && W == LANES && std::mem::size_of::<T>() == 4 && NN <= 16 {
        // SAFETY: `FMA` is true only in the AVX2 + FMA instantiation; `out` holds W·NN values.
        unsafe { write_tile_avx2::<T, NN>(tile.as_ptr() as *const [T; LANES], out) };
        return;
    }
    for (j, o) in out.chunks_exact_mut(NN).enumerate() {
        for i in 0..NN {
            o[i] = tile[i][j];
        }
    }
}

/// Write a tile (`NN` values × 8 lanes) point by point with AVX2 transposes (8×8 blocks of
/// f32), so every store is a whole vector; values that do not fill a block are stored one by
/// one.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn write_tile_avx2<T: Real, const NN: usize>(tile: *const [T; LANES], out: &mut [T]) {
    // SAFETY: the caller's tile is NN rows of LANES values.
    let tile = std::slice::from_raw_parts(tile, NN);
    use std::arch::x86_64::*;
    assert!(out.len() >= LANES * NN);
    let o = out.as_mut_ptr();
    let mut done = 0;
    if std::mem::size_of::<T>() == 4 {
        let t = tile.as_ptr() as *const f32;
        let o = o as *mut f32;
        macro_rules! st {
            ($p:expr, $v:expr) => {{
                _mm256_storeu_ps($p, $v)
            }};
        }
        while done + 8 <= NN {
            macro_rules! r {
                ($k:expr) => {
                    _mm256_loadu_ps(t.add((done + $k) * LANES))
                };
            }
            let (r0, r1, r2, r3) = (r!(0), r!(1), r!(2), r!(3));
            let (r4, r5, r6, r7) = (r!(4), r!(5), r!(6), r!(7));
            let (t0, t1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
            let (t2, t3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
            let (t4, t5) = (_mm256_unpacklo_ps(r4, r5), _mm256_unpackhi_ps(r4, r5));
            let (t6, t7) = (_mm256_unpacklo_ps(r6, r7), _mm256_unpackhi_ps(r6, r7));
            let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
            let s1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
            let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
            let s3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
            let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
            let s5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
            let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
            let s7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
            let c = [
                _mm256_permute2f128_ps::<0x20>(s0, s4),
                _mm256_permute2f128_ps::<0x20>(s1, s5),
                _mm256_permute2f128_ps::<0x20>(s2, s6),
                _mm256_permute2f128_ps::<0x20>(s3, s7),
                _mm256_permute2f128_ps::<0x31>(s0, s4),
                _mm256_permute2f128_ps::<0x31>(s1, s5),
                _mm256_permute2f128_ps::<0x31>(s2, s6),
                _mm256_permute2f128_ps::<0x31>(s3, s7),
            ];
            for (lane, v) in c.into_iter().enumerate() {
                st!(o.add(lane * NN + done), v);
            }
            done += 8;
        }
    }
    for (j, row) in out.chunks_exact_mut(NN).take(LANES).enumerate() {
        for i in done..NN {
            row[i] = tile[i][j];
        }
    }
}

/// [`eval_kernel`] with fused multiply-adds where [`lane_kernel`] uses them (the tail of an
/// FMA batch, so that every direction of one batch is rounded alike).
#[inline(always)]
fn eval_kernel_fma<T: Real, const CAP: usize, const FMA: bool>(
    leg: &Legendre<T>,
    n: usize,
    d: [T; 3],
    out: &mut [T],
) {
    let mut padded = [[T::zero(); 3]; LANES];
    padded.iter_mut().for_each(|p| *p = d);
    let mut buf = vec![T::zero(); LANES * n * n];
    lane_kernel::<T, CAP, FMA>(leg, n, &padded, &mut buf);
    out[..n * n].copy_from_slice(&buf[..n * n]);
}

/// Normalise `v`; errors if its length is zero, not finite, or so small that `v/|v|` is inexact.
pub fn normalize<T: Real>(v: [T; 3]) -> Result<[T; 3], ShError> {
    let [x, y, z] = v.map(|c| c.f64());
    // Scale by the largest component first so tiny or huge vectors neither under- nor overflow.
    let big = x.abs().max(y.abs()).max(z.abs());
    if !(x.is_finite() && y.is_finite() && z.is_finite() && big > f64::MIN_POSITIVE) {
        return Err(ShError::Direction { x, y, z });
    }
    let (a, b, c) = (x / big, y / big, z / big);
    let len = (a * a + b * b + c * c).sqrt();
    Ok([T::c(a / len), T::c(b / len), T::c(c / len)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Hand-written real SH for l ≤ 3 in Cartesian form (no Condon–Shortley phase).
    fn closed(i: usize, d: [f64; 3]) -> f64 {
        let [x, y, z] = d;
        let k = |num: f64, den: f64| (num / (den * PI)).sqrt();
        match i {
            0 => k(1.0, 4.0),
            1 => k(3.0, 4.0) * y,
            2 => k(3.0, 4.0) * z,
            3 => k(3.0, 4.0) * x,
            4 => k(15.0, 4.0) * x * y,
            5 => k(15.0, 4.0) * y * z,
            6 => k(5.0, 16.0) * (3.0 * z * z - 1.0),
            7 => k(15.0, 4.0) * x * z,
            8 => k(15.0, 16.0) * (x * x - y * y),
            9 => k(35.0, 32.0) * y * (3.0 * x * x - y * y),
            10 => k(105.0, 4.0) * x * y * z,
            11 => k(21.0, 32.0) * y * (5.0 * z * z - 1.0),
            12 => k(7.0, 16.0) * z * (5.0 * z * z - 3.0),
            13 => k(21.0, 32.0) * x * (5.0 * z * z - 1.0),
            14 => k(105.0, 16.0) * z * (x * x - y * y),
            15 => k(35.0, 32.0) * x * (x * x - 3.0 * y * y),
            _ => unreachable!(),
        }
    }

    fn dirs() -> Vec<[f64; 3]> {
        let mut v = vec![
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
        ];
        for i in 0..50 {
            let t = (i as f64 + 0.5) / 50.0;
            let z = 1.0 - 2.0 * t;
            let r = (1.0 - z * z).sqrt();
            let p = 2.399963229728653 * i as f64;
            v.push([r * p.cos(), r * p.sin(), z]);
        }
        v
    }

    #[test]
    fn matches_hand_written_forms_f64_and_f32() {
        const TOL64: f64 = 2e-15;
        const TOL32: f64 = 2e-6;
        let b64 = ShBasis::<f64>::new(4).unwrap();
        let b32 = ShBasis::<f32>::new(4).unwrap();
        for d in dirs() {
            let v64 = b64.values(d);
            let v32 = b32.values(d.map(|c| c as f32));
            for i in 0..16 {
                let want = closed(i, d);
                let e64 = (v64[i] - want).abs();
                let e32 = (v32[i] as f64 - want).abs();
                assert!(e64 < TOL64, "f64 i={i} d={d:?}: err {e64:e}");
                assert!(e32 < TOL32, "f32 i={i} d={d:?}: err {e32:e}");
            }
        }
    }

    #[test]
    fn theta_phi_form_agrees_with_cartesian() {
        let b = ShBasis::<f64>::new(10).unwrap();
        let mut a = vec![0.0; 100];
        for (theta, phi) in [(0.0, 0.3), (PI, 1.0), (0.7, -2.0), (2.9, 5.0)] {
            b.eval_theta_phi(theta, phi, &mut a);
            let c = b.values([
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
            for i in 0..100 {
                assert!((a[i] - c[i]).abs() < 1e-14, "i={i}");
            }
        }
    }

    #[test]
    fn normalize_rejects_degenerate_vectors() {
        assert!(normalize([0.0f64, 0.0, 0.0]).is_err());
        assert!(normalize([f64::NAN, 0.0, 1.0]).is_err());
        assert!(normalize([f64::INFINITY, 0.0, 1.0]).is_err());
        let d = normalize([1e-300f64, 0.0, 1e-300]).unwrap();
        assert!((d[0] - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-15);
        let d = normalize([1e300f64, 1e300, 0.0]).unwrap();
        assert!((d[1] - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-15);
    }

    /// The batched kernels against the one-direction kernel: the portable path performs the same
    /// operations (bit-identical), the AVX2 + FMA path rounds fused multiply-adds once (a few
    /// ulps, scaled by the order's largest value). Every order 1..=20 and batch lengths that
    /// leave a tail of every size.
    #[test]
    fn batch_agrees_with_one_direction_kernel() {
        use crate::simd::{detected, Level};
        fn check<T: Real>(tol_ulps: f64) {
            let dirs: Vec<[T; 3]> = dirs().iter().map(|d| d.map(T::c)).collect();
            let eps = T::epsilon().f64();
            let mut worst_fma = 0f64;
            for order in 1..=20usize {
                let b = ShBasis::<T>::new(order).unwrap();
                let nn = order * order;
                for len in [1usize, 7, 8, 9, 17, dirs.len()] {
                    let ds = &dirs[..len];
                    let mut one = vec![T::zero(); len * nn];
                    for (d, o) in ds.iter().zip(one.chunks_exact_mut(nn)) {
                        b.eval(*d, o);
                    }
                    let mut port = vec![T::zero(); len * nn];
                    b.eval_batch_with(Level::Portable, ds, &mut port);
                    assert!(
                        one.iter()
                            .zip(&port)
                            .all(|(a, c)| a.f64().to_bits() == c.f64().to_bits()),
                        "portable batch differs, order {order}, len {len}"
                    );
                    if detected() == Level::Avx2Fma {
                        let mut fma = vec![T::zero(); len * nn];
                        b.eval_batch_with(Level::Avx2Fma, ds, &mut fma);
                        let scale = one.iter().fold(1f64, |m, v| m.max(v.f64().abs()));
                        for (a, c) in one.iter().zip(&fma) {
                            let e = (a.f64() - c.f64()).abs() / (scale * eps);
                            worst_fma = worst_fma.max(e);
                        }
                    }
                }
            }
            println!(
                "{}: worst FMA-path difference {worst_fma:.1} ulps of the largest value",
                std::any::type_name::<T>()
            );
            assert!(worst_fma <= tol_ulps, "FMA path off by {worst_fma} ulps");
        }
        check::<f64>(32.0);
        check::<f32>(32.0);
    }
}
