//! Angular scaling functions τ: the backward map from a polar angle seen at the receiver to the
//! polar angle seen at the sample, `F_d(θ, φ) = F_r(τ(θ), φ)` (paper Eq. 1; docs/conventions.md §3).
//!
//! Every τ here is a strictly increasing bijection of `[0, π]` with `τ(0) = 0`, `τ(π) = π`, and
//! `τ′ > 0`; the matrix integrator relies on this (it partitions θ at preimages `τ⁻¹(u)`).

use crate::error::ScalingError;
use std::f64::consts::PI;

/// An angular scaling function: τ, its derivative and its inverse on `[0, π]`.
pub trait AngularScaling: Send + Sync {
    /// `τ(θ)` for `θ ∈ [0, π]`, in `[0, π]`.
    fn tau(&self, theta: f64) -> f64;
    /// `τ′(θ) > 0` for `θ ∈ [0, π]`.
    fn dtau(&self, theta: f64) -> f64;
    /// `τ⁻¹(u)` for `u ∈ [0, π]`. The default bisects τ to ~1 ulp of π (62 halvings).
    fn inverse(&self, u: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, PI);
        for _ in 0..62 {
            let mid = 0.5 * (lo + hi);
            if self.tau(mid) < u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
    /// Short name for output (`cone`, `midrange`, `identity`, `tabulated`).
    fn name(&self) -> &'static str;
}

/// The identity `τ(θ) = θ` (scale factor 1; `M = I`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Identity;

impl AngularScaling for Identity {
    fn tau(&self, theta: f64) -> f64 {
        theta
    }
    fn dtau(&self, _theta: f64) -> f64 {
        1.0
    }
    fn inverse(&self, u: f64) -> f64 {
        u
    }
    fn name(&self) -> &'static str {
        "identity"
    }
}

/// The cone model of the silhouette with half-angle α (paper Sec. 3.1 generalised, docs/conventions.md
/// §3.1). With `k = d/r` (receiver distance over bounding-sphere radius) and `a = tan α`,
/// `tan θ_r = k·a·tan θ_d / (a + (1−k)·tan θ_d)`, evaluated in the branch-free form
///
/// ```text
/// τ_k(θ)  = atan2(Y, X),  Y = k·sinα·sinθ,  X = sinα·cosθ + (1−k)·cosα·sinθ
/// τ_k′(θ) = k·sin²α / (X² + Y²)
/// ```
///
/// `Y ≥ 0` on `[0, π]`, so atan2 lands in `[0, π]` and replaces the paper's `θ′ < 0 → θ′ + π` rule.
/// Domain: `k` finite and `> 0`; `α ∈ (0, π/2)` open. Properties (tested): `τ_1 = id`,
/// `τ_{k1}∘τ_{k2} = τ_{k1·k2}`, `τ_k⁻¹ = τ_{1/k}`, `θ = π − α` fixed for every k.
/// For `α = π/4` this is the paper's `arctan(k tanθ / (1 + tanθ − k tanθ))`. Note the technical
/// report writes the same formula with `k = r/d`; we follow the journal paper (`k = d/r`).
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    k: f64,
    alpha: f64,
    sa: f64,
    ca: f64,
}

impl Cone {
    /// The cone map for scale `k = d/r` and half-angle `alpha` (radians).
    pub fn new(k: f64, alpha: f64) -> Result<Self, ScalingError> {
        check_cone_k(k)?;
        check_alpha(alpha)?;
        Ok(Self {
            k,
            alpha,
            sa: alpha.sin(),
            ca: alpha.cos(),
        })
    }

    /// The scale `k`.
    pub fn k(&self) -> f64 {
        self.k
    }

    /// The half-angle α in radians.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    #[inline]
    fn xy(&self, theta: f64) -> (f64, f64) {
        let (s, c) = theta.sin_cos();
        (
            self.sa * c + (1.0 - self.k) * self.ca * s,
            self.k * self.sa * s,
        )
    }
}

/// Check a cone scale: finite and `> 0`.
pub(crate) fn check_cone_k(k: f64) -> Result<(), ScalingError> {
    if k.is_finite() && k > 0.0 {
        Ok(())
    } else {
        Err(ScalingError::Domain {
            name: "k",
            value: k,
            domain: "finite and > 0 for the cone model",
        })
    }
}

/// Check a cone half-angle: `α ∈ (0, π/2)`.
pub(crate) fn check_alpha(alpha: f64) -> Result<(), ScalingError> {
    if alpha.is_finite() && alpha > 0.0 && alpha < 0.5 * PI {
        Ok(())
    } else {
        Err(ScalingError::Domain {
            name: "alpha",
            value: alpha.to_degrees(),
            domain: "(0°, 90°) open, in degrees",
        })
    }
}

