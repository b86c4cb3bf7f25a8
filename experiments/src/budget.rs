//! Speed and accuracy at equal budget: on the same receivers, how accurate is the visibility of
//! SH-scaling extrapolation, of a fully sampled shadow field (Zhou et al. 2005) with 2…16 shells,
//! and of direct ray tracing, for the time a deforming object allows per frame and for the
//! memory each holds — and is extrapolation "about 20× faster than the full shadow field" (SHS §4)
//! at equal accuracy?
//!
//! Receivers: the probe points of the `probe` kind (seeded directions × `radii`, outside the
//! bounding sphere), their converged truth computed once per group. A run is one method and
//! budget. Per frame of a deforming object every method starts from scratch: extrapolation
//! samples the BSV (P samples × H² rays; its k-table is built once, before the frames), the full
//! field samples S shells over [1, max radius]·r (the receivers' span, which favours it)
//! of P samples each (S·P·H² rays), ray tracing casts `4T²` stratified rays per receiver; then
//! each evaluates every receiver. `frame_seconds` is the sum (medians of the timing procedure),
//! `memory_bytes` what the field holds (BSV and table, S shells, nothing). Error: the mean
//! `occ_rel_l2` over the receivers against the converged truth.

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use shscale_field::evaluator::{FullField, VisibilityField};
use shscale_field::extrapolate::Extrapolator;
use shscale_field::metrics::occ_rel_l2;
use shscale_field::probe::random_directions;
use shscale_field::truth::{Truth, TruthSampler};
use shscale_field::{Bsv, Layout, VisibilitySampler};
use shscale_runner::check::Ends;
use shscale_runner::plots::{write_both, Labels};
use shscale_runner::records::{list, Results};
use shscale_runner::{Cost, Ctx, Device, GpuMode, KeyError, Kind, Typed};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Parameters of one run (one method at one budget).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    pub mesh: String,
    pub order: usize,
    /// `extrapolated`, `full_field` or `ray_traced`.
    pub method: String,
    /// Base-sphere layout (extrapolation) or per-shell layout (full field).
    pub layout: String,
    /// H: H² rays per BSV or shell sample.
    pub hemisphere_res: usize,
    /// Shells of the full field, 2..=64 (ignored by the other methods).
    pub shells: usize,
    /// T of the ray-traced method (4T² rays per receiver; ignored by the others).
    pub rt_res: usize,
    pub alpha_deg: f64,
    pub k_count: usize,
    /// Receivers: as many seeded directions as `receivers` at each radius.
    pub receivers: usize,
    pub probe_seed: u64,
    pub truth_res: usize,
    pub truth_seed: u64,
    #[serde(with = "list")]
    pub radii: Vec<f64>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            mesh: "bunny".into(),
            order: 4,
            method: "extrapolated".into(),
            layout: "latlong:12x20".into(),
            hemisphere_res: 32,
            shells: 16,
            rt_res: 8,
            alpha_deg: 45.0,
            k_count: 40,
            receivers: 240,
            probe_seed: 1,
            truth_res: shscale_field::truth::DEFAULT_TRUTH_RES,
            truth_seed: shscale_field::truth::DEFAULT_TRUTH_SEED,
            radii: vec![1.1, 1.3, 1.6, 2.0, 3.0],
        }
    }
}

/// One row per run.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    /// Receiver points (directions × radii).
    pub receiver_points: usize,
    /// Rays cast per frame.
    pub rays: f64,
    pub memory_bytes: f64,
    /// Sampling (and table build) per frame, evaluation of every receiver, their sum.
    pub build_seconds: f64,
    pub eval_seconds: f64,
    pub frame_seconds: f64,
    pub occ_rel_l2_mean: Option<f64>,
    /// The mean over the receivers nearest the object (ρ ≤ 1.3) and the rest.
    pub occ_rel_l2_near_mean: Option<f64>,
    pub occ_rel_l2_far_mean: Option<f64>,
    pub truth_rel_err_mean: Option<f64>,
}

/// The kind.
pub struct Budget;

