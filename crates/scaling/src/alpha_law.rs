//! The cone angle α by distance (docs/math.md §7): the α that makes the cone model exact for a
//! centred spherical occluder.
//!
//! A solid sphere of radius R at the centre, sampled on a sphere of radius `r_s ≥ R`, occludes at
//! every sample the cap of half-angle `θ₀ = asin(R / r_s)` about the direction to the centre; at
//! distance `d = k r_s` it occludes the cap `θ_e = asin(sin θ₀ / k)`. The cone model's backward
//! map (`V_k(θ) = V_1(τ_k(θ))`, docs/math.md §2) moves the cap edge from `θ₀` to the angle with
//! `τ_k(θ_e) = θ₀`. Putting `τ_k = atan2(k sinα sinθ, sinα cosθ + (1 − k) cosα sinθ)` equal to θ₀
//! and solving for α gives
//!
//! `tan α = (k − 1) tan θ₀ sin θ_e / (tan θ₀ cos θ_e − k sin θ_e)`,
//!
//! which for a sphere sampled on its own surface (`θ₀ = π/2`, `sin θ_e = 1/k`) is
//! `tan α = (k − 1) tan θ_e = √((k − 1)/(k + 1))`, i.e. **α = ½ arccos(1/k)** — 0 at contact,
//! 30° at k = 2, and 45° (the papers' choice) only as k → ∞.

/// The α (radians) that maps a centred cap of half-angle `theta0` seen from the sampling sphere
/// onto the cap the same sphere subtends at `k` sampling radii: `None` where no sphere fits
/// (`sin θ₀ / k > 1`: the point is inside it), at `k = 1` (every α is exact) and for `θ₀` outside
/// `(0, π/2]`. Valid for `k > 0`, `k ≠ 1`.
pub fn cap_matching_alpha(theta0: f64, k: f64) -> Option<f64> {
    use std::f64::consts::FRAC_PI_2;
    if !(theta0 > 0.0 && theta0 <= FRAC_PI_2 && k.is_finite() && k > 0.0) {
        return None;
    }
    let s = theta0.sin() / k;
    if s > 1.0 || (k - 1.0).abs() < 1e-12 {
        return None;
    }
    let (se, ce) = (s, (1.0 - s * s).sqrt());
    let a = if (FRAC_PI_2 - theta0) < 1e-12 {
        // tan θ₀ → ∞: tan α = (k − 1) tan θ_e.
        ((k - 1.0) * se / ce).atan()
    } else {
        let t0 = theta0.tan();
        ((k - 1.0) * t0 * se / (t0 * ce - k * se)).atan()
    };
    (a > 0.0 && a < FRAC_PI_2).then_some(a)
}

/// The law for a sphere sampled on its own surface: `α = ½ arccos(1/k)` (radians), `k ≥ 1`.
pub fn sphere_alpha(k: f64) -> Option<f64> {
    (k >= 1.0 && k.is_finite()).then(|| 0.5 * (1.0 / k).acos())
}

