//! The production traversal: an 8-wide BVH over packs of 8 triangles, in f32, traversed with one
//! SIMD box test per node (8 children at once) and one SIMD triangle test per pack (8 at once).
//! Packs of 8 (one AVX2 vector per coordinate) replaced packs of 4 on 2026-12-02: fewer, fuller
//! leaves (dragon_19k: 3,958 packs of 4.7 triangles against 7,011 of 2.7) for the same
//! instructions per test; +8 % rays per second on the kit's four workloads (median of 12
//! alternating rounds, −2 to +18 %; docs/BENCHMARKS.md).
//!
//! The tree comes from obvhs (a binary PLOC build with one triangle per leaf,
//! `BvhBuildParams::fast_build` in `MeshBvh::build`), collapsed here by the optimal
//! dynamic-programming collapse of Ylitie et al. (2017) under the surface-area heuristic: for
//! every binary node and every number of child slots 1–8, the least expected cost of spreading
//! its subtree over that many slots, where a leaf of `n ≤ 16` triangles costs `⌈n / 8⌉` pack
//! tests and an inner node one 8-box test, each weighted by its box's area. Nodes are stored
//! parents first, so a refit (same topology, moved vertices) is one reverse sweep.
//!
//! **Exactness.** Boxes are padded by [`BOX_PAD`] (unit-frame units, ~17 f32 ulps at 1) and the
//! slab test's exit distance is widened by a relative [`SLAB_SLACK`], so rounding in the box test
//! never loses a hit that the triangle test accepts: the answers are those of the f32
//! Möller–Trumbore test on every triangle (decided without a division, `pack_hit`; the one-ray
//! and packet kernels perform the same operations, so their answers are bit-identical; tested
//! against a scan of every pack and against brute force). Zero direction components are
//! replaced by ±[`TINY_DIR`] in the box test only (no NaN from `0 · ∞`).
//!
//! **Kernels.** Written once as `#[inline(always)]` lane-array code and instantiated for AVX2 and
//! FMA, for AVX2 and FMA with AVX-512 F/VL/BW/DQ as well (the same code and operations,
//! EVEX-encoded, 32 vector registers), both chosen at run time, and for the target's default
//! features (`shscale_sh::simd`). The packet kernel's body is inlined into one wrapper per
//! level (`packet_occluded`, `packet_occluded_avx512`); the smaller AVX2 intrinsic helpers
//! (`box_mask_avx2`, `lane_slabs`, `soa8`, `tri_lanes`) keep their AVX2 feature set and are
//! inlined where LLVM chooses — into an AVX-512 function they compile with AVX-512 enabled (a
//! helper left out of line runs its AVX2 code).

use obvhs::bvh2::Bvh2;
use obvhs::triangle::Triangle;
use shscale_sh::simd::Level;

/// Triangles per leaf pack (the SIMD width of the triangle test).
pub const PACK: usize = 8;
/// Children per node (the SIMD width of the box test).
pub const WIDTH: usize = 8;
/// Absolute box padding in the unit frame.
pub const BOX_PAD: f32 = 2e-6;
/// Relative widening of a box's exit distance.
pub const SLAB_SLACK: f32 = 1e-6;
/// Replacement for a zero direction component in the box test.
pub const TINY_DIR: f32 = 1e-20;

const LEAF: u32 = 1 << 31;
const EMPTY: u32 = u32::MAX;
const COUNT_SHIFT: u32 = 24;
/// The most packs one leaf child refers to.
pub const MAX_LEAF_PACKS: usize = 127;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Node {
    /// Rows 0–2: the boxes' minima in x, y, z; rows 3–5: their maxima.
    b: [[f32; WIDTH]; 6],
    /// Inner node index, `LEAF | (packs − 1) << 24 | first pack`, or `EMPTY`.
    child: [u32; WIDTH],
}

impl Node {
    fn empty() -> Self {
        Self {
            b: [
                [f32::INFINITY; WIDTH],
                [f32::INFINITY; WIDTH],
                [f32::INFINITY; WIDTH],
                [f32::NEG_INFINITY; WIDTH],
                [f32::NEG_INFINITY; WIDTH],
                [f32::NEG_INFINITY; WIDTH],
            ],
            child: [EMPTY; WIDTH],
        }
    }
    fn set_box(&mut self, j: usize, lo: [f32; 3], hi: [f32; 3]) {
        for a in 0..3 {
            self.b[a][j] = lo[a] - BOX_PAD;
            self.b[a + 3][j] = hi[a] + BOX_PAD;
        }
    }
}

/// Up to [`PACK`] triangles as `v0`, `e1 = v1 − v0`, `e2 = v2 − v0`, lane-major (padding lanes
/// are zero: their determinant is 0 and they never hit).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Pack {
    v0: [[f32; PACK]; 3],
    e1: [[f32; PACK]; 3],
    e2: [[f32; PACK]; 3],
}

/// A ray in the unit frame, prepared for the box test.
#[derive(Clone, Copy, Debug)]
pub struct WideRay {
    pub o: [f32; 3],
    pub d: [f32; 3],
    pub tmin: f32,
    pub tmax: f32,
}

/// The shape of a [`WideBvh`] (`bench rays` and `bench bsv` report it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeStats {
    /// Wide nodes (the root included).
    pub nodes: usize,
    /// Leaf children (each one to [`MAX_LEAF_PACKS`] packs).
    pub leaves: usize,
    /// Packs of up to [`PACK`] triangles.
    pub packs: usize,
    /// Triangles in the packs.
    pub triangles: usize,
    /// Deepest node level (root = 1).
    pub depth: usize,
}

