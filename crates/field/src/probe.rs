//! The probe experiment (SHS Fig. 5 / TR Fig. 1): for every probe direction u — by default as many
//! seeded uniform directions as base-sphere samples, so that they fall between the samples; or
//! the sample directions themselves, the papers' design — put a probe at `c + ρ·r·u` for each
//! radius factor ρ (default 0.5, 0.7, 0.9, 1.3, 2), compare the extrapolated visibility with the
//! band-limited truth, and summarise per radius: overall, on-surface and contact samples
//! (docs/conventions.md §7) separately, the truth's own error, the physical plausibility of the
//! extrapolation, and an error decomposition (each component replaced by its exact counterpart
//! in turn: the k-table, the BSV interpolation, the BSV's sampling resolution; what remains is
//! the cone model; the band-limiting of the truth is reported beside them).
//!
//! Truth: the converged ray-traced truth of [`TruthSampler`] (its own resolution, never the
//! method's H; `4T²` rays, with an error estimate), or, for the analytic sphere, the closed-form
//! cap `√(4π)e₀ − cap(asin(R/d))` about the direction to the centre (exact). Probes inside a solid
//! (no truth ray escapes) are excluded and counted (`inside_count`); probes that see nothing
//! occluded have no `occ_rel_l2` and are counted too.

use crate::bsv::{Bsv, Layout};
use crate::error::FieldError;
use crate::extrapolate::{
    bounding_cone, scale_to_with, Clamp, ExtrapolationKind, Extrapolator, Plausibility,
};
use crate::metrics::{facing_occlusion, mean_max, occ_rel_l2, occlusion, vis_rel_l2};
use crate::truth::{SplitMix, Truth, TruthSampler, DEFAULT_TRUTH_RES, DEFAULT_TRUTH_SEED};
use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::{Occluder, Sphere};
use shscale_scaling::{Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily};
use shscale_sh::{cap_zonal, rotate_zonal, EulerRotator, ShBasis};
use std::time::Instant;

/// Where the probes sit, as directions from the centre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeDirs {
    /// Exactly on the base-sphere sample directions (the papers' design: the BSV's interpolation
    /// is never exercised).
    Samples,
    /// As many directions as samples, uniform on the sphere from a seeded generator: between the
    /// samples, so the interpolation of the BSV is part of what is measured.
    Random { seed: u64 },
}

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
    /// The k-table's range; `None`: [`k_range`] of the radii (the range the probes need, widened
    /// by [`K_MARGIN`] so that no probe radius sits on an end node).
    pub k_min: Option<f64>,
    pub k_max: Option<f64>,
    /// On-surface threshold ε (distance < ε·r).
    pub on_surface_eps: f64,
    /// Contact threshold: a probe direction whose BSV occludes at least this fraction of the
    /// facing hemisphere is a contact sample (docs/conventions.md §7).
    pub contact_occlusion: f64,
    pub probe_dirs: ProbeDirs,
    /// Resolution T of the converged truth ([`TruthSampler`], `4T²` rays per probe) and its seed.
    pub truth_res: usize,
    pub truth_seed: u64,
    /// The plausibility mitigation of the extrapolation (and of the decomposition's columns).
    pub plausibility: Plausibility,
    /// α by distance instead of the fixed `alpha`: the cone-angle law at the BSV's effective cap
    /// ([`TauFamily::ConeFit`], [`crate::alpha::effective_cap_angle`]; docs/math.md §7).
    pub alpha_fit: bool,
}

/// The default contact threshold (docs/conventions.md §7, calibrated on the bundled meshes).
pub const DEFAULT_CONTACT_OCCLUSION: f64 = 0.4;

/// The probe radii (× the bounding radius) of the papers' Fig. 5: the default of every probe
/// (`shscale probe`, the `probe` kind, the Python `probe`).
pub const DEFAULT_RADII: [f64; 5] = [0.5, 0.7, 0.9, 1.3, 2.0];

impl Default for ProbeSpec {
    /// The documented defaults (those of the `probe` kind).
    fn default() -> Self {
        Self {
            order: 4,
            alpha: std::f64::consts::FRAC_PI_4,
            layout: Layout::LatLong { rows: 12, cols: 20 },
            hemisphere_res: 32,
            sampling_radius: 1.0,
            radii: DEFAULT_RADII.to_vec(),
            k_count: 40,
            k_spacing: Spacing::Exp,
            k_interp: Interp::Linear,
            k_min: None,
            k_max: None,
            on_surface_eps: 1e-3,
            contact_occlusion: DEFAULT_CONTACT_OCCLUSION,
            probe_dirs: ProbeDirs::Random { seed: 1 },
            truth_res: DEFAULT_TRUTH_RES,
            truth_seed: DEFAULT_TRUTH_SEED,
            plausibility: Plausibility::None,
            alpha_fit: false,
        }
    }
}

