//! Deformers: deterministic functions of a time parameter `t` that rewrite positions only
//! (topology fixed), applied to a rest pose. Each maps every vertex on its own, in parallel over
//! chunks of [`CHUNK`] vertices (the same values on any number of threads).

use crate::mesh::Mesh;
use crate::ray::UpdateStrategy;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Vertices per parallel task of a deformer: a mesh of at most this many is posed on the
/// calling thread (a task costs a few microseconds to hand over).
pub const CHUNK: usize = 2048;

/// `out[i] = f(rest[i])` for every vertex, in parallel chunks.
fn per_vertex(rest: &[DVec3], out: &mut [DVec3], f: impl Fn(DVec3) -> DVec3 + Sync) {
    (out.par_chunks_mut(CHUNK))
        .zip(rest.par_chunks(CHUNK))
        .for_each(|(o, r)| {
            for (o, p) in o.iter_mut().zip(r) {
                *o = f(*p);
            }
        });
}

/// The deformers of this module, for choosing how a BVH follows them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeformerKind {
    Bend,
    Twist,
    Morph,
    Flap,
}

impl DeformerKind {
    /// The BVH update strategy measured to be faster per frame (update + the BSV ray workload,
    /// `cargo bench -p shscale-field -- frame_update`, docs/BENCHMARKS.md): refitting keeps the
    /// old tree topology, which stays good under small or local motion (egg morph: 10.3 vs 12.7 ms;
    /// bird flap: equal) but degrades badly under large shear (sponge bend: 36 vs 20 ms; twist:
    /// 174 vs 22 ms), where rebuilding pays for itself — but not every frame: under bending and
    /// twisting the tree is refitted until its boxes have grown by `REBUILD_GROWTH`
    /// ([`UpdateStrategy::Adaptive`]; Table 1 sponge: 1.7 ms of BVH update per frame instead of
    /// 6–7 ms, the rays as fast, docs/BENCHMARKS.md).
    pub fn preferred_update(self) -> UpdateStrategy {
        match self {
            DeformerKind::Morph | DeformerKind::Flap => UpdateStrategy::Refit,
            DeformerKind::Bend | DeformerKind::Twist => UpdateStrategy::Adaptive,
        }
    }
}

/// Bend about the z axis: a point at `x` along the bend axis is rotated in the x–y... plane by
/// angle `κ·x` around the centre of curvature at `y = 1/κ`, with `κ = max_curvature · sin(πt)`
/// (t ∈ [0, 1] bends and straightens). The papers' bending plane and sponge.
pub fn bend(rest: &Mesh, out: &mut Mesh, max_curvature: f64, t: f64) {
    let k = bend_curvature(max_curvature, t);
    per_vertex(&rest.positions, &mut out.positions, |p| {
        if k.abs() < 1e-12 {
            p
        } else {
            // Map x ↦ angle κx on a circle of radius 1/κ − z (z is the thickness offset).
            let (s, c) = (k * p.x).sin_cos();
            let r = 1.0 / k - p.z;
            DVec3::new(r * s, p.y, 1.0 / k - r * c)
        }
    });
}

/// Twist about the z axis by `max_turns · 2π · sin(πt) · z / h` (h = half height of the rest pose).
pub fn twist(rest: &Mesh, out: &mut Mesh, max_turns: f64, t: f64) {
    // The maximum is exact, so the parallel reduction gives the serial value.
    twist_about(rest, out, max_turns, twist_height(rest), t)
}

/// [`twist`] about a given half height `h > 0`.
pub(crate) fn twist_about(rest: &Mesh, out: &mut Mesh, max_turns: f64, h: f64, t: f64) {
    let a = twist_angle(max_turns, t);
    per_vertex(&rest.positions, &mut out.positions, |p| {
        let (s, c) = (a * p.z / h).sin_cos();
        DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z)
    });
}

/// Morph between two poses of the same topology: `(1 − w) a + w b`, `w = (1 − cos 2πt)/2`.
pub fn morph(a: &Mesh, b: &Mesh, out: &mut Mesh, t: f64) {
    assert_eq!(
        a.positions.len(),
        b.positions.len(),
        "morph targets differ in vertex count"
    );
    let w = morph_weight(t);
    (out.positions.par_chunks_mut(CHUNK))
        .zip(a.positions.par_chunks(CHUNK))
        .zip(b.positions.par_chunks(CHUNK))
        .for_each(|((o, p), q)| {
            for ((o, p), q) in o.iter_mut().zip(p).zip(q) {
                *o = *p * (1.0 - w) + *q * w;
            }
        });
}

