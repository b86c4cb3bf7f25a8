//! SH exponentiation as Ren et al. 2006 define it ("Real-time soft shadows in dynamic scenes
//! using spherical harmonic exponentiation"): logs and exponentials **in the algebra of the
//! truncated SH product**, so that `exp(log g) = g` for one blocker and the sum of the S
//! blockers' logs exponentiates to (an approximation of) the product of their visibilities.
//!
//! - The product matrix `M_g` of an order-N vector g: `M_g x = P_N(g·x)` ([`product_matrix`],
//!   from the Gaunt tensor; symmetric).
//! - **Log of a sphere blocker** ([`ZonalLogTable`]): its band-limited visibility
//!   `g = √(4π)e₀ − cap(A)` is zonal, `log g = log(M_g)·1` with the matrix logarithm taken on
//!   `M_g`'s eigenvalues clamped below at `ε·λ_max` (`log 0` does not exist: a blocked direction
//!   has an eigenvalue near 0). For a zonal g, `M_g` is block-diagonal in m and `1 = √(4π)e₀`
//!   lives in the m = 0 block, so only an N × N symmetric eigenproblem is solved. Tabulated over
//!   `t = 1 − cos A` ∈ [0, 1] (A ≤ π/2; 1,024 intervals, linear interpolation) and rotated onto
//!   each blocker's direction as a zonal function.
//! - **Exponentials** of a summed log f ([`Exp`]): `Exact` is `exp(M_f)·1` (the product
//!   algebra's exponential, by the eigen-decomposition of the N² × N² `M_f`); `Ol`, the
//!   optimal linear approximation with DC isolation, `e^{f₀/√(4π)} (a(‖f̂‖)·1 + b(‖f̂‖)·f̂)`,
//!   f̂ the log without its DC; `Hyb`, the hybrid: f halved k times until `‖f̂‖` is inside the OL
//!   table, OL, then squared k times by the truncated product.
//! - **The OL table** is fitted here, from the single blockers' logs as Ren et al. fit it: for
//!   each tabulated angle, `ĝ = e^{−f₀/√(4π)} exp(M_f)·1`, `a = ĝ₀/√(4π)`, `b = ⟨ĝ, f̂⟩/⟨f̂, f̂⟩`
//!   (the least-squares fit of `ĝ` by `a·1 + b·f̂`, since `f̂ ⊥ 1`), indexed by `‖f̂‖`.
//!
//! Domain: orders 1..=8 (the exact exponential's eigenproblem is N² × N²; the table's N × N);
//! `ε ∈ (0, 1)`; a point inside a sphere sees nothing (0), radius 0 occludes nothing, no sphere is
//! the constant 1. What SHEXP approximates is the truncated product chain, not the union of the
//! caps: each blocker enters band-limited (docs/math.md, "SH exponentiation").

use crate::evaluator::VisibilityField;
use crate::sphereset::QuadratureGrid;
use glam::DVec3;
use shscale_geometry::Sphere;
use shscale_sh::cap::cap_zonal;
use shscale_sh::rotation::rotate_zonal;
use shscale_sh::{GauntTensor, ShBasis};
use std::f64::consts::PI;

/// The clamp of the blockers' logs fixed for the study before its runs: eigenvalues below 2 %
/// of the largest are raised to it (the value of Ren et al.'s public demonstration code).
pub const SHEXP_EPS: f64 = 0.02;

/// The magnitude `‖f̂‖` below which [`exp_hyb`] applies OL without squaring, fixed from the
/// sweep against the exact exponential in `tests/shexp.rs` (random blocker sums, N = 4: each
/// halving of the target halves HYB's error; at 1/16, 64 blockers' sums are within 5 % of the
/// exact exponential at about 8 squarings), before the study's runs.
pub const HYB_MAGNITUDE: f64 = 0.0625;

/// The highest order SH exponentiation takes here.
pub const MAX_SHEXP_ORDER: usize = 8;

