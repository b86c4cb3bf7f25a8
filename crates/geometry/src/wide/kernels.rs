//! The traversal kernels of the 8-wide BVH: any-hit and closest-hit for one ray, fans of rays
//! from one origin (packets of 8 rays on AVX2 / AVX-512), the slab and triangle tests, each
//! written once as lane-array code and instantiated per SIMD level (module doc of `wide`).

use super::layout::*;
use shscale_sh::simd::Level;

impl WideBvh {
    /// Whether the ray hits any triangle for `t ∈ (tmin, tmax)`.
    #[inline]
    pub fn occluded(&self, level: Level, ray: &WideRay) -> bool {
        // SAFETY (each arm): `usable` keeps a level only where the CPU has its instructions
        // (a level it lacks becomes `Portable`).
        #[cfg(target_arch = "x86_64")]
        match level.usable() {
            Level::Avx512 => return unsafe { self.occluded_avx512(ray) },
            Level::Avx2Fma => return unsafe { self.occluded_avx2(ray) },
            Level::Portable => {}
        }
        let _ = level;
        self.traverse::<true, false>(ray).is_some()
    }

    /// [`WideBvh::occluded`] with the instruction set fixed at compile time, for callers that
    /// inline it into their own kernels (`F`: AVX2 + FMA box tests; only inside an AVX2 + FMA
    /// `#[target_feature]` function).
    #[inline(always)]
    pub(crate) fn occluded_inline<const F: bool>(&self, ray: &WideRay) -> bool {
        self.traverse::<true, F>(ray).is_some()
    }

    /// Any-hit answers for many rays sharing their origin (the BSV workload): `hit[i]` for
    /// `dirs[i]`. Equal to [`WideBvh::occluded`] per ray.
    pub fn occluded_fan(
        &self,
        level: Level,
        o: [f32; 3],
        dirs: &[[f32; 3]],
        tmin: f32,
        tmax: f32,
        hit: &mut [bool],
    ) {
        // SAFETY (each arm): as in `occluded`.
        #[cfg(target_arch = "x86_64")]
        match level.usable() {
            Level::Avx512 => return unsafe { self.fan_avx512(o, dirs, tmin, tmax, hit) },
            Level::Avx2Fma => return unsafe { self.fan_avx2(o, dirs, tmin, tmax, hit) },
            Level::Portable => {}
        }
        let _ = level;
        self.fan::<false>(o, dirs, tmin, tmax, hit)
    }

