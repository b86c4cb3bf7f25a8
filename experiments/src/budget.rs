//! Speed and accuracy at equal budget on spherical receivers: how accurate is the visibility of
//! SH-scaling extrapolation, of a fully sampled shadow field (Zhou et al. 2005) and of direct ray
//! tracing, for the rays cast, the bytes stored and the time a deforming object allows per frame
//! — and, separately, is the papers' claim true as stated: "by sampling points only on bounding
//! spheres and extrapolating … our method produces shadow field data approximately 20 times
//! faster than full shadow field computation" (SHS §4, TR §4), a speed claim at the papers'
//! sampling rates?
//!
//! Receivers: the probe points of the `probe` kind (seeded directions × `radii`, outside the
//! bounding sphere), their converged truth computed once per group. A run is one method and
//! budget. Per frame of a deforming object every method starts from scratch: extrapolation
//! samples the BSV (P samples × H² rays; its k-table is built once, before the frames, unless α
//! is fitted to the BSV, then per frame), the full field samples S shells of P samples each
//! (S·P·H² rays) — by default as the papers build it, at uniform radial intervals over
//! [1, `shell_max`]·r = [1, 8]·r, trilinear; `shell_spacing = "exp"`, `shell_max` = the largest
//! receiver radius and `field_interp = "barycentric"` give the receiver-sized variant — and ray
//! tracing casts `4T²` stratified rays per receiver; then each evaluates every receiver.
//!
//! Budget axes: `rays` and `memory_bytes` per frame are deterministic; `frame_seconds` is the
//! median of the timing procedure's repeats of one whole frame (sampling and evaluation
//! together), with the order-statistic confidence interval of the median
//! (`frame_seconds_lo`/`_hi`, coverage `timing_coverage`). Error against the converged truth:
//! the mean `occ_rel_l2` over the receivers with a 95 % interval (mean ± 1.96 s/√n), near the
//! object (ρ ≤ 1.3) and beyond, and the occlusion-weighted error
//! `sqrt(Σ‖S − S_true‖² / Σ‖S_occ,true‖²)`, which faint receivers do not dominate.

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use shscale_field::bsv::RadialRule;
use shscale_field::evaluator::{FieldInterp, FullField, ShellSpacing, Shells, VisibilityField};
use shscale_field::extrapolate::{Extrapolator, Plausibility};
use shscale_field::metrics::{l2, l2_diff, mean_max, occlusion};
use shscale_field::probe::random_directions;
use shscale_field::sphereset::{QuadratureGrid, SphereSetField, SphereSetQuadrature};
use shscale_field::subvolume::SubVolumeField;
use shscale_field::truth::{Truth, TruthSampler};
use shscale_field::Occluder;
use shscale_field::{Bsv, Layout, VisibilitySampler};
use shscale_runner::check::Ends;
use shscale_runner::plots::{write_scatter_with_bars, Labels};
use shscale_runner::records::{list, Results};
use shscale_runner::{Cost, Ctx, Device, GpuMode, KeyError, Kind, Typed};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Parameters of one run (one method at one budget).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    pub mesh: String,
    pub order: usize,
    /// `extrapolated`, `full_field`, `ray_traced`, `sub_volumes` or `sphere_set`.
    pub method: String,
    /// Parts of the `sub_volumes` method, or spheres of `sphere_set`, 1..=64 (k-means on
    /// triangle centroids).
    pub parts: usize,
    /// Base-sphere layout (extrapolation) or per-shell layout (full field).
    pub layout: String,
    /// H: H² rays per BSV or shell sample.
    pub hemisphere_res: usize,
    /// Shells of the full field, 2..=64 (ignored by the other methods).
    pub shells: usize,
    /// The outermost shell in bounding radii, (1, 1e3] (the innermost is 1).
    pub shell_max: f64,
    /// `uniform` (the papers') or `exp`.
    pub shell_spacing: String,
    /// `trilinear` (the papers', grid layouts) or `barycentric`.
    pub field_interp: String,
    /// T of the ray-traced method (4T² rays per receiver; ignored by the others).
    pub rt_res: usize,
    pub alpha_deg: f64,
    /// `fixed` or `fit` (α by distance at the BSV's effective cap, as in `probe`).
    pub alpha_mode: String,
    /// `none` or `clamp` (the plausibility mitigation, as in `probe`).
    pub plausibility: String,
    /// The extrapolation's sampling sphere in bounding radii, [1, 1e3].
    pub sampling_radius: f64,
    /// Where each base-sphere sample lies along its direction: `uniform` (the papers'),
    /// `clearance` (at least `radial_delta`·r from the surface) or `occlusion` (facing
    /// occlusion at most `radial_tau`, searched up to `radial_max`·r).
    pub radial: String,
    pub radial_delta: f64,
    pub radial_tau: f64,
    pub radial_max: f64,
    /// How `sphere_set` combines its spheres: `product` (the truncated SH products near to
    /// far, as every multi-occluder method here) or `quadrature` (the set's joint visibility
    /// projected by a `SPHERE_QUADRATURE_RES`-node quadrature, no truncated products).
    pub sphere_combine: String,
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
            parts: 4,
            layout: "latlong:12x20".into(),
            hemisphere_res: 32,
            shells: 16,
            shell_max: 8.0,
            shell_spacing: "uniform".into(),
            field_interp: "trilinear".into(),
            rt_res: 8,
            alpha_deg: 45.0,
            alpha_mode: "fixed".into(),
            plausibility: "none".into(),
            sampling_radius: 1.0,
            radial: "uniform".into(),
            radial_delta: 0.1,
            radial_tau: 0.5,
            radial_max: 2.0,
            sphere_combine: "product".into(),
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
    /// Rays cast per frame (deterministic).
    pub rays: f64,
    /// Bytes the method holds (deterministic): BSV and k-table, the shells, or nothing.
    pub memory_bytes: f64,
    /// One frame (sampling, table if per frame, evaluation of every receiver): the median of the
    /// timing procedure's repeats and the order-statistic interval of that median.
    pub frame_seconds: f64,
    pub frame_seconds_lo: f64,
    pub frame_seconds_hi: f64,
    pub timing_coverage: f64,
    /// The sampling part and the evaluation part of the frame (medians).
    pub build_seconds: f64,
    pub eval_seconds: f64,
    /// `sub_volumes`: the partition (k-means, the parts' meshes and BVHs), once per run — for a
    /// deforming mesh once per sequence, as the partition is per triangle.
    pub partition_seconds: Option<f64>,
    /// Mean `occ_rel_l2` over the receivers, with the half-width of its 95 % interval.
    pub occ_rel_l2_mean: Option<f64>,
    pub occ_rel_l2_ci95: Option<f64>,
    /// The same near the object (ρ ≤ 1.3) and beyond.
    pub occ_rel_l2_near_mean: Option<f64>,
    pub occ_rel_l2_near_ci95: Option<f64>,
    pub occ_rel_l2_far_mean: Option<f64>,
    pub occ_rel_l2_far_ci95: Option<f64>,
    /// Occlusion-weighted: `sqrt(Σ‖S − S_true‖² / Σ‖S_occ,true‖²)`, all, near, far.
    pub occ_weighted: Option<f64>,
    pub occ_weighted_near: Option<f64>,
    pub occ_weighted_far: Option<f64>,
    /// Receivers in contact directions ([`Shared::contact`]) and their mean `occ_rel_l2` with
    /// its 95 % interval: where the papers' base-sphere samples touch the surface.
    pub contact_points: usize,
    pub occ_rel_l2_contact_mean: Option<f64>,
    pub occ_rel_l2_contact_ci95: Option<f64>,
    pub truth_rel_err_mean: Option<f64>,
}