/// Intervals of the log table in `t = 1 − cos A` over [0, 1] (A ∈ [0, π/2]).
const TABLE_INTERVALS: usize = 1024;

/// `M_g` (row-major, N² × N²): `M_g x = P_N(g·x)` for the Gaunt tensor's order N.
pub fn product_matrix(gaunt: &GauntTensor<f64>, g: &[f64]) -> Vec<f64> {
    let nn = g.len();
    let mut m = vec![0.0; nn * nn];
    for &(i, j, k, c) in gaunt.entries() {
        let (i, j, k) = (i as usize, j as usize, k as usize);
        m[k * nn + i] += c * g[j];
        if i != j {
            m[k * nn + j] += c * g[i];
        }
    }
    m
}

/// The eigen-decomposition `A = V diag(λ) Vᵀ` of a symmetric `n × n` row-major matrix by cyclic
/// Jacobi rotations (Golub & Van Loan, *Matrix Computations*, §8.5: each rotation
/// `t = sgn θ/(|θ| + √(θ² + 1))`, `θ = (a_qq − a_pp)/(2a_pq)`, zeroes `a_pq`; quadratic
/// convergence): `(λ, V)`, V row-major with the eigenvectors as columns. Domain: any symmetric
/// matrix (its symmetry is assumed, not checked; `n ≥ 1`); it stops when the off-diagonal norm is
/// 1e-15 of the matrix's, or after 64 sweeps. Tested: a random 16 × 16 rebuilt to 1e-12 with
/// orthogonal V, a diagonal one untouched.
pub fn sym_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    assert_eq!(a.len(), n * n, "an n × n matrix");
    let mut a = a.to_vec();
    let mut v = vec![0.0; n * n];
    (0..n).for_each(|i| v[i * n + i] = 1.0);
    let norm2: f64 = a.iter().map(|x| x * x).sum();
    for _sweep in 0..64 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |j| *j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * n + j] * a[i * n + j])
            .sum();
        if off <= 1e-30 * norm2 || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

/// `V diag(f(λ)) Vᵀ x` for the decomposition `(λ, V)` of [`sym_eigen`].
fn apply_function(lambda: &[f64], v: &[f64], f: impl Fn(f64) -> f64, x: &[f64]) -> Vec<f64> {
    let n = lambda.len();
    let proj: Vec<f64> = (0..n)
        .map(|j| f(lambda[j]) * (0..n).map(|i| v[i * n + j] * x[i]).sum::<f64>())
        .collect();
    (0..n)
        .map(|i| (0..n).map(|j| v[i * n + j] * proj[j]).sum())
        .collect()
}

/// The m = 0 block of `M_g` for a zonal g (coefficients `z_l`, l < N): `N × N`, rows and
/// columns the indices `l² + l`.
fn zonal_block(gaunt: &GauntTensor<f64>, z: &[f64]) -> Vec<f64> {
    let n = z.len();
    let mut g = vec![0.0; n * n];
    (0..n).for_each(|l| g[l * l + l] = z[l]);
    let m = product_matrix(gaunt, &g);
    let mut b = vec![0.0; n * n];
    for r in 0..n {
        for c in 0..n {
            b[r * n + c] = m[(r * r + r) * n * n + c * c + c];
        }
    }
    b
}

/// `F(M)·1` for a symmetric `n × n` matrix M, with `F` acting on its eigenvalues as
/// `f(λ, λ_max)`: `V diag(f) Vᵀ 1`, `1 = √(4π)e₀` the product algebra's unit — every log and
/// exponential here.
fn of_unit(m: &[f64], n: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
    let (lambda, v) = sym_eigen(m, n);
    let max = lambda.iter().cloned().fold(f64::MIN, f64::max);
    let mut one = vec![0.0; n];
    one[0] = (4.0 * PI).sqrt();
    apply_function(&lambda, &v, |x| f(x, max), &one)
}

