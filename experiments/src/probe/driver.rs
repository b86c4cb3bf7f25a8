//! The probe's driver: the shared work of a group (the BSV and the truth at every radius, each
//! timed), one repeat of a run's α- and K-dependent work (the k-table, then per radius the
//! extrapolation at every probe and its assessment against the truths), and the rows with their
//! stage times. The numbers — truths, the error decomposition, k ranges — are the field crate's
//! (`shscale_field::probe`); the stopwatches, the timing procedure and the rows are here. The
//! `probe` kind, `shscale probe` and the Python `probe` all run through it.

use super::row::ProbeRow;
use glam::DVec3;
use shscale_field::extrapolate::{Clamp, Extrapolator, Plausibility};
use shscale_field::metrics::occ_rel_l2;
use shscale_field::probe::{
    assess, extrapolate_at, node_offset, probe_base_on, probe_directions, sample_bsv, table_range,
    Decomposition, ProbeBase, ProbeSpec, Truths,
};
use shscale_field::truth::Truth;
use shscale_geometry::{Occluder, Sphere};
use shscale_runner::timing::{Procedure, Timing};
use shscale_scaling::{Eta, KTable, ScalingMatrix, TauFamily};
use shscale_scene::Error;
use std::time::Instant;

/// One probe point kept for images (the papers' Fig. 5): its position and the extrapolated SH
/// visibility.
#[derive(Clone, Debug)]
pub struct Example {
    pub radius: f64,
    pub point: DVec3,
    pub extrapolated: Vec<f64>,
    /// The point lies inside the occluder at this radius (no truth: its visibility is 0 in
    /// every direction).
    pub inside: bool,
}

/// The shared work of a group: the base and its stage times.
pub struct Base {
    pub base: ProbeBase,
    /// The BSV's sampling, by the timing procedure.
    pub bsv: Timing,
    /// The truth at each radius, once (the reference, not a method under test).
    pub truth_seconds: Vec<f64>,
}

/// Sample the BSV (timed by `timing`) and compute the truth at every radius (timed once each).
pub fn base(
    occ: &dyn Occluder,
    analytic: Option<Sphere>,
    spec: &ProbeSpec,
    timing: Procedure,
) -> Result<Base, Error> {
    let (bsv, bsv_timing) = timing.measure(|| sample_bsv(occ, spec))?;
    let truths = Truths::new(occ, analytic, spec)?;
    let dirs = probe_directions(spec, &bsv);
    let mut truth = Vec::new();
    let mut truth_seconds = Vec::new();
    for (ri, &rho) in spec.radii.iter().enumerate() {
        let t = Instant::now();
        truth.push(truths.at_radius(bsv.sphere, &dirs, ri, rho));
        truth_seconds.push(t.elapsed().as_secs_f64());
    }
    Ok(Base {
        base: probe_base_on(bsv, &truths, spec, truth)?,
        bsv: bsv_timing,
        truth_seconds,
    })
}

/// What one repeat of a run yields: a row per radius (accuracy columns), the examples, the
/// BSV's effective cap (degrees) and the table's k range.
pub struct Once {
    pub rows: Vec<ProbeRow>,
    pub examples: Vec<Example>,
    pub effective_cap_deg: f64,
    pub k_min: f64,
    pub k_max: f64,
}

/// A base built for other sampling parameters than `spec`'s (the runner's groups share a base
/// between runs that differ only in α and the table).
fn check_base(base: &ProbeBase, spec: &ProbeSpec) -> Result<(), Error> {
    let b = &base.bsv;
    let h2 = spec.hemisphere_res * spec.hemisphere_res;
    let same = b.layout == spec.layout
        && b.samples.len() * h2 == b.rays
        && (b.sampling_radius - spec.sampling_radius * b.sphere.radius).abs()
            <= 1e-12 * b.sampling_radius
        && base.truth.len() == spec.radii.len()
        && b.samples.first().map(|x| x.coeffs.len()) == Some(spec.order * spec.order);
    if same {
        Ok(())
    } else {
        Err(Error::config(format!(
            "a probe base of {} samples at H² = {} rays, {} radii, used for layout {}, H = {}, {} radii",
            b.samples.len(),
            b.rays / b.samples.len().max(1),
            base.truth.len(),
            spec.layout.name(),
            spec.hemisphere_res,
            spec.radii.len()
        )))
    }
}

