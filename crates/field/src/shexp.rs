//! Sphere sets combined in log space — the combination of Ren et al. 2006 ("Real-time soft
//! shadows in dynamic scenes using spherical harmonic exponentiation"), in its exact form.
//!
//! Each sphere's visibility, clamped to `ε` where it is blocked, has the logarithm
//! `ln ε · 1_cap`, whose SH projection is `ln ε` times the cap's closed form (any order M,
//! rotated onto the sphere's direction as a zonal function). The logs of the S spheres are
//! **summed** (no products), and the sum's exponential is taken **exactly**: the band-limited
//! log evaluated on the product quadrature of [`QuadratureGrid`] (Gauss–Legendre × uniform),
//! exponentiated node by node and projected back to order N ≤ M — the pointwise reading of a
//! log-space combination. SH exponentiation as Ren et al. define it (logs and exponentials in the
//! truncated product's algebra, DC isolation, OL, HYB) is [`crate::shexp_ol`], whose
//! `Exp::Pointwise` uses [`exp_by_quadrature`] from here.
//!
//! Domain: `ε ∈ (0, 1]` (`ε = 1`: every log is 0 and the visibility the constant 1); a point
//! inside a sphere sees nothing (0, as in the product chain); spheres of radius 0 occlude
//! nothing. Where the caps overlap the logs add, so an overlap is `ε²`-dark before the band
//! limit — the clamp, not the combination, decides how dark "blocked" is.
//! Cost per receiver: S zonal rotations at order M, then `2Q²` nodes × (M² + N²) multiply-adds
//! and an exponential each (Q = 64: 8,192 nodes).

use crate::evaluator::VisibilityField;
use crate::sphereset::QuadratureGrid;
use glam::DVec3;
use shscale_geometry::Sphere;
use shscale_sh::cap::cap_zonal;
use shscale_sh::rotation::rotate_zonal;
use shscale_sh::ShBasis;

/// `P(F ∘ f)`: `f` (SH coefficients at the grid's order or below) evaluated at every node of
/// `grid`, mapped pointwise by `F`, projected to `out.len()` coefficients (at most the grid's).
fn map_by_quadrature(grid: &QuadratureGrid, f: &[f64], map: impl Fn(f64) -> f64, out: &mut [f64]) {
    assert!(
        f.len() <= grid.nn && out.len() <= grid.nn,
        "coefficients beyond the grid's order"
    );
    out.iter_mut().for_each(|o| *o = 0.0);
    for (i, w) in grid.w.iter().enumerate() {
        let row = &grid.y[i * grid.nn..(i + 1) * grid.nn];
        let v: f64 = f.iter().zip(row).map(|(a, y)| a * y).sum();
        let e = w * map(v);
        out.iter_mut().zip(row).for_each(|(o, y)| *o += e * y);
    }
}

/// `f` exponentiated exactly: `exp(f(ω))` at every node of `grid`, projected to `out.len()`
/// coefficients (at most the grid's).
pub fn exp_by_quadrature(grid: &QuadratureGrid, f: &[f64], out: &mut [f64]) {
    map_by_quadrature(grid, f, f64::exp, out);
}

/// `ln max(ε, v(ω))` projected: `v` (SH coefficients, at most the grid's order) evaluated at
/// every node of `grid`, its pointwise log clamped at ε, projected to `out.len()` coefficients
/// — the pointwise log of a sampled visibility, the inverse of [`exp_by_quadrature`] where
/// `v ≥ ε`.
pub fn log_by_quadrature(grid: &QuadratureGrid, v: &[f64], eps: f64, out: &mut [f64]) {
    map_by_quadrature(grid, v, |x| x.max(eps).ln(), out);
}

/// The SH projection (order of `basis`) of the clamped log-visibility of one sphere seen from
/// `p`: `ln ε` on the cap the sphere subtends, 0 elsewhere; `None` when `p` is inside it.
pub(crate) fn log_sphere(
    basis: &ShBasis<f64>,
    s: &Sphere,
    p: DVec3,
    ln_eps: f64,
) -> Option<Vec<f64>> {
    let n = basis.order();
    let mut v = vec![0.0; n * n];
    if s.radius <= 0.0 {
        return Some(v);
    }
    let d = (s.center - p).length();
    if d < s.radius * (1.0 - 1e-9) || d == 0.0 {
        return None;
    }
    let cap = cap_zonal(n, (s.radius / d).min(1.0).asin()).ok()?;
    rotate_zonal(basis, &cap, ((s.center - p) / d).to_array(), &mut v).ok()?;
    v.iter_mut().for_each(|x| *x *= ln_eps);
    Some(v)
}

