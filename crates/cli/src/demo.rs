//! `shscale demo`: the built-in demonstration run by the README's main command until the
//! experiment runner exists. It computes real scaling matrices and checks them against closed
//! forms; the exit status is 1 if a check fails.
//!
//! 1. Operator accuracy: scaling the cap `θ ≤ A` with `M_k` must give the cap `θ ≤ τ_k⁻¹(A)` —
//!    exact in function space, so the error is band-limiting alone (table over k and N).
//! 2. The on-surface failure case (docs/conventions.md §7): a solid sphere whose bounding sphere is itself;
//!    every sample sees exactly half the sphere occluded, the truth at distance `d = k·r` is the
//!    cap of half-angle `asin(1/k)`. The cone model predicts `τ_k⁻¹(90°)`; the table shows both
//!    angles and `occ_rel_l2` at order 4.
//! 3. Identities: `M_1 = I`, energy preservation of the energy-preserving M, orthonormality.

use crate::args::DemoArgs;
use crate::flags;
use shscale_scaling::{AngularScaling, Cone, Eta, ScalingMatrix};
use shscale_sh::{cap_coeffs, DirectionSet, ShBasis};
use std::f64::consts::PI;
use std::process::ExitCode;
use std::time::Instant;

fn l2(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

pub fn run(a: DemoArgs) -> anyhow::Result<ExitCode> {
    flags::int("--order", a.order, 2, 32)?;
    shscale_scene::vocab::AlphaDeg::new(a.alpha_deg)
        .map_err(|m| anyhow::anyhow!("--alpha-deg: {m}"))?;
    let json = a.format == crate::args::TextFormat::Json;
    let say = |line: String| {
        if !json {
            println!("{line}");
        }
    };
    let alpha = a.alpha_deg.to_radians();
    let t0 = Instant::now();
    let mut failures = Vec::new();
    say(format!(
        "shscale demo — cone model α = {}°, radii k = d/r of the papers' Fig. 5\n",
        a.alpha_deg
    ));
    let operator = operator_accuracy(a.order, alpha, &say, &mut failures)?;
    say(String::new());
    let on_surface = on_surface_failure(alpha, &say)?;
    say(String::new());
    let identities = identities(a.order.min(16), alpha, &say, &mut failures)?;
    let secs = t0.elapsed().as_secs_f64();
    if json {
        crate::output::print_json(&serde_json::json!({
            "alpha_deg": a.alpha_deg,
            "operator_accuracy": operator,
            "on_surface": on_surface,
            "identities": identities,
            "seconds": secs,
            "failures": failures,
        }))?;
    } else {
        println!();
        println!("done in {secs:.2} s");
    }
    if failures.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        for f in &failures {
            eprintln!("check failed: {f}");
        }
        Ok(ExitCode::from(1))
    }
}

/// Check 1: `‖M_k·cap(40°) − cap(τ_k⁻¹(40°))‖ / ‖cap(τ_k⁻¹(40°))‖` at the papers' radii for every
/// order up to `max_order`; a failure when it does not decrease with N.
fn operator_accuracy(
    max_order: usize,
    alpha: f64,
    say: &dyn Fn(String),
    failures: &mut Vec<String>,
) -> anyhow::Result<Vec<serde_json::Value>> {
    let orders: Vec<usize> = [2usize, 4, 8, 16, 32]
        .into_iter()
        .filter(|&n| n <= max_order)
        .collect();
    say("1. Operator accuracy: ‖M_k·cap(40°) − cap(τ_k⁻¹(40°))‖₂ / ‖cap(τ_k⁻¹(40°))‖₂ (band-limiting only)".into());
    let mut head = format!("{:>6}", "k");
    for n in &orders {
        head.push_str(&format!("  {:>10}", format!("N={n}")));
    }
    say(head);
    let cap_angle = 40f64.to_radians();
    let mut operator = Vec::new();
    for &k in &shscale_field::probe::DEFAULT_RADII {
        let tau = Cone::new(k, alpha)?;
        let target = tau.inverse(cap_angle);
        let mut line = format!("{k:>6}");
        let mut errs = Vec::new();
        for &n in &orders {
            let m = ScalingMatrix::compute(&tau, Eta::Plain, n)?;
            let src = cap_coeffs(n, cap_angle)?;
            let want = cap_coeffs(n, target)?;
            let mut got = vec![0.0; n * n];
            m.apply(&src, &mut got)?;
            let e = l2(&got, &want) / l2(&want, &vec![0.0; n * n]);
            errs.push(e);
            line.push_str(&format!("  {e:>10.3e}"));
        }
        say(line);
        if errs.len() >= 2 && errs[errs.len() - 1] >= errs[0] {
            failures.push(format!(
                "operator error does not decrease with N at k = {k}: {errs:?}"
            ));
        }
        operator.push(serde_json::json!({"k": k, "orders": orders, "relative_error": errs}));
    }
    Ok(operator)
}

