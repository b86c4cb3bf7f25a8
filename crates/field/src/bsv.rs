//! Base-sphere visibility (BSV, docs/conventions.md §4): visibility sampled at P points on the entity's
//! bounding sphere (optionally inflated by `s ≥ 1`), over the hemisphere facing the centre at
//! `H × H` directions, projected to order N in the entity frame; on-surface flags (§7); and
//! interpolation at any direction from the centre.
//!
//! Layouts: lat-long θ×φ cell centres (`latlong:12x20`, the TR's GPU layout), cube faces
//! (`cube:8`: 6·8·8 cell centres of the cube map projected to the sphere, the paper's layout),
//! Fibonacci (`fib:P`). All three are interpolated on the spherical Delaunay triangulation of their
//! sample directions ([`crate::delaunay`]) — one interpolation path for every layout, so layouts
//! are compared on their sample placement alone (a deliberate simplification: bilinear
//! interpolation on the lat-long and cube grids is not implemented).

use crate::delaunay::SphericalTriangulation;
use crate::error::FieldError;
use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::{Occluder, Sphere};

/// Placement of the base-sphere samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// `rows × cols` θ×φ cell centres.
    LatLong { rows: usize, cols: usize },
    /// `6 × n × n` cube-face cell centres.
    Cube { n: usize },
    /// `p` Fibonacci-lattice points.
    Fibonacci { p: usize },
}

impl Layout {
    /// Parse `latlong:RxC`, `cube:N` or `fib:P`.
    pub fn parse(s: &str) -> Result<Self, FieldError> {
        let bad = || {
            FieldError::Spec(format!(
                "layout {s:?}: expected latlong:RxC, cube:N or fib:P"
            ))
        };
        let (kind, arg) = s.split_once(':').ok_or_else(bad)?;
        let num = |t: &str| {
            t.trim()
                .parse::<usize>()
                .ok()
                .filter(|v| *v > 0)
                .ok_or_else(bad)
        };
        let l = match kind.trim() {
            "latlong" => {
                let (r, c) = arg.split_once('x').ok_or_else(bad)?;
                Layout::LatLong {
                    rows: num(r)?,
                    cols: num(c)?,
                }
            }
            "cube" => Layout::Cube { n: num(arg)? },
            "fib" => Layout::Fibonacci { p: num(arg)? },
            _ => return Err(bad()),
        };
        let count = l.sample_count();
        if count.is_none_or(|c| c > Self::MAX_SAMPLES) {
            return Err(FieldError::Spec(format!(
                "layout {s:?} has {} samples, more than the limit {}",
                count.map_or("too many".to_string(), |c| c.to_string()),
                Self::MAX_SAMPLES
            )));
        }
        if count.is_some_and(|c| c < 4) {
            return Err(FieldError::Spec(format!(
                "layout {s:?} has fewer than 4 samples"
            )));
        }
        Ok(l)
    }

    /// The most base-sphere samples a layout may have (checked by [`Layout::parse`] before any
    /// allocation): 10⁶, about 4000× the TR's 12×20.
    pub(crate) const MAX_SAMPLES: usize = 1_000_000;

    /// The number of samples, without building them (`None` on overflow).
    pub fn sample_count(&self) -> Option<usize> {
        match *self {
            Layout::LatLong { rows, cols } => rows.checked_mul(cols),
            Layout::Cube { n } => n.checked_mul(n)?.checked_mul(6),
            Layout::Fibonacci { p } => Some(p),
        }
    }