/// The kind.
pub struct Budget;

/// What runs of a group share: the occluder, the receivers and their truth.
pub struct Shared {
    occ: Box<dyn shscale_geometry::Occluder>,
    /// The mesh (none for the analytic sphere), for the sub-volumes' partition.
    mesh: Option<shscale_geometry::Mesh>,
    points: Vec<(f64, DVec3)>,
    truth: Vec<Option<Truth>>,
    /// Per receiver: its direction is a contact direction — the bounding sphere's point in that
    /// direction has its facing hemisphere occluded at least
    /// [`shscale_field::probe::DEFAULT_CONTACT_OCCLUSION`] (docs/conventions.md §7), measured
    /// once per group with [`CONTACT_RES`]² rays. Every direction of the analytic sphere is.
    contact: Vec<bool>,
}

/// H of the contact classification of the receivers' directions.
pub const CONTACT_RES: usize = 32;

/// The methods of `budget` and `budget_plane`.
pub(crate) const METHODS: [&str; 5] = [
    "extrapolated",
    "full_field",
    "ray_traced",
    "sub_volumes",
    "sphere_set",
];
/// The most shells of a full field.
pub const MAX_SHELLS: usize = 64;
/// The most receivers per radius.
pub const MAX_RECEIVERS: usize = 100_000;

/// Mean and the half-width of its normal 95 % interval, `1.96·s/√n` (s the sample standard
/// deviation; `None` for fewer than 2 values).
pub fn mean_ci95(v: &[f64]) -> (Option<f64>, Option<f64>) {
    let m = mean_max(v.iter().map(|x| Some(*x))).0;
    let ci = (v.len() >= 2).then(|| {
        let m = m.unwrap_or(0.0);
        let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
        1.96 * (var / v.len() as f64).sqrt()
    });
    (m, ci)
}

/// One receiver's error: its radius, `‖S − S_true‖²`, `‖S_occ,true‖²` and the truth's own error.
struct Err2 {
    rho: f64,
    /// The receiver's direction is a contact direction ([`Shared::contact`]).
    contact: bool,
    diff2: f64,
    occ2: f64,
    truth_rel: Option<f64>,
}

/// The error columns over the receivers `e` passing `keep`: mean `occ_rel_l2` (receivers with
/// something occluded, ‖S_occ‖ > 1e-12) with its interval, and the occlusion-weighted error.
fn scores(e: &[Err2], keep: impl Fn(&Err2) -> bool) -> (Option<f64>, Option<f64>, Option<f64>) {
    let kept: Vec<&Err2> = e.iter().filter(|x| keep(x)).collect();
    let rel: Vec<f64> = (kept.iter())
        .filter(|x| x.occ2 > 1e-24)
        .map(|x| (x.diff2 / x.occ2).sqrt())
        .collect();
    let (m, ci) = mean_ci95(&rel);
    let (d, o) = (kept.iter()).fold((0.0, 0.0), |(d, o), x| (d + x.diff2, o + x.occ2));
    (m, ci, (o > 1e-24).then(|| (d / o).sqrt()))
}

/// The near regime: receivers within 1.3 bounding radii.
pub const NEAR_RHO: f64 = 1.3;