/// One repeat of the α- and K-dependent work on a shared base: the k-table, then per radius
/// the extrapolation at every probe point and its assessment (the single sphere's
/// decomposition included); the times `[table, radius 0, radius 1, …]`.
pub fn once(base: &ProbeBase, spec: &ProbeSpec) -> Result<(Once, Vec<f64>), Error> {
    check_base(base, spec)?;
    let bsv = &base.bsv;
    let (k_min, k_max) = table_range(spec);
    let t1 = Instant::now();
    let theta0 = shscale_field::alpha::effective_cap_angle(bsv);
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
    )
    .map_err(Error::from)?;
    let mut times = vec![t1.elapsed().as_secs_f64()];
    let at = Radii {
        base,
        spec,
        ex: Extrapolator::new(bsv, &table).with_plausibility(spec.plausibility),
        clamp: (spec.plausibility == Plausibility::Clamp)
            .then(|| Clamp::new(spec.order))
            .transpose()?,
        rot: shscale_sh::EulerRotator::<f64>::new(spec.order).map_err(Error::from)?,
        family,
        table: &table,
        theta0,
    };
    let mut rows = Vec::new();
    let mut examples = Vec::new();
    let mut example: Option<usize> = None;
    for (ri, &rho) in spec.radii.iter().enumerate() {
        let (row, values, points, secs) = at.radius(ri, rho)?;
        times.push(secs);
        // Every radius gets its example, at the one point chosen at the first radius that had
        // one; where that point lies inside the mesh the figure says so.
        let truth = &base.truth[ri];
        example = example.or_else(|| example_of(truth, &values));
        if let Some(i) = example {
            examples.push(Example {
                radius: rho,
                point: points[i],
                extrapolated: values[i].clone(),
                inside: truth[i].is_none(),
            });
        }
        rows.push(row);
    }
    let once = Once {
        rows,
        examples,
        effective_cap_deg: theta0.to_degrees(),
        k_min,
        k_max,
    };
    Ok((once, times))
}

/// One radius of a repeat: its row, the extrapolated values at its points, the points and the
/// extrapolation's seconds.
type Radius = (ProbeRow, Vec<Vec<f64>>, Vec<DVec3>, f64);

/// What every radius of one repeat shares.
struct Radii<'a> {
    base: &'a ProbeBase,
    spec: &'a ProbeSpec,
    ex: Extrapolator<'a>,
    clamp: Option<Clamp>,
    rot: shscale_sh::EulerRotator<f64>,
    family: TauFamily,
    table: &'a KTable,
    /// The BSV's effective cap (the fitted cone angle's input), radians.
    theta0: f64,
}

impl Radii<'_> {
    /// Radius `rho` (index `ri`, `k = ρ / s`): the extrapolation at every probe point (timed),
    /// assessed with the decomposition's exact `M_k`; its row, values, points and seconds.
    fn radius(&self, ri: usize, rho: f64) -> Result<Radius, Error> {
        let (spec, s) = (self.spec, self.base.bsv.sphere);
        let k = rho / spec.sampling_radius;
        let points: Vec<DVec3> = (self.base.dirs.iter())
            .map(|d| s.center + rho * s.radius * *d)
            .collect();
        let t2 = Instant::now();
        let ext = extrapolate_at(&self.ex, spec.order, &points);
        let secs = t2.elapsed().as_secs_f64();
        let exact_m = (self.family.at(k))
            .and_then(|tau| ScalingMatrix::compute(tau.as_ref(), Eta::Plain, spec.order))
            .map_err(Error::from)?;
        let dec = Decomposition {
            base: self.base,
            contact_occlusion: spec.contact_occlusion,
            clamp: self.clamp.as_ref(),
            rot: &self.rot,
            exact_m: &exact_m,
        };
        let (values, kinds): (Vec<Vec<f64>>, Vec<_>) = ext.into_iter().unzip();
        let truth = &self.base.truth[ri];
        let a = assess(rho, &values, Some(&kinds), truth, &points, Some(&dec));
        let row = ProbeRow {
            k_node_offset: Some(node_offset(self.table.ks(), k, self.table.log_k())),
            alpha_used_deg: if spec.alpha_fit {
                shscale_scaling::alpha_law::fitted_alpha(self.theta0, k).to_degrees()
            } else {
                spec.alpha.to_degrees()
            },
            effective_cap_deg: Some(self.theta0.to_degrees()),
            ..ProbeRow::assessed(rho, k, &a)
        };
        Ok((row, values, points, secs))
    }
}