/// Summary of one probe radius (metric names of docs/conventions.md §6). Means and maxima are
/// over the probes with a truth (outside the solid) and an occluded truth.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ProbeRow {
    pub radius: f64,
    pub k: f64,
    /// Distance of k from the nearest table node in node spacings (in ln k for exp spacing),
    /// 0 = on a node, 0.5 = midway.
    pub k_node_offset: f64,
    /// The cone angle used at this k (degrees): `alpha`, or the law's α(k) with `alpha_fit`.
    pub alpha_used_deg: f64,
    pub probes: usize,
    pub inside_count: usize,
    pub unoccluded_truth_count: usize,
    pub clamped_count: usize,
    pub vis_rel_l2_mean: Option<f64>,
    pub vis_rel_l2_max: Option<f64>,
    pub occ_rel_l2_mean: Option<f64>,
    pub occ_rel_l2_max: Option<f64>,
    /// Quantiles of `occ_rel_l2` over the probes with a truth (p5, p25, median, p75, p95;
    /// linear rule, `metrics::quantiles`).
    pub occ_rel_l2_p05: Option<f64>,
    pub occ_rel_l2_p25: Option<f64>,
    pub occ_rel_l2_p50: Option<f64>,
    pub occ_rel_l2_p75: Option<f64>,
    pub occ_rel_l2_p95: Option<f64>,
    /// The truth's own error relative to its occlusion ([`Truth::rel_error`]); 0 for the
    /// closed-form sphere.
    pub truth_rel_err_mean: Option<f64>,
    pub truth_rel_err_max: Option<f64>,
    /// Probes whose `occ_rel_l2` is within 3× the truth's own error (not resolved by the truth).
    pub truth_limited_count: usize,
    /// Error decomposition, each replacing one more component by its exact counterpart:
    /// the k-table by the exact `M_k` …
    pub occ_rel_l2_exact_k_mean: Option<f64>,
    /// … and the interpolated BSV by the BSV sampled at the probe's own direction (same H) …
    pub occ_rel_l2_exact_dir_mean: Option<f64>,
    /// … and that sample by the converged truth quadrature at the same point: what remains is
    /// the cone model (and the band-limiting of its input).
    pub occ_rel_l2_model_mean: Option<f64>,
    /// The band-limiting error of the truth itself, `‖occ − P_N occ‖ / ‖occ‖ =
    /// √(1 − ‖P_N occ‖² / Ω_occ)` (occlusion is an indicator, so `‖occ‖² = Ω_occ`).
    pub band_limit_rel_mean: Option<f64>,
    /// Probes whose extrapolated occluded solid angle `Ω = 4π − √(4π) c₀` is negative or exceeds
    /// what the bounding sphere can cover from there (`2π(1 − √(1 − 1/ρ²))` for ρ ≥ 1, 4π inside).
    pub implausible_count: usize,
    pub occ_solid_angle_min: Option<f64>,
    pub occ_solid_angle_max: Option<f64>,
    pub on_surface_count: usize,
    pub vis_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_max: Option<f64>,
    /// Probes in contact directions (the BSV there occludes ≥ `contact_occlusion` of the facing
    /// hemisphere) and their errors.
    pub contact_count: usize,
    pub occ_rel_l2_contact_mean: Option<f64>,
    pub occ_rel_l2_contact_max: Option<f64>,
    pub extrapolation_seconds: f64,
    pub truth_seconds: f64,
}

/// Result of a probe run.
#[derive(Clone, Debug)]
pub struct ProbeResult {
    pub rows: Vec<ProbeRow>,
    /// Per radius, one probe for images (the papers' Fig. 5): one probe direction for all radii,
    /// the most occluded one at the first radius.
    pub examples: Vec<ProbeExample>,
    pub samples: usize,
    pub on_surface_samples: usize,
    pub contact_samples: usize,
    /// The BSV's effective cap θ₀ (degrees, [`crate::alpha::effective_cap_angle`]).
    pub effective_cap_deg: f64,
    pub bsv_rays: usize,
    pub truth_rays_per_probe: usize,
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
    /// The point lies inside the occluder at this radius (no truth: its visibility is 0 in
    /// every direction).
    pub inside: bool,
}

