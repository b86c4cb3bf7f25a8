//! Quadrature rules: Gauss–Legendre nodes, and direction sets with solid-angle weights on the
//! sphere and the hemisphere.
//!
//! * [`GaussLegendre`]: `n` nodes on `[−1, 1]`, exact for polynomials of degree `≤ 2n−1`
//!   (Newton iteration on the three-term recurrence from Tricomi's initial guesses; Golub & Welsch
//!   1969 give the same nodes; `n ≤ 4096`).
//! * [`DirectionSet::gauss_sphere`]: Gauss–Legendre in `cosθ` × uniform φ. With `n_θ ≥ N` and
//!   `n_φ ≥ 2N−1` it integrates the product of any two order-`N` functions exactly (the product has
//!   degree `2N−2` in `cosθ` and in `e^{iφ}`), hence projection of band-limited data is exact.
//! * [`DirectionSet::gauss_hemisphere`]: the same on the hemisphere `z ≥ 0` (`H×H` directions), the
//!   cheap set used to sample visibility facing an entity's centre.
//! * [`DirectionSet::fibonacci_sphere`]: `P` nearly uniform directions with equal weights `4π/P`.
//! * [`DirectionSet::latlong`]: cell centres of a `rows×cols` θ×φ grid with exact cell solid angles
//!   `Δφ·(cosθ₀ − cosθ₁)`, the weights of lat-long environment maps.

use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on `[−1, 1]`, nodes ascending.
#[derive(Clone, Debug)]
pub struct GaussLegendre {
    pub nodes: Vec<f64>,
    pub weights: Vec<f64>,
}

impl GaussLegendre {
    /// `n ≥ 1` nodes (`n ≤ 4096`). Nodes are accurate to a few ulp and weights to ~1e-15 relative.
    pub fn new(n: usize) -> Self {
        assert!(
            (1..=4096).contains(&n),
            "Gauss–Legendre node count {n} outside 1..=4096"
        );
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        let nf = n as f64;
        for i in 0..n.div_ceil(2) {
            // Tricomi's asymptotic guess for the (i+1)-th largest root.
            let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos()
                * (1.0 - (nf - 1.0) / (8.0 * nf * nf * nf));
            let mut dp = 1.0;
            for _ in 0..100 {
                let (p, d) = legendre_p_and_derivative(n, x);
                dp = d;
                let dx = p / d;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, d) = legendre_p_and_derivative(n, x);
            if d.is_finite() {
                dp = d;
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            nodes[n - 1 - i] = x;
            nodes[i] = -x;
            weights[n - 1 - i] = w;
            weights[i] = w;
        }
        if n % 2 == 1 {
            nodes[n / 2] = 0.0;
        }
        Self { nodes, weights }
    }

    /// Nodes and weights mapped affinely onto `[a, b]`.
    pub fn on(&self, a: f64, b: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let (h, c) = (0.5 * (b - a), 0.5 * (b + a));
        self.nodes
            .iter()
            .zip(&self.weights)
            .map(move |(&x, &w)| (c + h * x, h * w))
    }
}

/// `(P_n(x), P_n'(x))` for the unnormalised Legendre polynomial, by the three-term recurrence.
/// Domain `|x| < 1` for the derivative (it uses `1 − x²` in the denominator).
fn legendre_p_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let p = if n == 0 { 1.0 } else { p1 };
    let d = n as f64 * (x * p - p0) / (x * x - 1.0);
    (p, d)
}

/// Unit directions with quadrature weights (solid angles, summing to the covered area).
#[derive(Clone, Debug, Default)]
pub struct DirectionSet {
    pub dirs: Vec<[f64; 3]>,
    pub weights: Vec<f64>,
}

/// The cells of a `rows × cols` grid (row-major indices) in tiles of 2 rows × 4 columns, tile
/// by tile (row-major), each tile row by row; tiles are clipped at the grid's edges. Eight
/// consecutive entries are one SIMD packet of the ray traversal.
pub fn tile_order(rows: usize, cols: usize) -> Vec<usize> {
    const TR: usize = 2;
    const TC: usize = 4;
    let mut out = Vec::with_capacity(rows * cols);
    for r0 in (0..rows).step_by(TR) {
        for c0 in (0..cols).step_by(TC) {
            for r in r0..(r0 + TR).min(rows) {
                for c in c0..(c0 + TC).min(cols) {
                    out.push(r * cols + c);
                }
            }
        }
    }
    out
}

impl DirectionSet {
    /// Number of directions.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True when there are no directions.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// Gauss–Legendre in `cosθ` (`n_theta` nodes over `[−1, 1]`) × `n_phi` uniform azimuths.
    pub fn gauss_sphere(n_theta: usize, n_phi: usize) -> Self {
        Self::gauss_band(n_theta, n_phi, -1.0, 1.0)
    }

