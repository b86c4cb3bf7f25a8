//! The equal-budget study where the papers put their receivers: the receiver plane of a scene,
//! scored in image space. For the rays, bytes and time of one frame, how close to full-frequency
//! truth (and to band-limited truth) are the shadows of SH-scaling extrapolation, of the fully
//! sampled shadow field as Zhou et al. build it and of ray tracing — near the object and far
//! from it — and is the papers' "about 20 times faster" true as stated on this scene?
//!
//! A group is one scene (and order): its band-limited truth (the converged stratified
//! visibility, `4T²` rays per receiver, projected to order N under the SH light), its
//! full-frequency truth (exact visibility lit by the environment itself) and the unshadowed
//! image are rendered once. A run renders the plane with one method at one budget (the scene
//! with the run's layout, H, α, plausibility and sampling radius; the full field's shells,
//! range, spacing and interpolation; or ray tracing with `4·rt_res²` rays per receiver, a
//! different seed from the truth's) and scores it: `shade_rmse_rel` (docs/conventions.md §6)
//! against both truths, against full-frequency truth on the receivers near an occluder
//! (within 1.3 bounding radii of its centre) and on the rest, each in the unit of the mean
//! unshadowed irradiance of those receivers, and `1 − SSIM` of the luminance against the
//! full-frequency truth's (Wang et al. 2004, [`shscale_field::metrics::ssim`]).
//!
//! Budget axes: rays per frame (deterministic: [`shscale_scene::render::estimated_work`]), the
//! bytes the field holds (deterministic), and the frame's time — the render without the light's
//! projection and the BVH build, which every method shares — as the median of the timing
//! procedure's repeats with its order-statistic interval.

use super::plane_images::{flicker, lum, own_err, rmse_where};
use super::plane_timings::{cached_frame, cpu_frames, gpu_frame};
use super::NEAR_RHO;
use crate::figures::flat;
use shscale_field::metrics::ssim;
use shscale_field::shading::shade_rmse_rel;
use shscale_runner::records::Results;
use shscale_runner::{Cost, Ctx, KeyError, Kind, Typed};
use shscale_scene::method::{Combine, Method, RayTracedSpec, SetSpec, Spec, SphereFit};
use shscale_scene::render::{estimated_work, render};
use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;
use shscale_scene::vocab::MAX_ORDER;
use shscale_scene::Error;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

pub use super::plane_params::Params;
pub use super::plane_rows::Row;

/// The kind.
pub struct BudgetPlane;

/// A group's scene and its truths.
pub struct Shared {
    scene: Scene,
    /// The group's render settings (the scene file's, with the order override).
    settings: RenderSettings,
    /// Per frame: the band-limited and full-frequency truth images.
    band: Vec<Vec<f64>>,
    full: Vec<Vec<f64>>,
    open: Vec<f64>,
    near: Vec<bool>,
    /// Per frame, each receiver's distance-to-surface bin (`surface::surface_bin`).
    bins: Vec<Vec<usize>>,
    full_err: f64,
    band_err: f64,
}

/// Seconds per receiver of one render besides its rays (locating, rotating and shading each
/// receiver), the cost model's rate: the extrapolated plane frames of
/// `configs/experiments/budget_plane.toml` took 22–40 ms for 25,600 receivers and 61,440 rays
/// (the rays' share ≈ 1 ms) on the development VM.
const SHADE_SECONDS_PER_RECEIVER: f64 = 1.0e-6;

/// The most frames of a run.
pub const MAX_FRAMES: usize = 64;

/// Per distance-to-surface bin: the mean over the frames of the error against full-frequency
/// truth on that bin's receivers, and the first frame's count of them.
fn distance_bins(es: &[Vec<f64>], sh: &Shared) -> ([Option<f64>; 7], [usize; 7]) {
    let by_bin = std::array::from_fn(|k| {
        let per_frame = (0..es.len()).map(|f| {
            let keep: Vec<bool> = sh.bins[f].iter().map(|b| *b == k).collect();
            rmse_where(&es[f], &sh.full[f], &sh.open, &keep, true)
        });
        shscale_field::metrics::mean_max(per_frame).0
    });
    let counts = std::array::from_fn(|k| sh.bins[0].iter().filter(|b| **b == k).count());
    (by_bin, counts)
}