impl AngularScaling for Cone {
    #[inline]
    fn tau(&self, theta: f64) -> f64 {
        let (x, y) = self.xy(theta);
        y.atan2(x)
    }
    #[inline]
    fn dtau(&self, theta: f64) -> f64 {
        let (x, y) = self.xy(theta);
        self.k * self.sa * self.sa / (x * x + y * y)
    }
    fn inverse(&self, u: f64) -> f64 {
        // Group law: τ_k⁻¹ = τ_{1/k}.
        Cone {
            k: 1.0 / self.k,
            ..*self
        }
        .tau(u)
    }
    fn name(&self) -> &'static str {
        "cone"
    }
}

/// Mid-range environment lighting (paper Sec. 3.2, Eq. 7; docs/conventions.md §3.2): an environment sphere
/// of radius R centred at the sample, the receiver displaced by `d` along the local +z axis,
/// `k = d/R ∈ (−1, 1)`. Exactly, `τ(θ) = θ − asin(k sinθ)` (law of sines in the triangle centre,
/// receiver, hit point). Evaluated without cancellation as
///
/// ```text
/// τ(θ) = 2·atan2((1−k)·sinθ, √(1−k²sin²θ) + cosθ)     for cosθ ≥ 0   (docs/conventions.md §3.2)
/// τ(θ) = 2·atan2(√(1−k²sin²θ) − cosθ, (1+k)·sinθ)     for cosθ < 0
/// ```
///
/// (the second is the first with numerator and denominator multiplied by `√(1−k²s²) − cosθ`; it
/// avoids `0/0` at `θ = π`). With `q = √(1−k²sin²θ)`, `τ′ = (1−k²)/(q(q + k cosθ))` when
/// `k cosθ ≥ 0` and `(q − k cosθ)/q` otherwise; `τ′(0) = 1−k`. Inverse:
/// `τ⁻¹(u) = atan2(sin u, (1−k) − 2 sin²(u/2))`. Domain: `k ∈ (−1, 1)`.
#[derive(Clone, Copy, Debug)]
pub struct MidRange {
    k: f64,
}

impl MidRange {
    /// The mid-range map for the signed displacement ratio `k = d/R`.
    pub fn new(k: f64) -> Result<Self, ScalingError> {
        check_midrange_k(k)?;
        Ok(Self { k })
    }

    /// The ratio `k`.
    pub fn k(&self) -> f64 {
        self.k
    }
}

/// Check a mid-range ratio: `−1 < k < 1`.
pub(crate) fn check_midrange_k(k: f64) -> Result<(), ScalingError> {
    if k.is_finite() && k > -1.0 && k < 1.0 {
        Ok(())
    } else {
        Err(ScalingError::Domain {
            name: "k",
            value: k,
            domain: "(-1, 1) for mid-range lighting (k = d/R)",
        })
    }
}

impl AngularScaling for MidRange {
    fn tau(&self, theta: f64) -> f64 {
        let (s, c) = theta.sin_cos();
        let k = self.k;
        let q = (1.0 - k * k * s * s).sqrt();
        if c >= 0.0 {
            2.0 * ((1.0 - k) * s).atan2(q + c)
        } else {
            2.0 * (q - c).atan2((1.0 + k) * s)
        }
    }
    fn dtau(&self, theta: f64) -> f64 {
        let (s, c) = theta.sin_cos();
        let k = self.k;
        let q = (1.0 - k * k * s * s).sqrt();
        if k * c >= 0.0 {
            (1.0 - k) * (1.0 + k) / (q * (q + k * c))
        } else {
            (q - k * c) / q
        }
    }
    fn inverse(&self, u: f64) -> f64 {
        let h = (0.5 * u).sin();
        u.sin().atan2((1.0 - self.k) - 2.0 * h * h)
    }
    fn name(&self) -> &'static str {
        "midrange"
    }
}

/// A τ tabulated at strictly increasing samples `(θ_i, τ_i)` covering `[0, π]` with `τ(0) = 0` and
/// `τ(π) = π`, interpolated by the monotone piecewise-cubic Hermite scheme of Fritsch & Carlson
/// (1980) (PCHIP: harmonic-mean knot slopes, one-sided at the ends), so τ stays increasing and τ′
/// is the exact derivative of the interpolant. For fitted or user-supplied mappings.
#[derive(Clone, Debug)]
pub struct Tabulated {
    theta: Vec<f64>,
    tau: Vec<f64>,
    slope: Vec<f64>,
}

