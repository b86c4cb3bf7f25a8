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

use crate::error::ShError;
use crate::index::{check_order, coeff_count};
use crate::legendre::Legendre;
use crate::real::Real;
use crate::simd::LANES;
#[cfg(target_arch = "x86_64")]
use crate::store::{is, write_tile_avx2};
use crate::store::{Store, STREAM_BYTES};

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
            n => eval_kernel::<T, { crate::index::MAX_ORDER }>(leg, n, d, out),
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
    ///
    /// The AVX2 path writes outputs of at least [`STREAM_BYTES`] with non-temporal stores
    /// (they bypass the caches: such an output would not stay there anyway, and its lines are
    /// then written without first being read), smaller ones with ordinary stores.
    pub fn eval_batch_with(&self, level: crate::simd::Level, dirs: &[[T; 3]], out: &mut [T]) {
        let bytes = std::mem::size_of_val(out);
        let store = if bytes >= STREAM_BYTES {
            Store::Stream
        } else {
            Store::Vector
        };
        self.eval_batch_store(level, dirs, out, store)
    }

    /// [`ShBasis::eval_batch_with`] with the AVX2 path's store kind forced (tests).
    fn eval_batch_store(
        &self,
        level: crate::simd::Level,
        dirs: &[[T; 3]],
        out: &mut [T],
        store: Store,
    ) {
        let nn = self.len();
        assert_eq!(out.len(), dirs.len() * nn, "eval_batch: output length");
        #[cfg(target_arch = "x86_64")]
        if level.usable() >= crate::simd::Level::Avx2Fma {
            // SAFETY: the CPU supports AVX2 and FMA (`usable` checked it).
            unsafe { batch_avx2(&self.leg, dirs, out, store) };
            return;
        }
        let _ = (level, store);
        batch_dispatch::<T, false>(&self.leg, dirs, out, None);
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

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn batch_avx2<T: Real>(leg: &Legendre<T>, dirs: &[[T; 3]], out: &mut [T], store: Store) {
    batch_dispatch::<T, true>(leg, dirs, out, Some(store))
}

/// Whole batches of [`LANES`] directions through the lane kernel (literal orders compiled one by
/// one), the remainder through the one-direction kernel.
///
/// A hot dispatch of ~95 lines: most of it is the one `match` that lists every literal order the
/// fixed kernels are compiled for (each arm a different monomorphisation); splitting the list
/// would only add a call level between the caller and the kernel.
#[inline(always)]
fn batch_dispatch<T: Real, const FMA: bool>(
    leg: &Legendre<T>,
    dirs: &[[T; 3]],
    out: &mut [T],
    store: Option<Store>,
) {
    let store = if FMA { store } else { None };
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
            // Long rows of f64 in half batches: tile and staging copy (8 KiB each) then fit the
            // first-level cache together (N = 16 f64: 110–118 ns against 115–239 ns in 8-lane
            // batches, five alternating runs, docs/BENCHMARKS.md).
            if std::mem::size_of::<T>() == 8 && $nn >= 256 {
                fixed_batches::<T, $n, $nn, { LANES / 2 }, FMA>(leg, head, out_head, store)
            } else {
                fixed_batches::<T, $n, $nn, LANES, FMA>(leg, head, out_head, store)
            }
        }};
    }
    #[cfg(target_arch = "x86_64")]
    let order4 = n == 4 && FMA && (is::<T, f64>() || is::<T, f32>());
    #[cfg(target_arch = "x86_64")]
    if order4 {
        let store = store.unwrap_or(Store::Vector);
        // SAFETY: `FMA` is true only in the AVX2 + FMA instantiation, and T is f64 or f32
        // (checked by type identity just above), so the casts are to T itself.
        unsafe {
            if is::<T, f64>() {
                order4::batch_f64(
                    &*(leg as *const Legendre<T> as *const Legendre<f64>),
                    std::slice::from_raw_parts(head.as_ptr() as *const [f64; 3], head.len()),
                    std::slice::from_raw_parts_mut(
                        out_head.as_mut_ptr() as *mut f64,
                        out_head.len(),
                    ),
                    store,
                );
            } else {
                order4::batch_f32(
                    &*(leg as *const Legendre<T> as *const Legendre<f32>),
                    std::slice::from_raw_parts(head.as_ptr() as *const [f32; 3], head.len()),
                    std::slice::from_raw_parts_mut(
                        out_head.as_mut_ptr() as *mut f32,
                        out_head.len(),
                    ),
                    store,
                );
            }
        }
    }
    match n {
        1 => run!(8, 1),
        2 => fixed!(2, 4),
        3 => fixed!(3, 9),
        #[cfg(target_arch = "x86_64")]
        4 if order4 => {}
        4 => fixed!(4, 16),
        5 => fixed!(5, 25),
        6 => fixed!(6, 36),
        8 => fixed!(8, 64),
        n if n <= 8 => run!(8, n),
        12 => fixed!(12, 144),
        16 => fixed!(16, 256),
        n if n <= 16 => run!(16, n),
        n if n <= 32 => run!(32, n),
        n => run!({ crate::index::MAX_ORDER }, n),
    }
    #[cfg(target_arch = "x86_64")]
    if store == Some(Store::Stream) {
        // SAFETY: only reached in the AVX2 instantiation (`store` is `None` otherwise); the
        // fence orders the non-temporal stores before anything that follows.
        unsafe { std::arch::x86_64::_mm_sfence() };
    }
    for (d, o) in tail.iter().zip(out_tail.chunks_exact_mut(nn)) {
        if FMA {
            eval_kernel_fma::<T, { crate::index::MAX_ORDER }, FMA>(leg, n, *d, o)
        } else {
            eval_kernel::<T, { crate::index::MAX_ORDER }>(leg, n, *d, o)
        }
    }
}

