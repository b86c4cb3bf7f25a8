//! Ray casting against an entity's surface: the [`Occluder`] seam with three implementations
//! compared in tests — [`MeshBvh`] (an 8-wide BVH built from obvhs' binary tree and traversed
//! with SIMD kernels, f32, the production path: [`crate::wide`]),
//! [`BruteForce`] (every triangle, f64 Möller–Trumbore; the oracle) and [`AnalyticSphere`]
//! (exact f64 ray–sphere intersection, for closed-form truth).
//!
//! **Offset rule.** Rays that start on a surface would re-hit it at `t ≈ 0` through round-off
//! (f32 positions carry ~6e-8 relative error, so a hit at distance ≲ 1e-6·r is indistinguishable
//! from the origin's own surface). Every query therefore starts at `tmin = RAY_EPS · r`, `r` the
//! entity's bounding radius: with `RAY_EPS = 1e-4` the smallest accepted hit is ~10³ f32 ulps away.
//! The price: geometry closer than `1e-4·r` to the origin is ignored (a contact gap of 0.01 % of
//! the entity's size), and a grazing ray that leaves a concave surface tangentially may miss a
//! re-entry closer than that.
//!
//! **Scale.** [`MeshBvh`] holds its f32 triangles in the entity's unit frame — `(p − c) / r` for
//! the bounding sphere (c, r) — and maps every ray into it in f64, so a mesh of size 1e20 or
//! 1e-20 is traced exactly like one of size 1 (f32 alone would overflow or lose every digit).
//! A ray whose line misses the bounding ball is answered without traversal, and an origin far
//! outside it is first advanced in f64 to just before the ball, so queries from up to
//! [`MAX_QUERY_DISTANCE`]·r away keep the unit-frame precision (the advanced origin carries a
//! rounding error of ~1e-16 × the distance, 1e-4·r at the limit). Mesh coordinates themselves
//! are bounded by `Mesh::MAX_COORDINATE` (checked when a mesh is built).

use crate::bsphere::Sphere;
use crate::mesh::Mesh;
use crate::wide::{WideBvh, WideRay};
use glam::{DVec3, Vec3A};
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use shscale_sh::simd::Level;
use std::time::Duration;

/// Relative ray start offset: queries start at `t = RAY_EPS · bounding radius`.
pub const RAY_EPS: f64 = 1e-4;

/// The farthest a query point may be from an entity, in bounding radii, for [`MeshBvh`] to keep
/// its precision (see the module documentation); commands refuse points beyond it.
pub const MAX_QUERY_DISTANCE: f64 = 1e12;

/// A fan traced ray by ray through [`Occluder::occluded`], each direction turned into f64 by
/// `f64_dir`: the default fan queries, and the mesh BVH's for origins its fan kernel does not
/// take.
fn fan_ray_by_ray<O: Occluder + ?Sized, D: Copy>(
    occ: &O,
    o: DVec3,
    dirs: &[D],
    f64_dir: impl Fn(D) -> DVec3,
    tmin: f64,
    hit: &mut [bool],
) {
    for (&d, h) in dirs.iter().zip(hit.iter_mut()) {
        *h = occ.occluded(o, f64_dir(d), tmin, f64::INFINITY);
    }
}

/// An f32 direction in f64 (exact).
fn widen(d: [f32; 3]) -> DVec3 {
    DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64)
}

