//! The extrapolated field (docs/conventions.md §4; SHS §3.1): visibility at a point p from the base-sphere
//! samples — interpolate the BSV at p's direction from the centre, rotate into p's local frame
//! (z toward the centre), scale with `M_k`, `k = |p − c| / (s·r)` (distance over the sampling
//! radius), and rotate back to the entity frame. Out of the table's range (docs/conventions.md §3.3): above
//! `k_max` the entity does not occlude (visibility 1); below `k_min` the matrix at `k_min` is used
//! and the result says so.
//!
//! Interpolation frame: BSVs are stored in the entity frame and interpolated there (docs/conventions.md §2
//! allows either; the entity frame needs no per-sample frame bookkeeping and is what a rotation of
//! the whole entity would carry).

use crate::bsv::Bsv;
use crate::frame::LocalFrame;
use glam::DVec3;
use shscale_scaling::{KLookup, KTable, ScalingMatrix};
use shscale_sh::EulerRotator;

/// Scale `e`, visibility (entity frame) on the sampling sphere in the direction of `p` from the
/// centre `c`, to `p` with the matrix `m` (`M_k` at `k = |p − c| / (s·r)`): rotate into `p`'s local
/// frame (z toward `c`), apply `m`, rotate back. The one scaling step of [`Extrapolator::eval`],
/// also used with exact inputs in the probe's error decomposition.
pub fn scale_to(
    rot: &EulerRotator<f64>,
    e: &[f64],
    p: DVec3,
    c: DVec3,
    m: &ScalingMatrix<f64>,
    out: &mut [f64],
) {
    scale_to_with(rot, e, p, c, m, None, out)
}

/// [`scale_to`] with the [`Plausibility::Clamp`] projection in the local frame (`clamp`: the
/// projector and the bounding cone's half-angle at `p`).
pub(crate) fn scale_to_with(
    rot: &EulerRotator<f64>,
    e: &[f64],
    p: DVec3,
    c: DVec3,
    m: &ScalingMatrix<f64>,
    clamp: Option<(&Clamp, f64)>,
    out: &mut [f64],
) {
    let f = LocalFrame::toward(p, c);
    let r = f.matrix();
    let rt = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]));
    let mut local = vec![0.0; out.len()];
    rot.apply(&rt, e, &mut local).expect("lengths agree");
    let mut scaled = vec![0.0; out.len()];
    m.apply_unchecked(&local, &mut scaled);
    if let Some((cl, theta_c)) = clamp {
        cl.apply(&mut scaled, theta_c);
    }
    rot.apply(&r, &scaled, out).expect("lengths agree");
}

/// The physical-plausibility mitigation of an extrapolated visibility (docs/conventions.md §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plausibility {
    /// The scaled coefficients as they are.
    None,
    /// In the angular domain: visibility clamped to [0, 1], and 1 outside the cone the bounding
    /// sphere subtends from the point (nothing outside it can occlude); then re-projected to
    /// order N. See [`Clamp`].
    Clamp,
}

shscale_names::names!(Plausibility { None = "none", Clamp = "clamp" });

impl Plausibility {
    /// `"none" | "clamp"`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| shscale_names::one_of(s, Self::NAMES))
    }
}

/// The [`Plausibility::Clamp`] projection in a point's local frame (z toward the centre). The
/// part outside the bounding cone `θ > θ_c` is the constant 1, projected in closed form
/// (`√(4π)δ₀ − cap(θ_c)`); inside, `clamp(V, 0, 1)` is projected by Gauss–Legendre in cos θ on
/// `[cos θ_c, 1]` (the cone's edge is a panel end, so the cut costs no accuracy) × `4N + 16`
/// uniform φ, `2N + 16` nodes: exact for the unclamped band-limited part, and the clamp's kinks
/// are continuous. Valid for any order and any cone angle in `[0, π]` (`θ_c = π`: no cut).
pub struct Clamp {
    basis: shscale_sh::ShBasis<f64>,
    gl: shscale_sh::GaussLegendre,
    n_phi: usize,
}

impl Clamp {
    pub fn new(order: usize) -> Result<Self, crate::error::FieldError> {
        Ok(Self {
            basis: shscale_sh::ShBasis::new(order)?,
            gl: shscale_sh::GaussLegendre::new(2 * order + 16),
            n_phi: 4 * order + 16,
        })
    }

