//! Procedural shapes with fixed topology: UV sphere, subdivided box ("sponge block"), plane grid,
//! egg, and a procedural bird. Sizes are chosen to match the papers' Table 1 vertex counts where
//! the papers give them.

use crate::mesh::Mesh;
use glam::DVec3;
use std::f64::consts::PI;

/// UV sphere of radius `r` at the origin with `rings ≥ 2` latitude bands and `segments ≥ 3`
/// longitudes (poles are single vertices), outward (counter-clockwise) winding.
pub fn uv_sphere(r: f64, rings: usize, segments: usize) -> Mesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut p = vec![DVec3::new(0.0, 0.0, r)];
    for i in 1..rings {
        let th = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let ph = 2.0 * PI * j as f64 / segments as f64;
            p.push(r * DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()));
        }
    }
    p.push(DVec3::new(0.0, 0.0, -r));
    let s = segments as u32;
    let south = p.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * s + (j % s);
    let mut t = Vec::new();
    for j in 0..s {
        t.push([0, ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..rings as u32 - 1 {
        for j in 0..s {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
    }
    for j in 0..s {
        t.push([
            south,
            ring(rings as u32 - 1, j + 1),
            ring(rings as u32 - 1, j),
        ]);
    }
    Mesh::new(&format!("sphere(r={r},{rings}x{segments})"), p, t, false)
        .expect("valid by construction")
}

/// A plane grid in z = 0 over `[−sx/2, sx/2] × [−sy/2, sy/2]` with `nx × ny` vertices, normal +z.
pub fn plane(sx: f64, sy: f64, nx: usize, ny: usize) -> Mesh {
    let (nx, ny) = (nx.max(2), ny.max(2));
    let mut p = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            p.push(DVec3::new(
                sx * (i as f64 / (nx - 1) as f64 - 0.5),
                sy * (j as f64 / (ny - 1) as f64 - 0.5),
                0.0,
            ));
        }
    }
    let mut t = Vec::new();
    let id = |i: usize, j: usize| (j * nx + i) as u32;
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh::new(&format!("plane({sx}x{sy},{nx}x{ny})"), p, t, false).expect("valid by construction")
}

/// A single square `[−s/2, s/2]²` in z = 0 (two triangles), with normal +z (`up`) or −z — e.g. a
/// one-sided area light, which emits toward its normal.
pub fn quad(size: f64, up: bool) -> Mesh {
    let h = 0.5 * size;
    let p = vec![
        DVec3::new(-h, -h, 0.0),
        DVec3::new(h, -h, 0.0),
        DVec3::new(h, h, 0.0),
        DVec3::new(-h, h, 0.0),
    ];
    let t = if up {
        vec![[0, 1, 2], [0, 2, 3]]
    } else {
        vec![[0, 2, 1], [0, 3, 2]]
    };
    Mesh::new(&format!("quad({size})"), p, t, false).expect("valid by construction")
}

/// A closed box `[−h, h]` (half-extents `h`) whose faces are `n × n` quads each, welded at the
/// edges (the "sponge block"; n = 37 gives ≈ 8.4k vertices as the papers' bending sponge).
pub fn box_block(h: DVec3, n: usize) -> Mesh {
    let n = n.max(1);
    let mut p: Vec<DVec3> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut vid = |q: DVec3, p: &mut Vec<DVec3>| -> u32 {
        let key = (
            (q.x * 1e9).round() as i64,
            (q.y * 1e9).round() as i64,
            (q.z * 1e9).round() as i64,
        );
        *index.entry(key).or_insert_with(|| {
            p.push(q);
            p.len() as u32 - 1
        })
    };
    let mut t = Vec::new();
    // Each face: normal axis k with sign s; u, v the other axes ordered so u × v = s·e_k.
    for (k, s) in [
        (0usize, 1.0f64),
        (0, -1.0),
        (1, 1.0),
        (1, -1.0),
        (2, 1.0),
        (2, -1.0),
    ] {
        let (u, v) = ((k + 1) % 3, (k + 2) % 3);
        let (u, v) = if s > 0.0 { (u, v) } else { (v, u) };
        let mut ids = vec![0u32; (n + 1) * (n + 1)];
        for j in 0..=n {
            for i in 0..=n {
                let mut q = [0.0; 3];
                q[k] = s;
                q[u] = 2.0 * i as f64 / n as f64 - 1.0;
                q[v] = 2.0 * j as f64 / n as f64 - 1.0;
                let q = DVec3::from(q) * h;
                ids[j * (n + 1) + i] = vid(q, &mut p);
            }
        }
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (
                    ids[j * (n + 1) + i],
                    ids[j * (n + 1) + i + 1],
                    ids[(j + 1) * (n + 1) + i],
                    ids[(j + 1) * (n + 1) + i + 1],
                );
                t.push([a, b, d]);
                t.push([a, d, c]);
            }
        }
    }
    Mesh::new(&format!("box({:?},n={n})", h.to_array()), p, t, false)
        .expect("valid by construction")
}