impl Kind for Budget {
    const NAME: &'static str = "budget";
    const QUESTION: &'static str = "On spherical receivers, for the rays, bytes and time a frame allows, which is most accurate — SH-scaling extrapolation, the fully sampled shadow field as Zhou et al. build it, or ray tracing — and is extrapolation's shadow-field data about 20× faster to produce than the full field's at the papers' sampling, as SHS §4 claims?";
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
            ("method", "`extrapolated`, `full_field`, `ray_traced`, `sub_volumes` (the mesh split into `parts`, each extrapolated from its own sphere, multiplied near to far; meshes only) or `sphere_set` (Ren et al. 2006's occluder model: one sphere fitted per part every frame, closed-form caps multiplied near to far; no rays; the analytic sphere is its own one-sphere set)"),
            ("parts", "parts of `sub_volumes`, or spheres S of `sphere_set`, 1..=64 and at most one per triangle (k-means on triangle centroids)"),
            ("layout", "base-sphere layout (extrapolation) or the layout of every shell (full field), as in `probe`"),
            ("hemisphere_res", "H: H² rays per BSV or shell sample, 1..=256"),
            ("shells", "shells of the full field over [1, shell_max]·r, 2..=64"),
            ("shell_max", "the full field's outermost shell in bounding radii, (1, 1000]; the papers' 8"),
            ("shell_spacing", "`uniform` (the papers': equal steps in ρ, linear in ρ between shells) or `exp` (equal steps in ln ρ)"),
            ("field_interp", "`trilinear` (the papers': the eight nearest samples of a latlong or cube grid) or `barycentric` (the layout's triangulation; any layout)"),
            ("rt_res", "T of the ray-traced method: 4T² stratified rays per receiver, 1..=1024"),
            ("alpha_deg", "cone angle α of the extrapolation, degrees, (0, 90)"),
            ("alpha_mode", "`fixed` or `fit` (α by distance at the BSV's effective cap, as in `probe`; the table is then built per frame)"),
            ("plausibility", "`none` or `clamp` (the extrapolation's plausibility mitigation, as in `probe`)"),
            ("sampling_radius", "the extrapolation's sampling sphere in bounding radii, [1, 1000]"),
            ("radial", "where each base-sphere sample of `extrapolated` and `sub_volumes` lies along its direction: `uniform` (the papers': on the sampling sphere), `clearance` (moved outward until at least `radial_delta`·r from the surface; distance queries, no extra rays) or `occlusion` (moved outward until its facing hemisphere is occluded at most `radial_tau`, up to `radial_max`·r; each bisection step casts a hemisphere, counted in `rays`); the extrapolation uses k = d / r(q)"),
            ("radial_delta", "δ of `radial = \"clearance\"`, [0, 10] bounding radii"),
            ("radial_tau", "τ of `radial = \"occlusion\"`, [0, 1)"),
            ("radial_max", "the search's ceiling for `radial = \"occlusion\"`, [1, 10] bounding radii"),
            ("sphere_combine", "how `sphere_set` combines its spheres: `product` (truncated SH products near to far) or `quadrature` (the set's joint visibility projected by a 64 × 128-direction Gauss–Legendre × uniform quadrature at every receiver: no truncated products; its 8,192 rays per receiver, cast at the spheres, are counted in `rays`)"),
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
        if p.method == "sub_volumes" && p.mesh == "sphere" {
            return Err(KeyError::new(
                "mesh",
                "`sub_volumes` splits a mesh; the analytic sphere has none",
            ));
        }
        KeyError::int("parts", p.parts, 1, shscale_geometry::partition::MAX_PARTS)?;
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
        KeyError::real("shell_max", p.shell_max, 1.0, 1e3, Ends::OpenClosed)?;
        KeyError::real("sampling_radius", p.sampling_radius, 1.0, 1e3, Ends::Closed)?;
        let shells = shells_of(p).map_err(|(k, m)| KeyError::new(k, m))?;
        if p.method == "full_field" {
            shells
                .check(layout)
                .map_err(|e| KeyError::new("field_interp", e.to_string()))?;
        }
        Plausibility::parse(&p.plausibility).map_err(|m| KeyError::new("plausibility", m))?;
        crate::probe::parse_alpha_mode(&p.alpha_mode)
            .map_err(|m| KeyError::new("alpha_mode", m))?;
        radial_of(&p.radial, p.radial_delta, p.radial_tau, p.radial_max)?;
        if !matches!(p.sphere_combine.as_str(), "product" | "quadrature") {
            return Err(KeyError::new(
                "sphere_combine",
                format!(
                    "{:?} is not one of \"product\", \"quadrature\"",
                    p.sphere_combine
                ),
            ));
        }
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
        // The truths, and the contact classification of the directions.
        let contact_rays = (p.receivers * CONTACT_RES * CONTACT_RES) as f64;
        let shared_rays = if p.mesh == "sphere" {
            contact_rays
        } else {
            n * t4 + contact_rays
        };
        // The occlusion rule's search casts up to two ends and its halvings per sample.
        let search = if p.radial == "occlusion" {
            (2 + shscale_field::bsv::OCCLUSION_STEPS) as f64
        } else {
            1.0
        };
        let rays = match p.method.as_str() {
            "extrapolated" => search * samples * h2,
            "full_field" => p.shells as f64 * samples * h2,
            "sub_volumes" => search * p.parts as f64 * samples * h2,
            "sphere_set" if p.sphere_combine == "quadrature" => {
                n * (2 * SPHERE_QUADRATURE_RES * SPHERE_QUADRATURE_RES) as f64
            }
            "sphere_set" => 0.0,
            _ => n * 4.0 * (p.rt_res * p.rt_res) as f64,
        };
        let shells = match p.method.as_str() {
            "full_field" => p.shells as f64,
            "sub_volumes" => p.parts as f64,
            "sphere_set" => 0.0,
            _ => 1.0,
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
                // The quadrature's rays meet spheres, not the mesh: priced per direction and
                // sphere test instead.
                seconds: if p.method == "sphere_set" && p.sphere_combine == "quadrature" {
                    rays * (SPHERE_DIRECTION_SECONDS + p.parts as f64 * SPHERE_TEST_SECONDS)
                } else {
                    rays / shscale_runner::timing::TRUTH_RAYS_PER_SECOND
                        + n * sphere_set_seconds(&p.method, p.parts)
                },
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
        let (occ, mesh) = (u.occ, u.mesh);
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
        let contact = (p.radii.iter())
            .flat_map(|_| contact_dir.iter().copied())
            .collect();
        Ok(Shared {
            occ,
            mesh,
            points,
            truth,
            contact,
        })
    }

