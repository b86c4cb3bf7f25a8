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
    let f = LocalFrame::toward(p, c);
    let r = f.matrix();
    let rt = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]));
    let mut local = vec![0.0; out.len()];
    rot.apply(&rt, e, &mut local).expect("lengths agree");
    let mut scaled = vec![0.0; out.len()];
    m.apply_unchecked(&local, &mut scaled);
    rot.apply(&r, &scaled, out).expect("lengths agree");
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
        }
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
        let k = d / self.bsv.sampling_radius;
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
        let dir = (p - c) / d;
        let mut e = vec![0.0; out.len()];
        self.bsv.interpolate(dir, &mut e);
        scale_to(&self.rot, &e, p, c, m, out);
        match status {
            KLookup::BelowMin { .. } => ExtrapolationKind::ClampedBelow,
            _ => ExtrapolationKind::Scaled,
        }
    }
}
