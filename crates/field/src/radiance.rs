//! Radiance sampling for emissive meshes (lights; docs/conventions.md §4 "source radiance fields"):
//! `L(ω)` is the emitted radiance of the first surface a ray hits — per-triangle radiance,
//! one-sided (a triangle emits toward the side its counter-clockwise normal faces; a ray hitting
//! its back sees 0) — and 0 on a miss. Sampled like visibility; for a point on or outside the
//! bounding sphere the back hemisphere is exactly 0 (docs/conventions.md §4), so only the facing hemisphere
//! is traced.

use crate::frame::LocalFrame;
use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use shscale_geometry::{Mesh, MeshBvh, Occluder, Sphere, RAY_EPS};

/// A light whose radiance can be sampled along rays: an emissive mesh ([`Emitter`]) or the
/// analytic [`SphereEmitter`].
pub trait Radiant: Sync {
    /// The light's bounding sphere.
    fn bounding_sphere(&self) -> Sphere;
    /// `L` seen from `p` along unit `d`.
    fn radiance_along(&self, p: DVec3, d: DVec3) -> f64;
    /// The exact SH projection (order `order`, entity frame) of the radiance seen from `p`, where
    /// a closed form exists.
    fn exact(&self, _order: usize, _p: DVec3) -> Option<Vec<f64>> {
        None
    }
}

/// A sphere of uniform radiance `radiance` (a Lambertian emitter seen from outside: every ray
/// that hits it sees `radiance`). Seen from `p` at distance `d > R` it fills the cap of
/// half-angle `asin(R/d)` toward its centre, so its SH projection is the cap's, closed form
/// ([`shscale_sh::cap_zonal`] rotated toward the centre) — the analytic emitter of the SRF study.
pub struct SphereEmitter {
    pub sphere: Sphere,
    pub radiance: f64,
}

impl Radiant for SphereEmitter {
    fn bounding_sphere(&self) -> Sphere {
        self.sphere
    }
    fn radiance_along(&self, p: DVec3, d: DVec3) -> f64 {
        let oc = p - self.sphere.center;
        let b = oc.dot(d);
        let c = oc.length_squared() - self.sphere.radius * self.sphere.radius;
        // A hit in front of p (p outside the sphere or on it, within rounding): the ray heads
        // toward the centre (b < 0) and meets the sphere (real roots).
        let r2 = self.sphere.radius * self.sphere.radius;
        if c >= -1e-9 * r2 && b < 0.0 && b * b - c >= 0.0 {
            self.radiance
        } else {
            0.0
        }
    }
    fn exact(&self, order: usize, p: DVec3) -> Option<Vec<f64>> {
        let basis = shscale_sh::ShBasis::<f64>::new(order).ok()?;
        let v = crate::probe::sphere_truth(&basis, &self.sphere, p)?;
        // Radiance = L·(1 − V) for the sphere's visibility V.
        let mut occ = crate::metrics::occlusion(&v);
        occ.iter_mut().for_each(|x| *x *= self.radiance);
        Some(occ)
    }
}

/// An emissive mesh: geometry, a BVH and per-triangle emitted radiance.
pub struct Emitter {
    pub bvh: MeshBvh,
    normals: Vec<DVec3>,
    pub radiance: Vec<f64>,
}

impl Emitter {
    /// `radiance` has one value per triangle (≥ 0, finite).
    pub fn new(
        mesh: &Mesh,
        bvh: MeshBvh,
        radiance: Vec<f64>,
    ) -> Result<Self, crate::error::FieldError> {
        if radiance.len() != mesh.triangles.len() {
            return Err(crate::error::FieldError::Spec(format!(
                "{} radiance values for {} triangles",
                radiance.len(),
                mesh.triangles.len()
            )));
        }
        if let Some(i) = radiance.iter().position(|r| !(r.is_finite() && *r >= 0.0)) {
            return Err(crate::error::FieldError::Spec(format!(
                "triangle {i}: radiance {} must be finite and ≥ 0",
                radiance[i]
            )));
        }
        let normals = (0..mesh.triangles.len())
            .map(|f| {
                let [a, b, c] = mesh.corners(f);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();
        Ok(Self {
            bvh,
            normals,
            radiance,
        })
    }

    /// `L` seen from `p` along unit `d`.
    pub fn radiance_along(&self, p: DVec3, d: DVec3) -> f64 {
        let tmin = RAY_EPS * self.bvh.bounding_sphere().radius;
        match self.bvh.closest_hit_triangle(p, d, tmin, f64::INFINITY) {
            Some((_, tri)) if self.normals[tri].dot(d) < 0.0 => self.radiance[tri],
            _ => 0.0,
        }
    }
}

impl Radiant for Emitter {
    fn bounding_sphere(&self) -> Sphere {
        self.bvh.bounding_sphere()
    }
    fn radiance_along(&self, p: DVec3, d: DVec3) -> f64 {
        Emitter::radiance_along(self, p, d)
    }
}

impl VisibilitySampler {
    /// Radiance over the full sphere at `p` (`2H²` rays), SH coefficients in `frame`.
    pub fn radiance_full_sphere(
        &self,
        e: &dyn Radiant,
        p: DVec3,
        frame: Frame,
    ) -> (Vec<f64>, usize) {
        let c = e.bounding_sphere().center;
        let f = if (c - p).length() > 0.0 {
            LocalFrame::toward(p, c)
        } else {
            LocalFrame::from_z(DVec3::Z)
        };
        let mut out = vec![0.0; self.order() * self.order()];
        for side in [1.0, -1.0] {
            self.accumulate_with(&f, side, frame, &mut out, |w| e.radiance_along(p, w));
        }
        (out, 2 * self.rays_per_hemisphere())
    }

    /// Radiance over the hemisphere facing the emitter's centre only (the back hemisphere is 0 on
    /// or outside the bounding sphere), `H²` rays.
    pub fn radiance_facing(&self, e: &dyn Radiant, p: DVec3, frame: Frame) -> (Vec<f64>, usize) {
        let f = LocalFrame::toward(p, e.bounding_sphere().center);
        let mut out = vec![0.0; self.order() * self.order()];
        self.accumulate_with(&f, 1.0, frame, &mut out, |w| e.radiance_along(p, w));
        (out, self.rays_per_hemisphere())
    }
}
