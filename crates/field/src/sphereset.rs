//! Sphere-set occluders (the occluder model of Ren et al. 2006, "Real-time soft shadows in
//! dynamic scenes using spherical harmonic exponentiation"): an object approximated by S
//! spheres ([`shscale_geometry::partition::fit_spheres`], refitted every frame of a deforming
//! sequence), each sphere's visibility the closed-form cap, the caps multiplied near to far with
//! the truncated SH product ([`crate::subvolume::near_to_far`]), the order in which
//! shadow fields combine occluders. Ren et al. accumulate the spheres' log-visibilities and
//! exponentiate once; that variant is not built here (docs/math.md says why).
//!
//! The visibility of one sphere of radius R, centre c, at a point p with d = |c − p| > R is
//! `√(4π)e₀ − cap(asin(R/d))` about `(c − p)/d` (exact, band-limited to order N by
//! projection, [`crate::probe::sphere_truth`]); for d ≤ R (p inside it) every direction is
//! blocked and the visibility is 0. Cost per receiver: S caps (a zonal projection and a
//! rotation each) and S − 1 products; no rays. Domain: any point; radius 0 occludes nothing.

use crate::evaluator::VisibilityField;
use crate::probe::sphere_truth;
use crate::subvolume::near_to_far;
use glam::DVec3;
use shscale_geometry::Sphere;
use shscale_sh::{GauntTensor, ShBasis};

/// One sphere's closed-form visibility field.
pub struct SphereVisibility<'a> {
    pub sphere: Sphere,
    basis: &'a ShBasis<f64>,
}

impl<'a> SphereVisibility<'a> {
    pub fn new(sphere: Sphere, basis: &'a ShBasis<f64>) -> Self {
        Self { sphere, basis }
    }
}

impl VisibilityField for SphereVisibility<'_> {
    fn name(&self) -> &'static str {
        "sphere"
    }
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        if self.sphere.radius <= 0.0 {
            out[0] = (4.0 * std::f64::consts::PI).sqrt();
            return;
        }
        if let Some(v) = sphere_truth(self.basis, &self.sphere, p) {
            out.copy_from_slice(&v);
        }
    }
}

/// The product of a sphere set's visibilities, near to far by the distance to each centre.
pub struct SphereSetField<'a> {
    spheres: Vec<SphereVisibility<'a>>,
    gaunt: &'a GauntTensor<f64>,
}

impl<'a> SphereSetField<'a> {
    /// At least one sphere; `basis` and `gaunt` of one order.
    pub fn new(spheres: &[Sphere], basis: &'a ShBasis<f64>, gaunt: &'a GauntTensor<f64>) -> Self {
        assert!(!spheres.is_empty(), "a sphere set needs a sphere");
        Self {
            spheres: (spheres.iter())
                .map(|s| SphereVisibility::new(*s, basis))
                .collect(),
            gaunt,
        }
    }

    /// Bytes a frame's set holds (centre and radius per sphere).
    pub fn size_bytes(&self) -> usize {
        self.spheres.len() * 4 * 8
    }
}

impl VisibilityField for SphereSetField<'_> {
    fn name(&self) -> &'static str {
        "sphere-set"
    }
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let fields: Vec<&dyn VisibilityField> = (self.spheres.iter())
            .map(|s| s as &dyn VisibilityField)
            .collect();
        let centers: Vec<DVec3> = self.spheres.iter().map(|s| s.sphere.center).collect();
        near_to_far(self.gaunt, &fields, &centers, p, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The domain's edges: a sphere of radius 0 occludes nothing (exactly the constant 1), a
    /// point on the surface sees exactly the hemisphere's cap (DC `√(4π)/2`), a point inside
    /// sees nothing, and the far limit tends to the constant 1.
    #[test]
    fn sphere_visibility_at_its_edges() {
        let basis = ShBasis::<f64>::new(4).unwrap();
        let one = (4.0 * std::f64::consts::PI).sqrt();
        let mut v = vec![0.0; 16];
        let s = |radius: f64| Sphere {
            center: DVec3::ZERO,
            radius,
        };
        SphereVisibility::new(s(0.0), &basis).eval(DVec3::X, &mut v);
        assert_eq!(v[0], one);
        assert!(v[1..].iter().all(|x| *x == 0.0));
        SphereVisibility::new(s(1.0), &basis).eval(DVec3::X, &mut v);
        println!("on the surface: DC {} (want {})", v[0], one / 2.0);
        assert!((v[0] - one / 2.0).abs() < 1e-12);
        SphereVisibility::new(s(1.0), &basis).eval(0.5 * DVec3::Y, &mut v);
        assert!(v.iter().all(|x| *x == 0.0));
        SphereVisibility::new(s(1.0), &basis).eval(1e6 * DVec3::Z, &mut v);
        // Occluded solid angle 2π(1 − cos asin 1e-6) ≈ π·1e-12.
        assert!((v[0] - one).abs() < 1e-11, "{}", v[0] - one);
        // An empty set is refused by name.
        let gaunt = GauntTensor::<f64>::new(4).unwrap();
        assert!(std::panic::catch_unwind(|| SphereSetField::new(&[], &basis, &gaunt)).is_err());
    }
}
