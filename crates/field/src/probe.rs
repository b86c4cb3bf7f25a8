//! The probe experiment (SHS Fig. 5 / TR Fig. 1): for every base-sphere sample direction u, put a
//! probe at `c + ρ·r·u` for each radius factor ρ (default 0.5, 0.7, 0.9, 1.3, 2), compare the
//! extrapolated visibility with the band-limited truth, and summarise per radius — overall and for
//! the on-surface samples (docs/conventions.md §7) separately.
//!
//! Truth: ray traced over the full sphere (`2H²` rays), or, for the analytic sphere, the
//! closed-form cap `√(4π)e₀ − cap(asin(R/d))` about the direction to the centre (exact up to
//! nothing). Probes inside a solid (the truth sees nothing: `c₀ ≤ 1e-9`) are excluded and counted
//! (`inside_count`); probes that see nothing occluded have no `occ_rel_l2` and are counted too.

use crate::bsv::{Bsv, Layout};
use crate::extrapolate::{ExtrapolationKind, Extrapolator};
use crate::metrics::{mean_max, occ_rel_l2, vis_rel_l2};
use crate::visibility::{Frame, VisibilitySampler};
use crate::FieldError;
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::{Occluder, Sphere};
use shscale_scaling::{Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily};
use shscale_sh::{cap_zonal, rotate_zonal, ShBasis};
use std::time::Instant;

/// Parameters of a probe run.
#[derive(Clone, Debug)]
pub struct ProbeSpec {
    pub order: usize,
    /// Cone half-angle α in radians.
    pub alpha: f64,
    pub layout: Layout,
    pub hemisphere_res: usize,
    /// Sampling sphere radius factor `s ≥ 1`.
    pub sampling_radius: f64,
    /// Probe radii as multiples of the bounding radius r.
    pub radii: Vec<f64>,
    pub k_count: usize,
    /// Placement of the K tabulated k values and interpolation between them.
    pub k_spacing: Spacing,
    pub k_interp: Interp,
    /// On-surface threshold ε (distance < ε·r).
    pub on_surface_eps: f64,
}

/// Summary of one probe radius.
#[derive(Clone, Debug, Default)]
pub struct ProbeRow {
    pub radius: f64,
    pub k: f64,
    pub probes: usize,
    pub inside_count: usize,
    pub unoccluded_truth_count: usize,
    pub clamped_count: usize,
    pub vis_rel_l2_mean: Option<f64>,
    pub vis_rel_l2_max: Option<f64>,
    pub occ_rel_l2_mean: Option<f64>,
    pub occ_rel_l2_max: Option<f64>,
    pub on_surface_count: usize,
    pub vis_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_max: Option<f64>,
    pub extrapolation_seconds: f64,
    pub truth_seconds: f64,
}

/// Result of a probe run.
#[derive(Clone, Debug)]
pub struct ProbeResult {
    pub rows: Vec<ProbeRow>,
    /// Per radius, one probe for images (the papers' Fig. 5): one sample direction for all radii,
    /// the most occluded one at the first radius.
    pub examples: Vec<ProbeExample>,
    pub samples: usize,
    pub on_surface_samples: usize,
    pub bsv_rays: usize,
    pub k_min: f64,
    pub k_max: f64,
    pub bsv_sampling_seconds: f64,
    pub table_build_seconds: f64,
}

/// One probe point kept for images: its position and the extrapolated SH visibility.
#[derive(Clone, Debug)]
pub struct ProbeExample {
    pub radius: f64,
    pub point: DVec3,
    pub extrapolated: Vec<f64>,
}

/// Closed-form visibility of a solid sphere seen from `p` (entity frame), `None` inside it.
pub fn sphere_truth(basis: &ShBasis<f64>, s: &Sphere, p: DVec3) -> Option<Vec<f64>> {
    let d = (s.center - p).length();
    if d <= s.radius {
        return None;
    }
    let n = basis.order();
    let cap = cap_zonal(n, (s.radius / d).asin()).ok()?;
    let mut v = vec![0.0; n * n];
    rotate_zonal(basis, &cap, ((s.center - p) / d).to_array(), &mut v).ok()?;
    v.iter_mut().for_each(|x| *x = -*x);
    v[0] += (4.0 * std::f64::consts::PI).sqrt();
    Some(v)
}

/// The part of a probe run that depends only on the occluder and its sampling — not on α or K:
/// the BSV and the truth at every probe point (one entry per radius and base-sphere sample;
/// `None` inside the entity). Runs that differ only in α or K share one ([`probe_with`]).
pub struct ProbeBase {
    pub bsv: Bsv,
    /// `truth[radius][sample]`, entity frame.
    pub truth: Vec<Vec<Option<Vec<f64>>>>,
    pub truth_seconds: Vec<f64>,
    pub bsv_sampling_seconds: f64,
    /// The sharing key: order, layout, H, sampling radius, ε and radii of the spec it was built for.
    pub key: String,
}

