//! The SH scaling matrix `M` (paper Eq. 5–6, Appendix; docs/conventions.md §3) in its sparse block form.
//!
//! With `Y_l^m = S_m(φ) P̄_l^{|m|}(cosθ)` and `∫₀^{2π} S_m S_{m'} dφ = 2π δ_{mm'}`,
//!
//! ```text
//! M_{(l',m),(l,m)} = 2π ∫₀^π P̄_l^{|m|}(cos τ(θ)) · P̄_{l'}^{|m|}(cos θ) · η(θ) dθ,   m' ≠ m → 0
//! η(θ) = sinθ (plain)   or   sin τ(θ) · τ′(θ) (energy preserving, paper Eq. 2; TR Appendix A)
//! ```
//!
//! so `M` is block diagonal in `m` and the `−m` block equals the `+m` block. Row `i` of the dense
//! matrix is the output coefficient `(l', m)`, column `j` the input `(l, m)`. Storage keeps only
//! the distinct values, one `(N−m)×(N−m)` block per `m ≥ 0`: `Σ_{m=0}^{N−1}(N−m)² = N(N+1)(2N+1)/6`
//! numbers (30 at N = 4). The papers' count of non-zeros, `N(2N²+1)/3` (44 at N = 4), is the
//! number of *structurally allowed* positions. Fewer are non-zero: for the plain η, column 0
//! (input = constant) is `√(4π)·e_0` because scaling a constant gives the same constant; for the
//! energy η, row 0 is `e_0ᵀ` because the integral of the function (its energy) is preserved. Each
//! removes `N−1` entries, so a generic τ has `N(2N²+1)/3 − (N−1)` non-zeros (41 at N = 4); see
//! docs/math.md.
//!
//! The energy-preserving matrix is integrated after the substitution `u = τ(θ)`:
//! `M_energy(τ)_{ij} = 2π ∫ P̄_j(cos u) P̄_i(cos τ⁻¹(u)) sin u du = M_plain(τ⁻¹)_{ji}` (docs/conventions.md
//! §3.1). In θ the weight `sin τ · τ′` has peaks of height up to `1/(k sin²α)` and width
//! `k sin²α` — below the spacing of doubles near π for a needle cone (α = 1e-4°, k = 1e-3) — while
//! in `u` the integrand is bounded by the Legendre values. The direct θ form is kept
//! ([`EnergyForm::Direct`]) so the tests can check the identity between the two integrals.
//!
//! All blocks come from one adaptive θ-integration ([`crate::quad`]) of the vector of every block
//! entry, on an initial partition that unites a uniform grid in θ with the preimages `τ⁻¹(u_j)`
//! of a uniform grid in `u = τ(θ)` — so panels start dense where τ changes fast (the boundary
//! layers of width ~1/k at large k, around `π − α` at small k, and the needle of small α).

use crate::error::ScalingError;
use crate::quad::{integrate_vec, QuadReport};
use crate::tau::AngularScaling;
use shscale_sh::legendre::{tri_count, tri_index, Legendre};
use shscale_sh::{check_coeffs, check_order, coeff_count, GaussLegendre, Real};
use std::f64::consts::PI;

/// The angular weight η in the scaling integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Eta {
    /// `η = sinθ`: `F_d(θ) = F_r(τ(θ))` (visibility).
    Plain,
    /// `η = sin τ(θ) · τ′(θ)`: preserves `∫F` (radiance of lights).
    Energy,
}

/// Number of structurally allowed non-zero positions, `N(2N²+1)/3` (the papers' count).
pub const fn structural_nonzeros(order: usize) -> usize {
    order * (2 * order * order + 1) / 3
}

/// Number of distinct stored values, `Σ_{m=0}^{N−1}(N−m)² = N(N+1)(2N+1)/6`.
pub const fn distinct_count(order: usize) -> usize {
    order * (order + 1) * (2 * order + 1) / 6
}

/// Offset of block `m` in the packed storage: `Σ_{m'<m}(N−m')²`.
#[inline(always)]
fn block_offset(order: usize, m: usize) -> usize {
    distinct_count(order) - distinct_count(order - m)
}

/// How the energy-preserving matrix is integrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnergyForm {
    /// In `u = τ(θ)`: the plain integral of `τ⁻¹`, transposed (robust at every extreme).
    Substituted,
    /// In θ with `η = sin τ(θ) · τ′(θ)` (paper Eq. 2 as written; fails to resolve the peaks of
    /// τ′ at extreme k or α).
    Direct,
}

