//! One frame of each method on spherical receivers, from scratch, as the timing procedure
//! repeats it: the method's data built (base-sphere samples and tables, shells, fitted spheres)
//! and every receiver evaluated. Each frame returns its values, rays and bytes and its
//! [build, eval, frame] seconds.

use glam::DVec3;
use rayon::prelude::*;
use shscale_field::evaluator::{FullField, VisibilityField};
use shscale_field::extrapolate::Extrapolator;
use shscale_field::shexp_ol::{log_bsv, SubVolumeLog, ZonalLogTable, SHEXP_EPS};
use shscale_field::subvolume::SubVolumeField;
use shscale_field::truth::TruthSampler;
use shscale_field::{Bsv, Occluder, VisibilitySampler};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
use shscale_scene::method::{Alpha, Combine, Extrapolation, FieldSpec, SetSpec, SetTables};
use shscale_scene::Error;
use std::time::Instant;

/// One frame's values per receiver, rays and bytes.
pub(crate) type Frame = (Vec<Vec<f64>>, f64, f64);
/// A frame from scratch, timed as a whole: its [`Frame`] and [build, eval, frame] seconds.
pub(crate) type FrameFn<'a> = Box<dyn FnMut() -> Result<(Frame, [f64; 3]), Error> + 'a>;

/// The receivers: (ρ in bounding radii, point).
pub(crate) type Points = [(f64, DVec3)];

/// The k-table of `family` over `(lo, hi)`: plain η, `k_count` entries, exponential spacing,
/// linear interpolation.
fn k_table(
    order: usize,
    k_count: usize,
    family: TauFamily,
    (lo, hi): (f64, f64),
) -> Result<KTable, Error> {
    KTable::build(
        family,
        Eta::Plain,
        order,
        k_count,
        lo,
        hi,
        Spacing::Exp,
        Interp::Linear,
    )
    .map_err(Error::from)
}

/// Every receiver evaluated (in parallel).
pub(crate) fn eval_all(
    f: &(dyn VisibilityField + Sync),
    points: &Points,
    nn: usize,
) -> Vec<Vec<f64>> {
    points
        .par_iter()
        .map(|(_, q)| {
            let mut out = vec![0.0; nn];
            f.eval(*q, &mut out);
            out
        })
        .collect()
}

/// Occluders (the object or its parts) with the k range each is extrapolated over.
pub(crate) type Parts<'a> = Vec<(&'a dyn Occluder, (f64, f64))>;

/// The frame of extrapolation from the spheres of `parts` (occluder and k range each): every
/// part's BSV sampled at the sampling radius × its bounding radius, its k-table (built once,
/// before the frames, for a fixed α — part of the memory, not of a frame's time; per frame for
/// α by distance, which depends on the BSV) and, for several parts, their visibilities
/// multiplied near to far ([`SubVolumeField`]). One part is the papers' method. With
/// `combine = Shexp` every part's samples are replaced by their product-algebra logs (their
/// time in the frame's build), the logs extrapolated, summed and exponentiated once
/// ([`SubVolumeLog`]), for any number of parts.
pub(crate) fn extrapolation<'a>(
    ex: &'a Extrapolation,
    (order, k_count): (usize, usize),
    (parts, combine): (Parts<'a>, Combine),
    sampler: &'a VisibilitySampler,
    points: &'a Points,
) -> Result<FrameFn<'a>, Error> {
    let s = ex.sampling_radius;
    // Samples moved outward by the radial rule see smaller k: the tables reach down to the
    // receivers' distances over the largest radius the rule can reach.
    let down = s / ex.radial.max_factor(s);
    let parts: Vec<_> = (parts.into_iter())
        .map(|(o, (lo, hi))| (o, (lo * down, hi)))
        .collect();
    let nn = order * order;
    let fixed: Option<Vec<KTable>> = match ex.alpha {
        Alpha::Fixed(a) => {
            let alpha = a.radians();
            Some(
                (parts.iter())
                    .map(|(_, r)| k_table(order, k_count, TauFamily::Cone { alpha }, *r))
                    .collect::<Result<_, _>>()?,
            )
        }
        Alpha::Fit => None,
    };
    let log_space = combine == Combine::Shexp;
    let gaunt = (parts.len() > 1 || log_space)
        .then(|| shscale_sh::GauntTensor::<f64>::new(order))
        .transpose()
        .map_err(Error::from)?;
    let table = (gaunt.as_ref())
        .filter(|_| log_space)
        .map(|g| ZonalLogTable::new(g, SHEXP_EPS));
    Ok(Box::new(move || {
        let t0 = Instant::now();
        let bsvs: Vec<Bsv> = (parts.iter())
            .map(|(o, _)| Bsv::sample_radial(*o, ex.layout, sampler, s, ex.radial))
            .collect::<Result<_, _>>()?;
        let own: Vec<KTable>;
        let tables = match &fixed {
            Some(t) => t,
            None => {
                own = (bsvs.iter().zip(&parts))
                    .map(|(b, (_, r))| {
                        let theta0 = shscale_field::alpha::effective_cap_angle(b);
                        k_table(order, k_count, TauFamily::ConeFit { theta0 }, *r)
                    })
                    .collect::<Result<_, _>>()?;
                &own
            }
        };
        let logs: Vec<Bsv> = match (&gaunt, &table) {
            (Some(g), Some(_)) => (bsvs.iter()).map(|b| log_bsv(b, g, SHEXP_EPS)).collect(),
            _ => Vec::new(),
        };
        let build = t0.elapsed().as_secs_f64();
        let sources = if log_space { &logs } else { &bsvs };
        let mut exs: Vec<Extrapolator> = (sources.iter().zip(tables))
            .map(|(b, t)| Extrapolator::new(b, t).with_plausibility(ex.plausibility))
            .collect();
        let t1 = Instant::now();
        let v = match (&gaunt, &table) {
            (Some(g), Some(t)) => eval_all(&SubVolumeLog::new(&exs, g, t), points, nn),
            (Some(g), None) => eval_all(&SubVolumeField::new(exs, g), points, nn),
            _ => eval_all(&exs.remove(0), points, nn),
        };
        let eval = t1.elapsed().as_secs_f64();
        let rays = bsvs.iter().map(|b| b.rays).sum::<usize>() as f64;
        let mem = (bsvs.iter().zip(tables))
            .map(|(b, t)| b.samples.len() * nn * 8 + t.size_bytes())
            .sum::<usize>() as f64;
        Ok(((v, rays, mem), [build, eval, build + eval]))
    }))
}

