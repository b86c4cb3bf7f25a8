//! A `budget_plane` run's frames timed: the direct CPU render it is scored by ([`cpu_frames`]),
//! and other ways — through the per-receiver caches on still one-occluder planes
//! ([`cached_frame`]), and on the GPU path.
//!
//! The device axis (`device = "cpu" | "gpu" | "auto"`): a run's frame timed on the
//! GPU path beside the CPU's, for the methods that have one — the papers' extrapolation from one
//! sampling sphere (`gpu_path`: the real-time sequence, whose sampling sphere encloses every
//! pose) or from clearance radii (`gpu_radial`), sub-volumes (`gpu_parts`), the full field
//! (`gpu_field`) and sphere sets by the chain, the union or SH exponentiation (`gpu_sets`).
//! The run's errors stay the CPU render's; the GPU images are compared with it
//! (`gpu_max_diff`, in the unit of the mean unshadowed irradiance) so a row says how far its GPU
//! frame is from the frame it scores. `gpu` needs an adapter (the config's `gpu` setting opens
//! it) and a GPU form of the run's method on its scene, and refuses otherwise, naming why;
//! `auto` times on the GPU where both exist and otherwise records none, saying why in
//! `gpu_adapter`.

use shscale_gpu::GpuContext;
use shscale_runner::timing::Timing;
use shscale_runner::{Ctx, KeyError};
use shscale_scene::gpu_methods::GpuForm;
use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;
use shscale_scene::Error;

/// Where a run's frame is timed besides the CPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The CPU only.
    Cpu,
    /// The GPU path too; refused without an adapter or a GPU form.
    Gpu,
    /// The GPU path too where an adapter and a GPU form exist; otherwise the CPU only, and the
    /// row says why.
    Auto,
}

shscale_names::names!(DeviceChoice { Cpu = "cpu", Gpu = "gpu", Auto = "auto" });

impl DeviceChoice {
    pub fn parse(s: &str) -> Result<Self, KeyError> {
        Self::from_name(s).ok_or_else(|| {
            KeyError::new(
                "device",
                format!("{s:?}: give one of {}", Self::NAMES.join(", ")),
            )
        })
    }
}

/// Whether the method of `rs` has a GPU form on `scene` (with `frames` frames,
/// [`shscale_scene::gpu_methods::gpu_form`]), or why not.
pub fn gpu_form(scene: &Scene, rs: &RenderSettings, frames: usize) -> Result<GpuForm, String> {
    let deforming = scene.occluders.iter().any(|o| o.deformer.is_some());
    if frames == 1 && deforming {
        return Err(
            "a still frame of a deforming scene: the GPU sequences pose t = f/frames, the plane's one frame is the rest pose".into(),
        );
    }
    match shscale_scene::gpu_methods::gpu_form(scene, rs) {
        Ok(Some(form)) => Ok(form),
        Ok(None) => Err(format!("{} has no GPU form", rs.method)),
        Err(e) => Err(e.to_string()),
    }
}

/// A run's frame on the GPU path as its `device` asks (`(device, frames)` of the run on `scene`
/// with `rs`, the CPU images and unshadowed image it is compared with): the timing, or none; and
/// the adapter that timed it, or why none did. `gpu` without an adapter is an error naming the
/// key (a method without a form was refused at plan time).
pub(crate) fn gpu_frame(
    (device, frames): (DeviceChoice, usize),
    (scene, rs): (&Scene, &RenderSettings),
    cpu: (&[Vec<f64>], &[f64]),
    ctx: &Ctx,
) -> Result<(Option<GpuTimed>, String), Error> {
    if device == DeviceChoice::Cpu {
        return Ok((None, "none: device = cpu".into()));
    }
    let Some(gpu) = shscale_scene::gpu_path::gpu_of(ctx) else {
        if device == DeviceChoice::Gpu {
            return Err(Error::config(format!(
                "device = \"gpu\": no adapter was opened (the config's gpu setting: \"auto\" or \"required\"); device = \"auto\" records the CPU only ({})",
                scene.file
            )));
        }
        return Ok((None, "none: no adapter".into()));
    };
    let form = match gpu_form(scene, rs, frames) {
        Ok(form) => form,
        Err(why) => return Ok((None, format!("none: {why}"))),
    };
    let timed = time_on_gpu((scene, rs), form, frames, gpu, ctx, cpu)?;
    Ok((Some(timed), gpu.describe()))
}

