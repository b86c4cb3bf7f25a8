//! The collapse of obvhs' binary BVH into the 8-wide tree (the optimal dynamic-programming
//! collapse of Ylitie et al. 2017 under the surface-area heuristic), the refit of a tree whose
//! vertices moved, and the tree's shape and relative area.

use super::layout::*;
use obvhs::bvh2::Bvh2;
use obvhs::triangle::Triangle;
use rayon::prelude::*;

pub(super) fn tri_bounds(t: &Triangle) -> ([f32; 3], [f32; 3]) {
    let lo = t.v0.min(t.v1).min(t.v2);
    let hi = t.v0.max(t.v1).max(t.v2);
    (lo.to_array(), hi.to_array())
}

/// The box of a pack's triangles (padding ids skipped).
fn pack_box(tris: &[Triangle], ids: &[u32; PACK]) -> ([f32; 3], [f32; 3]) {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for &id in ids.iter().filter(|&&id| id != u32::MAX) {
        let (a, b) = tri_bounds(&tris[id as usize]);
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    }
    (lo, hi)
}

pub(super) fn pack_of(tris: &[Triangle], ids: &[u32; PACK]) -> Pack {
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
pub(super) const COST_NODE: f32 = 1.0;
pub(super) const COST_PACK: f32 = 1.0;
/// The most triangles the collapse puts in one leaf (as `⌈n / PACK⌉` packs).
pub(super) const LEAF_MAX: u32 = 16;

pub(super) struct Builder<'a> {
    pub(super) bvh2: &'a Bvh2,
    pub(super) tris: &'a [Triangle],
    /// Triangles under each binary node.
    pub(super) counts: Vec<u32>,
    /// Per binary node and `i = 1..=8`: the least cost of the subtree spread over at most `i`
    /// child slots of a wide node (`cost[n][i - 1]`), and how: 0 = the node itself as one
    /// child, `k > 0` = `k` slots for its left subtree and `i − k` for its right.
    pub(super) cost: Vec<[f32; WIDTH]>,
    pub(super) split: Vec<[u8; WIDTH]>,
    /// For a node that becomes a wide node: its left subtree's share of the 8 slots.
    pub(super) wide_split: Vec<u8>,
    /// Scratch for a leaf's triangle indices.
    pub(super) prims: Vec<u32>,
    /// Whether the node, as one child, is a leaf (else a wide node of its own).
    pub(super) as_leaf: Vec<bool>,
    pub(super) out: WideBvh,
}

impl<'a> Builder<'a> {
    pub(super) fn new(bvh2: &'a Bvh2, tris: &'a [Triangle]) -> Self {
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
    pub(super) fn plan(&mut self, n: usize) {
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
    pub(super) fn children(&self, n: usize, i: usize, into: &mut ([usize; WIDTH], usize)) {
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

    pub(super) fn gather(&self, n: usize, into: &mut Vec<u32>) {
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
    pub(super) fn leaf(&mut self, n: usize) -> u32 {
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
    pub(super) fn inner(&mut self, n: usize, level: usize) -> u32 {
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

    /// Follow moved vertices (same triangles, same tree): new packs and their boxes in one
    /// parallel pass, then the node boxes bottom-up.
    pub fn refit(&mut self, tris: &[Triangle]) {
        let pack_boxes: Vec<([f32; 3], [f32; 3])> =
            (self.packs.par_iter_mut().zip(&self.ids).with_min_len(512))
                .map(|(p, ids)| {
                    *p = pack_of(tris, ids);
                    pack_box(tris, ids)
                })
                .collect();
        self.sweep_boxes(&pack_boxes);
    }

    /// Every box from the triangles (the packs as they are).
    pub(super) fn refit_boxes(&mut self, tris: &[Triangle]) {
        let pack_boxes: Vec<([f32; 3], [f32; 3])> = (self.ids.par_iter().with_min_len(512))
            .map(|ids| pack_box(tris, ids))
            .collect();
        self.sweep_boxes(&pack_boxes);
    }

    /// The node boxes and the root bounds from each pack's box (min and max are exact: the
    /// union of the packs' boxes is the union of their triangles' boxes, in any order).
    fn sweep_boxes(&mut self, pack_boxes: &[([f32; 3], [f32; 3])]) {
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
                    for (a, b) in &pack_boxes[first..first + count] {
                        for k in 0..3 {
                            lo[k] = lo[k].min(a[k]);
                            hi[k] = hi[k].max(b[k]);
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
}
