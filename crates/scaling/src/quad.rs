//! Globally adaptive composite Gauss–Legendre quadrature of a vector-valued integrand on an
//! interval, for the θ-integrals of the scaling matrices.
//!
//! Every live panel is integrated with `p` Gauss–Legendre nodes once whole and once as two halves;
//! `e = max_i |I_whole − I_halves|` bounds the error of the whole-panel value (the halves are far
//! more accurate for smooth integrands) and the halves' value is used. The panel with the largest
//! `e` is split until `Σ e ≤ tol` (the QUADPACK QAG strategy, Piessens et al. 1983). A global
//! criterion matters here: near the steep parts of τ the integrand carries round-off noise of
//! size ~ε·τ′ (θ itself is only known to ε), which a per-panel `tol·width` test would chase down
//! to the spacing of doubles. Panels narrower than `4ε·|θ|` are frozen; if their bounds alone
//! exceed `tol` the report says so. Integrating in θ (not cosθ) is deliberate: τ makes the
//! integrand non-polynomial in cosθ with endpoint singularities of τ′ (docs/conventions.md §3.1).

use shscale_sh::GaussLegendre;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// What an adaptive integration did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QuadReport {
    /// Live panels at the end.
    pub panels: usize,
    /// Integrand evaluations.
    pub evaluations: usize,
    /// Sum of the panel error bounds (max over components).
    pub error_bound: f64,
    /// False when `max_panels` or frozen panels stopped the refinement above `tol`.
    pub converged: bool,
}

struct Panel {
    err: f64,
    a: f64,
    b: f64,
}

impl PartialEq for Panel {
    fn eq(&self, o: &Self) -> bool {
        self.err.total_cmp(&o.err) == Ordering::Equal
    }
}
impl Eq for Panel {}
impl PartialOrd for Panel {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Panel {
    fn cmp(&self, o: &Self) -> Ordering {
        self.err.total_cmp(&o.err)
    }
}

/// Integrate `f` (which writes `dim` values at `x` into its buffer) over the partition `breaks`
/// (sorted, at least two points) into `out` (length `dim`, overwritten).
///
/// The numerical kernel of every scaling-matrix element (N⁴ calls for a matrix of order N), kept
/// in one function of ~105 lines: the panel rule and the refinement loop share four scratch
/// vectors and the evaluation count through closures, so no allocation happens per panel.
pub(crate) fn integrate_vec(
    f: &mut dyn FnMut(f64, &mut [f64]),
    dim: usize,
    breaks: &[f64],
    gl: &GaussLegendre,
    tol: f64,
    max_panels: usize,
    out: &mut [f64],
) -> QuadReport {
    assert!(breaks.len() >= 2 && out.len() == dim);
    let mut buf = vec![0.0; dim];
    let mut evaluations = 0;
    let mut rule = |a: f64, b: f64, acc: &mut [f64]| {
        acc.iter_mut().for_each(|v| *v = 0.0);
        for (x, w) in gl.on(a, b) {
            f(x, &mut buf);
            for (s, v) in acc.iter_mut().zip(&buf) {
                *s += w * v;
            }
        }
        evaluations += gl.nodes.len();
    };
    let (mut whole, mut left, mut right) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; dim]);
    // Evaluate a panel: its halves' value is added to `out` with sign `sign`; returns the bound.
    let mut assess = |a: f64,
                      b: f64,
                      out: &mut [f64],
                      whole: &mut [f64],
                      left: &mut [f64],
                      right: &mut [f64]| {
        let mid = 0.5 * (a + b);
        rule(a, b, whole);
        rule(a, mid, left);
        rule(mid, b, right);
        let mut err = 0.0f64;
        for i in 0..dim {
            let s = left[i] + right[i];
            err = err.max((s - whole[i]).abs());
            out[i] += s;
        }
        err
    };
    out.iter_mut().for_each(|o| *o = 0.0);
    let mut heap = BinaryHeap::new();
    let mut total = 0.0;
    for w in breaks.windows(2) {
        if w[1] > w[0] {
            let err = assess(w[0], w[1], out, &mut whole, &mut left, &mut right);
            total += err;
            heap.push(Panel {
                err,
                a: w[0],
                b: w[1],
            });
        }
    }
    let mut frozen = Vec::new();
    let mut frozen_err = 0.0;
    let mut converged = true;
    let mut sub = vec![0.0; dim];
    while total > tol {
        let Some(p) = heap.pop() else { break };
        if p.b - p.a <= 4.0 * f64::EPSILON * p.b.abs().max(1.0) {
            frozen_err += p.err;
            frozen.push(p);
            if heap.is_empty() || frozen_err > tol {
                converged = frozen_err <= tol;
                break;
            }
            continue;
        }
        if heap.len() + frozen.len() + 2 > max_panels {
            heap.push(p);
            converged = false;
            break;
        }
        let mid = 0.5 * (p.a + p.b);
        // Remove the parent's value (= the children's whole-panel values, recomputed with the
        // same nodes, hence bit-identical) and add the children's refined values.
        sub.iter_mut().for_each(|v| *v = 0.0);
        let el = assess(p.a, mid, out, &mut whole, &mut left, &mut right);
        sub.iter_mut().zip(&whole).for_each(|(s, w)| *s += w);
        let er = assess(mid, p.b, out, &mut whole, &mut left, &mut right);
        sub.iter_mut().zip(&whole).for_each(|(s, w)| *s += w);
        out.iter_mut().zip(&sub).for_each(|(o, s)| *o -= s);
        total += el + er - p.err;
        heap.push(Panel {
            err: el,
            a: p.a,
            b: mid,
        });
        heap.push(Panel {
            err: er,
            a: mid,
            b: p.b,
        });
    }
    // Recompute the bound from the live panels (the running total drifts by rounding).
    let error_bound = heap.iter().chain(&frozen).map(|p| p.err).sum::<f64>();
    QuadReport {
        panels: heap.len() + frozen.len(),
        evaluations,
        error_bound,
        converged: converged && error_bound <= tol * 1.0001,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_smooth_and_peaked_functions() {
        let gl = GaussLegendre::new(10);
        let mut out = [0.0; 2];
        // ∫₀^π sin = 2; ∫₀^1 ε/(ε² + x²) dx = atan(1/ε) for a sharp peak at 0.
        let eps = 1e-6;
        let r = integrate_vec(
            &mut |x, o| {
                o[0] = x.sin();
                o[1] = if x <= 1.0 {
                    eps / (eps * eps + x * x)
                } else {
                    0.0
                };
            },
            2,
            &[0.0, 1.0, std::f64::consts::PI],
            &gl,
            1e-13,
            100_000,
            &mut out,
        );
        assert!(r.converged, "{r:?}");
        assert!((out[0] - 2.0).abs() < 1e-13, "{}", out[0]);
        let want = (1.0 / eps).atan();
        assert!((out[1] - want).abs() < 1e-12, "{} vs {want}: {r:?}", out[1]);
    }
}