/// The scene at frame `f` of `frames` (the rest pose for one frame).
fn at_frame(scene: &Scene, f: usize, frames: usize) -> Scene {
    let mut s = scene.clone();
    s.pose_t = (frames > 1).then(|| f as f64 / frames as f64);
    s
}

/// A group's scene and the render settings of its file.
type Setup = (Scene, RenderSettings);

/// The scene of a group and its render settings: the file with the order override.
fn group_scene(p: &Params, config_dir: &Path) -> Result<Setup, Error> {
    let (mut s, mut rs) = Scene::load(&config_dir.join(&p.scene))?;
    if let Some(n) = p.order {
        rs.order = n;
    }
    if p.placement_seed != 0 {
        let mut rng = shscale_field::truth::SplitMix(p.placement_seed);
        for o in s.occluders.iter_mut().filter(|o| o.mesh != "sphere") {
            o.turn = Some(rng.rotation());
        }
    }
    Ok((s, rs))
}

/// The scenes read at plan time, by path and modification time: a plan reads each scene file
/// once, however many runs name it.
fn planned_scene(p: &Params, config_dir: &Path) -> Result<Arc<Setup>, Error> {
    type Cache = Vec<(
        (PathBuf, Option<std::time::SystemTime>, Option<usize>, u64),
        Arc<Setup>,
    )>;
    static CACHE: Mutex<Cache> = Mutex::new(Vec::new());
    const KEEP: usize = 16;
    let path = config_dir.join(&p.scene);
    let modified = std::fs::metadata(&path).and_then(|m| m.modified()).ok();
    let key = (path, modified, p.order, p.placement_seed);
    if let Some(s) =
        (CACHE.lock().ok()).and_then(|c| c.iter().find(|(k, _)| *k == key).map(|(_, s)| s.clone()))
    {
        return Ok(s);
    }
    let s = Arc::new(group_scene(p, config_dir)?);
    if let Ok(mut c) = CACHE.lock() {
        if c.len() >= KEEP {
            c.remove(0);
        }
        c.push((key, s.clone()));
    }
    Ok(s)
}

/// Ray tracing is scored against a band-limited truth that must be converged beyond it: `rt_res`
/// below the scene's `truth_res` (of its render settings `rs`).
fn check_rt_res(spec: &Spec, p: &Params, rs: &RenderSettings) -> Result<(), KeyError> {
    match spec {
        Spec::RayTraced(RayTracedSpec { rt_res }) if *rt_res >= rs.truth_res => Err(KeyError::new(
            "rt_res",
            format!(
                "rt_res = {rt_res} is not below the scene's truth_res = {} ({}): the band-limited truth must be converged beyond the method it measures",
                rs.truth_res, p.scene
            ),
        )),
        _ => Ok(()),
    }
}

/// A run's resolved form: its method, and the group's scene where it was read at plan time.
pub struct PlaneSpec {
    method: Spec,
    device: super::plane_timings::DeviceChoice,
    scene: Option<Arc<Setup>>,
}

/// The render settings of a run: the group's with the run's method and its parameters.
fn run_settings(
    p: &Typed<Params, PlaneSpec>,
    base: &RenderSettings,
) -> Result<RenderSettings, Error> {
    check_rt_res(&p.typed.method, p, base)
        .map_err(|e| Error::config(format!("{}: {}", e.key, e.message)))?;
    let mut s = base.clone();
    p.typed.method.apply(&mut s);
    Ok(s)
}

