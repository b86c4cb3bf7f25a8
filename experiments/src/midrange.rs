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

use glam::DVec3;
use serde::{Deserialize, Serialize};
use shscale_field::shading::EnvLight;
use shscale_present::plots::{write_both, Labels};
use shscale_runner::check::Ends;
use shscale_runner::records::Results;
use shscale_runner::{Cost, Ctx, KeyError, Kind};
use shscale_scene::Error;
use shscale_sh::{ClampedCosine, DirectionSet, ShBasis};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Parameters of one run (one k); sweep `k` (and anything else) in the config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    pub order: usize,
    /// k = d/R in [0, 1).
    pub k: f64,
    /// Point directions (Fibonacci) at distance k; each with `normals` normals.
    pub points: usize,
    pub normals: usize,
    /// Sun strength, direction (normalised here) and angular radius (degrees) of the sky.
    pub sun: f64,
    #[serde(with = "shscale_runner::records::list")]
    pub sun_dir: Vec<f64>,
    pub sun_radius_deg: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            order: 8,
            k: 0.5,
            points: 12,
            normals: 6,
            sun: 8.0,
            sun_dir: vec![0.6, 0.0, 0.8],
            sun_radius_deg: 20.0,
        }
    }
}

/// One row per run.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    pub scaled_rel_err_mean: f64,
    pub scaled_rel_err_max: f64,
    pub distant_rel_err_mean: f64,
    pub distant_rel_err_max: f64,
    /// Fraction of (point, normal) pairs where scaling is at least as close as the distant
    /// assumption.
    pub scaled_better_fraction: f64,
    /// The truth's own error: the largest relative change of the truth when its quadrature is
    /// halved in each direction (48 × 96 against 96 × 192 nodes).
    pub truth_rel_err_max: f64,
    /// Median over the timing procedure of the whole evaluation of this k.
    pub evaluation_seconds: f64,
    pub evaluation_spread: f64,
}

/// The kind `midrange`.
pub struct MidRange;

/// The truth quadrature: a 96 × 192 Gauss rule of the exact ray exit.
const QUAD: (usize, usize) = (96, 192);

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

