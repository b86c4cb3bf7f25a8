//! Geometry oracles: mesh validation errors, bundled meshes, BVH against brute force, the
//! analytic sphere, bounding spheres of real meshes.

use shscale_geometry::ray::{intersect_triangle, UpdateStrategy};
use shscale_geometry::*;

fn err_of(name: &str, text: &str) -> String {
    Mesh::from_obj_bytes(name, text.as_bytes())
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_obj_files_name_file_and_line() {
    let e = err_of("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    assert!(e.contains("a.obj:4") && e.contains("out of range"), "{e}");
    let e = err_of("b.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
    assert!(e.contains("b.obj:2") && e.contains("non-finite"), "{e}");
    let e = err_of("c.obj", "v 0 0\n");
    assert!(e.contains("c.obj:1"), "{e}");
    let e = err_of("d.obj", "# nothing\n");
    assert!(e.contains("d.obj") && e.contains("empty"), "{e}");
    let e = err_of("e.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    assert!(
        e.contains("e.obj") && e.contains("face 0") && e.contains("zero-area"),
        "{e}"
    );
    let e = err_of("f.obj", "v 0 0 0\nf 1 2\n");
    assert!(e.contains("f.obj:2"), "{e}");
    let e = Mesh::load(std::path::Path::new("/nonexistent/x.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/x.obj"), "{e}");
}

#[test]
fn ply_ascii_and_binary_and_errors() {
    let ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    let m = ply::parse_ply("q.ply", ascii.as_bytes()).unwrap();
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(m.positions.len(), 4);
    // Binary little endian: same quad.
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
    for v in [
        [0.0f64, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b.push(4);
    for i in [0u32, 1, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    let mb = ply::parse_ply("q.ply", &b).unwrap();
    assert_eq!(mb.positions, m.positions);
    assert_eq!(mb.triangles, m.triangles);
    // Truncated binary names the element; bad ASCII names the line.
    let e = ply::parse_ply("t.ply", &b[..b.len() - 3])
        .unwrap_err()
        .to_string();
    assert!(e.contains("t.ply") && e.contains("face"), "{e}");
    let bad = ascii.replace("1 1 0\n", "1 x 0\n");
    let e = ply::parse_ply("r.ply", bad.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("r.ply:12"), "{e}");
    let bad = ascii.replace("4 0 1 2 3", "4 0 1 2 9");
    let e = ply::parse_ply("s.ply", bad.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("s.ply") && e.contains("face 0"), "{e}");
}

#[test]
fn bundled_meshes_load_with_expected_topology() {
    for (name, v, f, watertight) in [
        ("bunny", 1839, 3674, true),
        ("duck", 2108, 4212, true),
        ("dragon_19k", 9357, 18718, true),
        ("knot", 3200, 6400, true),
        ("teapot", 8257, 16256, false),
    ] {
        let m = bundled::load(name).unwrap();
        let r = m.inspect();
        assert_eq!((r.vertices, r.triangles), (v, f), "{name}");
        assert_eq!(r.watertight, watertight, "{name}: {r:?}");
        // Every vertex lies inside the bounding sphere, and it is tight: some vertex is on it.
        let s = r.bounding_sphere;
        assert!(m.positions.iter().all(|p| s.contains(*p)), "{name}");
        let far = m
            .positions
            .iter()
            .map(|p| (*p - s.center).length())
            .fold(0.0, f64::max);
        assert!((far - s.radius).abs() < 1e-9 * s.radius, "{name}");
    }
    assert!(bundled::load("nope")
        .unwrap_err()
        .to_string()
        .contains("bunny"));
}

/// xorshift for reproducible random rays.
struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn dir(&mut self) -> DVec3 {
        let z = 2.0 * self.f() - 1.0;
        let p = 2.0 * std::f64::consts::PI * self.f();
        let r = (1.0 - z * z).sqrt();
        DVec3::new(r * p.cos(), r * p.sin(), z)
    }
}

/// Smallest barycentric margin of the ray against any triangle it hits or nearly hits (how
/// grazing it is).
fn grazing_margin(m: &Mesh, o: DVec3, d: DVec3) -> f64 {
    let mut best = f64::INFINITY;
    for f in 0..m.triangles.len() {
        let [a, b, c] = m.corners(f);
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-300 {
            continue;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let v = d.dot(s.cross(e1)) / det;
        let w = 1.0 - u - v;
        if u > -1e-3 && v > -1e-3 && w > -1e-3 {
            best = best.min(u.abs().min(v.abs()).min(w.abs()));
        }
    }
    best
}

#[test]
fn bvh_agrees_with_brute_force_on_random_rays() {
    let mesh = bundled::load("bunny").unwrap();
    let s = mesh.bounding_sphere();
    let brute = BruteForce::new(&mesh);
    let mut rng = Rng(7);
    for strategy in [
        UpdateStrategy::Rebuild,
        UpdateStrategy::Refit,
        UpdateStrategy::Adaptive,
    ] {
        let bvh = MeshBvh::build(&mesh, strategy);
        let (mut disagree, mut total) = (0, 0);
        for _ in 0..3000 {
            // Origins on the bounding sphere, directions random (half of them aimed inward).
            let o = s.center + s.radius * rng.dir();
            let mut d = rng.dir();
            if rng.f() < 0.5 && d.dot(s.center - o) < 0.0 {
                d = -d;
            }
            let tmin = RAY_EPS * s.radius;
            let (a, b) = (
                bvh.occluded(o, d, tmin, 1e30),
                brute.occluded(o, d, tmin, 1e30),
            );
            total += 1;
            if a != b {
                disagree += 1;
                let g = grazing_margin(&mesh, o, d);
                // f32 vs f64 may disagree only for rays within ~1e-5 (barycentric) of an edge.
                assert!(
                    g < 1e-5,
                    "{strategy:?}: non-grazing disagreement (margin {g:e}) at o={o} d={d}"
                );
            }
            if a && b {
                let (ta, tb) = (
                    bvh.closest_hit(o, d, tmin, 1e30).unwrap(),
                    brute.closest_hit(o, d, tmin, 1e30).unwrap(),
                );
                assert!(
                    (ta - tb).abs() < 1e-4 * s.radius || grazing_margin(&mesh, o, d) < 1e-5,
                    "{strategy:?}: t {ta} vs {tb}"
                );
            }
        }
        println!("{strategy:?}: {disagree} grazing disagreements in {total} rays");
        assert!(
            disagree * 100 < total,
            "too many disagreements: {disagree}/{total}"
        );
    }
}

/// The BVH traces in the mesh's unit frame: the bunny scaled by 1e20, 1e-20 and 1e45 agrees with
/// the f64 brute force exactly as at scale 1 (grazing rays only), and so do rays from 1e11
/// bounding radii away aimed into the bounding sphere (the far origin is advanced in f64).
#[test]
fn bvh_is_scale_invariant_and_far_origins_keep_precision() {
    let unit = bundled::load("bunny").unwrap();
    for scale in [1e20, 1e-20, 1e45] {
        let mesh = Mesh::new(
            "scaled",
            unit.positions.iter().map(|p| *p * scale).collect(),
            unit.triangles.clone(),
            false,
        )
        .unwrap();
        let s = mesh.bounding_sphere();
        let brute = BruteForce::new(&mesh);
        let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
        let mut rng = Rng(11);
        let (mut disagree, mut hits, mut worst_t) = (0, 0, 0f64);
        for i in 0..1000 {
            let far = i % 2 == 1;
            let o = s.center + s.radius * if far { 1e11 } else { 1.0 } * rng.dir();
            let target = s.center + 0.8 * s.radius * rng.f() * rng.dir();
            let d = (target - o).normalize();
            let tmin = RAY_EPS * s.radius;
            let (a, b) = (
                bvh.occluded(o, d, tmin, f64::INFINITY),
                brute.occluded(o, d, tmin, f64::INFINITY),
            );
            if a != b {
                disagree += 1;
                let g = grazing_margin(&mesh, o, d);
                assert!(
                    g < if far { 1e-3 } else { 1e-5 },
                    "scale {scale:e}, far {far}: non-grazing disagreement (margin {g:e})"
                );
            }
            if a && b {
                hits += 1;
                let (ta, tb) = (
                    bvh.closest_hit(o, d, tmin, f64::INFINITY).unwrap(),
                    brute.closest_hit(o, d, tmin, f64::INFINITY).unwrap(),
                );
                if grazing_margin(&mesh, o, d) > 1e-3 {
                    worst_t = worst_t.max((ta - tb).abs() / s.radius);
                }
            }
        }
        println!(
            "scale {scale:e}: {disagree} grazing disagreements in 1000 rays, {hits} hits, worst |Δt|/r = {worst_t:.2e}"
        );
        assert!(
            disagree * 50 < 1000,
            "scale {scale:e}: {disagree} disagreements"
        );
        assert!(hits > 200, "scale {scale:e}: only {hits} hits");
        assert!(worst_t < 5e-4, "scale {scale:e}: |Δt|/r = {worst_t:e}");
    }
}

/// Meshes outside the supported domain are refused naming the culprit, at the edges too.
#[test]
fn mesh_domain_edges() {
    let tri = |s: f64| {
        Mesh::new(
            "m",
            vec![DVec3::ZERO, DVec3::X * s, DVec3::Y * s],
            vec![[0, 1, 2]],
            false,
        )
    };
    assert!(tri(1e50).is_ok());
    assert!(tri(1e-50).is_ok());
    let e = tri(2e50).unwrap_err().to_string();
    assert!(e.contains("vertex 1") && e.contains("beyond ±1e50"), "{e}");
    let e = tri(1e-51).unwrap_err().to_string();
    assert!(e.contains("below 1e-50"), "{e}");
}

#[test]
fn refit_follows_deformation_like_a_rebuild() {
    let rest = shapes::box_block(DVec3::new(1.0, 0.3, 0.1), 12);
    let mut bent = rest.clone();
    let mut refit = MeshBvh::build(&rest, UpdateStrategy::Refit);
    let mut rebuilt = MeshBvh::build(&rest, UpdateStrategy::Rebuild);
    deform::bend(&rest, &mut bent, 1.4, 0.5);
    refit.update(&bent);
    rebuilt.update(&bent);
    let brute = BruteForce::new(&bent);
    let mut rng = Rng(99);
    let s = bent.bounding_sphere();
    for _ in 0..2000 {
        let o = s.center + 1.5 * s.radius * rng.dir();
        let d = (s.center + 0.5 * s.radius * rng.dir() - o).normalize();
        let (a, b, c) = (
            refit.occluded(o, d, 0.0, 1e30),
            rebuilt.occluded(o, d, 0.0, 1e30),
            brute.occluded(o, d, 0.0, 1e30),
        );
        if !(a == c && b == c) {
            assert!(
                grazing_margin(&bent, o, d) < 1e-5,
                "refit {a} rebuild {b} brute {c}"
            );
        }
    }
}

/// `Adaptive` refits while the refitted boxes stay within `REBUILD_GROWTH` of the last build's
/// relative area and rebuilds past it: a static mesh never rebuilds (a refit of the same
/// triangles reproduces the built area exactly), a twist from straight to half a turn does,
/// fewer times than a rebuild every frame; its answers equal brute force at every frame.
#[test]
fn adaptive_update_rebuilds_only_when_the_boxes_have_grown() {
    use shscale_geometry::ray::{rebuild_due, REBUILD_GROWTH};
    assert!(!rebuild_due(1.0, 1.0));
    assert!(!rebuild_due(1.0 + REBUILD_GROWTH * 0.99, 1.0));
    assert!(rebuild_due(1.0 + REBUILD_GROWTH * 1.01, 1.0));
    assert!(
        rebuild_due(f64::NAN, 1.0),
        "an unmeasurable tree is rebuilt"
    );

    let rest = shapes::box_block(DVec3::new(1.0, 0.3, 0.1), 12);
    let mut still = MeshBvh::build(&rest, UpdateStrategy::Adaptive);
    for _ in 0..5 {
        still.update(&rest);
    }
    assert_eq!(still.builds(), 1, "a static mesh is only refitted");

    let rest = shapes::box_block(DVec3::new(0.3, 0.3, 1.0), 12);
    let mut bent = rest.clone();
    let mut bvh = MeshBvh::build(&rest, UpdateStrategy::Adaptive);
    let frames = 12;
    let mut rng = Rng(5);
    let mut disagree = 0;
    for f in 1..=frames {
        deform::twist(&rest, &mut bent, 0.5, 0.5 * f as f64 / frames as f64);
        bvh.update(&bent);
        let brute = BruteForce::new(&bent);
        let s = bent.bounding_sphere();
        for _ in 0..300 {
            let o = s.center + 1.5 * s.radius * rng.dir();
            let d = (s.center + 0.5 * s.radius * rng.dir() - o).normalize();
            if bvh.occluded(o, d, 0.0, 1e30) != brute.occluded(o, d, 0.0, 1e30) {
                disagree += 1;
                assert!(
                    grazing_margin(&bent, o, d) < 1e-5,
                    "frame {f}: non-grazing disagreement"
                );
            }
        }
    }
    let builds = bvh.builds();
    println!("twist over {frames} frames: {builds} builds, {disagree} grazing disagreements");
    assert!(builds > 1, "half a turn should trigger a rebuild");
    assert!(
        builds < frames + 1,
        "every frame rebuilt: the trigger never refits"
    );
}

#[test]
fn analytic_sphere_and_triangle_intersection() {
    let s = AnalyticSphere::unit();
    // From outside along the axis: hits at t = 2 (near side).
    let o = DVec3::new(0.0, 0.0, 3.0);
    assert_eq!(s.closest_hit(o, -DVec3::Z, 0.0, 10.0), Some(2.0));
    // From a point on the surface: outward rays miss, inward rays hit the far side at 2cosθ.
    let p = DVec3::new(0.0, 0.0, 1.0);
    assert!(!s.occluded(p, DVec3::Z, RAY_EPS, 1e30));
    let d = DVec3::new(0.6, 0.0, -0.8);
    let t = s.closest_hit(p, d, RAY_EPS, 1e30).unwrap();
    assert!((t - 1.6).abs() < 1e-15, "{t}");
    // Tangent ray from the surface: misses beyond tmin.
    assert!(!s.occluded(p, DVec3::X, RAY_EPS, 1e30));
    assert!((s.distance_to_surface(DVec3::new(0.0, 2.0, 0.0)) - 1.0).abs() < 1e-15);
    let tri = [DVec3::ZERO, DVec3::X, DVec3::Y];
    assert_eq!(
        intersect_triangle(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z, tri),
        Some(1.0)
    );
    assert_eq!(
        intersect_triangle(DVec3::new(0.8, 0.8, 1.0), -DVec3::Z, tri),
        None
    );
    // Tessellated sphere distance: vertices at 0.
    let m = shapes::uv_sphere(1.0, 8, 12);
    let b = MeshBvh::build(&m, UpdateStrategy::Rebuild);
    assert!(b.distance_to_surface(m.positions[5]) < 1e-12);
    assert!((b.distance_to_surface(DVec3::new(0.0, 0.0, 3.0)) - 2.0).abs() < 1e-12);
}

#[test]
fn procedural_shapes_have_papers_sizes_and_are_watertight() {
    let sponge = shapes::box_block(DVec3::new(1.0, 0.5, 0.3), 37);
    assert!(
        (8000..9000).contains(&sponge.positions.len()),
        "{}",
        sponge.positions.len()
    );
    assert!(sponge.inspect().watertight);
    let egg = shapes::egg(1.0, 0.4, 22, 24);
    assert!((450..600).contains(&egg.positions.len()));
    assert!(egg.inspect().watertight);
    let bird = shapes::bird();
    assert!(
        (1000..1300).contains(&bird.positions.len()),
        "{}",
        bird.positions.len()
    );
    assert!(bird.inspect().watertight, "{:?}", bird.inspect());
    assert!(shapes::uv_sphere(1.0, 10, 16).inspect().watertight);
}

/// The batched queries answer exactly as the one-ray query: `occluded_many` on random rays
/// (near, inside and far origins — the far ones take the f64 advance), `occluded_fan` on
/// hemisphere fans from the bounding sphere, on both instruction sets.
#[test]
fn batched_queries_equal_one_ray_queries() {
    let mesh = bundled::load("bunny").unwrap();
    let s = mesh.bounding_sphere();
    let levels = shscale_sh::simd::supported();
    for level in levels {
        let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild).with_level(level);
        let mut rng = Rng(23);
        let (mut origins, mut dirs) = (Vec::new(), Vec::new());
        for i in 0..5000 {
            let dist = [0.3, 1.0, 1.5, 3.9, 4.1, 50.0, 1e9][i % 7];
            origins.push(s.center + dist * s.radius * rng.dir());
            dirs.push(if i % 3 == 0 {
                (s.center + 0.5 * s.radius * rng.dir() - origins[i]).normalize()
            } else {
                rng.dir()
            });
        }
        let tmin = RAY_EPS * s.radius;
        let mut many = vec![false; dirs.len()];
        bvh.occluded_many(&origins, &dirs, tmin, &mut many);
        let mut hits = 0;
        for i in 0..dirs.len() {
            let one = bvh.occluded(origins[i], dirs[i], tmin, f64::INFINITY);
            assert_eq!(many[i], one, "{level:?} ray {i}");
            hits += usize::from(one);
        }
        // Fans: 1000 directions over the hemisphere facing the centre from 60 points, most on
        // the bounding sphere (the fan kernel), some inside it and some 3 radii away (the
        // one-ray path). Directions are f32 values, so the f64 and f32 fan queries trace the
        // same rays.
        let (mut fan_hits, mut fan_rays) = (0, 0);
        for f in 0..60 {
            let dist = [1.0, 1.0, 1.0, 0.5, 3.0][f % 5];
            let o = s.center + dist * s.radius * rng.dir();
            let fan32: Vec<[f32; 3]> = (0..1000)
                .map(|_| {
                    let d = rng.dir();
                    let d = if d.dot(s.center - o) < 0.0 { -d } else { d };
                    d.as_vec3().to_array()
                })
                .collect();
            let fan: Vec<DVec3> = fan32
                .iter()
                .map(|d| DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64))
                .collect();
            let mut hit = vec![false; fan.len()];
            bvh.occluded_fan(o, &fan, tmin, &mut hit);
            let mut hit32 = vec![false; fan.len()];
            bvh.occluded_fan_f32(o, &fan32, tmin, &mut hit32);
            for ((d, h), h32) in fan.iter().zip(&hit).zip(&hit32) {
                let one = bvh.occluded(o, *d, tmin, f64::INFINITY);
                assert_eq!(*h, one, "{level:?} fan from {dist} radii");
                assert_eq!(*h32, one, "{level:?} f32 fan from {dist} radii");
                fan_hits += usize::from(*h);
                fan_rays += 1;
            }
        }
        println!("{level:?}: {hits}/5000 random and {fan_hits}/{fan_rays} fan rays occluded");
        assert!(
            hits > 500 && fan_hits > 5000,
            "too few hits to test anything"
        );
    }
}