/// Flap wings: vertices with `|y| > y0` rotate about the x axis (through `y = ±y0`) by
/// `amplitude · sin(2πt)` times a smooth span weight, so the wing bends as it flaps.
pub fn flap(rest: &Mesh, out: &mut Mesh, y0: f64, amplitude: f64, t: f64) {
    let a = flap_angle(amplitude, t);
    per_vertex(&rest.positions, &mut out.positions, |p| {
        let d = p.y.abs() - y0;
        if d <= 0.0 {
            p
        } else {
            let ang = a * (1.0 - (-d).exp()) * p.y.signum();
            let (s, c) = ang.sin_cos();
            let (yy, zz) = (p.y - p.y.signum() * y0, p.z);
            DVec3::new(p.x, p.y.signum() * y0 + c * yy - s * zz, s * yy + c * zz)
        }
    });
}

/// The bend's curvature at time `t`: `κ = max_curvature · sin(πt)`.
pub(crate) fn bend_curvature(max_curvature: f64, t: f64) -> f64 {
    max_curvature * (PI * t).sin()
}

/// The twist's half height `h`: the rest pose's largest `|z|` (at least 1e-12).
pub fn twist_height(rest: &Mesh) -> f64 {
    // The maximum is exact, so the parallel reduction gives the serial value.
    (rest.positions.par_iter().with_min_len(CHUNK))
        .map(|p| p.z.abs())
        .reduce(|| 1e-12, f64::max)
}

/// The twist's angle at `z = h` at time `t`: `max_turns · 2π · sin(πt)`.
pub(crate) fn twist_angle(max_turns: f64, t: f64) -> f64 {
    max_turns * 2.0 * PI * (PI * t).sin()
}

/// The morph's weight of the second pose at time `t`: `(1 − cos 2πt)/2`.
pub(crate) fn morph_weight(t: f64) -> f64 {
    0.5 * (1.0 - (2.0 * PI * t).cos())
}

/// The flap's amplitude at time `t`: `amplitude · sin(2πt)`.
pub(crate) fn flap_angle(amplitude: f64, t: f64) -> f64 {
    amplitude * (2.0 * PI * t).sin()
}

/// A deformer with its parameters: what posing a frame applies on the host ([`Self::apply`]),
/// and what a device needs to apply the same map (each kind's per-frame scalar, [`Self::scalar`],
/// and its constant, [`Self::constant`]).
#[derive(Clone, Debug)]
pub enum Deformer {
    /// [`bend`] with this maximal curvature.
    Bend { max_curvature: f64 },
    /// [`twist`] with these maximal turns about the rest pose's half height `h`.
    Twist { max_turns: f64, h: f64 },
    /// [`morph`] from the rest pose to this target (same vertex count).
    Morph { target: Mesh },
    /// [`flap`] about `|y| = y0` with this amplitude.
    Flap { y0: f64, amplitude: f64 },
}

impl Deformer {
    /// Which of the four.
    pub fn kind(&self) -> DeformerKind {
        match self {
            Deformer::Bend { .. } => DeformerKind::Bend,
            Deformer::Twist { .. } => DeformerKind::Twist,
            Deformer::Morph { .. } => DeformerKind::Morph,
            Deformer::Flap { .. } => DeformerKind::Flap,
        }
    }

    /// Pose `rest` at time `t` into `out` (same topology).
    pub fn apply(&self, rest: &Mesh, t: f64, out: &mut Mesh) {
        match self {
            Deformer::Bend { max_curvature } => bend(rest, out, *max_curvature, t),
            Deformer::Twist { max_turns, h } => twist_about(rest, out, *max_turns, *h, t),
            Deformer::Morph { target } => morph(rest, target, out, t),
            Deformer::Flap { y0, amplitude } => flap(rest, out, *y0, *amplitude, t),
        }
    }