/// An entity's surface as seen by rays.
pub trait Occluder: Send + Sync {
    /// Whether the ray `o + t d` (`d` unit) hits the surface for some `t ∈ (tmin, tmax)`.
    fn occluded(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool;
    /// [`Occluder::occluded`] for many rays from one origin, `t ∈ (tmin, ∞)`: `hit[i]` for
    /// `dirs[i]` (the BSV workload; implementations may share work between the rays).
    fn occluded_fan(&self, o: DVec3, dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        fan_ray_by_ray(self, o, dirs, |d| d, tmin, hit);
    }
    /// [`Occluder::occluded_fan`] with the directions given in f32 (unit vectors), the
    /// precision the mesh BVH traces in: no conversion pass over the fan. By default each
    /// direction is widened to f64 and traced by [`Occluder::occluded`].
    fn occluded_fan_f32(&self, o: DVec3, dirs: &[[f32; 3]], tmin: f64, hit: &mut [bool]) {
        fan_ray_by_ray(self, o, dirs, widen, tmin, hit);
    }
    /// Whether [`Occluder::occluded_fan_f32`] is this occluder's native fan query (it traces in
    /// f32, so callers that can produce f32 directions directly should): `false` by default.
    fn fans_in_f32(&self) -> bool {
        false
    }
    /// [`Occluder::occluded`] for many independent rays, `t ∈ (tmin, ∞)`: `hit[i]` for
    /// `(origins[i], dirs[i])` (implementations may vectorise the set-up of the rays).
    fn occluded_many(&self, origins: &[DVec3], dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        for ((o, d), h) in origins.iter().zip(dirs).zip(hit.iter_mut()) {
            *h = self.occluded(*o, *d, tmin, f64::INFINITY);
        }
    }
    /// The nearest hit distance in `(tmin, tmax)`, if any.
    fn closest_hit(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<f64>;
    /// Minimal enclosing sphere of the surface.
    fn bounding_sphere(&self) -> Sphere;
    /// Euclidean distance from `p` to the surface.
    fn distance_to_surface(&self, p: DVec3) -> f64;
    /// Distance from `p` to the farthest point of the entity (a ball about `p` of this radius
    /// contains it).
    fn farthest_distance(&self, p: DVec3) -> f64;
}

/// How [`MeshBvh::update`] follows a deforming mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateStrategy {
    /// Build the tree again every frame (best traversal; costs a build).
    Rebuild,
    /// Keep the tree and refit its boxes (fast update; traversal degrades as the mesh moves
    /// away from the pose the tree was built for).
    Refit,
    /// Refit, and rebuild once refitting has made the tree's boxes too large: when its
    /// [`relative_area`](crate::wide::WideBvh::relative_area) (the summed surface area of every
    /// box over the root's, the surface-area heuristic's measure of how many boxes a random ray
    /// enters) exceeds that of the last build by more than [`REBUILD_GROWTH`]. For large,
    /// gradual deformations (bending, twisting), where a refit alone degrades and a rebuild
    /// every frame costs more than it saves.
    Adaptive,
}

/// [`UpdateStrategy::Adaptive`] rebuilds once the refitted tree's relative box area has grown
/// by this fraction over the last build's (measured on the Table 1 sponge in
/// docs/BENCHMARKS.md).
pub const REBUILD_GROWTH: f64 = 0.15;

/// Whether [`UpdateStrategy::Adaptive`] rebuilds: the refitted tree's relative area `now`
/// against `built`, that of the last build.
pub fn rebuild_due(now: f64, built: f64) -> bool {
    // A NaN area (a degenerate tree) rebuilds.
    now.is_nan() || built.is_nan() || now > built * (1.0 + REBUILD_GROWTH)
}

/// A BVH over a mesh's triangles, in f32 ([`crate::wide`]).
pub struct MeshBvh {
    /// Triangles in the unit frame `(p − frame.center) / frame.radius`.
    tris: Vec<Triangle>,
    /// The unit frame: the bounding sphere (radius 1 when the mesh is a point).
    frame: UnitFrame,
    accel: WideBvh,
    /// The kernels' instruction set ([`shscale_sh::simd::level`] at build time).
    level: Level,
    strategy: UpdateStrategy,
    /// The tree's relative box area right after its last build ([`UpdateStrategy::Adaptive`]).
    built_area: f64,
    /// Builds since [`MeshBvh::build`] (the first included): how often `Adaptive` rebuilt.
    builds: usize,
    sphere: Sphere,
    mesh_tris: Vec<[u32; 3]>,
    positions: Vec<DVec3>,
}

fn to_tri(m: &Mesh, f: usize, frame: &UnitFrame) -> Triangle {
    let [a, b, c] = m
        .corners(f)
        .map(|p| ((p - frame.center) / frame.radius).as_vec3());
    Triangle {
        v0: Vec3A::from(a),
        v1: Vec3A::from(b),
        v2: Vec3A::from(c),
    }
}

/// The unit frame `(p − center) / radius` of an entity, with the reciprocal radius kept.
#[derive(Clone, Copy, Debug)]
struct UnitFrame {
    center: DVec3,
    radius: f64,
    inv: f64,
}

/// The unit frame of a bounding sphere (a zero or non-finite radius falls back to 1).
fn frame_of(s: Sphere) -> UnitFrame {
    let radius = if s.radius.is_finite() && s.radius > 0.0 {
        s.radius
    } else {
        1.0
    };
    UnitFrame {
        center: s.center,
        radius,
        inv: 1.0 / radius,
    }
}

/// The bounding ball in the unit frame: radius 1 plus a margin for the f32 rounding of the
/// vertices.
const BALL: f64 = 1.0 + 1e-5;

/// A unit-frame ray `o + t d` (`d` unit) against the ball `|x| = BALL`: `|o + t d|² = BALL²` is
/// `t² + 2 b t + c = 0`, with the discriminant `b² − c` computed as `BALL² − |o − b d|²` (the
/// squared distance of the line from the centre), which does not cancel catastrophically for
/// far origins.
#[derive(Clone, Copy)]
struct Ball {
    b: f64,
    c: f64,
    disc: f64,
}

impl Ball {
    #[inline(always)]
    fn of(o: DVec3, d: DVec3) -> Self {
        let b = o.dot(d);
        Self {
            b,
            c: o.length_squared() - BALL * BALL,
            disc: BALL * BALL - (o - b * d).length_squared(),
        }
    }