fn evaluate(p: &Params) -> Result<Row, Error> {
    let cfg = |m: String| Error::config(m);
    let env = EnvLight::sky(
        p.order,
        0.2,
        0.8,
        DVec3::Z,
        p.sun,
        DVec3::new(p.sun_dir[0], p.sun_dir[1], p.sun_dir[2]),
        p.sun_radius_deg.to_radians(),
    )?;
    let lobe = ClampedCosine::<f64>::new(p.order).map_err(|e| cfg(e.to_string()))?;
    let basis = ShBasis::<f64>::new(p.order).map_err(|e| cfg(e.to_string()))?;
    let quad = DirectionSet::gauss_sphere(QUAD.0, QUAD.1);
    let coarse = DirectionSet::gauss_sphere(QUAD.0 / 2, QUAD.1 / 2);
    let (mut sc, mut di, mut better) = (Vec::new(), Vec::new(), 0usize);
    let mut truth_err = 0f64;
    for v in fib(p.points) {
        let q = p.k * v;
        let light = shscale_field::midrange::light_at(&env, q, 1.0)?;
        for n in fib(p.normals) {
            let truth =
                shscale_field::midrange::irradiance_by_ray_exit(&env, 0, q, 1.0, n, &quad, &basis);
            let half = shscale_field::midrange::irradiance_by_ray_exit(
                &env, 0, q, 1.0, n, &coarse, &basis,
            );
            truth_err = truth_err.max((half - truth).abs() / truth.abs().max(1e-300));
            let scaled = lobe
                .irradiance(&light.rgb[0], n.to_array())
                .map_err(|e| cfg(e.to_string()))?;
            let distant = lobe
                .irradiance(&env.rgb[0], n.to_array())
                .map_err(|e| cfg(e.to_string()))?;
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
    Ok(Row {
        scaled_rel_err_mean: mean(&sc),
        scaled_rel_err_max: max(&sc),
        distant_rel_err_mean: mean(&di),
        distant_rel_err_max: max(&di),
        scaled_better_fraction: better as f64 / sc.len() as f64,
        truth_rel_err_max: truth_err,
        evaluation_seconds: 0.0,
        evaluation_spread: 0.0,
    })
}

/// The most point directions and normals per run.
pub const MAX_POINTS: usize = 10_000;

impl Kind for MidRange {
    const NAME: &'static str = "midrange";
    const QUESTION: &'static str = "SHS §3.2: with the irradiance sampled only at the centre of an environment sphere, how much closer to the exact irradiance is SH scaling with the mid-range τ (Eq. 7) than the distant-lighting assumption, as the receiver moves to k = d/R?";
    type Params = Params;
    type Shared = ();
    type Row = Row;
    type Error = Error;
    type Spec = Params;

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("order", "SH order N, 1..=16"),
            (
                "k",
                "receiver distance from the centre over the environment radius, k = d/R in [0, 1)",
            ),
            (
                "points",
                "point directions (Fibonacci) at distance k, 1..=10000",
            ),
            (
                "normals",
                "receiver normals per point (Fibonacci), 1..=10000",
            ),
            ("sun", "sun strength of the analytic sky, [0, 1e6]"),
            (
                "sun_dir",
                "sun direction, three finite numbers not all 0 (normalised)",
            ),
            ("sun_radius_deg", "sun's angular radius, degrees, (0, 90]"),
        ]
    }

    fn resolve(p: &Params) -> Result<Params, KeyError> {
        KeyError::int("order", p.order, 1, 16)?;
        KeyError::real("k", p.k, 0.0, 1.0, Ends::ClosedOpen)?;
        for (key, v) in [("points", p.points), ("normals", p.normals)] {
            KeyError::int(key, v, 1, MAX_POINTS)?;
        }
        KeyError::real("sun", p.sun, 0.0, 1e6, Ends::Closed)?;
        let len = p.sun_dir.iter().map(|x| x * x).sum::<f64>().sqrt();
        if p.sun_dir.len() != 3 || !(len.is_finite() && len > 0.0) {
            return Err(KeyError::new(
                "sun_dir",
                format!("{:?} must be three finite numbers, not all 0", p.sun_dir),
            ));
        }
        KeyError::real(
            "sun_radius_deg",
            p.sun_radius_deg,
            0.0,
            90.0,
            Ends::OpenClosed,
        )?;
        Ok(p.clone())
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        let pairs = (p.points * p.normals) as f64;
        let quad = (QUAD.0 * QUAD.1) as f64;
        (
            Cost::default(),
            Cost {
                cached_once: None,
                rays: 0.0,
                bytes: quad * 8.0 * (p.order * p.order) as f64,
                // ≈ 70 ns per quadrature point and pair: `shscale run configs/experiments/
                // midrange.toml` (12 × 6 pairs, 6 k × 4 timed calls) took 2.1 s here.
                seconds: pairs * quad * 7e-8,
                once_seconds: 0.0,
                drivers: format!("points × normals = {pairs} pairs × {quad} quadrature points"),
            },
        )
    }

    fn rows_per_run(_: &Params) -> usize {
        1
    }

    fn shared(_: &Params, _: &Ctx) -> Result<(), Error> {
        Ok(())
    }

    fn run(p: &Params, _: &str, _: &(), ctx: &Ctx) -> Result<Vec<Row>, Error> {
        let (mut row, t) = ctx.timing.measure(|| evaluate(p))?;
        row.evaluation_seconds = t.median;
        row.evaluation_spread = t.spread();
        Ok(vec![row])
    }

    fn time_columns() -> &'static [&'static str] {
        &["evaluation_seconds", "evaluation_spread"]
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "k",
            "scaled_rel_err_mean",
            "distant_rel_err_mean",
            "scaled_better_fraction",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        // Error against k: per combination of the other varying parameters, scaled and distant.
        let params = shscale_runner::Erased::<MidRange>::new();
        let others: Vec<String> = t
            .varying(&shscale_runner::DynKind::param_columns(&params))
            .into_iter()
            .filter(|c| c != "k")
            .collect();
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for r in 0..t.rows.len() {
            let label = others
                .iter()
                .map(|o| format!(", {} = {}", shscale_present::plots::words(o), t.cell(r, o)))
                .collect::<String>();
            for (name, col) in [
                ("SH scaling (mid-range τ)", "scaled_rel_err_mean"),
                ("distant assumption", "distant_rel_err_mean"),
            ] {
                series
                    .entry(format!("{name}{label}"))
                    .or_default()
                    .push((t.num(r, "k"), t.num(r, col)));
            }
        }
        for v in series.values_mut() {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        Ok(write_both(
            dir,
            "midrange_error_vs_k",
            &Labels {
                title: "mid-range lighting: irradiance error vs k = d/R",
                x: "k = d / R (1)",
                y: "mean relative irradiance error (1)",
            },
            &series,
            false,
            &[],
        )?)
    }
}
