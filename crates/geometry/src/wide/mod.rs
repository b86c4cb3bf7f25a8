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
//! **Kernels.** Written once over eight f32 lanes (`lanes.rs`: the `Lanes` vocabulary, an AVX2
//! form on `__m256` and a portable form on `[f32; 8]` that LLVM turns into two SSE2 or NEON
//! vectors) and instantiated per level: AVX2 + FMA, AVX2 + FMA with AVX-512 F/VL/BW/DQ as well
//! (the same code EVEX-encoded, 32 vector registers), both chosen at run time, and the target's
//! default features (`shscale_sh::simd`). The one-ray box test (`box_mask`) and the packet
//! kernel (`packet_body`: 8 rays from one origin, the BSV fans) are each one generic function;
//! the packet kernel is inlined into one wrapper per level (`packet_occluded_avx2`,
//! `packet_occluded_avx512`, `packet_occluded_portable`). The two forms agree bit for bit on
//! every lane operation but the fused multiply-add (tested), so every level's answers are the
//! same.
//!
//! | file | what it owns |
//! |---|---|
//! | `layout.rs` | the node and pack layouts (sizes asserted at compile time), rays, the tree |
//! | `build.rs` | the collapse of a binary BVH, refit, the tree's shape and area |
//! | `kernels.rs` | the traversal kernels: one ray (any-hit, closest) and fans, per SIMD level |
//! | `lanes.rs` | eight f32 lanes: the operations the kernels use, per SIMD level |
//! | `packet.rs` | the packet kernel: 8 rays from one origin traversed together |
//! | `prepared.rs` | a ray's prepared slab data and its traversal stack |

mod build;
mod kernels;
mod lanes;
mod layout;
mod packet;
mod prepared;
#[cfg(test)]
mod tests;

pub use layout::{
    TreeStats, WideBvh, WideRay, BOX_PAD, MAX_LEAF_PACKS, PACK, SLAB_SLACK, TINY_DIR, WIDTH,
};