/// Where a sphere set's spheres come from each frame.
pub(crate) enum SetSource<'a> {
    /// Fitted every frame to the mesh's parts (`fit_spheres`, timed in the frame's build).
    Refit(&'a shscale_geometry::Mesh, Vec<u32>),
    /// Fixed before the frames: the analytic sphere as its own set, or a one-off fit (the
    /// inscribed balls), whose time is the run's `partition_seconds`.
    Fixed(Vec<shscale_geometry::Sphere>),
}

/// The frame of a sphere set: `set.parts` spheres refitted to the mesh's parts (`labels`) every
/// frame — the analytic sphere is its own one-sphere set — combined as `set` says, with the
/// tables of [`SetTables`] (the factory `render` uses too): truncated products at the internal
/// order (≥ `order`, truncated to `order` once), the quadrature, whose rays (cast at the
/// spheres, not at the mesh) are counted, the exact union of the caps, or SH exponentiation
/// (HYB).
pub(crate) fn sphere_set<'a>(
    order: usize,
    set: &SetSpec,
    source: SetSource<'a>,
    points: &'a Points,
) -> Result<FrameFn<'a>, Error> {
    let nn = order * order;
    let parts = set.parts;
    let basis = shscale_sh::ShBasis::<f64>::new(order).map_err(Error::from)?;
    let gaunt = shscale_sh::GauntTensor::<f64>::new(order).map_err(Error::from)?;
    // What the combination needs, built once before the frames.
    let tables = SetTables::new(set, order, &basis)?;
    Ok(Box::new(move || {
        let t0 = Instant::now();
        let spheres = match &source {
            SetSource::Refit(m, l) => shscale_geometry::partition::fit_spheres(m, l, parts),
            SetSource::Fixed(set) => set.clone(),
        };
        let build = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let f = (tables.field(&spheres, &basis, Some(&gaunt)))
            .expect("the chain's Gaunt tensor is given");
        let v = eval_all(f.field.as_ref(), points, nn);
        let (rays, bytes) = (points.len() * f.rays_per_receiver, f.bytes);
        let eval = t1.elapsed().as_secs_f64();
        Ok(((v, rays as f64, bytes as f64), [build, eval, build + eval]))
    }))
}

/// The frame of the fully sampled field: its shells sampled, then every receiver interpolated.
pub(crate) fn full_field<'a>(
    f: &'a FieldSpec,
    order: usize,
    occ: &'a dyn Occluder,
    sampler: &'a VisibilitySampler,
    points: &'a Points,
) -> FrameFn<'a> {
    let nn = order * order;
    let shells = f.shells();
    Box::new(move || {
        let t0 = Instant::now();
        let ff = FullField::build(occ, f.layout, sampler, &shells)?;
        let build = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let v = eval_all(&ff, points, nn);
        let eval = t1.elapsed().as_secs_f64();
        let (rays, mem) = (ff.rays as f64, ff.size_bytes() as f64);
        Ok(((v, rays, mem), [build, eval, build + eval]))
    })
}

/// The frame of ray tracing: `4T²` stratified rays per receiver, with a different seed from
/// the reference truth's (independent draws); nothing built, nothing held.
pub(crate) fn ray_traced<'a>(
    order: usize,
    rt_res: usize,
    truth_seed: u64,
    occ: &'a dyn Occluder,
    points: &'a Points,
) -> Result<FrameFn<'a>, Error> {
    let ts = TruthSampler::new(order, rt_res, truth_seed ^ 0x00ff_00ff_00ff)?;
    Ok(Box::new(move || {
        let t1 = Instant::now();
        let v: Vec<Vec<f64>> = (points.par_iter().enumerate())
            .map(|(i, (_, q))| ts.sample_stream(occ, *q, i as u64).coeffs)
            .collect();
        let eval = t1.elapsed().as_secs_f64();
        let rays = (points.len() * ts.rays()) as f64;
        Ok(((v, rays, 0.0), [0.0, eval, eval]))
    }))
}
