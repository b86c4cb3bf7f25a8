//! Tables of scaling matrices over the scale parameter k (paper Sec. 2.3: "numerically compute
//! M_k for sampled values of k, and then linearly interpolate"; docs/conventions.md §3.3).
//!
//! * Spacing of the K samples over `[k_min, k_max]`: exponential (geometric, the paper's choice,
//!   default K = 40), uniform, or Chebyshev–Lobatto (`cos(jπ/(K−1))` mapped onto the range, so
//!   both ends are samples and nodes cluster toward them).
//! * Interpolation coordinate `x = ln k` when `k_min > 0` (always for the cone), else `x = k`
//!   (mid-range tables with signed k). Linear (default) or cubic (4-point Lagrange on the nearest
//!   samples in x; needs K ≥ 4).
//! * Out of range (docs/conventions.md §3.3), reported to the caller by [`KLookup`]: below `k_min` the nearest
//!   sample is used; above `k_max` the matrix at `k_max` is returned but the rule is that the
//!   entity does not occlude (visibility 1) — the field layer applies that, not this table.

use crate::error::ScalingError;
use crate::matrix::{Eta, ScalingMatrix};
use crate::tau::{check_alpha, check_cone_k, check_midrange_k};
use crate::tau::{AngularScaling, Cone, MidRange};
use std::f64::consts::PI;

/// How the K sample values of k are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Spacing {
    /// Geometric: `k_j = k_min (k_max/k_min)^{j/(K−1)}`.
    Exp,
    /// Arithmetic: `k_j = k_min + j (k_max − k_min)/(K−1)`.
    Uniform,
    /// Chebyshev–Lobatto nodes on `[k_min, k_max]` (in k), ascending.
    Chebyshev,
}

/// How matrices between samples are formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interp {
    /// Linear in the interpolation coordinate (ln k when k_min > 0).
    Linear,
    /// 4-point Lagrange cubic in the interpolation coordinate.
    Cubic,
}

/// The family of angular scaling functions a table samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TauFamily {
    /// The cone model with half-angle `alpha` (radians), `k = d/r > 0`.
    Cone { alpha: f64 },
    /// The cone model with α by distance, `α(k) =` [`crate::alpha_law::fitted_alpha`]`(θ₀, k)`:
    /// exact for a centred sphere whose cap seen from the sampling sphere has half-angle
    /// `theta0` (radians, in (0, π/2]); `k = d/r > 0`.
    ConeFit { theta0: f64 },
    /// Mid-range environment lighting, `k = d/R ∈ (−1, 1)`.
    MidRange,
}

impl TauFamily {
    /// The τ of this family at `k` (validated).
    pub fn at(&self, k: f64) -> Result<Box<dyn AngularScaling>, ScalingError> {
        Ok(match *self {
            TauFamily::Cone { alpha } => Box::new(Cone::new(k, alpha)?),
            TauFamily::ConeFit { theta0 } => {
                if !(theta0 > 0.0 && theta0 <= std::f64::consts::FRAC_PI_2) {
                    return Err(ScalingError::Domain {
                        name: "effective cap angle θ₀ (rad)",
                        value: theta0,
                        domain: "(0, π/2]",
                    });
                }
                Box::new(Cone::new(k, crate::alpha_law::fitted_alpha(theta0, k))?)
            }
            TauFamily::MidRange => Box::new(MidRange::new(k)?),
        })
    }

    /// Output name (`cone` or `midrange`).
    pub fn name(&self) -> &'static str {
        match self {
            TauFamily::Cone { .. } => "cone",
            TauFamily::ConeFit { .. } => "cone-fit",
            TauFamily::MidRange => "midrange",
        }
    }
}

/// Where a looked-up k fell relative to the sampled range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KLookup {
    /// `k_min ≤ k ≤ k_max`: interpolated.
    Interior,
    /// `k < k_min`: the matrix at `k_min` was used (say so in output).
    BelowMin { k_min: f64 },
    /// `k > k_max`: the matrix at `k_max` was written, but the entity should be treated as not
    /// occluding (visibility 1) — docs/conventions.md §3.3.
    AboveMax { k_max: f64 },
}

