//! Visibility evaluators compared side by side (docs/conventions.md §4; docs/ARCHITECTURE.md (habit 2) — a real seam): the
//! extrapolated field, the fully sampled field of Zhou et al. 2005, and ray-traced truth. Each
//! returns visibility as SH coefficients in the entity frame at any point.

use crate::bsv::Layout;
use crate::delaunay::SphericalTriangulation;
use crate::error::FieldError;
use crate::extrapolate::Extrapolator;
use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::{Occluder, Sphere};
use shscale_scaling::ScalingMatrix;

/// A visibility field around one entity.
pub trait VisibilityField: Sync {
    /// Short name for output (`extrapolated`, `full-field`, `raytraced`).
    fn name(&self) -> &'static str;
    /// Visibility SH (entity frame) at `p` into `out` (length N²).
    fn eval(&self, p: DVec3, out: &mut [f64]);
}

impl VisibilityField for Extrapolator<'_> {
    fn name(&self) -> &'static str {
        "extrapolated"
    }
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let n = self.table.order();
        let mut m = ScalingMatrix::identity(n).expect("valid order");
        Extrapolator::eval(self, p, &mut m, out);
    }
}

/// Ray tracing with the method's Gauss–Legendre rings (band-limited): `2H²` rays per query. The
/// reference of accuracy columns is [`ConvergedTruth`]; this one is kept for comparison.
pub struct RayTraced<'a> {
    pub occ: &'a dyn Occluder,
    pub sampler: &'a VisibilitySampler,
}

impl VisibilityField for RayTraced<'_> {
    fn name(&self) -> &'static str {
        "raytraced"
    }
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let (v, _) = self.sampler.full_sphere(self.occ, p, Frame::Entity);
        out.copy_from_slice(&v);
    }
}

/// Converged ray-traced truth (band-limited): [`crate::truth::TruthSampler`], `4T²` stratified
/// rays per query, drawn from the seed and the query point.
pub struct ConvergedTruth<'a> {
    pub occ: &'a dyn Occluder,
    pub truth: &'a crate::truth::TruthSampler,
}

impl VisibilityField for ConvergedTruth<'_> {
    fn name(&self) -> &'static str {
        "raytraced"
    }
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        out.copy_from_slice(&self.truth.sample(self.occ, p).coeffs);
    }
}

/// The fully sampled shadow field (Zhou et al. 2005, "Precomputed shadow fields for dynamic
/// scenes"): the base-sphere layout sampled on `R` concentric shells with radii exponentially
/// spaced over `[ρ_min r, ρ_max r]` (default 16 shells over [1, 8]), interpolated barycentrically in
/// angle (the layout's spherical Delaunay triangulation) and linearly in `ln ρ` between shells — the
/// "trilinear" interpolation of the shadow-field paper on our layouts. No extrapolation: beyond
/// the outermost shell the entity does not occlude; inside the innermost shell the innermost
/// shell's value is used (clamped).
pub struct FullField {
    sphere: Sphere,
    ln_radii: Vec<f64>,
    /// `coeffs[shell][sample]`.
    coeffs: Vec<Vec<Vec<f64>>>,
    tri: SphericalTriangulation,
    order: usize,
    /// Rays cast to build it.
    pub rays: usize,
}

impl FullField {
    /// Sample `shells ≥ 2` shells with radius factors from `rho_min ≥ 1` to `rho_max > rho_min`.
    pub fn build(
        occ: &dyn Occluder,
        layout: Layout,
        sampler: &VisibilitySampler,
        shells: usize,
        rho_min: f64,
        rho_max: f64,
    ) -> Result<Self, FieldError> {
        if shells < 2 || !(rho_min >= 1.0 && rho_max > rho_min && rho_max.is_finite()) {
            return Err(FieldError::Spec(format!("full field: need ≥ 2 shells over 1 ≤ ρ_min < ρ_max, got {shells} over [{rho_min}, {rho_max}]")));
        }
        let ln_radii: Vec<f64> = (0..shells)
            .map(|i| rho_min.ln() + (rho_max / rho_min).ln() * i as f64 / (shells - 1) as f64)
            .collect();
        let dirs = layout.directions();
        let sphere = occ.bounding_sphere();
        let coeffs: Vec<Vec<Vec<f64>>> = ln_radii
            .iter()
            .map(|lr| {
                let rs = lr.exp() * sphere.radius;
                dirs.par_iter()
                    .map(|&u| {
                        sampler
                            .facing_hemisphere(
                                occ,
                                sphere.center + rs * u,
                                sphere.center,
                                Frame::Entity,
                            )
                            .0
                    })
                    .collect()
            })
            .collect();
        let tri = SphericalTriangulation::new(&dirs).map_err(FieldError::Spec)?;
        Ok(Self {
            sphere,
            ln_radii,
            coeffs,
            tri,
            order: sampler.order(),
            rays: shells * dirs.len() * sampler.rays_per_hemisphere(),
        })
    }

    /// Number of shells.
    pub fn shells(&self) -> usize {
        self.ln_radii.len()
    }
}

impl VisibilityField for FullField {
    fn name(&self) -> &'static str {
        "full-field"
    }
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let d = p - self.sphere.center;
        let rho = d.length() / self.sphere.radius;
        let lr = rho.ln();
        let last = self.ln_radii.len() - 1;
        out.iter_mut().for_each(|o| *o = 0.0);
        if lr > self.ln_radii[last] {
            out[0] = (4.0 * std::f64::consts::PI).sqrt();
            return;
        }
        let (i, t) = if lr <= self.ln_radii[0] {
            (0, 0.0)
        } else {
            let i = (self.ln_radii.partition_point(|&x| x <= lr).max(1) - 1).min(last - 1);
            (
                i,
                (lr - self.ln_radii[i]) / (self.ln_radii[i + 1] - self.ln_radii[i]),
            )
        };
        let w = self.tri.locate(d.normalize());
        for (shell, ws) in [(i, 1.0 - t), ((i + 1).min(last), t)] {
            if ws == 0.0 {
                continue;
            }
            for (v, wa) in w {
                for (o, c) in out.iter_mut().zip(&self.coeffs[shell][v as usize]) {
                    *o += ws * wa * c;
                }
            }
        }
        debug_assert_eq!(out.len(), self.order * self.order);
    }
}
