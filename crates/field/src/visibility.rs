//! Visibility sampling at a point by ray casting, projected to SH.
//!
//! Directions: Gauss–Legendre in cosθ × uniform φ over a hemisphere (`H × H`, weights sum to 2π),
//! taken in the point's local frame (z toward the entity centre). The full sphere is two such
//! hemispheres (`2H²` rays). For the hemisphere facing the centre, the back hemisphere is exactly
//! unoccluded for any point on or outside the bounding sphere (the tangent plane separates it from
//! the entity), so it is added in closed form: the cap of half-angle π/2 about the direction away
//! from the centre, `c_l = (−1)^l cap_l(π/2)` rotated onto that axis. Visibility is 1 when the ray
//! escapes. Rays start at `tmin = RAY_EPS · r` (the offset rule of [`shscale_geometry::ray`]).
//! Error: the quadrature integrates the visibility step exactly only where it is aligned with the
//! rings, so coefficient errors are O(1/H) (see the tests for the stated bound).

use crate::frame::LocalFrame;
use glam::DVec3;
use shscale_geometry::{Occluder, RAY_EPS};
use shscale_sh::{cap_zonal, rotate_zonal, DirectionSet, EulerRotator, ShBasis};

/// Per-thread buffers of [`VisibilitySampler::accumulate`].
struct Scratch {
    world: Vec<DVec3>,
    world32: Vec<[f32; 3]>,
    hit: Vec<bool>,
    free: Vec<[f64; 3]>,
    weights: Vec<f64>,
    values: Vec<f64>,
    rotated: Vec<f64>,
}

impl Scratch {
    const fn new() -> Self {
        Self {
            world: Vec::new(),
            world32: Vec::new(),
            hit: Vec::new(),
            free: Vec::new(),
            weights: Vec::new(),
            values: Vec::new(),
            rotated: Vec::new(),
        }
    }
}

/// The frame SH coefficients are expressed in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// The entity's (world) axes, no rotation.
    Entity,
    /// The point's local frame: z toward the entity centre (docs/conventions.md §2).
    Local,
}

shscale_names::names!(Frame { Entity = "entity", Local = "local" });

/// Visibility sampler of one order and hemisphere resolution.
#[derive(Clone, Debug)]
pub struct VisibilitySampler {
    basis: ShBasis<f64>,
    hemi: DirectionSet,
    back_zonal: Vec<f64>,
    /// The local-frame SH of every hemisphere direction and their weighted sum, when the
    /// table fits [`LOCAL_TABLE_VALUES`]: occlusion is then projected by subtracting the
    /// occluded rows from the sum and rotating once ([`VisibilitySampler::facing_hemisphere`]).
    local: Option<LocalTable>,
    rotator: EulerRotator<f64>,
}

/// The most values (`H² · N²`) a sampler tabulates (16 MiB of f64).
pub const LOCAL_TABLE_VALUES: usize = 2 << 20;

#[derive(Clone, Debug)]
struct LocalTable {
    /// `Y(d_i)` for the hemisphere directions about +z, row by row.
    rows: Vec<f64>,
    /// `Σ w_i Y(d_i)`.
    sum: Vec<f64>,
}

impl VisibilitySampler {
    /// Order `N` and hemisphere resolution `H ≥ 1` (`H × H` rays per hemisphere).
    pub fn new(order: usize, h: usize) -> Result<Self, crate::error::FieldError> {
        let basis = ShBasis::new(order)?;
        if h == 0 {
            return Err(crate::error::FieldError::Spec(
                "hemisphere resolution must be ≥ 1".into(),
            ));
        }
        let cap = cap_zonal(order, std::f64::consts::FRAC_PI_2)?;
        let hemi = DirectionSet::gauss_hemisphere(h).in_tiles(h, h);
        let nn = basis.len();
        let local = (h.saturating_mul(h).saturating_mul(nn) <= LOCAL_TABLE_VALUES).then(|| {
            let mut rows = vec![0.0; hemi.len() * nn];
            basis.eval_batch(&hemi.dirs, &mut rows);
            let mut sum = vec![0.0; nn];
            for (y, &w) in rows.chunks_exact(nn).zip(&hemi.weights) {
                sum.iter_mut().zip(y).for_each(|(o, b)| *o += w * b);
            }
            LocalTable { rows, sum }
        });
        Ok(Self {
            basis,
            hemi,
            back_zonal: cap,
            local,
            rotator: EulerRotator::new(order)?,
        })
    }

    /// The order N.
    pub fn order(&self) -> usize {
        self.basis.order()
    }

    /// Rays per hemisphere (`H²`).
    pub fn rays_per_hemisphere(&self) -> usize {
        self.hemi.len()
    }

