//! Ray-traced truth at any point (docs/conventions.md §4).
//!
//! * [`TruthSampler`]: the **converged band-limited truth** every accuracy column is measured
//!   against — the visibility over the full sphere projected to order N, by a quadrature of its
//!   own resolution (never tied to the method's `hemisphere_res`), with an estimate of its own
//!   error. See the type for the estimator and docs/math.md §5 for its measured convergence.
//! * [`visibility_map`]: a full-resolution lat-long visibility map (images, full-frequency
//!   shading truth).
//! * [`band_limited`]: the Gauss–Legendre full-sphere projection of a [`VisibilitySampler`]
//!   (`2H²` rays on fixed rings): the method's own quadrature, kept for comparison; its error does
//!   not fall monotonically with H when an occluder's edge lines up with the rings.

use crate::visibility::{Frame, VisibilitySampler};
use glam::{DQuat, DVec3};
use rayon::prelude::*;
use shscale_geometry::{Occluder, RAY_EPS};
use shscale_sh::ShBasis;

/// Band-limited visibility by the method's Gauss–Legendre quadrature (`2H²` rays).
pub fn band_limited(sampler: &VisibilitySampler, occ: &dyn Occluder, p: DVec3) -> Vec<f64> {
    sampler.full_sphere(occ, p, Frame::Entity).0
}

/// The default truth resolution T (`4T²` rays per point): the smallest power of two whose
/// measured error is ≤ 1 % of the occlusion at order 8 on the analytic sphere seen from
/// (0, 0, 2) and from an oblique point (test `truth_default_meets_one_percent`, docs/math.md §5).
pub const DEFAULT_TRUTH_RES: usize = 128;

/// The default seed of the truth's per-point rotations and jitter.
pub const DEFAULT_TRUTH_SEED: u64 = 0x5eed_7207;

/// SplitMix64: a small, fast, seedable generator (reproducible across machines and threads).
#[derive(Clone, Debug)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// A generator seeded by `seed` and a point's coordinates (bit patterns), so that the draw
    /// at a point does not depend on the order or the thread the points are visited in.
    pub fn at(seed: u64, p: DVec3) -> Self {
        let mut s = Self(seed ^ 0x9e37_79b9_7f4a_7c15);
        for c in [p.x, p.y, p.z] {
            s.0 ^= c.to_bits();
            s.next_u64();
        }
        s
    }
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1) (53 bits).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// A direction uniform on the unit sphere (`z` uniform in [−1, 1], then φ uniform; Archimedes).
    pub fn direction(&mut self) -> DVec3 {
        let z = 2.0 * self.unit() - 1.0;
        let phi = std::f64::consts::TAU * self.unit();
        let s = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }
    /// A uniformly distributed rotation (Shoemake 1992, from three uniforms).
    pub fn rotation(&mut self) -> DQuat {
        let (u1, u2, u3) = (self.unit(), self.unit(), self.unit());
        let tau = std::f64::consts::TAU;
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        DQuat::from_xyzw(
            a * (tau * u2).sin(),
            a * (tau * u2).cos(),
            b * (tau * u3).sin(),
            b * (tau * u3).cos(),
        )
        .normalize()
    }
}

/// The truth at one point.
#[derive(Clone, Debug)]
pub struct Truth {
    /// SH coefficients of the visibility, entity frame (the mean of the two half estimates).
    pub coeffs: Vec<f64>,
    /// Estimated RMS error of `coeffs`, `‖A − B‖ / 2` from the two independent half estimates
    /// A, B (unbiased, independent, equally distributed): `E[‖A − B‖²/4]` equals the mean
    /// squared error of `(A + B)/2`, so this is a one-point estimate of it (averaged over many
    /// points it converges to the RMS error).
    pub error: f64,
    /// `(A − B)/2`, the coefficient vector whose norm is `error`: the error estimate of any linear
    /// functional of the visibility (e.g. a receiver's irradiance `⟨T, V⟩`) is `|⟨T, (A − B)/2⟩|`.
    pub half_diff: Vec<f64>,
    /// Rays traced (`4T²`).
    pub rays: usize,
    /// Rays that escaped; 0 means the point sees nothing (inside a solid).
    pub escaped: usize,
}

