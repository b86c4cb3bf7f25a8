//! The numbers of the probe experiment (SHS Fig. 5 / TR Fig. 1): for every probe direction u — by
//! default as many seeded uniform directions as base-sphere samples, so that they fall between
//! the samples; or the sample directions themselves, the papers' design — a probe at `c + ρ·r·u`
//! for each radius factor ρ (default 0.5, 0.7, 0.9, 1.3, 2); the truth there; each probe's
//! errors against it with the error decomposition (each component replaced by its exact
//! counterpart in turn: the k-table, the BSV interpolation, the BSV's sampling resolution; what
//! remains is the cone model; the band-limiting of the truth beside them), the plausibility of
//! the extrapolation, and the k ranges of the tables. The experiment's driver — its timers,
//! grouping and rows — is the `probe` kind's (`shscale_experiments::probe`).
//!
//! Truth: the converged ray-traced truth of [`TruthSampler`] (its own resolution, never the
//! method's H; `4T²` rays, with an error estimate), or, for the analytic sphere, the closed-form
//! cap `√(4π)e₀ − cap(asin(R/d))` about the direction to the centre (exact). Probes inside a solid
//! (no truth ray escapes) are excluded and counted (`inside`); probes that see nothing occluded
//! have no `occ_rel_l2` and are counted too.

use crate::bsv::{Bsv, Layout};
use crate::error::FieldError;
use crate::extrapolate::{
    bounding_cone, scale_to_with, Clamp, ExtrapolationKind, Extrapolator, Plausibility,
};
use crate::metrics::{facing_occlusion, occ_rel_l2, occlusion, vis_rel_l2};
use crate::truth::{SplitMix, Truth, TruthSampler, DEFAULT_TRUTH_RES, DEFAULT_TRUTH_SEED};
use crate::visibility::{Frame, VisibilitySampler};
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::{Occluder, Sphere};
use shscale_scaling::{Interp, ScalingMatrix, Spacing};
use shscale_sh::{cap_zonal, rotate_zonal, EulerRotator, ShBasis};

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
    /// ([`shscale_scaling::TauFamily::ConeFit`], [`crate::alpha::effective_cap_angle`]; docs/math.md §7).
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
/// share one.
pub struct ProbeBase {
    pub bsv: Bsv,
    /// Probe directions from the centre.
    pub dirs: Vec<DVec3>,
    /// `truth[radius][probe]`, entity frame.
    pub truth: Vec<Vec<Option<Truth>>>,
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
    let bsv = sample_bsv(occ, spec)?;
    let truths = Truths::new(occ, analytic, spec)?;
    let dirs = probe_directions(spec, &bsv);
    let truth = (spec.radii.iter().enumerate())
        .map(|(ri, &rho)| truths.at_radius(bsv.sphere, &dirs, ri, rho))
        .collect();
    probe_base_on(bsv, &truths, spec, truth)
}

/// The truths of a probe run: closed form for the analytic sphere, else the converged
/// ray-traced truth. Each truth draws from the seed and its own stream (radius index, probe
/// index): the same draw whatever the scene's scale, the thread or the order.
pub struct Truths<'a> {
    occ: &'a dyn Occluder,
    analytic: Option<Sphere>,
    sampler: TruthSampler,
    basis: ShBasis<f64>,
    radii: usize,
}

impl<'a> Truths<'a> {
    pub fn new(
        occ: &'a dyn Occluder,
        analytic: Option<Sphere>,
        spec: &ProbeSpec,
    ) -> Result<Self, FieldError> {
        check_radii(spec)?;
        Ok(Self {
            occ,
            analytic,
            sampler: TruthSampler::new(spec.order, spec.truth_res, spec.truth_seed)?,
            basis: ShBasis::<f64>::new(spec.order)?,
            radii: spec.radii.len(),
        })
    }

    /// Rays per probe (0 for the closed form).
    pub(crate) fn rays_per_probe(&self) -> usize {
        if self.analytic.is_some() {
            0
        } else {
            self.sampler.rays()
        }
    }

    /// The truth at `p` from stream `stream`; `None` inside the solid.
    fn at(&self, p: DVec3, stream: u64) -> Option<Truth> {
        match self.analytic {
            Some(sph) => sphere_truth(&self.basis, &sph, p).map(Truth::exact),
            None => Some(self.sampler.sample_stream(self.occ, p, stream)).filter(|t| t.escaped > 0),
        }
    }