    fn run(p: &Self::Spec, _: &str, sh: &Shared, ctx: &Ctx) -> Result<Vec<Row>, Error> {
        let occ = sh.occ.as_ref();
        let layout = p.typed;
        let nn = p.order * p.order;
        let sampler = VisibilitySampler::new(p.order, p.hemisphere_res)?;
        let mut partition_seconds = None;
        // The partition of `sub_volumes` and `sphere_set`: once per run (per triangle, so a
        // deforming mesh would keep it over its sequence); its time is its own column. The
        // sub-volumes' part meshes and BVHs are built with it; the spheres are refitted every
        // frame.
        let mut labels: Option<Vec<u32>> = None;
        let mut part_bvhs: Vec<shscale_geometry::MeshBvh> = Vec::new();
        if let ("sub_volumes" | "sphere_set", Some(mesh)) = (p.method.as_str(), sh.mesh.as_ref()) {
            let t0 = Instant::now();
            let l = shscale_geometry::partition::kmeans_parts(mesh, p.parts)
                .map_err(|e| Error::config(e.to_string()))?;
            if p.method == "sub_volumes" {
                part_bvhs = (shscale_geometry::partition::split(mesh, &l, p.parts).iter())
                    .map(|m| {
                        shscale_geometry::MeshBvh::build(
                            m,
                            shscale_geometry::ray::UpdateStrategy::Rebuild,
                        )
                    })
                    .collect();
            }
            partition_seconds = Some(t0.elapsed().as_secs_f64());
            labels = Some(l);
        } else if p.method == "sub_volumes" {
            return Err(Error::config(
                "`sub_volumes` splits a mesh; the analytic sphere has none".into(),
            ));
        }
        let frame: FrameFn<'_> = match p.method.as_str() {
            "extrapolated" => {
                let range = shscale_field::probe::k_range(&p.radii, p.sampling_radius);
                extrapolation_frame(p, vec![(occ, range)], &sampler, &sh.points)?
            }
            "sub_volumes" => {
                // Each part's k range: its receivers' distances over its sampling radius, with
                // 5 % margins.
                let parts = (part_bvhs.iter())
                    .map(|b| {
                        let s = b.bounding_sphere();
                        let range = shscale_field::probe::k_range_to(
                            s.center,
                            s.radius * p.sampling_radius,
                            sh.points.iter().map(|(_, q)| *q),
                            1.05,
                        );
                        (b as &dyn Occluder, range)
                    })
                    .collect();
                extrapolation_frame(p, parts, &sampler, &sh.points)?
            }
            "sphere_set" => {
                let basis = shscale_sh::ShBasis::<f64>::new(p.order)
                    .map_err(|e| Error::config(e.to_string()))?;
                let gaunt = shscale_sh::GauntTensor::<f64>::new(p.order)
                    .map_err(|e| Error::config(e.to_string()))?;
                let mesh = sh.mesh.as_ref();
                let grid = (p.sphere_combine == "quadrature")
                    .then(|| QuadratureGrid::new(&basis, SPHERE_QUADRATURE_RES));
                Box::new(move || {
                    let t0 = Instant::now();
                    // The analytic sphere is its own one-sphere set.
                    let spheres = match (mesh, &labels) {
                        (Some(m), Some(l)) => {
                            shscale_geometry::partition::fit_spheres(m, l, p.parts)
                        }
                        _ => vec![occ.bounding_sphere()],
                    };
                    let build = t0.elapsed().as_secs_f64();
                    let t1 = Instant::now();
                    // The quadrature casts a ray per grid direction and receiver at the
                    // spheres (not at the mesh): counted as rays.
                    let (v, rays, bytes) = match &grid {
                        Some(g) => {
                            let set = SphereSetQuadrature::new(&spheres, g);
                            (
                                eval_all(&set, &sh.points, nn),
                                sh.points.len() * g.len(),
                                spheres.len() * 32 + g.size_bytes(),
                            )
                        }
                        None => {
                            let set = SphereSetField::new(&spheres, &basis, &gaunt);
                            (eval_all(&set, &sh.points, nn), 0, set.size_bytes())
                        }
                    };
                    let eval = t1.elapsed().as_secs_f64();
                    Ok(((v, rays as f64, bytes as f64), [build, eval, build + eval]))
                })
            }
            "full_field" => {
                let shells = shells_of(p).map_err(|(_, m)| Error::config(m))?;
                let sampler = &sampler;
                Box::new(move || {
                    let t0 = Instant::now();
                    let ff = FullField::build(occ, layout, sampler, &shells)?;
                    let build = t0.elapsed().as_secs_f64();
                    let t1 = Instant::now();
                    let v = eval_all(&ff, &sh.points, nn);
                    let eval = t1.elapsed().as_secs_f64();
                    let (rays, mem) = (ff.rays as f64, ff.size_bytes() as f64);
                    Ok(((v, rays, mem), [build, eval, build + eval]))
                })
            }
            _ => {
                // A different seed from the reference truth's: independent draws.
                let ts = TruthSampler::new(p.order, p.rt_res, p.truth_seed ^ 0x00ff_00ff_00ff)?;
                Box::new(move || {
                    let t1 = Instant::now();
                    let v: Vec<Vec<f64>> = (sh.points.par_iter().enumerate())
                        .map(|(i, (_, q))| ts.sample_stream(occ, *q, i as u64).coeffs)
                        .collect();
                    let eval = t1.elapsed().as_secs_f64();
                    let rays = (sh.points.len() * ts.rays()) as f64;
                    Ok(((v, rays, 0.0), [0.0, eval, eval]))
                })
            }
        };
        let mut frame = frame;
        let ((values, rays, memory), [build, eval, total]) =
            ctx.timing.measure_parts(&mut *frame)?;
        let errs: Vec<Err2> = (values.iter().zip(&sh.truth).zip(&sh.points))
            .zip(&sh.contact)
            .filter_map(|(((v, t), (rho, _)), contact)| {
                let t = t.as_ref()?;
                Some(Err2 {
                    rho: *rho,
                    contact: *contact,
                    diff2: l2_diff(v, &t.coeffs).powi(2),
                    occ2: l2(&occlusion(&t.coeffs)).powi(2),
                    truth_rel: t.rel_error(),
                })
            })
            .collect();
        let (m, ci, w) = scores(&errs, |_| true);
        let (mn, cin, wn) = scores(&errs, |e| e.rho <= NEAR_RHO);
        let (mf, cif, wf) = scores(&errs, |e| e.rho > NEAR_RHO);
        let (mc, cic, _) = scores(&errs, |e| e.contact);
        Ok(vec![Row {
            receiver_points: sh.points.len(),
            rays,
            memory_bytes: memory,
            frame_seconds: total.median,
            frame_seconds_lo: total.lo,
            frame_seconds_hi: total.hi,
            timing_coverage: total.coverage,
            build_seconds: build.median,
            eval_seconds: eval.median,
            partition_seconds,
            occ_rel_l2_mean: m,
            occ_rel_l2_ci95: ci,
            occ_rel_l2_near_mean: mn,
            occ_rel_l2_near_ci95: cin,
            occ_rel_l2_far_mean: mf,
            occ_rel_l2_far_ci95: cif,
            occ_weighted: w,
            occ_weighted_near: wn,
            occ_weighted_far: wf,
            contact_points: sh.contact.iter().filter(|c| **c).count(),
            occ_rel_l2_contact_mean: mc,
            occ_rel_l2_contact_ci95: cic,
            truth_rel_err_mean: mean_max(
                errs.iter().filter(|e| e.occ2 > 1e-24).map(|e| e.truth_rel),
            )
            .0,
        }])
    }

    fn time_columns() -> &'static [&'static str] {
        &["build_seconds", "eval_seconds", "frame_seconds"]
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
        let mut files = Vec::new();
        for (mesh, order) in distinct_pairs(t, "mesh", "order") {
            let of = |r: usize| t.cell(r, "mesh") == mesh && t.cell(r, "order") == order;
            // A mesh given as a path is named by its file stem in the plot's file name.
            let m = plot_name(&mesh);
            for (x, stem, xl, short) in [
                (
                    "rays",
                    format!("pareto_rays_{m}_n{order}"),
                    "rays per frame",
                    "rays",
                ),
                (
                    "memory_bytes",
                    format!("pareto_memory_{m}_n{order}"),
                    "memory (bytes)",
                    "memory",
                ),
                (
                    "frame_seconds",
                    format!("pareto_time_{m}_n{order}"),
                    "time per frame (s; bars: interval of the median)",
                    "time",
                ),
            ] {
                let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
                let mut bars = Vec::new();
                for r in (0..t.rows.len()).filter(|&r| of(r)) {
                    let (xv, y) = (t.num(r, x), t.num(r, "occ_rel_l2_mean"));
                    if xv.is_finite() && xv > 0.0 && y.is_finite() {
                        series.entry(variant(t, r)).or_default().push((xv, y));
                        if x == "frame_seconds" {
                            bars.push((
                                y,
                                t.num(r, "frame_seconds_lo"),
                                t.num(r, "frame_seconds_hi"),
                            ));
                        }
                    }
                }
                for v in series.values_mut() {
                    v.sort_by(|a, b| a.0.total_cmp(&b.0));
                }
                if series.is_empty() {
                    continue;
                }
                let front = pareto(series.values().flatten().copied());
                let labels = Labels {
                    title: &format!("{mesh}, N = {order}: error against {short}"),
                    x: xl,
                    y: "mean occ_rel_l2 (spherical receivers)",
                };
                let bars = if x == "frame_seconds" { &bars[..] } else { &[] };
                files.extend(write_scatter_with_bars(
                    dir, &stem, &labels, &series, &front, bars, true,
                )?);
            }
        }
        Ok(files)
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        let mut s = String::new();
        for (mesh, order) in distinct_pairs(t, "mesh", "order") {
            let rows: Vec<usize> = (0..t.rows.len())
                .filter(|&r| t.cell(r, "mesh") == mesh && t.cell(r, "order") == order)
                .collect();
            let keys = config_keys::<Params>(&[
                "mesh",
                "probe_seed",
                "receivers",
                "truth_res",
                "truth_seed",
                "radii",
            ]);
            let configs = by_config(t, &rows, &keys);
            let seeds = t.distinct_in(rows.iter().copied(), "probe_seed").len();
            s.push_str(&format!(
                "**{mesh}, N = {order}** ({} configurations, {seeds} receiver seed(s); errors are means over the seeds, in brackets their range).\n\n",
                configs.len()
            ));
            s.push_str(&speed_claim(t, &configs, "occ_rel_l2_mean"));
            for (col, regime) in [
                ("occ_rel_l2_mean", "all receivers, mean occ_rel_l2"),
                ("occ_rel_l2_near_mean", "near (ρ ≤ 1.3), mean occ_rel_l2"),
                ("occ_rel_l2_far_mean", "far (ρ > 1.3), mean occ_rel_l2"),
                (
                    "occ_rel_l2_contact_mean",
                    "contact directions, mean occ_rel_l2",
                ),
                ("occ_weighted", "all receivers, occlusion-weighted"),
            ] {
                s.push_str(&equal_accuracy(t, &configs, col, regime));
            }
            s.push('\n');
        }
        Ok(s)
    }
}