    /// Project `value(world direction)` over the hemisphere about the local `z` axis (`side` =
    /// +1) or `−z` (−1) into `out`.
    pub(crate) fn accumulate_with(
        &self,
        p_frame: &LocalFrame,
        side: f64,
        frame: Frame,
        out: &mut [f64],
        mut value: impl FnMut(DVec3) -> f64,
    ) {
        let mut y = vec![0.0; out.len()];
        for (d, &w) in self.hemi.dirs.iter().zip(&self.hemi.weights) {
            let local = DVec3::new(d[0], d[1], side * d[2]);
            let world = p_frame.to_world(local);
            let v = value(world);
            if v == 0.0 {
                continue;
            }
            let e = match frame {
                Frame::Entity => world,
                Frame::Local => local,
            };
            self.basis.eval(e.to_array(), &mut y);
            out.iter_mut().zip(&y).for_each(|(o, b)| *o += w * v * b);
        }
    }

    /// The hemisphere's rays from `p` in world directions and their answers (`s.hit`, one fan
    /// query). The directions are kept in `s.world` when `keep_world`; an occluder that traces
    /// in f32 ([`Occluder::fans_in_f32`]) is given them in f32 directly (`s.world32`, the same
    /// values it would round them to).
    #[allow(clippy::too_many_arguments)]
    fn cast(
        &self,
        s: &mut Scratch,
        occ: &dyn Occluder,
        p: DVec3,
        f: &LocalFrame,
        side: f64,
        tmin: f64,
        keep_world: bool,
    ) {
        let n = self.hemi.dirs.len();
        s.hit.clear();
        s.hit.resize(n, false);
        let world = |d: &[f64; 3]| f.to_world(DVec3::new(d[0], d[1], side * d[2]));
        if occ.fans_in_f32() && !keep_world {
            s.world32.resize(n, [0.0; 3]);
            for (w, d) in s.world32.iter_mut().zip(&self.hemi.dirs) {
                *w = world(d).as_vec3().to_array();
            }
            occ.occluded_fan_f32(p, &s.world32, tmin, &mut s.hit);
            return;
        }
        s.world.clear();
        s.world.extend(self.hemi.dirs.iter().map(world));
        occ.occluded_fan(p, &s.world, tmin, &mut s.hit);
    }

    /// The occlusion rays of one hemisphere, all from `p`, in one fan query
    /// ([`Occluder::occluded_fan`]), projected to SH: for the facing hemisphere with a table,
    /// the table's weighted sum minus the occluded rows, rotated once to the entity frame;
    /// otherwise the SH of every escaping direction in batches ([`ShBasis::eval_batch`]),
    /// summed with their weights. Scratch buffers are per thread and reused: no allocation per
    /// sample once a thread has run one.
    fn accumulate(
        &self,
        occ: &dyn Occluder,
        p: DVec3,
        f: &LocalFrame,
        side: f64,
        frame: Frame,
        out: &mut [f64],
    ) {
        thread_local! {
            static SCRATCH: std::cell::RefCell<Scratch> = const { std::cell::RefCell::new(Scratch::new()) };
        }
        let tmin = RAY_EPS * occ.bounding_sphere().radius;
        let nn = out.len();
        if let (Some(t), true) = (&self.local, side > 0.0) {
            // Σ over the escaping rays = the whole hemisphere's sum − the occluded rows, in the
            // local frame; then one rotation to the entity frame.
            SCRATCH.with_borrow_mut(|s| {
                self.cast(s, occ, p, f, side, tmin, false);
                s.values.clear();
                s.values.extend_from_slice(&t.sum);
                for ((y, &w), &h) in t.rows.chunks_exact(nn).zip(&self.hemi.weights).zip(&s.hit) {
                    if h {
                        s.values.iter_mut().zip(y).for_each(|(o, b)| *o -= w * b);
                    }
                }
                match frame {
                    Frame::Local => out.iter_mut().zip(&s.values).for_each(|(o, v)| *o += v),
                    Frame::Entity => {
                        let r = [
                            [f.x.x, f.y.x, f.z.x],
                            [f.x.y, f.y.y, f.z.y],
                            [f.x.z, f.y.z, f.z.z],
                        ];
                        s.rotated.resize(nn, 0.0);
                        self.rotator
                            .apply(&r, &s.values, &mut s.rotated)
                            .expect("lengths agree");
                        out.iter_mut().zip(&s.rotated).for_each(|(o, v)| *o += v);
                    }
                }
            });
            return;
        }
        SCRATCH.with_borrow_mut(|s| {
            self.cast(s, occ, p, f, side, tmin, true);
            s.free.clear();
            s.weights.clear();
            for ((w, &h), (d, &wt)) in s
                .world
                .iter()
                .zip(&s.hit)
                .zip(self.hemi.dirs.iter().zip(&self.hemi.weights))
            {
                if h {
                    continue;
                }
                s.free.push(match frame {
                    Frame::Entity => w.to_array(),
                    Frame::Local => [d[0], d[1], side * d[2]],
                });
                s.weights.push(wt);
            }
            // In chunks that stay in the first-level cache; the buffer is only ever grown, and
            // every value read was written by the batch just before.
            const CHUNK: usize = 64;
            if s.values.len() < CHUNK * nn {
                s.values.resize(CHUNK * nn, 0.0);
            }
            for (dirs, ws) in s.free.chunks(CHUNK).zip(s.weights.chunks(CHUNK)) {
                let vals = &mut s.values[..dirs.len() * nn];
                self.basis.eval_batch(dirs, vals);
                for (y, &w) in vals.chunks_exact(nn).zip(ws) {
                    out.iter_mut().zip(y).for_each(|(o, b)| *o += w * b);
                }
            }
        });
    }

