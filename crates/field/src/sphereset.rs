//! Sphere-set occluders (the occluder model of Ren et al. 2006, "Real-time soft shadows in
//! dynamic scenes using spherical harmonic exponentiation"): an object approximated by S
//! spheres ([`shscale_geometry::partition::fit_spheres`], refitted every frame of a deforming
//! sequence), each sphere's visibility the closed-form cap, the caps multiplied near to far with
//! the truncated SH product ([`crate::subvolume::near_to_far`]), the order in which
//! shadow fields combine occluders — at an internal order M ≥ N when built with a basis and
//! Gaunt tensor of order M, truncated to N once at the end ([`SphereSetField`]). Ren et al.
//! accumulate the spheres' log-visibilities and exponentiate once ([`crate::shexp_ol`]; a
//! pointwise reading is [`crate::shexp::SphereSetLog`]); the exact union of the caps is
//! [`crate::union`] (docs/math.md, "Combining in log space", "The union of the caps", "SH
//! exponentiation").
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

/// The product of a sphere set's visibilities, near to far by the distance to each centre, at
/// the order M of its `basis` and `gaunt` (the internal order), returned truncated to the
/// order N its caller asks for (`out.len() = N²`, N ≤ M). At M = N every product is truncated
/// to N; a larger M keeps the caps' and the partial products' bands up to M and truncates once,
/// at the end — the caps are closed-form at any order, so only the products' cost grows (a
/// sparse Gaunt product at M, about M⁵ terms).
pub struct SphereSetField<'a> {
    spheres: Vec<SphereVisibility<'a>>,
    gaunt: &'a GauntTensor<f64>,
    internal: usize,
}

impl<'a> SphereSetField<'a> {
    /// At least one sphere; `basis` and `gaunt` of one order (the internal order).
    pub fn new(spheres: &[Sphere], basis: &'a ShBasis<f64>, gaunt: &'a GauntTensor<f64>) -> Self {
        assert!(!spheres.is_empty(), "a sphere set needs a sphere");
        assert_eq!(
            basis.order(),
            gaunt.order(),
            "basis and Gaunt tensor of one order"
        );
        Self {
            spheres: (spheres.iter())
                .map(|s| SphereVisibility::new(*s, basis))
                .collect(),
            gaunt,
            internal: basis.order(),
        }
    }

    /// The order the products are computed at.
    pub fn internal_order(&self) -> usize {
        self.internal
    }

    /// Bytes a frame's set holds (centre and radius per sphere).
    pub fn size_bytes(&self) -> usize {
        self.spheres.len() * 4 * 8
    }
}

impl VisibilityField for SphereSetField<'_> {
    /// `out`: N² coefficients, N at most the internal order (its first N² coefficients are the
    /// order-N truncation, the l-major order of docs/conventions.md).
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let fields: Vec<&dyn VisibilityField> = (self.spheres.iter())
            .map(|s| s as &dyn VisibilityField)
            .collect();
        let centers: Vec<DVec3> = self.spheres.iter().map(|s| s.sphere.center).collect();
        let mm = self.internal * self.internal;
        assert!(
            out.len() <= mm,
            "asked for {} coefficients of an order-{} set",
            out.len(),
            self.internal
        );
        if out.len() == mm {
            near_to_far(self.gaunt, &fields, &centers, p, out);
        } else {
            let mut full = vec![0.0; mm];
            near_to_far(self.gaunt, &fields, &centers, p, &mut full);
            out.copy_from_slice(&full[..out.len()]);
        }
    }
}

/// A product quadrature of the sphere: `n` Gauss–Legendre nodes in cos θ × `2n` uniform φ,
/// with the basis at every node (`2n²` directions × N² values).
pub struct QuadratureGrid {
    pub(crate) dirs: Vec<DVec3>,
    pub(crate) w: Vec<f64>,
    /// The basis at every node, `nn` values per node.
    pub(crate) y: Vec<f64>,
    pub(crate) nn: usize,
}

