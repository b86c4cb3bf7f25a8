//! The packet kernel: any-hit for up to 8 rays from one origin, traversed together, written once
//! over [`Lanes`] and instantiated per SIMD level — [`Avx2`] inside AVX2 + FMA and AVX-512
//! wrappers, [`Portable`] (two SSE2 or NEON vectors) everywhere else.

use super::lanes::*;
use super::layout::*;
use super::prepared::{stack_slots, uninit_slots, Prepared};

/// A packet subtree with at most this many live lanes is finished ray by ray. 6 (was 4 until
/// the seventh session of 2026-12-02): −7 % fan-kernel instructions on the kit's dragon_19k A
/// rays, −9 % on bunny A, and on the Zen 4 VM faster on dragon_19k A on two threads (alternating
/// runs, docs/BENCHMARKS.md); bunny A and `bench bsv` unchanged within noise.
pub(super) const SOLO_LANES: u32 = 6;

/// The packet's slab test of one box: `t(a, k)` is the distance vector to the box's lower
/// (`k = 0`) or upper (`k = 1`) plane on axis `a`, lanes = rays. Bit i is set when ray i enters
/// the box for some `t ∈ [tmin, tmax]`, with the exit distance widened by [`SLAB_SLACK`] like
/// `box_mask`'s (each axis takes the lesser and the greater plane distance, so the lanes' signs
/// may differ). `#[inline(always)]` and generic, so it is expanded inside the kernel (as a
/// `#[target_feature]` function LLVM left it out of line there, 25 % more instructions).
#[inline(always)]
fn lanes_entering<V: Lanes>(t: impl Fn(usize, usize) -> V, vtmin: V, vtmax: V) -> u32 {
    let (x0, x1) = (t(0, 0), t(0, 1));
    let (y0, y1) = (t(1, 0), t(1, 1));
    let (z0, z1) = (t(2, 0), t(2, 1));
    let tn = x0.min(x1).max(y0.min(y1)).max(z0.min(z1).max(vtmin));
    let tf = x0.max(x1).min(y0.max(y1)).min(z0.max(z1).min(vtmax));
    let abs = V::splat(-0.0).andnot(tf);
    let widened = abs.mul_add(V::splat(SLAB_SLACK), tf);
    tn.le(widened).bits()
}