    #[inline(always)]
    pub(super) fn fan<const F: bool>(
        &self,
        o: [f32; 3],
        dirs: &[[f32; 3]],
        tmin: f32,
        tmax: f32,
        hit: &mut [bool],
    ) {
        for (d, h) in dirs.iter().zip(hit.iter_mut()) {
            *h = self
                .traverse::<true, F>(&WideRay {
                    o,
                    d: *d,
                    tmin,
                    tmax,
                })
                .is_some();
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
    pub(super) unsafe fn fan_avx2(
        &self,
        o: [f32; 3],
        dirs: &[[f32; 3]],
        tmin: f32,
        tmax: f32,
        hit: &mut [bool],
    ) {
        self.fan_packets::<false>(o, dirs, tmin, tmax, hit)
    }

    /// [`WideBvh::fan_avx2`]'s code compiled with AVX-512 F, VL, BW and DQ as well.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
    pub(super) unsafe fn fan_avx512(
        &self,
        o: [f32; 3],
        dirs: &[[f32; 3]],
        tmin: f32,
        tmax: f32,
        hit: &mut [bool],
    ) {
        self.fan_packets::<true>(o, dirs, tmin, tmax, hit)
    }

    /// The fan in 8-ray packets; only inlined into a function that enables AVX2, FMA, POPCNT,
    /// BMI1 and BMI2 (`AVX512`: and AVX-512 F/VL/BW/DQ, whose packet kernel it then calls).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) unsafe fn fan_packets<const AVX512: bool>(
        &self,
        o: [f32; 3],
        dirs: &[[f32; 3]],
        tmin: f32,
        tmax: f32,
        hit: &mut [bool],
    ) {
        // Packets of 8 consecutive directions: callers order fans coherently (the BSV
        // sampler's hemisphere comes in 2×4 tiles of its grid).
        for (d, h) in dirs.chunks(8).zip(hit.chunks_mut(8)) {
            let m = if AVX512 {
                packet_occluded_avx512(self, o, d, tmin, tmax)
            } else {
                packet_occluded(self, o, d, tmin, tmax)
            };
            for (i, h) in h.iter_mut().enumerate() {
                *h = m >> i & 1 == 1;
            }
        }
    }

    /// The nearest hit `(t, triangle index)` for `t ∈ (tmin, tmax)`.
    pub fn closest(&self, level: Level, ray: &WideRay) -> Option<(f32, u32)> {
        // SAFETY (each arm): as in `occluded`.
        #[cfg(target_arch = "x86_64")]
        match level.usable() {
            Level::Avx512 => return unsafe { self.closest_avx512(ray) },
            Level::Avx2Fma => return unsafe { self.closest_avx2(ray) },
            Level::Portable => {}
        }
        let _ = level;
        self.traverse::<false, false>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
    pub(super) unsafe fn occluded_avx2(&self, ray: &WideRay) -> bool {
        self.traverse::<true, true>(ray).is_some()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
    pub(super) unsafe fn closest_avx2(&self, ray: &WideRay) -> Option<(f32, u32)> {
        self.traverse::<false, true>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
    pub(super) unsafe fn occluded_avx512(&self, ray: &WideRay) -> bool {
        self.traverse::<true, true>(ray).is_some()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
    pub(super) unsafe fn closest_avx512(&self, ray: &WideRay) -> Option<(f32, u32)> {
        self.traverse::<false, true>(ray)
    }

    /// The most entries a traversal stack holds: at each of the tree's levels at most 7 of a
    /// node's 8 children are pushed (the eighth is visited next), plus one.
    pub(super) fn stack_need(&self) -> usize {
        self.depth * (WIDTH - 1) + 1
    }

    /// Stack traversal; `ANY`: stop at the first hit (the returned hit is then some hit, not
    /// the nearest); `F`: fused multiply-adds in the box test.
    #[inline(always)]
    pub(super) fn traverse<const ANY: bool, const F: bool>(
        &self,
        ray: &WideRay,
    ) -> Option<(f32, u32)> {
        let pre = Prepared::new(ray);
        let (mut fixed, mut heap) = (uninit_slots(), Vec::new());
        let mut stack = stack_slots(&mut fixed, &mut heap, self.stack_need());
        self.traverse_prepared::<ANY, F>(ray, &pre, 0, &mut stack)
    }

    /// [`WideBvh::traverse`] of the subtree under node `start`, with the ray's slab data
    /// prepared and a stack given (the packet kernel's one-ray traversals share one; it is
    /// emptied here, since a traversal that ends at a hit leaves entries behind).
    #[inline(always)]
    pub(super) fn traverse_prepared<const ANY: bool, const F: bool>(
        &self,
        ray: &WideRay,
        pre: &Prepared,
        start: u32,
        stack: &mut Stack,
    ) -> Option<(f32, u32)> {
        stack.len = 0;
        let mut tmax = ray.tmax;
        let mut best: Option<(f32, u32)> = None;
        let mut n = start;
        loop {
            let node = &self.nodes[n as usize];
            #[cfg(target_arch = "x86_64")]
            let mut mask = if F {
                // SAFETY: `F` is true only in the AVX2 + FMA instantiations.
                unsafe { box_mask_avx2(node, pre, ray.tmin, tmax) }
            } else {
                box_mask::<F>(node, pre, ray.tmin, tmax)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let mut mask = box_mask::<F>(node, pre, ray.tmin, tmax);
            // The last inner child entered is visited next without a round trip through the
            // stack; the others are pushed.
            let mut next = EMPTY;
            while mask != 0 {
                let j = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let c = node.child[j];
                if c & LEAF == 0 {
                    if next != EMPTY {
                        stack.push(next);
                    }
                    next = c;
                    continue;
                }
                let (first, count) = leaf_range(c);
                for p in first..first + count {
                    let (t, lane) = pack_hit::<ANY>(&self.packs[p], ray, tmax);
                    if lane < PACK {
                        if ANY {
                            return Some((t, self.ids[p][lane]));
                        }
                        tmax = t;
                        best = Some((t, self.ids[p][lane]));
                    }
                }
            }
            n = if next != EMPTY {
                next
            } else {
                match stack.pop() {
                    Some(n) => n,
                    None => break,
                }
            };
        }
        best
    }
}

/// Slots on the call stack for a traversal stack; trees deeper than ~36 levels take a heap
/// buffer instead ([`stack_slots`]).
pub(super) const FIXED_SLOTS: usize = 256;

/// The slots of a traversal stack of at most `need` entries: the fixed array (not initialised:
/// only pushed slots are read) or, when it is too small, `heap`, sized once here.
#[inline(always)]
pub(super) fn stack_slots<'a>(
    fixed: &'a mut [std::mem::MaybeUninit<u32>; FIXED_SLOTS],
    heap: &'a mut Vec<std::mem::MaybeUninit<u32>>,
    need: usize,
) -> Stack<'a> {
    let slots: &'a mut [std::mem::MaybeUninit<u32>] = if need <= FIXED_SLOTS {
        fixed
    } else {
        heap.resize(need, std::mem::MaybeUninit::uninit());
        heap
    };
    Stack { slots, len: 0 }
}

/// A traversal stack over preallocated slots: a push is one checked store, a pop one load.
pub(super) struct Stack<'a> {
    pub(super) slots: &'a mut [std::mem::MaybeUninit<u32>],
    pub(super) len: usize,
}

impl Stack<'_> {
    #[inline(always)]
    pub(super) fn push(&mut self, v: u32) {
        // Checked: the slots are sized for the tree's depth, so this never fails.
        self.slots[self.len].write(v);
        self.len += 1;
    }
    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<u32> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: `len < slots.len()` (it was pushed), and slots below `len` were written by
        // `push`.
        Some(unsafe { self.slots.get_unchecked(self.len).assume_init() })
    }
}

