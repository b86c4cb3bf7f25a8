//! Stability at the extremes: do the scaling matrices and the angular scaling functions stay
//! finite, converged and invariant-preserving at extreme k (10⁻⁶ … 10⁶), extreme cone angles
//! (10⁻⁴° … 90° − 10⁻⁴°), high orders (to N = 32) and polar angles at the poles (θ = 0, π)?
//!
//! Per matrix case: the adaptive quadrature's panels, evaluations, error bound and convergence,
//! whether every value is finite, and the defect of the exact invariant — `M e₀ = e₀` for the
//! plain matrix (a constant stays constant), `e₀ᵀ M = e₀ᵀ` for the energy one (the integral is
//! preserved): |M₀₀ − 1| plus the largest other entry of that column/row. Per τ case: whether τ
//! and τ′ are finite at θ ∈ {0, 10⁻¹², 10⁻⁶, π/2, π − 10⁻⁶, π − 10⁻¹², π} and the round trip
//! |τ⁻¹(τ(θ)) − θ| (τ⁻¹ is computed by its own formula or bisection, not by inverting τ's code).
//!
//! One run is one τ (cone at k and α, or mid-range at k) at one order: two rows, one per η, with
//! the τ checks of that τ on both. Sweep with `[[sweep]]` blocks (cone over k × α × N, mid-range
//! over its k).

use serde::{Deserialize, Serialize};
use shscale_present::plots::{write_both, Labels};
use shscale_runner::records::Results;
use shscale_runner::{Cost, Ctx, KeyError, Kind, Typed};
use shscale_scaling::{AngularScaling, Eta, QuadOptions, ScalingMatrix};
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Parameters of one run (one τ at one order).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// `cone` (k > 0 and α) or `midrange` (k in (−1, 1); α unused).
    pub tau: String,
    pub k: f64,
    pub alpha_deg: f64,
    pub order: usize,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            tau: "cone".into(),
            k: 1.0,
            alpha_deg: 45.0,
            order: 4,
        }
    }
}

/// One row per η.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    /// `plain` or `energy`.
    pub eta: String,
    /// The adaptive quadrature's panels, integrand evaluations, error bound and convergence.
    pub panels: usize,
    pub evaluations: usize,
    pub error_bound: f64,
    pub converged: bool,
    /// Every matrix element finite.
    pub finite: bool,
    /// |M₀₀ − 1| plus the largest other entry of column 0 (plain) or row 0 (energy).
    pub invariant_defect: f64,
    /// τ at θ ∈ {0, 1e-12, 1e-6, π/2, π − 1e-6, π − 1e-12, π}: evaluations that are non-finite,
    /// outside [0, π] or fail the round trip, and the worst round-trip error among those judged
    /// on θ.
    pub tau_pole_failures: usize,
    pub tau_round_trip_max: f64,
    /// Finite, converged, defect ≤ 1e-8 and no τ failure.
    pub ok: bool,
}

/// The kind `extremes`.
pub struct Extremes;

/// The largest order of the study (the matrices' own limit).
pub const MAX_ORDER: usize = 32;

/// The invariant defect bound of a passing case.
const DEFECT_OK: f64 = 1e-8;

fn tau_of(p: &Params) -> Result<Box<dyn AngularScaling>, KeyError> {
    shscale_scene::vocab::scaling_tau(&p.tau, p.k, p.alpha_deg)
}

/// τ at the poles: failures and the worst round trip.
fn tau_checks(tau: &dyn AngularScaling) -> (usize, f64) {
    let thetas = [0.0, 1e-12, 1e-6, PI / 2.0, PI - 1e-6, PI - 1e-12, PI];
    let (mut bad, mut worst) = (0usize, 0f64);
    for &t in &thetas {
        let (v, dv) = (tau.tau(t), tau.dtau(t));
        let finite = v.is_finite() && dv.is_finite() && (0.0..=PI).contains(&v);
        let trip = (tau.inverse(v) - t).abs();
        // Where τ is flat to rounding (|τ′| tiny), τ⁻¹ is ill-conditioned: the round trip is
        // then judged on τ(τ⁻¹(τ(θ))) = τ(θ) instead.
        let trip_ok = trip < 1e-6 || (tau.tau(tau.inverse(v)) - v).abs() < 1e-9;
        if trip_ok && trip < 1e-6 {
            worst = worst.max(trip);
        }
        bad += usize::from(!finite || !trip_ok);
    }
    (bad, worst)
}

/// The invariant defect of `m` for `eta` (0 in exact arithmetic).
fn invariant_defect(m: &ScalingMatrix<f64>, eta: Eta) -> f64 {
    let d = m.to_dense();
    let n = d.len();
    let mut e = (d[0][0] - 1.0).abs();
    for i in 1..n {
        e = e.max(match eta {
            Eta::Plain => d[i][0].abs(),
            Eta::Energy => d[0][i].abs(),
        });
    }
    e
}

