//! Camera renders of a scene, like the papers' figures: a perspective camera (from the scene's
//! `[camera]` table, or a default looking down at the receiver plane) ray-casts the occluders and
//! the receiver plane; the plane is shaded with the irradiance a method computed on the receiver
//! grid (bilinear lookup, Lambertian albedo 0.8: radiance = 0.8 E / π), the occluders with simple
//! diffuse shading under the light's dominant direction (the sun, or +z for a map), on the same
//! exposure. Rays that hit nothing show a flat grey background.

use crate::error::Error;
use crate::render::RenderOutput;
use crate::scene::{Camera, LightSpec, Scene};
use glam::DVec3;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{MeshBvh, Sphere};

enum Shape {
    Mesh(Box<MeshBvh>),
    Ball(Sphere),
}

/// The camera image (row-major, row 0 at the top) of `scene` with the receiver plane shaded by
/// `irradiance` (a render of that scene: one pixel per receiver, row 0 at +y).
pub fn render_camera(
    scene: &Scene,
    irradiance: &RenderOutput,
    cam: &Camera,
) -> Result<Vec<[f32; 3]>, Error> {
    use rayon::prelude::*;
    let shapes: Vec<Shape> = (scene.occluders.iter())
        .map(|o| {
            Ok(if o.mesh == "sphere" {
                Shape::Ball(Sphere {
                    center: o.center,
                    radius: o.radius,
                })
            } else {
                Shape::Mesh(Box::new(MeshBvh::build(
                    &o.placed()?,
                    UpdateStrategy::Rebuild,
                )))
            })
        })
        .collect::<Result<_, Error>>()?;
    let light_dir = match &scene.light {
        LightSpec::Sky { sun_dir, .. } => *sun_dir,
        _ => DVec3::Z,
    };
    let (w, h) = (cam.resolution[0], cam.resolution[1]);
    let fwd = (cam.look_at - cam.position).normalize();
    let right = fwd.cross(DVec3::Z).normalize_or(DVec3::X);
    let up = right.cross(fwd);
    let tan = (cam.fov_deg.to_radians() / 2.0).tan();
    let aspect = w as f64 / h as f64;
    let plane = Plane {
        scene,
        irradiance,
        e_max: (irradiance.pixels.iter().flat_map(|p| p.iter())).fold(0f32, |a, v| a.max(*v))
            as f64,
    };
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % w, k / w);
            let sxp = (2.0 * (i as f64 + 0.5) / w as f64 - 1.0) * tan * aspect;
            let syp = (1.0 - 2.0 * (j as f64 + 0.5) / h as f64) * tan;
            let d = (fwd + sxp * right + syp * up).normalize();
            let o = cam.position;
            let best = nearest_hit(&shapes, o, d);
            // The receiver plane z = c.z, seen from above.
            let cz = scene.receiver_center.z;
            let plane_t = if d.z.abs() > 1e-12 {
                Some((cz - o.z) / d.z).filter(|t| *t > 0.0)
            } else {
                None
            };
            let dark = [0.08 * (ALBEDO * plane.e_max) as f32; 3];
            match (best, plane_t) {
                (Some((t, n)), pt) if pt.is_none_or(|p| t < p) => {
                    let n = if n.dot(d) > 0.0 { -n } else { n };
                    let shade = 0.15 + 0.85 * n.dot(light_dir).max(0.0);
                    let v = (0.7 * ALBEDO * plane.e_max * shade) as f32;
                    [v, v * 0.97, v * 0.92]
                }
                (_, Some(t)) => {
                    let p = o + t * d;
                    plane.radiance(p.x, p.y).unwrap_or(dark)
                }
                _ => dark,
            }
        })
        .collect();
    Ok(pixels)
}

/// The receiver plane's diffuse reflectance over π (albedo 0.8).
const ALBEDO: f64 = 0.8 / std::f64::consts::PI;

/// The nearest occluder hit along `o + t·d` and its normal there.
fn nearest_hit(shapes: &[Shape], o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    let mut best: Option<(f64, DVec3)> = None;
    for s in shapes {
        let hit = match s {
            Shape::Mesh(m) => m
                .closest_hit_triangle(o, d, 1e-9, f64::INFINITY)
                .map(|(t, tri)| (t, m.triangle_normal(tri))),
            Shape::Ball(b) => {
                let oc = o - b.center;
                let bb = oc.dot(d);
                let disc = b.radius * b.radius - (oc - bb * d).length_squared();
                (disc >= 0.0)
                    .then(|| -bb - disc.sqrt())
                    .filter(|t| *t > 0.0)
                    .map(|t| (t, (o + t * d - b.center) / b.radius))
            }
        };
        if let Some((t, n)) = hit {
            if best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, n));
            }
        }
    }
    best
}

/// The receiver plane as the camera sees it: the render's irradiance, bilinearly interpolated.
struct Plane<'a> {
    scene: &'a Scene,
    irradiance: &'a RenderOutput,
    /// The largest irradiance value (the exposure of occluders and background).
    e_max: f64,
}

impl Plane<'_> {
    /// Radiance `ALBEDO · E` at `(x, y)` on the plane; `None` outside the receiver grid.
    fn radiance(&self, x: f64, y: f64) -> Option<[f32; 3]> {
        let (gw, gh) = (self.irradiance.width, self.irradiance.height);
        let [sx, sy] = self.scene.receiver_size;
        let c = self.scene.receiver_center;
        let u = (x - (c.x - sx / 2.0)) / sx * (gw - 1) as f64;
        let v = ((c.y + sy / 2.0) - y) / sy * (gh - 1) as f64;
        if !(0.0..=(gw - 1) as f64).contains(&u) || !(0.0..=(gh - 1) as f64).contains(&v) {
            return None;
        }
        let (i0, j0) = (u.floor() as usize, v.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(gw - 1), (j0 + 1).min(gh - 1));
        let (fu, fv) = (u - i0 as f64, v - j0 as f64);
        let px = |i: usize, j: usize| self.irradiance.pixels[j * gw + i];
        let mut out = [0f32; 3];
        for (ch, o) in out.iter_mut().enumerate() {
            let a = px(i0, j0)[ch] as f64 * (1.0 - fu) + px(i1, j0)[ch] as f64 * fu;
            let b = px(i0, j1)[ch] as f64 * (1.0 - fu) + px(i1, j1)[ch] as f64 * fu;
            *o = ((a * (1.0 - fv) + b * fv) * ALBEDO) as f32;
        }
        Some(out)
    }
}