/// The GPU timing of a run: the frame's timing over the procedure's repeats (each the mean of
/// the sequence's frames after its first, host stages included) and the largest difference of
/// its images from the CPU's `cpu` (flat RGB per frame; the extrapolation's GPU sequence keeps its
/// last frame only), in the unit of the mean of `open`.
pub struct GpuTimed {
    pub frame: Timing,
    pub max_diff: f64,
}

/// Time `frames` frames of `scene` by the GPU `form` of the method of `rs` (see [`GpuTimed`]).
pub fn time_on_gpu(
    (scene, rs): (&Scene, &RenderSettings),
    form: GpuForm,
    frames: usize,
    gpu: &GpuContext,
    ctx: &Ctx,
    (cpu, open): (&[Vec<f64>], &[f64]),
) -> Result<GpuTimed, Error> {
    // A GPU sequence's first frame carries the device's one-off costs (a driver may compile a
    // pipeline at its first dispatch): a still plane (the only single frame with a GPU form) is
    // rendered twice and timed by its second frame; a sequence is timed by its frames after the
    // first.
    let run = frames.max(2);
    let (mut images, [t]) = ctx.timing.measure_parts(|| {
        let (images, seconds) = gpu_frames((scene, rs), form, run, gpu)?;
        let later = &seconds[1.min(seconds.len() - 1)..];
        let mean = later.iter().sum::<f64>() / later.len() as f64;
        Ok::<_, Error>((images, [mean]))
    })?;
    if frames == 1 {
        images.drain(..images.len().saturating_sub(1));
    }
    // The images the GPU path kept are the sequence's last ones.
    let skip = cpu.len() - images.len();
    let pairs = (images.iter().zip(&cpu[skip..])).flat_map(|(g, c)| {
        g.iter()
            .flatten()
            .map(|&a| f64::from(a))
            .zip(c.iter().copied())
    });
    Ok(GpuTimed {
        frame: t,
        max_diff: largest_difference(pairs, open),
    })
}

/// The largest `|a − b|` over `pairs`, in the unit of the mean of `open` (the mean unshadowed
/// irradiance).
fn largest_difference(pairs: impl Iterator<Item = (f64, f64)>, open: &[f64]) -> f64 {
    let unit = open.iter().sum::<f64>() / open.len().max(1) as f64;
    let diff = pairs.map(|(a, b)| (a - b).abs()).fold(0.0f64, f64::max);
    diff / unit.max(1e-300)
}

/// One frame's pixels, RGB per receiver.
type Image = Vec<[f32; 3]>;

/// One GPU sequence of `scene` by `form`: its images (every frame's, or the last for the papers'
/// sequence) and every frame's seconds (host stages and device).
fn gpu_frames(
    (scene, rs): (&Scene, &RenderSettings),
    form: GpuForm,
    frames: usize,
    gpu: &GpuContext,
) -> Result<(Vec<Image>, Vec<f64>), Error> {
    let (mut images, mut seconds) = (Vec::new(), Vec::new());
    if form == GpuForm::Sequence {
        let run = shscale_scene::gpu_path::render_sequence_gpu(scene, rs, frames, gpu)?;
        seconds.extend((run.frames.iter()).map(|f| f.seconds()));
        images.push(run.image.pixels);
    } else {
        shscale_scene::gpu_methods::render_gpu_frames(
            scene,
            rs,
            form,
            frames,
            gpu,
            &mut |f, px| {
                seconds.push(f.seconds);
                images.push(px.to_vec());
            },
        )?;
    }
    Ok((images, seconds))
}

