//! The effective cap of a BSV, which applies the cone-angle law of a centred sphere
//! ([`shscale_scaling::alpha_law`], docs/math.md §7) to any entity.

pub use shscale_scaling::alpha_law::{cap_matching_alpha, fitted_alpha, sphere_alpha};

use crate::bsv::Bsv;
use crate::metrics::facing_occlusion;

/// The effective cap of a BSV: the half-angle θ₀ of the centred cap whose solid angle is the
/// samples' mean occluded solid angle of the facing hemisphere, `Ω̄ = 2π(1 − cos θ₀)`. For the
/// analytic sphere sampled on itself it is π/2; for a small entity far inside the sampling
/// sphere it tends to its angular radius.
pub fn effective_cap_angle(bsv: &Bsv) -> f64 {
    let n = bsv.samples.len().max(1) as f64;
    let f = bsv
        .samples
        .iter()
        .map(|s| facing_occlusion(&s.coeffs).clamp(0.0, 1.0))
        .sum::<f64>()
        / n;
    // Ω̄ / 2π = 1 − cos θ₀.
    (1.0 - f).clamp(-1.0, 1.0).acos()
}
