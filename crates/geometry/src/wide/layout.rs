//! The layouts of the 8-wide BVH: nodes of 8 boxes (struct-of-arrays rows, one AVX2 vector
//! each) and packs of 8 triangles (lane-major), both 32-byte aligned; their sizes are asserted at
//! compile time, as the GPU layouts are.

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

pub(super) const LEAF: u32 = 1 << 31;
pub(super) const EMPTY: u32 = u32::MAX;
pub(super) const COUNT_SHIFT: u32 = 24;
/// The most packs one leaf child refers to.
pub const MAX_LEAF_PACKS: usize = 127;
pub(super) const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Node {
    /// Rows 0–2: the boxes' minima in x, y, z; rows 3–5: their maxima.
    pub(super) b: [[f32; WIDTH]; 6],
    /// Inner node index, `LEAF | (packs − 1) << 24 | first pack`, or `EMPTY`.
    pub(super) child: [u32; WIDTH],
}

// One node is 6 rows of 8 f32 boxes and 8 child words: 224 bytes, 7 cache half-lines.
const _: () = assert!(std::mem::size_of::<Node>() == 224, "Node layout size");
const _: () = assert!(std::mem::align_of::<Node>() == 32, "Node alignment");
// One pack is 9 rows of 8 f32 (v0, e1, e2 per axis): 288 bytes.
const _: () = assert!(std::mem::size_of::<Pack>() == 288, "Pack layout size");
const _: () = assert!(std::mem::align_of::<Pack>() == 32, "Pack alignment");

impl Node {
    pub(super) fn empty() -> Self {
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
    pub(super) fn set_box(&mut self, j: usize, lo: [f32; 3], hi: [f32; 3]) {
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
pub(super) struct Pack {
    pub(super) v0: [[f32; PACK]; 3],
    pub(super) e1: [[f32; PACK]; 3],
    pub(super) e2: [[f32; PACK]; 3],
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
    pub(super) nodes: Vec<Node>,
    pub(super) packs: Vec<Pack>,
    /// The triangle index of every pack lane (`u32::MAX` for padding).
    pub(super) ids: Vec<[u32; PACK]>,
    /// Deepest node level (root = 1), which bounds the traversal stack.
    pub(super) depth: usize,
    /// The root's children's (padded) boxes together, `[minima, maxima]`: the packets' first,
    /// cheap test, conservative like the children's (for an empty tree it is inverted and lets
    /// every lane through to the root's own test, which rejects them).
    pub(super) bounds: [[f32; 3]; 2],
}

pub(super) fn leaf_range(c: u32) -> (usize, usize) {
    (
        (c & FIRST_MASK) as usize,
        (((c & !LEAF) >> COUNT_SHIFT) + 1) as usize,
    )
}