    /// Replace local-frame visibility `v` by its plausible projection, the bounding cone of
    /// half-angle `theta_c` about +z.
    pub fn apply(&self, v: &mut [f64], theta_c: f64) {
        let nn = v.len();
        let theta_c = theta_c.clamp(0.0, std::f64::consts::PI);
        let mut out = vec![0.0; nn];
        // Outside the cone: the constant 1.
        let cap = shscale_sh::cap_coeffs(self.basis.order(), theta_c).expect("valid angle");
        out.iter_mut().zip(&cap).for_each(|(o, c)| *o = -c);
        out[0] += (4.0 * std::f64::consts::PI).sqrt();
        let mut y = vec![0.0; nn];
        let dphi = std::f64::consts::TAU / self.n_phi as f64;
        for (z, w) in self.gl.on(theta_c.cos(), 1.0) {
            let s = (1.0 - z * z).max(0.0).sqrt();
            for j in 0..self.n_phi {
                let phi = dphi * (j as f64 + 0.5);
                self.basis.eval([s * phi.cos(), s * phi.sin(), z], &mut y);
                let val: f64 = y.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
                let c = val.clamp(0.0, 1.0) * w * dphi;
                if c != 0.0 {
                    out.iter_mut().zip(&y).for_each(|(o, b)| *o += c * b);
                }
            }
        }
        v.copy_from_slice(&out);
    }
}

/// Half-angle of the cone the bounding sphere of radius `r` subtends at distance `d` from its
/// centre (π inside it: every direction can be occluded).
pub(crate) fn bounding_cone(r: f64, d: f64) -> f64 {
    if d > r {
        (r / d).asin()
    } else {
        std::f64::consts::PI
    }
}

/// What happened to one query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExtrapolationKind {
    /// Scaled with an interpolated matrix.
    Scaled,
    /// `k < k_min`: scaled with `M(k_min)`.
    ClampedBelow,
    /// `k > k_max`: unoccluded (visibility 1).
    Unoccluded,
}

/// What a field is beyond the table's `k_max` (docs/conventions.md §3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Beyond {
    /// An occluder: visibility 1.
    Unoccluded,
    /// A light: radiance 0.
    Dark,
}

/// Extrapolates one entity's BSV with a k-table.
pub struct Extrapolator<'a> {
    pub bsv: &'a Bsv,
    pub table: &'a KTable,
    rot: EulerRotator<f64>,
    beyond: Beyond,
    clamp: Option<Clamp>,
}

impl<'a> Extrapolator<'a> {
    /// The BSV and the table must have the same order.
    pub fn new(bsv: &'a Bsv, table: &'a KTable) -> Self {
        assert_eq!(
            bsv.samples[0].coeffs.len(),
            table.order() * table.order(),
            "BSV and table orders differ"
        );
        Self {
            bsv,
            table,
            rot: EulerRotator::new(table.order()).expect("valid order"),
            beyond: Beyond::Unoccluded,
            clamp: None,
        }
    }

    /// The same with a plausibility mitigation (occluders only; a light's field is unchanged).
    pub fn with_plausibility(mut self, p: Plausibility) -> Self {
        self.clamp = (p == Plausibility::Clamp && self.beyond == Beyond::Unoccluded)
            .then(|| Clamp::new(self.table.order()).expect("valid order"));
        self
    }

    /// The same, for a light's radiance samples (dark beyond `k_max`).
    pub fn for_light(bsv: &'a Bsv, table: &'a KTable) -> Self {
        Self {
            beyond: Beyond::Dark,
            ..Self::new(bsv, table)
        }
    }

