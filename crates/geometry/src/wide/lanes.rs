//! Eight f32 lanes, the vocabulary the packet kernel (`packet.rs`) is written in, with one
//! implementation per SIMD level: [`Avx2`] (one `__m256`, x86-64 with AVX2 and FMA; the
//! AVX-512 instantiation compiles the same intrinsics EVEX-encoded) and [`Portable`] (an array
//! of 8 `f32` with per-lane loops, which LLVM turns into two 128-bit vectors: SSE2 on x86-64,
//! NEON on aarch64). A compare yields a lane mask in the SSE manner (all bits set where true,
//! as an `f32` lane), so masks combine with [`Lanes::and`] and leave as bits with
//! [`Lanes::bits`].
//!
//! Every operation is the IEEE one lane by lane, with the same NaN rules in both forms
//! (`min(a, b) = a < b ? a : b`, `max(a, b) = a > b ? a : b`, as `minps`/`maxps`), so the two
//! instantiations of one kernel give the same bits; only [`Lanes::mul_add`] differs (fused
//! where the level has FMA), and the kernel uses it only in the conservative box test.

use super::layout::TINY_DIR;

/// Eight f32 lanes (see the module doc). Methods are `#[inline(always)]`; [`Avx2`]'s are only
/// sound inside functions that enable AVX2 and FMA.
pub(super) trait Lanes: Copy {
    fn splat(x: f32) -> Self;
    fn load(a: &[f32; 8]) -> Self;
    fn store(self, a: &mut [f32; 8]);
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    /// `self < o ? self : o` per lane.
    fn min(self, o: Self) -> Self;
    /// `self > o ? self : o` per lane.
    fn max(self, o: Self) -> Self;
    /// `self · m + a`, fused where the level has FMA.
    fn mul_add(self, m: Self, a: Self) -> Self;
    fn and(self, o: Self) -> Self;
    /// `!self & o` (bitwise), as `andnot`.
    fn andnot(self, o: Self) -> Self;
    fn or(self, o: Self) -> Self;
    fn xor(self, o: Self) -> Self;
    fn lt(self, o: Self) -> Self;
    fn le(self, o: Self) -> Self;
    fn gt(self, o: Self) -> Self;
    fn ge(self, o: Self) -> Self;
    /// Ordered not-equal (false where either lane is NaN).
    fn ne(self, o: Self) -> Self;
    /// Per lane: `t` where the mask lane's sign bit is set, else `f`.
    fn select(mask: Self, t: Self, f: Self) -> Self;
    /// The lanes' sign bits, lane i at bit i.
    fn bits(self) -> u32;
    /// Eight `[x, y, z]` directions as x, y and z lanes (lane i = `dirs[i]`; exactly 8).
    fn soa8(dirs: &[[f32; 3]]) -> [Self; 3];
    /// The children that are empty slots (`u32::MAX`), as bits.
    fn empty_slots(child: &[u32; 8]) -> u32;

    /// `1 / d` per lane, a component with `|d| < TINY_DIR` first replaced by `±TINY_DIR` (its
    /// sign kept): the operations of `Prepared::new`, so the values are bit-identical.
    #[inline(always)]
    fn recip_dir(self) -> Self {
        let neg = Self::splat(-0.0);
        let sign = self.and(neg);
        let small = neg.andnot(self).lt(Self::splat(TINY_DIR));
        let fixed = Self::select(small, sign.or(Self::splat(TINY_DIR)), self);
        Self::splat(1.0).div(fixed)
    }
}

/// The portable form: 8 lanes in an array, each operation a loop LLVM vectorizes for the
/// target's default vectors (two SSE2 or NEON registers).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(super) struct Portable(pub(super) [f32; 8]);

impl Portable {
    #[inline(always)]
    fn map(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        Portable(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }
    #[inline(always)]
    fn bitwise(self, o: Self, f: impl Fn(u32, u32) -> u32) -> Self {
        self.map(o, |a, b| f32::from_bits(f(a.to_bits(), b.to_bits())))
    }
    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(f32, f32) -> bool) -> Self {
        self.map(o, |a, b| f32::from_bits(if f(a, b) { u32::MAX } else { 0 }))
    }
}