/// Uninitialised slots for [`stack_slots`] (built without writing them: an array-repeat
/// expression here was compiled to a 1 KiB `memset` per traversal).
#[inline(always)]
pub(super) fn uninit_slots() -> [std::mem::MaybeUninit<u32>; FIXED_SLOTS] {
    // SAFETY: an array of `MaybeUninit` needs no initialisation.
    unsafe { std::mem::MaybeUninit::uninit().assume_init() }
}

/// A ray prepared for the slab tests: reciprocal direction, `o·inv`, and for each axis the
/// node rows of the near and far planes (chosen once per ray, so the box test has no branch).
pub(super) struct Prepared {
    pub(super) inv: [f32; 3],
    pub(super) oi: [f32; 3],
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
}

impl Prepared {
    #[inline(always)]
    pub(super) fn new(ray: &WideRay) -> Self {
        let mut inv = [0.0f32; 3];
        for a in 0..3 {
            let d = ray.d[a];
            // Zero (or denormal-small) components become ±TINY_DIR: no 0·∞ in the test.
            let d = if d.abs() < TINY_DIR {
                TINY_DIR.copysign(d)
            } else {
                d
            };
            inv[a] = 1.0 / d;
        }
        let oi = [ray.o[0] * inv[0], ray.o[1] * inv[1], ray.o[2] * inv[2]];
        Self::with(inv, oi)
    }

    /// Lane `i` of the packet kernel's reciprocals and `o·inv`, which it computes 8 lanes at
    /// a time with the same operations as [`Prepared::new`] (so the values are identical).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) fn lane(inv: &[[f32; 8]; 3], oi: &[[f32; 8]; 3], i: usize) -> Self {
        Self::with(
            [inv[0][i], inv[1][i], inv[2][i]],
            [oi[0][i], oi[1][i], oi[2][i]],
        )
    }

    #[inline(always)]
    pub(super) fn with(inv: [f32; 3], oi: [f32; 3]) -> Self {
        let mut near = [0usize; 3];
        let mut far = [0usize; 3];
        for a in 0..3 {
            let neg = usize::from(inv[a] < 0.0);
            near[a] = a + 3 * neg;
            far[a] = a + 3 * (1 - neg);
        }
        Self { inv, oi, near, far }
    }
}