/// The probe whose truth is the least visible among those with a defined error (the Fig. 5
/// example), if any.
fn example_of(truth: &[Option<Truth>], ext: &[Vec<f64>]) -> Option<usize> {
    (truth.iter().zip(ext).enumerate())
        .filter_map(|(i, (t, e))| {
            let t = t.as_ref()?;
            occ_rel_l2(e, &t.coeffs).map(|_| (i, t.coeffs[0]))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// A run's rows with the shared work's rays and times and its own stages: `table` and
/// `radii[ri]` the timing procedure's medians and spreads.
pub(crate) fn with_times(
    mut rows: Vec<ProbeRow>,
    b: &Base,
    table: &Timing,
    radii: &[Timing],
) -> Vec<ProbeRow> {
    for (ri, row) in rows.iter_mut().enumerate() {
        let ext = radii.get(ri).copied().unwrap_or_default();
        row.bsv_rays = b.base.bsv.rays;
        row.truth_rays = b.base.truth_rays_per_probe;
        row.bsv_sampling_seconds = b.bsv.median;
        row.bsv_sampling_spread = b.bsv.spread();
        row.table_build_seconds = table.median;
        row.table_build_spread = table.spread();
        row.extrapolation_seconds = ext.median;
        row.extrapolation_spread = ext.spread();
        row.truth_seconds = b.truth_seconds[ri];
    }
    rows
}

/// One probe from scratch, as `shscale probe` and the Python `probe` run it: the base and one
/// repeat of the run (each stage timed once), with the BSV's counts.
pub struct Probed {
    pub rows: Vec<ProbeRow>,
    pub examples: Vec<Example>,
    pub samples: usize,
    pub on_surface_samples: usize,
    pub contact_samples: usize,
    pub bsv_rays: usize,
    pub truth_rays_per_probe: usize,
    pub k_min: f64,
    pub k_max: f64,
    /// The BSV's effective cap θ₀, degrees.
    pub effective_cap_deg: f64,
    pub bsv_sampling_seconds: f64,
    pub table_build_seconds: f64,
}

/// Run the probe on `occ` once (`analytic`: the closed-form truth of a solid sphere).
pub fn probe(
    occ: &dyn Occluder,
    analytic: Option<Sphere>,
    spec: &ProbeSpec,
) -> Result<Probed, Error> {
    let one = Procedure {
        warmup: 0,
        repeats: 1,
    };
    let b = base(occ, analytic, spec, one)?;
    let (o, t) = one.measure_each(|| once(&b.base, spec))?;
    let bsv = &b.base.bsv;
    Ok(Probed {
        samples: bsv.samples.len(),
        on_surface_samples: bsv.on_surface_count(),
        contact_samples: (bsv.samples.iter())
            .filter(|x| {
                shscale_field::metrics::facing_occlusion(&x.coeffs) >= spec.contact_occlusion
            })
            .count(),
        bsv_rays: bsv.rays,
        truth_rays_per_probe: b.base.truth_rays_per_probe,
        k_min: o.k_min,
        k_max: o.k_max,
        effective_cap_deg: o.effective_cap_deg,
        bsv_sampling_seconds: b.bsv.median,
        table_build_seconds: t[0].median,
        rows: with_times(o.rows, &b, &t[0], &t[1..]),
        examples: o.examples,
    })
}