    /// Visibility coefficients (entity frame) at `p` (`p` ≠ centre) into `out`; scratch `m` is a
    /// matrix of the table's order.
    pub fn eval(&self, p: DVec3, m: &mut ScalingMatrix<f64>, out: &mut [f64]) -> ExtrapolationKind {
        let c = self.bsv.sphere.center;
        // At (or numerically at) the centre the direction and the local frame are undefined and
        // k = 0 lies below any table: use the +z direction with the table's smallest k (reported
        // as ClampedBelow) instead of failing.
        let tiny = 1e-12 * self.bsv.sampling_radius;
        let p = if (p - c).length() < tiny {
            c + tiny * DVec3::Z
        } else {
            p
        };
        let d = (p - c).length();
        let dir = (p - c) / d;
        // k over the sampling surface's radius in p's direction (the sphere's, or the
        // interpolated per-sample radii of a radial rule).
        let k = d / self.bsv.radius_at(dir);
        let status = self
            .table
            .lookup(k, m)
            .expect("k is finite and > 0 after the centre guard");
        if let KLookup::AboveMax { .. } = status {
            out.iter_mut().for_each(|o| *o = 0.0);
            if self.beyond == Beyond::Unoccluded {
                out[0] = (4.0 * std::f64::consts::PI).sqrt();
            }
            return ExtrapolationKind::Unoccluded;
        }
        let mut e = vec![0.0; out.len()];
        self.bsv.interpolate(dir, &mut e);
        let cone = bounding_cone(self.bsv.sphere.radius, d);
        scale_to_with(
            &self.rot,
            &e,
            p,
            c,
            m,
            self.clamp.as_ref().map(|cl| (cl, cone)),
            out,
        );
        match status {
            KLookup::BelowMin { .. } => ExtrapolationKind::ClampedBelow,
            _ => ExtrapolationKind::Scaled,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Oracle: brute-force midpoint quadrature (2 × 1200 θ cells, split at the cone's edge, ×
    /// 2400 φ cells) of `clamp(V, 0, 1)` inside the cone and 1 outside, against [`Clamp::apply`]; the constant 1 is a fixed point; after
    /// the clamp the occluded solid angle lies in [0, the cone's solid angle] (to the
    /// band-limiting of the result).
    #[test]
    fn clamp_matches_brute_force_projection_and_bounds_the_occlusion() {
        let order = 4;
        let basis = shscale_sh::ShBasis::<f64>::new(order).unwrap();
        let cl = Clamp::new(order).unwrap();
        // An implausible input: 1 − 1.3 × a 70° cap about +z (values down to −0.3).
        let cap = shscale_sh::cap_coeffs(order, 70f64.to_radians()).unwrap();
        let mut v: Vec<f64> = cap.iter().map(|c| -1.3 * c).collect();
        v[0] += (4.0 * std::f64::consts::PI).sqrt();
        let theta_c = 40f64.to_radians();
        let mut got = v.clone();
        cl.apply(&mut got, theta_c);
        let (nt, np) = (1200, 2400);
        let mut want = vec![0.0; v.len()];
        let mut y = vec![0.0; v.len()];
        let cells = (0..nt)
            .map(|i| (0.0, theta_c, i))
            .chain((0..nt).map(|i| (theta_c, std::f64::consts::PI, i)));
        for (a, b, i) in cells {
            let h = (b - a) / nt as f64;
            let th = a + h * (i as f64 + 0.5);
            let w = th.sin() * h * (std::f64::consts::TAU / np as f64);
            for j in 0..np {
                let ph = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
                basis.eval([th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()], &mut y);
                let val: f64 = y.iter().zip(&v).map(|(a, b)| a * b).sum();
                let f = if a > 0.0 { 1.0 } else { val.clamp(0.0, 1.0) };
                want.iter_mut().zip(&y).for_each(|(o, b)| *o += w * f * b);
            }
        }
        let err = crate::metrics::l2_diff(&got, &want);
        println!("clamp vs brute force: {err:.2e}");
        assert!(err < 2e-5, "{err:e}");
        let omega = 4.0 * std::f64::consts::PI - (4.0 * std::f64::consts::PI).sqrt() * got[0];
        let cone = std::f64::consts::TAU * (1.0 - theta_c.cos());
        println!("occluded solid angle {omega:.4} ≤ cone {cone:.4}");
        assert!(omega >= 0.0 && omega <= cone + 1e-9, "{omega} vs {cone}");
        let mut one = vec![0.0; v.len()];
        one[0] = (4.0 * std::f64::consts::PI).sqrt();
        let mut c1 = one.clone();
        cl.apply(&mut c1, theta_c);
        assert!(crate::metrics::l2_diff(&c1, &one) < 1e-12);
        // Edges of the cone angle: θ_c = 0 leaves only the constant 1 (nothing can occlude);
        // θ_c = π cuts nothing, and a band-limited input already in [0, 1] (0.5 + 0.3·Y₁⁰, so
        // 0.35…0.65) is a fixed point: the quadrature is exact for it.
        let mut none = v.clone();
        cl.apply(&mut none, 0.0);
        assert!(crate::metrics::l2_diff(&none, &one) < 1e-12);
        let mut w = vec![0.0; v.len()];
        w[0] = 0.5 * (4.0 * std::f64::consts::PI).sqrt();
        w[2] = 0.3;
        let mut all = w.clone();
        cl.apply(&mut all, std::f64::consts::PI);
        let moved = crate::metrics::l2_diff(&all, &w);
        println!("θ_c = π on a plausible input: moved {moved:.2e}");
        assert!(moved < 1e-12, "{moved}");
        assert_eq!(Plausibility::parse("clamp"), Ok(Plausibility::Clamp));
        assert!(Plausibility::parse("nope").is_err());
        assert_eq!(bounding_cone(1.0, 0.5), std::f64::consts::PI);
        assert!((bounding_cone(1.0, 2.0) - std::f64::consts::FRAC_PI_6).abs() < 1e-15);
    }
}
