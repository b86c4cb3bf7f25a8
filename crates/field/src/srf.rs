//! Source radiance fields of local lights (SHS §3.1, TR §4.1 / Appendix A; docs/conventions.md §4): the
//! light's radiance sampled on its bounding sphere and extrapolated with the plain and with the
//! energy-preserving scaling matrix, both compared with ray-traced radiance truth, so the
//! framework reports which variant matches (the papers prescribe energy preservation).

use crate::bsv::{Bsv, BsvSample, Layout};
use crate::error::FieldError;
use crate::extrapolate::Extrapolator;
use crate::metrics::l2_diff;
use crate::radiance::Radiant;
use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use rayon::prelude::*;
use shscale_scaling::{Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily};

/// Per radius: mean relative L2 error of each η variant against ray-traced radiance — the `srf`
/// kind's row as it is (one struct: its CSV columns, in this order).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SrfRow {
    pub radius: f64,
    pub plain_rel_l2: f64,
    pub energy_rel_l2: f64,
    /// The energy-preserving result scaled by `(r_s/d)² = 1/k²` (radiant intensity conserved:
    /// the light's power spread over a sphere of radius d instead of r_s).
    pub energy_r2_rel_l2: f64,
    /// The radiance truth's own error relative to its norm (mean over the probes).
    pub truth_rel_err: f64,
    /// Sample directions whose truth is lit (the errors' denominator).
    pub probes: usize,
    /// `plain`, `energy` or `energy_r2`: the closest variant ([`SrfRow::closest`]).
    pub better: String,
}

impl SrfRow {
    /// The row of radius `rho` from each probe's (plain, energy, energy × 1/k², truth) errors:
    /// their means, and the closest variant.
    fn of(rho: f64, errs: &[(f64, f64, f64, f64)]) -> Self {
        let n = errs.len().max(1) as f64;
        let mut row = SrfRow {
            radius: rho,
            plain_rel_l2: errs.iter().map(|x| x.0).sum::<f64>() / n,
            energy_rel_l2: errs.iter().map(|x| x.1).sum::<f64>() / n,
            energy_r2_rel_l2: errs.iter().map(|x| x.2).sum::<f64>() / n,
            truth_rel_err: errs.iter().map(|x| x.3).sum::<f64>() / n,
            probes: errs.len(),
            better: String::new(),
        };
        row.better = row.closest().into();
        row
    }

    /// `"plain"`, `"energy"` or `"energy_r2"`: the variant with the smallest error.
    pub fn closest(&self) -> &'static str {
        if self.plain_rel_l2 <= self.energy_rel_l2 && self.plain_rel_l2 <= self.energy_r2_rel_l2 {
            "plain"
        } else if self.energy_rel_l2 <= self.energy_r2_rel_l2 {
            "energy"
        } else {
            "energy_r2"
        }
    }
}

/// Sample the light's radiance on its bounding sphere (facing hemisphere, `H²` rays per sample).
pub fn radiance_bsv(
    e: &dyn Radiant,
    layout: Layout,
    sampler: &VisibilitySampler,
    inflate: f64,
) -> Result<Bsv, FieldError> {
    let sphere = e.bounding_sphere();
    let rs = inflate * sphere.radius;
    let samples: Vec<BsvSample> = layout
        .directions()
        .par_iter()
        .map(|&dir| {
            let pos = sphere.center + rs * dir;
            let (coeffs, _) = sampler.radiance_facing(e, pos, Frame::Entity);
            BsvSample {
                dir,
                pos,
                coeffs,
                on_surface: false,
            }
        })
        .collect();
    let rays = samples.len() * sampler.rays_per_hemisphere();
    Bsv::from_samples(layout, sphere, rs, samples, rays)
}