/// A file-name-safe name of a mesh parameter: a bundled name as is, a path by its file stem,
/// every character but letters, digits, `.`, `_` and `-` replaced by `_`.
pub(crate) fn plot_name(mesh: &str) -> String {
    let stem = Path::new(mesh)
        .file_stem()
        .map_or(mesh.to_string(), |s| s.to_string_lossy().into_owned());
    stem.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The distinct pairs of cells `(a, b)` of a table, in order of appearance: the fronts are
/// drawn per pair (per mesh and order here — errors at different orders are against different
/// truths; per scene and frame count in `budget_plane`).
pub(crate) fn distinct_pairs(t: &Results, a: &str, b: &str) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = Vec::new();
    for r in 0..t.rows.len() {
        let k = (t.cell(r, a).to_string(), t.cell(r, b).to_string());
        if !v.contains(&k) {
            v.push(k);
        }
    }
    v
}

/// The parameter columns that make a configuration of kind parameters `P`: all of them but
/// `grouping` (the columns a discussion is split by, and the seeds and receivers its rows
/// repeat over). Derived from `P`, so a new parameter is never merged away.
pub(crate) fn config_keys<P: Default + Serialize>(grouping: &[&str]) -> Vec<String> {
    shscale_runner::records::to_cells(&P::default())
        .map(|(h, _)| h)
        .unwrap_or_default()
        .into_iter()
        .filter(|h| !grouping.contains(&h.as_str()))
        .collect()
}

/// A configuration's rows (one per seed).
pub(crate) struct Config {
    rows: Vec<usize>,
}

impl Config {
    /// Mean of `col` over the seeds, and its range.
    fn mean(&self, t: &Results, col: &str) -> (f64, f64, f64) {
        let v: Vec<f64> = self.rows.iter().map(|&r| t.num(r, col)).collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (m, lo, hi)
    }
    fn first(&self) -> usize {
        self.rows[0]
    }
}