/// Closed-form visibility of a solid sphere of radius R seen from `p` at distance d (entity
/// frame): 1 minus the cap of half-angle `asin(min(1, R/d))` about the direction to the centre.
/// On the surface (`d ≥ R(1 − 1e-9)`, within round-off of it) that is the tangent-plane
/// hemisphere; `None` strictly inside.
pub fn sphere_truth(basis: &ShBasis<f64>, s: &Sphere, p: DVec3) -> Option<Vec<f64>> {
    let d = (s.center - p).length();
    if d < s.radius * (1.0 - 1e-9) || d == 0.0 {
        return None;
    }
    let n = basis.order();
    let cap = cap_zonal(n, (s.radius / d).min(1.0).asin()).ok()?;
    let mut v = vec![0.0; n * n];
    rotate_zonal(basis, &cap, ((s.center - p) / d).to_array(), &mut v).ok()?;
    v.iter_mut().for_each(|x| *x = -*x);
    v[0] += (4.0 * std::f64::consts::PI).sqrt();
    Some(v)
}

/// The part of a probe run that depends only on the occluder and its sampling — not on α or K:
/// the BSV, the probe directions, the truth at every probe point (`None` inside the entity),
/// and the exact inputs of the error decomposition. Runs that differ only in α or the k-table
/// share one ([`probe_with`]).
pub struct ProbeBase {
    pub bsv: Bsv,
    /// Probe directions from the centre.
    pub dirs: Vec<DVec3>,
    /// `truth[radius][probe]`, entity frame.
    pub truth: Vec<Vec<Option<Truth>>>,
    pub truth_seconds: Vec<f64>,
    /// The BSV sampled at each probe direction with the method's H (the samples themselves when
    /// the probes sit on them).
    pub direct: Vec<Vec<f64>>,
    /// The visibility at each probe direction on the sampling sphere by the converged truth.
    pub converged: Vec<Vec<f64>>,
    /// The BSV interpolated at each probe direction (the extrapolation's input there).
    pub interpolated: Vec<Vec<f64>>,
    /// Per probe direction: on-surface (its nearest sample is), and the occluded fraction of the
    /// facing hemisphere of the interpolated BSV (contact when ≥ `contact_occlusion`).
    pub on_surface: Vec<bool>,
    pub facing_occlusion: Vec<f64>,
    pub truth_rays_per_probe: usize,
    pub bsv_sampling_seconds: f64,
    /// The sharing key ([`base_key`]).
    pub key: String,
}

/// The fields of a spec a [`ProbeBase`] depends on, as a key.
pub fn base_key(spec: &ProbeSpec) -> String {
    format!(
        "order={};layout={};h={};s={};eps={};dirs={:?};truth={}/{};radii={:?}",
        spec.order,
        spec.layout.name(),
        spec.hemisphere_res,
        spec.sampling_radius,
        spec.on_surface_eps,
        spec.probe_dirs,
        spec.truth_res,
        spec.truth_seed,
        spec.radii
    )
}

/// How far [`k_range`] widens the probes' k range at each end (×1.25 up, ÷1.25 down).
pub const K_MARGIN: f64 = 1.25;

/// The k range from a sampling sphere (centre `center`, radius `sampling_radius`) to `points`:
/// `[min d/r_s, max d/r_s]` over the points' distances `d` from the centre, widened by
/// `margin ≥ 1` both ways (`(∞, 0)` for no points). For parts of an object (sub-volumes),
/// whose receivers are not at fixed radii.
pub fn k_range_to(
    center: DVec3,
    sampling_radius: f64,
    points: impl IntoIterator<Item = DVec3>,
    margin: f64,
) -> (f64, f64) {
    let (lo, hi) = (points.into_iter())
        .map(|q| (q - center).length() / sampling_radius)
        .fold((f64::INFINITY, 0.0f64), |(a, b), k| (a.min(k), b.max(k)));
    (lo / margin, hi * margin)
}

