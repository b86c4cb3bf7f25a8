//! Cone angle by distance: for each probe radius, which α minimises the mean `occ_rel_l2` of the
//! extrapolation against the converged truth, how much better is it than the papers' 45°, and
//! does the closed-form law of a centred sphere (docs/math.md §7,
//! `shscale_field::alpha::cap_matching_alpha`) predict it?
//!
//! Per run: the BSV, the probe directions and the truth of the `probe` kind (shared machinery,
//! `shscale_field::probe::probe_base`), then for every radius every α on a grid of
//! `alpha_step_deg` over (0°, 90°), each with the **exact** `M_k(α)` (no k-table: the table's
//! interpolation error would blur the α dependence). The BSV at each probe direction and the
//! truth are rotated once into the probe's local frame, so each α costs one sparse
//! matrix–vector product per probe. The law's α uses the BSV's effective cap
//! (`shscale_field::alpha::effective_cap_angle`), which is exact for the analytic sphere.

use crate::probe::{Probe, ProbeParams};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use shscale_field::alpha::{cap_matching_alpha, effective_cap_angle};
use shscale_field::metrics::{l2, occ_rel_l2, occlusion};
use shscale_field::probe::{probe_base, ProbeBase};
use shscale_field::LocalFrame;
use shscale_present::plots::{write_both, Labels};
use shscale_runner::check::Ends;
use shscale_runner::records::{list, Results};
use shscale_runner::{Cost, Ctx, KeyError, Kind, Typed};
use shscale_scaling::{Eta, ScalingMatrix, TauFamily};
use shscale_scene::Error;
use shscale_sh::EulerRotator;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Parameters of one run (every one sweepable); the shared ones mean what they mean in `probe`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    pub mesh: String,
    pub order: usize,
    pub layout: String,
    pub hemisphere_res: usize,
    pub sampling_radius: f64,
    pub probe_dirs: String,
    pub probe_seed: u64,
    pub truth_res: usize,
    pub truth_seed: u64,
    /// Grid step of α, degrees: α = step, 2·step, … below 90°.
    pub alpha_step_deg: f64,
    #[serde(with = "list")]
    pub radii: Vec<f64>,
}

impl Default for Params {
    fn default() -> Self {
        let p = ProbeParams::default();
        Self {
            mesh: "sphere".into(),
            order: 4,
            layout: p.layout,
            hemisphere_res: p.hemisphere_res,
            sampling_radius: 1.0,
            probe_dirs: p.probe_dirs,
            probe_seed: p.probe_seed,
            truth_res: p.truth_res,
            truth_seed: p.truth_seed,
            alpha_step_deg: 0.5,
            radii: vec![1.1, 1.3, 1.6, 2.0, 3.0, 5.0],
        }
    }
}

impl Params {
    /// The `probe` parameters these stand for (α and the k-table unused).
    fn probe(&self) -> ProbeParams {
        ProbeParams {
            mesh: self.mesh.clone(),
            order: self.order,
            layout: self.layout.clone(),
            hemisphere_res: self.hemisphere_res,
            sampling_radius: self.sampling_radius,
            probe_dirs: self.probe_dirs.clone(),
            probe_seed: self.probe_seed,
            truth_res: self.truth_res,
            truth_seed: self.truth_seed,
            radii: self.radii.clone(),
            ..ProbeParams::default()
        }
    }
}

/// One row per run and radius.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    /// Probe radius in bounding radii, and k = radius / sampling_radius.
    pub radius: f64,
    pub k: f64,
    /// Probes with an occluded truth outside the entity (the mean runs over these).
    pub probes: usize,
    pub truth_rel_err_mean: Option<f64>,
    pub best_alpha_deg: Option<f64>,
    pub occ_rel_l2_best: Option<f64>,
    pub occ_rel_l2_45: Option<f64>,
    /// The centred-sphere law at the BSV's effective cap, its α and its error.
    pub effective_cap_deg: f64,
    pub law_alpha_deg: Option<f64>,
    pub occ_rel_l2_law: Option<f64>,
}

/// The kind.
pub struct AlphaFit;

/// The finest α grid step.
pub(crate) const MIN_ALPHA_STEP_DEG: f64 = 0.01;

/// Per probe, in its local frame: the BSV at its direction and the truth.
struct Local {
    input: Vec<f64>,
    truth: Vec<f64>,
}