/// Whole batches of `W` directions at the literal order `N` (`NN = N²`), each order in a
/// function of its own (so each gets its own small stack frame and is optimised alone).
#[inline(always)]
fn fixed_batches<T: Real, const N: usize, const NN: usize, const W: usize, const FMA: bool>(
    leg: &Legendre<T>,
    dirs: &[[T; 3]],
    out: &mut [T],
    store: Option<Store>,
) {
    #[cfg(target_arch = "x86_64")]
    if FMA {
        // SAFETY: `FMA` is true only in the AVX2 + FMA instantiation (`batch_avx2`).
        unsafe { fixed_batches_avx2::<T, N, NN, W>(leg, dirs, out, store) };
        return;
    }
    let _ = store;
    fixed_batches_portable::<T, N, NN, W>(leg, dirs, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn fixed_batches_avx2<T: Real, const N: usize, const NN: usize, const W: usize>(
    leg: &Legendre<T>,
    dirs: &[[T; 3]],
    out: &mut [T],
    store: Option<Store>,
) {
    for (d, o) in dirs.chunks_exact(W).zip(out.chunks_exact_mut(W * NN)) {
        lane_kernel_fixed::<T, N, NN, W, true>(leg, d, o, store)
    }
}

#[inline(never)]
fn fixed_batches_portable<T: Real, const N: usize, const NN: usize, const W: usize>(
    leg: &Legendre<T>,
    dirs: &[[T; 3]],
    out: &mut [T],
) {
    for (d, o) in dirs.chunks_exact(W).zip(out.chunks_exact_mut(W * NN)) {
        lane_kernel_fixed::<T, N, NN, W, false>(leg, d, o, None)
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
/// count, so LLVM can unroll the recurrence into straight-line SIMD code on a tile of
/// `NN × LANES` values (at N = 8, 12 and 16 it leaves loops rolled, hence the slices below),
/// which is then written out point by point. The same operations as [`lane_kernel`].
///
/// A hot kernel of ~85 lines kept whole: the recurrence's tile lives in registers and on the
/// stack frame of this one function (per order, so each is optimised alone).
#[inline(always)]
fn lane_kernel_fixed<T: Real, const N: usize, const NN: usize, const W: usize, const FMA: bool>(
    leg: &Legendre<T>,
    d: &[[T; 3]],
    out: &mut [T],
    store: Option<Store>,
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
    // Every row of the tile is written below (index l² + l ± m for every l < N, m ≤ l), so it
    // is not initialised first.
    let mut tile = [std::mem::MaybeUninit::<[T; W]>::uninit(); NN];
    p1[0] = [qmm[0]; W];
    tile[0].write(p1[0]);
    let mut k = 0;
    // Where LLVM leaves these loops rolled (at N = 8, 12 and 16) they run with run-time
    // indices, so they are written with slices and iterators: one bounds check per band, none
    // per value (indexing each value had cost ~10 instructions of checks and index arithmetic
    // per multiply).
    for l in 1..N {
        let row = &ab[k..k + l.saturating_sub(1)];
        k += row.len();
        for ((&(a, b), p1m), p2m) in row.iter().zip(p1.iter_mut()).zip(p2.iter_mut()) {
            for j in 0..W {
                let q = madd::<T, FMA>(a * z[j], p1m[j], -(b * p2m[j]));
                p2m[j] = p1m[j];
                p1m[j] = q;
            }
        }
        for j in 0..W {
            p2[l - 1][j] = p1[l - 1][j];
            p1[l - 1][j] = sub[l - 1] * z[j] * qmm[l - 1];
        }
        p1[l] = [qmm[l]; W];
        // Band l: rows l² .. (l + 1)², the sine parts (index l − m) below the centre l² + l,
        // the cosine parts (l + m) above.
        let band = &mut tile[l * l..(l + 1) * (l + 1)];
        let (below, rest) = band.split_at_mut(l);
        let (centre, above) = rest.split_at_mut(1);
        centre[0].write(p1[0]);
        let parts = p1[1..=l].iter().zip(&cs[1..=l]).zip(&sn[1..=l]);
        for (((p, c), s), (up, down)) in parts.zip(above.iter_mut().zip(below.iter_mut().rev())) {
            let (mut pos, mut neg) = ([T::zero(); W], [T::zero(); W]);
            for j in 0..W {
                pos[j] = p[j] * c[j];
                neg[j] = p[j] * s[j];
            }
            up.write(pos);
            down.write(neg);
        }
    }
    // SAFETY: every row was written (the indices l² + l ± m cover 0..N² exactly once), and
    // `MaybeUninit<[T; W]>` has the layout of `[T; W]`.
    let tile: &[[T; W]; NN] = unsafe { &*(tile.as_ptr() as *const [[T; W]; NN]) };
    #[cfg(target_arch = "x86_64")]
    if let Some(store) = store {
        // SAFETY: `store` is `Some` only in the AVX2 + FMA instantiation; `out` holds W·NN
        // values.
        unsafe { write_tile_avx2::<T, NN, W>(tile.as_ptr(), out, store) };
        return;
    }
    let _ = store;
    for (j, o) in out.chunks_exact_mut(NN).enumerate() {
        for i in 0..NN {
            o[i] = tile[i][j];
        }
    }
}

/// Order 4 (the papers' order) in explicit AVX2 + FMA code: the operations of
/// [`lane_kernel_fixed`] with `FMA = true`, one after another in the same order (so the same
/// roundings), on whole vectors held in registers — 4 directions per batch in f64, 8 in f32 —
/// and the 16 values per direction transposed to point-major vectors in registers.
#[cfg(target_arch = "x86_64")]
mod order4 {
    use crate::legendre::Legendre;
    use crate::real::Real;
    use crate::store::{ahead_of, stream_copy, transpose4_pd, transpose8_ps, Store};
    use std::arch::x86_64::*;

    /// A 256-bit vector of `W` lanes of `S`.
    trait Lane: Copy {
        type S: Real;
        unsafe fn splat(s: Self::S) -> Self;
        unsafe fn mul(a: Self, b: Self) -> Self;
        /// `a·b + c`, one rounding.
        unsafe fn fmadd(a: Self, b: Self, c: Self) -> Self;
        /// `a·b − c`, one rounding.
        unsafe fn fmsub(a: Self, b: Self, c: Self) -> Self;
    }

    impl Lane for __m256d {
        type S = f64;
        #[inline(always)]
        unsafe fn splat(s: f64) -> Self {
            _mm256_set1_pd(s)
        }
        #[inline(always)]
        unsafe fn mul(a: Self, b: Self) -> Self {
            _mm256_mul_pd(a, b)
        }
        #[inline(always)]
        unsafe fn fmadd(a: Self, b: Self, c: Self) -> Self {
            _mm256_fmadd_pd(a, b, c)
        }
        #[inline(always)]
        unsafe fn fmsub(a: Self, b: Self, c: Self) -> Self {
            _mm256_fmsub_pd(a, b, c)
        }
    }

    impl Lane for __m256 {
        type S = f32;
        #[inline(always)]
        unsafe fn splat(s: f32) -> Self {
            _mm256_set1_ps(s)
        }
        #[inline(always)]
        unsafe fn mul(a: Self, b: Self) -> Self {
            _mm256_mul_ps(a, b)
        }
        #[inline(always)]
        unsafe fn fmadd(a: Self, b: Self, c: Self) -> Self {
            _mm256_fmadd_ps(a, b, c)
        }
        #[inline(always)]
        unsafe fn fmsub(a: Self, b: Self, c: Self) -> Self {
            _mm256_fmsub_ps(a, b, c)
        }
    }

    /// The recurrence's constants for order 4.
    struct Consts<S> {
        q: [S; 4],
        sub: [S; 3],
        ab: [(S, S); 3],
    }

    impl<S: Real> Consts<S> {
        fn of(leg: &Legendre<S>) -> Self {
            Self {
                q: [leg.qmm[0], leg.qmm[1], leg.qmm[2], leg.qmm[3]],
                sub: [leg.sub[0], leg.sub[1], leg.sub[2]],
                ab: [leg.ab_l[0], leg.ab_l[1], leg.ab_l[2]],
            }
        }
    }

    /// The 16 values (index order) for the directions in the lanes of `x, y, z`: the steps of
    /// [`super::lane_kernel_fixed`] at N = 4, written out.
    #[inline(always)]
    unsafe fn values<L: Lane>(k: &Consts<L::S>, x: L, y: L, z: L) -> [L; 16] {
        let s = |v: L::S| L::splat(v);
        // (Re, Im) of (x + iy)^m: m = 1 is (x, y) exactly.
        let (cs1, sn1) = (x, y);
        let cs2 = L::fmsub(x, cs1, L::mul(y, sn1));
        let sn2 = L::fmadd(x, sn1, L::mul(y, cs1));
        let cs3 = L::fmsub(x, cs2, L::mul(y, sn2));
        let sn3 = L::fmadd(x, sn2, L::mul(y, cs2));
        let [q0, q1, q2, q3] = k.q;
        let (a0, b0) = k.ab[0];
        let (a1, b1) = k.ab[1];
        let (a2, b2) = k.ab[2];
        let q10 = L::mul(L::mul(s(k.sub[0]), z), s(q0));
        let q20 = L::fmsub(L::mul(s(a0), z), q10, L::mul(s(b0), s(q0)));
        let q21 = L::mul(L::mul(s(k.sub[1]), z), s(q1));
        let q30 = L::fmsub(L::mul(s(a1), z), q20, L::mul(s(b1), q10));
        let q31 = L::fmsub(L::mul(s(a2), z), q21, L::mul(s(b2), s(q1)));
        let q32 = L::mul(L::mul(s(k.sub[2]), z), s(q2));
        let (q1, q2, q3) = (s(q1), s(q2), s(q3));
        [
            s(q0),
            L::mul(q1, sn1),
            q10,
            L::mul(q1, cs1),
            L::mul(q2, sn2),
            L::mul(q21, sn1),
            q20,
            L::mul(q21, cs1),
            L::mul(q2, cs2),
            L::mul(q3, sn3),
            L::mul(q32, sn2),
            L::mul(q31, sn1),
            q30,
            L::mul(q31, cs1),
            L::mul(q32, cs2),
            L::mul(q3, cs3),
        ]
    }

    /// Order 4 in f64, 4 directions per batch: `out[j·16 ..]` for `dirs[j]`; `dirs.len()` a
    /// multiple of 4.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn batch_f64(
        leg: &Legendre<f64>,
        dirs: &[[f64; 3]],
        out: &mut [f64],
        store: Store,
    ) {
        let k = Consts::of(leg);
        assert!(dirs.len().is_multiple_of(4) && out.len() == dirs.len() * 16);
        #[repr(C, align(64))]
        struct Stage([f64; 64], [u8; 4096]);
        let mut stage = std::mem::MaybeUninit::<Stage>::uninit();
        let mut half = HalfShift::new(store, out.as_ptr() as *const u8);
        for (d, o) in dirs.chunks_exact(4).zip(out.chunks_exact_mut(64)) {
            let x = _mm256_set_pd(d[3][0], d[2][0], d[1][0], d[0][0]);
            let y = _mm256_set_pd(d[3][1], d[2][1], d[1][1], d[0][1]);
            let z = _mm256_set_pd(d[3][2], d[2][2], d[1][2], d[0][2]);
            let v = values::<__m256d>(&k, x, y, z);
            if let Some(h) = half.as_mut() {
                // The batch's 16 vectors in address order, then streamed half a vector on.
                let mut w = [_mm256_setzero_si256(); 16];
                for b in 0..4 {
                    let c = transpose4_pd([v[4 * b], v[4 * b + 1], v[4 * b + 2], v[4 * b + 3]]);
                    for (j, c) in c.into_iter().enumerate() {
                        w[4 * j + b] = _mm256_castpd_si256(c);
                    }
                }
                h.put(&w, o.as_mut_ptr() as *mut u8);
                continue;
            }
            let sp = ahead_of::<f64>(stage.as_mut_ptr() as *mut u8, o.as_ptr());
            let dst = if store == Store::Stream {
                sp
            } else {
                o.as_mut_ptr()
            };
            for b in 0..4 {
                let c = transpose4_pd([v[4 * b], v[4 * b + 1], v[4 * b + 2], v[4 * b + 3]]);
                for (j, c) in c.into_iter().enumerate() {
                    _mm256_storeu_pd(dst.add(16 * j + 4 * b), c);
                }
            }
            if store == Store::Stream {
                stream_copy(sp, o.as_mut_ptr(), 64);
            }
        }
        if let Some(h) = half {
            h.finish(out.as_mut_ptr().add(out.len()) as *mut u8);
        }
    }

    /// Order 4 in f32, 8 directions per batch; `dirs.len()` a multiple of 8.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn batch_f32(
        leg: &Legendre<f32>,
        dirs: &[[f32; 3]],
        out: &mut [f32],
        store: Store,
    ) {
        let k = Consts::of(leg);
        assert!(dirs.len().is_multiple_of(8) && out.len() == dirs.len() * 16);
        #[repr(C, align(64))]
        struct Stage([f32; 128], [u8; 4096]);
        let mut stage = std::mem::MaybeUninit::<Stage>::uninit();
        let mut half = HalfShift::new(store, out.as_ptr() as *const u8);
        for (d, o) in dirs.chunks_exact(8).zip(out.chunks_exact_mut(128)) {
            let lane = |a: usize| {
                _mm256_set_ps(
                    d[7][a], d[6][a], d[5][a], d[4][a], d[3][a], d[2][a], d[1][a], d[0][a],
                )
            };
            let v = values::<__m256>(&k, lane(0), lane(1), lane(2));
            if let Some(h) = half.as_mut() {
                let mut w = [_mm256_setzero_si256(); 16];
                for b in 0..2 {
                    let c = transpose8_ps(std::array::from_fn(|k| v[8 * b + k]));
                    for (j, c) in c.into_iter().enumerate() {
                        w[2 * j + b] = _mm256_castps_si256(c);
                    }
                }
                h.put(&w, o.as_mut_ptr() as *mut u8);
                continue;
            }
            let sp = ahead_of::<f32>(stage.as_mut_ptr() as *mut u8, o.as_ptr());
            let dst = if store == Store::Stream {
                sp
            } else {
                o.as_mut_ptr()
            };
            for b in 0..2 {
                let c = transpose8_ps(std::array::from_fn(|k| v[8 * b + k]));
                for (j, c) in c.into_iter().enumerate() {
                    _mm256_storeu_ps(dst.add(16 * j + 8 * b), c);
                }
            }
            if store == Store::Stream {
                stream_copy(sp, o.as_mut_ptr(), 128);
            }
        }
        if let Some(h) = half {
            h.finish(out.as_mut_ptr().add(out.len()) as *mut u8);
        }
    }

    /// Streaming to an output that starts 16 B past a 32-B boundary — where a large `Vec` from
    /// the system allocator starts (16 B past a page): each batch's 16 vectors, in address
    /// order, are streamed shifted by half a vector (the upper half of one and the lower half of
    /// the next, one lane permute), so every non-temporal store but the output's first and last
    /// 16 B is a whole aligned vector, with no staging copy. The staging copy had written each
    /// batch's unaligned ends value by value. `None` for other placements and for `Store::Vector`.
    pub(super) struct HalfShift {
        /// The last vector of the previous batch, whose upper half is not yet written (`None`
        /// before the first batch).
        prev: Option<__m256i>,
    }

    impl HalfShift {
        pub(super) fn new(store: Store, out: *const u8) -> Option<Self> {
            (store == Store::Stream && out as usize % 32 == 16).then_some(Self { prev: None })
        }

        /// One batch: `w` are its 32-B vectors in address order, `o` (16 B past a 32-B
        /// boundary) where the first belongs; the batches come in address order, back to back.
        /// Writes `o − 16 .. o + 496` (`o .. o + 496` for the first batch); the batch's last
        /// 16 B wait for the next batch or [`HalfShift::finish`].
        ///
        /// # Safety
        /// AVX2 is available, and the 512 B at `o` belong to the output this was made for.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) unsafe fn put(&mut self, w: &[__m256i; 16], o: *mut u8) {
            let (mut prev, from) = match self.prev {
                Some(p) => (p, 0),
                None => {
                    // The output's first 16 B (aligned to 16).
                    _mm_stream_si128(o as *mut __m128i, _mm256_castsi256_si128(w[0]));
                    (w[0], 1)
                }
            };
            for (i, &v) in w.iter().enumerate().skip(from) {
                let joined = _mm256_permute2x128_si256::<0x21>(prev, v);
                _mm256_stream_si256(o.add(32 * i - 16) as *mut __m256i, joined);
                prev = v;
            }
            self.prev = Some(prev);
        }

        /// The last 16 B, before `end` (the end of the batches' output).
        ///
        /// # Safety
        /// AVX2 is available, and `end` is the end of the output given to every `put`.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) unsafe fn finish(self, end: *mut u8) {
            if let Some(prev) = self.prev {
                _mm_stream_si128(
                    end.sub(16) as *mut __m128i,
                    _mm256_extracti128_si256::<1>(prev),
                );
            }
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
                    if detected() >= Level::Avx2Fma {
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

    /// Both store kinds of the AVX2 path (ordinary transposed stores and non-temporal streams
    /// through the staging copy) give the same values, at every alignment of the output and
    /// with tails; and they equal the one-direction kernel to the FMA tolerance above. The
    /// order-4 kernel written out in intrinsics performs the generic kernel's operations, so it
    /// equals the generic AVX2 kernel exactly (as numbers; zeros may differ in sign).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn store_kinds_and_alignments_agree() {
        use crate::simd::{detected, Level};
        if detected() < Level::Avx2Fma {
            println!("notice: no AVX2 + FMA on this CPU; only the portable path exists");
            return;
        }
        fn check<T: Real>() {
            let dirs: Vec<[T; 3]> = dirs().iter().map(|d| d.map(T::c)).collect();
            let eps = T::epsilon().f64();
            let mut worst = 0f64;
            for order in [1usize, 2, 3, 4, 5, 7, 8, 12, 16, 17] {
                let b = ShBasis::<T>::new(order).unwrap();
                let nn = order * order;
                for len in [8usize, 13, 48, 54] {
                    let ds = &dirs[..len];
                    let mut one = vec![T::zero(); len * nn];
                    for (d, o) in ds.iter().zip(one.chunks_exact_mut(nn)) {
                        b.eval(*d, o);
                    }
                    let scale = one.iter().fold(1f64, |m, v| m.max(v.f64().abs()));
                    let mut first: Option<Vec<T>> = None;
                    for store in [Store::Vector, Store::Stream] {
                        for shift in 0..8 {
                            // Sentinels around the output catch writes outside it.
                            let mut buf = vec![T::c(7.0); len * nn + 16];
                            let out = &mut buf[shift..shift + len * nn];
                            b.eval_batch_store(Level::Avx2Fma, ds, out, store);
                            let got = out.to_vec();
                            assert!(buf[..shift].iter().all(|v| *v == T::c(7.0)));
                            assert!(buf[shift + len * nn..].iter().all(|v| *v == T::c(7.0)));
                            for (a, c) in one.iter().zip(&got) {
                                worst = worst.max((a.f64() - c.f64()).abs() / (scale * eps));
                            }
                            match &first {
                                None => first = Some(got),
                                Some(f) => assert!(
                                    f.iter().zip(&got).all(|(a, c)| a == c),
                                    "order {order}, len {len}, {store:?}, shift {shift}"
                                ),
                            }
                        }
                    }
                    if order == 4 {
                        // The generic AVX2 kernel on the whole batches.
                        let whole = len / LANES * LANES;
                        let mut generic = vec![T::zero(); whole * nn];
                        // SAFETY: the CPU has AVX2 and FMA (checked above).
                        unsafe {
                            fixed_batches_avx2::<T, 4, 16, LANES>(
                                &b.leg,
                                &ds[..whole],
                                &mut generic,
                                Some(Store::Vector),
                            )
                        };
                        let f = first.as_ref().unwrap();
                        assert!(
                            generic.iter().zip(f).all(|(a, c)| a == c),
                            "order 4, len {len}"
                        );
                    }
                }
            }
            println!(
                "{}: store kinds and alignments agree; worst difference from the one-direction \
                 kernel {worst:.1} ulps of the largest value",
                std::any::type_name::<T>()
            );
            assert!(worst <= 32.0, "{worst} ulps");
        }
        check::<f64>();
        check::<f32>();
    }

    /// An output past [`STREAM_BYTES`] takes the streaming path through the public entry point
    /// and matches the one-direction kernel.
    #[test]
    fn large_output_streams_correctly() {
        let order = 16;
        let b = ShBasis::<f64>::new(order).unwrap();
        let nn = order * order;
        let n = STREAM_BYTES / (nn * 8) + 5;
        let base = dirs();
        let ds: Vec<[f64; 3]> = (0..n).map(|i| base[i % base.len()]).collect();
        let mut out = vec![0.0; n * nn];
        b.eval_batch(&ds, &mut out);
        let mut one = vec![0.0; nn];
        let mut worst = 0f64;
        for (i, d) in ds
            .iter()
            .enumerate()
            .step_by(97)
            .chain(std::iter::once((n - 1, &ds[n - 1])))
        {
            b.eval(*d, &mut one);
            let scale = one.iter().fold(1f64, |m, v| m.max(v.abs()));
            for (a, c) in one.iter().zip(&out[i * nn..(i + 1) * nn]) {
                worst = worst.max((a - c).abs() / (scale * f64::EPSILON));
            }
        }
        println!("{n} directions at order {order}: worst difference {worst:.1} ulps of the largest value");
        assert!(worst <= 32.0, "{worst}");
    }
}