/// The slab test of one ray against a node's 8 boxes: bit j set when box j is entered for some
/// `t ∈ [tmin, tmax]`.
#[inline(always)]
pub(super) fn box_mask<const F: bool>(node: &Node, pre: &Prepared, tmin: f32, tmax: f32) -> u32 {
    let mut tn = [tmin; WIDTH];
    let mut tf = [tmax; WIDTH];
    for a in 0..3 {
        let (near, far) = (&node.b[pre.near[a]], &node.b[pre.far[a]]);
        let (inv, oi) = (pre.inv[a], pre.oi[a]);
        for j in 0..WIDTH {
            let (t0, t1) = if F {
                (near[j].mul_add(inv, -oi), far[j].mul_add(inv, -oi))
            } else {
                (near[j] * inv - oi, far[j] * inv - oi)
            };
            tn[j] = if t0 > tn[j] { t0 } else { tn[j] };
            tf[j] = if t1 < tf[j] { t1 } else { tf[j] };
        }
    }
    let mut mask = 0u32;
    for j in 0..WIDTH {
        let slack = tf[j] + tf[j].abs() * SLAB_SLACK;
        mask |= ((tn[j] <= slack) as u32) << j;
    }
    mask
}

/// [`box_mask`] in AVX2 + FMA intrinsics (LLVM splits the lane-array form into two 128-bit
/// halves); the same operations with fused multiply-adds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
#[inline]
pub(super) unsafe fn box_mask_avx2(node: &Node, pre: &Prepared, tmin: f32, tmax: f32) -> u32 {
    use std::arch::x86_64::*;
    let mut tn = _mm256_set1_ps(tmin);
    let mut tf = _mm256_set1_ps(tmax);
    for a in 0..3 {
        let (near, far) = (&node.b[pre.near[a]], &node.b[pre.far[a]]);
        let (i, n) = (_mm256_set1_ps(pre.inv[a]), _mm256_set1_ps(-pre.oi[a]));
        // SAFETY: each row is 8 contiguous f32 (unaligned loads).
        let t0 = _mm256_fmadd_ps(_mm256_loadu_ps(near.as_ptr()), i, n);
        let t1 = _mm256_fmadd_ps(_mm256_loadu_ps(far.as_ptr()), i, n);
        tn = _mm256_max_ps(t0, tn);
        tf = _mm256_min_ps(t1, tf);
    }
    let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), tf);
    let slack = _mm256_fmadd_ps(abs, _mm256_set1_ps(SLAB_SLACK), tf);
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, slack)) as u32
}

/// The packet's slab test of one box, as a macro so that it is expanded in place inside the
/// packet kernel (as a `#[target_feature]` function LLVM left it out of line there, 25 % more
/// instructions): `$t(a, k)` is the distance vector to the box's lower (`k = 0`) or upper
/// (`k = 1`) plane on axis `a`, lanes = rays. Bit i is set when ray i enters the box for some
/// `t ∈ [tmin, tmax]`, with the exit distance widened by [`SLAB_SLACK`] like [`box_mask`]'s
/// (each axis takes the lesser and the greater plane distance, so the lanes' signs may differ).
#[cfg(target_arch = "x86_64")]
macro_rules! lanes_entering {
    ($t:expr, $vtmin:expr, $vtmax:expr) => {{
        let t = $t;
        let (x0, x1) = (t(0, 0), t(0, 1));
        let (y0, y1) = (t(1, 0), t(1, 1));
        let (z0, z1) = (t(2, 0), t(2, 1));
        let tn = _mm256_max_ps(
            _mm256_max_ps(_mm256_min_ps(x0, x1), _mm256_min_ps(y0, y1)),
            _mm256_max_ps(_mm256_min_ps(z0, z1), $vtmin),
        );
        let tf = _mm256_min_ps(
            _mm256_min_ps(_mm256_max_ps(x0, x1), _mm256_max_ps(y0, y1)),
            _mm256_min_ps(_mm256_max_ps(z0, z1), $vtmax),
        );
        let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), tf);
        let widened = _mm256_fmadd_ps(abs, _mm256_set1_ps(SLAB_SLACK), tf);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, widened)) as u32
    }};
}