    /// Unit directions (from the centre) of the samples.
    pub fn directions(&self) -> Vec<DVec3> {
        match *self {
            Layout::LatLong { rows, cols } => shscale_sh::DirectionSet::latlong(rows, cols)
                .dirs
                .iter()
                .map(|d| DVec3::from_array(*d))
                .collect(),
            Layout::Fibonacci { p } => shscale_sh::DirectionSet::fibonacci_sphere(p)
                .dirs
                .iter()
                .map(|d| DVec3::from_array(*d))
                .collect(),
            Layout::Cube { n } => {
                let mut v = Vec::with_capacity(6 * n * n);
                for axis in 0..3 {
                    for sign in [1.0, -1.0] {
                        for j in 0..n {
                            for i in 0..n {
                                let (a, b) = (
                                    2.0 * (i as f64 + 0.5) / n as f64 - 1.0,
                                    2.0 * (j as f64 + 0.5) / n as f64 - 1.0,
                                );
                                let mut q = [0.0; 3];
                                q[axis] = sign;
                                q[(axis + 1) % 3] = a;
                                q[(axis + 2) % 3] = b;
                                v.push(DVec3::from_array(q).normalize());
                            }
                        }
                    }
                }
                v
            }
        }
    }

    /// Canonical string form (as parsed).
    pub fn name(&self) -> String {
        match *self {
            Layout::LatLong { rows, cols } => format!("latlong:{rows}x{cols}"),
            Layout::Cube { n } => format!("cube:{n}"),
            Layout::Fibonacci { p } => format!("fib:{p}"),
        }
    }
}

/// One base-sphere sample.
#[derive(Clone, Debug, PartialEq)]
pub struct BsvSample {
    /// Unit direction from the centre.
    pub dir: DVec3,
    /// Sample position `c + s·r·dir`.
    pub pos: DVec3,
    /// Visibility coefficients (entity frame), order N.
    pub coeffs: Vec<f64>,
    /// Distance from the sample to the surface is below `ε·r` (docs/conventions.md §7).
    pub on_surface: bool,
}

/// Base-sphere visibility of one entity at one instant.
#[derive(Clone, Debug)]
pub struct Bsv {
    pub layout: Layout,
    pub sphere: Sphere,
    /// The sampling sphere's radius `s·r`.
    pub sampling_radius: f64,
    pub samples: Vec<BsvSample>,
    /// Rays cast, the radial search's included.
    pub rays: usize,
    /// Per-sample radii (`pos = c + radius·dir`) when the samples were placed by a [`RadialRule`] other
    /// than [`RadialRule::Uniform`]; empty when every sample lies on the sampling sphere.
    pub radii: Vec<f64>,
    tri: std::sync::Arc<SphericalTriangulation>,
}

/// Where each base-sphere sample lies along its direction (the papers' future work, TR §6:
/// "sampling at different radial distances for different (θ, ϕ) directions according to certain
/// geometric criteria"). The search starts on the sampling sphere `s·r` and moves a sample
/// outward only; the chosen radius is stored and the extrapolation uses `k = d / r(q)`, `r(q)`
/// interpolated with the same barycentric weights as the coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RadialRule {
    /// Every sample on the sampling sphere (the papers).
    Uniform,
    /// The smallest radius `t ≥ s·r` at which the sample is at least `δ·r` from the surface.
    /// For `t > r` the distance to any point of the bounding ball grows strictly with `t`, so
    /// the distance is monotone along the search and bisection finds the radius; it is at most
    /// `(1 + δ)·r` (where the distance is at least `t − r`). Cost: distance queries, no rays.
    /// Domain: `0 ≤ δ ≤ 10`.
    Clearance { delta: f64 },
    /// The smallest radius in `[s·r, t_max·r]` at which the facing hemisphere's occluded
    /// fraction (`1 − e₀√(4π)/(2π)`… see [`crate::metrics::facing_occlusion`]) is at most
    /// `τ`; `t_max·r` where none is. Occlusion is not monotone in `t` for every shape, so
    /// bisection (`OCCLUSION_STEPS` halvings, each a hemisphere of rays, counted in
    /// [`Bsv::rays`]) returns a crossing, not necessarily the first. Domain: `0 ≤ τ < 1`,
    /// `1 ≤ t_max ≤ 10`.
    Occlusion { tau: f64, t_max: f64 },
}