impl Truth {
    /// The truth from its two independent estimates `a`, `b`: their mean, `‖a − b‖/2` and
    /// `(a − b)/2`.
    fn from_estimates(a: &[f64], b: &[f64], rays: usize, escaped: usize) -> Self {
        Self {
            coeffs: a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect(),
            error: 0.5 * crate::metrics::l2_diff(a, b),
            half_diff: a.iter().zip(b).map(|(x, y)| 0.5 * (x - y)).collect(),
            rays,
            escaped,
        }
    }

    /// A closed-form truth (the analytic sphere): no error, no rays.
    pub fn exact(coeffs: Vec<f64>) -> Self {
        Self {
            half_diff: vec![0.0; coeffs.len()],
            coeffs,
            error: 0.0,
            rays: 0,
            escaped: 1,
        }
    }

    /// The truth's own error relative to its occlusion, `error / ‖P_N(1 − V)‖`; `None` when
    /// nothing is occluded (docs/conventions.md §6, `truth_rel_err`).
    pub fn rel_error(&self) -> Option<f64> {
        let d = crate::metrics::l2(&crate::metrics::occlusion(&self.coeffs));
        (d > 1e-12).then(|| self.error / d)
    }
}

/// Converged ray-traced truth: two independent stratified jittered quadratures of the full
/// sphere, each with its own seeded random rotation, the unoccluded part in closed form.
///
/// One estimate cuts the sphere into `T` bands of equal `cos θ` height × `2T` equal φ sectors:
/// `2T²` strata of equal area `4π / 2T²`, one uniformly jittered ray in each, the whole pattern
/// turned by a uniform random rotation. Two such estimates A and B (`4T²` rays in all) are drawn
/// per point from [`SplitMix::at`] (seed and the point's coordinates, so results do not depend
/// on threads or order); the truth is their mean and its error estimate `‖A − B‖ / 2`. Visibility is `1 − occlusion`, and
/// `∫ Y = √(4π) δ₀` exactly, so only occluded rays are summed:
/// `V ≈ √(4π) e₀ − (4π / 2T²) Σ_occluded Y(d_i)` per estimate — unbiased for any rotation, with no variance
/// from the unoccluded part. Unlike fixed rings, no occluder edge can line up with the
/// strata, and the error falls steadily as `T` grows: for a visibility step along a curve its
/// RMS is `O(T^{-3/2})` (boundary strata `∝ T`, each contributing a variance `∝ T^{-4}`).
///
/// Valid for any point and any occluder; inside a solid every ray is occluded and the estimate
/// is 0 in `c₀` exactly ([`Truth::escaped`] is then 0).
#[derive(Clone, Debug)]
pub struct TruthSampler {
    basis: ShBasis<f64>,
    res: usize,
    seed: u64,
}

/// The largest truth resolution (4·1024² ≈ 4.2 M rays per point).
pub const MAX_TRUTH_RES: usize = 1024;

impl TruthSampler {
    /// Order `N`, resolution `1 ≤ T ≤` [`MAX_TRUTH_RES`] (`4T²` rays per point), seed.
    pub fn new(order: usize, res: usize, seed: u64) -> Result<Self, crate::error::FieldError> {
        let basis = ShBasis::new(order)?;
        if !(1..=MAX_TRUTH_RES).contains(&res) {
            return Err(crate::error::FieldError::Spec(format!(
                "truth resolution {res} is outside 1..={MAX_TRUTH_RES}"
            )));
        }
        Ok(Self { basis, res, seed })
    }

    /// The order N.
    pub fn order(&self) -> usize {
        self.basis.order()
    }

    /// Rays per point, `4T²`.
    pub fn rays(&self) -> usize {
        4 * self.res * self.res
    }

