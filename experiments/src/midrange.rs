//! Mid-range environment lighting (SHS §3.2, Eq. 7): how much better than the distant-lighting
//! assumption is SH scaling of the light captured at the centre, as the receiver moves from the
//! centre toward the environment sphere (k = d/R → 1)?
//!
//! Environment: the analytic sky with a sun (`EnvLight::sky`) on a sphere of radius R = 1. Truth
//! at a point q with normal n: `∫ L_c(u(ω)) max(0, n·ω) dω` by Gauss quadrature, u(ω) the
//! direction from the centre to where the ray from q leaves the sphere (radiance is constant along
//! rays). Compared: ⟨lobe(n), M_k L_c⟩ (mid-range scaling, rotated into q's frame) and
//! ⟨lobe(n), L_c⟩ (distant). Per k: mean and max relative irradiance error over a Fibonacci set
//! of point directions × normals.

use crate::{write_text, FigureOutput};
use glam::DVec3;
use serde::Deserialize;
use shscale_field::shading::EnvLight;
use shscale_lab::plots::{write_both, Labels};
use shscale_lab::LabError;
use shscale_sh::{ClampedCosine, DirectionSet, ShBasis};
use std::collections::BTreeMap;
use std::path::Path;

/// Config of the study.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    #[serde(alias = "experiment")]
    pub figure: String,
    pub title: String,
    pub claim: String,
    pub order: usize,
    /// k = d/R values in [0, 1).
    pub k: Vec<f64>,
    /// Point directions (Fibonacci) per k; each with `normals` normals.
    pub points: usize,
    pub normals: usize,
    /// Sun strength, direction and angular radius (degrees) of the sky.
    pub sun: f64,
    pub sun_dir: [f64; 3],
    pub sun_radius_deg: f64,
}

crate::impl_header!(Spec);

fn fib(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let a = i as f64 * 2.399963229728653;
            let s = (1.0 - z * z).sqrt();
            DVec3::new(s * a.cos(), s * a.sin(), z)
        })
        .collect()
}

/// Run the study.
pub fn run(file: &str, s: &Spec, out: &Path, stem: &str) -> Result<FigureOutput, LabError> {
    let cfg = |f: &str, m: String| LabError::Config(format!("{file}: {f}: {m}"));
    if !(1..=16).contains(&s.order) {
        return Err(cfg("order", format!("{} is outside 1..=16", s.order)));
    }
    if s.k.is_empty() || s.k.iter().any(|k| !(0.0..1.0).contains(k)) {
        return Err(cfg("k", format!("{:?}: every k must be in [0, 1)", s.k)));
    }
    if s.points == 0 || s.normals == 0 {
        return Err(cfg("points", "points and normals must be ≥ 1".into()));
    }
    let env = EnvLight::sky(
        s.order,
        0.2,
        0.8,
        DVec3::Z,
        s.sun,
        DVec3::from_array(s.sun_dir),
        s.sun_radius_deg.to_radians(),
    )?;
    let lobe = ClampedCosine::<f64>::new(s.order).map_err(|e| cfg("order", e.to_string()))?;
    let basis = ShBasis::<f64>::new(s.order).map_err(|e| cfg("order", e.to_string()))?;
    let quad = DirectionSet::gauss_sphere(96, 192);
    let mut csv = String::from("k,scaled_rel_err_mean,scaled_rel_err_max,distant_rel_err_mean,distant_rel_err_max,scaled_better_fraction,seconds\n");
    let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut rows = Vec::new();
    for &k in &s.k {
        let t0 = std::time::Instant::now();
        let (mut sc, mut di, mut better) = (Vec::new(), Vec::new(), 0usize);
        for v in fib(s.points) {
            let q = k * v;
            let light = shscale_field::midrange::light_at(&env, q, 1.0)?;
            for n in fib(s.normals) {
                let truth = shscale_field::midrange::irradiance_by_ray_exit(
                    &env, 0, q, 1.0, n, &quad, &basis,
                );
                let scaled = lobe
                    .irradiance(&light.rgb[0], n.to_array())
                    .map_err(|e| cfg("order", e.to_string()))?;
                let distant = lobe
                    .irradiance(&env.rgb[0], n.to_array())
                    .map_err(|e| cfg("order", e.to_string()))?;
                let (es, ed) = (
                    (scaled - truth).abs() / truth,
                    (distant - truth).abs() / truth,
                );
                better += usize::from(es <= ed);
                sc.push(es);
                di.push(ed);
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        let frac = better as f64 / sc.len() as f64;
        let secs = t0.elapsed().as_secs_f64();
        csv.push_str(&format!(
            "{k},{},{},{},{},{frac},{secs}\n",
            mean(&sc),
            max(&sc),
            mean(&di),
            max(&di)
        ));
        series
            .entry("SH scaling (mid-range τ)".into())
            .or_default()
            .push((k, mean(&sc)));
        series
            .entry("distant assumption".into())
            .or_default()
            .push((k, mean(&di)));
        rows.push(format!(
            "| {k} | {:.4} | {:.4} | {:.4} | {:.4} | {:.0} % |",
            mean(&sc),
            max(&sc),
            mean(&di),
            max(&di),
            100.0 * frac
        ));
    }
    let pairs: Vec<(f64, f64, f64)> = series["SH scaling (mid-range τ)"]
        .iter()
        .zip(&series["distant assumption"])
        .filter(|(a, _)| a.0 > 0.0)
        .map(|(a, b)| (a.0, a.1, b.1))
        .collect();
    let verdict = if pairs.is_empty() {
        "no k > 0 was measured".to_string()
    } else if pairs.iter().all(|p| p.1 < p.2) {
        let ratio = |p: &(f64, f64, f64)| p.2 / p.1.max(1e-300);
        let (lo, hi) = pairs
            .iter()
            .map(ratio)
            .fold((f64::MAX, 0f64), |(a, b), r| (a.min(r), b.max(r)));
        format!(
            "at every k > 0 mid-range scaling has the lower mean error, by a factor {lo:.0}–{hi:.0}; the distant assumption's error grows to {:.2} at k = {}, scaling's stays ≤ {:.4} (order-{} band-limiting and quadrature are what remain)",
            pairs.last().map_or(0.0, |p| p.2),
            pairs.last().map_or(0.0, |p| p.0),
            pairs.iter().map(|p| p.1).fold(0.0, f64::max),
            s.order
        )
    } else {
        "mid-range scaling does NOT have the lower mean error at every k — see the table"
            .to_string()
    };
    let mut files = write_both(
        out,
        stem,
        &Labels {
            title: "mid-range lighting: irradiance error vs k = d/R",
            x: "k = d / R (1)",
            y: "mean relative irradiance error (1)",
        },
        &series,
        false,
        &[],
    )?;
    files.push(write_text(out, &format!("{stem}.csv"), &csv)?);
    let markdown = format!(
        "**Ours.** Sky (ambient 0.2, zenith 0.8, sun {} of radius {}°) on an environment sphere R = 1, order {}; per k, {} point \
directions × {} normals; truth by a 96 × 192 Gauss rule of the exact ray exit.\n\n| k | scaled mean | scaled max | distant mean | distant max | scaled better |\n|---:|---:|---:|---:|---:|---:|\n{}\n\n\
**Comparison.** The paper shows images only. Measured: {}.",
        s.sun,
        s.sun_radius_deg,
        s.order,
        s.points,
        s.normals,
        rows.join("\n"),
        verdict
    );
    Ok(FigureOutput { files, markdown })
}
