//! Memory movement of the SH kernels: how a tile of `N² × lanes` values computed lane-major is
//! written out point-major — AVX2 in-register transposes (8×8 f32, 4×4 f64) straight into the
//! output, or into an aligned staging copy streamed out with non-temporal stores for outputs
//! far larger than the caches ([`STREAM_BYTES`]). The recurrences are in the `eval` module.

#[cfg(target_arch = "x86_64")]
use crate::real::Real;
#[cfg(target_arch = "x86_64")]
use crate::simd::LANES;

/// How [`lane_kernel_fixed`] writes its tile out (chosen per call by [`batch_dispatch`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Store {
    /// Whole-vector transposes, ordinary stores (the output stays in cache).
    Vector,
    /// Whole-vector transposes, non-temporal stores (outputs far larger than the caches:
    /// no read-for-ownership of lines that are overwritten whole).
    Stream,
}

/// Outputs of [`ShBasis::eval_batch`] at least this large are written with non-temporal
/// stores: well past the second-level cache of one core, where the lines would be evicted
/// unread anyway (measured in docs/BENCHMARKS.md: 2–3× faster at N = 8 and 16 for 10⁶ points,
/// and slower for outputs that stay in cache).
pub const STREAM_BYTES: usize = 8 << 20;

/// Write a tile (`NN` values × `W` lanes, `W` = 8, or 4 for f64) point by point.
///
/// [`Store::Vector`]: AVX2 in-register transposes (8×8 blocks of f32, 4×4 blocks of f64)
/// straight into `out`, so every load and store is a whole vector; values that do not fill a
/// block are stored one by one. [`Store::Stream`]: the same transposes into an aligned staging
/// copy of the batch's output (it stays in the first-level cache), which is then copied to
/// `out` in address order with non-temporal stores — whole aligned 32-B vectors, the unaligned
/// ends value by value — so each output line is written once, whole, without being read.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn write_tile_avx2<T: Real, const NN: usize, const W: usize>(
    tile: *const [T; W],
    out: &mut [T],
    store: Store,
) {
    // SAFETY: the caller's tile is NN rows of W values.
    let tile = std::slice::from_raw_parts(tile, NN);
    assert!(out.len() >= W * NN);
    if store == Store::Vector || !(is::<T, f64>() || is::<T, f32>()) {
        transpose_tile::<T, NN, W>(tile, out.as_mut_ptr());
        return;
    }
    // The staging copy is placed 1 KiB *ahead* of the output modulo 4 KiB: its loads then
    // never share their low 12 address bits with the non-temporal stores just issued to the
    // output (which the CPU would take for a possible dependence and stall on — 4 KiB
    // aliasing), whatever the relative placement of stack and output in this process.
    #[repr(C, align(64))]
    struct Staging<T, const L: usize>([[T; L]; W_MAX], [u8; 4096]);
    const W_MAX: usize = LANES;
    let mut staging = std::mem::MaybeUninit::<Staging<T, NN>>::uninit();
    let sp = ahead_of(staging.as_mut_ptr() as *mut u8, out.as_ptr());
    transpose_tile::<T, NN, W>(tile, sp);
    stream_copy(sp, out.as_mut_ptr(), W * NN);
}

/// The place in a staging buffer (`base`, 64-B aligned, 4 KiB longer than the copy) that lies
/// 1 KiB ahead of `out` modulo 4 KiB, to a cache line (see [`write_tile_avx2`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn ahead_of<T>(base: *mut u8, out: *const T) -> *mut T {
    let want = (out as usize + 1024) % 4096;
    let shift = (want + 4096 - base as usize % 4096) % 4096 / 64 * 64;
    base.wrapping_add(shift) as *mut T
}

/// An 8×8 transpose of f32 vectors: `out[j][i] = r[i][j]`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn transpose8_ps(
    r: [std::arch::x86_64::__m256; 8],
) -> [std::arch::x86_64::__m256; 8] {
    use std::arch::x86_64::*;
    let (t0, t1) = (
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
    );
    let (t2, t3) = (
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
    );
    let (t4, t5) = (
        _mm256_unpacklo_ps(r[4], r[5]),
        _mm256_unpackhi_ps(r[4], r[5]),
    );
    let (t6, t7) = (
        _mm256_unpacklo_ps(r[6], r[7]),
        _mm256_unpackhi_ps(r[6], r[7]),
    );
    let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
    let s1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
    let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
    let s3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
    let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
    let s5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
    let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
    let s7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
    [
        _mm256_permute2f128_ps::<0x20>(s0, s4),
        _mm256_permute2f128_ps::<0x20>(s1, s5),
        _mm256_permute2f128_ps::<0x20>(s2, s6),
        _mm256_permute2f128_ps::<0x20>(s3, s7),
        _mm256_permute2f128_ps::<0x31>(s0, s4),
        _mm256_permute2f128_ps::<0x31>(s1, s5),
        _mm256_permute2f128_ps::<0x31>(s2, s6),
        _mm256_permute2f128_ps::<0x31>(s3, s7),
    ]
}