/// The fields of a spec a [`ProbeBase`] depends on, as a key.
pub fn base_key(spec: &ProbeSpec) -> String {
    format!(
        "order={};layout={};h={};s={};eps={};radii={:?}",
        spec.order,
        spec.layout.name(),
        spec.hemisphere_res,
        spec.sampling_radius,
        spec.on_surface_eps,
        spec.radii
    )
}

/// The k range a k-table needs for probe radii `radii` (× r) sampled at radius `s` (× r):
/// `[min ρ/s, max ρ/s]`, widened ×2 both ways when it is a single value. The one definition,
/// used by probes, the runner and the figures.
pub fn k_range(radii: &[f64], sampling_radius: f64) -> (f64, f64) {
    let (mut lo, mut hi) = radii
        .iter()
        .map(|r| r / sampling_radius)
        .fold((f64::MAX, f64::MIN), |(a, b), k| (a.min(k), b.max(k)));
    if hi / lo < 1.0 + 1e-9 {
        lo /= 2.0;
        hi *= 2.0;
    }
    (lo, hi)
}

fn check_radii(spec: &ProbeSpec) -> Result<(), FieldError> {
    if spec.radii.is_empty() || spec.radii.iter().any(|r| !(r.is_finite() && *r > 0.0)) {
        return Err(FieldError::Spec(format!(
            "radii {:?} must be finite and > 0",
            spec.radii
        )));
    }
    Ok(())
}

/// Sample the BSV of `occ` and compute the truth at every probe point (`analytic`: closed-form
/// truth of a solid sphere; otherwise ray-traced, `2H²` rays, projected to order N).
pub fn probe_base(
    occ: &dyn Occluder,
    analytic: Option<Sphere>,
    spec: &ProbeSpec,
) -> Result<ProbeBase, FieldError> {
    check_radii(spec)?;
    let t0 = Instant::now();
    let bsv = sample_bsv(occ, spec)?;
    let bsv_sampling_seconds = t0.elapsed().as_secs_f64();
    probe_base_on(bsv, bsv_sampling_seconds, occ, analytic, spec)
}

/// The BSV of a probe spec (what [`probe_base`] samples first).
pub fn sample_bsv(occ: &dyn Occluder, spec: &ProbeSpec) -> Result<Bsv, FieldError> {
    let sampler = VisibilitySampler::new(spec.order, spec.hemisphere_res)?;
    Bsv::sample(
        occ,
        spec.layout,
        &sampler,
        spec.sampling_radius,
        spec.on_surface_eps,
    )
}

/// [`probe_base`] on a BSV sampled (and timed) by the caller: the truth at every probe point.
pub fn probe_base_on(
    bsv: Bsv,
    bsv_sampling_seconds: f64,
    occ: &dyn Occluder,
    analytic: Option<Sphere>,
    spec: &ProbeSpec,
) -> Result<ProbeBase, FieldError> {
    check_radii(spec)?;
    let sampler = VisibilitySampler::new(spec.order, spec.hemisphere_res)?;
    let basis = ShBasis::<f64>::new(spec.order)?;
    let s = bsv.sphere;
    let (mut truth, mut truth_seconds) = (Vec::new(), Vec::new());
    for &rho in &spec.radii {
        let t = Instant::now();
        let per: Vec<Option<Vec<f64>>> = bsv
            .samples
            .par_iter()
            .map(|smp| {
                let p = s.center + rho * s.radius * smp.dir;
                match analytic {
                    Some(sph) => sphere_truth(&basis, &sph, p),
                    None => {
                        let (v, _) = sampler.full_sphere(occ, p, Frame::Entity);
                        (v[0] > 1e-9).then_some(v)
                    }
                }
            })
            .collect();
        truth.push(per);
        truth_seconds.push(t.elapsed().as_secs_f64());
    }
    Ok(ProbeBase {
        bsv,
        truth,
        truth_seconds,
        bsv_sampling_seconds,
        key: base_key(spec),
    })
}

/// Run the probe experiment on `occ`; `analytic` selects the closed-form truth of a solid sphere.
pub fn probe(
    occ: &dyn Occluder,
    analytic: Option<Sphere>,
    spec: &ProbeSpec,
) -> Result<ProbeResult, FieldError> {
    probe_with(&probe_base(occ, analytic, spec)?, spec)
}