    /// The two stratified direction sets drawn from `rng`, each rotated by its own rotation, one
    /// after the other, and which set (false = A, true = B) each belongs to.
    fn directions(&self, mut rng: SplitMix) -> (Vec<DVec3>, Vec<bool>) {
        let t = self.res;
        let mut dirs = Vec::with_capacity(4 * t * t);
        let mut half = Vec::with_capacity(4 * t * t);
        let dz = 2.0 / t as f64;
        let dphi = std::f64::consts::PI / t as f64;
        for b in [false, true] {
            let q = rng.rotation();
            for i in 0..t {
                for j in 0..2 * t {
                    let z = 1.0 - dz * (i as f64 + rng.unit());
                    let phi = dphi * (j as f64 + rng.unit());
                    let s = (1.0 - z * z).max(0.0).sqrt();
                    dirs.push(q * DVec3::new(s * phi.cos(), s * phi.sin(), z));
                    half.push(b);
                }
            }
        }
        (dirs, half)
    }

    /// The truth at `p` (entity frame), drawn from the seed and the point's coordinates.
    pub fn sample(&self, occ: &dyn Occluder, p: DVec3) -> Truth {
        self.sample_from(occ, p, SplitMix::at(self.seed, p))
    }

    /// The truth at `p`, drawn from the seed and a stream number (e.g. a probe's index) instead of
    /// the point: the same draw for the same stream whatever the scene's scale or placement.
    pub fn sample_stream(&self, occ: &dyn Occluder, p: DVec3, stream: u64) -> Truth {
        let mut rng = SplitMix(self.seed ^ stream.wrapping_mul(0xd1b5_4a32_d192_ed03));
        rng.next_u64();
        self.sample_from(occ, p, rng)
    }

    fn sample_from(&self, occ: &dyn Occluder, p: DVec3, rng: SplitMix) -> Truth {
        let (dirs, half) = self.directions(rng);
        let mut hit = vec![false; dirs.len()];
        let tmin = RAY_EPS * occ.bounding_sphere().radius;
        occ.occluded_fan(p, &dirs, tmin, &mut hit);
        let nn = self.basis.len();
        let mut sums = [vec![0.0; nn], vec![0.0; nn]];
        let mut lists: [Vec<[f64; 3]>; 2] = [Vec::new(), Vec::new()];
        for ((d, &h), &b) in dirs.iter().zip(&hit).zip(&half) {
            if h {
                lists[b as usize].push(d.to_array());
            }
        }
        const CHUNK: usize = 64;
        let mut vals = vec![0.0; CHUNK * nn];
        for (sum, list) in sums.iter_mut().zip(&lists) {
            for chunk in list.chunks(CHUNK) {
                let v = &mut vals[..chunk.len() * nn];
                self.basis.eval_batch(chunk, v);
                for y in v.chunks_exact(nn) {
                    sum.iter_mut().zip(y).for_each(|(o, b)| *o += b);
                }
            }
        }
        // Each estimate has 2T² strata of area 4π / 2T².
        let w_half = 2.0 * std::f64::consts::PI / (self.res * self.res) as f64;
        let s0 = (4.0 * std::f64::consts::PI).sqrt();
        let est = |s: &[f64]| -> Vec<f64> {
            let mut v: Vec<f64> = s.iter().map(|x| -w_half * x).collect();
            v[0] += s0;
            v
        };
        let occluded = lists[0].len() + lists[1].len();
        Truth::from_estimates(
            &est(&sums[0]),
            &est(&sums[1]),
            dirs.len(),
            dirs.len() - occluded,
        )
    }