/// A table of `M_k` at K sampled values of k.
#[derive(Clone, Debug)]
pub struct KTable {
    family: TauFamily,
    eta: Eta,
    order: usize,
    spacing: Spacing,
    interp: Interp,
    ks: Vec<f64>,
    xs: Vec<f64>,
    log: bool,
    mats: Vec<ScalingMatrix<f64>>,
}

/// The K sample values for a spacing (validated: K ≥ 2, finite `k_min < k_max`, `k_min > 0` for
/// exponential spacing).
pub(crate) fn sample_ks(
    k_count: usize,
    k_min: f64,
    k_max: f64,
    spacing: Spacing,
) -> Result<Vec<f64>, ScalingError> {
    if k_count < 2 {
        return Err(ScalingError::Table(format!(
            "K = {k_count}: need at least 2 samples"
        )));
    }
    if !(k_min.is_finite() && k_max.is_finite() && k_min < k_max) {
        return Err(ScalingError::Table(format!(
            "k range [{k_min}, {k_max}] must be finite with k_min < k_max"
        )));
    }
    let last = (k_count - 1) as f64;
    Ok(match spacing {
        Spacing::Exp => {
            if k_min <= 0.0 {
                return Err(ScalingError::Table(format!(
                    "exponential spacing needs k_min > 0, got {k_min}"
                )));
            }
            let r = (k_max / k_min).ln();
            let mut v: Vec<f64> = (0..k_count)
                .map(|j| k_min * (r * j as f64 / last).exp())
                .collect();
            v[k_count - 1] = k_max;
            v
        }
        Spacing::Uniform => (0..k_count)
            .map(|j| k_min + (k_max - k_min) * j as f64 / last)
            .collect(),
        Spacing::Chebyshev => (0..k_count)
            .map(|j| {
                let c = -(PI * j as f64 / last).cos();
                let v = 0.5 * (k_min + k_max) + 0.5 * (k_max - k_min) * c;
                if j == 0 {
                    k_min
                } else if j == k_count - 1 {
                    k_max
                } else {
                    v
                }
            })
            .collect(),
    })
}