impl Tabulated {
    /// Build from samples. Errors name the first offending sample.
    pub fn new(theta: Vec<f64>, tau: Vec<f64>) -> Result<Self, ScalingError> {
        let n = theta.len();
        if n < 2 || tau.len() != n {
            return Err(ScalingError::Tabulated(format!(
                "need ≥ 2 samples of equal length, got {} θ and {} τ",
                n,
                tau.len()
            )));
        }
        for (i, (&t, &u)) in theta.iter().zip(&tau).enumerate() {
            if !t.is_finite() || !u.is_finite() {
                return Err(ScalingError::Tabulated(format!(
                    "sample {i} is not finite (θ={t}, τ={u})"
                )));
            }
            if i > 0 && (t <= theta[i - 1] || u <= tau[i - 1]) {
                return Err(ScalingError::Tabulated(format!(
                    "sample {i} (θ={t}, τ={u}) is not strictly above sample {} (θ={}, τ={})",
                    i - 1,
                    theta[i - 1],
                    tau[i - 1]
                )));
            }
        }
        const END_TOL: f64 = 1e-9;
        if theta[0].abs() > END_TOL || tau[0].abs() > END_TOL {
            return Err(ScalingError::Tabulated(format!(
                "first sample must be (0, 0), got ({}, {})",
                theta[0], tau[0]
            )));
        }
        if (theta[n - 1] - PI).abs() > END_TOL || (tau[n - 1] - PI).abs() > END_TOL {
            return Err(ScalingError::Tabulated(format!(
                "last sample must be (π, π), got ({}, {})",
                theta[n - 1],
                tau[n - 1]
            )));
        }
        let (mut theta, mut tau) = (theta, tau);
        theta[0] = 0.0;
        tau[0] = 0.0;
        theta[n - 1] = PI;
        tau[n - 1] = PI;
        let delta: Vec<f64> = (0..n - 1)
            .map(|i| (tau[i + 1] - tau[i]) / (theta[i + 1] - theta[i]))
            .collect();
        let mut slope = vec![0.0; n];
        slope[0] = delta[0];
        slope[n - 1] = delta[n - 2];
        for i in 1..n - 1 {
            let (h0, h1) = (theta[i] - theta[i - 1], theta[i + 1] - theta[i]);
            let (w1, w2) = (2.0 * h1 + h0, h1 + 2.0 * h0);
            slope[i] = (w1 + w2) / (w1 / delta[i - 1] + w2 / delta[i]);
        }
        Ok(Self { theta, tau, slope })
    }

    /// Sample `other` at `n ≥ 2` uniform angles (e.g. to approximate a closed form).
    pub fn sample(other: &dyn AngularScaling, n: usize) -> Result<Self, ScalingError> {
        let n = n.max(2);
        let theta: Vec<f64> = (0..n).map(|i| PI * i as f64 / (n - 1) as f64).collect();
        let tau = theta.iter().map(|&t| other.tau(t)).collect();
        Self::new(theta, tau)
    }

    /// Hermite data at θ: local parameter `s ∈ [0, 1]`, width `h`, end values and scaled slopes.
    fn hermite(&self, theta: f64) -> (f64, f64, [f64; 4]) {
        let (i, s, h) = self.segment(theta);
        (
            s,
            h,
            [
                self.tau[i],
                self.tau[i + 1],
                self.slope[i] * h,
                self.slope[i + 1] * h,
            ],
        )
    }

    fn segment(&self, theta: f64) -> (usize, f64, f64) {
        let t = theta.clamp(0.0, PI);
        let i = match self.theta.partition_point(|&x| x <= t) {
            0 => 0,
            p => (p - 1).min(self.theta.len() - 2),
        };
        let h = self.theta[i + 1] - self.theta[i];
        (i, (t - self.theta[i]) / h, h)
    }
}

impl AngularScaling for Tabulated {
    fn tau(&self, theta: f64) -> f64 {
        let (s, _, [y0, y1, d0, d1]) = self.hermite(theta);
        let (s2, s3) = (s * s, s * s * s);
        (2.0 * s3 - 3.0 * s2 + 1.0) * y0
            + (s3 - 2.0 * s2 + s) * d0
            + (-2.0 * s3 + 3.0 * s2) * y1
            + (s3 - s2) * d1
    }
    fn dtau(&self, theta: f64) -> f64 {
        let (s, h, [y0, y1, d0, d1]) = self.hermite(theta);
        let s2 = s * s;
        ((6.0 * s2 - 6.0 * s) * y0
            + (3.0 * s2 - 4.0 * s + 1.0) * d0
            + (-6.0 * s2 + 6.0 * s) * y1
            + (3.0 * s2 - 2.0 * s) * d1)
            / h
    }
    fn name(&self) -> &'static str {
        "tabulated"
    }
}
