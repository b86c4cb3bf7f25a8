//! Tests of the 8-wide BVH: traversal against a scan of every pack and brute force, the
//! collapse against its cost model, the edges of the triangle test, deep and empty trees.

use super::build::*;
use super::kernels::*;
use super::layout::*;
use super::prepared::*;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::bvh2::Bvh2;
use obvhs::triangle::Triangle;
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
/// with zero, signed-zero, denormal, tiny and ordinary components — in the portable lane form,
/// and in the AVX2 form where the CPU has it.
#[test]
fn packet_lane_slabs_equal_the_one_ray_ones() {
    use super::lanes::{Lanes, Portable};
    use super::packet::lane_slabs;
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
    #[cfg(target_arch = "x86_64")]
    let avx2 = shscale_sh::simd::detected() >= shscale_sh::simd::Level::Avx2Fma;
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
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut forms = vec![("portable", {
            let (_, linv, loi) = lane_slabs(o, Portable::soa8(&dirs));
            (linv, loi)
        })];
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: the AVX2 + FMA level (with POPCNT and BMI) was detected above.
            forms.push(("avx2", unsafe { avx2_slabs(o, &dirs) }));
        }
        for (form, (linv, loi)) in forms {
            for (i, d) in dirs.iter().enumerate() {
                let pre = Prepared::new(&WideRay {
                    o,
                    d: *d,
                    tmin: 0.0,
                    tmax: f32::MAX,
                });
                let lane = Prepared::lane(&linv, &loi, i);
                for a in 0..3 {
                    assert_eq!(
                        pre.inv[a].to_bits(),
                        lane.inv[a].to_bits(),
                        "{form} inv {d:?}"
                    );
                    assert_eq!(
                        pre.oi[a].to_bits(),
                        lane.oi[a].to_bits(),
                        "{form} o·inv {d:?}"
                    );
                }
                assert_eq!(
                    (pre.near, pre.far),
                    (lane.near, lane.far),
                    "{form} rows {d:?}"
                );
                checked += 1;
            }
        }
    }
    eprintln!("{checked} directions × forms: packet lane slabs equal Prepared::new bit for bit");
}

/// The AVX2 form's per-lane slab data.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
unsafe fn avx2_slabs(o: [f32; 3], dirs: &[[f32; 3]; 8]) -> ([[f32; 8]; 3], [[f32; 8]; 3]) {
    use super::lanes::{Avx2, Lanes};
    let (_, linv, loi) = super::packet::lane_slabs(o, Avx2::soa8(dirs));
    (linv, loi)
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

/// The two lane forms agree bit for bit on every operation the kernels use (all but the fused
/// `mul_add`, which the AVX2 form fuses), on ordinary values and on ±0, ±∞, NaN and
/// denormals — the "same NaN rules" the packet and box tests rely on for identical answers.
#[cfg(target_arch = "x86_64")]
#[test]
fn lane_forms_agree_bit_for_bit() {
    if shscale_sh::simd::detected() < shscale_sh::simd::Level::Avx2Fma {
        eprintln!("notice: no AVX2 + FMA level here; only the portable form exists");
        return;
    }
    let special = [
        0.0f32,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1e-40,
        -1e-40,
        1.5,
        -2.25,
        f32::MAX,
    ];
    let mut rng = Rng(11);
    let mut pick = |k: usize| {
        if k.is_multiple_of(3) {
            rng.f() * 8.0 - 4.0
        } else {
            special[k % special.len()]
        }
    };
    let mut compared = 0;
    for round in 0..200 {
        let a: [f32; 8] = std::array::from_fn(|i| pick(round * 16 + i));
        let b: [f32; 8] = std::array::from_fn(|i| pick(round * 16 + 8 + i * 7));
        // SAFETY: the AVX2 + FMA level was detected above.
        let (got, want) = unsafe { avx2_ops(a, b) };
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            for i in 0..8 {
                assert_eq!(
                    g[i].to_bits(),
                    w[i].to_bits(),
                    "op {k}, lane {i}: {a:?} {b:?}"
                );
            }
            compared += 8;
        }
    }
    eprintln!("{compared} lane results: the AVX2 and portable forms agree bit for bit");
}