/// Halvings of the [`RadialRule::Occlusion`] search (the radius to `(t_max − s)·r / 2⁶`).
pub const OCCLUSION_STEPS: usize = 6;
/// Halvings of the [`RadialRule::Clearance`] search (distance queries only).
pub const CLEARANCE_STEPS: usize = 40;

impl RadialRule {
    /// The largest radius the rule can place a sample at, in bounding radii, from the sampling
    /// sphere `s` (for a table's k range).
    pub fn max_factor(&self, s: f64) -> f64 {
        match *self {
            Self::Uniform => s,
            Self::Clearance { delta } => s.max(1.0 + delta),
            Self::Occlusion { t_max, .. } => s.max(t_max),
        }
    }
}

/// The triangulation of a set of sample directions, shared between every BSV sampled on the
/// same directions (a deforming sequence resamples each frame on one layout): the last few
/// are kept, looked up by exact equality of the directions.
pub(crate) fn triangulation(
    dirs: &[DVec3],
) -> Result<std::sync::Arc<SphericalTriangulation>, FieldError> {
    use std::sync::{Arc, Mutex};
    type Cache = Vec<(Vec<DVec3>, Arc<SphericalTriangulation>)>;
    static CACHE: Mutex<Cache> = Mutex::new(Vec::new());
    const KEEP: usize = 8;
    if let Some(t) = CACHE.lock().ok().and_then(|c| {
        c.iter()
            .find(|(d, _)| d.as_slice() == dirs)
            .map(|(_, t)| t.clone())
    }) {
        return Ok(t);
    }
    let t = Arc::new(SphericalTriangulation::new(dirs).map_err(FieldError::Spec)?);
    if let Ok(mut c) = CACHE.lock() {
        if c.len() == KEEP {
            c.remove(0);
        }
        c.push((dirs.to_vec(), t.clone()));
    }
    Ok(t)
}

/// The [`RadialRule::Clearance`] radius along the unit `dir` from the entity's bounding sphere
/// `(c, r)`: the first t in `[s·r, max(s·r, (1 + δ)·r)]` (s = `inflate`) whose point `c + t·dir`
/// lies at least `δ·r` from the surface, by [`CLEARANCE_STEPS`] halvings of distance queries
/// (no rays; the upper end always qualifies, as every point of the surface is within r of c).
/// What [`Bsv::sample_radial`] places its samples by, and the GPU path's radii.
pub fn clearance_radius(
    occ: &dyn Occluder,
    (c, r): (DVec3, f64),
    dir: DVec3,
    inflate: f64,
    delta: f64,
) -> f64 {
    let lo = inflate * r;
    let want = delta * r;
    let ok = |t: f64| (occ.distance_to_surface(c + t * dir) >= want, ());
    let hi = lo.max((1.0 + delta) * r);
    bisect_first(lo, hi, CLEARANCE_STEPS, ok).0
}

impl Bsv {
    /// Sample the BSV of `occ` (rayon-parallel over samples). `inflate ≥ 1` scales the sampling
    /// sphere (the on-surface mitigation), `eps` is the on-surface threshold relative to r.
    pub fn sample(
        occ: &dyn Occluder,
        layout: Layout,
        sampler: &VisibilitySampler,
        inflate: f64,
        eps: f64,
    ) -> Result<Self, FieldError> {
        if !(inflate.is_finite() && inflate >= 1.0) {
            return Err(FieldError::Spec(format!(
                "sampling radius factor {inflate} must be ≥ 1"
            )));
        }
        if !(eps.is_finite() && eps >= 0.0) {
            return Err(FieldError::Spec(format!(
                "on-surface epsilon {eps} must be ≥ 0"
            )));
        }
        Self::sample_dirs(occ, layout, layout.directions(), sampler, inflate, eps)
    }