/// A 4×4 transpose of f64 vectors: `out[j][i] = r[i][j]`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn transpose4_pd(
    r: [std::arch::x86_64::__m256d; 4],
) -> [std::arch::x86_64::__m256d; 4] {
    use std::arch::x86_64::*;
    let (t0, t1) = (
        _mm256_unpacklo_pd(r[0], r[1]),
        _mm256_unpackhi_pd(r[0], r[1]),
    );
    let (t2, t3) = (
        _mm256_unpacklo_pd(r[2], r[3]),
        _mm256_unpackhi_pd(r[2], r[3]),
    );
    [
        _mm256_permute2f128_pd::<0x20>(t0, t2),
        _mm256_permute2f128_pd::<0x20>(t1, t3),
        _mm256_permute2f128_pd::<0x31>(t0, t2),
        _mm256_permute2f128_pd::<0x31>(t1, t3),
    ]
}

/// The tile's transpose: `out[j·NN + i] = tile[i][j]` for `j < W`, `i < NN`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn transpose_tile<T: Real, const NN: usize, const W: usize>(
    tile: &[[T; W]],
    out: *mut T,
) {
    use std::arch::x86_64::*;
    let mut done = 0;
    if is::<T, f32>() && W == 8 {
        let t = tile.as_ptr() as *const f32;
        let o = out as *mut f32;
        while done + 8 <= NN {
            let c = transpose8_ps(std::array::from_fn(|k| {
                _mm256_loadu_ps(t.add((done + k) * 8))
            }));
            for (lane, v) in c.into_iter().enumerate() {
                _mm256_storeu_ps(o.add(lane * NN + done), v);
            }
            done += 8;
        }
    } else if is::<T, f64>() && W.is_multiple_of(4) {
        let t = tile.as_ptr() as *const f64;
        let o = out as *mut f64;
        while done + 4 <= NN {
            for g in 0..W / 4 {
                let c = transpose4_pd(std::array::from_fn(|k| {
                    _mm256_loadu_pd(t.add((done + k) * W + 4 * g))
                }));
                for (k, v) in c.into_iter().enumerate() {
                    _mm256_storeu_pd(o.add((4 * g + k) * NN + done), v);
                }
            }
            done += 4;
        }
    }
    for j in 0..W {
        for (i, row) in tile.iter().enumerate().skip(done) {
            *out.add(j * NN + i) = row[j];
        }
    }
}

/// Copy `n` values from `src` to `dst` with non-temporal stores: the unaligned head and tail of
/// `dst` value by value, the 32-B aligned body in whole vectors (unaligned loads from `src`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn stream_copy<T: Real>(src: *const T, dst: *mut T, n: usize) {
    use std::arch::x86_64::*;
    let size = std::mem::size_of::<T>();
    let per = 32 / size;
    let mis = (dst as usize % 32) / size;
    let head = if mis == 0 { 0 } else { (per - mis).min(n) };
    let body = (n - head) / per * per;
    let one = |k: usize| {
        if size == 8 {
            _mm_stream_si64(dst.add(k) as *mut i64, *(src.add(k) as *const i64));
        } else {
            _mm_stream_si32(dst.add(k) as *mut i32, *(src.add(k) as *const i32));
        }
    };
    for k in 0..head {
        one(k);
    }
    let mut k = head;
    let copy = |k: usize| {
        let v = _mm256_loadu_si256(src.add(k) as *const __m256i);
        _mm256_stream_si256(dst.add(k) as *mut __m256i, v);
    };
    // Four vectors (two lines) per step: the loop's counters and branch had been two thirds of
    // the copy's instructions.
    while k + 4 * per <= head + body {
        for i in 0..4 {
            copy(k + i * per);
        }
        k += 4 * per;
    }
    while k < head + body {
        copy(k);
        k += per;
    }
    for k in head + body..n {
        one(k);
    }
}

/// Whether `T` is `U` (the kernels that reinterpret memory as f32 or f64 check this, not the
/// size: `Real` is implementable outside this crate).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn is<T: 'static, U: 'static>() -> bool {
    std::any::TypeId::of::<T>() == std::any::TypeId::of::<U>()
}
