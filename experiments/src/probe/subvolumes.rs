//! Probe runs with `parts > 1` (sub-volumes, TR §6 / SHS §5): the mesh partitioned once per run
//! (timed on its own); per repeat of the timing procedure every part's BSV (the run's layout, H
//! and sampling radius on the part's own sphere), its k-table (fixed α, or α by distance at the
//! part's effective cap; over the k its probes need, widened by `K_MARGIN`, at least 1e-3) and
//! the product of the parts near to far at every probe point ([`SubVolumeField`]), each stage
//! timed; then every radius assessed against the group's truth as the one-sphere rows are
//! (`shscale_field::probe::assess`), without the single sphere's decomposition, on-surface and
//! contact columns and the GPU timing of the one sphere's BSV (empty).

use super::driver::Base;
use super::row::ProbeRow;
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::evaluator::VisibilityField;
use shscale_field::extrapolate::Extrapolator;
use shscale_field::probe::{assess, k_range_to, sample_bsv, ProbeSpec, K_MARGIN};
use shscale_field::subvolume::SubVolumeField;
use shscale_field::Bsv;
use shscale_runner::Ctx;
use shscale_scaling::{Eta, KTable, TauFamily};
use shscale_scene::Error;
use std::time::Instant;

/// The rows of a run with `parts > 1` (see the module documentation).
pub(super) fn rows(
    spec: &ProbeSpec,
    parts: usize,
    mesh: Option<&shscale_geometry::Mesh>,
    b: &Base,
    ctx: &Ctx,
) -> Result<Vec<ProbeRow>, Error> {
    let mesh = mesh.ok_or_else(|| {
        Error::config("sub-volumes split a mesh; the analytic sphere has none".into())
    })?;
    let t0 = Instant::now();
    let labels = shscale_geometry::partition::kmeans_parts(mesh, parts).map_err(Error::from)?;
    let bvhs: Vec<shscale_geometry::MeshBvh> =
        (shscale_geometry::partition::split(mesh, &labels, parts).iter())
            .map(|m| {
                shscale_geometry::MeshBvh::build(m, shscale_geometry::ray::UpdateStrategy::Rebuild)
            })
            .collect();
    let partition_seconds = t0.elapsed().as_secs_f64();
    let s = b.base.bsv.sphere;
    let points: Vec<Vec<DVec3>> = (spec.radii.iter())
        .map(|rho| {
            (b.base.dirs.iter())
                .map(|d| s.center + rho * s.radius * *d)
                .collect()
        })
        .collect();
    let gaunt = shscale_sh::GauntTensor::<f64>::new(spec.order).map_err(Error::from)?;
    let ((values, bsvs), t) = ctx
        .timing
        .measure_each(|| once(spec, &bvhs, &points, &gaunt))?;
    let rays: usize = bsvs.iter().map(|b| b.rays).sum();
    let rows = (spec.radii.iter().enumerate())
        .map(|(ri, &rho)| {
            let truth = &b.base.truth[ri];
            let a = assess(rho, &values[ri], None, truth, &points[ri], None);
            ProbeRow {
                alpha_used_deg: alpha_used_deg(spec, &bsvs, &points[ri]),
                bsv_rays: rays,
                truth_rays: b.base.truth_rays_per_probe,
                bsv_sampling_seconds: t[0].median,
                bsv_sampling_spread: t[0].spread(),
                table_build_seconds: t[1].median,
                table_build_spread: t[1].spread(),
                // Every radius at once (the one-sphere rows time each radius).
                extrapolation_seconds: t[2].median,
                extrapolation_spread: t[2].spread(),
                truth_seconds: b.truth_seconds[ri],
                partition_seconds: Some(partition_seconds),
                // The group's GPU timing is of the one sphere's BSV, not of the parts'.
                ..ProbeRow::assessed(rho, rho / spec.sampling_radius, &a)
            }
        })
        .collect();
    Ok(rows)
}

/// Every radius's values and the parts' BSVs of one repeat; the times [sampling, tables,
/// evaluation].
type Repeat = ((Vec<Vec<Vec<f64>>>, Vec<Bsv>), Vec<f64>);

/// One repeat: the parts' BSVs, their tables, the product at every probe point.
fn once(
    spec: &ProbeSpec,
    bvhs: &[shscale_geometry::MeshBvh],
    points: &[Vec<DVec3>],
    gaunt: &shscale_sh::GauntTensor<f64>,
) -> Result<Repeat, Error> {
    let t0 = Instant::now();
    let bsvs = (bvhs.iter())
        .map(|b| sample_bsv(b, spec))
        .collect::<Result<Vec<_>, _>>()?;
    let t1 = Instant::now();
    let tables = (bsvs.iter())
        .map(|b| table(spec, b, points))
        .collect::<Result<Vec<_>, _>>()?;
    let t2 = Instant::now();
    let exs = (bsvs.iter().zip(&tables))
        .map(|(b, t)| Extrapolator::new(b, t).with_plausibility(spec.plausibility))
        .collect();
    let field = SubVolumeField::new(exs, gaunt);
    let nn = spec.order * spec.order;
    let values: Vec<Vec<Vec<f64>>> = (points.iter())
        .map(|ps| {
            ps.par_iter()
                .map(|q| {
                    let mut out = vec![0.0; nn];
                    field.eval(*q, &mut out);
                    out
                })
                .collect()
        })
        .collect();
    let t3 = Instant::now();
    let secs = |a: Instant, b: Instant| (b - a).as_secs_f64();
    Ok((
        (values, bsvs),
        vec![secs(t0, t1), secs(t1, t2), secs(t2, t3)],
    ))
}

/// A part's k-table over the k its probes need.
fn table(spec: &ProbeSpec, b: &Bsv, points: &[Vec<DVec3>]) -> Result<KTable, Error> {
    let (lo, hi) = k_range_to(
        b.sphere.center,
        b.sampling_radius,
        points.iter().flatten().copied(),
        K_MARGIN,
    );
    let lo = lo.max(1e-3);
    let family = if spec.alpha_fit {
        TauFamily::ConeFit {
            theta0: shscale_field::alpha::effective_cap_angle(b),
        }
    } else {
        TauFamily::Cone { alpha: spec.alpha }
    };
    KTable::build(
        family,
        Eta::Plain,
        spec.order,
        spec.k_count,
        lo,
        hi.max(lo * 1.01),
        spec.k_spacing,
        spec.k_interp,
    )
    .map_err(Error::from)
}

/// The α the parts used at one radius, degrees: the fixed α, or with α by distance the mean over
/// the parts and probes of each part's fitted α at its own k (`d / r_s` from the part's centre).
fn alpha_used_deg(spec: &ProbeSpec, bsvs: &[Bsv], points: &[DVec3]) -> f64 {
    if !spec.alpha_fit {
        return spec.alpha.to_degrees();
    }
    let mut sum = 0.0;
    let mut n = 0usize;
    for b in bsvs {
        let theta0 = shscale_field::alpha::effective_cap_angle(b);
        for q in points {
            let k = (*q - b.sphere.center).length() / b.sampling_radius;
            sum += shscale_scaling::alpha_law::fitted_alpha(theta0, k);
            n += 1;
        }
    }
    (sum / n.max(1) as f64).to_degrees()
}