    /// As [`Bsv::sample`] on a given sampling sphere (e.g. fixed over a deforming sequence so that
    /// per-receiver caches stay valid). The sphere must enclose the entity — otherwise the
    /// closed-form back hemisphere would be wrong — and the error says so.
    pub fn sample_on(
        occ: &dyn Occluder,
        layout: Layout,
        sampler: &VisibilitySampler,
        sampling: Sphere,
        eps: f64,
    ) -> Result<Self, FieldError> {
        let b = occ.bounding_sphere();
        let far = occ.farthest_distance(sampling.center);
        if far > sampling.radius * (1.0 + 1e-9) {
            return Err(FieldError::Spec(format!(
                "sampling sphere (centre {}, radius {}) does not enclose the entity (farthest point at distance {far})",
                sampling.center, sampling.radius
            )));
        }
        let samples = sample_points(
            occ,
            &layout.directions(),
            sampler,
            sampling.center,
            sampling.radius,
            eps * b.radius,
        );
        let rays = samples.len() * sampler.rays_per_hemisphere();
        Self::from_samples(layout, sampling, sampling.radius, samples, rays)
    }

    /// As [`Bsv::sample`] with explicit sample directions (unit vectors); `layout` is recorded.
    pub fn sample_dirs(
        occ: &dyn Occluder,
        layout: Layout,
        dirs: Vec<DVec3>,
        sampler: &VisibilitySampler,
        inflate: f64,
        eps: f64,
    ) -> Result<Self, FieldError> {
        let sphere = occ.bounding_sphere();
        let rs = inflate * sphere.radius;
        let samples = sample_points(occ, &dirs, sampler, sphere.center, rs, eps * sphere.radius);
        let rays = samples.len() * sampler.rays_per_hemisphere();
        Self::from_samples(layout, sphere, rs, samples, rays)
    }

    /// As [`Bsv::sample`], each sample placed along its direction by `rule` (the radii are
    /// kept in [`Bsv::radii`]; [`RadialRule::Uniform`] is [`Bsv::sample`]). On-surface flags
    /// are not computed here (all false): the rules exist to move samples off the surface.
    pub fn sample_radial(
        occ: &dyn Occluder,
        layout: Layout,
        sampler: &VisibilitySampler,
        inflate: f64,
        rule: RadialRule,
    ) -> Result<Self, FieldError> {
        if rule == RadialRule::Uniform {
            return Self::sample(occ, layout, sampler, inflate, 0.0);
        }
        if !(inflate.is_finite() && inflate >= 1.0) {
            return Err(FieldError::Spec(format!(
                "sampling radius factor {inflate} must be ≥ 1"
            )));
        }
        let sphere = occ.bounding_sphere();
        let (c, r) = (sphere.center, sphere.radius);
        let hemi = sampler.rays_per_hemisphere();
        let placed: Vec<(BsvSample, usize, f64)> = layout
            .directions()
            .par_iter()
            .map(|&dir| {
                let at = |t: f64| {
                    sampler
                        .facing_hemisphere(occ, c + t * dir, c, Frame::Entity)
                        .0
                };
                let lo = inflate * r;
                let (t, coeffs, casts) = match rule {
                    RadialRule::Uniform => unreachable!("handled above"),
                    RadialRule::Clearance { delta } => {
                        let t = clearance_radius(occ, (c, r), dir, inflate, delta);
                        (t, at(t), 1)
                    }
                    RadialRule::Occlusion { tau, t_max } => {
                        let ok = |t: f64| {
                            let v = at(t);
                            (crate::metrics::facing_occlusion(&v) <= tau, v)
                        };
                        bisect_first(lo, lo.max(t_max * r), OCCLUSION_STEPS, ok)
                    }
                };
                let sample = BsvSample {
                    dir,
                    pos: c + t * dir,
                    coeffs,
                    on_surface: false,
                };
                (sample, casts * hemi, t)
            })
            .collect();
        let rays = placed.iter().map(|(_, n, _)| n).sum();
        let radii = placed.iter().map(|(_, _, t)| *t).collect();
        let samples = placed.into_iter().map(|(s, _, _)| s).collect();
        let mut bsv = Self::from_samples(layout, sphere, inflate * r, samples, rays)?;
        bsv.radii = radii;
        Ok(bsv)
    }