/// A superquadric (superellipsoid) with semi-axes `a`, east-west exponent `e1` (in θ) and
/// north-south exponent `e2` (in φ), on the same UV topology as [`uv_sphere`]:
/// `x = a.x·sgn(sθ cφ)|sθ|^e1 |cφ|^e2`, `y = a.y·sgn(sθ sφ)|sθ|^e1 |sφ|^e2`, `z = a.z·sgn(cθ)|cθ|^e1`
/// (Barr 1981). `e1 = e2 = 1` and equal semi-axes give the sphere.
pub fn superquadric(a: DVec3, e1: f64, e2: f64, rings: usize, segments: usize) -> Mesh {
    let mut m = uv_sphere(1.0, rings, segments);
    let sp = |v: f64, e: f64| v.signum() * v.abs().powf(e);
    for q in &mut m.positions {
        let theta = q.z.clamp(-1.0, 1.0).acos();
        let phi = q.y.atan2(q.x);
        let (st, ct) = theta.sin_cos();
        let (sf, cf) = phi.sin_cos();
        *q = DVec3::new(
            a.x * sp(st, e1) * sp(cf, e2),
            a.y * sp(st, e1) * sp(sf, e2),
            a.z * sp(ct, e1),
        );
    }
    m.name = format!("superquadric({:?},{e1},{e2})", a.to_array());
    m
}

/// An egg: a [`superquadric`] (exponents `1 − e/3`, slightly boxy) of radius `r` whose horizontal
/// radius is tapered by `1 + e·z/r` and whose height is stretched by `1 + e/2` (e = 0 is the
/// sphere). The papers' transforming egg has ~0.5k vertices: 22 rings × 24 segments gives 506.
/// Morph between egg and sphere (same topology) with [`crate::deform::morph`].
pub fn egg(r: f64, e: f64, rings: usize, segments: usize) -> Mesh {
    let mut m = superquadric(
        DVec3::splat(r),
        1.0 - e / 3.0,
        1.0 - e / 3.0,
        rings,
        segments,
    );
    for q in &mut m.positions {
        let s = 1.0 + e * q.z / r;
        *q = DVec3::new(q.x * s, q.y * s, q.z * (1.0 + 0.5 * e));
    }
    m.name = format!("egg(r={r},e={e})");
    m
}

/// A procedural bird (our stand-in for the papers' flying dragon, 1,086 vertices): an ellipsoidal
/// body along x (UV sphere scaled to semi-axes 1 × 0.35 × 0.3, 14 × 24) and two wings, each a
/// closed thin slab (a [`box_block`] with 8 × 8 quads per face, chord tapered) spanning
/// `0.3 < |y| < 2.3`. Wing vertices carry their span coordinate so [`crate::deform::flap`] can
/// rotate them about the body axis. Chosen over flapping the bundled duck because the duck has no
/// wings to separate from the body by a clean rule.
pub fn bird() -> Mesh {
    let mut body = uv_sphere(1.0, 14, 24);
    for q in &mut body.positions {
        *q *= DVec3::new(1.0, 0.35, 0.3);
    }
    let mut p = body.positions.clone();
    let mut t = body.triangles.clone();
    for side in [1.0f64, -1.0] {
        let wing = box_block(DVec3::new(0.45, 1.0, 0.02), 8);
        let base = p.len() as u32;
        for q in &wing.positions {
            // Span from y = 0.3 to 2.3 (taper the chord toward the tip), flipped for the left wing.
            let span = q.y + 1.0; // 0..2
            let chord = 1.0 - 0.5 * span / 2.0;
            p.push(DVec3::new(q.x * chord, side * (0.3 + span), q.z));
        }
        for tri in &wing.triangles {
            let tri = [tri[0] + base, tri[1] + base, tri[2] + base];
            t.push(if side > 0.0 {
                tri
            } else {
                [tri[0], tri[2], tri[1]]
            });
        }
    }
    Mesh::new("bird", p, t, false).expect("valid by construction")
}
