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
    /// Visibility SH (entity frame) at `p` into `out` (length N²).
    fn eval(&self, p: DVec3, out: &mut [f64]);
}

impl VisibilityField for Extrapolator<'_> {
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
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        out.copy_from_slice(&self.truth.sample(self.occ, p).coeffs);
    }
}

/// How the shells of a [`FullField`] are spaced between `ρ_min` and `ρ_max`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShellSpacing {
    /// Equal steps in ρ, as Zhou et al. 2005 sample ("at uniform intervals angularly and
    /// radially"); the field is linear in ρ between shells.
    Uniform,
    /// Equal steps in ln ρ (more shells near the object); the field is linear in ln ρ.
    Exp,
}

shscale_names::names!(ShellSpacing { Uniform = "uniform", Exp = "exp" });

/// How a [`FullField`] interpolates between the samples of a shell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldInterp {
    /// Bilinear on the layout's grid (lat-long: in θ and φ, φ periodic, θ clamped to the first
    /// and last row's centres; cube map: on each face, clamped at the face's edge cell centres),
    /// times linear between shells: the eight nearest samples, as Zhou et al. 2005 interpolate
    /// ("trilinearly … from the eight nearest sample points"). Lat-long and cube layouts only.
    Trilinear,
    /// Barycentric on the layout's spherical Delaunay triangulation (any layout), times linear
    /// between shells: six samples.
    Barycentric,
}

shscale_names::names!(FieldInterp { Trilinear = "trilinear", Barycentric = "barycentric" });

impl ShellSpacing {
    /// Parse `uniform` or `exp`.
    pub fn parse(s: &str) -> Result<Self, FieldError> {
        Self::from_name(s).ok_or_else(|| {
            FieldError::Spec(format!("shell spacing {s:?}: expected uniform or exp"))
        })
    }
}

impl FieldInterp {
    /// Parse `trilinear` or `barycentric`.
    pub fn parse(s: &str) -> Result<Self, FieldError> {
        Self::from_name(s).ok_or_else(|| {
            FieldError::Spec(format!(
                "full-field interpolation {s:?}: expected trilinear or barycentric"
            ))
        })
    }
}

/// The construction of a [`FullField`]: `count` shells from `rho_min·r` to `rho_max·r` (radii in
/// bounding radii `r` of the entity), their spacing and the interpolation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shells {
    pub count: usize,
    pub rho_min: f64,
    pub rho_max: f64,
    pub spacing: ShellSpacing,
    pub interp: FieldInterp,
}

impl Shells {
    /// The papers' field (Zhou et al. 2005; the renderer's): 16 shells at uniform radial
    /// intervals over [1, 8]·r, trilinear.
    pub const PAPERS: Shells = Shells {
        count: 16,
        rho_min: 1.0,
        rho_max: 8.0,
        spacing: ShellSpacing::Uniform,
        interp: FieldInterp::Trilinear,
    };

    /// The shell radii (in bounding radii), increasing.
    pub fn radii(&self) -> Vec<f64> {
        let last = (self.count - 1) as f64;
        (0..self.count)
            .map(|i| {
                let t = i as f64 / last;
                match self.spacing {
                    ShellSpacing::Uniform => self.rho_min + (self.rho_max - self.rho_min) * t,
                    ShellSpacing::Exp => self.rho_min * (self.rho_max / self.rho_min).powf(t),
                }
            })
            .collect()
    }

    /// Check the domain: `count ≥ 2`, `1 ≤ rho_min < rho_max < ∞`, and a trilinear field on a
    /// grid layout.
    pub fn check(&self, layout: Layout) -> Result<(), FieldError> {
        if self.count < 2
            || !(self.rho_min >= 1.0 && self.rho_max > self.rho_min && self.rho_max.is_finite())
        {
            return Err(FieldError::Spec(format!(
                "full field: need ≥ 2 shells over 1 ≤ ρ_min < ρ_max < ∞, got {} over [{}, {}]",
                self.count, self.rho_min, self.rho_max
            )));
        }
        if self.interp == FieldInterp::Trilinear && matches!(layout, Layout::Fibonacci { .. }) {
            return Err(FieldError::Spec(format!(
                "full field: trilinear interpolation needs a grid (latlong:RxC or cube:N), not {}; use barycentric",
                layout.name()
            )));
        }
        Ok(())
    }
}

/// Interpolation within a shell.
enum Angular {
    /// The layout's triangulation, shared with every BSV and field of the same directions.
    Tri(std::sync::Arc<SphericalTriangulation>),
    LatLong {
        rows: usize,
        cols: usize,
    },
    Cube {
        n: usize,
    },
}