/// Rows grouped by configuration (equal cells in `keys`), in the order of the table.
pub(crate) fn by_config(t: &Results, rows: &[usize], keys: &[String]) -> Vec<Config> {
    let mut index: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut out: Vec<Config> = Vec::new();
    for &r in rows {
        let key = keys
            .iter()
            .map(|k| t.cell(r, k))
            .collect::<Vec<_>>()
            .join(";");
        match index.get(&key) {
            Some(&i) => out[i].rows.push(r),
            None => {
                index.insert(key, out.len());
                out.push(Config { rows: vec![r] });
            }
        }
    }
    out
}

/// The series a row belongs to: its method and, where it is not the papers', its variant.
pub(crate) fn variant(t: &Results, r: usize) -> String {
    match t.cell(r, "method") {
        "full_field" => {
            let papers = t.cell(r, "shell_spacing") == "uniform"
                && t.num(r, "shell_max") == 8.0
                && t.cell(r, "field_interp") == "trilinear";
            if papers {
                "full field (papers')".into()
            } else {
                format!(
                    "full field ({}, [1, {}]r, {})",
                    t.cell(r, "shell_spacing"),
                    t.cell(r, "shell_max"),
                    t.cell(r, "field_interp")
                )
            }
        }
        "ray_traced" => "ray tracing".into(),
        "sphere_set" => format!(
            "sphere set (S = {}{})",
            t.cell(r, "parts"),
            if t.cell(r, "sphere_combine") == "quadrature" {
                ", quadrature"
            } else {
                ""
            }
        ),
        method => {
            let mut v = Vec::new();
            if method == "sub_volumes" {
                v.push(format!("P = {}", t.cell(r, "parts")));
            }
            if t.cell(r, "alpha_mode") == "fit" {
                v.push("α fit".to_string());
            }
            if t.cell(r, "plausibility") == "clamp" {
                v.push("clamp".into());
            }
            if t.num(r, "sampling_radius") != 1.0 {
                v.push(format!("s = {}", t.cell(r, "sampling_radius")));
            }
            match t.cell(r, "radial") {
                "clearance" => v.push(format!("clearance δ = {}", t.cell(r, "radial_delta"))),
                "occlusion" => v.push(format!(
                    "occlusion τ = {} to {}r",
                    t.cell(r, "radial_tau"),
                    t.cell(r, "radial_max")
                )),
                _ => {}
            }
            let base = if method == "sub_volumes" {
                "sub-volumes"
            } else {
                "extrapolation"
            };
            if v.is_empty() {
                base.into()
            } else {
                format!("{base} ({})", v.join(", "))
            }
        }
    }
}

/// A configuration in words.
fn name(t: &Results, c: &Config) -> String {
    let r = c.first();
    match t.cell(r, "method") {
        "full_field" => format!(
            "{}, {} shells of `{}`, H = {}",
            variant(t, r),
            t.cell(r, "shells"),
            t.cell(r, "layout"),
            t.cell(r, "hemisphere_res")
        ),
        "ray_traced" => format!("ray tracing, T = {}", t.cell(r, "rt_res")),
        "sphere_set" => variant(t, r),
        method => format!(
            "{}, `{}`{}, H = {}, α = {}°",
            variant(t, r),
            t.cell(r, "layout"),
            if method == "sub_volumes" { " each" } else { "" },
            t.cell(r, "hemisphere_res"),
            t.cell(r, "alpha_deg")
        ),
    }
}

/// The lower-left Pareto front of `(x, y)` points: sorted by x, each with a lower y than all
/// before it.
pub fn pareto(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut best = f64::INFINITY;
    p.into_iter()
        .filter(|&(_, y)| {
            let keep = y < best;
            best = best.min(y);
            keep
        })
        .collect()
}

/// The papers' claim as stated: at the same layout and H, the papers' method (one sphere, fixed
/// α, no mitigation) against the papers' 16-shell full field — rays and time to produce the data.
pub(crate) fn speed_claim(t: &Results, configs: &[Config], err: &str) -> String {
    let is_papers_ex = |r: usize| {
        t.cell(r, "method") == "extrapolated"
            && t.cell(r, "alpha_mode") != "fit"
            && t.cell(r, "plausibility") == "none"
            && t.num(r, "sampling_radius") == 1.0
            && matches!(t.cell(r, "radial"), "uniform" | "")
    };
    let mut parts = Vec::new();
    for ex in configs.iter().filter(|c| is_papers_ex(c.first())) {
        let e = ex.first();
        let ff = configs.iter().find(|c| {
            let r = c.first();
            t.cell(r, "method") == "full_field"
                && variant(t, r) == "full field (papers')"
                && t.num(r, "shells") == 16.0
                && t.cell(r, "layout") == t.cell(e, "layout")
                && t.cell(r, "hemisphere_res") == t.cell(e, "hemisphere_res")
        });
        if let Some(ff) = ff {
            let f = ff.first();
            let rays = t.num(f, "rays") / t.num(e, "rays");
            // Per seed the ratio of the medians and the interval from the medians' intervals;
            // the mean ratio over the seeds, the widest interval.
            let mut ratio = 0.0;
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            let pairs: Vec<(usize, usize)> = (ff.rows.iter())
                .filter_map(|&f| {
                    let seed = t.cell(f, "probe_seed");
                    let e = ex.rows.iter().find(|&&e| t.cell(e, "probe_seed") == seed)?;
                    Some((f, *e))
                })
                .collect();
            for &(f, e) in &pairs {
                ratio += t.num(f, "frame_seconds") / t.num(e, "frame_seconds") / pairs.len() as f64;
                lo = lo.min(t.num(f, "frame_seconds_lo") / t.num(e, "frame_seconds_hi"));
                hi = hi.max(t.num(f, "frame_seconds_hi") / t.num(e, "frame_seconds_lo"));
            }
            let (ee, _, _) = ex.mean(t, err);
            let (ef, _, _) = ff.mean(t, err);
            parts.push(format!(
                "`{}`, H = {}: the full field casts {rays:.0}× the rays and takes {ratio:.1}× the time per frame (interval {lo:.1}–{hi:.1}×); error ({err}) {ee:.3} extrapolated, {ef:.3} full field",
                t.cell(e, "layout"),
                t.cell(e, "hemisphere_res"),
            ));
        }
    }
    if parts.is_empty() {
        return "The claim as stated (the papers' 16-shell field against one sphere at the same sampling) is not among these runs.\n\n".into();
    }
    format!(
        "*The claim as stated* (\"about 20 times faster than full shadow field computation\", at the papers' sampling: one sphere against the papers' 16-shell field of the same layout and H): {}.\n\n",
        parts.join("; ")
    )
}