    /// [`TruthSampler::sample`] with the coefficients in `frame` (`Local`: z toward the
    /// occluder's bounding-sphere centre, as [`VisibilitySampler::full_sphere`]). The error
    /// estimate is a norm, unchanged by the rotation.
    pub fn sample_in(&self, occ: &dyn Occluder, p: DVec3, frame: Frame) -> Truth {
        let mut t = self.sample(occ, p);
        if frame == Frame::Local {
            let c = occ.bounding_sphere().center;
            let f = if (c - p).length() > 0.0 {
                crate::frame::LocalFrame::toward(p, c)
            } else {
                crate::frame::LocalFrame::from_z(DVec3::Z)
            };
            // Entity → local: the transpose of the local → entity matrix.
            let r = f.matrix();
            let rt = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]));
            let rot = shscale_sh::EulerRotator::new(self.order()).expect("valid order");
            let mut local = vec![0.0; t.coeffs.len()];
            rot.apply(&rt, &t.coeffs, &mut local)
                .expect("lengths agree");
            t.coeffs = local.clone();
            rot.apply(&rt, &t.half_diff, &mut local)
                .expect("lengths agree");
            t.half_diff = local;
        }
        t
    }

    /// The converged projection of any bounded `value(direction)` over the sphere at `p` (e.g. a
    /// light's radiance): the same two stratified estimates, `Σ w value(d) Y(d)` each, no closed
    /// form for any part; `escaped` counts the directions where the value is non-zero.
    pub fn project(&self, p: DVec3, mut value: impl FnMut(DVec3) -> f64) -> Truth {
        let (dirs, half) = self.directions(SplitMix::at(self.seed, p));
        let nn = self.basis.len();
        let mut sums = [vec![0.0; nn], vec![0.0; nn]];
        let mut y = vec![0.0; nn];
        let mut nonzero = 0;
        for (d, &b) in dirs.iter().zip(&half) {
            let v = value(*d);
            if v == 0.0 {
                continue;
            }
            nonzero += 1;
            self.basis.eval(d.to_array(), &mut y);
            sums[b as usize]
                .iter_mut()
                .zip(&y)
                .for_each(|(o, x)| *o += v * x);
        }
        let w = 2.0 * std::f64::consts::PI / (self.res * self.res) as f64;
        let scaled = |s: &[f64]| s.iter().map(|x| w * x).collect::<Vec<f64>>();
        Truth::from_estimates(&scaled(&sums[0]), &scaled(&sums[1]), dirs.len(), nonzero)
    }
}