/// A packet subtree with at most this many live lanes is finished ray by ray. 6 (was 4 until
/// the seventh session of 2026-12-02): −7 % fan-kernel instructions on the kit's dragon_19k A
/// rays, −9 % on bunny A, and on the Zen 4 VM faster on dragon_19k A on two threads (alternating
/// runs, docs/BENCHMARKS.md); bunny A and `bench bsv` unchanged within noise.
#[cfg(target_arch = "x86_64")]
pub(super) const SOLO_LANES: u32 = 6;

/// Any-hit for up to 8 rays from one origin, traversed together (AVX2 lanes = rays): each
/// child box is tested against every live lane, a subtree is entered by the lanes that hit
/// its box, and a lane leaves when a triangle occludes it; the packet stops when every lane
/// has. The triangle test is [`pack_hit`]'s operations lane by lane (unfused, so the answers
/// are bit-identical to the one-ray traversal); the box test is conservative like
/// [`box_mask`]. Returns the occluded lanes as bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
pub(super) unsafe fn packet_occluded(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    packet_body(w, o, dirs, tmin, tmax)
}

/// [`packet_occluded`] compiled with AVX-512 F, VL, BW and DQ as well.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
pub(super) unsafe fn packet_occluded_avx512(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    packet_body(w, o, dirs, tmin, tmax)
}