/// Every lane operation but `mul_add` in both forms: (AVX2 results, portable results).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
unsafe fn avx2_ops(a: [f32; 8], b: [f32; 8]) -> (Vec<[f32; 8]>, Vec<[f32; 8]>) {
    use super::lanes::{Avx2, Lanes, Portable};
    fn all<V: Lanes>(a: [f32; 8], b: [f32; 8]) -> Vec<[f32; 8]> {
        let (x, y) = (V::load(&a), V::load(&b));
        let mut out = vec![
            x.add(y),
            x.sub(y),
            x.mul(y),
            x.div(y),
            x.min(y),
            x.max(y),
            x.and(y),
            x.andnot(y),
            x.or(y),
            x.xor(y),
            x.lt(y),
            x.le(y),
            x.gt(y),
            x.ge(y),
            x.ne(y),
            V::select(x, x, y),
            x.recip_dir(),
        ]
        .into_iter()
        .map(|v| {
            let mut s = [0f32; 8];
            v.store(&mut s);
            s
        })
        .collect::<Vec<_>>();
        let bits = [
            x.bits(),
            x.lt(y).bits(),
            V::empty_slots(&a.map(f32::to_bits)),
        ];
        out.push(
            bits.map(f32::from_bits)
                .iter()
                .copied()
                .chain([0.0; 5])
                .collect::<Vec<_>>()
                .try_into()
                .unwrap(),
        );
        out
    }
    (all::<Avx2>(a, b), all::<Portable>(a, b))
}

/// After a refit every child box is exactly the union of its triangles' boxes (a leaf) or of
/// its children's stored boxes with their padding removed (an inner node), then padded by
/// `BOX_PAD`, computed here triangle by triangle from the tree's ids and recursively; on one
/// thread and on two the same boxes.
#[test]
fn refit_boxes_are_the_unions_of_their_triangles() {
    let mut rng = Rng(21);
    let mut t = tris(5000, &mut rng);
    let mut dur = std::time::Duration::default();
    let params = BvhBuildParams {
        max_prims_per_leaf: 1,
        ..BvhBuildParams::fast_build()
    };
    let w0 = WideBvh::from_bvh2(&build_bvh2_from_tris(&t, params, &mut dur), &t);
    for tri in &mut t {
        tri.v0.x += 0.05 * tri.v1.y;
        tri.v2.z -= 0.04;
    }
    let refit = |threads: usize| {
        let mut w = w0.clone();
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| w.refit(&t));
        w
    };
    let (w, w2) = (refit(1), refit(2));
    // The union of a subtree's triangles, recursively, as the refit defines it.
    fn union(w: &WideBvh, t: &[Triangle], c: u32) -> ([f32; 3], [f32; 3]) {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        if c & LEAF != 0 {
            let (first, count) = leaf_range(c);
            for ids in &w.ids[first..first + count] {
                for &id in ids.iter().filter(|&&id| id != u32::MAX) {
                    let (a, b) = tri_bounds(&t[id as usize]);
                    for k in 0..3 {
                        lo[k] = lo[k].min(a[k]);
                        hi[k] = hi[k].max(b[k]);
                    }
                }
            }
        } else {
            let n = &w.nodes[c as usize];
            for j in (0..WIDTH).filter(|&j| n.child[j] != EMPTY) {
                let (a, b) = union(w, t, n.child[j]);
                for k in 0..3 {
                    // As stored in the child (padded), the padding then removed.
                    lo[k] = lo[k].min((a[k] - BOX_PAD) + BOX_PAD);
                    hi[k] = hi[k].max((b[k] + BOX_PAD) - BOX_PAD);
                }
            }
        }
        (lo, hi)
    }
    let mut checked = 0;
    for (n, node) in w.nodes.iter().enumerate() {
        for j in (0..WIDTH).filter(|&j| node.child[j] != EMPTY) {
            let (lo, hi) = union(&w, &t, node.child[j]);
            let mut want = Node::empty();
            want.set_box(j, lo, hi);
            for row in 0..6 {
                assert_eq!(
                    node.b[row][j].to_bits(),
                    want.b[row][j].to_bits(),
                    "node {n} child {j} row {row}"
                );
                assert_eq!(node.b[row][j].to_bits(), w2.nodes[n].b[row][j].to_bits());
            }
            checked += 1;
        }
    }
    assert_eq!(w.bounds, w2.bounds);
    println!("{checked} child boxes equal their triangles' unions, on 1 and 2 threads");
}