/// The k range a k-table needs for probe radii `radii` (× r) sampled at radius `s` (× r):
/// `[min ρ/s, max ρ/s]` widened by [`K_MARGIN`] both ways, so that the extreme probes fall
/// between table nodes rather than on the end nodes. The one definition, used by probes, the
/// runner and the figures.
pub fn k_range(radii: &[f64], sampling_radius: f64) -> (f64, f64) {
    let (lo, hi) = radii
        .iter()
        .map(|r| r / sampling_radius)
        .fold((f64::MAX, f64::MIN), |(a, b), k| (a.min(k), b.max(k)));
    (lo / K_MARGIN, hi * K_MARGIN)
}

/// The table range of a spec: its own `k_min`/`k_max` where given, else [`k_range`].
pub fn table_range(spec: &ProbeSpec) -> (f64, f64) {
    table_range_of(spec.k_min, spec.k_max, &spec.radii, spec.sampling_radius)
}

/// [`table_range`] from its parts.
pub fn table_range_of(
    k_min: Option<f64>,
    k_max: Option<f64>,
    radii: &[f64],
    sampling_radius: f64,
) -> (f64, f64) {
    let (lo, hi) = k_range(radii, sampling_radius);
    (k_min.unwrap_or(lo), k_max.unwrap_or(hi))
}

/// Distance of `k` from the nearest of the sorted nodes `ks`, in units of the local node spacing
/// (in ln k when `log`): 0 on a node, 0.5 midway; outside the nodes, the distance past the end
/// in units of the last spacing.
pub fn node_offset(ks: &[f64], k: f64, log: bool) -> f64 {
    let f = |x: f64| if log { x.ln() } else { x };
    let x = f(k);
    let i = ks.partition_point(|&n| f(n) <= x);
    let (a, b) = match i {
        0 => (0, 1),
        i if i >= ks.len() => (ks.len() - 2, ks.len() - 1),
        i => (i - 1, i),
    };
    let (xa, xb) = (f(ks[a]), f(ks[b]));
    let h = xb - xa;
    if h <= 0.0 {
        return 0.0;
    }
    (x - xa).abs().min((xb - x).abs()) / h
}

fn check_radii(spec: &ProbeSpec) -> Result<(), FieldError> {
    if spec.radii.is_empty() || spec.radii.iter().any(|r| !(r.is_finite() && *r > 0.0)) {
        return Err(FieldError::Spec(format!(
            "radii {:?} must be finite and > 0",
            spec.radii
        )));
    }
    if !(0.0..=1.0).contains(&spec.contact_occlusion) {
        return Err(FieldError::Spec(format!(
            "contact occlusion {} is outside [0, 1]",
            spec.contact_occlusion
        )));
    }
    Ok(())
}

/// Sample the BSV of `occ` and compute the truth at every probe point (`analytic`: closed-form
/// truth of a solid sphere; otherwise the converged ray-traced truth of [`TruthSampler`]).
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

/// The probe directions of a spec on its BSV: the sample directions, or as many seeded uniform
/// directions on the sphere.
pub fn probe_directions(spec: &ProbeSpec, bsv: &Bsv) -> Vec<DVec3> {
    match spec.probe_dirs {
        ProbeDirs::Samples => bsv.samples.iter().map(|s| s.dir).collect(),
        ProbeDirs::Random { seed } => random_directions(seed, bsv.samples.len()),
    }
}

/// `n` directions uniform on the sphere from the seeded generator (the `random` probes).
pub fn random_directions(seed: u64, n: usize) -> Vec<DVec3> {
    let mut rng = SplitMix(seed);
    (0..n).map(|_| rng.direction()).collect()
}