/// The packet kernel's code, inlined into [`packet_occluded`] and [`packet_occluded_avx512`]
/// (only into functions that enable AVX2, FMA, POPCNT, BMI1 and BMI2).
///
/// A hot kernel, kept as one body of ~165 lines on purpose: the traversal loop holds the packet's
/// slab vectors and lane masks in registers across the box test, the leaf test and the solo
/// hand-over, and every piece moved into a function of its own was either left out of line by
/// LLVM (25 % more instructions for the slab macro as a function, module doc) or had to pass
/// the register state through memory.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn packet_body(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    use std::arch::x86_64::*;
    let n = dirs.len().min(8);
    let valid = (1u32 << n) - 1;
    let (vdx, vdy, vdz) = if n == 8 {
        soa8(dirs)
    } else {
        // A short packet: the last direction fills the empty lanes.
        let (mut dx, mut dy, mut dz) = ([0f32; 8], [0f32; 8], [0f32; 8]);
        for i in 0..8 {
            let d = dirs[i.min(n - 1)];
            (dx[i], dy[i], dz[i]) = (d[0], d[1], d[2]);
        }
        (
            _mm256_loadu_ps(dx.as_ptr()),
            _mm256_loadu_ps(dy.as_ptr()),
            _mm256_loadu_ps(dz.as_ptr()),
        )
    };
    let (inv, linv, loi) = lane_slabs(o, [vdx, vdy, vdz]);
    let (vtmin, vtmax) = (_mm256_set1_ps(tmin), _mm256_set1_ps(tmax));
    // The whole packet against the root's children's boxes together first: a packet that
    // misses them all (a common case: fans see the object from outside) ends after one test.
    let root = |a: usize, k: usize| _mm256_mul_ps(_mm256_set1_ps(w.bounds[k][a] - o[a]), inv[a]);
    if lanes_entering!(root, vtmin, vtmax) & valid == 0 {
        return 0;
    }
    let mut occluded = 0u32;
    let need = w.stack_need();
    // The one-ray traversals below share one stack.
    let (mut fixed_solo, mut heap_solo) = (uninit_slots(), Vec::new());
    let mut solo = stack_slots(&mut fixed_solo, &mut heap_solo, need);
    let (mut fixed, mut heap) = (uninit_slots(), Vec::new());
    let mut stack = stack_slots(&mut fixed, &mut heap, need);
    let (mut fixed_masks, mut heap_masks) = (uninit_slots(), Vec::new());
    let mut masks = stack_slots(&mut fixed_masks, &mut heap_masks, need);
    stack.push(0);
    masks.push(valid);
    'outer: while let (Some(node_id), Some(m)) = (stack.pop(), masks.pop()) {
        let live = m & !occluded & valid;
        if live == 0 {
            continue;
        }
        if live.count_ones() <= SOLO_LANES {
            // Few lanes left in this subtree: one-ray traversals are cheaper than the packet's
            // 8-lane tests.
            let mut l = live;
            while l != 0 {
                let i = l.trailing_zeros() as usize;
                l &= l - 1;
                let ray = WideRay {
                    o,
                    d: dirs[i.min(n - 1)],
                    tmin,
                    tmax,
                };
                let pre = Prepared::lane(&linv, &loi, i);
                if w.traverse_prepared::<true, true>(&ray, &pre, node_id, &mut solo)
                    .is_some()
                {
                    occluded |= 1 << i;
                }
            }
            if occluded & valid == valid {
                break 'outer;
            }
            continue;
        }
        let node = &w.nodes[node_id as usize];
        // The planes relative to the common origin, for all 8 children at once.
        let mut rel = [[0f32; WIDTH]; 6];
        for (row, r) in rel.iter_mut().enumerate() {
            let v = _mm256_sub_ps(
                _mm256_loadu_ps(node.b[row].as_ptr()),
                _mm256_set1_ps(o[row % 3]),
            );
            _mm256_storeu_ps(r.as_mut_ptr(), v);
        }
        // Every child against every lane first (no branch), then the children some lane
        // enters.
        let mut hits = [0u32; WIDTH];
        let mut any = 0u32;
        for j in 0..WIDTH {
            let child =
                |a: usize, k: usize| _mm256_mul_ps(_mm256_set1_ps(rel[a + 3 * k][j]), inv[a]);
            hits[j] = lanes_entering!(child, vtmin, vtmax) & live;
            any |= u32::from(hits[j] != 0) << j;
        }
        // Empty slots: their inverted boxes become unbounded under the min/max of the lane
        // test, so they are masked out here.
        let empty = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_loadu_si256(node.child.as_ptr() as *const __m256i),
            _mm256_set1_epi32(-1),
        ))) as u32;
        any &= !empty;
        // Nearest boxes first (squared distance from the common origin to the box centre, for
        // all 8 children at once): occluded lanes then leave the packet sooner. Leaves are
        // tested in that order, inner nodes pushed farthest first.
        let mut key = [0f32; WIDTH];
        {
            let half = _mm256_set1_ps(0.5);
            let c = |a: usize| {
                let lo = _mm256_loadu_ps(rel[a].as_ptr());
                let hi = _mm256_loadu_ps(rel[a + 3].as_ptr());
                _mm256_mul_ps(_mm256_add_ps(lo, hi), half)
            };
            let (cx, cy, cz) = (c(0), c(1), c(2));
            let d2 = _mm256_fmadd_ps(cx, cx, _mm256_fmadd_ps(cy, cy, _mm256_mul_ps(cz, cz)));
            _mm256_storeu_ps(key.as_mut_ptr(), d2);
        }
        let mut order = [0usize; WIDTH];
        let mut k = 0;
        while any != 0 {
            let j = any.trailing_zeros() as usize;
            any &= any - 1;
            let mut i = k;
            while i > 0 && key[order[i - 1]] > key[j] {
                order[i] = order[i - 1];
                i -= 1;
            }
            order[i] = j;
            k += 1;
        }
        let mut inner = [(0u32, 0u32); WIDTH];
        let mut ni = 0;
        for &j in &order[..k] {
            let c = node.child[j];
            let lanes = hits[j] & !occluded;
            if lanes == 0 {
                continue;
            }
            if c & LEAF == 0 {
                inner[ni] = (c, lanes);
                ni += 1;
                continue;
            }
            let (first, count) = leaf_range(c);
            for (p, ids) in w.packs[first..first + count]
                .iter()
                .zip(&w.ids[first..first + count])
            {
                for k in 0..PACK {
                    if ids[k] == u32::MAX {
                        break; // padding lanes are at the end of a pack
                    }
                    occluded |= tri_lanes(p, k, o, vdx, vdy, vdz, vtmin, vtmax) & lanes;
                }
                if occluded & valid == valid {
                    break 'outer;
                }
            }
        }
        for &(c, lanes) in inner[..ni].iter().rev() {
            stack.push(c);
            masks.push(lanes);
        }
    }
    occluded & valid
}

