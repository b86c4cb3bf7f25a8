//! The traversal kernels of the 8-wide BVH: any-hit and closest-hit for one ray, fans of rays
//! from one origin (packets of 8 rays on AVX2 / AVX-512), the slab and triangle tests, each
//! written once as lane-array code and instantiated per SIMD level (module doc of `wide`).

use super::lanes::*;
use super::layout::*;
use super::packet::*;
use super::prepared::*;
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
        self.fan_packets(o, dirs, tmin, tmax, hit, packet_occluded_portable)
    }

    /// The fan in packets of 8 consecutive directions (callers order fans coherently: the BSV
    /// sampler's hemisphere comes in 2×4 tiles of its grid), each answered by `packet`.
    #[inline(always)]
    pub(super) fn fan_packets(
        &self,
        o: [f32; 3],
        dirs: &[[f32; 3]],
        tmin: f32,
        tmax: f32,
        hit: &mut [bool],
        packet: impl Fn(&WideBvh, [f32; 3], &[[f32; 3]], f32, f32) -> u32,
    ) {
        for (d, h) in dirs.chunks(8).zip(hit.chunks_mut(8)) {
            let m = packet(self, o, d, tmin, tmax);
            for (i, h) in h.iter_mut().enumerate() {
                *h = m >> i & 1 == 1;
            }
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
        // SAFETY (the closure): this function enables the packet kernel's features.
        self.fan_packets(o, dirs, tmin, tmax, hit, |w, o, d, t0, t1| unsafe {
            packet_occluded_avx2(w, o, d, t0, t1)
        })
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
        // SAFETY (the closure): this function enables the packet kernel's features.
        self.fan_packets(o, dirs, tmin, tmax, hit, |w, o, d, t0, t1| unsafe {
            packet_occluded_avx512(w, o, d, t0, t1)
        })
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
            // `F` is true only in the AVX2 + FMA instantiations, where the `Avx2` form is sound.
            #[cfg(target_arch = "x86_64")]
            let mut mask = if F {
                box_mask::<Avx2>(node, pre, ray.tmin, tmax)
            } else {
                box_mask::<Portable>(node, pre, ray.tmin, tmax)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let mut mask = box_mask::<Portable>(node, pre, ray.tmin, tmax);
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

/// The slab test of one ray against a node's 8 boxes: bit j set when box j is entered for some
/// `t ∈ [tmin, tmax]`. In the [`Avx2`] form (only inside AVX2 + FMA functions) the plane
/// distances are fused multiply-adds; in the [`Portable`] form `near · inv − o·inv` unfused.
#[inline(always)]
pub(super) fn box_mask<V: Lanes>(node: &Node, pre: &Prepared, tmin: f32, tmax: f32) -> u32 {
    let mut tn = V::splat(tmin);
    let mut tf = V::splat(tmax);
    for a in 0..3 {
        let (near, far) = (&node.b[pre.near[a]], &node.b[pre.far[a]]);
        let (i, n) = (V::splat(pre.inv[a]), V::splat(-pre.oi[a]));
        tn = V::load(near).mul_add(i, n).max(tn);
        tf = V::load(far).mul_add(i, n).min(tf);
    }
    let slack = V::splat(-0.0).andnot(tf).mul_add(V::splat(SLAB_SLACK), tf);
    tn.le(slack).bits()
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
