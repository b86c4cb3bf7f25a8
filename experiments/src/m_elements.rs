//! Fig. 3 (SHS §2.2): how do individual elements of the scaling matrix `M_k` vary with k, and is
//! a table of 40 exponentially spaced k values, linearly interpolated, enough to represent them?
//!
//! Computes the chosen elements directly (adaptive quadrature) on a fine k grid, and again through
//! the k-table the paper recommends, and reports the interpolation error of those elements and of
//! the whole matrix (`KTable::max_interp_error`).

use crate::{write_text, FigureOutput};
use serde::Deserialize;
use shscale_lab::plots::{write_both, Labels};
use shscale_lab::LabError;
use shscale_scaling::{Cone, Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily};
use shscale_sh::sh_lm;
use std::collections::BTreeMap;
use std::path::Path;

/// Config of the figure.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// The kind (checked by [`crate::parse`]).
    #[serde(alias = "experiment")]
    pub figure: String,
    pub title: String,
    pub claim: String,
    pub order: usize,
    pub alpha_deg: f64,
    pub k_min: f64,
    pub k_max: f64,
    /// Entries of the table (the paper: 40, exponential).
    pub k_count: usize,
    /// `[row, column]` of each plotted element (must be structurally non-zero).
    pub elements: Vec<[usize; 2]>,
    /// Points of the direct curves.
    pub curve_points: usize,
}

crate::impl_header!(Spec);

fn cfg(file: &str, field: &str, msg: String) -> LabError {
    LabError::Config(format!("{file}: {field}: {msg}"))
}

/// Run the figure.
pub fn run(file: &str, s: &Spec, out: &Path, stem: &str) -> Result<FigureOutput, LabError> {
    let n = s.order;
    if !(1..=16).contains(&n) {
        return Err(cfg(file, "order", format!("{n} is outside 1..=16")));
    }
    if !(s.k_min > 0.0 && s.k_max > s.k_min && s.k_max.is_finite()) {
        return Err(cfg(
            file,
            "k_min",
            format!("need 0 < k_min < k_max, got {} and {}", s.k_min, s.k_max),
        ));
    }
    if !(2..=10_000).contains(&s.curve_points) || s.k_count < 2 {
        return Err(cfg(
            file,
            "curve_points",
            "need 2..=10000 curve points and k_count ≥ 2".into(),
        ));
    }
    for e in &s.elements {
        let ((li, mi), (lj, mj)) = (sh_lm(e[0]), sh_lm(e[1]));
        if e[0] >= n * n || e[1] >= n * n || mi != mj {
            return Err(cfg(
                file,
                "elements",
                format!("{e:?} is not a structural non-zero of an order-{n} matrix (same m needed; (l,m) = ({li},{mi}), ({lj},{mj}))"),
            ));
        }
    }
    let alpha = s.alpha_deg.to_radians();
    let table = KTable::build(
        TauFamily::Cone { alpha },
        Eta::Plain,
        n,
        s.k_count,
        s.k_min,
        s.k_max,
        Spacing::Exp,
        Interp::Linear,
    )
    .map_err(|e| cfg(file, "alpha_deg", e.to_string()))?;
    let mut interp = ScalingMatrix::identity(n).map_err(|e| cfg(file, "order", e.to_string()))?;
    let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut csv = String::from("k");
    for e in &s.elements {
        csv.push_str(&format!(
            ",M_{}_{}_direct,M_{}_{}_table",
            e[0], e[1], e[0], e[1]
        ));
    }
    csv.push('\n');
    let mut worst_elem: f64 = 0.0;
    let (l0, l1) = (s.k_min.ln(), s.k_max.ln());
    for p in 0..s.curve_points {
        let k = (l0 + (l1 - l0) * p as f64 / (s.curve_points - 1) as f64).exp();
        let m = ScalingMatrix::<f64>::compute(
            &Cone::new(k, alpha).map_err(|e| cfg(file, "k", e.to_string()))?,
            Eta::Plain,
            n,
        )
        .map_err(|e| cfg(file, "order", e.to_string()))?;
        table
            .lookup(k, &mut interp)
            .map_err(|e| cfg(file, "k", e.to_string()))?;
        csv.push_str(&format!("{k}"));
        for e in &s.elements {
            let (a, b) = (m.get(e[0], e[1]), interp.get(e[0], e[1]));
            worst_elem = worst_elem.max((a - b).abs());
            csv.push_str(&format!(",{a},{b}"));
            series
                .entry(format!("M[{}][{}]", e[0], e[1]))
                .or_default()
                .push((k, a));
        }
        csv.push('\n');
    }
    let (whole, at_k) = table
        .max_interp_error(8)
        .map_err(|e| cfg(file, "k_count", e.to_string()))?;
    let title = format!("elements of M_k vs k (cone, α = {}°, N = {n})", s.alpha_deg);
    let mut files = write_both(
        out,
        stem,
        &Labels {
            title: &title,
            x: "k = d / r (1)",
            y: "M_k element (1)",
        },
        &series,
        false,
        &[],
    )?;
    files.push(write_text(out, &format!("{stem}.csv"), &csv)?);
    let range = |e: &[usize; 2]| {
        let v = &series[&format!("M[{}][{}]", e[0], e[1])];
        let lo = v.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        let hi = v.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        format!("| ({}, {}) | {lo:.4} | {hi:.4} |", e[0], e[1])
    };
    let rows: Vec<String> = s.elements.iter().map(range).collect();
    let markdown = format!(
        "**Ours.** Cone τ, α = {}°, N = {n}, k ∈ [{}, {}] on {} exponentially spaced points, {} elements computed directly. \
A table of K = {} exponentially spaced k values with linear interpolation (the paper's choice) reproduces the plotted elements to \
{worst_elem:.2e} (max abs) and the whole matrix to {whole:.2e} (worst at k = {at_k:.3}; 8 points per interval checked against direct quadrature). \
Values as CSV in `{stem}.csv`.\n\n\
**Comparison.** The paper shows six elements changing smoothly with k and finds 40 exponentially spaced samples sufficient. Our curves are smooth over the range \
(no element jumps), and the measured interpolation error quantifies \"sufficient\": {whole:.1e} absolute on elements of magnitude ≤ 1 — small for low-frequency \
shadowing but not negligible; docs/math.md shows it falls as K⁻² (cubic interpolation in ln k: K⁻⁴).\n\n| element (row, column) | min over k | max over k |\n|---|---:|---:|\n{}",
        s.alpha_deg,
        s.k_min,
        s.k_max,
        s.curve_points,
        s.elements.len(),
        s.k_count,
        rows.join("\n")
    );
    Ok(FigureOutput { files, markdown })
}