impl Angular {
    /// Up to four `(sample index, weight)` pairs for the unit direction `u` (weights sum to 1).
    fn weights(&self, u: DVec3) -> ([(usize, f64); 4], usize) {
        let mut w = [(0usize, 0.0f64); 4];
        match *self {
            Angular::Tri(ref t) => {
                for (slot, (v, a)) in w.iter_mut().zip(t.locate(u)) {
                    *slot = (v as usize, a);
                }
                (w, 3)
            }
            Angular::LatLong { rows, cols } => {
                let theta = u.z.clamp(-1.0, 1.0).acos();
                let phi = u.y.atan2(u.x).rem_euclid(std::f64::consts::TAU);
                let (i0, i1, t) =
                    clamped_cell(theta * rows as f64 / std::f64::consts::PI - 0.5, rows);
                let v = phi * cols as f64 / std::f64::consts::TAU - 0.5;
                let vf = v.floor();
                let s = v - vf;
                let j0 = (vf as i64).rem_euclid(cols as i64) as usize;
                let j1 = (j0 + 1) % cols;
                w[0] = (i0 * cols + j0, (1.0 - t) * (1.0 - s));
                w[1] = (i0 * cols + j1, (1.0 - t) * s);
                w[2] = (i1 * cols + j0, t * (1.0 - s));
                w[3] = (i1 * cols + j1, t * s);
                (w, 4)
            }
            Angular::Cube { n } => {
                let a = u.abs();
                let axis = if a.x >= a.y && a.x >= a.z {
                    0
                } else if a.y >= a.z {
                    1
                } else {
                    2
                };
                let c = u.to_array();
                let face = 2 * axis + usize::from(c[axis] < 0.0);
                let m = c[axis].abs();
                let (pa, pb) = (c[(axis + 1) % 3] / m, c[(axis + 2) % 3] / m);
                let cell = |x: f64| clamped_cell((x + 1.0) * n as f64 / 2.0 - 0.5, n);
                let ((a0, a1, s), (b0, b1, t)) = (cell(pa), cell(pb));
                let base = face * n * n;
                w[0] = (base + b0 * n + a0, (1.0 - t) * (1.0 - s));
                w[1] = (base + b0 * n + a1, (1.0 - t) * s);
                w[2] = (base + b1 * n + a0, t * (1.0 - s));
                w[3] = (base + b1 * n + a1, t * s);
                (w, 4)
            }
        }
    }
}

/// Cells `(i0, i1, t)` around the fractional index `x` of `n` cell centres, clamped at both ends.
fn clamped_cell(x: f64, n: usize) -> (usize, usize, f64) {
    let x = x.clamp(0.0, (n - 1) as f64);
    let i0 = (x.floor() as usize).min(n - 1);
    let i1 = (i0 + 1).min(n - 1);
    (i0, i1, if i1 == i0 { 0.0 } else { x - i0 as f64 })
}

/// The fully sampled shadow field (Zhou et al. 2005, "Precomputed shadow fields for dynamic
/// scenes"): the base-sphere layout sampled on concentric shells ([`Shells`]: count, range,
/// spacing, interpolation; the papers' construction is [`Shells::PAPERS`]), each sample the
/// facing hemisphere's visibility. Between shells the field is linear in ρ (uniform spacing) or
/// in ln ρ (exponential). No extrapolation: beyond the outermost shell the entity does not
/// occlude; inside the innermost shell the innermost shell's value is used (clamped).
pub struct FullField {
    sphere: Sphere,
    /// The interpolation coordinate of each shell: ρ (uniform) or ln ρ (exponential).
    coords: Vec<f64>,
    spacing: ShellSpacing,
    rho_max: f64,
    /// `coeffs[shell][sample]`.
    coeffs: Vec<Vec<Vec<f64>>>,
    angular: Angular,
    order: usize,
    /// Rays cast to build it.
    pub rays: usize,
}