impl KTable {
    /// Build the table: `k_count` matrices of order `order` for `family` and `eta` over
    /// `[k_min, k_max]`.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        family: TauFamily,
        eta: Eta,
        order: usize,
        k_count: usize,
        k_min: f64,
        k_max: f64,
        spacing: Spacing,
        interp: Interp,
    ) -> Result<Self, ScalingError> {
        shscale_sh::check_order(order)?;
        match family {
            TauFamily::Cone { alpha } => {
                check_alpha(alpha)?;
                check_cone_k(k_min)?;
                check_cone_k(k_max)?;
            }
            TauFamily::ConeFit { theta0 } => {
                family.at(1.0)?;
                let _ = theta0;
                check_cone_k(k_min)?;
                check_cone_k(k_max)?;
            }
            TauFamily::MidRange => {
                check_midrange_k(k_min)?;
                check_midrange_k(k_max)?;
            }
        }
        if interp == Interp::Cubic && k_count < 4 {
            return Err(ScalingError::Table(format!(
                "cubic interpolation needs K ≥ 4, got {k_count}"
            )));
        }
        let ks = sample_ks(k_count, k_min, k_max, spacing)?;
        let log = k_min > 0.0;
        let xs = ks.iter().map(|&k| if log { k.ln() } else { k }).collect();
        let mats = ks
            .iter()
            .map(|&k| ScalingMatrix::compute(family.at(k)?.as_ref(), eta, order))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            family,
            eta,
            order,
            spacing,
            interp,
            ks,
            xs,
            log,
            mats,
        })
    }

    /// The sampled k values, ascending.
    pub fn ks(&self) -> &[f64] {
        &self.ks
    }

    /// The sampled matrices, in the order of [`KTable::ks`].
    pub fn matrices(&self) -> &[ScalingMatrix<f64>] {
        &self.mats
    }

    /// Whether the table interpolates in ln k (every table with `k_min > 0`) rather than in k.
    pub fn log_k(&self) -> bool {
        self.log
    }

    /// The order N.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The τ family, η, spacing and interpolation the table was built with.
    pub fn spec(&self) -> (TauFamily, Eta, Spacing, Interp) {
        (self.family, self.eta, self.spacing, self.interp)
    }

    /// Storage of the matrices in bytes (f64 distinct values).
    pub fn size_bytes(&self) -> usize {
        self.mats
            .iter()
            .map(|m| std::mem::size_of_val(m.values()))
            .sum()
    }

    /// Write `M_k` into `out` (same order) and say where k fell. Errors on a NaN k.
    pub fn lookup(&self, k: f64, out: &mut ScalingMatrix<f64>) -> Result<KLookup, ScalingError> {
        if k.is_nan() || (self.log && k <= 0.0) {
            return Err(ScalingError::Domain {
                name: "k",
                value: k,
                domain: "a number (and > 0 for log-k tables)",
            });
        }
        let kk = self.ks.len();
        let (k_min, k_max) = (self.ks[0], self.ks[kk - 1]);
        // A k within 1e-12 (relative) of an end is that end: distances recomputed from positions
        // (p = c + ρ r u, then |p − c|/r) round across the boundary otherwise.
        const END_TOL: f64 = 1e-12;
        let k = if k < k_min && k >= k_min * (1.0 - END_TOL) {
            k_min
        } else if k > k_max && k <= k_max * (1.0 + END_TOL) {
            k_max
        } else {
            k
        };
        if k < k_min {
            out.values_mut().copy_from_slice(self.mats[0].values());
            return Ok(KLookup::BelowMin { k_min });
        }
        if k > k_max {
            out.values_mut().copy_from_slice(self.mats[kk - 1].values());
            return Ok(KLookup::AboveMax { k_max });
        }
        let x = if self.log { k.ln() } else { k };
        let j = (self.xs.partition_point(|&v| v <= x).max(1) - 1).min(kk - 2);
        let out = out.values_mut();
        match self.interp {
            Interp::Linear => {
                let t = ((x - self.xs[j]) / (self.xs[j + 1] - self.xs[j])).clamp(0.0, 1.0);
                let (a, b) = (self.mats[j].values(), self.mats[j + 1].values());
                for ((o, &p), &q) in out.iter_mut().zip(a).zip(b) {
                    *o = p + t * (q - p);
                }
            }
            Interp::Cubic => {
                let s = j.saturating_sub(1).min(kk - 4);
                let idx = [s, s + 1, s + 2, s + 3];
                let w: Vec<f64> = idx
                    .iter()
                    .map(|&a| {
                        idx.iter()
                            .filter(|&&b| b != a)
                            .map(|&b| (x - self.xs[b]) / (self.xs[a] - self.xs[b]))
                            .product()
                    })
                    .collect();
                out.iter_mut().enumerate().for_each(|(e, o)| {
                    *o = idx
                        .iter()
                        .zip(&w)
                        .map(|(&a, &wa)| wa * self.mats[a].values()[e])
                        .sum();
                });
            }
        }
        Ok(KLookup::Interior)
    }

    /// The table's worst interpolation error: the largest absolute entry difference between the
    /// interpolated and the directly computed `M_k` at `per_interval` evenly spaced points (in the
    /// interpolation coordinate) inside every interval. Returns `(error, k where it occurs)`.
    pub fn max_interp_error(&self, per_interval: usize) -> Result<(f64, f64), ScalingError> {
        let mut worst = (0.0, self.ks[0]);
        let mut interp = ScalingMatrix::identity(self.order)?;
        for j in 0..self.ks.len() - 1 {
            for s in 1..=per_interval.max(1) {
                let x = self.xs[j]
                    + (self.xs[j + 1] - self.xs[j]) * s as f64 / (per_interval.max(1) + 1) as f64;
                let k = if self.log { x.exp() } else { x };
                self.lookup(k, &mut interp)?;
                let direct =
                    ScalingMatrix::compute(self.family.at(k)?.as_ref(), self.eta, self.order)?;
                let e = interp.max_abs_diff(&direct);
                if e > worst.0 {
                    worst = (e, k);
                }
            }
        }
        Ok(worst)
    }
}