/// The packet's slab data: the reciprocals of its 8 directions (`d`, lanes = rays) as vectors,
/// and per lane the reciprocals and `o·inv` for the one-ray traversals it hands subtrees to —
/// the values [`Prepared::new`] makes, with the same operations (bit-identical, tested), without
/// its three divisions per ray.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
#[inline]
#[allow(clippy::type_complexity)]
pub(super) unsafe fn lane_slabs(
    o: [f32; 3],
    d: [std::arch::x86_64::__m256; 3],
) -> ([std::arch::x86_64::__m256; 3], [[f32; 8]; 3], [[f32; 8]; 3]) {
    use std::arch::x86_64::*;
    let recip = |v: __m256| {
        // |d| < TINY_DIR → ±TINY_DIR (sign kept), then 1/d.
        let sign = _mm256_and_ps(v, _mm256_set1_ps(-0.0));
        let small = _mm256_cmp_ps::<_CMP_LT_OQ>(
            _mm256_andnot_ps(_mm256_set1_ps(-0.0), v),
            _mm256_set1_ps(TINY_DIR),
        );
        let fixed = _mm256_blendv_ps(v, _mm256_or_ps(sign, _mm256_set1_ps(TINY_DIR)), small);
        _mm256_div_ps(_mm256_set1_ps(1.0), fixed)
    };
    let inv = [recip(d[0]), recip(d[1]), recip(d[2])];
    let (mut linv, mut loi) = ([[0f32; 8]; 3], [[0f32; 8]; 3]);
    for a in 0..3 {
        _mm256_storeu_ps(linv[a].as_mut_ptr(), inv[a]);
        _mm256_storeu_ps(
            loi[a].as_mut_ptr(),
            _mm256_mul_ps(_mm256_set1_ps(o[a]), inv[a]),
        );
    }
    (inv, linv, loi)
}

/// Eight `[x, y, z]` directions (AoS, 96 bytes) as x, y and z vectors (lane i = `dirs[i]`):
/// three unaligned loads of two 16-byte halves each, then five shuffles — no round trip through
/// memory, whose 4-byte stores a 32-byte load could not forward.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1,bmi2")]
#[inline]
pub(super) unsafe fn soa8(
    dirs: &[[f32; 3]],
) -> (
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
) {
    use std::arch::x86_64::*;
    let f = dirs[..8].as_flattened();
    let p = f.as_ptr();
    // Halves: m03 = x0 y0 z0 x1 | x4 y4 z4 x5, m14 = y1 z1 x2 y2 | y5 z5 x6 y6,
    // m25 = z2 x3 y3 z3 | z6 x7 y7 z7.
    // SAFETY: `f` holds 24 floats; each load reads 4 of them at offsets ≤ 20.
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
    (x, y, z)
}

/// [`pack_hit`]'s test of triangle `k` of a pack against 8 rays from `o` (lanes), with the same
/// unfused operations in the same order: bit i set when ray i hits in `(tmin, tmax)`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1,bmi2")]
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn tri_lanes(
    p: &Pack,
    k: usize,
    o: [f32; 3],
    dx: std::arch::x86_64::__m256,
    dy: std::arch::x86_64::__m256,
    dz: std::arch::x86_64::__m256,
    tmin: std::arch::x86_64::__m256,
    tmax: std::arch::x86_64::__m256,
) -> u32 {
    use std::arch::x86_64::*;
    let b = _mm256_set1_ps;
    let (mul, sub, add) = (
        |a, c| _mm256_mul_ps(a, c),
        |a, c| _mm256_sub_ps(a, c),
        |a, c| _mm256_add_ps(a, c),
    );
    let (e1x, e1y, e1z) = (b(p.e1[0][k]), b(p.e1[1][k]), b(p.e1[2][k]));
    let (e2x, e2y, e2z) = (b(p.e2[0][k]), b(p.e2[1][k]), b(p.e2[2][k]));
    let px = sub(mul(dy, e2z), mul(dz, e2y));
    let py = sub(mul(dz, e2x), mul(dx, e2z));
    let pz = sub(mul(dx, e2y), mul(dy, e2x));
    let det = add(add(mul(e1x, px), mul(e1y, py)), mul(e1z, pz));
    let neg = b(-0.0);
    let sign = _mm256_and_ps(det, neg);
    let adet = _mm256_andnot_ps(neg, det);
    // s = o − v0 and q = s × e1 are the same for every lane.
    let (sx, sy, sz) = (o[0] - p.v0[0][k], o[1] - p.v0[1][k], o[2] - p.v0[2][k]);
    let (qx, qy, qz) = (
        sy * p.e1[2][k] - sz * p.e1[1][k],
        sz * p.e1[0][k] - sx * p.e1[2][k],
        sx * p.e1[1][k] - sy * p.e1[0][k],
    );
    let u = _mm256_xor_ps(
        add(add(mul(b(sx), px), mul(b(sy), py)), mul(b(sz), pz)),
        sign,
    );
    let v = _mm256_xor_ps(
        add(add(mul(dx, b(qx)), mul(dy, b(qy))), mul(dz, b(qz))),
        sign,
    );
    let t = _mm256_xor_ps(b(p.e2[0][k] * qx + p.e2[1][k] * qy + p.e2[2][k] * qz), sign);
    let zero = _mm256_setzero_ps();
    let ok = _mm256_and_ps(
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, zero),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero),
                _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero),
            ),
        ),
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LE_OQ>(add(u, v), adet),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(t, mul(tmin, adet)),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, mul(tmax, adet)),
            ),
        ),
    );
    _mm256_movemask_ps(ok) as u32
}