    /// The frame's one scalar: the bend's curvature κ, the twist's angle, the morph's weight,
    /// the flap's angle.
    pub fn scalar(&self, t: f64) -> f64 {
        match self {
            Deformer::Bend { max_curvature } => bend_curvature(*max_curvature, t),
            Deformer::Twist { max_turns, .. } => twist_angle(*max_turns, t),
            Deformer::Morph { .. } => morph_weight(t),
            Deformer::Flap { amplitude, .. } => flap_angle(*amplitude, t),
        }
    }

    /// The deformer's constant: the twist's `h`, the flap's `y0` (0 for the others).
    pub fn constant(&self) -> f64 {
        match self {
            Deformer::Twist { h, .. } => *h,
            Deformer::Flap { y0, .. } => *y0,
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    #[test]
    fn deformers_keep_topology_and_are_deterministic() {
        let rest = shapes::box_block(DVec3::new(1.0, 0.3, 0.1), 6);
        let mut a = rest.clone();
        let mut b = rest.clone();
        for t in [0.0, 0.25, 0.5, 0.9] {
            bend(&rest, &mut a, 1.2, t);
            bend(&rest, &mut b, 1.2, t);
            assert_eq!(a, b);
            assert_eq!(a.triangles, rest.triangles);
            assert!(a.positions.iter().all(|p| p.is_finite()));
        }
        // Bending preserves lengths along the bend axis on the neutral surface (z = 0 row).
        let strip = shapes::plane(2.0, 0.5, 41, 3);
        let mut s = strip.clone();
        bend(&strip, &mut s, 1.5, 0.5);
        let len: f64 = (0..40)
            .map(|i| (s.positions[i + 1] - s.positions[i]).length())
            .sum();
        assert!((len - 2.0).abs() < 1e-3, "arc length {len}");
        bend(&strip, &mut s, 1.5, 0.0);
        assert_eq!(s.positions, strip.positions);
        let bird = shapes::bird();
        let mut f = bird.clone();
        flap(&bird, &mut f, 0.3, 0.8, 0.25);
        assert_eq!(f.triangles, bird.triangles);
        assert!(f
            .positions
            .iter()
            .zip(&bird.positions)
            .any(|(p, q)| (*p - *q).length() > 0.1));
        let egg = shapes::egg(1.0, 0.5, 22, 24);
        let sphere = shapes::uv_sphere(1.0, 22, 24);
        let mut m = egg.clone();
        morph(&egg, &sphere, &mut m, 0.5);
        assert!(m
            .positions
            .iter()
            .zip(&sphere.positions)
            .all(|(p, q)| (*p - *q).length() < 1e-12));
        let mut tw = rest.clone();
        twist(&rest, &mut tw, 0.25, 0.5);
        assert!(tw
            .positions
            .iter()
            .zip(&rest.positions)
            .all(|(p, q)| ((p.x * p.x + p.y * p.y) - (q.x * q.x + q.y * q.y)).abs() < 1e-12));
    }

    /// Above `CHUNK` vertices the deformers run in parallel: one thread and two give the same
    /// positions, bit for bit, for every deformer.
    #[test]
    fn deformers_give_the_same_pose_on_any_number_of_threads() {
        let rest = shapes::box_block(DVec3::new(1.0, 0.5, 0.3), 37);
        assert!(rest.positions.len() > 2 * CHUNK);
        let mut target = rest.clone();
        target.positions.iter_mut().for_each(|p| *p *= 1.3);
        let pose = |threads: usize, which: usize| {
            let mut out = rest.clone();
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| match which {
                    0 => bend(&rest, &mut out, 1.2, 0.3),
                    1 => twist(&rest, &mut out, 0.25, 0.4),
                    2 => morph(&rest, &target, &mut out, 0.3),
                    _ => flap(&rest, &mut out, 0.1, 0.8, 0.2),
                });
            out.positions
        };
        for which in 0..4 {
            let (a, b) = (pose(1, which), pose(2, which));
            assert!(a != rest.positions, "deformer {which} moved nothing");
            assert!(
                a.iter()
                    .zip(&b)
                    .all(|(p, q)| p.to_array().map(f64::to_bits) == q.to_array().map(f64::to_bits)),
                "deformer {which}: 1 and 2 threads differ"
            );
        }
    }
}