/// A window on the log's bands before it is exponentiated (the log of a hard cap rings; a
/// window trades the ringing for a softer edge): band `l` of an order-M log scaled by `σ_l`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    /// `σ_l = 1`.
    None,
    /// Hann: `σ_l = (1 + cos(π l / M)) / 2`.
    Hann,
    /// Lanczos: `σ_l = sinc(l / M) = sin(π l / M) / (π l / M)` (`σ_0 = 1`).
    Lanczos,
}

impl Window {
    /// `σ_l` for band `l` of an order-`m` function.
    pub fn factor(self, l: usize, m: usize) -> f64 {
        let x = std::f64::consts::PI * l as f64 / m as f64;
        match self {
            Window::None => 1.0,
            Window::Hann => 0.5 * (1.0 + x.cos()),
            Window::Lanczos if l == 0 => 1.0,
            Window::Lanczos => x.sin() / x,
        }
    }
}

/// A sphere set's visibility by the exact exponential of its summed clamped logs (module doc).
/// The log is kept at the order M of `basis` (= the grid's order), windowed, and exponentiated;
/// `eval` returns order N ≤ M.
pub struct SphereSetLog<'a> {
    spheres: Vec<Sphere>,
    basis: &'a ShBasis<f64>,
    grid: &'a QuadratureGrid,
    ln_eps: f64,
    window: Window,
}

impl<'a> SphereSetLog<'a> {
    /// `eps ∈ (0, 1]`; `basis` of the grid's order.
    pub fn new(
        spheres: &[Sphere],
        basis: &'a ShBasis<f64>,
        grid: &'a QuadratureGrid,
        eps: f64,
    ) -> Self {
        assert!(
            eps > 0.0 && eps <= 1.0,
            "the log clamp ε = {eps} is outside (0, 1]"
        );
        assert_eq!(
            basis.order() * basis.order(),
            grid.nn,
            "basis and grid of one order"
        );
        Self {
            spheres: spheres.to_vec(),
            basis,
            grid,
            ln_eps: eps.ln(),
            window: Window::None,
        }
    }

    /// The same set with its log windowed before the exponential.
    pub fn with_window(mut self, window: Window) -> Self {
        self.window = window;
        self
    }

    /// The summed (windowed) log at `p` (order M), or `None` when `p` is inside a sphere.
    pub(crate) fn log_at(&self, p: DVec3) -> Option<Vec<f64>> {
        let mut sum = vec![0.0; self.grid.nn];
        for s in &self.spheres {
            let l = log_sphere(self.basis, s, p, self.ln_eps)?;
            sum.iter_mut().zip(&l).for_each(|(a, b)| *a += b);
        }
        let m = self.basis.order();
        if self.window != Window::None {
            for l in 0..m {
                let f = self.window.factor(l, m);
                sum[l * l..(l + 1) * (l + 1)]
                    .iter_mut()
                    .for_each(|x| *x *= f);
            }
        }
        Some(sum)
    }
}