/// Möller–Trumbore on the pack's triangles, decided without a division: with
/// `det = e1 · (d × e2)`, the barycentric `u = s · p / det`, `v = d · q / det` and the distance
/// `t = e2 · q / det` are tested as their numerators with `det`'s sign moved onto them
/// (`u·sgn ≥ 0`, `v·sgn ≥ 0`, `(u + v)·sgn ≤ |det|`, `tmin·|det| < t·sgn < tmax·|det|`); the
/// one division, `t`, is made for accepted lanes only. Edges count as hits. `ANY`: the first
/// accepted lane `(t, lane)`; otherwise the nearest accepted lane with `t < tmax`; lane = PACK
/// when none.
#[inline(always)]
pub(super) fn pack_hit<const ANY: bool>(p: &Pack, ray: &WideRay, tmax: f32) -> (f32, usize) {
    let [dx, dy, dz] = ray.d;
    let mut num = [0.0f32; PACK];
    let mut den = [0.0f32; PACK];
    let mut ok = [false; PACK];
    for k in 0..PACK {
        let (e1x, e1y, e1z) = (p.e1[0][k], p.e1[1][k], p.e1[2][k]);
        let (e2x, e2y, e2z) = (p.e2[0][k], p.e2[1][k], p.e2[2][k]);
        // p = d × e2, det = e1 · p
        let px = dy * e2z - dz * e2y;
        let py = dz * e2x - dx * e2z;
        let pz = dx * e2y - dy * e2x;
        let det = e1x * px + e1y * py + e1z * pz;
        let sx = ray.o[0] - p.v0[0][k];
        let sy = ray.o[1] - p.v0[1][k];
        let sz = ray.o[2] - p.v0[2][k];
        let u = sx * px + sy * py + sz * pz;
        // q = s × e1
        let qx = sy * e1z - sz * e1y;
        let qy = sz * e1x - sx * e1z;
        let qz = sx * e1y - sy * e1x;
        let v = dx * qx + dy * qy + dz * qz;
        let tt = e2x * qx + e2y * qy + e2z * qz;
        let sign = det.to_bits() & 0x8000_0000;
        let flip = |x: f32| f32::from_bits(x.to_bits() ^ sign);
        let (u, v, tt, adet) = (flip(u), flip(v), flip(tt), det.abs());
        num[k] = tt;
        den[k] = adet;
        ok[k] = det != 0.0
            && u >= 0.0
            && v >= 0.0
            && u + v <= adet
            && tt > ray.tmin * adet
            && tt < tmax * adet;
    }
    let mut bits = 0u32;
    for (k, &ok) in ok.iter().enumerate() {
        bits |= u32::from(ok) << k;
    }
    let mut best = (tmax, PACK);
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let t = num[k] / den[k];
        if ANY {
            return (t, k);
        }
        if t < best.0 {
            best = (t, k);
        }
    }
    best
}