/// The product algebra's exponential `exp(M_f)·1` of a zonal f (coefficients `z_l`).
fn zonal_exp(gaunt: &GauntTensor<f64>, z: &[f64]) -> Vec<f64> {
    of_unit(&zonal_block(gaunt, z), z.len(), |x, _| x.exp())
}

/// The clamped product-algebra log of a zonal g: `log(max(M_g, ε λ_max))·1`.
pub fn zonal_log(gaunt: &GauntTensor<f64>, z: &[f64], eps: f64) -> Vec<f64> {
    of_unit(&zonal_block(gaunt, z), z.len(), |x, max| {
        x.max(eps * max).ln()
    })
}

/// One blocker's band-limited visibility as zonal coefficients: `√(4π)δ_l0 − cap(A)`.
fn blocker(order: usize, angle: f64) -> Vec<f64> {
    let mut z = cap_zonal(order, angle).expect("angle in [0, π/2]");
    z.iter_mut().for_each(|x| *x = -*x);
    z[0] += (4.0 * PI).sqrt();
    z
}

/// The tabulated logs of a sphere blocker and the fitted OL coefficients (module doc).
pub struct ZonalLogTable {
    order: usize,
    eps: f64,
    /// `TABLE_INTERVALS + 1` rows of N zonal log coefficients, at `1 − cos A = i/T`.
    logs: Vec<Vec<f64>>,
    /// `(‖f̂‖, a, b)` ascending in `‖f̂‖`.
    ol: Vec<(f64, f64, f64)>,
}