    /// The truth at every probe point `c + ρ·r·d` of radius index `ri` (streams `ri·n + i`).
    pub fn at_radius(&self, s: Sphere, dirs: &[DVec3], ri: usize, rho: f64) -> Vec<Option<Truth>> {
        let np = dirs.len() as u64;
        (dirs.par_iter().enumerate())
            .map(|(i, d)| self.at(s.center + rho * s.radius * *d, ri as u64 * np + i as u64))
            .collect()
    }
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

/// [`probe_base`] on a BSV and the truths at every radius (`truth[ri]` from
/// [`Truths::at_radius`]), computed by the caller: the exact inputs of the error decomposition.
pub fn probe_base_on(
    bsv: Bsv,
    truths: &Truths,
    spec: &ProbeSpec,
    truth: Vec<Vec<Option<Truth>>>,
) -> Result<ProbeBase, FieldError> {
    check_radii(spec)?;
    let dirs = probe_directions(spec, &bsv);
    if truth.len() != spec.radii.len() || truth.iter().any(|t| t.len() != dirs.len()) {
        return Err(FieldError::Spec(format!(
            "{} radii of truths for {} radii of {} probes",
            truth.len(),
            spec.radii.len(),
            dirs.len()
        )));
    }
    let s = bsv.sphere;
    let np = dirs.len() as u64;
    let on_sampling = |d: &DVec3| s.center + bsv.sampling_radius * *d;
    let direct = direct_visibility(&bsv, &dirs, truths.occ, spec)?;
    let last = truths.radii as u64 * np;
    let nn = spec.order * spec.order;
    let converged: Vec<Vec<f64>> = dirs
        .par_iter()
        .enumerate()
        .map(|(i, d)| {
            (truths.at(on_sampling(d), last + i as u64)).map_or_else(|| vec![0.0; nn], |t| t.coeffs)
        })
        .collect();
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
        direct,
        converged,
        interpolated,
        on_surface,
        facing_occlusion: occluded,
        truth_rays_per_probe: truths.rays_per_probe(),
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

/// One probe's errors against its truth (docs/conventions.md §6) and, where a single sphere's
/// decomposition applies ([`Decomposition`]), its components; `None` where not applicable.
#[derive(Clone, Debug, Default)]
pub struct ProbeError {
    /// The probe direction's nearest base-sphere sample lies on the surface.
    pub on_surface: Option<bool>,
    /// The probe direction is a contact direction (the interpolated BSV occludes at least the
    /// contact threshold of the facing hemisphere).
    pub contact: Option<bool>,
    pub vis: Option<f64>,
    pub occ: Option<f64>,
    /// The truth's own error relative to its occlusion ([`Truth::rel_error`]).
    pub truth_err: Option<f64>,
    /// `occ_rel_l2` with the k-table replaced by the exact `M_k` …
    pub exact_k: Option<f64>,
    /// … and the interpolated BSV by the BSV sampled at the probe's own direction …
    pub exact_dir: Option<f64>,
    /// … and that sample by the converged truth at the same point: the cone model.
    pub model: Option<f64>,
    /// The truth's own band-limiting error `√(1 − ‖P_N occ‖² / Ω_occ)`.
    pub band: Option<f64>,
}

/// One radius's probes against their truths: each probe's errors and the radius's counts.
#[derive(Clone, Debug, Default)]
pub struct Assessment {
    /// The probes with a truth (outside the solid), in order.
    pub per: Vec<ProbeError>,
    pub probes: usize,
    /// Probes inside the solid (no truth).
    pub inside: usize,
    /// Probes whose truth sees nothing occluded (no `occ_rel_l2`).
    pub unoccluded_truth: usize,
    /// Probes below the table's range, clamped to its first entry (`None` where the evaluation
    /// does not report it: sub-volumes).
    pub clamped: Option<usize>,
    /// Probes whose extrapolated occluded solid angle `Ω = 4π − √(4π) c₀` is negative or exceeds
    /// [`max_occluded_solid_angle`].
    pub implausible: usize,
    /// Probes whose `occ_rel_l2` is within 3× the truth's own error (not resolved by it).
    pub truth_limited: usize,
    pub solid_min: Option<f64>,
    pub solid_max: Option<f64>,
    /// The single sphere's decomposition, on-surface and contact flags were computed.
    pub decomposed: bool,
}

/// The exact inputs of a single sphere's error decomposition at one radius.
pub struct Decomposition<'a> {
    pub base: &'a ProbeBase,
    pub contact_occlusion: f64,
    pub clamp: Option<&'a Clamp>,
    pub rot: &'a EulerRotator<f64>,
    /// The exact `M_k` at the radius's k.
    pub exact_m: &'a ScalingMatrix<f64>,
}

impl Decomposition<'_> {
    /// The three decomposition errors and the band-limit of probe `i` at `p` against `t`.
    fn components(&self, i: usize, p: DVec3, t: &Truth) -> [Option<f64>; 3] {
        let s = self.base.bsv.sphere;
        let nn = t.coeffs.len();
        let cone = bounding_cone(s.radius, (p - s.center).length());
        let mut scaled = vec![0.0; nn];
        let mut with = |v: &[f64]| {
            let clamp = self.clamp.map(|c| (c, cone));
            scale_to_with(self.rot, v, p, s.center, self.exact_m, clamp, &mut scaled);
            occ_rel_l2(&scaled, &t.coeffs)
        };
        [
            with(&self.base.interpolated[i]),
            with(&self.base.direct[i]),
            with(&self.base.converged[i]),
        ]
    }
}