/// Options of the adaptive θ quadrature.
#[derive(Clone, Copy, Debug)]
pub struct QuadOptions {
    /// Integration form of the energy-preserving matrix.
    pub energy_form: EnergyForm,
    /// Absolute tolerance on every entry (the sum of accepted panel error bounds targets it).
    pub tol: f64,
    /// Gauss–Legendre nodes per panel.
    pub nodes: usize,
    /// Cap on accepted panels; the report says whether it was hit.
    pub max_panels: usize,
    /// Panels of the initial uniform partition in θ and, separately, in `u = τ(θ)`
    /// (at least the order is used).
    pub initial_panels: usize,
}

impl Default for QuadOptions {
    fn default() -> Self {
        Self {
            energy_form: EnergyForm::Substituted,
            tol: 1e-13,
            nodes: 10,
            max_panels: 200_000,
            initial_panels: 8,
        }
    }
}

/// A scaling matrix of one order, stored as its distinct `m ≥ 0` blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalingMatrix<T> {
    order: usize,
    values: Vec<T>,
}

impl ScalingMatrix<f64> {
    /// `M` for `tau`, `eta` and order `N` with the default quadrature options (entries accurate
    /// to ~1e-13 absolute). Errors if the order is invalid or the quadrature did not converge.
    pub fn compute(tau: &dyn AngularScaling, eta: Eta, order: usize) -> Result<Self, ScalingError> {
        let (m, report) = Self::compute_with(tau, eta, order, &QuadOptions::default())?;
        if !report.converged {
            return Err(ScalingError::Domain {
                name: "scaling-matrix quadrature error bound",
                value: report.error_bound,
                domain: "did not reach its tolerance within max_panels",
            });
        }
        Ok(m)
    }

    /// `M` and the quadrature report, with explicit options.
    pub fn compute_with(
        tau: &dyn AngularScaling,
        eta: Eta,
        order: usize,
        opts: &QuadOptions,
    ) -> Result<(Self, QuadReport), ScalingError> {
        check_order(order)?;
        if eta == Eta::Energy && opts.energy_form == EnergyForm::Substituted {
            let (m, report) = Self::compute_with(&Inverted(tau), Eta::Plain, order, opts)?;
            return Ok((m.transpose(), report));
        }
        let leg = Legendre::<f64>::new(order)?;
        let tc = tri_count(order);
        let (mut pa, mut pb) = (vec![0.0; tc], vec![0.0; tc]);
        let dim = distinct_count(order);
        let mut integrand = |theta: f64, out: &mut [f64]| {
            let t = tau.tau(theta);
            let (st, ct) = t.sin_cos();
            leg.eval(ct, st.max(0.0), &mut pa);
            let (s, c) = theta.sin_cos();
            leg.eval(c, s.max(0.0), &mut pb);
            let w = match eta {
                Eta::Plain => s,
                Eta::Energy => st * tau.dtau(theta),
            };
            let mut k = 0;
            for m in 0..order {
                for lo in m..order {
                    let bo = w * pb[tri_index(lo, m)];
                    for li in m..order {
                        out[k] = bo * pa[tri_index(li, m)];
                        k += 1;
                    }
                }
            }
        };
        let breaks = initial_partition(tau, opts.initial_panels.max(order));
        let gl = GaussLegendre::new(opts.nodes.max(2));
        let mut values = vec![0.0; dim];
        // The integrand carries no 2π; scale the tolerance so the final entries meet `tol`.
        let report = integrate_vec(
            &mut integrand,
            dim,
            &breaks,
            &gl,
            opts.tol / (2.0 * PI),
            opts.max_panels,
            &mut values,
        );
        values.iter_mut().for_each(|v| *v *= 2.0 * PI);
        Ok((
            Self { order, values },
            QuadReport {
                error_bound: report.error_bound * 2.0 * PI,
                ..report
            },
        ))
    }
}

/// `y = M·x` for order `n` from the packed blocks `v`: for each `m`, the `(N−m)²` block multiplies
/// the `+m` and the `−m` coefficients (indices `l² + l ± m`).
#[inline(always)]
fn apply_kernel<T: Real>(v: &[T], n: usize, x: &[T], y: &mut [T]) {
    let (x, y) = (&x[..n * n], &mut y[..n * n]);
    let mut off = 0;
    for m in 0..n {
        let w = n - m;
        let blk = &v[off..off + w * w];
        off += w * w;
        for r in 0..w {
            let lo = m + r;
            let (mut acc_p, mut acc_n) = (T::zero(), T::zero());
            for c in 0..w {
                let li = m + c;
                let b = blk[r * w + c];
                acc_p = acc_p + b * x[li * li + li + m];
                acc_n = acc_n + b * x[li * li + li - m];
            }
            // For m = 0 both accumulators hold the same value (the duplicate is cheaper than a
            // branch once unrolled).
            y[lo * lo + lo - m] = acc_n;
            y[lo * lo + lo + m] = acc_p;
        }
    }
}