    /// The origin is outside the ball and the ray moves away from it or passes by (no
    /// short-circuit, so block loops stay branch-free).
    #[inline(always)]
    fn missed(self) -> bool {
        (self.c > 0.0) & ((self.b >= 0.0) | (self.disc <= 0.0))
    }
}

/// A ray in the unit frame, or `None` when its line misses the bounding ball (radius 1 plus a
/// margin for the f32 rounding of the vertices) within `[tmin, tmax]`. Returns the f32 ray and
/// the offset `t0` (unit-frame units) the origin was advanced by.
#[inline]
fn unit_ray(frame: &UnitFrame, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<(WideRay, f64)> {
    let inv = frame.inv;
    let (o, tmin, tmax) = ((o - frame.center) * inv, tmin * inv, tmax * inv);
    let ball = Ball::of(o, d);
    if ball.missed() {
        return None; // outside the ball, moving away or passing by
    }
    let Ball { b, c, disc } = ball;
    // The exit distance −b + √disc is below tmin ⟺ √disc < tmin + b (no square root needed).
    let need = tmin + b;
    if need > 0.0 && disc.max(0.0) < need * need {
        return None; // the ball is left before tmin
    }
    // Advance a far origin to just before the ball (no geometry before it); the entry distance
    // −b − √disc exceeds 4 only for origins more than 4 radii away.
    let t0 = if c > 15.0 {
        let t_enter = -b - disc.max(0.0).sqrt();
        if t_enter > tmax {
            return None;
        }
        if t_enter > 4.0 {
            t_enter - 2.0
        } else {
            0.0
        }
    } else {
        // Entry beyond tmax ⟺ −b − tmax > √disc.
        let over = -b - tmax;
        if over > 0.0 && over * over > disc.max(0.0) {
            return None;
        }
        0.0
    };
    let o = o + t0 * d;
    Some((
        WideRay {
            o: o.as_vec3().to_array(),
            d: d.as_vec3().to_array(),
            tmin: (tmin - t0).max(0.0) as f32,
            tmax: (tmax - t0).min(f32::MAX as f64) as f32,
        },
        t0,
    ))
}

impl MeshBvh {
    /// Build for `mesh` with the given per-frame update strategy.
    pub fn build(mesh: &Mesh, strategy: UpdateStrategy) -> Self {
        let sphere = mesh.bounding_sphere();
        let frame = frame_of(sphere);
        let tris: Vec<Triangle> = (0..mesh.triangles.len())
            .map(|f| to_tri(mesh, f, &frame))
            .collect();
        let accel = Self::make_accel(&tris);
        Self {
            tris,
            frame,
            built_area: accel.relative_area(),
            builds: 1,
            accel,
            level: shscale_sh::simd::level(),
            strategy,
            sphere,
            mesh_tris: mesh.triangles.clone(),
            positions: mesh.positions.clone(),
        }
    }

    fn make_accel(tris: &[Triangle]) -> WideBvh {
        let mut t = Duration::default();
        // Leaves of one triangle: the collapse to the wide tree chooses its own leaves.
        let params = BvhBuildParams {
            max_prims_per_leaf: 1,
            ..BvhBuildParams::fast_build()
        };
        let bvh2 = build_bvh2_from_tris(tris, params, &mut t);
        WideBvh::from_bvh2(&bvh2, tris)
    }

    /// The kernels' instruction set; [`MeshBvh::with_level`] changes it (tests and benchmarks
    /// compare the two paths on one tree).
    pub fn level(&self) -> Level {
        self.level
    }

    /// The same tree traversed with `level` (a level the CPU lacks becomes portable).
    pub fn with_level(mut self, level: Level) -> Self {
        self.level = level.usable();
        self
    }

    /// Follow a deformation of the same mesh (same topology): rebuild or refit.
    pub fn update(&mut self, mesh: &Mesh) {
        assert_eq!(mesh.triangles.len(), self.tris.len(), "topology changed");
        self.sphere = mesh.bounding_sphere();
        self.frame = frame_of(self.sphere);
        let frame = &self.frame;
        (self.tris.par_iter_mut().enumerate().with_min_len(4096))
            .for_each(|(f, t)| *t = to_tri(mesh, f, frame));
        match self.strategy {
            UpdateStrategy::Rebuild => {
                self.accel = Self::make_accel(&self.tris);
                self.builds += 1;
            }
            UpdateStrategy::Refit => self.accel.refit(&self.tris),
            UpdateStrategy::Adaptive => {
                self.accel.refit(&self.tris);
                if rebuild_due(self.accel.relative_area(), self.built_area) {
                    self.accel = Self::make_accel(&self.tris);
                    self.built_area = self.accel.relative_area();
                    self.builds += 1;
                }
            }
        }
        self.positions.clone_from(&mesh.positions);
    }

    /// The shape of the tree.
    pub fn tree_stats(&self) -> crate::wide::TreeStats {
        self.accel.stats()
    }

    /// The update strategy.
    pub fn strategy(&self) -> UpdateStrategy {
        self.strategy
    }

    /// Trees built so far, the first included (with [`UpdateStrategy::Adaptive`]: how often it
    /// chose to rebuild).
    pub fn builds(&self) -> usize {
        self.builds
    }
}

impl Occluder for MeshBvh {
    #[inline]
    fn occluded(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        let Some((ray, _)) = unit_ray(&self.frame, o, d, tmin, tmax) else {
            return false;
        };
        self.accel.occluded(self.level, &ray)
    }

    fn occluded_fan(&self, o: DVec3, dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        let Some(ou) = self.fan_origin(o, tmin) else {
            return fan_ray_by_ray(self, o, dirs, |d| d, tmin, hit);
        };
        thread_local! {
            static DIRS: std::cell::RefCell<Vec<[f32; 3]>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        DIRS.with_borrow_mut(|buf| {
            buf.clear();
            buf.extend(dirs.iter().map(|d| d.as_vec3().to_array()));
            self.fan_unit(ou, buf, tmin, hit);
        });
    }

    fn fans_in_f32(&self) -> bool {
        true
    }

    fn occluded_fan_f32(&self, o: DVec3, dirs: &[[f32; 3]], tmin: f64, hit: &mut [bool]) {
        let Some(ou) = self.fan_origin(o, tmin) else {
            return fan_ray_by_ray(self, o, dirs, widen, tmin, hit);
        };
        self.fan_unit(ou, dirs, tmin, hit);
    }

    fn occluded_many(&self, origins: &[DVec3], dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        // SAFETY (each arm): a level is only held where the CPU has its instructions
        // (`MeshBvh::build` and `with_level` keep only usable levels).
        #[cfg(target_arch = "x86_64")]
        match self.level {
            Level::Avx512 => return unsafe { self.many_avx512(origins, dirs, tmin, hit) },
            Level::Avx2Fma => return unsafe { self.many_avx2(origins, dirs, tmin, hit) },
            Level::Portable => {}
        }
        self.many::<false>(origins, dirs, tmin, hit)
    }

    fn closest_hit(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
        self.closest_hit_triangle(o, d, tmin, tmax).map(|(t, _)| t)
    }

    fn bounding_sphere(&self) -> Sphere {
        self.sphere
    }

    fn distance_to_surface(&self, p: DVec3) -> f64 {
        mesh_distance(&self.positions, &self.mesh_tris, p)
    }
    fn farthest_distance(&self, p: DVec3) -> f64 {
        self.positions
            .iter()
            .map(|v| (*v - p).length())
            .fold(0.0, f64::max)
    }
}

impl MeshBvh {
    /// Any-hit queries for a batch of rays `(origin, unit direction)` in parallel (rayon), all
    /// from `tmin` to infinity: `true` = occluded.
    pub fn occluded_batch(&self, rays: &[(DVec3, DVec3)], tmin: f64) -> Vec<bool> {
        rays.par_iter()
            .with_min_len(256)
            .map(|(o, d)| self.occluded(*o, *d, tmin, f64::INFINITY))
            .collect()
    }

    /// The unit geometric normal of triangle `i` of the mesh (counter-clockwise winding).
    pub fn triangle_normal(&self, i: usize) -> DVec3 {
        let [a, b, c] = self.mesh_tris[i].map(|v| self.positions[v as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Closest hit `(t, triangle index in the mesh)` in `(tmin, tmax)`, if any.
    pub fn closest_hit_triangle(
        &self,
        o: DVec3,
        d: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> Option<(f64, usize)> {
        let (ray, t0) = unit_ray(&self.frame, o, d, tmin, tmax)?;
        let (t, i) = self.accel.closest(self.level, &ray)?;
        Some(((t as f64 + t0) * self.frame.radius, i as usize))
    }
}

impl MeshBvh {
    /// [`Occluder::occluded_many`] in blocks of rays: the unit-frame set-up and the ball test
    /// for the whole block first (straight-line code the compiler vectorises), the survivors
    /// compacted, then traversed one by one. Far origins (more than 4 radii away) take the
    /// one-ray path, which advances them in f64. `F`: the AVX2 + FMA traversal, inlined here.
    #[inline(always)]
    fn many<const F: bool>(&self, origins: &[DVec3], dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        const BLOCK: usize = 64;
        let (c, inv) = (self.frame.center, self.frame.inv);
        let tmin_u = (tmin * inv).max(0.0) as f32;
        let mut keep = [0u8; BLOCK];
        let mut far = [false; BLOCK];
        let mut unit = [[0f32; 3]; BLOCK];
        for ((os, ds), hs) in origins
            .chunks(BLOCK)
            .zip(dirs.chunks(BLOCK))
            .zip(hit.chunks_mut(BLOCK))
        {
            let n = os.len();
            for i in 0..n {
                let o = (os[i] - c) * inv;
                far[i] = o.length_squared() > 16.0;
                keep[i] = u8::from(!Ball::of(o, ds[i]).missed() | far[i]);
                unit[i] = o.as_vec3().to_array();
            }
            let mut idx = [0u8; BLOCK];
            let mut m = 0;
            for i in 0..n {
                idx[m] = i as u8;
                m += usize::from(keep[i]);
                hs[i] = false;
            }
            for &i in &idx[..m] {
                let i = i as usize;
                hs[i] = if far[i] {
                    self.occluded(os[i], ds[i], tmin, f64::INFINITY)
                } else {
                    self.accel.occluded_inline::<F>(&WideRay {
                        o: unit[i],
                        d: ds[i].as_vec3().to_array(),
                        tmin: tmin_u,
                        tmax: f32::MAX,
                    })
                };
            }
        }
    }

    /// The unit-frame origin shared by a fan's rays, or `None` when the fan takes the one-ray
    /// path instead: an origin more than 2 radii from the centre (the one-ray path advances it
    /// in f64 first), or a `tmin` that is not finite in the unit frame.
    fn fan_origin(&self, o: DVec3, tmin: f64) -> Option<[f32; 3]> {
        let s = self.frame.radius;
        let ou = (o - self.frame.center) / s;
        (ou.length_squared() <= 4.0 && (tmin / s).is_finite()).then(|| ou.as_vec3().to_array())
    }

    /// A fan from the unit-frame origin `ou` ([`MeshBvh::fan_origin`]) through the tree.
    fn fan_unit(&self, ou: [f32; 3], dirs: &[[f32; 3]], tmin: f64, hit: &mut [bool]) {
        let tmin = (tmin / self.frame.radius) as f32;
        self.accel
            .occluded_fan(self.level, ou, dirs, tmin, f32::MAX, hit);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2")]
    unsafe fn many_avx2(&self, origins: &[DVec3], dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        self.many::<true>(origins, dirs, tmin, hit)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,avx512f,avx512vl,avx512bw,avx512dq")]
    unsafe fn many_avx512(&self, origins: &[DVec3], dirs: &[DVec3], tmin: f64, hit: &mut [bool]) {
        self.many::<true>(origins, dirs, tmin, hit)
    }
}

/// Brute force over every triangle in f64: the oracle for the BVH.
pub struct BruteForce {
    mesh: Mesh,
    sphere: Sphere,
}

impl BruteForce {
    pub fn new(mesh: &Mesh) -> Self {
        Self {
            mesh: mesh.clone(),
            sphere: mesh.bounding_sphere(),
        }
    }
}

/// Möller–Trumbore in f64: hit distance or `None`. Edges count as hits (closed test).
pub fn intersect_triangle(o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if u < 0.0 || v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(e2.dot(q) * inv)
}

impl Occluder for BruteForce {
    fn occluded(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        self.closest_hit(o, d, tmin, tmax).is_some()
    }
    fn closest_hit(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
        (0..self.mesh.triangles.len())
            .filter_map(|f| intersect_triangle(o, d, self.mesh.corners(f)))
            .filter(|t| *t > tmin && *t < tmax)
            .min_by(f64::total_cmp)
    }
    fn bounding_sphere(&self) -> Sphere {
        self.sphere
    }
    fn distance_to_surface(&self, p: DVec3) -> f64 {
        mesh_distance(&self.mesh.positions, &self.mesh.triangles, p)
    }
    fn farthest_distance(&self, p: DVec3) -> f64 {
        self.mesh
            .positions
            .iter()
            .map(|v| (*v - p).length())
            .fold(0.0, f64::max)
    }
}

/// Closest point on triangle `abc` to `p` (Ericson, *Real-Time Collision Detection*, §5.1.5).
pub(crate) fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Distance from `p` to the nearest triangle (brute force with a bounding-box early-out).
pub(crate) fn mesh_distance(pos: &[DVec3], tris: &[[u32; 3]], p: DVec3) -> f64 {
    let mut best = f64::INFINITY;
    for t in tris {
        let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
        let lo = a.min(b).min(c);
        let hi = a.max(b).max(c);
        let box_d = (lo - p).max(p - hi).max(DVec3::ZERO).length();
        if box_d >= best {
            continue;
        }
        best = best.min((closest_point_on_triangle(p, a, b, c) - p).length());
    }
    best
}

/// The exact sphere `|x − c| = R`, intersected in f64.
#[derive(Clone, Copy, Debug)]
pub struct AnalyticSphere {
    pub sphere: Sphere,
}

impl AnalyticSphere {
    /// The unit sphere at the origin.
    pub fn unit() -> Self {
        Self {
            sphere: Sphere {
                center: DVec3::ZERO,
                radius: 1.0,
            },
        }
    }

    /// Both roots of `|o + t d − c|² = R²` (`d` unit), ascending, computed without cancellation.
    fn roots(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let oc = o - self.sphere.center;
        let b = d.dot(oc);
        // |oc|² − R² as (|oc| − R)(|oc| + R) keeps accuracy for origins on the surface.
        let l = oc.length();
        let c = (l - self.sphere.radius) * (l + self.sphere.radius);
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let q = -b - b.signum() * disc.sqrt();
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q, c / q) };
        Some((t0.min(t1), t0.max(t1)))
    }
}

impl Occluder for AnalyticSphere {
    fn occluded(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        self.closest_hit(o, d, tmin, tmax).is_some()
    }
    fn closest_hit(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
        let (t0, t1) = self.roots(o, d)?;
        [t0, t1].into_iter().find(|t| *t > tmin && *t < tmax)
    }
    fn bounding_sphere(&self) -> Sphere {
        self.sphere
    }
    fn distance_to_surface(&self, p: DVec3) -> f64 {
        ((p - self.sphere.center).length() - self.sphere.radius).abs()
    }
    fn farthest_distance(&self, p: DVec3) -> f64 {
        (p - self.sphere.center).length() + self.sphere.radius
    }
}