/// Check 2: the on-surface failure case: a solid sphere sampled on its surface sees a half sphere,
/// which the cone model maps to a wrong cap (N = 4).
fn on_surface_failure(alpha: f64, say: &dyn Fn(String)) -> anyhow::Result<Vec<serde_json::Value>> {
    say("2. On-surface failure case: solid sphere, samples on its surface (visibility = half sphere)".into());
    say(format!(
        "{:>6}  {:>14}  {:>16}  {:>12}",
        "k", "true cap angle", "cone prediction", "occ_rel_l2 N=4"
    ));
    let mut on_surface = Vec::new();
    for &k in &[1.05, 1.3, 2.0, 4.0, 8.0] {
        let tau = Cone::new(k, alpha)?;
        let truth = (1.0 / k).asin();
        let predicted = tau.inverse(0.5 * PI);
        let n = 4;
        let m = ScalingMatrix::compute(&tau, Eta::Plain, n)?;
        // Occluded parts as caps (visibility = 1 − cap; the constant cancels in differences).
        let src = cap_coeffs(n, 0.5 * PI)?;
        let want = cap_coeffs(n, truth)?;
        let mut got = vec![0.0; n * n];
        // M maps the constant to itself, so M·(1 − cap) = 1 − M·cap.
        m.apply(&src, &mut got)?;
        let occ = l2(&got, &want) / l2(&want, &vec![0.0; n * n]);
        say(format!(
            "{k:>6}  {:>13.3}°  {:>15.3}°  {occ:>12.3e}",
            truth.to_degrees(),
            predicted.to_degrees()
        ));
        on_surface.push(serde_json::json!({
            "k": k,
            "true_cap_deg": truth.to_degrees(),
            "cone_prediction_deg": predicted.to_degrees(),
            "occ_rel_l2": occ,
        }));
    }
    Ok(on_surface)
}

/// The largest deviation of the Gram matrix of the order-`n` basis on its exact quadrature from I.
fn orthonormality_error(n: usize) -> anyhow::Result<f64> {
    let basis = ShBasis::<f64>::new(n)?;
    let set = DirectionSet::gauss_sphere_for_order(n);
    let mut gram = vec![0.0; n * n * n * n];
    let mut y = vec![0.0; n * n];
    for (d, &w) in set.dirs.iter().zip(&set.weights) {
        basis.eval(*d, &mut y);
        for i in 0..n * n {
            for j in 0..n * n {
                gram[i * n * n + j] += w * y[i] * y[j];
            }
        }
    }
    Ok((0..n * n)
        .flat_map(|i| (0..n * n).map(move |j| (i, j)))
        .map(|(i, j)| (gram[i * n * n + j] - if i == j { 1.0 } else { 0.0 }).abs())
        .fold(0.0f64, f64::max))
}

/// Check 3: the operator's identities at order `n`, each against [`TOL`].
fn identities(
    n: usize,
    alpha: f64,
    say: &dyn Fn(String),
    failures: &mut Vec<String>,
) -> anyhow::Result<Vec<serde_json::Value>> {
    say("3. Identities".into());
    let m1 = ScalingMatrix::compute(&Cone::new(1.0, alpha)?, Eta::Plain, n)?;
    let e_id = m1.max_abs_diff(&ScalingMatrix::identity(n)?);
    let me = ScalingMatrix::compute(&Cone::new(3.0, alpha)?, Eta::Energy, n)?.to_dense();
    let e_energy = (me[0][0] - 1.0)
        .abs()
        .max(me[0][1..].iter().fold(0.0f64, |s, v| s.max(v.abs())));
    let e_orth = orthonormality_error(n)?;
    let mut identities = Vec::new();
    for (name, e) in [
        ("M at k = 1 equals I", e_id),
        (
            "energy-preserving M keeps the l = 0 coefficient (row 0 = e0)",
            e_energy,
        ),
        ("SH orthonormal on the exact quadrature", e_orth),
    ] {
        let ok = e < TOL;
        say(format!(
            "  [{}] {name} (order {n}): max error {e:.2e} (tolerance {TOL:e})",
            if ok { "ok" } else { "FAIL" }
        ));
        if !ok {
            failures.push(format!("{name}: {e:e}"));
        }
        identities.push(serde_json::json!({"check": name, "order": n, "max_error": e, "tolerance": TOL, "ok": ok}));
    }
    Ok(identities)
}

/// The identities' tolerance: each holds to rounding (exact quadrature, exact matrices).
const TOL: f64 = 1e-12;