/// The α- and K-dependent part of a probe run on a shared [`ProbeBase`] (built for a spec with the
/// same [`base_key`]; otherwise an error).
pub fn probe_with(base: &ProbeBase, spec: &ProbeSpec) -> Result<ProbeResult, FieldError> {
    if base.key != base_key(spec) {
        return Err(FieldError::Spec(format!(
            "probe base built for {} used for {}",
            base.key,
            base_key(spec)
        )));
    }
    let bsv = &base.bsv;
    let bsv_sampling_seconds = base.bsv_sampling_seconds;
    let ks: Vec<f64> = spec
        .radii
        .iter()
        .map(|r| r / spec.sampling_radius)
        .collect();
    let (k_min, k_max) = k_range(&spec.radii, spec.sampling_radius);
    let t1 = Instant::now();
    let table = KTable::build(
        TauFamily::Cone { alpha: spec.alpha },
        Eta::Plain,
        spec.order,
        spec.k_count,
        k_min,
        k_max,
        spec.k_spacing,
        spec.k_interp,
    )
    .map_err(|e| FieldError::Spec(e.to_string()))?;
    let table_build_seconds = t1.elapsed().as_secs_f64();
    let ex = Extrapolator::new(bsv, &table);
    let s = bsv.sphere;
    let nn = spec.order * spec.order;
    let mut rows = Vec::new();
    let mut examples = Vec::new();
    let mut example_index: Option<usize> = None;
    for (ri, (&rho, &k)) in spec.radii.iter().zip(&ks).enumerate() {
        let points: Vec<(DVec3, bool)> = bsv
            .samples
            .iter()
            .map(|smp| (s.center + rho * s.radius * smp.dir, smp.on_surface))
            .collect();
        let t2 = Instant::now();
        let ext: Vec<(Vec<f64>, ExtrapolationKind)> = points
            .par_iter()
            .map_init(
                || ScalingMatrix::identity(spec.order).expect("valid order"),
                |m, (p, _)| {
                    let mut out = vec![0.0; nn];
                    let kind = ex.eval(*p, m, &mut out);
                    (out, kind)
                },
            )
            .collect();
        let extrapolation_seconds = t2.elapsed().as_secs_f64();
        let truth = &base.truth[ri];
        let truth_seconds = base.truth_seconds[ri];
        let mut row = ProbeRow {
            radius: rho,
            k,
            probes: points.len(),
            extrapolation_seconds,
            truth_seconds,
            ..Default::default()
        };
        // The example direction (the papers' Fig. 5 shows one direction at every radius): the
        // sample whose truth is most occluded at the first radius (smallest visible integral
        // v₀), kept for the other radii wherever the truth exists there.
        if example_index.is_none() {
            example_index = truth
                .iter()
                .zip(&ext)
                .enumerate()
                .filter_map(|(i, (t, (e, _)))| {
                    let t = t.as_ref()?;
                    occ_rel_l2(e, t).map(|_| (i, t[0]))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(i, _)| i);
        }
        if let Some(i) = example_index.filter(|&i| truth[i].is_some()) {
            examples.push(ProbeExample {
                radius: rho,
                point: points[i].0,
                extrapolated: ext[i].0.clone(),
            });
        }
        let mut per: Vec<(bool, Option<f64>, Option<f64>)> = Vec::new();
        for ((e, kind), (t, (_, on))) in ext.iter().zip(truth.iter().zip(&points)) {
            if *kind == ExtrapolationKind::ClampedBelow {
                row.clamped_count += 1;
            }
            let Some(t) = t else {
                row.inside_count += 1;
                continue;
            };
            let occ = occ_rel_l2(e, t);
            if occ.is_none() {
                row.unoccluded_truth_count += 1;
            }
            per.push((*on, vis_rel_l2(e, t), occ));
        }
        (row.vis_rel_l2_mean, row.vis_rel_l2_max, _) = mean_max(per.iter().map(|x| x.1));
        (row.occ_rel_l2_mean, row.occ_rel_l2_max, _) = mean_max(per.iter().map(|x| x.2));
        row.on_surface_count = per.iter().filter(|x| x.0).count();
        (row.vis_rel_l2_on_surface_mean, _, _) = mean_max(per.iter().filter(|x| x.0).map(|x| x.1));
        (
            row.occ_rel_l2_on_surface_mean,
            row.occ_rel_l2_on_surface_max,
            _,
        ) = mean_max(per.iter().filter(|x| x.0).map(|x| x.2));
        rows.push(row);
    }
    Ok(ProbeResult {
        rows,
        examples,
        samples: bsv.samples.len(),
        on_surface_samples: bsv.on_surface_count(),
        bsv_rays: bsv.rays,
        k_min,
        k_max,
        bsv_sampling_seconds,
        table_build_seconds,
    })
}