/// Equal accuracy in one regime (`col`): the Pareto front against rays, and the cheapest full
/// field at least as accurate as the best extrapolation.
/// A ray count in the discussion: `0` for none (sphere sets), else three significant digits.
fn rays_text(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.2e}")
    }
}

pub(crate) fn equal_accuracy(t: &Results, configs: &[Config], col: &str, regime: &str) -> String {
    let pts: Vec<(f64, f64, usize)> = (configs.iter().enumerate())
        .map(|(i, c)| (c.mean(t, "rays").0, c.mean(t, col).0, i))
        .filter(|(x, y, _)| x.is_finite() && *x >= 0.0 && y.is_finite())
        .collect();
    if pts.is_empty() {
        return String::new();
    }
    let front = pareto(pts.iter().map(|p| (p.0, p.1)));
    let on_front: Vec<String> = front
        .iter()
        .filter_map(|f| pts.iter().find(|p| p.0 == f.0 && p.1 == f.1))
        .map(|&(x, _, i)| {
            let (m, lo, hi) = configs[i].mean(t, col);
            format!(
                "{} at {} rays ({m:.3} [{lo:.3}–{hi:.3}])",
                name(t, &configs[i]),
                rays_text(x)
            )
        })
        .collect();
    let method = |i: usize| t.cell(configs[i].first(), "method");
    let best_ex = (pts.iter())
        .filter(|p| method(p.2) == "extrapolated")
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let verdict = match best_ex {
        Some(bx) => {
            let mut v = format!(
                " The most accurate extrapolation is {} ({:.3} at {:.2e} rays); the cheapest as accurate",
                name(t, &configs[bx.2]),
                bx.1,
                bx.0
            );
            let families: [(&str, &dyn Fn(usize) -> bool); 2] = [
                ("papers' full field", &|i| {
                    variant(t, configs[i].first()) == "full field (papers')"
                }),
                ("full field of any construction", &|i| {
                    method(i) == "full_field"
                }),
            ];
            let parts: Vec<String> = families
                .iter()
                .map(|(label, keep)| {
                    match (pts.iter())
                        .filter(|p| keep(p.2) && p.1 <= bx.1)
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                    {
                        Some(f) => format!(
                            "{label}: {} ({:.3}) at {:.2e} rays, {:.2}× the extrapolation's",
                            name(t, &configs[f.2]),
                            f.1,
                            f.0,
                            f.0 / bx.0
                        ),
                        None => format!("{label}: none of these runs"),
                    }
                })
                .collect();
            v.push_str(&format!(" — {}.", parts.join("; ")));
            v
        }
        None => String::new(),
    };
    // The papers' proposals and the successor: does each beat one sphere sampled on its
    // sampling sphere, and which full field is as accurate for fewer rays?
    let radial = |i: usize| !matches!(t.cell(configs[i].first(), "radial"), "uniform" | "");
    let one_sphere = (pts.iter())
        .filter(|p| method(p.2) == "extrapolated" && !radial(p.2))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let new_methods: [(&str, &dyn Fn(usize) -> bool); 3] = [
        ("Sub-volumes", &|i| method(i) == "sub_volumes"),
        ("Per-direction radii", &|i| {
            method(i) == "extrapolated" && radial(i)
        }),
        ("Sphere sets", &|i| method(i) == "sphere_set"),
    ];
    let mut sub = String::new();
    for (label, keep) in new_methods {
        let Some(b) = (pts.iter())
            .filter(|p| keep(p.2))
            .min_by(|a, b| a.1.total_cmp(&b.1))
        else {
            continue;
        };
        sub.push_str(&format!(
            " {label}: the most accurate is {} ({:.3} at {} rays)",
            name(t, &configs[b.2]),
            b.1,
            rays_text(b.0)
        ));
        if let Some(o) = one_sphere {
            sub.push_str(&format!(
                ", {} the most accurate extrapolation sampled on its sphere ({:.3})",
                if b.1 < o.1 {
                    "better than"
                } else {
                    "no better than"
                },
                o.1
            ));
        }
        match (pts.iter())
            .filter(|p| method(p.2) == "full_field" && p.1 <= b.1)
            .min_by(|a, b| a.0.total_cmp(&b.0))
        {
            Some(f) => sub.push_str(&format!(
                "; the cheapest full field as accurate: {} ({:.3}) at {:.2e} rays.",
                name(t, &configs[f.2]),
                f.1,
                f.0
            )),
            None => sub.push_str("; no full field in these runs is as accurate."),
        }
    }
    format!(
        "*{regime}*: lowest error for the rays (Pareto front) — {}.{verdict}{sub}\n\n",
        on_front.join("; ")
    )
}

/// One frame from scratch, timed as a whole: (values, rays, bytes) and [build, eval, frame].
type Frame = (Vec<Vec<f64>>, f64, f64);
type FrameFn<'a> = Box<dyn FnMut() -> Result<(Frame, [f64; 3]), Error> + 'a>;