/// The extrapolated visibility of `ex` at every point, with how each was obtained.
pub fn extrapolate_at(
    ex: &Extrapolator,
    order: usize,
    points: &[DVec3],
) -> Vec<(Vec<f64>, ExtrapolationKind)> {
    points
        .par_iter()
        .map_init(
            || ScalingMatrix::identity(order).expect("valid order"),
            |m, p| {
                let mut out = vec![0.0; order * order];
                let kind = ex.eval(*p, m, &mut out);
                (out, kind)
            },
        )
        .collect()
}

/// Every probe of one radius `rho` (extrapolated `ext` at `points`, how each was obtained in
/// `kinds` where the evaluation reports it) against its `truth`; with `dec`, each probe's error
/// decomposition, on-surface and contact flags.
pub fn assess(
    rho: f64,
    ext: &[Vec<f64>],
    kinds: Option<&[ExtrapolationKind]>,
    truth: &[Option<Truth>],
    points: &[DVec3],
    dec: Option<&Decomposition>,
) -> Assessment {
    let s0 = (4.0 * std::f64::consts::PI).sqrt();
    let bound = max_occluded_solid_angle(rho) * (1.0 + 1e-9) + 1e-12;
    let mut a = Assessment {
        probes: points.len(),
        decomposed: dec.is_some(),
        clamped: kinds.map(|k| {
            (k.iter())
                .filter(|k| **k == ExtrapolationKind::ClampedBelow)
                .count()
        }),
        ..Assessment::default()
    };
    let solid: Vec<f64> = ext
        .iter()
        .map(|e| 4.0 * std::f64::consts::PI - s0 * e[0])
        .collect();
    a.implausible = solid
        .iter()
        .filter(|o| !(-1e-12..=bound).contains(*o))
        .count();
    a.solid_min = solid.iter().copied().reduce(f64::min);
    a.solid_max = solid.iter().copied().reduce(f64::max);
    for (i, (e, t)) in ext.iter().zip(truth).enumerate() {
        let Some(t) = t else {
            a.inside += 1;
            continue;
        };
        let occ = occ_rel_l2(e, &t.coeffs);
        if occ.is_none() {
            a.unoccluded_truth += 1;
        }
        let [exact_k, exact_dir, model] = dec.map_or([None; 3], |d| d.components(i, points[i], t));
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
                a.truth_limited += 1;
            }
        }
        a.per.push(ProbeError {
            on_surface: dec.map(|d| d.base.on_surface[i]),
            contact: dec.map(|d| d.base.facing_occlusion[i] >= d.contact_occlusion),
            vis: vis_rel_l2(e, &t.coeffs),
            occ,
            truth_err,
            exact_k,
            exact_dir,
            model,
            band,
        });
    }
    a
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
