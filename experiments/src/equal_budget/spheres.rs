//! The kind `budget`: speed and accuracy at equal budget on spherical receivers. How accurate
//! is the visibility of SH-scaling extrapolation, of a fully sampled shadow field (Zhou et al.
//! 2005) and of direct ray tracing, for the rays cast, the bytes stored and the time a
//! deforming object allows per frame — and, separately, is the papers' claim true as stated:
//! "by sampling points only on bounding spheres and extrapolating … our method produces shadow
//! field data approximately 20 times faster than full shadow field computation" (SHS §4, TR
//! §4), a speed claim at the papers' sampling rates?
//!
//! Receivers: the probe points of the `probe` kind (seeded directions × `radii`, outside the
//! bounding sphere), their converged truth computed once per group. A run is one method and
//! budget ([`Spec`], parsed once). Per frame of a deforming object every method starts from
//! scratch ([`super::frames`]): extrapolation samples the BSV (P samples × H² rays; its k-table
//! is built once, before the frames, unless α is fitted to the BSV, then per frame), the full
//! field samples S shells of P samples each (S·P·H² rays) — by default as the papers build it,
//! at uniform radial intervals over [1, `shell_max`]·r = [1, 8]·r, trilinear; `shell_spacing =
//! "exp"`, `shell_max` = the largest receiver radius and `field_interp = "barycentric"` give
//! the receiver-sized variant — and ray tracing casts `4T²` stratified rays per receiver; then
//! each evaluates every receiver.
//!
//! Budget axes: `rays` and `memory_bytes` per frame are deterministic; `frame_seconds` is the
//! median of the timing procedure's repeats of one whole frame (sampling and evaluation
//! together), with the order-statistic confidence interval of the median
//! (`frame_seconds_lo`/`_hi`, coverage `timing_coverage`). Error against the converged truth:
//! the mean `occ_rel_l2` over the receivers with a 95 % interval (mean ± 1.96 s/√n), near the
//! object (ρ ≤ 1.3) and beyond, and the occlusion-weighted error
//! `sqrt(Σ‖S − S_true‖² / Σ‖S_occ,true‖²)`, which faint receivers do not dominate.

use super::frames::{self, FrameFn};
use super::receivers::{continuous_radii, oriented_occluder, CONTINUOUS};
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::probe::random_directions;
use shscale_field::truth::{Truth, TruthSampler};
use shscale_field::{Occluder, VisibilitySampler};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::MeshBvh;
use shscale_runner::check::Ends;
use shscale_runner::records::Results;
use shscale_runner::{Cost, Ctx, KeyError, Kind, Typed};
use shscale_scene::method::{Combine, RayTracedSpec, SetSpec, Spec, SphereFit, SubVolumeSpec};
use shscale_scene::Error;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use super::spheres_params::Params;
use super::spheres_rows::row_of;
pub use super::spheres_rows::{Row, Shared};

/// The kind.
pub struct Budget;

/// H of the contact classification of the receivers' directions.
pub const CONTACT_RES: usize = 32;
/// The most receivers per radius.
pub(crate) const MAX_RECEIVERS: usize = 100_000;