impl ZonalLogTable {
    /// The table of order N (1..=[`MAX_SHEXP_ORDER`], the Gaunt tensor's) and clamp ε ∈ (0, 1).
    pub fn new(gaunt: &GauntTensor<f64>, eps: f64) -> Self {
        let order = gaunt.order();
        assert!(
            (1..=MAX_SHEXP_ORDER).contains(&order),
            "SH exponentiation takes orders 1..={MAX_SHEXP_ORDER}, not {order}"
        );
        assert!(
            eps > 0.0 && eps < 1.0,
            "the log clamp ε = {eps} is outside (0, 1)"
        );
        let root = (4.0 * PI).sqrt();
        let logs: Vec<Vec<f64>> = (0..=TABLE_INTERVALS)
            .map(|i| {
                let t = i as f64 / TABLE_INTERVALS as f64;
                zonal_log(gaunt, &blocker(order, (1.0 - t).acos()), eps)
            })
            .collect();
        let mut ol: Vec<(f64, f64, f64)> = (logs.iter())
            .map(|f| {
                let e = zonal_exp(gaunt, f);
                let scale = (-f[0] / root).exp();
                let mag2: f64 = f[1..].iter().map(|x| x * x).sum();
                let a = scale * e[0] / root;
                let b = if mag2 > 0.0 {
                    scale * (e[1..].iter().zip(&f[1..]).map(|(x, y)| x * y).sum::<f64>()) / mag2
                } else {
                    1.0
                };
                (mag2.sqrt(), a, b)
            })
            .collect();
        ol.sort_by(|x, y| x.0.total_cmp(&y.0));
        Self {
            order,
            eps,
            logs,
            ol,
        }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    pub fn eps(&self) -> f64 {
        self.eps
    }

    /// The tabulated zonal logs: `TABLE_INTERVALS + 1` rows of N coefficients at
    /// `t = 1 − cos A = i / TABLE_INTERVALS` (what [`Self::log_of_t`] interpolates; a device
    /// copy's).
    pub fn log_rows(&self) -> &[Vec<f64>] {
        &self.logs
    }

    /// The OL rows `(‖f̂‖, a, b)`, ascending in `‖f̂‖` (what [`Self::ol_coefficients`]
    /// interpolates; a device copy's).
    pub fn ol_rows(&self) -> &[(f64, f64, f64)] {
        &self.ol
    }

    /// The largest `‖f̂‖` the OL table covers (a hemisphere-sized blocker's).
    pub fn max_magnitude(&self) -> f64 {
        self.ol.last().map_or(0.0, |r| r.0)
    }

    /// The zonal log of a blocker of half-angle `angle` ∈ [0, π/2].
    pub fn log_of(&self, angle: f64) -> Vec<f64> {
        self.log_of_t(2.0 * (0.5 * angle.clamp(0.0, PI / 2.0)).sin().powi(2))
    }

    /// The zonal log of a blocker with `t = 1 − cos A` ∈ [0, 1] (linear interpolation in t, in
    /// which a small cap's log is nearly linear: its occlusion is the solid angle `2πt`).
    pub fn log_of_t(&self, t: f64) -> Vec<f64> {
        let x = t.clamp(0.0, 1.0) * TABLE_INTERVALS as f64;
        let i = (x.floor() as usize).min(TABLE_INTERVALS - 1);
        let t = x - i as f64;
        (self.logs[i].iter().zip(&self.logs[i + 1]))
            .map(|(a, b)| a + t * (b - a))
            .collect()
    }

    /// `(a, b)` at magnitude `m` (linear interpolation; clamped to the table's ends).
    pub fn ol_coefficients(&self, m: f64) -> (f64, f64) {
        let k = self.ol.partition_point(|r| r.0 < m);
        if k == 0 {
            return (self.ol[0].1, self.ol[0].2);
        }
        if k >= self.ol.len() {
            let r = self.ol[self.ol.len() - 1];
            return (r.1, r.2);
        }
        let (lo, hi) = (self.ol[k - 1], self.ol[k]);
        let t = if hi.0 > lo.0 {
            (m - lo.0) / (hi.0 - lo.0)
        } else {
            0.0
        };
        (lo.1 + t * (hi.1 - lo.1), lo.2 + t * (hi.2 - lo.2))
    }
}

/// The exponential applied to a summed log.
#[derive(Clone, Copy)]
pub enum Exp<'a> {
    /// `exp(M_f)·1`, the product algebra's exponential (an N² × N² eigenproblem per point).
    Exact,
    /// The optimal linear approximation with DC isolation.
    Ol,
    /// OL after halving into the table's range, then squaring back by truncated products.
    Hyb,
    /// The pointwise exponential of the band-limited log, by quadrature, re-projected.
    Pointwise(&'a QuadratureGrid),
}

/// `exp(M_f)·1` for any order-N f.
pub fn exp_exact(gaunt: &GauntTensor<f64>, f: &[f64]) -> Vec<f64> {
    of_unit(&product_matrix(gaunt, f), f.len(), |x, _| x.exp())
}

/// The OL exponential of `f` with `table`'s coefficients.
pub fn exp_ol(table: &ZonalLogTable, f: &[f64]) -> Vec<f64> {
    let root = (4.0 * PI).sqrt();
    let m = f[1..].iter().map(|x| x * x).sum::<f64>().sqrt();
    let (a, b) = table.ol_coefficients(m);
    let scale = (f[0] / root).exp();
    let mut out: Vec<f64> = f.iter().map(|x| scale * b * x).collect();
    out[0] = scale * a * root;
    out
}

/// The HYB exponential: f halved until `‖f̂‖` is below `target` (and inside the OL table), OL,
/// squared back by truncated products. [`HYB_MAGNITUDE`] is the study's target.
pub fn exp_hyb(
    table: &ZonalLogTable,
    gaunt: &GauntTensor<f64>,
    f: &[f64],
    target: f64,
) -> Vec<f64> {
    let limit = target.min(0.96 * table.max_magnitude());
    let mut g = f.to_vec();
    let mut m = g[1..].iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut squarings = 0;
    while m >= limit && squarings < 64 {
        g.iter_mut().for_each(|x| *x *= 0.5);
        m *= 0.5;
        squarings += 1;
    }
    let mut out = exp_ol(table, &g);
    let mut tmp = vec![0.0; out.len()];
    for _ in 0..squarings {
        gaunt
            .product(&out, &out, &mut tmp)
            .expect("the table's order");
        std::mem::swap(&mut out, &mut tmp);
    }
    out
}

/// A sphere set combined by SH exponentiation: the blockers' tabulated logs rotated onto their
/// directions, summed, and exponentiated by `exp`.
pub struct SphereSetShexp<'a> {
    spheres: Vec<Sphere>,
    basis: &'a ShBasis<f64>,
    gaunt: &'a GauntTensor<f64>,
    table: &'a ZonalLogTable,
    exp: Exp<'a>,
}