/// [`probe_base`] on a BSV sampled (and timed) by the caller: the truth at every probe point and
/// the exact inputs of the error decomposition.
pub fn probe_base_on(
    bsv: Bsv,
    bsv_sampling_seconds: f64,
    occ: &dyn Occluder,
    analytic: Option<Sphere>,
    spec: &ProbeSpec,
) -> Result<ProbeBase, FieldError> {
    check_radii(spec)?;
    let truth_sampler = TruthSampler::new(spec.order, spec.truth_res, spec.truth_seed)?;
    let basis = ShBasis::<f64>::new(spec.order)?;
    let s = bsv.sphere;
    let dirs = probe_directions(spec, &bsv);
    // Each truth draws from the seed and its own stream (radius index, probe index): the same
    // draw whatever the scene's scale, the thread or the order.
    let np = dirs.len() as u64;
    let exact_at = |p: DVec3, stream: u64| -> Option<Truth> {
        match analytic {
            Some(sph) => sphere_truth(&basis, &sph, p).map(Truth::exact),
            None => Some(truth_sampler.sample_stream(occ, p, stream)).filter(|t| t.escaped > 0),
        }
    };
    let (mut truth, mut truth_seconds) = (Vec::new(), Vec::new());
    for (ri, &rho) in spec.radii.iter().enumerate() {
        let t = Instant::now();
        let per: Vec<Option<Truth>> = dirs
            .par_iter()
            .enumerate()
            .map(|(i, d)| exact_at(s.center + rho * s.radius * *d, ri as u64 * np + i as u64))
            .collect();
        truth.push(per);
        truth_seconds.push(t.elapsed().as_secs_f64());
    }
    let on_sampling = |d: &DVec3| s.center + bsv.sampling_radius * *d;
    let direct = direct_visibility(&bsv, &dirs, occ, spec)?;
    let last = spec.radii.len() as u64 * np;
    let converged: Vec<Vec<f64>> = dirs
        .par_iter()
        .enumerate()
        .map(|(i, d)| {
            exact_at(on_sampling(d), last + i as u64)
                .map_or_else(|| vec![0.0; spec.order * spec.order], |t| t.coeffs)
        })
        .collect();
    let nn = spec.order * spec.order;
    let on_surface: Vec<bool> = dirs
        .iter()
        .map(|d| bsv.samples[bsv.nearest(*d)].on_surface)
        .collect();
    let interpolated: Vec<Vec<f64>> = dirs
        .par_iter()
        .map(|d| {
            let mut e = vec![0.0; nn];
            bsv.interpolate(*d, &mut e);
            e
        })
        .collect();
    let occluded = interpolated.iter().map(|e| facing_occlusion(e)).collect();
    Ok(ProbeBase {
        bsv,
        dirs,
        truth,
        truth_seconds,
        direct,
        converged,
        interpolated,
        on_surface,
        facing_occlusion: occluded,
        truth_rays_per_probe: if analytic.is_some() {
            0
        } else {
            truth_sampler.rays()
        },
        bsv_sampling_seconds,
        key: base_key(spec),
    })
}