/// The α of [`crate::TauFamily::ConeFit`] at `k` for the effective cap `theta0`: the law
/// [`cap_matching_alpha`] where it is defined; at `k = 1` (every α maps identically) and where
/// the point is inside the effective sphere (`k < sin θ₀`: the law at `k = sin θ₀`, its limit
/// `tan α = (1 − k) tan θ₀ / k`) a continuous extension; 45° when `θ₀ = π/2` and `k < 1` (a
/// point inside a sphere sampled on itself, where nothing is defined).
pub fn fitted_alpha(theta0: f64, k: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    if let Some(a) = cap_matching_alpha(theta0, k) {
        return a;
    }
    let s = theta0.sin();
    if k < 1.0 && (FRAC_PI_2 - theta0) > 1e-12 && k > 0.0 {
        let kk = k.max(s);
        let a = ((1.0 - kk) * theta0.tan() / kk).atan();
        if a > 0.0 && a < FRAC_PI_2 {
            return a;
        }
    }
    if (k - 1.0).abs() < 1e-12 {
        // Continuous at k = 1 from above: tan α → 0 on the surface sphere, and in general the
        // limit of the law, (k − 1) tan θ₀ sin θ_e / (tan θ₀ cos θ_e − k sin θ_e) → 0.
        return 1e-9;
    }
    FRAC_PI_4
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tau::{AngularScaling, Cone};

    /// Oracle: the cone τ at the returned α maps the exact cap edge θ_e back onto θ₀, for inflated
    /// and on-surface sampling, k below and above 1; the on-surface case equals ½ arccos(1/k).
    #[test]
    fn cap_matching_alpha_makes_the_cone_map_the_cap_edge_exactly() {
        let mut worst = 0f64;
        for theta0 in [0.2, 0.7, 1.2, std::f64::consts::FRAC_PI_2] {
            for k in [0.3, 0.8, 1.05, 1.3, 2.0, 10.0, 1e4] {
                let Some(a) = cap_matching_alpha(theta0, k) else {
                    // No sphere fits (the point is inside it), or it touches the point.
                    assert!(theta0.sin() / k >= 1.0 - 1e-12, "θ₀ {theta0}, k {k}");
                    continue;
                };
                let te = (theta0.sin() / k).asin();
                let tau = Cone::new(k, a).unwrap();
                let err = (tau.tau(te) - theta0).abs();
                worst = worst.max(err);
                assert!(err < 1e-10, "θ₀ {theta0}, k {k}: τ(θ_e) − θ₀ = {err:e}");
                if theta0 == std::f64::consts::FRAC_PI_2 {
                    let law = sphere_alpha(k).unwrap();
                    assert!((a - law).abs() < 1e-12, "k {k}: {a} vs {law}");
                }
            }
        }
        println!("worst |τ(θ_e) − θ₀| = {worst:e}");
        // Limits: 45° as k → ∞, 30° at k = 2, → 0 at contact.
        assert!((sphere_alpha(1e12).unwrap().to_degrees() - 45.0).abs() < 1e-6);
        assert!((sphere_alpha(2.0).unwrap().to_degrees() - 30.0).abs() < 1e-12);
        assert!(sphere_alpha(1.0).unwrap() == 0.0);
        assert!(cap_matching_alpha(0.0, 2.0).is_none());
        assert!(cap_matching_alpha(1.0, 1.0).is_none());
        assert!(cap_matching_alpha(1.0, f64::NAN).is_none());
        // The extension where the law is undefined: at k = 1, inside the effective sphere
        // (continuous with the law at k = sin θ₀), and inside a sphere sampled on itself.
        for theta0 in [0.3, 1.0, std::f64::consts::FRAC_PI_2] {
            for k in [1e-3, 0.2, theta0.sin(), 0.999, 1.0, 1.001, 5.0] {
                let a = fitted_alpha(theta0, k);
                assert!(
                    a > 0.0 && a < std::f64::consts::FRAC_PI_2,
                    "θ₀ {theta0}, k {k}: {a}"
                );
            }
        }
        let (t0, s) = (1.0f64, 1.0f64.sin());
        let inside = fitted_alpha(t0, 0.5 * s);
        let edge = fitted_alpha(t0, s);
        let just_out = fitted_alpha(t0, s * (1.0 + 1e-9));
        // Continuous at k = sin θ₀, with the square-root cusp of θ_e = asin(sin θ₀ / k) there
        // (a step of 1e-9 in k moves α by ~√(2e-9)).
        assert!(
            (inside - edge).abs() < 1e-12 && (edge - just_out).abs() < 1e-4,
            "{inside} {edge} {just_out}"
        );
        assert_eq!(
            fitted_alpha(std::f64::consts::FRAC_PI_2, 0.5),
            std::f64::consts::FRAC_PI_4
        );
    }
}