impl<'a> SphereSetShexp<'a> {
    /// `basis`, `gaunt` and `table` of one order.
    pub fn new(
        spheres: &[Sphere],
        (basis, gaunt): (&'a ShBasis<f64>, &'a GauntTensor<f64>),
        table: &'a ZonalLogTable,
        exp: Exp<'a>,
    ) -> Self {
        assert!(
            basis.order() == table.order() && gaunt.order() == table.order(),
            "basis, Gaunt tensor and log table of one order"
        );
        Self {
            spheres: spheres.to_vec(),
            basis,
            gaunt,
            table,
            exp,
        }
    }

    /// The summed log at `p`, or `None` inside a sphere.
    pub(crate) fn log_at(&self, p: DVec3) -> Option<Vec<f64>> {
        let n = self.table.order();
        let (mut sum, mut rotated) = (vec![0.0; n * n], vec![0.0; n * n]);
        for s in self.spheres.iter().filter(|s| s.radius > 0.0) {
            let oc = s.center - p;
            let d = oc.length();
            if d < s.radius {
                return None;
            }
            let sin_a = (s.radius / d).min(1.0);
            let cos_a = ((d - s.radius) * (d + s.radius)).max(0.0).sqrt() / d;
            let zl = self.table.log_of_t(sin_a * sin_a / (1.0 + cos_a));
            rotate_zonal(self.basis, &zl, (oc / d).to_array(), &mut rotated)
                .expect("the table's order");
            sum.iter_mut().zip(&rotated).for_each(|(a, b)| *a += b);
        }
        Some(sum)
    }

    /// Bytes a frame's set holds (centre and radius per sphere).
    pub fn size_bytes(&self) -> usize {
        self.spheres.len() * 32
    }
}

impl VisibilityField for SphereSetShexp<'_> {
    /// `out`: N² coefficients, N at most the table's order.
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let Some(f) = self.log_at(p) else {
            out.iter_mut().for_each(|o| *o = 0.0);
            return;
        };
        let v = match self.exp {
            Exp::Exact => exp_exact(self.gaunt, &f),
            Exp::Ol => exp_ol(self.table, &f),
            Exp::Hyb => exp_hyb(self.table, self.gaunt, &f, HYB_MAGNITUDE),
            Exp::Pointwise(grid) => {
                let mut v = vec![0.0; f.len()];
                crate::shexp::exp_by_quadrature(grid, &f, &mut v);
                v
            }
        };
        out.copy_from_slice(&v[..out.len()]);
    }
}

/// The product-algebra log of a sampled visibility `v` (order N, any direction dependence):
/// `log(max(M_v, ε))·1`, the eigenvalues of `M_v` raised to the **absolute** floor ε (a sampled
/// visibility can be blocked in every direction — a sample on the surface, inside a concavity —
/// where `M_v`'s largest eigenvalue is itself near 0 and a relative floor would not bound the
/// log; for a sphere blocker's cap, whose largest eigenvalue is about 1, the two agree).
pub fn log_visibility(gaunt: &GauntTensor<f64>, v: &[f64], eps: f64) -> Vec<f64> {
    of_unit(&product_matrix(gaunt, v), v.len(), |x, _| x.max(eps).ln())
}