impl Lanes for Portable {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Portable([x; 8])
    }
    #[inline(always)]
    fn load(a: &[f32; 8]) -> Self {
        Portable(*a)
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; 8]) {
        *a = self.0;
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.map(o, |a, b| a + b)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.map(o, |a, b| a - b)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.map(o, |a, b| a * b)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self.map(o, |a, b| a / b)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.map(o, |a, b| if a < b { a } else { b })
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.map(o, |a, b| if a > b { a } else { b })
    }
    #[inline(always)]
    fn mul_add(self, m: Self, a: Self) -> Self {
        self.mul(m).add(a)
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        self.bitwise(o, |a, b| a & b)
    }
    #[inline(always)]
    fn andnot(self, o: Self) -> Self {
        self.bitwise(o, |a, b| !a & b)
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        self.bitwise(o, |a, b| a | b)
    }
    #[inline(always)]
    fn xor(self, o: Self) -> Self {
        self.bitwise(o, |a, b| a ^ b)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        self.cmp(o, |a, b| a < b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self {
        self.cmp(o, |a, b| a <= b)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        self.cmp(o, |a, b| a > b)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self {
        self.cmp(o, |a, b| a >= b)
    }
    #[inline(always)]
    // Ordered: `a != b` would be true where a lane is NaN (clippy's suggestion is not this).
    #[allow(clippy::double_comparisons)]
    fn ne(self, o: Self) -> Self {
        self.cmp(o, |a, b| a < b || a > b)
    }
    #[inline(always)]
    fn select(mask: Self, t: Self, f: Self) -> Self {
        Portable(std::array::from_fn(|i| {
            if mask.0[i].to_bits() >> 31 == 1 {
                t.0[i]
            } else {
                f.0[i]
            }
        }))
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        // x86-64: SSE `movmskps` on each half (SSE is part of the x86-64 baseline); LLVM does
        // not find it in the loop below, which cost shifts and ors per lane.
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_loadu_ps, _mm_movemask_ps};
            let p = self.0.as_ptr();
            // SAFETY: SSE is enabled on every x86-64 target; each load reads 4 of the 8 floats.
            let (lo, hi) = unsafe {
                (
                    _mm_movemask_ps(_mm_loadu_ps(p)),
                    _mm_movemask_ps(_mm_loadu_ps(p.add(4))),
                )
            };
            (lo | hi << 4) as u32
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut b = 0;
            for i in 0..8 {
                b |= (self.0[i].to_bits() >> 31) << i;
            }
            b
        }
    }
    #[inline(always)]
    fn soa8(dirs: &[[f32; 3]]) -> [Self; 3] {
        let d = &dirs[..8];
        std::array::from_fn(|a| Portable(std::array::from_fn(|i| d[i][a])))
    }
    #[inline(always)]
    fn empty_slots(child: &[u32; 8]) -> u32 {
        let mut b = 0;
        for (i, &c) in child.iter().enumerate() {
            b |= u32::from(c == u32::MAX) << i;
        }
        b
    }
}

/// The AVX2 + FMA form: one `__m256`. Only constructed and used inside functions that enable
/// AVX2, FMA, POPCNT, BMI1 and BMI2 (the packet kernel's per-level wrappers), where every
/// method below is inlined.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct Avx2(pub(super) std::arch::x86_64::__m256);

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Avx2, Lanes};
    use std::arch::x86_64::*;

    // SAFETY (every `unsafe` block of this impl): the intrinsics need AVX (FMA for `mul_add`,
    // AVX2 for the integer compare); `Avx2` values exist only inside functions that enable
    // AVX2 and FMA (type doc), into which these `#[inline(always)]` methods are inlined; the
    // loads and stores touch exactly the 8 floats (or words) of the arrays given.
    impl Lanes for Avx2 {
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Avx2(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn load(a: &[f32; 8]) -> Self {
            Avx2(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, a: &mut [f32; 8]) {
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul_add(self, m: Self, a: Self) -> Self {
            Avx2(unsafe { _mm256_fmadd_ps(self.0, m.0, a.0) })
        }
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_and_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn andnot(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_andnot_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_or_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn xor(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_xor_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ge(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ne(self, o: Self) -> Self {
            Avx2(unsafe { _mm256_cmp_ps::<_CMP_NEQ_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn select(mask: Self, t: Self, f: Self) -> Self {
            Avx2(unsafe { _mm256_blendv_ps(f.0, t.0, mask.0) })
        }
        #[inline(always)]
        fn bits(self) -> u32 {
            (unsafe { _mm256_movemask_ps(self.0) }) as u32
        }
        /// Three unaligned loads of two 16-byte halves each, then five shuffles — no round trip
        /// through memory, whose 4-byte stores a 32-byte load could not forward.
        #[inline(always)]
        fn soa8(dirs: &[[f32; 3]]) -> [Self; 3] {
            let f = dirs[..8].as_flattened();
            let p = f.as_ptr();
            unsafe {
                // Halves: m03 = x0 y0 z0 x1 | x4 y4 z4 x5, m14 = y1 z1 x2 y2 | y5 z5 x6 y6,
                // m25 = z2 x3 y3 z3 | z6 x7 y7 z7 (`f` holds 24 floats; loads at offsets ≤ 20).
                let half = |lo: usize, hi: usize| {
                    _mm256_insertf128_ps::<1>(
                        _mm256_castps128_ps256(_mm_loadu_ps(p.add(lo))),
                        _mm_loadu_ps(p.add(hi)),
                    )
                };
                let (m03, m14, m25) = (half(0, 12), half(4, 16), half(8, 20));
                // xy = x2 y2 x3 y3 | x6 y6 x7 y7, yz = y0 z0 y1 z1 | y4 z4 y5 z5
                let xy = _mm256_shuffle_ps::<0b10_01_11_10>(m14, m25);
                let yz = _mm256_shuffle_ps::<0b01_00_10_01>(m03, m14);
                let x = _mm256_shuffle_ps::<0b10_00_11_00>(m03, xy);
                let y = _mm256_shuffle_ps::<0b11_01_10_00>(yz, xy);
                let z = _mm256_shuffle_ps::<0b11_00_11_01>(yz, m25);
                [Avx2(x), Avx2(y), Avx2(z)]
            }
        }
        #[inline(always)]
        fn empty_slots(child: &[u32; 8]) -> u32 {
            unsafe {
                _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
                    _mm256_loadu_si256(child.as_ptr() as *const __m256i),
                    _mm256_set1_epi32(-1),
                ))) as u32
            }
        }
    }
}