    /// The smallest [`DirectionSet::gauss_sphere`] that projects order-`N` data exactly:
    /// `n_θ = N`, `n_φ = 2N`.
    pub fn gauss_sphere_for_order(order: usize) -> Self {
        Self::gauss_sphere(order.max(1), 2 * order.max(1))
    }

    /// `h × h` directions on the hemisphere `z ≥ 0`: Gauss–Legendre in `cosθ ∈ [0, 1]` × `h`
    /// uniform azimuths; weights sum to `2π`.
    pub fn gauss_hemisphere(h: usize) -> Self {
        Self::gauss_band(h, h, 0.0, 1.0)
    }

    /// The same directions and weights reordered by [`tile_order`] (a `rows × cols` grid
    /// stored row by row, as [`DirectionSet::gauss_hemisphere`] is): neighbours in the grid
    /// become neighbours in the list, so consecutive rays from one point are coherent.
    pub fn in_tiles(&self, rows: usize, cols: usize) -> Self {
        assert_eq!(rows * cols, self.len(), "in_tiles: grid size");
        let order = tile_order(rows, cols);
        Self {
            dirs: order.iter().map(|&i| self.dirs[i]).collect(),
            weights: order.iter().map(|&i| self.weights[i]).collect(),
        }
    }

    fn gauss_band(n_theta: usize, n_phi: usize, z0: f64, z1: f64) -> Self {
        let gl = GaussLegendre::new(n_theta.max(1));
        let n_phi = n_phi.max(1);
        let dphi = 2.0 * PI / n_phi as f64;
        let mut set = Self::default();
        for (z, w) in gl.on(z0, z1) {
            let r = (1.0 - z * z).max(0.0).sqrt();
            for j in 0..n_phi {
                let phi = (j as f64 + 0.5) * dphi;
                set.dirs.push([r * phi.cos(), r * phi.sin(), z]);
                set.weights.push(w * dphi);
            }
        }
        set
    }

    /// `p` Fibonacci-lattice directions on the sphere, equal weights `4π/p`.
    pub fn fibonacci_sphere(p: usize) -> Self {
        let golden = PI * (3.0 - 5f64.sqrt());
        let mut set = Self::default();
        for i in 0..p {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / p as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            set.dirs.push([r * phi.cos(), r * phi.sin(), z]);
            set.weights.push(4.0 * PI / p as f64);
        }
        set
    }

    /// Cell centres of a `rows × cols` lat-long grid (row 0 at θ = 0), weights the exact cell
    /// solid angles.
    pub fn latlong(rows: usize, cols: usize) -> Self {
        let mut set = Self::default();
        let dphi = 2.0 * PI / cols as f64;
        for i in 0..rows {
            let t0 = PI * i as f64 / rows as f64;
            let t1 = PI * (i + 1) as f64 / rows as f64;
            let t = 0.5 * (t0 + t1);
            let w = dphi * (t0.cos() - t1.cos());
            for j in 0..cols {
                let phi = (j as f64 + 0.5) * dphi;
                set.dirs
                    .push([t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos()]);
                set.weights.push(w);
            }
        }
        set
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_monomials_exactly() {
        // ∫_{-1}^{1} x^k dx = 2/(k+1) for even k, 0 for odd k; exact for k ≤ 2n−1.
        for n in [1usize, 2, 3, 7, 20, 64, 200] {
            let gl = GaussLegendre::new(n);
            for k in 0..(2 * n).min(40) {
                let got: f64 = gl
                    .nodes
                    .iter()
                    .zip(&gl.weights)
                    .map(|(x, w)| w * x.powi(k as i32))
                    .sum();
                let want = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    0.0
                };
                assert!((got - want).abs() < 1e-14, "n={n} k={k}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn direction_sets_cover_their_area() {
        let total = |s: &DirectionSet| s.weights.iter().sum::<f64>();
        assert!((total(&DirectionSet::gauss_sphere(5, 9)) - 4.0 * PI).abs() < 1e-13);
        assert!((total(&DirectionSet::gauss_hemisphere(8)) - 2.0 * PI).abs() < 1e-13);
        assert!((total(&DirectionSet::fibonacci_sphere(101)) - 4.0 * PI).abs() < 1e-12);
        assert!((total(&DirectionSet::latlong(16, 32)) - 4.0 * PI).abs() < 1e-12);
        for s in [
            DirectionSet::gauss_hemisphere(8),
            DirectionSet::fibonacci_sphere(33),
        ] {
            for d in &s.dirs {
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                assert!((n - 1.0).abs() < 1e-14);
            }
        }
        assert!(DirectionSet::gauss_hemisphere(8)
            .dirs
            .iter()
            .all(|d| d[2] >= 0.0));
    }
}