/// The frame of extrapolation from the spheres of `parts` (occluder and k range each): every
/// part's BSV sampled at `sampling_radius` × its bounding radius, its k-table (built once, before
/// the frames, for a fixed α — part of the memory, not of a frame's time; per frame for α by
/// distance, which depends on the BSV) and, for several parts, their visibilities multiplied near
/// to far ([`SubVolumeField`]). One part is the papers' method.
fn extrapolation_frame<'a>(
    p: &'a Params,
    parts: Vec<(&'a dyn Occluder, (f64, f64))>,
    sampler: &'a VisibilitySampler,
    points: &'a [(f64, DVec3)],
) -> Result<FrameFn<'a>, Error> {
    let fit = crate::probe::parse_alpha_mode(&p.alpha_mode).map_err(Error::config)?;
    let plaus = Plausibility::parse(&p.plausibility).map_err(Error::config)?;
    let layout = Layout::parse(&p.layout).map_err(|e| Error::config(e.to_string()))?;
    let radial = radial_of(&p.radial, p.radial_delta, p.radial_tau, p.radial_max)
        .map_err(|e| Error::config(format!("{}: {}", e.key, e.message)))?;
    // Samples moved outward by the radial rule see smaller k: the tables reach down to the
    // receivers' distances over the largest radius the rule can reach.
    let down = p.sampling_radius / radial.max_factor(p.sampling_radius);
    let parts: Vec<_> = (parts.into_iter())
        .map(|(o, (lo, hi))| (o, (lo * down, hi)))
        .collect();
    let nn = p.order * p.order;
    let fixed: Option<Vec<KTable>> = (!fit)
        .then(|| {
            let alpha = p.alpha_deg.to_radians();
            (parts.iter())
                .map(|(_, r)| k_table(p, TauFamily::Cone { alpha }, *r))
                .collect()
        })
        .transpose()?;
    let gaunt = (parts.len() > 1)
        .then(|| shscale_sh::GauntTensor::<f64>::new(p.order))
        .transpose()
        .map_err(|e| Error::config(e.to_string()))?;
    Ok(Box::new(move || {
        let t0 = Instant::now();
        let bsvs: Vec<Bsv> = (parts.iter())
            .map(|(o, _)| Bsv::sample_radial(*o, layout, sampler, p.sampling_radius, radial))
            .collect::<Result<_, _>>()?;
        let own: Vec<KTable>;
        let tables = match &fixed {
            Some(t) => t,
            None => {
                own = (bsvs.iter().zip(&parts))
                    .map(|(b, (_, r))| {
                        let theta0 = shscale_field::alpha::effective_cap_angle(b);
                        k_table(p, TauFamily::ConeFit { theta0 }, *r)
                    })
                    .collect::<Result<_, _>>()?;
                &own
            }
        };
        let build = t0.elapsed().as_secs_f64();
        let mut exs: Vec<Extrapolator> = (bsvs.iter().zip(tables))
            .map(|(b, t)| Extrapolator::new(b, t).with_plausibility(plaus))
            .collect();
        let t1 = Instant::now();
        let v = match &gaunt {
            Some(g) => eval_all(&SubVolumeField::new(exs, g), points, nn),
            None => eval_all(&exs.remove(0), points, nn),
        };
        let eval = t1.elapsed().as_secs_f64();
        let rays = bsvs.iter().map(|b| b.rays).sum::<usize>() as f64;
        let mem = (bsvs.iter().zip(tables))
            .map(|(b, t)| b.samples.len() * nn * 8 + t.size_bytes())
            .sum::<usize>() as f64;
        Ok(((v, rays, mem), [build, eval, build + eval]))
    }))
}

/// The [`RadialRule`] of a run's `radial*` keys, or the key at fault.
pub(crate) fn radial_of(
    name: &str,
    delta: f64,
    tau: f64,
    max: f64,
) -> Result<RadialRule, KeyError> {
    RadialRule::parse(name, delta, tau, max).map_err(|m| {
        let key = ["radial_delta", "radial_tau", "radial_max"]
            .into_iter()
            .find(|k| m.starts_with(k))
            .unwrap_or("radial");
        KeyError::new(key, m)
    })
}

/// The cost model's time per receiver of a sphere set, per sphere (a cap's projection and
/// rotation and a truncated product at N = 4): 0.36 µs on spherical receivers, 0.57–0.63 µs on
/// the plane, at S = 16 and 64 in `configs/experiments/budget.toml` and `budget_plane.toml`
/// on the development VM.
pub const SPHERE_SECONDS: f64 = 5e-7;

/// Gauss–Legendre nodes in cos θ of `sphere_combine = "quadrature"` (× twice as many φ).
pub const SPHERE_QUADRATURE_RES: usize = 64;

/// The cost model's time of the quadrature combination: per direction and receiver, and per
/// ray–sphere test, fitted to `sphere_combine = "quadrature"` in `configs/experiments/
/// budget.toml` (S = 2 / 16 / 64: 0.06 / 0.17 / 0.60 s per frame of 1,200 receivers) on the
/// development VM.
pub const SPHERE_DIRECTION_SECONDS: f64 = 4.3e-9;
pub const SPHERE_TEST_SECONDS: f64 = 0.9e-9;

/// The evaluation time per receiver of `method` with `parts` spheres (0 unless a sphere set).
pub(crate) fn sphere_set_seconds(method: &str, parts: usize) -> f64 {
    if method == "sphere_set" {
        parts as f64 * SPHERE_SECONDS
    } else {
        0.0
    }
}

/// The run's k-table of `family` over `(lo, hi)`: plain η, `k_count` entries, exponential
/// spacing, linear interpolation.
fn k_table(p: &Params, family: TauFamily, (lo, hi): (f64, f64)) -> Result<KTable, Error> {
    KTable::build(
        family,
        Eta::Plain,
        p.order,
        p.k_count,
        lo,
        hi,
        Spacing::Exp,
        Interp::Linear,
    )
    .map_err(|e| Error::config(e.to_string()))
}

/// The full field of a run's parameters, or the offending key and why.
fn shells_of(p: &Params) -> Result<Shells, (&'static str, String)> {
    Ok(Shells {
        count: p.shells,
        rho_min: 1.0,
        rho_max: p.shell_max,
        spacing: ShellSpacing::parse(&p.shell_spacing)
            .map_err(|e| ("shell_spacing", e.to_string()))?,
        interp: FieldInterp::parse(&p.field_interp).map_err(|e| ("field_interp", e.to_string()))?,
    })
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

#[cfg(test)]
mod tests {
    #[test]
    fn the_mean_interval_is_the_normal_one_and_needs_two_values() {
        // [1, 2, 3]: mean 2, sample s.d. 1, so 1.96/√3.
        let (m, ci) = super::mean_ci95(&[1.0, 2.0, 3.0]);
        assert_eq!(m, Some(2.0));
        assert!((ci.unwrap() - 1.96 / 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(super::mean_ci95(&[4.0]), (Some(4.0), None));
        assert_eq!(super::mean_ci95(&[]), (None, None));
        // Equal values: no spread.
        assert_eq!(super::mean_ci95(&[0.5; 4]).1, Some(0.0));
    }
}