/// The 8-wide BVH.
#[derive(Clone, Debug)]
pub struct WideBvh {
    nodes: Vec<Node>,
    packs: Vec<Pack>,
    /// The triangle index of every pack lane (`u32::MAX` for padding).
    ids: Vec<[u32; PACK]>,
    /// Deepest node level (root = 1), which bounds the traversal stack.
    depth: usize,
    /// The root's children's (padded) boxes together, `[minima, maxima]`: the packets' first,
    /// cheap test, conservative like the children's (for an empty tree it is inverted and lets
    /// every lane through to the root's own test, which rejects them).
    bounds: [[f32; 3]; 2],
}

fn tri_bounds(t: &Triangle) -> ([f32; 3], [f32; 3]) {
    let lo = t.v0.min(t.v1).min(t.v2);
    let hi = t.v0.max(t.v1).max(t.v2);
    (lo.to_array(), hi.to_array())
}

fn pack_of(tris: &[Triangle], ids: &[u32; PACK]) -> Pack {
    let mut p = Pack::default();
    for (lane, &id) in ids.iter().enumerate() {
        if id == u32::MAX {
            continue;
        }
        let t = &tris[id as usize];
        let (e1, e2) = (t.v1 - t.v0, t.v2 - t.v0);
        for a in 0..3 {
            p.v0[a][lane] = t.v0[a];
            p.e1[a][lane] = e1[a];
            p.e2[a][lane] = e2[a];
        }
    }
    p
}

/// The collapse's cost model (surface-area heuristic, in units of one 8-box node test): a
/// pack test (8 triangles at once) costs about as much as a node test. Pack costs of 0.7, 1.5
/// and 2 and leaves of at most 8 or 32 triangles were timed too, alternating with these on the
/// kit's four workloads: no difference outside the noise.
const COST_NODE: f32 = 1.0;
const COST_PACK: f32 = 1.0;
/// The most triangles the collapse puts in one leaf (as `⌈n / PACK⌉` packs).
const LEAF_MAX: u32 = 16;

struct Builder<'a> {
    bvh2: &'a Bvh2,
    tris: &'a [Triangle],
    /// Triangles under each binary node.
    counts: Vec<u32>,
    /// Per binary node and `i = 1..=8`: the least cost of the subtree spread over at most `i`
    /// child slots of a wide node (`cost[n][i - 1]`), and how: 0 = the node itself as one
    /// child, `k > 0` = `k` slots for its left subtree and `i − k` for its right.
    cost: Vec<[f32; WIDTH]>,
    split: Vec<[u8; WIDTH]>,
    /// For a node that becomes a wide node: its left subtree's share of the 8 slots.
    wide_split: Vec<u8>,
    /// Scratch for a leaf's triangle indices.
    prims: Vec<u32>,
    /// Whether the node, as one child, is a leaf (else a wide node of its own).
    as_leaf: Vec<bool>,
    out: WideBvh,
}

impl<'a> Builder<'a> {
    fn new(bvh2: &'a Bvh2, tris: &'a [Triangle]) -> Self {
        let n = bvh2.nodes.len();
        Builder {
            bvh2,
            tris,
            counts: vec![0; n],
            cost: vec![[0.0; WIDTH]; n],
            split: vec![[0; WIDTH]; n],
            wide_split: vec![0; n],
            prims: Vec::new(),
            as_leaf: vec![false; n],
            out: WideBvh {
                nodes: Vec::new(),
                packs: Vec::new(),
                ids: Vec::new(),
                depth: 1,
                bounds: [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]],
            },
        }
    }

    /// Counts, costs and choices bottom-up (the optimal collapse of a binary tree into a wide
    /// one under the cost model, by dynamic programming over the child slots).
    fn plan(&mut self, n: usize) {
        let node = &self.bvh2.nodes[n];
        let area = node.aabb().half_area().max(0.0);
        let packs = |c: u32| c.div_ceil(PACK as u32) as f32;
        if node.is_leaf() {
            let c = node.prim_count;
            self.counts[n] = c;
            self.cost[n] = [area * COST_PACK * packs(c); WIDTH];
            self.as_leaf[n] = true;
            return;
        }
        let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
        self.plan(l);
        self.plan(r);
        let c = self.counts[l] + self.counts[r];
        self.counts[n] = c;
        // spread[i]: the least cost of `i` slots shared by both subtrees (each taking ≥ 1),
        // the left one's share in `share[i]` (the first of equal costs).
        let (cl, cr) = (self.cost[l], self.cost[r]);
        let mut spread = [f32::INFINITY; WIDTH + 1];
        let mut share = [0u8; WIDTH + 1];
        for a in 1..WIDTH {
            for b in 1..=WIDTH - a {
                let cost = cl[a - 1] + cr[b - 1];
                if cost < spread[a + b] {
                    spread[a + b] = cost;
                    share[a + b] = a as u8;
                }
            }
        }
        let leaf = if c <= LEAF_MAX {
            area * COST_PACK * packs(c)
        } else {
            f32::INFINITY
        };
        let inner = area * COST_NODE + spread[WIDTH];
        self.as_leaf[n] = leaf <= inner;
        self.wide_split[n] = share[WIDTH];
        let (cost, split) = (&mut self.cost[n], &mut self.split[n]);
        cost[0] = leaf.min(inner);
        split[0] = 0;
        for i in 2..=WIDTH {
            if spread[i] < cost[i - 2] {
                cost[i - 1] = spread[i];
                split[i - 1] = share[i];
            } else {
                cost[i - 1] = cost[i - 2];
                split[i - 1] = split[i - 2];
            }
        }
    }

    /// The children of a wide node for binary node `n` spread over at most `i` slots.
    fn children(&self, n: usize, i: usize, into: &mut ([usize; WIDTH], usize)) {
        let k = self.split[n][i - 1] as usize;
        if k == 0 {
            into.0[into.1] = n;
            into.1 += 1;
        } else {
            let l = self.bvh2.nodes[n].first_index as usize;
            self.children(l, k, into);
            self.children(l + 1, i - k, into);
        }
    }

    fn gather(&self, n: usize, into: &mut Vec<u32>) {
        let node = &self.bvh2.nodes[n];
        if node.is_leaf() {
            let f = node.first_index as usize;
            into.extend_from_slice(&self.bvh2.primitive_indices[f..f + node.prim_count as usize]);
        } else {
            let l = node.first_index as usize;
            self.gather(l, into);
            self.gather(l + 1, into);
        }
    }

    /// A leaf reference for the triangles under binary node `n`.
    fn leaf(&mut self, n: usize) -> u32 {
        let mut prims = std::mem::take(&mut self.prims);
        prims.clear();
        self.gather(n, &mut prims);
        let first = self.out.packs.len();
        for chunk in prims.chunks(PACK) {
            let mut ids = [u32::MAX; PACK];
            ids[..chunk.len()].copy_from_slice(chunk);
            self.out.packs.push(pack_of(self.tris, &ids));
            self.out.ids.push(ids);
        }
        self.prims = prims;
        let count = self.out.packs.len() - first;
        debug_assert!((1..=MAX_LEAF_PACKS).contains(&count) && first < FIRST_MASK as usize);
        LEAF | ((count as u32 - 1) << COUNT_SHIFT) | first as u32
    }

    /// Emit a wide node for binary inner node `n`; returns its index.
    fn inner(&mut self, n: usize, level: usize) -> u32 {
        self.out.depth = self.out.depth.max(level);
        let l = self.bvh2.nodes[n].first_index as usize;
        let k = self.wide_split[n] as usize;
        let mut kids = ([0usize; WIDTH], 0);
        self.children(l, k, &mut kids);
        self.children(l + 1, WIDTH - k, &mut kids);
        let me = self.out.nodes.len();
        self.out.nodes.push(Node::empty());
        for (j, &k) in kids.0[..kids.1].iter().enumerate() {
            let r = if self.as_leaf[k] {
                self.leaf(k)
            } else {
                self.inner(k, level + 1)
            };
            self.out.nodes[me].child[j] = r;
        }
        me as u32
    }
}