fn locals(base: &ProbeBase, ri: usize, rho: f64, order: usize) -> Vec<Local> {
    let rot = EulerRotator::<f64>::new(order).expect("valid order");
    let s = base.bsv.sphere;
    let nn = order * order;
    base.dirs
        .iter()
        .zip(&base.truth[ri])
        .zip(&base.interpolated)
        .filter_map(|((d, t), e)| {
            // Probes outside the entity whose truth has something occluded.
            let t = t.as_ref()?;
            if l2(&occlusion(&t.coeffs)) <= 1e-12 {
                return None;
            }
            let p: DVec3 = s.center + rho * s.radius * *d;
            let r = LocalFrame::toward(p, s.center).matrix();
            let rt = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]));
            let (mut input, mut truth) = (vec![0.0; nn], vec![0.0; nn]);
            rot.apply(&rt, e, &mut input).expect("lengths agree");
            rot.apply(&rt, &t.coeffs, &mut truth)
                .expect("lengths agree");
            Some(Local { input, truth })
        })
        .collect()
}

/// Mean `occ_rel_l2` over the probes with the exact `M_k(α)`.
fn mean_error(l: &[Local], order: usize, k: f64, alpha: f64) -> Option<f64> {
    let m = TauFamily::Cone { alpha }
        .at(k)
        .and_then(|t| ScalingMatrix::compute(t.as_ref(), Eta::Plain, order))
        .ok()?;
    let mut out = vec![0.0; order * order];
    let v: Vec<f64> = l
        .iter()
        .filter_map(|x| {
            m.apply_unchecked(&x.input, &mut out);
            occ_rel_l2(&out, &x.truth)
        })
        .collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

impl Kind for AlphaFit {
    const NAME: &'static str = "alpha_fit";
    const QUESTION: &'static str = "Which cone angle α makes extrapolation most accurate at each distance, how much does it gain over the papers' 45°, and does the closed-form law of a centred sphere (α = ½ arccos(1/k) when sampled on its surface) predict it?";
    type Params = Params;
    type Shared = ();
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, shscale_field::probe::ProbeSpec>;

    fn inputs(
        p: &Self::Params,
        _config_dir: &std::path::Path,
    ) -> Result<Vec<shscale_runner::inputs::Input>, KeyError> {
        crate::common::mesh_inputs(&p.mesh)
    }

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("mesh", "the occluder, as in `probe`"),
            ("order", "SH order N, 1..=16"),
            ("layout", "base-sphere sample layout, as in `probe`"),
            ("hemisphere_res", "H of the BSV, 1..=256"),
            (
                "sampling_radius",
                "sampling sphere radius in bounding radii, [1, 1000]",
            ),
            ("probe_dirs", "`random` or `samples`, as in `probe`"),
            ("probe_seed", "seed of the random probe directions"),
            (
                "truth_res",
                "resolution T of the converged truth (4T² rays per probe), 1..=1024",
            ),
            ("truth_seed", "seed of the truth's rotations and jitter"),
            (
                "alpha_step_deg",
                "grid step of α in degrees, [0.01, 10]: α = step, 2·step, … < 90°",
            ),
            ("radii", "probe radii in bounding radii, as in `probe`"),
        ]
    }

    fn resolve(p: &Params) -> Result<Self::Spec, KeyError> {
        let probe = <Probe as Kind>::resolve(&p.probe())?;
        let step = p.alpha_step_deg;
        KeyError::real(
            "alpha_step_deg",
            step,
            MIN_ALPHA_STEP_DEG,
            10.0,
            Ends::Closed,
        )?;
        Ok(Typed {
            params: p.clone(),
            typed: probe.typed,
        })
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        let probe = Typed {
            params: p.probe(),
            typed: p.typed.clone(),
        };
        let (shared, mut run) = <Probe as Kind>::cost(&probe);
        let steps = (90.0 / p.alpha_step_deg).ceil();
        // Nothing is timed: the probe's work once, then one exact matrix per α and radius.
        run.once_seconds = steps * p.radii.len() as f64 * crate::common::matrix_seconds(p.order);
        run.drivers = format!("{steps} α values × {} radii", p.radii.len());
        (
            Cost::default(),
            Cost {
                cached_once: None,
                rays: shared.rays,
                bytes: shared.bytes,
                seconds: 0.0,
                once_seconds: shared.seconds + shared.once_seconds + run.once_seconds,
                drivers: format!("{}; {}", shared.drivers, run.drivers),
            },
        )
    }

    fn rows_per_run(p: &Params) -> usize {
        p.radii.len()
    }

    fn shared(_: &Self::Spec, _: &Ctx) -> Result<(), Error> {
        Ok(())
    }

    fn run(p: &Self::Spec, _: &str, _: &(), _: &Ctx) -> Result<Vec<Row>, Error> {
        let spec = &p.typed;
        let u = shscale_scene::vocab::unit_occluder(&p.mesh)?;
        let base = probe_base(u.occ.as_ref(), u.analytic, spec)?;
        let theta0 = effective_cap_angle(&base.bsv);
        let steps = ((90.0 / p.alpha_step_deg).ceil() as usize).saturating_sub(1);
        let grid: Vec<f64> = (1..=steps)
            .map(|i| i as f64 * p.alpha_step_deg)
            .filter(|a| *a < 90.0)
            .collect();
        let mut rows = Vec::new();
        for (ri, &rho) in p.radii.iter().enumerate() {
            let k = rho / p.sampling_radius;
            let l = locals(&base, ri, rho, p.order);
            let errs: Vec<(f64, Option<f64>)> = grid
                .par_iter()
                .map(|&a| (a, mean_error(&l, p.order, k, a.to_radians())))
                .collect();
            let best = errs
                .iter()
                .filter_map(|(a, e)| e.map(|e| (*a, e)))
                .min_by(|x, y| x.1.total_cmp(&y.1));
            let law = cap_matching_alpha(theta0, k);
            let truth_errs: Vec<f64> = base.truth[ri]
                .iter()
                .flatten()
                .filter_map(|t| t.rel_error())
                .collect();
            rows.push(Row {
                radius: rho,
                k,
                probes: l.len(),
                truth_rel_err_mean: (!truth_errs.is_empty())
                    .then(|| truth_errs.iter().sum::<f64>() / truth_errs.len() as f64),
                best_alpha_deg: best.map(|b| b.0),
                occ_rel_l2_best: best.map(|b| b.1),
                occ_rel_l2_45: mean_error(&l, p.order, k, 45f64.to_radians()),
                effective_cap_deg: theta0.to_degrees(),
                law_alpha_deg: law.map(f64::to_degrees),
                occ_rel_l2_law: law.and_then(|a| mean_error(&l, p.order, k, a)),
            });
        }
        Ok(rows)
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "radius",
            "best_alpha_deg",
            "law_alpha_deg",
            "occ_rel_l2_best",
            "occ_rel_l2_45",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        // Best α against radius per mesh and order, with the law.
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for r in 0..t.rows.len() {
            let name = format!("{} N={}", t.cell(r, "mesh"), t.cell(r, "order"));
            let (x, y, law) = (
                t.num(r, "radius"),
                t.num(r, "best_alpha_deg"),
                t.num(r, "law_alpha_deg"),
            );
            for (label, v) in [(name.clone(), y), (format!("{name} law"), law)] {
                if !v.is_finite() {
                    continue;
                }
                series.entry(label).or_default().push((x, v));
            }
        }
        if series.is_empty() {
            return Ok(Vec::new());
        }
        Ok(write_both(
            dir,
            "best_alpha",
            &Labels {
                title: "best cone angle by distance",
                x: "probe radius (× r)",
                y: "α (degrees)",
            },
            &series,
            false,
            &[],
        )?)
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        let f = |v: f64| {
            if v.is_finite() {
                format!("{v:.3}")
            } else {
                "—".into()
            }
        };
        let mut s = String::from(
            "| mesh | N | radius (× r) | best α | law α | occ_rel_l2 best | at law α | at 45° | truth error |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        let (mut gain_n, mut gain_sum) = (0usize, 0.0);
        for r in 0..t.rows.len() {
            let (b, f45) = (t.num(r, "occ_rel_l2_best"), t.num(r, "occ_rel_l2_45"));
            if b.is_finite() && f45.is_finite() && b > 0.0 {
                gain_n += 1;
                gain_sum += f45 / b;
            }
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                t.cell(r, "mesh"),
                t.cell(r, "order"),
                t.cell(r, "radius"),
                f(t.num(r, "best_alpha_deg")),
                f(t.num(r, "law_alpha_deg")),
                f(b),
                f(t.num(r, "occ_rel_l2_law")),
                f(f45),
                f(t.num(r, "truth_rel_err_mean")),
            ));
        }
        if gain_n > 0 {
            s.push_str(&format!(
                "\nThe best α lowers the mean occ_rel_l2 by {:.2}× on average over these {gain_n} rows against α = 45°.\n",
                gain_sum / gain_n as f64
            ));
        }
        Ok(s)
    }
}
