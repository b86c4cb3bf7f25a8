//! Helpers shared by the combination tests (`union.rs`, `shexp.rs`).
#![allow(dead_code)]

use glam::DVec3;
use shscale_field::metrics::{l2, l2_diff, occlusion};
use shscale_geometry::Sphere;

pub fn sphere(c: [f64; 3], r: f64) -> Sphere {
    Sphere {
        center: DVec3::from_array(c),
        radius: r,
    }
}

/// Error relative to the truth's occlusion (the study's `occ_rel_l2`).
pub fn occ_rel(got: &[f64], want: &[f64]) -> f64 {
    l2_diff(got, want) / l2(&occlusion(want)).max(1e-300)
}

/// A seeded xorshift64 stream of uniforms in [0, 1) (reproducible draws, no dependency).
pub struct Uniform(u64);

impl Uniform {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }

    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}