/// The visibility sampled directly at each probe direction on the sampling sphere (the
/// decomposition's "exact direction" input): the samples themselves for `probe_dirs =
/// samples`, else the facing hemisphere ray traced there.
fn direct_visibility(
    bsv: &Bsv,
    dirs: &[DVec3],
    occ: &dyn Occluder,
    spec: &ProbeSpec,
) -> Result<Vec<Vec<f64>>, FieldError> {
    let s = bsv.sphere;
    let on_sampling = |d: &DVec3| s.center + bsv.sampling_radius * *d;
    Ok(match spec.probe_dirs {
        ProbeDirs::Samples => bsv.samples.iter().map(|x| x.coeffs.clone()).collect(),
        ProbeDirs::Random { .. } => {
            let sampler = VisibilitySampler::new(spec.order, spec.hemisphere_res)?;
            dirs.par_iter()
                .map(|d| {
                    sampler
                        .facing_hemisphere(occ, on_sampling(d), s.center, Frame::Entity)
                        .0
                })
                .collect()
        }
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

/// The largest occluded solid angle an occluder inside the bounding sphere can cover from a
/// point at ρ bounding radii from its centre: the cap the sphere subtends,
/// `2π(1 − √(1 − 1/ρ²))` for ρ > 1 (→ 2π as ρ → 1⁺, ≈ π/ρ² far away), 4π for ρ ≤ 1.
pub fn max_occluded_solid_angle(rho: f64) -> f64 {
    if rho <= 1.0 {
        4.0 * std::f64::consts::PI
    } else {
        2.0 * std::f64::consts::PI * (1.0 - (1.0 - 1.0 / (rho * rho)).sqrt())
    }
}

/// Per-probe metrics of one radius, before summarising.
struct PerProbe {
    on_surface: bool,
    contact: bool,
    vis: Option<f64>,
    occ: Option<f64>,
    truth_err: Option<f64>,
    exact_k: Option<f64>,
    exact_dir: Option<f64>,
    model: Option<f64>,
    band: Option<f64>,
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
    let (k_min, k_max) = table_range(spec);
    let t1 = Instant::now();
    let theta0 = crate::alpha::effective_cap_angle(bsv);
    let family = if spec.alpha_fit {
        TauFamily::ConeFit { theta0 }
    } else {
        TauFamily::Cone { alpha: spec.alpha }
    };
    let table = KTable::build(
        family,
        Eta::Plain,
        spec.order,
        spec.k_count,
        k_min,
        k_max,
        spec.k_spacing,
        spec.k_interp,
    )?;
    let table_build_seconds = t1.elapsed().as_secs_f64();
    let ex = Extrapolator::new(bsv, &table).with_plausibility(spec.plausibility);
    let clamp = (spec.plausibility == Plausibility::Clamp)
        .then(|| Clamp::new(spec.order))
        .transpose()?;
    let at = RadiusWork {
        base,
        spec,
        clamp: clamp.as_ref(),
        rot: EulerRotator::<f64>::new(spec.order)?,
        nn: spec.order * spec.order,
        family,
        table: &table,
        ex,
        theta0,
    };
    let mut rows = Vec::new();
    let mut examples = Vec::new();
    let mut example_index: Option<usize> = None;
    for (ri, (&rho, &k)) in spec.radii.iter().zip(&ks).enumerate() {
        rows.push(at.radius(ri, rho, k, &mut example_index, &mut examples)?);
    }
    Ok(ProbeResult {
        rows,
        examples,
        samples: bsv.samples.len(),
        on_surface_samples: bsv.on_surface_count(),
        contact_samples: bsv
            .samples
            .iter()
            .filter(|x| facing_occlusion(&x.coeffs) >= spec.contact_occlusion)
            .count(),
        effective_cap_deg: theta0.to_degrees(),
        bsv_rays: bsv.rays,
        truth_rays_per_probe: base.truth_rays_per_probe,
        k_min,
        k_max,
        bsv_sampling_seconds,
        table_build_seconds,
    })
}

/// What every probe radius of [`probe_with`] shares.
struct RadiusWork<'a> {
    base: &'a ProbeBase,
    spec: &'a ProbeSpec,
    clamp: Option<&'a Clamp>,
    rot: EulerRotator<f64>,
    nn: usize,
    family: TauFamily,
    table: &'a KTable,
    ex: Extrapolator<'a>,
    /// The BSV's effective cap (the fitted cone angle's input).
    theta0: f64,
}

impl RadiusWork<'_> {
    /// One probe radius `rho` (`k = rho / s`, index `ri`): extrapolate at every probe point,
    /// assess against the truths and summarise into its row; the Fig. 5 example (chosen at the
    /// first radius that has one) is added to `examples`.
    fn radius(
        &self,
        ri: usize,
        rho: f64,
        k: f64,
        example_index: &mut Option<usize>,
        examples: &mut Vec<ProbeExample>,
    ) -> Result<ProbeRow, FieldError> {
        let s = self.base.bsv.sphere;
        let points: Vec<DVec3> = (self.base.dirs.iter())
            .map(|d| s.center + rho * s.radius * *d)
            .collect();
        let t2 = Instant::now();
        let ext = self.extrapolate(&self.ex, &points);
        let extrapolation_seconds = t2.elapsed().as_secs_f64();
        // The decomposition's exact matrix at this k.
        let exact_m = self
            .family
            .at(k)
            .and_then(|tau| ScalingMatrix::compute(tau.as_ref(), Eta::Plain, self.spec.order))?;
        let truth = &self.base.truth[ri];
        let mut row = ProbeRow {
            radius: rho,
            k,
            k_node_offset: node_offset(self.table.ks(), k, self.table.log_k()),
            alpha_used_deg: if self.spec.alpha_fit {
                shscale_scaling::alpha_law::fitted_alpha(self.theta0, k).to_degrees()
            } else {
                self.spec.alpha.to_degrees()
            },
            probes: points.len(),
            extrapolation_seconds,
            truth_seconds: self.base.truth_seconds[ri],
            ..Default::default()
        };
        if example_index.is_none() {
            *example_index = example_of(truth, &ext);
        }
        // Every radius gets its example, at the one point chosen at the first radius that had
        // one; where that point lies inside the mesh the figure says so (it once dropped the
        // radius silently).
        if let Some(i) = *example_index {
            examples.push(ProbeExample {
                radius: rho,
                point: points[i],
                extrapolated: ext[i].0.clone(),
                inside: truth[i].is_none(),
            });
        }
        let per = self.assess(&mut row, &ext, truth, &points, &exact_m);
        summarise(&mut row, &per);
        Ok(row)
    }

    /// The extrapolated visibility at every point, with how each was obtained.
    fn extrapolate(
        &self,
        ex: &Extrapolator,
        points: &[DVec3],
    ) -> Vec<(Vec<f64>, ExtrapolationKind)> {
        points
            .par_iter()
            .map_init(
                || ScalingMatrix::identity(self.spec.order).expect("valid order"),
                |m, p| {
                    let mut out = vec![0.0; self.nn];
                    let kind = ex.eval(*p, m, &mut out);
                    (out, kind)
                },
            )
            .collect()
    }

    /// Every probe of one radius against its truth: the error decomposition per probe, and the
    /// counts (clamped, implausible, inside, unoccluded truth, truth-limited) and the occluded
    /// solid angle's range in `row`.
    fn assess(
        &self,
        row: &mut ProbeRow,
        ext: &[(Vec<f64>, ExtrapolationKind)],
        truth: &[Option<Truth>],
        points: &[DVec3],
        exact_m: &ScalingMatrix<f64>,
    ) -> Vec<PerProbe> {
        let s = self.base.bsv.sphere;
        let s0 = (4.0 * std::f64::consts::PI).sqrt();
        let bound = max_occluded_solid_angle(row.radius) * (1.0 + 1e-9) + 1e-12;
        let mut solid: Vec<f64> = Vec::new();
        let mut per: Vec<PerProbe> = Vec::new();
        let mut scaled = vec![0.0; self.nn];
        for (i, ((e, kind), t)) in ext.iter().zip(truth).enumerate() {
            if *kind == ExtrapolationKind::ClampedBelow {
                row.clamped_count += 1;
            }
            let omega = 4.0 * std::f64::consts::PI - s0 * e[0];
            solid.push(omega);
            if !(-1e-12..=bound).contains(&omega) {
                row.implausible_count += 1;
            }
            let Some(t) = t else {
                row.inside_count += 1;
                continue;
            };
            let occ = occ_rel_l2(e, &t.coeffs);
            if occ.is_none() {
                row.unoccluded_truth_count += 1;
            }
            let cone = bounding_cone(s.radius, (points[i] - s.center).length());
            let mut with = |v: &[f64]| {
                let clamp = self.clamp.map(|c| (c, cone));
                scale_to_with(
                    &self.rot,
                    v,
                    points[i],
                    s.center,
                    exact_m,
                    clamp,
                    &mut scaled,
                );
                occ_rel_l2(&scaled, &t.coeffs)
            };
            let exact_k = with(&self.base.interpolated[i]);
            let exact_dir = with(&self.base.direct[i]);
            let model = with(&self.base.converged[i]);
            let occ_n = occlusion(&t.coeffs);
            let omega_t = s0 * occ_n[0];
            let band = (omega_t > 1e-12).then(|| {
                (1.0 - occ_n.iter().map(|x| x * x).sum::<f64>() / omega_t)
                    .max(0.0)
                    .sqrt()
            });
            let truth_err = t.rel_error();
            if let (Some(o), Some(te)) = (occ, truth_err) {
                if o < 3.0 * te {
                    row.truth_limited_count += 1;
                }
            }
            per.push(PerProbe {
                on_surface: self.base.on_surface[i],
                contact: self.base.facing_occlusion[i] >= self.spec.contact_occlusion,
                vis: vis_rel_l2(e, &t.coeffs),
                occ,
                truth_err,
                exact_k,
                exact_dir,
                model,
                band,
            });
        }
        row.occ_solid_angle_min = solid.iter().copied().reduce(f64::min);
        row.occ_solid_angle_max = solid.iter().copied().reduce(f64::max);
        per
    }
}

/// The probe whose truth is the least visible among those with a defined error (the Fig. 5
/// example), if any.
fn example_of(truth: &[Option<Truth>], ext: &[(Vec<f64>, ExtrapolationKind)]) -> Option<usize> {
    truth
        .iter()
        .zip(ext)
        .enumerate()
        .filter_map(|(i, (t, (e, _)))| {
            let t = t.as_ref()?;
            occ_rel_l2(e, &t.coeffs).map(|_| (i, t.coeffs[0]))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// A radius's means and maxima over its probes (the error decomposition, on-surface and
/// contact subsets) into `row`.
fn summarise(row: &mut ProbeRow, per: &[PerProbe]) {
    (row.vis_rel_l2_mean, row.vis_rel_l2_max, _) = mean_max(per.iter().map(|x| x.vis));
    (row.occ_rel_l2_mean, row.occ_rel_l2_max, _) = mean_max(per.iter().map(|x| x.occ));
    let q = crate::metrics::quantiles(per.iter().map(|x| x.occ), &crate::metrics::QUANTILE_LEVELS);
    [
        row.occ_rel_l2_p05,
        row.occ_rel_l2_p25,
        row.occ_rel_l2_p50,
        row.occ_rel_l2_p75,
        row.occ_rel_l2_p95,
    ] = [q[0], q[1], q[2], q[3], q[4]];
    (row.truth_rel_err_mean, row.truth_rel_err_max, _) =
        mean_max(per.iter().map(|x| x.occ.and(x.truth_err)));
    (row.occ_rel_l2_exact_k_mean, _, _) = mean_max(per.iter().map(|x| x.occ.and(x.exact_k)));
    (row.occ_rel_l2_exact_dir_mean, _, _) = mean_max(per.iter().map(|x| x.occ.and(x.exact_dir)));
    (row.occ_rel_l2_model_mean, _, _) = mean_max(per.iter().map(|x| x.occ.and(x.model)));
    (row.band_limit_rel_mean, _, _) = mean_max(per.iter().map(|x| x.occ.and(x.band)));
    row.on_surface_count = per.iter().filter(|x| x.on_surface).count();
    (row.vis_rel_l2_on_surface_mean, _, _) =
        mean_max(per.iter().filter(|x| x.on_surface).map(|x| x.vis));
    (
        row.occ_rel_l2_on_surface_mean,
        row.occ_rel_l2_on_surface_max,
        _,
    ) = mean_max(per.iter().filter(|x| x.on_surface).map(|x| x.occ));
    row.contact_count = per.iter().filter(|x| x.contact).count();
    (row.occ_rel_l2_contact_mean, row.occ_rel_l2_contact_max, _) =
        mean_max(per.iter().filter(|x| x.contact).map(|x| x.occ));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a node 0, midway 0.5, in ln k for a log table and in k for a uniform one; past an end,
    /// the distance in units of the end spacing; a point exactly on the surface of the analytic
    /// sphere sees the tangent-plane hemisphere (cap π/2), strictly inside nothing.
    /// Distances over the sampling radius, widened both ways; no points: the empty range
    /// `(∞, 0)`; margin 1: the exact extremes.
    #[test]
    fn k_range_to_points_and_its_edges() {
        let c = DVec3::new(1.0, 0.0, 0.0);
        let pts = [DVec3::new(1.0, 3.0, 0.0), DVec3::new(1.0, 0.0, -6.0)];
        assert_eq!(k_range_to(c, 2.0, pts, 1.0), (1.5, 3.0));
        let (lo, hi) = k_range_to(c, 2.0, pts, 1.25);
        assert!((lo - 1.2).abs() < 1e-15 && (hi - 3.75).abs() < 1e-15);
        let (lo, hi) = k_range_to(c, 2.0, std::iter::empty(), 1.25);
        assert!(lo.is_infinite() && hi == 0.0);
    }

    #[test]
    fn node_offset_and_sphere_truth_at_their_edges() {
        let ks = [1.0, 2.0, 4.0, 8.0];
        assert_eq!(node_offset(&ks, 2.0, true), 0.0);
        assert!((node_offset(&ks, 8f64.sqrt(), true) - 0.5).abs() < 1e-12);
        assert!((node_offset(&ks, 3.0, false) - 0.5).abs() < 1e-12);
        assert!((node_offset(&ks, 16.0, true) - 1.0).abs() < 1e-12);
        assert!((node_offset(&ks, 0.5, true) - 1.0).abs() < 1e-12);
        let basis = ShBasis::<f64>::new(4).unwrap();
        let s = Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        };
        let on = sphere_truth(&basis, &s, DVec3::Z).unwrap();
        // Half the sphere visible: c₀ = √(4π)/2.
        assert!((on[0] - (4.0 * std::f64::consts::PI).sqrt() / 2.0).abs() < 1e-12);
        assert!(sphere_truth(&basis, &s, 0.99 * DVec3::Z).is_none());
        assert!(sphere_truth(&basis, &s, DVec3::ZERO).is_none());
        // Random directions are unit and reproducible.
        let d = random_directions(9, 100);
        assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-12));
        assert_eq!(d, random_directions(9, 100));
    }
}