/// A lat-long visibility map in the entity frame: row 0 at θ = 0 (+z), `width × height` texel
/// centres, 1 = unoccluded. Row-major.
pub fn visibility_map(occ: &dyn Occluder, p: DVec3, width: usize, height: usize) -> Vec<f32> {
    let tmin = RAY_EPS * occ.bounding_sphere().radius;
    (0..width * height)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % width, k / width);
            let theta = std::f64::consts::PI * (j as f64 + 0.5) / height as f64;
            let phi = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / width as f64;
            let d = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            if occ.occluded(p, d, tmin, f64::INFINITY) {
                0.0
            } else {
                1.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::sphere_truth;
    use shscale_geometry::{AnalyticSphere, Sphere};

    fn occ_err(truth: &[f64], est: &[f64]) -> f64 {
        crate::metrics::occ_rel_l2(est, truth).unwrap()
    }

    /// Against the closed-form cap: the actual error relative to the occlusion at order 8, for
    /// T doubling, at (0, 0, 2) and at an oblique point; the default meets 1 % at both.
    #[test]
    fn truth_default_meets_one_percent() {
        let sph = AnalyticSphere::unit();
        let s = Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        };
        let basis = ShBasis::new(8).unwrap();
        for p in [DVec3::new(0.0, 0.0, 2.0), DVec3::new(1.1, -0.7, 1.3)] {
            let exact = sphere_truth(&basis, &s, p).unwrap();
            let mut prev = f64::INFINITY;
            for t in [16, 32, 64, 128] {
                // The RMS over 8 seeds: the convergence claim is about the RMS.
                let (mut e2, mut est2) = (0.0, 0.0);
                for seed in 0..8 {
                    let tr = TruthSampler::new(8, t, seed).unwrap().sample(&sph, p);
                    e2 += occ_err(&exact, &tr.coeffs).powi(2);
                    est2 += tr.rel_error().unwrap().powi(2);
                }
                let (e, est) = ((e2 / 8.0).sqrt(), (est2 / 8.0).sqrt());
                println!("p = {p}, T = {t}: actual {e:.2e}, estimated {est:.2e}");
                // Monotone, and falling at least ×1.8 per doubling (theory: ×2.8).
                assert!(e < prev / 1.8, "T = {t}: {e:.3e} after {prev:.3e}");
                // The estimate is within a factor 2 of the actual error (RMS over seeds).
                assert!(
                    est > 0.5 * e && est < 2.0 * e,
                    "T = {t}: est {est:.3e} vs {e:.3e}"
                );
                if t == DEFAULT_TRUTH_RES {
                    assert!(e < 0.01, "default T = {t}: {e:.3e} ≥ 1 %");
                }
                prev = e;
            }
            // The method's Gauss–Legendre rings for comparison (printed for docs/math.md §5;
            // not monotone in H where the cap's edge lines up with the rings).
            for h in [16, 32, 64, 128, 256] {
                let gl = VisibilitySampler::new(8, h)
                    .unwrap()
                    .full_sphere(&sph, p, Frame::Entity)
                    .0;
                println!(
                    "p = {p}, Gauss–Legendre H = {h} ({} rays): actual {:.2e}",
                    2 * h * h,
                    occ_err(&exact, &gl)
                );
            }
        }
    }

    /// The same point, seed and resolution give the same bits; inside a solid c₀ is 0 and nothing
    /// escapes; an unoccluded point is exact.
    #[test]
    fn truth_is_reproducible_and_exact_at_degenerate_points() {
        let sph = AnalyticSphere::unit();
        let ts = TruthSampler::new(4, 16, 7).unwrap();
        let p = DVec3::new(0.3, 1.4, -0.9);
        assert_eq!(ts.sample(&sph, p).coeffs, ts.sample(&sph, p).coeffs);
        let other = TruthSampler::new(4, 16, 8).unwrap().sample(&sph, p).coeffs;
        assert_ne!(ts.sample(&sph, p).coeffs, other);
        let inside = ts.sample(&sph, DVec3::new(0.1, 0.0, 0.2));
        assert_eq!(inside.escaped, 0);
        assert!(inside.coeffs[0].abs() < 1e-12, "{}", inside.coeffs[0]);
        // Far away and looking nowhere near: the sphere at 1e6 r subtends 1e-12 sr, and every ray
        // escapes with overwhelming probability; then the estimate is the constant 1 exactly.
        let far = ts.sample(&sph, DVec3::new(1e6, 0.0, 0.0));
        assert_eq!(far.escaped, far.rays);
        assert_eq!(far.coeffs[0], (4.0 * std::f64::consts::PI).sqrt());
        assert!(far.coeffs[1..].iter().all(|&c| c == 0.0));
        assert_eq!(far.error, 0.0);
        assert!(TruthSampler::new(4, 0, 0).is_err());
        assert!(TruthSampler::new(4, MAX_TRUTH_RES + 1, 0).is_err());
    }

    /// The directions are stratified samples: one in each stratum before the rotation, so each
    /// set's mean direction is O(1/T²) from 0.
    #[test]
    fn rotation_is_uniform_and_directions_are_unit() {
        let ts = TruthSampler::new(2, 24, 1).unwrap();
        let (dirs, half) = ts.directions(SplitMix::at(1, DVec3::new(0.5, 0.2, 3.0)));
        assert_eq!(dirs.len(), 4 * 24 * 24);
        assert_eq!(half.iter().filter(|&&h| h).count(), 2 * 24 * 24);
        let mean = dirs.iter().copied().sum::<DVec3>() / dirs.len() as f64;
        assert!(dirs.iter().all(|d| (d.length() - 1.0).abs() < 1e-12));
        println!("mean direction {mean}");
        assert!(mean.length() < 2e-3, "{mean}");
        // Rotations: the mean of R·z over many draws is ~0 (uniform on SO(3)).
        let mut rng = SplitMix(3);
        let n = 20_000;
        let m = (0..n).map(|_| rng.rotation() * DVec3::Z).sum::<DVec3>() / n as f64;
        assert!(m.length() < 0.03, "{m}");
    }
}