/// `τ⁻¹` as an angular scaling function (for the substituted energy integral).
struct Inverted<'a>(&'a dyn AngularScaling);

impl AngularScaling for Inverted<'_> {
    fn tau(&self, theta: f64) -> f64 {
        self.0.inverse(theta)
    }
    fn dtau(&self, theta: f64) -> f64 {
        1.0 / self.0.dtau(self.0.inverse(theta))
    }
    fn inverse(&self, u: f64) -> f64 {
        self.0.tau(u)
    }
    fn name(&self) -> &'static str {
        self.0.name()
    }
}

/// Uniform grid in θ united with the τ-preimages of a uniform grid in `u`, sorted, deduplicated.
fn initial_partition(tau: &dyn AngularScaling, panels: usize) -> Vec<f64> {
    let mut b: Vec<f64> = (0..=panels)
        .map(|j| PI * j as f64 / panels as f64)
        .collect();
    b.extend((1..panels).map(|j| tau.inverse(PI * j as f64 / panels as f64).clamp(0.0, PI)));
    b.sort_by(f64::total_cmp);
    b.dedup_by(|a, c| (*a - *c).abs() <= 1e-15);
    b
}

impl<T: Real> ScalingMatrix<T> {
    /// The identity of order `N` (what `τ = id` gives, up to quadrature error).
    pub fn identity(order: usize) -> Result<Self, ScalingError> {
        check_order(order)?;
        let mut values = vec![T::zero(); distinct_count(order)];
        for m in 0..order {
            let n = order - m;
            let off = block_offset(order, m);
            for r in 0..n {
                values[off + r * n + r] = T::one();
            }
        }
        Ok(Self { order, values })
    }

    /// The order `N`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The packed distinct values.
    pub fn values(&self) -> &[T] {
        &self.values
    }

    /// Mutable packed values (for interpolation into a preallocated matrix).
    pub fn values_mut(&mut self) -> &mut [T] {
        &mut self.values
    }

    /// Block `m ≥ 0`, `(N−m)×(N−m)` row-major; row `l' − m`, column `l − m`.
    pub fn block(&self, m: usize) -> &[T] {
        let n = self.order - m;
        let off = block_offset(self.order, m);
        &self.values[off..off + n * n]
    }

    /// Dense entry `M_ij` (zero off the block structure).
    pub fn get(&self, i: usize, j: usize) -> T {
        let (lo, mo) = shscale_sh::sh_lm(i);
        let (li, mi) = shscale_sh::sh_lm(j);
        if mo != mi {
            return T::zero();
        }
        let m = mo.unsigned_abs() as usize;
        let n = self.order - m;
        self.values[block_offset(self.order, m) + (lo - m) * n + (li - m)]
    }

    /// The dense `N²×N²` matrix (tests, inspection and the CLI; not for hot paths).
    pub fn to_dense(&self) -> Vec<Vec<T>> {
        let nn = coeff_count(self.order);
        (0..nn)
            .map(|i| (0..nn).map(|j| self.get(i, j)).collect())
            .collect()
    }

    /// Number of dense entries with `|M_ij| > threshold`.
    pub fn nonzeros(&self, threshold: f64) -> usize {
        (0..self.order)
            .map(|m| {
                let c = self
                    .block(m)
                    .iter()
                    .filter(|v| v.f64().abs() > threshold)
                    .count();
                if m == 0 {
                    c
                } else {
                    2 * c
                }
            })
            .sum()
    }

    /// `y = M·x` (both of length `N²`).
    pub fn apply(&self, x: &[T], y: &mut [T]) -> Result<(), shscale_sh::ShError> {
        check_coeffs(self.order, x.len())?;
        check_coeffs(self.order, y.len())?;
        self.apply_unchecked(x, y);
        Ok(())
    }