/// The cost model's seconds of the cached frame ([`cached_frame`]) where it applies: the
/// re-sampling's rays at the rate (its shading is a few dot products per receiver).
pub(crate) fn cached_seconds(
    (scene, rs): (&Scene, &RenderSettings),
    frames: usize,
    rays: f64,
    rate: f64,
) -> f64 {
    if frames == 1 && shscale_scene::cached::CachedPlane::applies(scene, rs) {
        rays / rate
    } else {
        0.0
    }
}

/// The cached frame of a still scene ([`shscale_scene::cached::CachedPlane`]), where it
/// applies: its timing, the cache's build seconds and the largest difference of its image from
/// the direct render's `direct` (flat RGB) in the unit of the mean unshadowed irradiance.
pub fn cached_frame(
    (scene, rs): (&Scene, &RenderSettings),
    frames: usize,
    direct: &[f64],
    open: &[f64],
    ctx: &Ctx,
) -> Result<Option<(shscale_runner::timing::Timing, f64, f64)>, Error> {
    if frames != 1 {
        return Ok(None);
    }
    let Some(plane) = shscale_scene::cached::CachedPlane::new(scene, rs)? else {
        return Ok(None);
    };
    let (img, t) = ctx.timing.measure(|| plane.frame())?;
    let diff = largest_difference(
        img.iter().flatten().copied().zip(direct.iter().copied()),
        open,
    );
    Ok(Some((t, plane.build_seconds, diff)))
}

/// Seconds of one GPU-timed repetition besides its frames (`device` ≠ `cpu`): the sequence's
/// buffers, pipelines (a software device compiles them at the first dispatch) and receiver
/// set-up, made per repetition. `budget_plane_gpu.toml` on Mesa lavapipe (32 runs × 6
/// repetitions, 90.2 s, 2026-12-05, the development VM) puts it near 0.5 s.
pub(crate) const GPU_SEQUENCE_SECONDS: f64 = 0.5;

/// The cost model's seconds of a run's GPU-timed repetition besides the CPU's (`frame`: the CPU
/// frame's estimate, all its frames): none for `device = "cpu"`, else a sequence's set-up and up
/// to twice its frames (a still plane is rendered twice, [`time_on_gpu`]) at the CPU frame's
/// cost (a software device's; an upper bound on a GPU).
pub(crate) fn gpu_seconds(device: DeviceChoice, frame: f64) -> f64 {
    if device == DeviceChoice::Cpu {
        0.0
    } else {
        GPU_SEQUENCE_SECONDS + 2.0 * frame
    }
}

/// A run's frames rendered and timed: each the render without the stages every method shares
/// (the light's projection, the BVH build); the time the mean over the sequence's frames, by
/// the timing procedure.
pub fn cpu_frames(
    scenes: &[Scene],
    rs: &RenderSettings,
    ctx: &Ctx,
) -> Result<
    (
        Vec<shscale_scene::render::RenderOutput>,
        shscale_runner::timing::Timing,
    ),
    Error,
> {
    let (imgs, [t]) = ctx.timing.measure_parts(|| {
        let mut imgs = Vec::with_capacity(scenes.len());
        let mut total = 0.0;
        for s in scenes {
            let t0 = std::time::Instant::now();
            let img = shscale_scene::render::render(s, rs)?;
            let shared: f64 = (img.stages.iter())
                .filter(|(s, _)| s == "light_projection" || s == "bvh_build")
                .map(|(_, v)| v)
                .sum();
            total += (t0.elapsed().as_secs_f64() - shared).max(0.0);
            imgs.push(img);
        }
        Ok::<_, Error>((imgs, [total / scenes.len() as f64]))
    })?;
    Ok((imgs, t))
}