/// `bsv` with every sample's visibility replaced by its clamped product-algebra log
/// ([`log_visibility`]): the base-sphere log-visibility, which the extrapolator scales like any
/// coefficient vector (SH scaling is an angular warp: `M_k log V` approximates the log of the
/// scaled visibility).
pub fn log_bsv(bsv: &crate::Bsv, gaunt: &GauntTensor<f64>, eps: f64) -> crate::Bsv {
    let mut out = bsv.clone();
    for s in &mut out.samples {
        s.coeffs = log_visibility(gaunt, &s.coeffs, eps);
    }
    out
}

/// Sub-volumes combined in log space (the many-occluders issue, item 3): each part's
/// base-sphere **log**-visibility extrapolated with its own k, the parts' logs summed, and the
/// sum exponentiated once by HYB — against [`crate::subvolume::SubVolumeField`], which scales
/// each part's visibility and multiplies them near to far.
pub struct SubVolumeLog<'a> {
    parts: &'a [crate::extrapolate::Extrapolator<'a>],
    gaunt: &'a GauntTensor<f64>,
    table: &'a ZonalLogTable,
}

impl<'a> SubVolumeLog<'a> {
    /// Extrapolators over log-BSVs ([`log_bsv`]; at least one, of the table's order, without
    /// the plausibility clamp, which bounds visibilities, not logs).
    pub fn new(
        parts: &'a [crate::extrapolate::Extrapolator<'a>],
        gaunt: &'a GauntTensor<f64>,
        table: &'a ZonalLogTable,
    ) -> Self {
        assert!(!parts.is_empty(), "a sub-volume field needs a part");
        Self {
            parts,
            gaunt,
            table,
        }
    }
}

impl VisibilityField for SubVolumeLog<'_> {
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let nn = self.table.order() * self.table.order();
        let (mut sum, mut part) = (vec![0.0; nn], vec![0.0; nn]);
        for e in self.parts {
            VisibilityField::eval(e, p, &mut part);
            sum.iter_mut().zip(&part).for_each(|(a, b)| *a += b);
        }
        let v = exp_hyb(self.table, self.gaunt, &sum, HYB_MAGNITUDE);
        out.copy_from_slice(&v[..out.len()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jacobi against its definition: `V diag(λ) Vᵀ` rebuilds the matrix and V is orthogonal,
    /// on a random symmetric 16 × 16 and a diagonal one (no rotation needed).
    #[test]
    fn jacobi_rebuilds_the_matrix() {
        let n = 16;
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in i..n {
                let x = rnd();
                a[i * n + j] = x;
                a[j * n + i] = x;
            }
        }
        let (l, v) = sym_eigen(&a, n);
        let mut worst = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let r: f64 = (0..n).map(|k| v[i * n + k] * l[k] * v[j * n + k]).sum();
                let o: f64 = (0..n).map(|k| v[k * n + i] * v[k * n + j]).sum();
                worst = worst
                    .max((r - a[i * n + j]).abs())
                    .max((o - f64::from(u8::from(i == j))).abs());
            }
        }
        println!("Jacobi 16 × 16: worst rebuild / orthogonality error {worst:.1e}");
        assert!(worst < 1e-12, "{worst}");
        let d = [3.0, 0.0, 0.0, -1.0];
        assert_eq!(sym_eigen(&d, 2).0, vec![3.0, -1.0]);
    }

    /// The product matrix is the truncated product: `M_g x = gaunt.product(g, x)`.
    #[test]
    fn product_matrix_is_the_truncated_product() {
        let gaunt = GauntTensor::<f64>::new(4).unwrap();
        let g: Vec<f64> = (0..16).map(|i| (i as f64 * 0.7).sin()).collect();
        let x: Vec<f64> = (0..16).map(|i| (i as f64 * 1.3).cos()).collect();
        let m = product_matrix(&gaunt, &g);
        let mut want = vec![0.0; 16];
        gaunt.product(&g, &x, &mut want).unwrap();
        for k in 0..16 {
            let got: f64 = (0..16).map(|i| m[k * 16 + i] * x[i]).sum();
            assert!((got - want[k]).abs() < 1e-13, "{k}");
        }
    }
}