    /// `y = M·x` without length checks beyond slice indexing (lengths must be `N²`).
    #[inline]
    pub fn apply_unchecked(&self, x: &[T], y: &mut [T]) {
        // Literal orders let the compiler unroll the block products completely (N = 4: 44
        // multiply-adds, no index arithmetic left).
        let v = &self.values[..];
        match self.order {
            1 => apply_kernel(v, 1, x, y),
            2 => apply_kernel(v, 2, x, y),
            3 => apply_kernel(v, 3, x, y),
            4 => apply_kernel(v, 4, x, y),
            5 => apply_kernel(v, 5, x, y),
            6 => apply_kernel(v, 6, x, y),
            n => apply_kernel(v, n, x, y),
        }
    }

    /// Batched `y_b = M·x_b` over contiguous vectors of length `N²`.
    pub fn apply_batch(&self, xs: &[T], ys: &mut [T]) -> Result<(), shscale_sh::ShError> {
        let nn = coeff_count(self.order);
        if xs.len() != ys.len() || !xs.len().is_multiple_of(nn) {
            return Err(shscale_sh::ShError::Length {
                what: "apply_batch: inputs vs outputs (multiples of N²)",
                a: xs.len(),
                b: ys.len(),
            });
        }
        for (x, y) in xs.chunks_exact(nn).zip(ys.chunks_exact_mut(nn)) {
            self.apply_unchecked(x, y);
        }
        Ok(())
    }

    /// Batched `y = M·x` in coefficient-major (structure-of-arrays) layout: coefficient `i` of
    /// vector `b` is at `i·count + b`, for `count` vectors. Every stored value then multiplies a
    /// contiguous run of `count` inputs, which the compiler vectorises — the layout to use for
    /// many receivers (measured in docs/BENCHMARKS.md).
    pub fn apply_batch_soa(
        &self,
        xs: &[T],
        ys: &mut [T],
        count: usize,
    ) -> Result<(), shscale_sh::ShError> {
        let nn = coeff_count(self.order);
        if xs.len() != nn * count || ys.len() != nn * count {
            return Err(shscale_sh::ShError::Length {
                what: "apply_batch_soa: N²·count vs inputs/outputs",
                a: nn * count,
                b: xs.len().min(ys.len()),
            });
        }
        ys.iter_mut().for_each(|v| *v = T::zero());
        let n = self.order;
        let mut off = 0;
        for m in 0..n {
            let w = n - m;
            let blk = &self.values[off..off + w * w];
            off += w * w;
            let signs: &[i64] = if m == 0 { &[0] } else { &[1, -1] };
            for &sg in signs {
                for r in 0..w {
                    let lo = m + r;
                    let yi = (lo * lo + lo) as i64 + sg * m as i64;
                    let y = &mut ys[yi as usize * count..(yi as usize + 1) * count];
                    for c in 0..w {
                        let li = m + c;
                        let xi = ((li * li + li) as i64 + sg * m as i64) as usize;
                        let b = blk[r * w + c];
                        let x = &xs[xi * count..(xi + 1) * count];
                        for (yv, &xv) in y.iter_mut().zip(x) {
                            *yv = *yv + b * xv;
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The product `self · other` (block-wise; the structure is closed under products).
    pub fn mul(&self, other: &Self) -> Self {
        assert_eq!(self.order, other.order, "orders differ");
        let n = self.order;
        let mut values = vec![T::zero(); self.values.len()];
        for m in 0..n {
            let w = n - m;
            let off = block_offset(n, m);
            let (a, b) = (
                &self.values[off..off + w * w],
                &other.values[off..off + w * w],
            );
            for r in 0..w {
                for c in 0..w {
                    values[off + r * w + c] =
                        (0..w).fold(T::zero(), |s, k| s + a[r * w + k] * b[k * w + c]);
                }
            }
        }
        Self { order: n, values }
    }

    /// The transpose (block-wise).
    pub fn transpose(&self) -> Self {
        let n = self.order;
        let mut values = self.values.clone();
        for m in 0..n {
            let w = n - m;
            let off = block_offset(n, m);
            for r in 0..w {
                for c in 0..w {
                    values[off + r * w + c] = self.values[off + c * w + r];
                }
            }
        }
        Self { order: n, values }
    }

    /// Largest absolute entry difference to `other` (same order).
    pub fn max_abs_diff(&self, other: &Self) -> f64 {
        assert_eq!(self.order, other.order, "orders differ");
        self.values
            .iter()
            .zip(&other.values)
            .map(|(a, b)| (a.f64() - b.f64()).abs())
            .fold(0.0, f64::max)
    }

    /// The same matrix in another precision.
    pub fn cast<U: Real>(&self) -> ScalingMatrix<U> {
        ScalingMatrix {
            order: self.order,
            values: self.values.iter().map(|v| U::c(v.f64())).collect(),
        }
    }
}