impl FullField {
    /// Sample the shells `shells` (domain: [`Shells::check`]).
    pub fn build(
        occ: &dyn Occluder,
        layout: Layout,
        sampler: &VisibilitySampler,
        shells: &Shells,
    ) -> Result<Self, FieldError> {
        shells.check(layout)?;
        let dirs = layout.directions();
        let sphere = occ.bounding_sphere();
        let radii = shells.radii();
        let coeffs: Vec<Vec<Vec<f64>>> = radii
            .iter()
            .map(|rho| {
                let rs = rho * sphere.radius;
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
        let rays = shells.count * dirs.len() * sampler.rays_per_hemisphere();
        Self::from_samples(sphere, layout, shells, coeffs, sampler.order(), rays)
    }

    /// A field from given shell samples `coeffs[shell][sample]` (order `order`, the layout's
    /// sample order) at the radii of `shells`.
    pub fn from_samples(
        sphere: Sphere,
        layout: Layout,
        shells: &Shells,
        coeffs: Vec<Vec<Vec<f64>>>,
        order: usize,
        rays: usize,
    ) -> Result<Self, FieldError> {
        shells.check(layout)?;
        let count = layout.sample_count().unwrap_or(0);
        if coeffs.len() != shells.count
            || coeffs
                .iter()
                .any(|s| s.len() != count || s.iter().any(|c| c.len() != order * order))
        {
            return Err(FieldError::Spec(format!(
                "full field: expected {} shells × {count} samples × {} coefficients",
                shells.count,
                order * order
            )));
        }
        let angular = match (shells.interp, layout) {
            (FieldInterp::Trilinear, Layout::LatLong { rows, cols }) => {
                Angular::LatLong { rows, cols }
            }
            (FieldInterp::Trilinear, Layout::Cube { n }) => Angular::Cube { n },
            _ => Angular::Tri(crate::bsv::triangulation(&layout.directions())?),
        };
        let coords = (shells.radii().into_iter())
            .map(|r| match shells.spacing {
                ShellSpacing::Uniform => r,
                ShellSpacing::Exp => r.ln(),
            })
            .collect();
        Ok(Self {
            sphere,
            coords,
            spacing: shells.spacing,
            rho_max: shells.rho_max,
            coeffs,
            angular,
            order,
            rays,
        })
    }

    /// The same layout and shells about another bounding `sphere`: the interpolation
    /// ([`Self::weights`]) of a field sampled about it. The coefficients are kept; the GPU path
    /// holds a template whose coefficients live on the device and moves it with each frame's
    /// bounding sphere (no re-triangulation of the layout).
    pub fn recentre(&mut self, sphere: Sphere) {
        self.sphere = sphere;
    }

    /// The sphere the shells are about.
    pub fn sphere(&self) -> Sphere {
        self.sphere
    }

    /// Number of shells.
    pub fn shells(&self) -> usize {
        self.coords.len()
    }

    /// Bytes of the stored coefficients (f64).
    pub fn size_bytes(&self) -> usize {
        self.coeffs.iter().map(|s| s.len()).sum::<usize>() * self.order * self.order * 8
    }
}

/// Up to eight `(flat sample index, weight)` pairs and how many are used
/// ([`FullField::weights`]).
pub type FieldWeights = ([(u32, f64); 8], usize);

impl FullField {
    /// The interpolation weights at `p`: up to eight `(flat sample index, weight)` pairs (flat
    /// index `shell × samples + sample`, [`FullField::sample`]) whose weighted sum is the field
    /// there, with how many are used; `None` beyond the outermost shell (with a relative tolerance
    /// of 1e-9, so that a point on it is not pushed out by rounding), where the entity does not
    /// occlude. Inside the innermost shell the innermost shell's values (clamped).
    pub fn weights(&self, p: DVec3) -> Option<FieldWeights> {
        let d = p - self.sphere.center;
        let rho = d.length() / self.sphere.radius;
        if rho > self.rho_max * (1.0 + 1e-9) {
            return None;
        }
        let x = match self.spacing {
            ShellSpacing::Uniform => rho,
            ShellSpacing::Exp => rho.ln(),
        };
        let last = self.coords.len() - 1;
        let (i, t) = if x <= self.coords[0] {
            (0, 0.0)
        } else if x >= self.coords[last] {
            (last - 1, 1.0)
        } else {
            let i = (self.coords.partition_point(|&c| c <= x).max(1) - 1).min(last - 1);
            (
                i,
                (x - self.coords[i]) / (self.coords[i + 1] - self.coords[i]),
            )
        };
        let (w, m) = self.angular.weights(d.normalize());
        let per_shell = self.coeffs[0].len();
        let mut out = [(0u32, 0.0f64); 8];
        let mut n = 0;
        for (shell, ws) in [(i, 1.0 - t), ((i + 1).min(last), t)] {
            if ws == 0.0 {
                continue;
            }
            for &(v, wa) in &w[..m] {
                if wa == 0.0 {
                    continue;
                }
                out[n] = ((shell * per_shell + v) as u32, ws * wa);
                n += 1;
            }
        }
        Some((out, n))
    }

    /// The coefficients of flat sample `i` (`shell × samples + sample`).
    pub fn sample(&self, i: usize) -> &[f64] {
        let per_shell = self.coeffs[0].len();
        &self.coeffs[i / per_shell][i % per_shell]
    }

    /// The SH order of its samples.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Samples in all shells.
    pub fn sample_count(&self) -> usize {
        self.coeffs.len() * self.coeffs[0].len()
    }
}

impl VisibilityField for FullField {
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let Some((w, n)) = self.weights(p) else {
            out[0] = (4.0 * std::f64::consts::PI).sqrt();
            return;
        };
        for &(i, wi) in &w[..n] {
            for (o, c) in out.iter_mut().zip(self.sample(i as usize)) {
                *o += wi * c;
            }
        }
        debug_assert_eq!(out.len(), self.order * self.order);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A field of order 1 whose only coefficient at shell `s`, sample `i` is `f(ρ_s, dir_i)`.
    fn synthetic(layout: Layout, shells: &Shells, f: impl Fn(f64, DVec3) -> f64) -> FullField {
        let dirs = layout.directions();
        let coeffs = (shells.radii().into_iter())
            .map(|rho| dirs.iter().map(|d| vec![f(rho, *d)]).collect())
            .collect();
        let sphere = Sphere {
            center: DVec3::new(0.3, -0.2, 0.1),
            radius: 2.0,
        };
        FullField::from_samples(sphere, layout, shells, coeffs, 1, 0).unwrap()
    }

    fn at(f: &FullField, rho: f64, u: DVec3) -> f64 {
        let mut out = [0.0];
        f.eval(
            f.sphere.center + rho * f.sphere.radius * u.normalize(),
            &mut out,
        );
        out[0]
    }

    #[test]
    fn the_papers_shells_are_uniform_over_one_to_eight_radii() {
        let r = Shells::PAPERS.radii();
        assert_eq!(r.len(), 16);
        assert_eq!((r[0], r[15]), (1.0, 8.0));
        for w in r.windows(2) {
            assert!((w[1] - w[0] - 7.0 / 15.0).abs() < 1e-14, "{w:?}");
        }
        let e = Shells {
            spacing: ShellSpacing::Exp,
            ..Shells::PAPERS
        }
        .radii();
        for w in e.windows(2) {
            assert!(
                ((w[1] / w[0]).ln() - 8f64.ln() / 15.0).abs() < 1e-14,
                "{w:?}"
            );
        }
    }

    #[test]
    fn trilinear_reproduces_every_sample_and_averages_the_eight_around_a_cell_centre() {
        // Oracle: interpolation reproduces the samples at the grid nodes, and at the centre of a
        // grid cell between two shells it is the mean of the eight surrounding samples.
        let f = |rho: f64, d: DVec3| 1.0 + 0.7 * rho + d.x - 2.0 * d.y * d.z + 0.3 * d.z;
        for layout in [Layout::LatLong { rows: 6, cols: 10 }, Layout::Cube { n: 4 }] {
            let shells = Shells {
                count: 5,
                ..Shells::PAPERS
            };
            let ff = synthetic(layout, &shells, f);
            let dirs = layout.directions();
            let mut worst: f64 = 0.0;
            for rho in shells.radii() {
                for d in &dirs {
                    worst = worst.max((at(&ff, rho, *d) - f(rho, *d)).abs());
                }
            }
            println!(
                "{}: largest error at the nodes {worst:.2e} (tolerance 1e-12)",
                layout.name()
            );
            assert!(worst < 1e-12);
            // The cell centre between rows 2–3, columns 4–5 (lat-long) or face 0's cells
            // (1,1)–(2,2) (cube), half-way between shells 1 and 2.
            let (corners, mid): ([usize; 4], DVec3) = match layout {
                Layout::LatLong { cols, .. } => {
                    let (th, ph) = (
                        3.0 * std::f64::consts::PI / 6.0,
                        5.0 * std::f64::consts::TAU / 10.0,
                    );
                    (
                        [2 * cols + 4, 2 * cols + 5, 3 * cols + 4, 3 * cols + 5],
                        DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()),
                    )
                }
                _ => ([5, 6, 9, 10], DVec3::X),
            };
            let r = shells.radii();
            let want = corners
                .iter()
                .map(|&c| 0.5 * (f(r[1], dirs[c]) + f(r[2], dirs[c])))
                .sum::<f64>()
                / 4.0;
            let got = at(&ff, 0.5 * (r[1] + r[2]), mid);
            println!("{}: cell centre {got} vs mean of 8 {want}", layout.name());
            assert!((got - want).abs() < 1e-12);
        }
    }

    #[test]
    fn trilinear_wraps_in_phi_and_clamps_at_the_poles_and_face_edges() {
        // Edges of the grid: between the last and the first column the weights wrap (the mean
        // of the two at the seam); above the first row's centre (toward the pole) θ is clamped,
        // so the field is row 0 interpolated in φ; on a cube face beyond the edge cell centres
        // the value is the edge cell's.
        let f = |_: f64, d: DVec3| 1.0 + d.x + 2.0 * d.y - 0.5 * d.z;
        let shells = Shells {
            count: 2,
            ..Shells::PAPERS
        };
        let (rows, cols) = (6, 10);
        let ll = Layout::LatLong { rows, cols };
        let ff = synthetic(ll, &shells, f);
        let dirs = ll.directions();
        let at_angles =
            |th: f64, ph: f64| DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
        let th = 2.5 * std::f64::consts::PI / rows as f64; // row 2's centre
        let seam = at(&ff, 1.0, at_angles(th, 0.0)); // half-way between columns 9 and 0
        let want = 0.5 * (f(1.0, dirs[2 * cols + cols - 1]) + f(1.0, dirs[2 * cols]));
        assert!((seam - want).abs() < 1e-12, "seam {seam} vs {want}");
        let polar = at(
            &ff,
            1.0,
            at_angles(0.2 * std::f64::consts::PI / rows as f64, 0.0),
        );
        let want = 0.5 * (f(1.0, dirs[cols - 1]) + f(1.0, dirs[0]));
        assert!((polar - want).abs() < 1e-12, "polar cap {polar} vs {want}");
        let cube = Layout::Cube { n: 4 };
        let fc = synthetic(cube, &shells, f);
        let cd = cube.directions();
        // Face 0 (+x), beyond cell (3, 3)'s centre toward the face's corner.
        let corner = at(&fc, 1.0, DVec3::new(1.0, 0.95, 0.95));
        assert!(
            (corner - f(1.0, cd[3 * 4 + 3])).abs() < 1e-12,
            "corner {corner}"
        );
    }

    #[test]
    fn radial_interpolation_is_exact_for_the_spacings_own_coordinate() {
        // Linear in ρ (uniform) or in ln ρ (exp) between shells: exact for a field linear in
        // that coordinate; 0 occlusion beyond the last shell, the first shell's value inside.
        let u = DVec3::new(0.2, 0.5, -0.8);
        for (spacing, g) in [
            (
                ShellSpacing::Uniform,
                (|r: f64| 2.0 - 0.25 * r) as fn(f64) -> f64,
            ),
            (ShellSpacing::Exp, |r: f64| 2.0 - 0.25 * r.ln()),
        ] {
            let shells = Shells {
                count: 4,
                rho_min: 1.2,
                rho_max: 6.0,
                spacing,
                interp: FieldInterp::Trilinear,
            };
            let ff = synthetic(Layout::LatLong { rows: 8, cols: 16 }, &shells, |r, _| g(r));
            for rho in [1.2, 1.7, 2.9, 4.44, 6.0] {
                let e = (at(&ff, rho, u) - g(rho)).abs();
                assert!(e < 1e-12, "{spacing:?} at {rho}: {e}");
            }
            assert!((at(&ff, 1.01, u) - g(1.2)).abs() < 1e-12);
            assert_eq!(at(&ff, 6.01, u), (4.0 * std::f64::consts::PI).sqrt());
        }
    }

    #[test]
    fn a_full_field_outside_its_domain_is_refused() {
        let l = Layout::LatLong { rows: 4, cols: 8 };
        for bad in [
            Shells {
                count: 1,
                ..Shells::PAPERS
            },
            Shells {
                rho_min: 0.9,
                ..Shells::PAPERS
            },
            Shells {
                rho_max: 1.0,
                ..Shells::PAPERS
            },
            Shells {
                rho_max: f64::INFINITY,
                ..Shells::PAPERS
            },
            Shells {
                rho_max: f64::NAN,
                ..Shells::PAPERS
            },
        ] {
            assert!(bad.check(l).is_err(), "{bad:?}");
        }
        let e = Shells::PAPERS
            .check(Layout::Fibonacci { p: 50 })
            .unwrap_err();
        assert!(e.to_string().contains("fib:50"), "{e}");
        assert!(Shells {
            interp: FieldInterp::Barycentric,
            ..Shells::PAPERS
        }
        .check(Layout::Fibonacci { p: 50 })
        .is_ok());
    }
}
