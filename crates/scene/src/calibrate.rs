//! How fast this machine casts rays, measured in a fraction of a second, so `--dry-run`'s
//! estimates (fitted on the development VM, `shscale_runner::timing`) can be scaled to the
//! machine that runs them: the bundled bunny's BVH, a fixed seeded batch of occlusion rays from
//! its sampling sphere (the BSV's own workload), cast in parallel on every thread the runs would
//! use, repeated until [`CALIBRATION_SECONDS`] have passed.

use glam::DVec3;
use shscale_field::probe::random_directions;
use shscale_geometry::ray::{MeshBvh, UpdateStrategy};
use std::time::Instant;

/// The least time the calibration casts rays (after one untimed warm-up batch).
pub const CALIBRATION_SECONDS: f64 = 0.12;

/// Rays in one batch: 128 sampling points on 1.1r × 256 directions each.
const POINTS: usize = 128;
const DIRECTIONS: usize = 256;

/// Occlusion rays per second of this machine on the calibration workload (module docs), or
/// `None` if the bundled mesh cannot be read. Takes about [`CALIBRATION_SECONDS`] plus the BVH
/// build (≈ 10 ms).
pub fn rays_per_second() -> Option<f64> {
    let mesh = shscale_geometry::bundled::load("bunny").ok()?;
    let sphere = mesh.bounding_sphere();
    let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
    let origins = random_directions(0x5eed_ca1b, POINTS);
    let dirs = random_directions(0xd1ec_7105, DIRECTIONS);
    let rays: Vec<(DVec3, DVec3)> = (origins.iter())
        .flat_map(|o| {
            let p = sphere.center + *o * (1.1 * sphere.radius);
            dirs.iter().map(move |d| (p, *d))
        })
        .collect();
    let mut hits = bvh
        .occluded_batch(&rays, 0.0)
        .iter()
        .filter(|h| **h)
        .count();
    // The median batch's rate: a batch the VM's neighbours or the scheduler interrupted is an
    // outlier, not the machine's speed.
    let start = Instant::now();
    let mut rates = Vec::new();
    while start.elapsed().as_secs_f64() < CALIBRATION_SECONDS {
        let t = Instant::now();
        hits += bvh
            .occluded_batch(&rays, 0.0)
            .iter()
            .filter(|h| **h)
            .count();
        rates.push(rays.len() as f64 / t.elapsed().as_secs_f64().max(1e-9));
    }
    // Some rays hit (the directions cover the sphere), so the work cannot be optimised away.
    debug_assert!(hits > 0);
    rates.sort_by(f64::total_cmp);
    rates.get(rates.len() / 2).copied()
}