impl Kind for Extremes {
    const NAME: &'static str = "extremes";
    const QUESTION: &'static str = "Do the scaling matrices and τ stay finite, converged and invariant-preserving at extreme k (1e-6 … 1e6), α (1e-4° … 90° − 1e-4°), N (to 32) and at the poles?";
    type Params = Params;
    type Shared = ();
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, Box<dyn AngularScaling>>;

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("tau", "angular scaling τ: `cone` or `midrange`"),
            (
                "k",
                "scale: d/r > 0 for the cone, d/R in (−1, 1) for mid-range",
            ),
            (
                "alpha_deg",
                "cone half-angle α, degrees, (0, 90); unused by mid-range",
            ),
            ("order", "SH order N, 1..=32"),
        ]
    }

    fn resolve(p: &Params) -> Result<Self::Spec, KeyError> {
        KeyError::int("order", p.order, 1, MAX_ORDER)?;
        Ok(Typed {
            params: p.clone(),
            typed: tau_of(p)?,
        })
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        crate::common::two_matrices_cost(p.order)
    }

    fn rows_per_run(_: &Params) -> usize {
        2
    }

    fn shared(_: &Self::Spec, _: &Ctx) -> Result<(), Error> {
        Ok(())
    }

    fn run(p: &Self::Spec, _: &str, _: &(), _: &Ctx) -> Result<Vec<Row>, Error> {
        let tau = &p.typed;
        let (tau_bad, trip) = tau_checks(tau.as_ref());
        [Eta::Plain, Eta::Energy]
            .into_iter()
            .map(|eta| {
                let (m, rep) = ScalingMatrix::<f64>::compute_with(
                    tau.as_ref(),
                    eta,
                    p.order,
                    &QuadOptions::default(),
                )
                .map_err(|e| Error::config(format!("k: {e}")))?;
                let finite = m.values().iter().all(|v| v.is_finite());
                let defect = invariant_defect(&m, eta);
                Ok(Row {
                    eta: shscale_scene::vocab::eta_name(eta).into(),
                    panels: rep.panels,
                    evaluations: rep.evaluations,
                    error_bound: rep.error_bound,
                    converged: rep.converged,
                    finite,
                    invariant_defect: defect,
                    tau_pole_failures: tau_bad,
                    tau_round_trip_max: trip,
                    ok: finite && rep.converged && defect <= DEFECT_OK && tau_bad == 0,
                })
            })
            .collect()
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "eta",
            "panels",
            "converged",
            "invariant_defect",
            "tau_pole_failures",
            "ok",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        Self::figure(dir, t, dir, "extremes_panels_vs_k")
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        if t.rows.is_empty() {
            return Ok(String::new());
        }
        let label = |r: usize| match t.cell(r, "tau") {
            "cone" => format!(
                "cone k={} α={}° N={} {}",
                t.cell(r, "k"),
                t.cell(r, "alpha_deg"),
                t.cell(r, "order"),
                t.cell(r, "eta")
            ),
            _ => format!(
                "mid-range k={} N={} {}",
                t.cell(r, "k"),
                t.cell(r, "order"),
                t.cell(r, "eta")
            ),
        };
        let bad: Vec<String> = (0..t.rows.len())
            .filter(|&r| t.cell(r, "ok") != "true")
            .map(label)
            .collect();
        let worst = (0..t.rows.len())
            .map(|r| t.num(r, "invariant_defect"))
            .fold(0f64, f64::max);
        let set = |c: &str| {
            let mut v: Vec<String> = Vec::new();
            for r in 0..t.rows.len() {
                let x = t.cell(r, c).to_string();
                if !v.contains(&x) {
                    v.push(x);
                }
            }
            v.join(", ")
        };
        Ok(format!(
            "**Ours.** {} matrices (τ ∈ {{{}}}, k ∈ {{{}}}, α ∈ {{{}}}°, N ∈ {{{}}}; both η), each with τ checked at 7 polar angles from 0 to π: \
{} failed (non-finite, not converged, invariant defect > {DEFECT_OK:.0e}, or a τ failure){}; worst invariant defect {worst:.1e}.\n\n\
**Comparison.** The papers do not discuss the extremes; this is the project's own stability claim: {}.",
            t.rows.len(),
            set("tau"),
            set("k"),
            set("alpha_deg"),
            set("order"),
            bad.len(),
            if bad.is_empty() {
                String::new()
            } else {
                format!(": {}", bad.join("; "))
            },
            if bad.is_empty() {
                "it holds on every case tried"
            } else {
                "it does NOT hold on the cases listed"
            }
        ))
    }

    fn figure(_: &Path, t: &Results, out: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        // Quadrature panels of the plain cone matrix against log10 k, per α and order.
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for r in
            (0..t.rows.len()).filter(|&r| t.cell(r, "tau") == "cone" && t.cell(r, "eta") == "plain")
        {
            series
                .entry(format!(
                    "α = {}°, N = {}",
                    t.cell(r, "alpha_deg"),
                    t.cell(r, "order")
                ))
                .or_default()
                .push((t.num(r, "k").log10(), t.num(r, "panels")));
        }
        for v in series.values_mut() {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        Ok(write_both(
            out,
            stem,
            &Labels {
                title: "quadrature panels of M (cone, plain η) vs k",
                x: "log10 k",
                y: "adaptive quadrature panels",
            },
            &series,
            false,
            &[],
        )?)
    }
}