impl VisibilityField for SphereSetLog<'_> {
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        match self.log_at(p) {
            Some(f) => exp_by_quadrature(self.grid, &f, out),
            None => out.iter_mut().for_each(|o| *o = 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The exact exponential against closed forms: a constant `c` gives `e^c` (DC `√(4π) e^c`);
    /// `a cos θ` gives the projections `2π K_l · 2 i_l(a)` with the modified spherical Bessel
    /// functions `i_0(a) = sinh a / a`, `i_1(a) = cosh a / a − sinh a / a²` — for magnitudes
    /// up to |a| = 8 (SHEXP's "large" logs), at N = 4 from a grid of order 8.
    #[test]
    fn exponential_matches_closed_forms() {
        let basis = ShBasis::<f64>::new(8).unwrap();
        let grid = QuadratureGrid::new(&basis, 64);
        let mut out = vec![0.0; 16];
        let mut f = vec![0.0; 64];
        f[0] = -1.7 * (4.0 * PI).sqrt();
        exp_by_quadrature(&grid, &f, &mut out);
        let want = (4.0 * PI).sqrt() * (-1.7f64).exp();
        assert!((out[0] - want).abs() < 1e-12 * want, "{} vs {want}", out[0]);
        assert!(out[1..].iter().all(|x| x.abs() < 1e-12));
        let mut worst = 0.0f64;
        for a in [-8.0, -2.0, -0.3, 0.5, 3.0, 8.0f64] {
            // a cos θ = a √(4π/3) Y_1^0; Y_1^0 is index 2 in l² + l + m order.
            f.iter_mut().for_each(|x| *x = 0.0);
            f[2] = a * (4.0 * PI / 3.0).sqrt();
            exp_by_quadrature(&grid, &f, &mut out);
            let i0 = a.sinh() / a;
            let i1 = a.cosh() / a - a.sinh() / (a * a);
            let k0 = (1.0 / (4.0 * PI)).sqrt();
            let k1 = (3.0 / (4.0 * PI)).sqrt();
            let (c0, c1) = (2.0 * PI * k0 * 2.0 * i0, 2.0 * PI * k1 * 2.0 * i1);
            let err = ((out[0] - c0).abs() / c0).max((out[2] - c1).abs() / c0);
            worst = worst.max(err);
            assert!(
                out[1].abs() < 1e-9 * c0 && out[3].abs() < 1e-9 * c0,
                "a = {a}: m ≠ 0"
            );
        }
        println!("exp(a cos θ), |a| ≤ 8: worst relative error {worst:.1e}");
        assert!(worst < 1e-10, "{worst}");
    }

    /// The pointwise log at its edges: a constant c > ε gives `ln c` exactly (DC `√(4π) ln c`),
    /// a constant at or below ε (a dark sample, 0 or negative from ringing) gives `ln ε`.
    #[test]
    fn pointwise_log_of_constants_and_the_clamp() {
        let basis = ShBasis::<f64>::new(4).unwrap();
        let grid = QuadratureGrid::new(&basis, 16);
        let root = (4.0 * PI).sqrt();
        let mut out = vec![0.0; 16];
        for (c, want) in [
            (0.7f64, 0.7f64.ln()),
            (0.0, 0.02f64.ln()),
            (-0.3, 0.02f64.ln()),
        ] {
            let mut v = vec![0.0; 16];
            v[0] = root * c;
            log_by_quadrature(&grid, &v, 0.02, &mut out);
            assert!((out[0] - root * want).abs() < 1e-12, "{c}: {}", out[0]);
            assert!(out[1..].iter().all(|x| x.abs() < 1e-12), "{c}");
        }
    }

    /// One sphere's clamped log against a direct quadrature of `ln max(ε, V)` (the indicator of
    /// the subtended cap, tested ray by ray at 2·256² nodes — another computation); its edges:
    /// radius 0 and ε = 1 give 0, a point inside gives `None`.
    #[test]
    fn log_of_one_sphere_against_quadrature() {
        let basis = ShBasis::<f64>::new(6).unwrap();
        let s = Sphere {
            center: DVec3::new(0.2, -0.1, 0.4),
            radius: 0.6,
        };
        let p = DVec3::new(1.1, 0.9, -0.8);
        let eps = 1e-3f64;
        let got = log_sphere(&basis, &s, p, eps.ln()).unwrap();
        let fine = QuadratureGrid::new(&basis, 256);
        let mut want = vec![0.0; 36];
        for (i, d) in fine.dirs.iter().enumerate() {
            let oc = s.center - p;
            let b = oc.dot(*d);
            let blocked = b > 0.0 && oc.length_squared() - b * b < s.radius * s.radius;
            if blocked {
                let row = &fine.y[i * 36..(i + 1) * 36];
                want.iter_mut()
                    .zip(row)
                    .for_each(|(o, y)| *o += fine.w[i] * eps.ln() * y);
            }
        }
        let err = crate::metrics::l2_diff(&got, &want) / crate::metrics::l2(&want);
        println!("clamped log of one sphere, closed form vs quadrature at 256: {err:.1e}");
        // The quadrature of an indicator converges as 1/n: a few parts in 10³ at n = 256.
        assert!(err < 5e-3, "{err}");
        let zero = Sphere {
            center: s.center,
            radius: 0.0,
        };
        assert!(log_sphere(&basis, &zero, p, eps.ln())
            .unwrap()
            .iter()
            .all(|x| *x == 0.0));
        assert!(log_sphere(&basis, &s, p, 0.0)
            .unwrap()
            .iter()
            .all(|x| *x == 0.0));
        assert!(log_sphere(&basis, &s, s.center, eps.ln()).is_none());
    }

    /// The set's edges: no sphere and ε = 1 give exactly the constant 1; a point inside a
    /// sphere sees nothing; far away (10⁶ radii) the set tends to the constant 1.
    #[test]
    fn sphere_set_log_at_its_edges() {
        let basis = ShBasis::<f64>::new(4).unwrap();
        let grid = QuadratureGrid::new(&basis, 32);
        let one = (4.0 * PI).sqrt();
        let mut v = vec![0.0; 16];
        SphereSetLog::new(&[], &basis, &grid, 1e-3).eval(DVec3::X, &mut v);
        assert!((v[0] - one).abs() < 1e-12 && v[1..].iter().all(|x| x.abs() < 1e-12));
        let s = [Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        }];
        SphereSetLog::new(&s, &basis, &grid, 1.0).eval(3.0 * DVec3::X, &mut v);
        assert!((v[0] - one).abs() < 1e-12);
        SphereSetLog::new(&s, &basis, &grid, 1e-3).eval(0.5 * DVec3::Y, &mut v);
        assert!(v.iter().all(|x| *x == 0.0));
        SphereSetLog::new(&s, &basis, &grid, 1e-3).eval(1e6 * DVec3::Z, &mut v);
        assert!((v[0] - one).abs() < 1e-9, "{}", v[0] - one);
    }

    /// One sphere, whose visibility is known in closed form: the log-space combination's only
    /// error is the band-limited clamped log's exponential. Measured at 1.3 radii in 8
    /// directions: it falls as the log's order M grows (the cap's edge resolved) and grows as ε
    /// falls (a deeper log rings harder) — at N = 4, M = 4 / 8 / 12 with ε = 0.01, and ε = 0.1 /
    /// 0.01 / 0.001 at M = 8.
    #[test]
    fn one_sphere_error_falls_with_the_order_and_grows_with_the_clamp() {
        use crate::metrics::{l2, l2_diff, occlusion};
        let s = [Sphere {
            center: DVec3::new(0.1, 0.2, -0.3),
            radius: 1.0,
        }];
        let b4 = ShBasis::<f64>::new(4).unwrap();
        let err = |m: usize, eps: f64| {
            let b = ShBasis::<f64>::new(m).unwrap();
            let grid = QuadratureGrid::new(&b, 64);
            let set = SphereSetLog::new(&s, &b, &grid, eps);
            let mut v = vec![0.0; 16];
            let mut total = 0.0;
            for k in 0..8 {
                let a = k as f64 * 0.8;
                let d = DVec3::new(a.cos(), a.sin(), 0.3 * (k as f64 - 3.5) / 3.5).normalize();
                let p = s[0].center + 1.3 * d;
                let truth = crate::probe::sphere_truth(&b4, &s[0], p).unwrap();
                set.eval(p, &mut v);
                total += l2_diff(&v, &truth) / l2(&occlusion(&truth));
            }
            total / 8.0
        };
        let by_m: Vec<f64> = [4, 8, 12].iter().map(|&m| err(m, 0.01)).collect();
        let by_eps: Vec<f64> = [0.1, 0.01, 0.001].iter().map(|&e| err(8, e)).collect();
        println!("one sphere at 1.3r: by M (ε = 0.01) {by_m:.3?}; by ε (M = 8) {by_eps:.3?}");
        assert!(by_m[1] < by_m[0] && by_m[2] < by_m[1], "{by_m:?}");
        assert!(by_eps[0] < by_eps[1] && by_eps[1] < by_eps[2], "{by_eps:?}");
    }

    /// The windows' factors at their edges: band 0 untouched by every window; Hann `cos²`-shaped
    /// (½ at l = M/2); Lanczos `2/π` at l = M/2; none of them negative below M.
    #[test]
    fn windows_at_their_edges() {
        for w in [Window::None, Window::Hann, Window::Lanczos] {
            assert_eq!(w.factor(0, 8), 1.0, "{w:?}");
            assert!(
                (0..8).all(|l| w.factor(l, 8) > 0.0 && w.factor(l, 8) <= 1.0),
                "{w:?}"
            );
        }
        assert!((Window::Hann.factor(4, 8) - 0.5).abs() < 1e-15);
        assert!((Window::Lanczos.factor(4, 8) - 2.0 / PI).abs() < 1e-15);
        assert_eq!(Window::None.factor(7, 8), 1.0);
    }
}