impl WideBvh {
    /// Collapse a binary BVH over `tris` (the triangles it was built from).
    pub fn from_bvh2(bvh2: &Bvh2, tris: &[Triangle]) -> Self {
        let mut b = Builder::new(bvh2, tris);
        if tris.is_empty() || bvh2.nodes.is_empty() {
            b.out.nodes.push(Node::empty());
            return b.out;
        }
        b.plan(0);
        if b.as_leaf[0] && b.counts[0] as usize <= PACK * MAX_LEAF_PACKS {
            let r = b.leaf(0);
            let mut root = Node::empty();
            root.child[0] = r;
            b.out.nodes.push(root);
        } else {
            b.inner(0, 1);
        }
        let mut w = b.out;
        w.refit_boxes(tris);
        w
    }

    /// Follow moved vertices (same triangles, same tree): new packs, then boxes bottom-up.
    pub fn refit(&mut self, tris: &[Triangle]) {
        for (p, ids) in self.packs.iter_mut().zip(&self.ids) {
            *p = pack_of(tris, ids);
        }
        self.refit_boxes(tris);
    }

    fn refit_boxes(&mut self, tris: &[Triangle]) {
        // Children have larger indices than their parents: a reverse sweep sees them first.
        for n in (0..self.nodes.len()).rev() {
            for j in 0..WIDTH {
                let c = self.nodes[n].child[j];
                if c == EMPTY {
                    continue;
                }
                let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
                if c & LEAF != 0 {
                    let (first, count) = leaf_range(c);
                    for ids in &self.ids[first..first + count] {
                        for &id in ids.iter().filter(|&&id| id != u32::MAX) {
                            let (a, b) = tri_bounds(&tris[id as usize]);
                            for k in 0..3 {
                                lo[k] = lo[k].min(a[k]);
                                hi[k] = hi[k].max(b[k]);
                            }
                        }
                    }
                } else {
                    let child = &self.nodes[c as usize];
                    for i in 0..WIDTH {
                        if child.child[i] == EMPTY {
                            continue;
                        }
                        for k in 0..3 {
                            lo[k] = lo[k].min(child.b[k][i] + BOX_PAD);
                            hi[k] = hi[k].max(child.b[k + 3][i] - BOX_PAD);
                        }
                    }
                }
                self.nodes[n].set_box(j, lo, hi);
            }
        }
        let root = &self.nodes[0];
        let mut bounds = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        for j in (0..WIDTH).filter(|&j| root.child[j] != EMPTY) {
            for a in 0..3 {
                bounds[0][a] = bounds[0][a].min(root.b[a][j]);
                bounds[1][a] = bounds[1][a].max(root.b[a + 3][j]);
            }
        }
        self.bounds = bounds;
    }

    /// The summed surface area of every child box over the root's box (the surface-area
    /// heuristic's expected number of boxes a random ray line enters, for a tree of this
    /// shape): 1 for a single leaf, larger as boxes overlap and grow. The padding is left out.
    pub fn relative_area(&self) -> f64 {
        let area = |lo: [f32; 3], hi: [f32; 3]| {
            let e = [0, 1, 2].map(|a| ((hi[a] - lo[a]) as f64 - 2.0 * BOX_PAD as f64).max(0.0));
            2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
        };
        let mut total = 0.0;
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for (i, n) in self.nodes.iter().enumerate() {
            for j in 0..WIDTH {
                if n.child[j] == EMPTY {
                    continue;
                }
                let b = |r: usize| n.b[r][j];
                let (l, h) = ([b(0), b(1), b(2)], [b(3), b(4), b(5)]);
                total += area(l, h);
                if i == 0 {
                    for a in 0..3 {
                        lo[a] = lo[a].min(l[a]);
                        hi[a] = hi[a].max(h[a]);
                    }
                }
            }
        }
        let root = area(lo, hi);
        if root > 0.0 {
            total / root
        } else {
            1.0
        }
    }