/// Compare the η variants at `radii` (multiples of r, ≥ the sampling radius factor) along every
/// sample direction whose truth is not dark. Truth: the closed form where the light has one
/// ([`Radiant::exact`], own error 0), otherwise the light's radiance projected by the converged
/// stratified quadrature ([`crate::truth::TruthSampler::project`], `4T²` rays, its own error
/// reported), never by the method's rings.
#[allow(clippy::too_many_arguments)]
pub fn compare(
    e: &dyn Radiant,
    layout: Layout,
    order: usize,
    h: usize,
    alpha: f64,
    inflate: f64,
    radii: &[f64],
    truth_res: usize,
) -> Result<Vec<SrfRow>, FieldError> {
    let sampler = VisibilitySampler::new(order, h)?;
    let truth_sampler =
        crate::truth::TruthSampler::new(order, truth_res, crate::truth::DEFAULT_TRUTH_SEED)?;
    let bsv = radiance_bsv(e, layout, &sampler, inflate)?;
    let (kmin, kmax) = srf_k_range(radii, inflate);
    let table = |eta| {
        KTable::build(
            TauFamily::Cone { alpha },
            eta,
            order,
            40,
            kmin,
            kmax,
            Spacing::Exp,
            Interp::Cubic,
        )
        .map_err(FieldError::from)
    };
    let (tp, te) = (table(Eta::Plain)?, table(Eta::Energy)?);
    let (xp, xe) = (
        Extrapolator::for_light(&bsv, &tp),
        Extrapolator::for_light(&bsv, &te),
    );
    let s = bsv.sphere;
    let mut rows = Vec::new();
    for &rho in radii {
        let k = rho * s.radius / bsv.sampling_radius;
        let errs: Vec<(f64, f64, f64, f64)> = bsv
            .samples
            .par_iter()
            .filter_map(|smp| {
                let p = s.center + rho * s.radius * smp.dir;
                let (truth, truth_err) = match e.exact(order, p) {
                    Some(c) => (c, 0.0),
                    None => {
                        let t = truth_sampler.project(p, |d| e.radiance_along(p, d));
                        (t.coeffs, t.error)
                    }
                };
                let norm = crate::metrics::l2(&truth);
                if norm < 1e-12 {
                    return None;
                }
                let mut m = ScalingMatrix::identity(order).expect("valid order");
                let (mut a, mut b) = (vec![0.0; order * order], vec![0.0; order * order]);
                xp.eval(p, &mut m, &mut a);
                xe.eval(p, &mut m, &mut b);
                let c: Vec<f64> = b.iter().map(|x| x / (k * k)).collect();
                Some((
                    l2_diff(&a, &truth) / norm,
                    l2_diff(&b, &truth) / norm,
                    l2_diff(&c, &truth) / norm,
                    truth_err / norm,
                ))
            })
            .collect();
        rows.push(SrfRow::of(rho, &errs));
    }
    Ok(rows)
}

/// The k range of the source radiance tables: the radii over the sampling radius, doubled both
/// ways when they span no range (one radius).
fn srf_k_range(radii: &[f64], inflate: f64) -> (f64, f64) {
    let (kmin, kmax) = radii.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
        (a.min(r / inflate), b.max(r / inflate))
    });
    if kmax / kmin < 1.0 + 1e-9 {
        (kmin / 2.0, kmax * 2.0)
    } else {
        (kmin, kmax)
    }
}

/// The papers' deformable light: a red and a green planar emitter (squares of side `size`) joined
/// at a hinge along the y axis, opened to `hinge` radians between them, both emitting on the
/// inside of the hinge. Returns the mesh and per-triangle (red, green) radiance.
pub fn hinged_light(size: f64, hinge: f64) -> (shscale_geometry::Mesh, Vec<[f64; 3]>) {
    let half = 0.5 * hinge;
    let (s, c) = half.sin_cos();
    // Panel directions in the x–z plane, symmetric about +z.
    let a = DVec3::new(-s, 0.0, c) * size;
    let b = DVec3::new(s, 0.0, c) * size;
    let (y0, y1) = (
        DVec3::new(0.0, -0.5 * size, 0.0),
        DVec3::new(0.0, 0.5 * size, 0.0),
    );
    let p = vec![y0, y1, y0 + a, y1 + a, y0 + b, y1 + b];
    // Winding so normals face into the opening (toward +z between the panels).
    let t = vec![[0, 3, 2], [0, 1, 3], [0, 5, 1], [0, 4, 5]];
    let mesh = shscale_geometry::Mesh::new(&format!("hinged_light({size},{hinge})"), p, t, false)
        .expect("valid by construction");
    (
        mesh,
        vec![
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hinged_panels_face_into_the_opening() {
        let (m, _) = hinged_light(1.0, 100f64.to_radians());
        // The opening is the region above the hinge line between the panels: a point on the +z
        // axis must be on the front side of every triangle.
        let q = DVec3::new(0.0, 0.0, 0.5);
        for f in 0..m.triangles.len() {
            let [a, b, c] = m.corners(f);
            let n = (b - a).cross(c - a);
            assert!(
                n.dot(q - a) > 0.0,
                "triangle {f} faces away from the opening"
            );
        }
    }
}