/// Any-hit for up to 8 rays from one origin, traversed together (lanes = rays): each child box
/// is tested against every live lane, a subtree is entered by the lanes that hit its box, and a
/// lane leaves when a triangle occludes it; the packet stops when every lane has. The triangle
/// test is `pack_hit`'s operations lane by lane (unfused, so the answers are bit-identical to
/// the one-ray traversal); the box test is conservative like `box_mask`. Returns the occluded
/// lanes as bits. `F`: the level has FMA (the one-ray hand-over's box test uses it).
///
/// A hot kernel, kept as one body of ~150 lines on purpose: the traversal loop holds the packet's
/// slab vectors and lane masks in registers across the box test, the leaf test and the solo
/// hand-over, and every piece moved into a function of its own was either left out of line by
/// LLVM (25 % more instructions for the slab test as a `#[target_feature]` function) or had to
/// pass the register state through memory.
#[inline(always)]
pub(super) fn packet_body<V: Lanes, const F: bool>(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    let n = dirs.len().min(8);
    let valid = (1u32 << n) - 1;
    let [vdx, vdy, vdz] = if n == 8 {
        V::soa8(dirs)
    } else {
        // A short packet: the last direction fills the empty lanes.
        let (mut dx, mut dy, mut dz) = ([0f32; 8], [0f32; 8], [0f32; 8]);
        for i in 0..8 {
            let d = dirs[i.min(n - 1)];
            (dx[i], dy[i], dz[i]) = (d[0], d[1], d[2]);
        }
        [V::load(&dx), V::load(&dy), V::load(&dz)]
    };
    let (inv, linv, loi) = lane_slabs(o, [vdx, vdy, vdz]);
    let (vtmin, vtmax) = (V::splat(tmin), V::splat(tmax));
    // The whole packet against the root's children's boxes together first: a packet that
    // misses them all (a common case: fans see the object from outside) ends after one test.
    let root = |a: usize, k: usize| V::splat(w.bounds[k][a] - o[a]).mul(inv[a]);
    if lanes_entering(root, vtmin, vtmax) & valid == 0 {
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
                if w.traverse_prepared::<true, F>(&ray, &pre, node_id, &mut solo)
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
            V::load(&node.b[row]).sub(V::splat(o[row % 3])).store(r);
        }
        // Every child against every lane first (no branch), then the children some lane
        // enters.
        let mut hits = [0u32; WIDTH];
        let mut any = 0u32;
        for j in 0..WIDTH {
            let child = |a: usize, k: usize| V::splat(rel[a + 3 * k][j]).mul(inv[a]);
            hits[j] = lanes_entering(child, vtmin, vtmax) & live;
            any |= u32::from(hits[j] != 0) << j;
        }
        // Empty slots: their inverted boxes become unbounded under the min/max of the lane
        // test, so they are masked out here.
        any &= !V::empty_slots(&node.child);
        // Nearest boxes first (squared distance from the common origin to the box centre, for
        // all 8 children at once): occluded lanes then leave the packet sooner. Leaves are
        // tested in that order, inner nodes pushed farthest first.
        let mut key = [0f32; WIDTH];
        {
            let half = V::splat(0.5);
            let c = |a: usize| V::load(&rel[a]).add(V::load(&rel[a + 3])).mul(half);
            let (cx, cy, cz) = (c(0), c(1), c(2));
            cx.mul_add(cx, cy.mul_add(cy, cz.mul(cz))).store(&mut key);
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
                    occluded |= tri_lanes(p, k, o, [vdx, vdy, vdz], vtmin, vtmax) & lanes;
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

/// The packet's slab data: the reciprocals of its 8 directions (`d`, lanes = rays) as lanes,
/// and per lane the reciprocals and `o·inv` for the one-ray traversals it hands subtrees to —
/// the values `Prepared::new` makes, with the same operations (bit-identical, tested), without
/// its three divisions per ray.
#[inline(always)]
#[allow(clippy::type_complexity)]
pub(super) fn lane_slabs<V: Lanes>(
    o: [f32; 3],
    d: [V; 3],
) -> ([V; 3], [[f32; 8]; 3], [[f32; 8]; 3]) {
    let inv = [d[0].recip_dir(), d[1].recip_dir(), d[2].recip_dir()];
    let (mut linv, mut loi) = ([[0f32; 8]; 3], [[0f32; 8]; 3]);
    for a in 0..3 {
        inv[a].store(&mut linv[a]);
        V::splat(o[a]).mul(inv[a]).store(&mut loi[a]);
    }
    (inv, linv, loi)
}

/// `pack_hit`'s test of triangle `k` of a pack against 8 rays from `o` (lanes), with the same
/// unfused operations in the same order: bit i set when ray i hits in `(tmin, tmax)`.
#[inline(always)]
pub(super) fn tri_lanes<V: Lanes>(
    p: &Pack,
    k: usize,
    o: [f32; 3],
    [dx, dy, dz]: [V; 3],
    tmin: V,
    tmax: V,
) -> u32 {
    let b = V::splat;
    let (e1x, e1y, e1z) = (b(p.e1[0][k]), b(p.e1[1][k]), b(p.e1[2][k]));
    let (e2x, e2y, e2z) = (b(p.e2[0][k]), b(p.e2[1][k]), b(p.e2[2][k]));
    let px = dy.mul(e2z).sub(dz.mul(e2y));
    let py = dz.mul(e2x).sub(dx.mul(e2z));
    let pz = dx.mul(e2y).sub(dy.mul(e2x));
    let det = e1x.mul(px).add(e1y.mul(py)).add(e1z.mul(pz));
    let neg = b(-0.0);
    let sign = det.and(neg);
    let adet = neg.andnot(det);
    // s = o − v0 and q = s × e1 are the same for every lane.
    let (sx, sy, sz) = (o[0] - p.v0[0][k], o[1] - p.v0[1][k], o[2] - p.v0[2][k]);
    let (qx, qy, qz) = (
        sy * p.e1[2][k] - sz * p.e1[1][k],
        sz * p.e1[0][k] - sx * p.e1[2][k],
        sx * p.e1[1][k] - sy * p.e1[0][k],
    );
    let u = b(sx)
        .mul(px)
        .add(b(sy).mul(py))
        .add(b(sz).mul(pz))
        .xor(sign);
    let v = dx
        .mul(b(qx))
        .add(dy.mul(b(qy)))
        .add(dz.mul(b(qz)))
        .xor(sign);
    let t = b(p.e2[0][k] * qx + p.e2[1][k] * qy + p.e2[2][k] * qz).xor(sign);
    let zero = b(0.0);
    let ok = det.ne(zero).and(u.ge(zero).and(v.ge(zero))).and(
        u.add(v)
            .le(adet)
            .and(t.gt(tmin.mul(adet)).and(t.lt(tmax.mul(adet)))),
    );
    ok.bits()
}

/// Any-hit for up to 8 rays from one origin at the AVX2 + FMA level ([`packet_body`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
pub(super) unsafe fn packet_occluded_avx2(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    packet_body::<Avx2, true>(w, o, dirs, tmin, tmax)
}

/// [`packet_occluded_avx2`] compiled with AVX-512 F, VL, BW and DQ as well.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
pub(super) unsafe fn packet_occluded_avx512(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    packet_body::<Avx2, true>(w, o, dirs, tmin, tmax)
}

/// [`packet_body`] at the target's default features (no FMA in the box tests).
pub(super) fn packet_occluded_portable(
    w: &WideBvh,
    o: [f32; 3],
    dirs: &[[f32; 3]],
    tmin: f32,
    tmax: f32,
) -> u32 {
    packet_body::<Portable, false>(w, o, dirs, tmin, tmax)
}