impl Kind for Budget {
    const NAME: &'static str = "budget";
    const QUESTION: &'static str = "On spherical receivers, for the rays, bytes and time a frame allows, which is most accurate — SH-scaling extrapolation, the fully sampled shadow field as Zhou et al. build it, or ray tracing — and is extrapolation's shadow-field data about 20× faster to produce than the full field's at the papers' sampling, as SHS §4 claims?";
    type Params = Params;
    type Shared = Shared;
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, Spec>;

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
            ("method", "`extrapolated`, `full_field`, `ray_traced`, `sub_volumes` (the mesh split into `parts`, each extrapolated from its own sphere, multiplied near to far; meshes only) or `sphere_set` (Ren et al. 2006's occluder model: one sphere fitted per part every frame, closed-form caps multiplied near to far; no rays; the analytic sphere is its own one-sphere set). A method key the method does not read (docs/methods.md) must keep its default"),
            ("parts", "parts of `sub_volumes`, or spheres S of `sphere_set`, 1..=64 and at most one per triangle (k-means on triangle centroids)"),
            ("layout", "base-sphere layout (extrapolation) or the layout of every shell (full field), as in `probe`"),
            ("hemisphere_res", "H: H² rays per BSV or shell sample, 1..=256"),
            ("shells", "shells of the full field over [s, shell_max·s]·r, 2..=64"),
            ("shell_max", "the full field's outermost shell in sampling radii, (1, 1000]; the papers' 8"),
            ("shell_spacing", "`uniform` (the papers': equal steps in ρ, linear in ρ between shells) or `exp` (equal steps in ln ρ)"),
            ("field_interp", "`trilinear` (the papers': the eight nearest samples of a latlong or cube grid) or `barycentric` (the layout's triangulation; any layout)"),
            ("rt_res", "T of the ray-traced method: 4T² stratified rays per receiver, 1..=1024"),
            ("alpha_deg", "cone angle α of the extrapolation, degrees, (0, 90); read with `alpha_mode = \"fixed\"` only"),
            ("alpha_mode", "`fixed` or `fit` (α by distance at the BSV's effective cap, as in `probe`; the table is then built per frame)"),
            ("plausibility", "`none` or `clamp` (the extrapolation's plausibility mitigation, as in `probe`)"),
            ("sampling_radius", "the extrapolation's sampling sphere, and the full field's innermost shell, in bounding radii, [1, 1000]"),
            ("radial", "where each base-sphere sample of `extrapolated` and `sub_volumes` lies along its direction: `uniform` (the papers': on the sampling sphere), `clearance` (moved outward until at least `radial_delta`·r from the surface; distance queries, no extra rays) or `occlusion` (moved outward until its facing hemisphere is occluded at most `radial_tau`, up to `radial_max`·r; each bisection step casts a hemisphere, counted in `rays`); the extrapolation uses k = d / r(q)"),
            ("radial_delta", "δ of `radial = \"clearance\"`, [0, 10] bounding radii"),
            ("radial_tau", "τ of `radial = \"occlusion\"`, [0, 1)"),
            ("radial_max", "the search's ceiling for `radial = \"occlusion\"`, [1, 10] bounding radii"),
            ("sphere_combine", "how `sphere_set` combines its spheres: `product` (truncated SH products near to far) `quadrature` (the set's joint visibility projected by a 64 × 128-direction Gauss–Legendre × uniform quadrature at every receiver: no truncated products; its 8,192 rays per receiver, cast at the spheres, are counted in `rays`) `union` (the same joint visibility, the caps' union integrated in φ in closed form on 32 Gauss–Legendre rings in z: no rays; docs/math.md, \"The union of the caps\") or `shexp` (SH exponentiation, Ren et al. 2006: the blockers' product-algebra logs, clamped at 2 % of the largest eigenvalue, summed and exponentiated by HYB; orders up to 8; docs/math.md, \"SH exponentiation\")"),
            ("sphere_fit", "which spheres `sphere_set` takes: `area` (default; one per k-means part, from the part's area-weighted centroid and RMS spread, refitted every frame) or `inscribed` (the greedy cover of the mesh's interior by inscribed balls on a 48-cell grid: every ball inside the solid and the sets nested in S, so the exact union's full-frequency error cannot rise with S; a one-off fit, timed in `partition_seconds`; docs/math.md, \"Inscribed sphere sets\")"),
            ("sphere_order", "the internal order M of `sphere_set` with `sphere_combine = \"product\"`: each cap projected to M, every product at M, the result truncated to `order` once (docs/math.md, \"Combining many spheres\"); 0 (default) for the run's order, else order..=16 (a product at M does about (M/4)⁵ the work of one at 4)"),
            ("part_combine", "how `sub_volumes` combines its parts: `product` (default; each part's scaled visibility multiplied near to far) or `shexp` (scaling in log space: each part's base-sphere samples replaced by their product-algebra logs, clamped at ε = 0.02, extrapolated with the part's own k, summed, and exponentiated once by HYB; orders up to 8, without the plausibility clamp; docs/math.md, \"SH exponentiation\")"),
            ("k_count", "k-table entries of the extrapolation, 2..=10000"),
            ("receiver_layout", "`grid` (default: `receivers` seeded directions at each of `radii`) or `continuous` (`receivers` points, each its own seeded direction and radius, ρ − 1 log-uniform over [rho_min − 1, rho_max − 1], stratified: every receiver its own distance and its own contact label)"),
            ("receivers", "receiver directions per radius (`grid`) or receiver points (`continuous`), seeded, 1..=100000"),
            ("rho_min", "the continuous layout's smallest receiver radius, bounding radii, (1, 1e3]"),
            ("rho_max", "the continuous layout's largest receiver radius, bounding radii, above rho_min"),
            ("probe_seed", "seed of the receiver directions (and the continuous layout's radii)"),
            ("truth_res", "T of the converged truth at the receivers, 1..=1024"),
            ("truth_seed", "seed of the truth"),
            ("orientation_seed", "the occluder's orientation against the world-fixed sampling grids: 0 (default) as loaded, any other seed a uniformly random rotation about its bounding sphere's centre"),
            ("radii", "receiver radii of the grid layout in bounding radii, each in (1, 1e3], distinct, 1 to 64"),
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
        let spec = p.spec()?;
        spec.check_order(p.order)?;
        if matches!(spec, Spec::SubVolumes(SubVolumeSpec { .. })) && p.mesh == "sphere" {
            return Err(KeyError::new(
                "mesh",
                "`sub_volumes` splits a mesh; the analytic sphere has none",
            ));
        }
        let max_truth = shscale_field::truth::MAX_TRUTH_RES;
        KeyError::int("truth_res", p.truth_res, 1, max_truth)?;
        KeyError::int("receivers", p.receivers, 1, MAX_RECEIVERS)?;
        p.check_receivers()?;
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
        Ok(Typed {
            params: p.clone(),
            typed: spec,
        })
    }

    /// [`Kind::resolve`], then the inscribed fit's mesh checked: one with no inside, or above
    /// the fit's bound, refused naming `sphere_fit` and the mesh before any work.
    fn resolve_in(p: &Params, _config_dir: &std::path::Path) -> Result<Self::Spec, KeyError> {
        let spec = Self::resolve(p)?;
        if let Spec::SphereSet(SetSpec {
            fit: SphereFit::Inscribed,
            ..
        }) = spec.typed
        {
            if p.mesh != "sphere" {
                crate::common::inscribed_work(&p.mesh, p.orientation_seed)?;
            }
        }
        Ok(spec)
    }

    fn group_key(p: &Params) -> String {
        format!(
            "{};{};{};{};{};{};{:?};{};{};{};{}",
            p.mesh,
            p.order,
            p.receivers,
            p.probe_seed,
            p.truth_res,
            p.truth_seed,
            p.radii,
            p.receiver_layout,
            p.rho_min,
            p.rho_max,
            p.orientation_seed
        )
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        let n = p.receiver_count() as f64;
        let t4 = 4.0 * (p.truth_res * p.truth_res) as f64;
        let nn = (p.order * p.order) as f64;
        // The truths, and the contact classification of the directions.
        let contact_rays = (p.receivers * CONTACT_RES * CONTACT_RES) as f64;
        let shared_rays = if p.mesh == "sphere" {
            contact_rays
        } else {
            n * t4 + contact_rays
        };
        let rays = p.typed.rays(1.0, n);
        (
            Cost {
                cached_once: None,
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
                // The inscribed fit: once per mesh and orientation, whatever the runs using it.
                cached_once: match p.typed {
                    Spec::SphereSet(SetSpec {
                        fit: SphereFit::Inscribed,
                        ..
                    }) if p.mesh != "sphere" => Some((
                        format!("inscribed {} {}", p.mesh, p.orientation_seed),
                        crate::common::inscribed_work(&p.mesh, p.orientation_seed).map_or(
                            shscale_geometry::inscribed::INSCRIBED_FIT_SECONDS,
                            shscale_geometry::inscribed::inscribed_fit_seconds,
                        ),
                    )),
                    _ => None,
                },
                // One frame; the estimate multiplies its seconds by the timing procedure's
                // warm-up + repeats (the rays counted are one frame's).
                rays,
                bytes: p.typed.memory_bytes(p.order, 1.0, p.k_count),
                // Every method's frame ran at 1.9–2.4e7 rays/s in `configs/experiments/
                // budget.toml` (the `rays` and `frame_seconds` columns): the truths' rate.
                seconds: p.typed.seconds(
                    p.order,
                    rays,
                    n,
                    shscale_runner::timing::TRUTH_RAYS_PER_SECOND,
                ),
                once_seconds: 0.0,
                drivers: format!("method {} → {rays:.3e} rays per frame", p.typed.method()),
            },
        )
    }

    fn rows_per_run(_: &Params) -> usize {
        1
    }

    fn shared(p: &Self::Spec, _: &Ctx) -> Result<Shared, Error> {
        let u = oriented_occluder(&p.mesh, p.orientation_seed)?;
        let (occ, mesh) = (u.occ, u.mesh);
        let s = occ.bounding_sphere();
        // The receivers: the probe kind's seeded directions, at every radius of the grid or
        // each at its own radius.
        let dirs = random_directions(p.probe_seed, p.receivers);
        let (rhos, dir_of): (Vec<f64>, Vec<usize>) = if p.receiver_layout == CONTINUOUS {
            let rho = continuous_radii(p.probe_seed, p.receivers, p.rho_min, p.rho_max);
            (rho, (0..p.receivers).collect())
        } else {
            (p.radii.iter())
                .flat_map(|&rho| (0..dirs.len()).map(move |i| (rho, i)))
                .unzip()
        };
        let points: Vec<(f64, DVec3)> = (rhos.iter().zip(&dir_of))
            .map(|(&rho, &i)| (rho, s.center + rho * s.radius * dirs[i]))
            .collect();
        let ts = TruthSampler::new(p.order, p.truth_res, p.truth_seed)?;
        let basis = shscale_sh::ShBasis::<f64>::new(p.order).map_err(Error::from)?;
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
        // Each receiver's distance to the surface, in bounding radii (the exact point-to-
        // triangle distance through the BVH; the analytic sphere's is ρ − 1).
        let surface: Vec<f64> = (points.par_iter())
            .map(|(_, q)| occ.distance_to_surface(*q) / s.radius)
            .collect();
        let facing = VisibilitySampler::new(p.order, CONTACT_RES)?;
        let contact_dir: Vec<bool> = (dirs.par_iter())
            .map(|d| {
                let q = s.center + s.radius * *d;
                let (v, _) = facing.facing_hemisphere(
                    occ.as_ref(),
                    q,
                    s.center,
                    shscale_field::Frame::Entity,
                );
                shscale_field::metrics::facing_occlusion(&v)
                    >= shscale_field::probe::DEFAULT_CONTACT_OCCLUSION
            })
            .collect();
        let contact = dir_of.iter().map(|&i| contact_dir[i]).collect();
        Ok(Shared {
            occ,
            mesh,
            points,
            dir_of,
            surface,
            truth,
            contact,
        })
    }

    fn run(p: &Self::Spec, _: &str, sh: &Shared, ctx: &Ctx) -> Result<Vec<Row>, Error> {
        let occ = sh.occ.as_ref();
        let order = p.order;
        // The partition of sub-volumes and sphere sets: once per run (per triangle, so a
        // deforming mesh would keep it over its sequence); its time is its own column. The
        // sub-volumes' part meshes and BVHs are built with it; the spheres are refitted every
        // frame.
        let sampler = match &p.typed {
            Spec::Extrapolated(e) | Spec::SubVolumes(SubVolumeSpec { ex: e, .. }) => {
                e.hemisphere_res
            }
            Spec::FullField(f) => f.hemisphere_res,
            _ => 1,
        };
        let sampler = VisibilitySampler::new(order, sampler)?;
        let t0 = Instant::now();
        let partition = |parts: usize| -> Result<Option<Vec<u32>>, Error> {
            (sh.mesh.as_ref())
                .map(|m| shscale_geometry::partition::kmeans_parts(m, parts))
                .transpose()
                .map_err(Error::from)
        };
        let part_bvhs: Vec<MeshBvh>;
        let mut partition_seconds = None;
        let mut frame: FrameFn<'_> = match &p.typed {
            Spec::Extrapolated(ex) => {
                let range = shscale_field::probe::k_range(&p.radius_span(), ex.sampling_radius);
                let k = (order, p.k_count);
                let parts = vec![(occ, range)];
                frames::extrapolation(ex, k, (parts, Combine::Product), &sampler, &sh.points)?
            }
            Spec::SubVolumes(SubVolumeSpec { parts, ex, combine }) => {
                let (Some(mesh), Some(labels)) = (sh.mesh.as_ref(), partition(*parts)?) else {
                    return Err(Error::config(
                        "`sub_volumes` splits a mesh; the analytic sphere has none".into(),
                    ));
                };
                part_bvhs = (shscale_geometry::partition::split(mesh, &labels, *parts).iter())
                    .map(|m| MeshBvh::build(m, UpdateStrategy::Rebuild))
                    .collect();
                partition_seconds = Some(t0.elapsed().as_secs_f64());
                let parts = (
                    part_ranges(&part_bvhs, ex.sampling_radius, &sh.points),
                    *combine,
                );
                frames::extrapolation(ex, (order, p.k_count), parts, &sampler, &sh.points)?
            }
            Spec::SphereSet(set) => {
                let source;
                (source, partition_seconds) = set_source(set.fit, set.parts, sh, occ)?;
                frames::sphere_set(order, set, source, &sh.points)?
            }
            Spec::FullField(f) => frames::full_field(f, order, occ, &sampler, &sh.points),
            Spec::RayTraced(RayTracedSpec { rt_res }) => {
                frames::ray_traced(order, *rt_res, p.truth_seed, occ, &sh.points)?
            }
        };
        let (values, times) = ctx.timing.measure_parts(&mut *frame)?;
        Ok(vec![Row {
            partition_seconds,
            ..row_of(sh, values, times)
        }])
    }

    fn time_columns() -> &'static [&'static str] {
        &[
            "build_seconds",
            "eval_seconds",
            "frame_seconds",
            "frame_seconds_lo",
            "frame_seconds_hi",
            "partition_seconds",
        ]
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "method",
            "rays",
            "frame_seconds",
            "memory_bytes",
            "occ_rel_l2_mean",
            "occ_weighted",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        super::spheres_report::report(dir, t)
    }

    fn verdict(t: &Results) -> Result<String, Error> {
        super::spheres_report::verdict(t)
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        super::spheres_report::discussion(t)
    }
}