    /// The tree's shape (for reports and tests).
    pub fn stats(&self) -> TreeStats {
        TreeStats {
            nodes: self.nodes.len(),
            leaves: self
                .nodes
                .iter()
                .flat_map(|n| n.child)
                .filter(|&c| c != EMPTY && c & LEAF != 0)
                .count(),
            packs: self.packs.len(),
            triangles: self
                .ids
                .iter()
                .flatten()
                .filter(|&&i| i != u32::MAX)
                .count(),
            depth: self.depth,
        }
    }

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
    fn fan<const F: bool>(
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
    unsafe fn fan_avx2(
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
    unsafe fn fan_avx512(
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
    unsafe fn fan_packets<const AVX512: bool>(
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
    unsafe fn occluded_avx2(&self, ray: &WideRay) -> bool {
        self.traverse::<true, true>(ray).is_some()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
    unsafe fn closest_avx2(&self, ray: &WideRay) -> Option<(f32, u32)> {
        self.traverse::<false, true>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
    unsafe fn occluded_avx512(&self, ray: &WideRay) -> bool {
        self.traverse::<true, true>(ray).is_some()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
    unsafe fn closest_avx512(&self, ray: &WideRay) -> Option<(f32, u32)> {
        self.traverse::<false, true>(ray)
    }

    /// The most entries a traversal stack holds: at each of the tree's levels at most 7 of a
    /// node's 8 children are pushed (the eighth is visited next), plus one.
    fn stack_need(&self) -> usize {
        self.depth * (WIDTH - 1) + 1
    }

    /// Stack traversal; `ANY`: stop at the first hit (the returned hit is then some hit, not
    /// the nearest); `F`: fused multiply-adds in the box test.
    #[inline(always)]
    fn traverse<const ANY: bool, const F: bool>(&self, ray: &WideRay) -> Option<(f32, u32)> {
        let pre = Prepared::new(ray);
        let (mut fixed, mut heap) = (uninit_slots(), Vec::new());
        let mut stack = stack_slots(&mut fixed, &mut heap, self.stack_need());
        self.traverse_prepared::<ANY, F>(ray, &pre, 0, &mut stack)
    }

    /// [`WideBvh::traverse`] of the subtree under node `start`, with the ray's slab data
    /// prepared and a stack given (the packet kernel's one-ray traversals share one; it is
    /// emptied here, since a traversal that ends at a hit leaves entries behind).
    #[inline(always)]
    fn traverse_prepared<const ANY: bool, const F: bool>(
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

fn leaf_range(c: u32) -> (usize, usize) {
    (
        (c & FIRST_MASK) as usize,
        (((c & !LEAF) >> COUNT_SHIFT) + 1) as usize,
    )
}

/// Slots on the call stack for a traversal stack; trees deeper than ~36 levels take a heap
/// buffer instead ([`stack_slots`]).
const FIXED_SLOTS: usize = 256;

/// The slots of a traversal stack of at most `need` entries: the fixed array (not initialised:
/// only pushed slots are read) or, when it is too small, `heap`, sized once here.
#[inline(always)]
fn stack_slots<'a>(
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
struct Stack<'a> {
    slots: &'a mut [std::mem::MaybeUninit<u32>],
    len: usize,
}

impl Stack<'_> {
    #[inline(always)]
    fn push(&mut self, v: u32) {
        // Checked: the slots are sized for the tree's depth, so this never fails.
        self.slots[self.len].write(v);
        self.len += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
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
fn uninit_slots() -> [std::mem::MaybeUninit<u32>; FIXED_SLOTS] {
    // SAFETY: an array of `MaybeUninit` needs no initialisation.
    unsafe { std::mem::MaybeUninit::uninit().assume_init() }
}

/// A ray prepared for the slab tests: reciprocal direction, `o·inv`, and for each axis the
/// node rows of the near and far planes (chosen once per ray, so the box test has no branch).
struct Prepared {
    inv: [f32; 3],
    oi: [f32; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl Prepared {
    #[inline(always)]
    fn new(ray: &WideRay) -> Self {
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
    fn lane(inv: &[[f32; 8]; 3], oi: &[[f32; 8]; 3], i: usize) -> Self {
        Self::with(
            [inv[0][i], inv[1][i], inv[2][i]],
            [oi[0][i], oi[1][i], oi[2][i]],
        )
    }

    #[inline(always)]
    fn with(inv: [f32; 3], oi: [f32; 3]) -> Self {
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
fn box_mask<const F: bool>(node: &Node, pre: &Prepared, tmin: f32, tmax: f32) -> u32 {
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
unsafe fn box_mask_avx2(node: &Node, pre: &Prepared, tmin: f32, tmax: f32) -> u32 {
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
const SOLO_LANES: u32 = 6;

/// Any-hit for up to 8 rays from one origin, traversed together (AVX2 lanes = rays): each
/// child box is tested against every live lane, a subtree is entered by the lanes that hit
/// its box, and a lane leaves when a triangle occludes it; the packet stops when every lane
/// has. The triangle test is [`pack_hit`]'s operations lane by lane (unfused, so the answers
/// are bit-identical to the one-ray traversal); the box test is conservative like
/// [`box_mask`]. Returns the occluded lanes as bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
unsafe fn packet_occluded(
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
unsafe fn packet_occluded_avx512(
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
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn packet_body(w: &WideBvh, o: [f32; 3], dirs: &[[f32; 3]], tmin: f32, tmax: f32) -> u32 {
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
unsafe fn lane_slabs(
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
unsafe fn soa8(
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
unsafe fn tri_lanes(
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
fn pack_hit<const ANY: bool>(p: &Pack, ray: &WideRay, tmax: f32) -> (f32, usize) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::bvh2::builder::build_bvh2_from_tris;
    use obvhs::BvhBuildParams;

    /// Every pack, no tree: what the traversal must reproduce exactly.
    fn scan(w: &WideBvh, ray: &WideRay) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        for (p, ids) in w.packs.iter().zip(&w.ids) {
            let (t, lane) = pack_hit::<false>(p, ray, best.map_or(ray.tmax, |b| b.0));
            if lane < PACK {
                best = Some((t, ids[lane]));
            }
        }
        best
    }

    struct Rng(u64);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn dir(&mut self) -> [f32; 3] {
            let z = 2.0 * self.f() - 1.0;
            let p = std::f32::consts::TAU * self.f();
            let s = (1.0 - z * z).max(0.0).sqrt();
            [s * p.cos(), s * p.sin(), z]
        }
    }

    fn tris(n: usize, rng: &mut Rng) -> Vec<Triangle> {
        // Small triangles scattered in the unit ball, plus a few large ones.
        (0..n)
            .map(|i| {
                let c = rng.dir().map(|v| v * 0.9 * rng.f());
                let s = if i % 50 == 0 { 0.5 } else { 0.05 };
                let mut v = [[0f32; 3]; 3];
                for p in &mut v {
                    let d = rng.dir();
                    *p = [c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2]];
                }
                Triangle {
                    v0: v[0].into(),
                    v1: v[1].into(),
                    v2: v[2].into(),
                }
            })
            .collect()
    }

    /// A tree too deep for the fixed stack slots: a binary "caterpillar" (every inner node has
    /// one leaf and one inner child): a wide level takes at most 7 of its binary levels, only
    /// the last leaf more. The heap-backed stack gives the same answers as the scan, one ray
    /// and fans.
    #[test]
    fn deep_trees_use_the_heap_stack() {
        use obvhs::{aabb::Aabb, bvh2::node::Bvh2Node};
        let n = 300;
        let t: Vec<Triangle> = (0..n)
            .map(|k| {
                let x = 0.99f32.powi(k as i32);
                let h = 0.002;
                Triangle {
                    v0: glam::Vec3A::new(x, -h, -h),
                    v1: glam::Vec3A::new(x, h, -h),
                    v2: glam::Vec3A::new(x, 0.0, h),
                }
            })
            .collect();
        // Node 0 is the root; inner node 2k has children 2k + 1 (the leaf of triangle k) and
        // 2k + 2 (the rest of the chain); the last node is the leaf of the last triangle.
        let span = |k: usize| {
            t[k..]
                .iter()
                .fold(t[k].aabb(), |b: Aabb, tri| b.union(&tri.aabb()))
        };
        let mut nodes = Vec::new();
        for k in 0..n - 1 {
            nodes.push(Bvh2Node::new(span(k), 0, 2 * k as u32 + 1));
            nodes.push(Bvh2Node::new(t[k].aabb(), 1, k as u32));
        }
        nodes.push(Bvh2Node::new(t[n - 1].aabb(), 1, n as u32 - 1));
        let bvh2 = Bvh2 {
            nodes,
            primitive_indices: (0..n as u32).collect(),
            ..Bvh2::default()
        };
        let w = WideBvh::from_bvh2(&bvh2, &t);
        let depth = w.stats().depth;
        println!("chain of {n} triangles: wide depth {depth}");
        assert!(
            w.stack_need() > FIXED_SLOTS,
            "depth {depth}: not deep enough"
        );
        let levels = shscale_sh::simd::supported();
        // A fan across the chain through every third triangle, then rays along its axis
        // from beyond each end.
        let o = [0.0, 0.0, -1.0];
        let mut dirs = Vec::new();
        let mut hits = 0;
        for k in (0..n).step_by(3) {
            let x = 0.99f32.powi(k as i32);
            let d = [x, 0.0, 1.0];
            let n = (d[0] * d[0] + 1.0f32).sqrt();
            dirs.push([d[0] / n, 0.0, 1.0 / n]);
        }
        for &l in &levels {
            let mut fan = vec![false; dirs.len()];
            w.occluded_fan(l, o, &dirs, 0.0, f32::MAX, &mut fan);
            for (d, h) in dirs.iter().zip(&fan) {
                let ray = WideRay {
                    o,
                    d: *d,
                    tmin: 0.0,
                    tmax: f32::MAX,
                };
                let want = scan(&w, &ray);
                hits += usize::from(want.is_some());
                assert_eq!(w.occluded(l, &ray), want.is_some(), "{l:?} {d:?}");
                assert_eq!(w.closest(l, &ray), want, "{l:?} {d:?}");
                assert_eq!(*h, want.is_some(), "fan, {l:?} {d:?}");
            }
            for o in [[2.0, 0.0, 0.0], [-1.0, 0.0, 0.0]] {
                let d = if o[0] > 0.0 {
                    [-1.0, 0.0, 0.0]
                } else {
                    [1.0, 0.0, 0.0]
                };
                let ray = WideRay {
                    o,
                    d,
                    tmin: 0.0,
                    tmax: f32::MAX,
                };
                let want = scan(&w, &ray);
                assert!(want.is_some());
                assert_eq!(w.closest(l, &ray), want, "{l:?} along the axis");
            }
        }
        assert!(
            hits * 2 > dirs.len() * levels.len(),
            "{hits} hits: the rays miss the chain"
        );
    }

    /// The division-free triangle test at its edges, on one triangle in both windings (det > 0
    /// and det < 0) with exactly representable rays: interior, edge and vertex points hit, a
    /// point just outside misses, a ray in the triangle's plane (det = 0) misses, and the hit
    /// distance 1 is excluded by `tmax = 1` and `tmin = 1` and included just beyond them. Any-hit
    /// and nearest-hit agree, and `t` is exact.
    #[test]
    fn triangle_test_at_its_edges() {
        let (a, b, c) = ([0.0f32, 0.0, 0.0], [1.0f32, 0.0, 0.0], [0.0f32, 1.0, 0.0]);
        let tri = |p: [f32; 3], q: [f32; 3], r: [f32; 3]| Triangle {
            v0: glam::Vec3A::from(p),
            v1: glam::Vec3A::from(q),
            v2: glam::Vec3A::from(r),
        };
        for t in [tri(a, b, c), tri(a, c, b)] {
            let mut ids = [u32::MAX; PACK];
            ids[0] = 0;
            let pack = pack_of(&[t], &ids);
            let down = |x: f32, y: f32, tmin: f32, tmax: f32| {
                let ray = WideRay {
                    o: [x, y, 1.0],
                    d: [0.0, 0.0, -1.0],
                    tmin,
                    tmax,
                };
                let any = pack_hit::<true>(&pack, &ray, tmax);
                let near = pack_hit::<false>(&pack, &ray, tmax);
                assert_eq!(any.1, near.1, "({x}, {y}) any-hit and nearest disagree");
                (near.1 < PACK).then_some(near.0)
            };
            let m = f32::MAX;
            for (x, y) in [
                (0.25, 0.25),
                (0.5, 0.0),
                (0.0, 0.5),
                (0.5, 0.5),
                (0.0, 0.0),
                (1.0, 0.0),
            ] {
                assert_eq!(
                    down(x, y, 0.0, m),
                    Some(1.0),
                    "({x}, {y}) should hit at t = 1"
                );
            }
            for (x, y) in [(-1e-3, 0.25), (0.25, -1e-3), (0.5, 0.5 + 1e-3), (2.0, 2.0)] {
                assert_eq!(down(x, y, 0.0, m), None, "({x}, {y}) is outside");
            }
            assert_eq!(down(0.25, 0.25, 0.0, 1.0), None, "t = tmax is excluded");
            assert_eq!(down(0.25, 0.25, 0.0, 1.0 + 1e-6), Some(1.0));
            assert_eq!(down(0.25, 0.25, 1.0, m), None, "t = tmin is excluded");
            assert_eq!(down(0.25, 0.25, 1.0 - 1e-6, m), Some(1.0));
            let grazing = WideRay {
                o: [-1.0, 0.25, 0.0],
                d: [1.0, 0.0, 0.0],
                tmin: 0.0,
                tmax: m,
            };
            assert_eq!(
                pack_hit::<false>(&pack, &grazing, m).1,
                PACK,
                "det = 0 misses"
            );
        }
    }

    /// An empty tree: every query misses, on both instruction sets, one ray and fans (its
    /// packets' root pre-test box is inverted and passes every lane to the root's own test).
    #[test]
    fn empty_trees_answer_no() {
        let mut dur = std::time::Duration::default();
        let params = BvhBuildParams::fast_build();
        let w = WideBvh::from_bvh2(&build_bvh2_from_tris(&[], params, &mut dur), &[]);
        let mut rng = Rng(11);
        let dirs: Vec<[f32; 3]> = (0..20).map(|_| rng.dir()).collect();
        let levels = shscale_sh::simd::supported();
        for &l in &levels {
            let mut hit = vec![true; dirs.len()];
            w.occluded_fan(l, [0.0; 3], &dirs, 0.0, f32::MAX, &mut hit);
            assert!(hit.iter().all(|h| !h), "{l:?}");
            let ray = WideRay {
                o: [0.0; 3],
                d: dirs[0],
                tmin: 0.0,
                tmax: f32::MAX,
            };
            assert!(
                !w.occluded(l, &ray) && w.closest(l, &ray).is_none(),
                "{l:?}"
            );
        }
    }

    /// The collapse against exhaustive search, on binary trees of 20–60 triangles: the least
    /// cost over every wide tree the binary one can be collapsed into (each wide node's children
    /// enumerated as every cut of at most 8 nodes below it, every child a leaf where allowed or
    /// a wide node) equals the planned cost, and the tree actually emitted, costed from its own
    /// (refitted) boxes, costs the same.
    #[test]
    fn collapse_is_optimal_under_its_cost_model() {
        fn cuts(b: &Builder, n: usize) -> Vec<Vec<usize>> {
            let node = &b.bvh2.nodes[n];
            let mut all = vec![vec![n]];
            if !node.is_leaf() {
                let l = node.first_index as usize;
                for a in cuts(b, l) {
                    for c in cuts(b, l + 1) {
                        if a.len() + c.len() <= WIDTH {
                            all.push([a.clone(), c].concat());
                        }
                    }
                }
            }
            all
        }
        fn best(b: &Builder, n: usize, memo: &mut Vec<Option<f64>>) -> f64 {
            if let Some(c) = memo[n] {
                return c;
            }
            let node = &b.bvh2.nodes[n];
            let area = node.aabb().half_area() as f64;
            let count = b.counts[n];
            let leaf = if node.is_leaf() || count <= LEAF_MAX {
                area * COST_PACK as f64 * count.div_ceil(PACK as u32) as f64
            } else {
                f64::INFINITY
            };
            let mut inner = f64::INFINITY;
            if !node.is_leaf() {
                let l = node.first_index as usize;
                for a in cuts(b, l) {
                    for c in cuts(b, l + 1) {
                        if a.len() + c.len() <= WIDTH {
                            let kids: f64 = a.iter().chain(&c).map(|&k| best(b, k, memo)).sum();
                            inner = inner.min(area * COST_NODE as f64 + kids);
                        }
                    }
                }
            }
            let c = leaf.min(inner);
            memo[n] = Some(c);
            c
        }
        /// The cost of the emitted subtree under wide node `n`, whose own box has `area`.
        fn emitted(w: &WideBvh, n: usize, area: f64) -> f64 {
            let node = &w.nodes[n];
            let mut c = area * COST_NODE as f64;
            for j in (0..WIDTH).filter(|&j| node.child[j] != EMPTY) {
                let e = [0, 1, 2].map(|a| (node.b[a + 3][j] - node.b[a][j] - 2.0 * BOX_PAD) as f64);
                let a = e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
                let r = node.child[j];
                c += if r & LEAF != 0 {
                    a * COST_PACK as f64 * leaf_range(r).1 as f64
                } else {
                    emitted(w, r as usize, a)
                };
            }
            c
        }
        let mut rng = Rng(7);
        let mut dur = core::time::Duration::default();
        for n in [20, 33, 47, 60] {
            let t = tris(n, &mut rng);
            let params = BvhBuildParams {
                max_prims_per_leaf: 1,
                ..BvhBuildParams::fast_build()
            };
            let bvh2 = build_bvh2_from_tris(&t, params, &mut dur);
            let mut b = Builder::new(&bvh2, &t);
            b.plan(0);
            let planned = b.cost[0][0] as f64;
            let searched = best(&b, 0, &mut vec![None; bvh2.nodes.len()]);
            let w = WideBvh::from_bvh2(&bvh2, &t);
            let root = bvh2.nodes[0].aabb().half_area() as f64;
            let built = emitted(&w, 0, root);
            println!(
                "{n} triangles: planned {planned:.6}, exhaustive {searched:.6}, emitted {built:.6} ({} nodes, {} packs)",
                w.nodes.len(),
                w.packs.len()
            );
            // f32 sums in the plan, f64 here; the emitted boxes are f32 refits of the same
            // triangles.
            let tol = 1e-4 * searched;
            assert!(
                (planned - searched).abs() <= tol,
                "plan {planned} vs search {searched}"
            );
            assert!(
                (built - searched).abs() <= tol,
                "emitted {built} vs search {searched}"
            );
        }
    }

    /// The relative area is 1 for a tree of one leaf and exceeds 1 otherwise; a refit with the
    /// same triangles leaves it unchanged, and moving the triangles to each other's places (the
    /// same root box, scattered leaves) raises it; a tree of zero extent reads 1.
    #[test]
    fn relative_area_measures_box_growth() {
        let mut rng = Rng(3);
        let one = tris(3, &mut rng);
        let build = |t: &[Triangle]| {
            let mut dur = std::time::Duration::default();
            let params = BvhBuildParams {
                max_prims_per_leaf: PACK as u32,
                ..BvhBuildParams::fast_build()
            };
            build_bvh2_from_tris(t, params, &mut dur)
        };
        let w1 = WideBvh::from_bvh2(&build(&one), &one);
        assert!(
            (w1.relative_area() - 1.0).abs() < 1e-12,
            "{}",
            w1.relative_area()
        );
        let mut many = tris(500, &mut rng);
        let mut w = WideBvh::from_bvh2(&build(&many), &many);
        let a0 = w.relative_area();
        w.refit(&many);
        assert_eq!(w.relative_area(), a0);
        // The same triangles, each moved to another's place: the root box stays, the leaves'
        // boxes now span the ball.
        many.reverse();
        w.refit(&many);
        println!(
            "relative area {a0:.3}, after shuffling the triangles {:.3}",
            w.relative_area()
        );
        assert!(a0 > 1.0 && w.relative_area() > a0 * 1.05);
        // Degenerate edge: every triangle at one point (a root box of zero area) reads 1, not
        // NaN, so `rebuild_due` is not fed a NaN by a collapsed mesh.
        let point: Vec<Triangle> = (0..40)
            .map(|_| Triangle {
                v0: [0.25f32; 3].into(),
                v1: [0.25f32; 3].into(),
                v2: [0.25f32; 3].into(),
            })
            .collect();
        let wp = WideBvh::from_bvh2(&build(&point), &point);
        assert_eq!(wp.relative_area(), 1.0);
    }

    /// Traversal = scan over every pack, bit for bit, on both instruction sets, for any-hit and
    /// nearest-hit queries, rays from inside and outside, axis-aligned directions (zero
    /// components) included; the fan query = the one-ray query; a refit after moving every
    /// vertex still equals the scan.
    #[test]
    fn traversal_equals_scan_of_every_pack() {
        let mut rng = Rng(5);
        for n in [1usize, 3, 4, 5, 33, 2000] {
            let mut t = tris(n, &mut rng);
            let mut dur = std::time::Duration::default();
            let params = BvhBuildParams {
                max_prims_per_leaf: PACK as u32,
                ..BvhBuildParams::medium_build()
            };
            let mut w = WideBvh::from_bvh2(&build_bvh2_from_tris(&t, params, &mut dur), &t);
            let levels = shscale_sh::simd::supported();
            let (mut hits, mut rays) = (0, 0);
            for round in 0..2 {
                if round == 1 {
                    // Move every vertex and refit.
                    for tri in &mut t {
                        tri.v0.x += 0.03;
                        tri.v1.y -= 0.02;
                        tri.v2.z *= 1.1;
                    }
                    w.refit(&t);
                }
                for i in 0..3000 {
                    let o = rng.dir().map(|v| v * if i % 2 == 0 { 1.5 } else { 0.5 });
                    let d = match i % 7 {
                        0 => [0.0, 0.0, if i % 2 == 0 { -1.0 } else { 1.0 }],
                        1 => [1.0, 0.0, 0.0],
                        _ => rng.dir(),
                    };
                    let ray = WideRay {
                        o,
                        d,
                        tmin: 1e-4,
                        tmax: f32::MAX,
                    };
                    let want = scan(&w, &ray);
                    rays += 1;
                    hits += usize::from(want.is_some());
                    for &l in &levels {
                        assert_eq!(w.occluded(l, &ray), want.is_some(), "n {n} ray {i} {l:?}");
                        assert_eq!(w.closest(l, &ray), want, "n {n} ray {i} {l:?}");
                    }
                }
                // Fans from one origin.
                let o = [0.0, 0.0, -1.2];
                let dirs: Vec<[f32; 3]> = (0..500).map(|_| rng.dir()).collect();
                for &l in &levels {
                    let mut hit = vec![false; dirs.len()];
                    w.occluded_fan(l, o, &dirs, 1e-4, f32::MAX, &mut hit);
                    for (d, h) in dirs.iter().zip(&hit) {
                        let ray = WideRay {
                            o,
                            d: *d,
                            tmin: 1e-4,
                            tmax: f32::MAX,
                        };
                        assert_eq!(*h, scan(&w, &ray).is_some());
                    }
                }
            }
            println!(
                "{n} triangles: {hits} hits in {rays} rays, tree {:?}",
                w.stats()
            );
            assert!(n < 1000 || hits * 5 > rays, "too few hits to test anything");
        }
    }

    /// The packet's per-lane slab data equals `Prepared::new`'s bit for bit, for directions
    /// with zero, signed-zero, denormal, tiny and ordinary components.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn packet_lane_slabs_equal_the_one_ray_ones() {
        if shscale_sh::simd::detected() < Level::Avx2Fma {
            eprintln!("notice: no AVX2 + FMA level here; the packet kernel is not used");
            return;
        }
        use std::arch::x86_64::*;
        let special = [
            0.0f32,
            -0.0,
            1e-40,
            -1e-40,
            TINY_DIR * 0.5,
            -TINY_DIR,
            TINY_DIR,
            1e-19,
            -0.3,
            0.7,
            1.0,
            -1.0,
        ];
        let mut rng = Rng(7);
        let o = [0.31f32, -1.7, 2.9];
        let mut checked = 0;
        for round in 0..64 {
            let mut dirs = [[0f32; 3]; 8];
            for (i, d) in dirs.iter_mut().enumerate() {
                for (a, c) in d.iter_mut().enumerate() {
                    let k = (round * 24 + i * 3 + a) % (special.len() + 4);
                    *c = if k < special.len() {
                        special[k]
                    } else {
                        rng.f() * 2.0 - 1.0
                    };
                }
            }
            let col = |a: usize| {
                let v: [f32; 8] = std::array::from_fn(|i| dirs[i][a]);
                // SAFETY: the level checked above includes AVX2; `v` holds 8 floats.
                unsafe { _mm256_loadu_ps(v.as_ptr()) }
            };
            // SAFETY: the AVX2 + FMA level (with POPCNT and BMI) was detected above.
            let (_, linv, loi) = unsafe { lane_slabs(o, [col(0), col(1), col(2)]) };
            for (i, d) in dirs.iter().enumerate() {
                let pre = Prepared::new(&WideRay {
                    o,
                    d: *d,
                    tmin: 0.0,
                    tmax: f32::MAX,
                });
                let lane = Prepared::lane(&linv, &loi, i);
                for a in 0..3 {
                    assert_eq!(pre.inv[a].to_bits(), lane.inv[a].to_bits(), "inv {d:?}");
                    assert_eq!(pre.oi[a].to_bits(), lane.oi[a].to_bits(), "o·inv {d:?}");
                }
                assert_eq!((pre.near, pre.far), (lane.near, lane.far), "rows {d:?}");
                checked += 1;
            }
        }
        eprintln!("{checked} directions: packet lane slabs equal Prepared::new bit for bit");
    }

    /// A finite `tmax` stops the search; `tmin` skips the nearer hit.
    #[test]
    fn interval_is_honoured() {
        let t: Vec<Triangle> = [0.0f32, 0.5]
            .iter()
            .map(|&z| Triangle {
                v0: [-1.0, -1.0, z].into(),
                v1: [1.0, -1.0, z].into(),
                v2: [0.0, 1.0, z].into(),
            })
            .collect();
        let mut dur = std::time::Duration::default();
        let w = WideBvh::from_bvh2(
            &build_bvh2_from_tris(&t, BvhBuildParams::medium_build(), &mut dur),
            &t,
        );
        let l = shscale_sh::simd::level();
        let ray = |tmin, tmax| WideRay {
            o: [0.0, 0.0, -1.0],
            d: [0.0, 0.0, 1.0],
            tmin,
            tmax,
        };
        assert_eq!(w.closest(l, &ray(0.0, 10.0)), Some((1.0, 0)));
        assert_eq!(w.closest(l, &ray(1.1, 10.0)), Some((1.5, 1)));
        assert!(!w.occluded(l, &ray(0.0, 0.99)));
        assert!(!w.occluded(l, &ray(1.6, 10.0)));
        assert!(w.occluded(l, &ray(1.2, 1.6)));
    }
}