impl QuadratureGrid {
    pub fn new(basis: &ShBasis<f64>, n: usize) -> Self {
        let nn = basis.order() * basis.order();
        let gl = shscale_sh::GaussLegendre::new(n);
        let dphi = std::f64::consts::TAU / (2 * n) as f64;
        let (mut dirs, mut w, mut y) = (Vec::new(), Vec::new(), Vec::new());
        let mut row = vec![0.0; nn];
        for (z, wz) in gl.on(-1.0, 1.0) {
            let sz = (1.0 - z * z).max(0.0).sqrt();
            for j in 0..2 * n {
                let phi = dphi * (j as f64 + 0.5);
                let d = DVec3::new(sz * phi.cos(), sz * phi.sin(), z);
                basis.eval(d.to_array(), &mut row);
                dirs.push(d);
                w.push(wz * dphi);
                y.extend_from_slice(&row);
            }
        }
        Self { dirs, w, y, nn }
    }

    /// Directions in the grid.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// Bytes the grid holds (directions, weights, basis values).
    pub fn size_bytes(&self) -> usize {
        self.dirs.len() * (24 + 8 + self.nn * 8)
    }

    /// Whether the grid is empty (`n` = 0).
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }
}

/// A sphere set's joint visibility projected by quadrature, without the truncated products:
/// at every grid direction the ray from `p` is tested against every sphere (blocked when it
/// meets one, or when `p` lies inside one), and `∫ V Y` is summed. Exact for the set up to the
/// quadrature of an indicator, whose error falls as 1/n at the caps' edges (one sphere at
/// n = 64 against its closed form: see the test). Cost per point: `2n²` × S ray–sphere tests.
/// It separates the set's own error (the occluder model) from the product chain's.
pub struct SphereSetQuadrature<'a> {
    spheres: Vec<Sphere>,
    grid: &'a QuadratureGrid,
}

impl<'a> SphereSetQuadrature<'a> {
    pub fn new(spheres: &[Sphere], grid: &'a QuadratureGrid) -> Self {
        Self {
            spheres: spheres.to_vec(),
            grid,
        }
    }
}

impl VisibilityField for SphereSetQuadrature<'_> {
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let g = self.grid;
        let rel: Vec<(DVec3, f64, f64)> = (self.spheres.iter())
            .filter(|s| s.radius > 0.0)
            .map(|s| {
                let oc = s.center - p;
                (oc, oc.length_squared(), s.radius * s.radius)
            })
            .collect();
        if rel.iter().any(|(_, d2, r2)| d2 < r2) {
            return; // inside a sphere: nothing is visible
        }
        for (i, d) in g.dirs.iter().enumerate() {
            let hit = rel.iter().any(|(oc, d2, r2)| {
                let b = oc.dot(*d);
                b > 0.0 && d2 - b * b < *r2
            });
            if !hit {
                let row = &g.y[i * g.nn..(i + 1) * g.nn];
                out.iter_mut().zip(row).for_each(|(o, y)| *o += g.w[i] * y);
            }
        }
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
        // The quadrature of the set: one sphere against its closed form, and inside it nothing.
        let grid = QuadratureGrid::new(&basis, 64);
        assert_eq!(grid.len(), 2 * 64 * 64);
        let one_sphere = [Sphere {
            center: DVec3::new(0.3, 0.0, 0.0),
            radius: 0.7,
        }];
        let q = SphereSetQuadrature::new(&one_sphere, &grid);
        let p = DVec3::new(1.2, 1.5, -0.4);
        let mut want = vec![0.0; 16];
        SphereVisibility::new(one_sphere[0], &basis).eval(p, &mut want);
        q.eval(p, &mut v);
        let occ = crate::metrics::l2(&crate::metrics::occlusion(&want));
        let err = crate::metrics::l2_diff(&v, &want) / occ;
        println!("one sphere by quadrature (n = 64) against the closed form: {err:.2e}");
        assert!(err < 2e-2, "{err}");
        q.eval(DVec3::new(0.5, 0.1, 0.0), &mut v);
        assert!(v.iter().all(|x| *x == 0.0));
        // An empty set is refused by name.
        let gaunt = GauntTensor::<f64>::new(4).unwrap();
        assert!(std::panic::catch_unwind(|| SphereSetField::new(&[], &basis, &gaunt)).is_err());
    }
}
