//! Ray-traced truth at any point (docs/conventions.md §4): the visibility over the full sphere projected to
//! order N (band-limited truth, which isolates the extrapolation error), and a full-resolution
//! lat-long visibility map (for full-frequency shading truth and for images).

use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::{Occluder, RAY_EPS};

/// Band-limited truth: SH coefficients (entity frame) of the visibility at `p`, `2H²` rays.
pub fn band_limited(sampler: &VisibilitySampler, occ: &dyn Occluder, p: DVec3) -> Vec<f64> {
    sampler.full_sphere(occ, p, Frame::Entity).0
}

/// A lat-long visibility map in the entity frame: row 0 at θ = 0 (+z), `width × height` texel
/// centres, 1 = unoccluded. Row-major.
pub fn visibility_map(occ: &dyn Occluder, p: DVec3, width: usize, height: usize) -> Vec<f32> {
    let tmin = RAY_EPS * occ.bounding_sphere().radius;
    (0..width * height)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % width, k / width);
            let theta = std::f64::consts::PI * (j as f64 + 0.5) / height as f64;
            let phi = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / width as f64;
            let d = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            if occ.occluded(p, d, tmin, f64::INFINITY) {
                0.0
            } else {
                1.0
            }
        })
        .collect()
}