    /// Visibility over the full sphere at `p` (local frame toward the occluder's bounding-sphere
    /// centre); returns the coefficients and the ray count `2H²`.
    pub fn full_sphere(&self, occ: &dyn Occluder, p: DVec3, frame: Frame) -> (Vec<f64>, usize) {
        let c = occ.bounding_sphere().center;
        let f = if (c - p).length() > 0.0 {
            LocalFrame::toward(p, c)
        } else {
            LocalFrame::from_z(DVec3::Z)
        };
        let mut out = vec![0.0; self.basis.len()];
        self.accumulate(occ, p, &f, 1.0, frame, &mut out);
        self.accumulate(occ, p, &f, -1.0, frame, &mut out);
        (out, 2 * self.hemi.len())
    }

    /// Visibility sampled over the hemisphere facing `center` only, the back hemisphere taken as
    /// unoccluded in closed form (valid on or outside the bounding sphere). Returns coefficients
    /// and the ray count `H²`.
    pub fn facing_hemisphere(
        &self,
        occ: &dyn Occluder,
        p: DVec3,
        center: DVec3,
        frame: Frame,
    ) -> (Vec<f64>, usize) {
        let f = LocalFrame::toward(p, center);
        let mut out = vec![0.0; self.basis.len()];
        self.accumulate(occ, p, &f, 1.0, frame, &mut out);
        let axis = match frame {
            Frame::Entity => -f.z,
            Frame::Local => -DVec3::Z,
        };
        let mut back = vec![0.0; out.len()];
        rotate_zonal(&self.basis, &self.back_zonal, axis.to_array(), &mut back)
            .expect("lengths agree");
        out.iter_mut().zip(&back).for_each(|(o, b)| *o += b);
        (out, self.hemi.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shscale_geometry::ray::UpdateStrategy;
    use shscale_geometry::{bundled, MeshBvh};

    /// The table path (hemisphere sum minus occluded rows, one rotation) against the direct
    /// path (SH of every escaping ray): the same coefficients to round-off, in both frames, at
    /// points on and off the bounding sphere. The table path hands the BVH its directions in
    /// f32 (`fans_in_f32`), the direct path in f64: equal coefficients also say that both
    /// casts gave the same answer for every ray.
    #[test]
    fn table_projection_equals_direct_projection() {
        let mesh = bundled::load("bunny").unwrap();
        let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
        let s = bvh.bounding_sphere();
        for (order, h) in [(4, 32), (8, 16), (3, 7)] {
            let table = VisibilitySampler::new(order, h).unwrap();
            assert!(table.local.is_some());
            let mut direct = table.clone();
            direct.local = None;
            let mut worst = 0f64;
            for (i, d) in [DVec3::X, DVec3::new(0.3, -0.8, 0.5).normalize(), -DVec3::Z]
                .into_iter()
                .enumerate()
            {
                let p = s.center + s.radius * (1.0 + 0.5 * i as f64) * d;
                for frame in [Frame::Entity, Frame::Local] {
                    let (a, _) = table.facing_hemisphere(&bvh, p, s.center, frame);
                    let (b, _) = direct.facing_hemisphere(&bvh, p, s.center, frame);
                    for (x, y) in a.iter().zip(&b) {
                        worst = worst.max((x - y).abs());
                    }
                }
            }
            println!("N = {order}, H = {h}: worst difference {worst:e}");
            assert!(worst < 1e-12, "N = {order}, H = {h}: {worst:e}");
        }
    }
}