/// What runs of a group share: the occluder, the receivers and their truth.
pub struct Shared {
    occ: Box<dyn shscale_geometry::Occluder>,
    points: Vec<(f64, DVec3)>,
    truth: Vec<Option<Truth>>,
}

const METHODS: [&str; 3] = ["extrapolated", "full_field", "ray_traced"];
/// The most shells of a full field.
pub const MAX_SHELLS: usize = 64;
/// The most receivers per radius.
pub const MAX_RECEIVERS: usize = 100_000;

fn mean(v: impl Iterator<Item = f64>) -> Option<f64> {
    let v: Vec<f64> = v.collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Median seconds of `f` under the config's timing procedure.
fn timed<T>(ctx: &Ctx, f: impl FnMut() -> Result<T, Error>) -> Result<(T, f64), Error> {
    let (v, t) = ctx.timing.measure(f)?;
    Ok((v, t.median))
}

impl Kind for Budget {
    const NAME: &'static str = "budget";
    const QUESTION: &'static str = "At equal time per frame (and memory) on the same receivers, which is most accurate — SH-scaling extrapolation, a fully sampled shadow field with 2…16 shells, or ray tracing — and is extrapolation about 20× faster than the full shadow field at equal accuracy?";
    type Params = Params;
    type Shared = Shared;
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, Layout>;
    fn open_device(mode: GpuMode) -> Result<Option<Device>, Error> {
        shscale_scene::gpu_path::open_device(mode)
    }

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("mesh", "the occluder, as in `probe`"),
            ("order", "SH order N, 1..=16"),
            ("method", "`extrapolated`, `full_field` or `ray_traced`"),
            ("layout", "base-sphere layout (extrapolation) or the layout of every shell (full field), as in `probe`"),
            ("hemisphere_res", "H: H² rays per BSV or shell sample, 1..=256"),
            ("shells", "shells of the full field over [1, max radius]·r, 2..=64"),
            ("rt_res", "T of the ray-traced method: 4T² stratified rays per receiver, 1..=1024"),
            ("alpha_deg", "cone angle α of the extrapolation, degrees, (0, 90)"),
            ("k_count", "k-table entries of the extrapolation, 2..=10000"),
            ("receivers", "receiver directions per radius (seeded), 1..=100000"),
            ("probe_seed", "seed of the receiver directions"),
            ("truth_res", "T of the converged truth at the receivers, 1..=1024"),
            ("truth_seed", "seed of the truth"),
            ("radii", "receiver radii in bounding radii, each in (1, 1e3], distinct, 1 to 64"),
        ]
    }

    fn resolve(p: &Params) -> Result<Self::Spec, KeyError> {
        shscale_scene::vocab::check_sampling_keys(
            &p.mesh,
            p.order,
            p.alpha_deg,
            &p.layout,
            p.hemisphere_res,
        )?;
        if !METHODS.contains(&p.method.as_str()) {
            return Err(KeyError::new(
                "method",
                format!("{:?} is not one of {METHODS:?}", p.method),
            ));
        }
        let checks: [(&str, usize, usize, usize); 4] = [
            ("shells", p.shells, 2, MAX_SHELLS),
            ("rt_res", p.rt_res, 1, shscale_field::truth::MAX_TRUTH_RES),
            (
                "truth_res",
                p.truth_res,
                1,
                shscale_field::truth::MAX_TRUTH_RES,
            ),
            ("receivers", p.receivers, 1, MAX_RECEIVERS),
        ];
        for (k, v, lo, hi) in checks {
            KeyError::int(k, v, lo, hi)?;
        }
        KeyError::int("k_count", p.k_count, 2, shscale_scene::vocab::MAX_K_COUNT)?;
        if p.radii.is_empty() || p.radii.len() > 64 {
            return Err(KeyError::new(
                "radii",
                format!("{} radii: give 1 to 64", p.radii.len()),
            ));
        }
        for (i, r) in p.radii.iter().enumerate() {
            KeyError::real("radii", *r, 1.0, 1e3, Ends::OpenClosed)?;
            if p.radii[..i].contains(r) {
                return Err(KeyError::new("radii", format!("radius {r} appears twice")));
            }
        }
        let layout =
            Layout::parse(&p.layout).map_err(|e| KeyError::new("layout", e.to_string()))?;
        Ok(Typed {
            params: p.clone(),
            typed: layout,
        })
    }

    fn group_key(p: &Params) -> String {
        format!(
            "{};{};{};{};{};{};{:?}",
            p.mesh, p.order, p.receivers, p.probe_seed, p.truth_res, p.truth_seed, p.radii
        )
    }

    fn cost(p: &Params) -> (Cost, Cost) {
        let n = (p.receivers * p.radii.len()) as f64;
        let t4 = 4.0 * (p.truth_res * p.truth_res) as f64;
        let samples = Layout::parse(&p.layout)
            .ok()
            .and_then(|l| l.sample_count())
            .unwrap_or(0) as f64;
        let h2 = (p.hemisphere_res * p.hemisphere_res) as f64;
        let nn = (p.order * p.order) as f64;
        let shared_rays = if p.mesh == "sphere" { 0.0 } else { n * t4 };
        let rays = match p.method.as_str() {
            "extrapolated" => samples * h2,
            "full_field" => p.shells as f64 * samples * h2,
            _ => n * 4.0 * (p.rt_res * p.rt_res) as f64,
        };
        let shells = if p.method == "full_field" {
            p.shells as f64
        } else {
            1.0
        };
        (
            Cost {
                rays: shared_rays,
                bytes: n * nn * 8.0 + 64e6,
                seconds: 0.0,
                // The truths: once, never timed.
                once_seconds: shared_rays / shscale_runner::timing::TRUTH_RAYS_PER_SECOND,
                drivers: format!(
                    "{n} receivers × truth_res = {} ({t4} rays each)",
                    p.truth_res
                ),
            },
            Cost {
                // One frame; the estimate multiplies its seconds by the timing procedure's
                // warm-up + repeats (the rays counted are one frame's).
                rays,
                bytes: shells * samples * nn * 8.0 + p.k_count as f64 * nn * nn * 8.0,
                // Every method's frame ran at 1.9–2.4e7 rays/s in `configs/experiments/
                // budget.toml` (the `rays` and `frame_seconds` columns): the truths' rate.
                seconds: rays / shscale_runner::timing::TRUTH_RAYS_PER_SECOND,
                once_seconds: 0.0,
                drivers: format!("method {} → {rays:.3e} rays per frame", p.method),
            },
        )
    }

    fn rows_per_run(_: &Params) -> usize {
        1
    }

    fn shared(p: &Self::Spec, _: &Ctx) -> Result<Shared, Error> {
        let u = shscale_scene::vocab::unit_occluder(&p.mesh)?;
        let occ = u.occ;
        let s = occ.bounding_sphere();
        // The receiver directions: the probe kind's seeded directions.
        let dirs = random_directions(p.probe_seed, p.receivers);
        let points: Vec<(f64, DVec3)> = p
            .radii
            .iter()
            .flat_map(|&rho| dirs.iter().map(move |d| (rho, *d)))
            .map(|(rho, d)| (rho, s.center + rho * s.radius * d))
            .collect();
        let ts = TruthSampler::new(p.order, p.truth_res, p.truth_seed)?;
        let basis =
            shscale_sh::ShBasis::<f64>::new(p.order).map_err(|e| Error::config(e.to_string()))?;
        let truth: Vec<Option<Truth>> = points
            .par_iter()
            .enumerate()
            .map(|(i, (_, q))| match u.analytic {
                Some(sph) => shscale_field::probe::sphere_truth(&basis, &sph, *q).map(Truth::exact),
                None => {
                    Some(ts.sample_stream(occ.as_ref(), *q, i as u64)).filter(|t| t.escaped > 0)
                }
            })
            .collect();
        Ok(Shared { occ, points, truth })
    }

    fn run(p: &Self::Spec, _: &str, sh: &Shared, ctx: &Ctx) -> Result<Vec<Row>, Error> {
        let occ = sh.occ.as_ref();
        let layout = p.typed;
        let nn = p.order * p.order;
        let sampler = VisibilitySampler::new(p.order, p.hemisphere_res)?;
        let rho_max = p.radii.iter().copied().fold(1.0, f64::max);
        let cfg = |e: shscale_scaling::ScalingError| Error::config(e.to_string());
        let (values, build, eval, rays, memory): (Vec<Vec<f64>>, f64, f64, f64, f64) =
            match p.method.as_str() {
                "extrapolated" => {
                    // The k-table depends on α, N and the k range only: built once, before the
                    // frames, and not part of a frame's time (it is part of the memory).
                    let (lo, hi) = shscale_field::probe::k_range(&p.radii, 1.0);
                    let table = KTable::build(
                        TauFamily::Cone {
                            alpha: p.alpha_deg.to_radians(),
                        },
                        Eta::Plain,
                        p.order,
                        p.k_count,
                        lo,
                        hi,
                        Spacing::Exp,
                        Interp::Linear,
                    )
                    .map_err(cfg)?;
                    let (bsv, build) =
                        timed(ctx, || Ok(Bsv::sample(occ, layout, &sampler, 1.0, 0.0)?))?;
                    let ex = Extrapolator::new(&bsv, &table);
                    let (v, eval) = timed(ctx, || Ok(eval_all(&ex, &sh.points, nn)))?;
                    let mem = (bsv.samples.len() * nn * 8 + table.size_bytes()) as f64;
                    (v, build, eval, bsv.rays as f64, mem)
                }
                "full_field" => {
                    let (ff, build) = timed(ctx, || {
                        Ok(FullField::build(
                            occ, layout, &sampler, p.shells, 1.0, rho_max,
                        )?)
                    })?;
                    let (v, eval) = timed(ctx, || Ok(eval_all(&ff, &sh.points, nn)))?;
                    let mem = (p.shells * layout.sample_count().unwrap_or(0) * nn * 8) as f64;
                    (v, build, eval, ff.rays as f64, mem)
                }
                _ => {
                    // A different seed from the reference truth's: independent draws.
                    let ts = TruthSampler::new(p.order, p.rt_res, p.truth_seed ^ 0x00ff_00ff_00ff)?;
                    let (v, eval) = timed(ctx, || {
                        Ok(sh
                            .points
                            .par_iter()
                            .enumerate()
                            .map(|(i, (_, q))| ts.sample_stream(occ, *q, i as u64).coeffs)
                            .collect::<Vec<_>>())
                    })?;
                    (v, 0.0, eval, (sh.points.len() * ts.rays()) as f64, 0.0)
                }
            };
        let errs: Vec<(f64, Option<f64>, Option<f64>)> = values
            .iter()
            .zip(&sh.truth)
            .zip(&sh.points)
            .filter_map(|((v, t), (rho, _))| {
                let t = t.as_ref()?;
                Some((*rho, occ_rel_l2(v, &t.coeffs), t.rel_error()))
            })
            .collect();
        Ok(vec![Row {
            receiver_points: sh.points.len(),
            rays,
            memory_bytes: memory,
            build_seconds: build,
            eval_seconds: eval,
            frame_seconds: build + eval,
            occ_rel_l2_mean: mean(errs.iter().filter_map(|e| e.1)),
            occ_rel_l2_near_mean: mean(errs.iter().filter(|e| e.0 <= 1.3).filter_map(|e| e.1)),
            occ_rel_l2_far_mean: mean(errs.iter().filter(|e| e.0 > 1.3).filter_map(|e| e.1)),
            truth_rel_err_mean: mean(errs.iter().filter(|e| e.1.is_some()).filter_map(|e| e.2)),
        }])
    }

    fn time_columns() -> &'static [&'static str] {
        &["build_seconds", "eval_seconds", "frame_seconds"]
    }

    fn summary_columns() -> &'static [&'static str] {
        &["method", "frame_seconds", "memory_bytes", "occ_rel_l2_mean"]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        let mut files = Vec::new();
        for mesh in t.distinct("mesh") {
            for (x, stem, xl) in [
                (
                    "frame_seconds",
                    format!("pareto_time_{mesh}"),
                    "time per frame (s)",
                ),
                (
                    "memory_bytes",
                    format!("pareto_memory_{mesh}"),
                    "memory (bytes)",
                ),
            ] {
                let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
                for r in (0..t.rows.len()).filter(|&r| t.cell(r, "mesh") == mesh) {
                    let (xv, y) = (t.num(r, x), t.num(r, "occ_rel_l2_mean"));
                    if xv.is_finite() && xv > 0.0 && y.is_finite() {
                        series
                            .entry(t.cell(r, "method").to_string())
                            .or_default()
                            .push((xv, y));
                    }
                }
                for v in series.values_mut() {
                    v.sort_by(|a, b| a.0.total_cmp(&b.0));
                }
                if series.is_empty() {
                    continue;
                }
                files.extend(write_both(
                    dir,
                    &stem,
                    &Labels {
                        title: &format!("{mesh}: error against {xl}"),
                        x: xl,
                        y: "mean occ_rel_l2",
                    },
                    &series,
                    true,
                    &[],
                )?);
            }
        }
        Ok(files)
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        let mut s = String::new();
        for mesh in t.distinct("mesh") {
            let rows: Vec<usize> = (0..t.rows.len())
                .filter(|&r| t.cell(r, "mesh") == mesh)
                .collect();
            let e = |r: usize| t.num(r, "occ_rel_l2_mean");
            let f = |r: usize| t.num(r, "frame_seconds");
            let name = |r: usize| match t.cell(r, "method") {
                "full_field" => format!(
                    "full field, {} shells of `{}`, H = {}",
                    t.cell(r, "shells"),
                    t.cell(r, "layout"),
                    t.cell(r, "hemisphere_res")
                ),
                "ray_traced" => format!("ray tracing, T = {}", t.cell(r, "rt_res")),
                _ => format!(
                    "extrapolation, `{}`, H = {}",
                    t.cell(r, "layout"),
                    t.cell(r, "hemisphere_res")
                ),
            };
            s.push_str(&format!("**{mesh}.** "));
            // The Pareto front over all methods: who wins at which budget.
            let mut by_time = rows.clone();
            by_time.sort_by(|&a, &b| f(a).total_cmp(&f(b)));
            let mut best = f64::INFINITY;
            let mut front = Vec::new();
            for &r in &by_time {
                if e(r).is_finite() && e(r) < best {
                    best = e(r);
                    front.push(r);
                }
            }
            s.push_str("Lowest error for the time per frame (the Pareto front): ");
            s.push_str(
                &front
                    .iter()
                    .map(|&r| format!("{} at {:.2} ms ({:.3})", name(r), 1e3 * f(r), e(r)))
                    .collect::<Vec<_>>()
                    .join("; "),
            );
            s.push_str(". ");
            // 20×: for each extrapolation run, the fastest full field at least as accurate.
            let mut ratios = Vec::new();
            for &x in rows
                .iter()
                .filter(|&&r| t.cell(r, "method") == "extrapolated")
            {
                let ff = rows
                    .iter()
                    .copied()
                    .filter(|&r| t.cell(r, "method") == "full_field" && e(r) <= e(x))
                    .min_by(|&a, &b| f(a).total_cmp(&f(b)));
                if let Some(ff) = ff {
                    ratios.push((f(ff) / f(x), x, ff));
                }
            }
            match ratios.iter().max_by(|a, b| a.0.total_cmp(&b.0)) {
                Some((ratio, x, ff)) => s.push_str(&format!(
                    "Equal accuracy: the fastest full field at least as accurate as {} ({:.3}) is {} ({:.3}), {ratio:.1}× its time per frame.\n\n",
                    name(*x), e(*x), name(*ff), e(*ff)
                )),
                None => s.push_str("No full field here is as accurate as any extrapolation run: the 20× claim cannot be checked at equal accuracy on these runs.\n\n"),
            }
        }
        Ok(s)
    }
}

fn eval_all(f: &(dyn VisibilityField + Sync), points: &[(f64, DVec3)], nn: usize) -> Vec<Vec<f64>> {
    points
        .par_iter()
        .map(|(_, q)| {
            let mut out = vec![0.0; nn];
            f.eval(*q, &mut out);
            out
        })
        .collect()
}