    /// The radius of the sampling surface at the unit direction `q`: the sampling sphere's, or
    /// the per-sample radii interpolated with the coefficients' weights.
    pub fn radius_at(&self, q: DVec3) -> f64 {
        if self.radii.is_empty() {
            return self.sampling_radius;
        }
        (self.tri.locate(q).iter())
            .map(|&(v, w)| w * self.radii[v as usize])
            .sum()
    }

    /// Assemble from precomputed samples (e.g. radiance samples of a light); builds the
    /// triangulation of the sample directions.
    pub fn from_samples(
        layout: Layout,
        sphere: Sphere,
        sampling_radius: f64,
        samples: Vec<BsvSample>,
        rays: usize,
    ) -> Result<Self, FieldError> {
        let dirs: Vec<DVec3> = samples.iter().map(|s| s.dir).collect();
        let tri = triangulation(&dirs)?;
        Ok(Self {
            layout,
            sphere,
            sampling_radius,
            samples,
            rays,
            radii: Vec::new(),
            tri,
        })
    }

    /// Interpolation weights `(sample, weight)` at the unit direction `q` from the centre.
    pub fn locate(&self, q: DVec3) -> [(u32, f64); 3] {
        self.tri.locate(q)
    }

    /// Interpolated coefficients (entity frame) at the unit direction `q` from the centre.
    pub fn interpolate(&self, q: DVec3, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        for (v, w) in self.tri.locate(q) {
            for (o, c) in out.iter_mut().zip(&self.samples[v as usize].coeffs) {
                *o += w * c;
            }
        }
    }

    /// The sample that weighs most in the interpolation at direction `q`.
    pub fn nearest(&self, q: DVec3) -> usize {
        let l = self.tri.locate(q);
        l.iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(0, |x| x.0 as usize)
    }

    /// Number of on-surface samples.
    pub fn on_surface_count(&self) -> usize {
        self.samples.iter().filter(|s| s.on_surface).count()
    }
}

/// Visibility samples at `center + radius·dir` for every direction (rayon-parallel), each over the
/// hemisphere facing `center`, flagged on-surface when closer than `flag_distance` to the surface
/// (0 flags nothing and skips the distance query).
fn sample_points(
    occ: &dyn Occluder,
    dirs: &[DVec3],
    sampler: &VisibilitySampler,
    center: DVec3,
    radius: f64,
    flag_distance: f64,
) -> Vec<BsvSample> {
    dirs.par_iter()
        .map(|&dir| {
            let pos = center + radius * dir;
            let (coeffs, _) = sampler.facing_hemisphere(occ, pos, center, Frame::Entity);
            let on_surface = flag_distance > 0.0 && occ.distance_to_surface(pos) < flag_distance;
            BsvSample {
                dir,
                pos,
                coeffs,
                on_surface,
            }
        })
        .collect()
}

/// The smallest `t` in `[lo, hi]` where `eval(t).0` holds, for a predicate false then true
/// along the interval, to `(hi − lo) / 2^steps`, with `eval`'s value there and the number of
/// evaluations: `lo` if it holds there (1), `hi` if it fails there too (2), else bisection
/// keeping the predicate at the upper end (2 + `steps`).
fn bisect_first<V>(
    lo: f64,
    hi: f64,
    steps: usize,
    eval: impl Fn(f64) -> (bool, V),
) -> (f64, V, usize) {
    let (ok, v) = eval(lo);
    if ok || hi <= lo {
        return (lo, v, 1);
    }
    let (ok, vh) = eval(hi);
    if !ok {
        return (hi, vh, 2);
    }
    let (mut a, mut b, mut vb) = (lo, hi, vh);
    for _ in 0..steps {
        let m = 0.5 * (a + b);
        let (ok, vm) = eval(m);
        if ok {
            (b, vb) = (m, vm);
        } else {
            a = m;
        }
    }
    (b, vb, 2 + steps)
}