/// Where a run's sphere set comes from, and the one-off seconds it took: the mesh's inscribed
/// balls (the fit's own cost, also when an earlier run of the mesh made it), or its k-means
/// partition whose parts are refitted every frame; the analytic sphere is its own set.
fn set_source<'a>(
    fit: SphereFit,
    parts: usize,
    sh: &'a Shared,
    occ: &dyn Occluder,
) -> Result<(frames::SetSource<'a>, Option<f64>), Error> {
    let t0 = Instant::now();
    match (fit, sh.mesh.as_ref()) {
        (SphereFit::Inscribed, Some(m)) => {
            let (set, seconds) = shscale_geometry::inscribed::inscribed_set(m, parts)
                .map_err(|e| Error::config(format!("sphere_fit: {e}")))?;
            Ok((frames::SetSource::Fixed(set), Some(seconds)))
        }
        (_, Some(m)) => {
            let labels =
                shscale_geometry::partition::kmeans_parts(m, parts).map_err(Error::from)?;
            let seconds = t0.elapsed().as_secs_f64();
            Ok((frames::SetSource::Refit(m, labels), Some(seconds)))
        }
        (_, None) => Ok((frames::SetSource::Fixed(vec![occ.bounding_sphere()]), None)),
    }
}

/// Each sub-volume part with its k range: its receivers' distances over its sampling radius
/// (`sampling_radius` times its bounding radius), with 5 % margins.
fn part_ranges<'a>(
    parts: &'a [MeshBvh],
    sampling_radius: f64,
    points: &[(f64, DVec3)],
) -> Vec<(&'a dyn Occluder, (f64, f64))> {
    (parts.iter())
        .map(|b| {
            let s = b.bounding_sphere();
            let range = shscale_field::probe::k_range_to(
                s.center,
                s.radius * sampling_radius,
                points.iter().map(|(_, q)| *q),
                1.05,
            );
            (b as &dyn Occluder, range)
        })
        .collect()
}