impl Kind for BudgetPlane {
    const NAME: &'static str = "budget_plane";
    const QUESTION: &'static str = "On a scene's receiver plane, in image space against full-frequency truth, which is most accurate for the rays, bytes and time of a frame — SH-scaling extrapolation, the full shadow field as Zhou et al. build it, or ray tracing — near the object and far from it, and does the papers' \"about 20× faster\" hold as stated?";
    type Params = Params;
    type Shared = Shared;
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, PlaneSpec>;

    fn inputs(
        p: &Self::Params,
        config_dir: &std::path::Path,
    ) -> Result<Vec<shscale_runner::inputs::Input>, KeyError> {
        crate::common::scene_inputs(config_dir, &p.scene)
    }

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("scene", "scene file (docs/config-reference.md, scene files), relative to the config's folder"),
            ("order", "override of the scene's SH order, 1..=16 (empty: the scene's)"),
            ("frames", "frames of the deformers' sequence (t = f/frames), each rendered from scratch by every method, 1..=64; 1: the rest pose"),
            ("method", "`extrapolated`, `full_field`, `ray_traced`, `sub_volumes` (every mesh occluder split into `parts`, each extrapolated from its own sphere; the partition's time is in the frame's) or `sphere_set` (one sphere fitted per part every frame, closed-form caps, no rays; Ren et al. 2006's occluder model). A method key the method does not read (docs/methods.md) must keep its default"),
            ("parts", "parts of every mesh occluder for `sub_volumes`, or its spheres for `sphere_set`, 1..=64 and at most one per triangle"),
            ("sphere_order", "the internal order M of `sphere_set`: each cap projected to M, every product at M, the result truncated to the scene's order once (docs/math.md, \"Combining many spheres\"); 0 (default) for the scene's order, else that order..=16 (a product at M does about (M/4)⁵ the work of one at 4)"),
            ("sphere_fit", "which spheres `sphere_set` takes: `area` (default; one per k-means part, refitted every frame) or `inscribed` (the greedy cover of each pose's interior by inscribed balls, a one-off fit per pose that a deforming sequence pays every frame, on the CPU and GPU paths alike; docs/math.md, \"Inscribed sphere sets\")"),
            ("sphere_combine", "how `sphere_set` combines its spheres: `product` (default; truncated SH products near to far, at `sphere_order`) `union` (the exact union of the caps: φ in closed form, 32 Gauss–Legendre rings in z, no rays; docs/math.md, \"The union of the caps\") or `shexp` (SH exponentiation by HYB, orders up to 8; docs/math.md, \"SH exponentiation\")"),
            ("part_combine", "how `sub_volumes` combines its parts: `product` (default; each part's scaled visibility multiplied near to far) or `shexp` (scaling in log space: the parts' base-sphere product-algebra logs scaled, summed and exponentiated once by HYB; orders up to 8, without the plausibility clamp; docs/math.md, \"Scaling in log space\")"),
            ("layout", "base-sphere layout (extrapolation) or the layout of every shell (full field)"),
            ("hemisphere_res", "H: H² rays per BSV or shell sample, 1..=256"),
            ("shells", "shells of the full field over [s, shell_max·s]·r, 2..=64"),
            ("shell_max", "the full field's outermost shell in sampling radii, (1, 1000]; the papers' 8"),
            ("shell_spacing", "`uniform` (the papers') or `exp`"),
            ("field_interp", "`trilinear` (the papers'; latlong or cube layouts) or `barycentric`"),
            ("rt_res", "T of the ray-traced method: 4T² rays per receiver, 1..=255 and below the scene's truth_res"),
            ("alpha_deg", "cone angle α of the extrapolation, degrees, (0, 90)"),
            ("plausibility", "`none` or `clamp` (the extrapolation's plausibility mitigation)"),
            ("sampling_radius", "sampling sphere in bounding radii, [1, 1000]"),
            ("radial", "`uniform` (the papers') or `clearance`: each base-sphere sample of `extrapolated` and `sub_volumes` moved outward until at least `radial_delta`·r from the surface (distance queries, no extra rays), k = d / r(q); `budget`'s `occlusion` rule is not offered here, where rays are counted from the layout"),
            ("radial_delta", "δ of `radial = \"clearance\"`, [0, 10] bounding radii"),
            ("save_image", "keep the run's irradiance image and the group's full-frequency truth as EXR (`plane_<run>.exr`, `plane_truth_<run>.exr`) for the figure: truth, the papers' full field, the papers' extrapolation and the most accurate other saved method at no more rays, with their differences from the truth; one frame only"),
            ("device", "where the frame is timed besides the CPU: `cpu` (default), `gpu` (the GPU path too — the papers' extrapolation from one sphere (the real-time sequence, its one sphere enclosing every pose of a deforming scene) or clearance radii, sub-volumes, the full field, sphere sets by `product`, `union` or `shexp`, the band-limited ray-traced reference (two Gauss hemispheres per receiver) — the errors still the CPU render's, `gpu_max_diff` its images' distance from it; refused without an adapter, which the config's `gpu` setting opens, or without a GPU form of the method on the scene) or `auto` (the GPU path where an adapter and a form exist, else none, `gpu_adapter` saying why)"),
            ("placement_seed", "0 (default): the occluders as the scene file places them; any other seed turns every mesh occluder by its own uniformly random rotation about its bounding sphere's centre (a placement; its bounding sphere and clearance unchanged). Configurations repeat over placement seeds: several give the verdict its intervals"),
        ]
    }

    fn resolve(p: &Params) -> Result<Self::Spec, KeyError> {
        if p.scene.trim().is_empty() {
            return Err(KeyError::new("scene", "give a scene file"));
        }
        if let Some(n) = p.order {
            KeyError::int("order", n, 1, MAX_ORDER)?;
        }
        KeyError::int("frames", p.frames, 1, MAX_FRAMES)?;
        let method = p.spec()?;
        let device = super::plane_timings::DeviceChoice::parse(&p.device)?;
        if p.save_image && p.frames != 1 {
            return Err(KeyError::new(
                "save_image",
                format!("keeps one frame's image; frames = {}", p.frames),
            ));
        }
        Ok(Typed {
            params: p.clone(),
            typed: PlaneSpec {
                method,
                device,
                scene: None,
            },
        })
    }

    /// With the scene read (once per plan): `rt_res` against its `truth_res`, before any work.
    fn resolve_in(p: &Params, config_dir: &Path) -> Result<Self::Spec, KeyError> {
        let mut spec = Self::resolve(p)?;
        let setup =
            planned_scene(p, config_dir).map_err(|e| KeyError::new("scene", e.to_string()))?;
        let (scene, base) = (&setup.0, &setup.1);
        check_rt_res(&spec.typed.method, p, base)?;
        if let Spec::SphereSet(SetSpec {
            combine: Combine::Quadrature,
            ..
        }) = spec.typed.method
        {
            return Err(KeyError::new(
                "sphere_combine",
                "\"quadrature\" is the spherical receivers' diagnostic (kind `budget`); the plane renders `product` or `union`".to_string(),
            ));
        }
        (spec.typed.method).check_order(base.order)?;
        if let Spec::SphereSet(SetSpec {
            fit: SphereFit::Inscribed,
            ..
        }) = spec.typed.method
        {
            shscale_scene::frame::inscribed_seconds(scene, true)
                .map_err(|e| KeyError::new("sphere_fit", e.to_string()))?;
        }
        if spec.typed.device == super::plane_timings::DeviceChoice::Gpu {
            let mut rs = base.clone();
            spec.typed.method.apply(&mut rs);
            let form = super::plane_timings::gpu_form(scene, &rs, p.frames)
                .map_err(|why| KeyError::new("device", format!("\"gpu\": {why}")))?;
            let (cells, defaults) = (p.keys().cells(), Params::default().keys().cells());
            if let Some((key, value, default)) = shscale_scene::gpu_methods::unhonoured(
                form,
                &spec.typed.method.reads(),
                &cells,
                &defaults,
            ) {
                return Err(KeyError::new(
                    "device",
                    format!(
                        "\"gpu\": the {} GPU form does not implement {key} = {value:?} (it would time another computation than the CPU's): device = \"cpu\", or {key} at its default {default:?}",
                        form.name()
                    ),
                ));
            }
        }
        spec.typed.scene = Some(setup);
        Ok(spec)
    }

    fn open_device(mode: shscale_runner::GpuMode) -> Result<Option<shscale_runner::Device>, Error> {
        shscale_scene::gpu_path::open_device(mode)
    }

    /// `device = "gpu"` asks for the GPU timing (`auto` records the CPU where there is none).
    fn needs_device(p: &Self::Spec) -> bool {
        p.typed.device == super::plane_timings::DeviceChoice::Gpu
    }

    fn group_key(p: &Params) -> String {
        format!(
            "{};{:?};{};{}",
            p.scene, p.order, p.frames, p.placement_seed
        )
    }

    /// From the scene read at plan time: the truths once (band-limited, full-frequency,
    /// unshadowed), the run's method per timed render, at the `shadows` kind's render rate.
    /// Resolved without it (rows read back from a CSV): not estimated.
    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        let Some((base, base_rs)) = p.typed.scene.as_deref() else {
            let unread = Cost {
                drivers: format!(
                    "scene {} (its truths; not estimated before the scene is read)",
                    p.scene
                ),
                once_seconds: f64::NAN,
                ..Cost::default()
            };
            return (unread, Cost::default());
        };
        let mut rs = base_rs.clone();
        p.typed.method.apply(&mut rs);
        let frames = p.frames as f64;
        let once: f64 = frames
            * [Method::RayTraced, Method::FullFrequency]
                .iter()
                .map(|m| estimated_work(base, &base_rs.with(*m)).0)
                .sum::<f64>()
            + estimated_work(base, &base_rs.with(Method::RayTraced)).0
                / base.occluders.len().max(1) as f64;
        let (_, bytes) = estimated_work(base, &rs);
        let receivers = (base.resolution[0] * base.resolution[1]) as f64;
        let occluders = base.occluders.len().max(1) as f64;
        let rays = frames * p.typed.method.rays(occluders, receivers);
        let rate = crate::shadows::RENDER_RAYS_PER_SECOND;
        let frame = (p.typed.method).seconds(base_rs.order, rays, frames * receivers, rate)
            + frames * receivers * SHADE_SECONDS_PER_RECEIVER;
        // The GPU path's repetition (`device`): a sequence's set-up and its frames, counted at
        // the CPU frame's cost (a software device's; an upper bound on a GPU).
        let gpu = super::plane_timings::gpu_seconds(p.typed.device, frame);
        (
            Cost {
                cached_once: None,
                rays: once,
                bytes,
                seconds: 0.0,
                once_seconds: once / rate,
                drivers: format!(
                    "scene {}: {}×{} receivers, truth_res {}",
                    p.scene, base.resolution[0], base.resolution[1], base_rs.truth_res
                ),
            },
            Cost {
                // The inscribed fit: once per mesh occluder and pose of the scene's sequence,
                // whatever the runs using it.
                cached_once: match p.typed.method {
                    Spec::SphereSet(SetSpec {
                        fit: SphereFit::Inscribed,
                        ..
                    }) => Some((
                        format!("inscribed {} {}", p.scene, p.frames),
                        frames
                            * shscale_scene::frame::inscribed_seconds(base, false).unwrap_or(
                                shscale_geometry::inscribed::INSCRIBED_FIT_SECONDS * occluders,
                            ),
                    )),
                    _ => None,
                },
                rays,
                bytes,
                seconds: frame
                    + gpu
                    + super::plane_timings::cached_seconds((base, &rs), p.frames, rays, rate),
                once_seconds: 0.0,
                drivers: format!(
                    "method {} → {rays:.3e} rays and {receivers} receivers shaded, over {} frame(s)",
                    p.method, p.frames
                ),
            },
        )
    }

    fn rows_per_run(_: &Params) -> usize {
        1
    }

    fn shared(p: &Self::Spec, ctx: &Ctx) -> Result<Shared, Error> {
        let (scene, settings) = match &p.typed.scene {
            Some(s) => Setup::clone(s),
            None => group_scene(&p.params, ctx.config_dir)?,
        };
        let frames = p.frames;
        let (mut band, mut full) = (Vec::new(), Vec::new());
        let (mut full_err, mut band_err) = (Vec::new(), Vec::new());
        let mut unshadowed = scene.clone();
        unshadowed.occluders.clear();
        let (band_rs, full_rs) = (
            settings.with(Method::RayTraced),
            settings.with(Method::FullFrequency),
        );
        let open = flat(&render(&unshadowed, &band_rs)?);
        for f in 0..frames {
            let s = at_frame(&scene, f, frames);
            let b = render(&s, &band_rs)?;
            let u = render(&s, &full_rs)?;
            band_err.push(own_err(&b.error, &open));
            full_err.push(own_err(&u.error, &open));
            band.push(flat(&b));
            full.push(flat(&u));
        }
        let near = shscale_scene::frame::receiver_grid(&scene)
            .iter()
            .map(|q| {
                (scene.occluders.iter()).any(|o| (*q - o.center).length() <= NEAR_RHO * o.radius)
            })
            .collect();
        let bins = (0..frames)
            .map(|f| super::receivers::plane_bins(&at_frame(&scene, f, frames)))
            .collect::<Result<Vec<_>, Error>>()?;
        let worst = |v: Vec<f64>| v.into_iter().fold(f64::NAN, f64::max);
        Ok(Shared {
            bins,
            full_err: worst(full_err),
            band_err: worst(band_err),
            band,
            full,
            open,
            near,
            scene,
            settings,
        })
    }

    fn run(p: &Self::Spec, run_id: &str, sh: &Shared, ctx: &Ctx) -> Result<Vec<Row>, Error> {
        let rs = run_settings(p, &sh.settings)?;
        let scene = &sh.scene;
        let frames = p.frames;
        let scenes: Vec<Scene> = (0..frames).map(|f| at_frame(scene, f, frames)).collect();
        let (imgs, t) = cpu_frames(&scenes, &rs, ctx)?;
        let black = || Error::config(format!("{}: the unshadowed image is black", p.scene));
        let occluders = scene.occluders.len() as f64;
        let receivers = (scene.resolution[0] * scene.resolution[1]) as f64;
        let rays = p.typed.method.rays(occluders.max(1.0), receivers);
        let memory = (p.typed.method).memory_bytes(rs.order, occluders, rs.k_count);
        if p.save_image {
            super::plane_images::save_images(&imgs[0], &sh.full[0], (ctx.dir, run_id))?;
        }
        let es: Vec<Vec<f64>> = imgs.iter().map(flat).collect();
        let cached = cached_frame((scene, &rs), frames, &es[0], &sh.open, ctx)?;
        let device = (p.typed.device, frames);
        let (gpu, gpu_adapter) = gpu_frame(device, (scene, &rs), (&es, &sh.open), ctx)?;
        let mean = |v: &[Option<f64>]| shscale_field::metrics::mean_max(v.iter().copied()).0;
        let per =
            |f: &dyn Fn(usize) -> Option<f64>| -> Vec<Option<f64>> { (0..frames).map(f).collect() };
        let full: Vec<Option<f64>> = per(&|f| shade_rmse_rel(&es[f], &sh.full[f], &sh.open));
        let band = per(&|f| shade_rmse_rel(&es[f], &sh.band[f], &sh.open));
        let near = per(&|f| rmse_where(&es[f], &sh.full[f], &sh.open, &sh.near, true));
        let far = per(&|f| rmse_where(&es[f], &sh.full[f], &sh.open, &sh.near, false));
        let (by_bin, counts) = distance_bins(&es, sh);
        let ssims = per(&|f| {
            let (lt, le) = (lum(&sh.full[f]), lum(&es[f]));
            let range = lt.iter().copied().fold(0.0, f64::max);
            ssim(&le, &lt, imgs[f].width, imgs[f].height, range).map(|s| 1.0 - s)
        });
        Ok(vec![Row {
            receivers: sh.near.len(),
            near_receivers: sh.near.iter().filter(|n| **n).count(),
            // Per frame (every frame casts the same rays).
            rays,
            memory_bytes: memory,
            frame_seconds: t.median,
            frame_seconds_lo: t.lo,
            frame_seconds_hi: t.hi,
            timing_coverage: t.coverage,
            rmse_vs_band_limited: mean(&band).ok_or_else(black)?,
            rmse_vs_full_frequency: mean(&full).ok_or_else(black)?,
            rmse_vs_full_frequency_max: full.iter().flatten().copied().fold(f64::NAN, f64::max),
            flicker: flicker(&es, &sh.full, &sh.open),
            rmse_near_vs_full_frequency: mean(&near),
            rmse_far_vs_full_frequency: mean(&far),
            one_minus_ssim: mean(&ssims),
            full_frequency_truth_err: sh.full_err,
            band_limited_truth_err: sh.band_err,
            receivers_s0: counts[0],
            receivers_s1: counts[1],
            receivers_s2: counts[2],
            receivers_s3: counts[3],
            receivers_s4: counts[4],
            receivers_s5: counts[5],
            receivers_s6: counts[6],
            rmse_s0_vs_full_frequency: by_bin[0],
            rmse_s1_vs_full_frequency: by_bin[1],
            rmse_s2_vs_full_frequency: by_bin[2],
            rmse_s3_vs_full_frequency: by_bin[3],
            rmse_s4_vs_full_frequency: by_bin[4],
            rmse_s5_vs_full_frequency: by_bin[5],
            rmse_s6_vs_full_frequency: by_bin[6],
            cached_frame_seconds: cached.map(|c| c.0.median),
            cached_frame_seconds_lo: cached.map(|c| c.0.lo),
            cached_frame_seconds_hi: cached.map(|c| c.0.hi),
            cache_seconds: cached.map(|c| c.1),
            cached_max_diff: cached.map(|c| c.2),
            gpu_frame_seconds: gpu.as_ref().map(|g| g.frame.median),
            gpu_frame_seconds_lo: gpu.as_ref().map(|g| g.frame.lo),
            gpu_frame_seconds_hi: gpu.as_ref().map(|g| g.frame.hi),
            gpu_adapter,
            gpu_max_diff: gpu.as_ref().map(|g| g.max_diff),
        }])
    }

    fn time_columns() -> &'static [&'static str] {
        &[
            "frame_seconds",
            "frame_seconds_lo",
            "frame_seconds_hi",
            "cached_frame_seconds",
            "cached_frame_seconds_lo",
            "cached_frame_seconds_hi",
            "cache_seconds",
            "gpu_frame_seconds",
            "gpu_frame_seconds_lo",
            "gpu_frame_seconds_hi",
        ]
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "method",
            "rays",
            "frame_seconds",
            "rmse_vs_full_frequency",
            "one_minus_ssim",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        super::plane_report::report(dir, t)
    }

    fn figure(dir: &Path, t: &Results, out: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        super::plane_report::figure(dir, t, out, stem)
    }

    fn verdict(t: &Results) -> Result<String, Error> {
        super::plane_report::verdict(t)
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        super::plane_report::discussion(t)
    }
}
