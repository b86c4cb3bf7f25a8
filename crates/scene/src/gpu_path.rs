//! The GPU path of scenes and experiment kinds: under the `gpu = "auto" | "off" | "required"`
//! setting ([`GpuMode`]) of scenes and experiments, opening the adapter (a one-line notice and the CPU path when there is none, an
//! error when one is required), rendering a deforming single-mesh sequence on the GPU, and timing
//! GPU BSV sampling for experiment runs.

use crate::error::Error;
use crate::frame::{light_of, receiver_grid, sequence_sphere, table_for};
use crate::render::RenderOutput;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use shscale_field::shading::Shader;
use shscale_field::{Bsv, BsvSample, Layout};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{Mesh, Sphere};
/// The adapter the GPU paths run on (re-exported for callers that hold one).
pub use shscale_gpu::GpuContext;
use shscale_gpu::{GpuSequence, GpuStageTimes, ReceiverSetup, Receivers};
use shscale_runner::{Ctx, Device, GpuMode};
use shscale_scaling::Eta;
use std::time::Instant;

/// Open the adapter as `mode` says: `Ok(None)` for `off`, and for `auto` without an adapter
/// (after a one-line notice on stderr); an error for `required` without one.
pub fn open_gpu(mode: GpuMode) -> Result<Option<GpuContext>, Error> {
    match mode {
        GpuMode::Off => Ok(None),
        GpuMode::Auto => match GpuContext::new() {
            Ok(c) => Ok(Some(c)),
            Err(e) => {
                eprintln!("notice: {e}; continuing with the CPU path");
                Ok(None)
            }
        },
        GpuMode::Required => GpuContext::new()
            .map(Some)
            .map_err(|e| Error::config(format!("gpu = \"required\": {e}"))),
    }
}

/// [`open_gpu`] as the runner's [`Device`] (what a kind's [`shscale_runner::Kind::open_device`]
/// returns): described as the adapter describes itself.
pub fn open_device(mode: GpuMode) -> Result<Option<Device>, Error> {
    Ok(open_gpu(mode)?.map(|c| Device::new(c.describe(), c)))
}

/// The GPU a kind's runs see: the device it opened, when that is a [`GpuContext`].
pub fn gpu_of<'a>(ctx: &Ctx<'a>) -> Option<&'a GpuContext> {
    ctx.device.and_then(|d| d.get::<GpuContext>())
}

/// How the GPU sequence of the papers' extrapolation runs its frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuFrames {
    /// The host poses and refits each frame, then the device runs it.
    Sequential,
    /// The host poses and refits frame i + 1 while the device runs frame i.
    Pipelined,
    /// The device poses and refits every frame (`shscale_gpu::pose`); the host only writes the
    /// pose's uniform (and builds a tree when the rebuild rule finds it due).
    DevicePose,
    /// Posed on the device, [`shscale_gpu::sequence::FRAMES_IN_FLIGHT`] frames in flight: the
    /// host submits frame i + 1 before waiting for frame i, and waits for each frame alone; a
    /// due tree is built on a host thread and swapped in when done; a frame's time is the period
    /// between completions (timestamp queries needed).
    DeviceInFlight,
}

/// Per-frame statistics of the GPU sequence.
#[derive(Clone, Debug, Default)]
pub struct GpuFrameStats {
    pub frame: usize,
    /// Host deformation (as the CPU path; 0 when posed on the device, whose pose is
    /// `gpu.deform_seconds`).
    pub deform_seconds: f64,
    /// The frame's stages; in a pipelined sequence its `frame_seconds` is the frame's period
    /// (from the previous frame's completion to this one's), which its stages overlap.
    pub gpu: GpuStageTimes,
    /// Pipelined: the host posed and refitted this frame while the device ran the previous one.
    pub pipelined: bool,
}

impl GpuFrameStats {
    /// The frame's wall time: posing and the GPU frame one after the other, or the pipelined
    /// frame's period.
    pub fn seconds(&self) -> f64 {
        if self.pipelined {
            self.gpu.frame_seconds
        } else {
            self.deform_seconds + self.gpu.frame_seconds
        }
    }

    /// The sum of the frame's stages (host and device): what a frame would take one stage after
    /// another; [`Self::seconds`] below it is the overlap a pipelined sequence gained.
    pub fn stage_sum(&self) -> f64 {
        let g = &self.gpu;
        self.deform_seconds
            + g.bvh_seconds
            + g.deform_seconds
            + g.refit_seconds
            + g.upload_seconds
            + g.sampling_seconds
            + g.projection_seconds
            + g.shading_seconds
    }
}

/// The single mesh occluder of a scene, or an error naming why the GPU path cannot take it.
/// Whether the GPU sequence of the papers' extrapolation ([`render_sequence_gpu`]) takes
/// `scene` rendered with `rs`: one mesh occluder, `N ≤ 8`, no local lights (the GPU shades the
/// environment's transfer only); or why not.
pub fn check(scene: &Scene, rs: &RenderSettings) -> Result<(), Error> {
    single_mesh(scene, rs.order)?;
    // The GPU sequences extrapolate the scaled coefficients as they are: a clamped run timed
    // there would record the time of another computation (issue 57).
    if rs.plausibility != shscale_field::extrapolate::Plausibility::None {
        return Err(Error::config(format!(
            "{}: plausibility = \"clamp\": the GPU sequence has no plausibility clamp (it runs on the CPU only; device = \"cpu\" or plausibility = \"none\")",
            scene.file
        )));
    }
    if !scene.light_sources.is_empty() {
        return Err(Error::config(format!(
            "{}: the GPU sequence shades the environment only; local lights are shaded on the CPU",
            scene.file
        )));
    }
    Ok(())
}

/// What every single-mesh GPU sequence sets up first: the occluder placed at rest, its poser,
/// the light's transfer for an upward receiver, the receivers, and the BVH update its deformer
/// prefers.
pub(crate) struct MeshSequence<'a> {
    pub occluder: &'a crate::scene::OccluderSpec,
    pub rest: Mesh,
    pub poser: Option<crate::frame::Poser>,
    pub transfer: [Vec<f64>; 3],
    pub recv: Vec<DVec3>,
    pub strategy: UpdateStrategy,
}

impl<'a> MeshSequence<'a> {
    /// The sequence of `scene`'s one mesh occluder, shaded at SH order `order`.
    pub(crate) fn of(scene: &'a Scene, order: usize) -> Result<Self, Error> {
        let occluder = single_mesh(scene, order)?;
        let rest = occluder.placed()?;
        let poser = (occluder.deformer).map(|(k, a)| crate::frame::Poser::new(&rest, k, a));
        let light = light_of(scene, order)?;
        let transfer = Shader::new(order)?.transfer(&light, DVec3::Z);
        let strategy =
            (occluder.deformer).map_or(UpdateStrategy::Rebuild, |(k, _)| k.preferred_update());
        Ok(Self {
            occluder,
            rest,
            poser,
            transfer,
            recv: receiver_grid(scene),
            strategy,
        })
    }

    /// Pose frame time `t` into `posed` (the rest pose without a deformer); its seconds.
    pub(crate) fn pose(&self, t: f64, posed: &mut Mesh) -> f64 {
        let t0 = Instant::now();
        if let Some(p) = &self.poser {
            p.pose(&self.rest, t, posed);
        }
        t0.elapsed().as_secs_f64()
    }
}

/// The one mesh occluder of `scene` rendered at SH order `order`, or why the GPU path cannot
/// take it.
pub(crate) fn single_mesh(
    scene: &Scene,
    order: usize,
) -> Result<&crate::scene::OccluderSpec, Error> {
    match scene.occluders.as_slice() {
        [o] if o.mesh != "sphere" => {
            if order > shscale_gpu::MAX_GPU_ORDER {
                return Err(Error::config(format!(
                    "{}: --gpu: order {} exceeds the GPU path's {}",
                    scene.file,
                    order,
                    shscale_gpu::MAX_GPU_ORDER
                )));
            }
            Ok(o)
        }
        _ => Err(Error::config(format!(
            "{}: --gpu: the GPU path renders scenes with exactly one mesh occluder (the analytic sphere has no triangles)",
            scene.file
        ))),
    }
}

/// A BSV carrying only the layout's directions on `sphere` (no coefficients): enough to locate
/// receivers in its spherical triangulation.
pub(crate) fn layout_only_bsv(layout: Layout, sphere: Sphere) -> Result<Bsv, Error> {
    let samples = layout
        .directions()
        .into_iter()
        .map(|dir| BsvSample {
            dir,
            pos: sphere.center + sphere.radius * dir,
            coeffs: Vec::new(),
            on_surface: false,
        })
        .collect();
    Ok(Bsv::from_samples(
        layout,
        sphere,
        sphere.radius,
        samples,
        0,
    )?)
}

/// Point location of every receiver's direction in the spherical triangulation of the layout
/// (on the host): the three samples and weights each receiver interpolates.
fn receiver_locations(
    layout: Layout,
    sampling: Sphere,
    recv: &[DVec3],
) -> Result<Vec<[(u32, f64); 3]>, Error> {
    let bsv = layout_only_bsv(layout, sampling)?;
    Ok(recv
        .iter()
        .map(|p| {
            let d = *p - sampling.center;
            let d = if d.length() > 0.0 { d } else { DVec3::Z };
            bsv.locate(d.normalize())
        })
        .collect())
}

/// Render `frames ≥ 1` frames of a deforming single-mesh scene with the extrapolated method on
/// the GPU — the twin of [`crate::render::render_sequence`] for one occluder (same fixed sampling
/// sphere, k-table, poses, and the same per-receiver `U`, built on the GPU). Returns the last
/// frame's image, per-frame statistics and the one-off setup time (table, point location,
/// buffers, pipelines, GPU receiver setup) in seconds.
pub fn render_sequence_gpu(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
) -> Result<GpuSequenceRun, Error> {
    render_sequence_gpu_with(scene, rs, frames, ctx, GpuFrames::Sequential)
}

/// [`render_sequence_gpu`] with its frames run as `mode` says. Pipelined (timestamp queries
/// needed): the host poses frame i + 1 and refits its BVH while the device runs frame i (the
/// upload waits for frame i to finish, whose timestamps are read first); every frame's stages are
/// kept, its `frame_seconds` the period between completions, so the overlap is the stages' sum
/// less it ([`GpuFrameStats::stage_sum`]); the images are the sequential path's. Posed on the
/// device: the deformation and the refit are two more device stages (`gpu.deform_seconds`,
/// `gpu.refit_seconds`); the images differ from the host-posed ones only where the f32 pose
/// moves a grazing ray. Posed on the device with frames in flight: the same passes, frame i + 1
/// submitted before frame i is waited for, each frame's time its period as when pipelined; the
/// rebuild rule reads a frame's area when it completes and a due tree is built on a host thread
/// while frames go on with the old one, so it lands frames later than posed one at a time (the
/// tree's shape, never the rays' answers).
pub fn render_sequence_gpu_with(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    mode: GpuFrames,
) -> Result<GpuSequenceRun, Error> {
    let t_setup = Instant::now();
    let frames = frames.max(1);
    let m = MeshSequence::of(scene, rs.order)?;
    let s = sequence_sphere(&m.rest, m.occluder.deformer, frames);
    let sampling = Sphere {
        center: s.center,
        radius: s.radius * rs.sampling_radius,
    };
    let (recv, transfer) = (&m.recv, &m.transfer);
    let table = table_for((scene, rs), sampling, recv, Eta::Plain)?;
    // Point location in the spherical triangulation stays on the host; k-table scaling and the
    // rotations of every receiver run on the GPU (ReceiverSetup).
    let locations = receiver_locations(rs.layout, sampling, recv)?;
    let dirs = rs.layout.directions();
    let mut seq = GpuSequence::new(
        ctx,
        &m.rest,
        m.strategy,
        rs.order,
        rs.hemisphere_res,
        sampling,
        &dirs,
        Receivers::Build(ReceiverSetup {
            table: &table,
            transfer,
            receivers: recv,
            locations: &locations,
            sampling,
            radii: None,
        }),
    )?;
    let setup = t_setup.elapsed().as_secs_f64();
    let stats = run_frames(&mut seq, ctx, &m, frames, mode)?;
    let out = RenderOutput::plane(scene, seq.read_image(ctx)?);
    Ok(GpuSequenceRun {
        host_rebuilds: seq.poser().map_or(0, |p| p.rebuilds),
        background_build_seconds: seq.poser().map_or(0.0, |p| p.background_seconds),
        image: out,
        frames: stats,
        setup_seconds: setup,
        receiver_setup_seconds: seq.receiver_setup_seconds,
    })
}

fn run_frames(
    seq: &mut GpuSequence,
    ctx: &GpuContext,
    m: &MeshSequence,
    frames: usize,
    mode: GpuFrames,
) -> Result<Vec<GpuFrameStats>, Error> {
    let (rest, poser, strategy) = (&m.rest, m.poser.as_ref(), m.strategy);
    let mut posed: Mesh = rest.clone();
    let pose = |f: usize, posed: &mut Mesh| m.pose(f as f64 / frames as f64, posed);
    let mut stats = Vec::with_capacity(frames);
    let stat = |frame, deform_seconds, gpu| GpuFrameStats {
        frame,
        deform_seconds,
        gpu,
        pipelined: false,
    };
    match mode {
        GpuFrames::Pipelined => {
            pipelined_frames(seq, ctx, (frames, &pose, &mut posed), &mut stats)?
        }
        GpuFrames::DevicePose => {
            seq.pose_on_device(ctx, rest, poser.map(|p| p.deformer()), strategy)?;
            for f in 0..frames {
                stats.push(stat(f, 0.0, seq.frame_at(ctx, f as f64 / frames as f64)?));
            }
        }
        GpuFrames::DeviceInFlight => {
            seq.pose_on_device(ctx, rest, poser.map(|p| p.deformer()), strategy)?;
            seq.rebuild_in_background()?;
            in_flight_frames(seq, ctx, frames, &mut stats)?;
        }
        GpuFrames::Sequential => {
            for f in 0..frames {
                let deform_seconds = pose(f, &mut posed);
                stats.push(stat(f, deform_seconds, seq.frame(ctx, &posed)?));
            }
        }
    }
    Ok(stats)
}

/// The loop of [`GpuFrames::DeviceInFlight`]: submit frames until
/// [`shscale_gpu::sequence::FRAMES_IN_FLIGHT`] are in flight, then finish the oldest before
/// each next submission (its period ends at its completion), and finish the rest.
fn in_flight_frames(
    seq: &mut GpuSequence,
    ctx: &GpuContext,
    frames: usize,
    stats: &mut Vec<GpuFrameStats>,
) -> Result<(), Error> {
    let mut period = Instant::now();
    let mut finish = |seq: &mut GpuSequence, stats: &mut Vec<GpuFrameStats>| {
        let done = seq.finish_oldest(ctx)?;
        if let Some(mut gpu) = done {
            gpu.frame_seconds = period.elapsed().as_secs_f64();
            period = Instant::now();
            stats.push(GpuFrameStats {
                frame: stats.len(),
                deform_seconds: 0.0,
                gpu,
                pipelined: true,
            });
        }
        Ok::<_, Error>(done.is_some())
    };
    for f in 0..frames {
        if f >= shscale_gpu::sequence::FRAMES_IN_FLIGHT {
            finish(seq, stats)?;
        }
        seq.submit_at(ctx, f as f64 / frames as f64)?;
    }
    while finish(seq, stats)? {}
    Ok(())
}

/// Poses frame `f` into the mesh given; its seconds.
type PoseFn<'a> = dyn Fn(usize, &mut Mesh) -> f64 + 'a;

/// The pipelined loop of [`render_sequence_gpu_with`]: frame 0 posed, refitted and submitted;
/// then for every next frame, pose and refit it (the device still running the previous one),
/// finish the previous one (its period ends there) and submit this one; finish the last.
fn pipelined_frames(
    seq: &mut GpuSequence,
    ctx: &GpuContext,
    (frames, pose, posed): (usize, &PoseFn, &mut Mesh),
    stats: &mut Vec<GpuFrameStats>,
) -> Result<(), Error> {
    let mut period = Instant::now();
    let mut deform = pose(0, posed);
    let mut bvh = seq.prepare(posed)?;
    let mut upload = seq.submit(ctx)?;
    for f in 1..=frames {
        // The next frame's host half, overlapping the device's work on frame f − 1.
        let next = if f < frames {
            let d = pose(f, posed);
            Some((d, seq.prepare(posed)?))
        } else {
            None
        };
        let [sampling, projection, shading] = seq.finish(ctx)?;
        stats.push(GpuFrameStats {
            frame: f - 1,
            deform_seconds: deform,
            gpu: GpuStageTimes {
                bvh_seconds: bvh,
                upload_seconds: upload,
                sampling_seconds: sampling,
                projection_seconds: projection,
                shading_seconds: shading,
                frame_seconds: period.elapsed().as_secs_f64(),
                timestamps: true,
                ..GpuStageTimes::default()
            },
            pipelined: true,
        });
        period = Instant::now();
        if let Some((d, b)) = next {
            (deform, bvh) = (d, b);
            upload = seq.submit(ctx)?;
        }
    }
    Ok(())
}

/// What [`render_sequence_gpu`] returns.
pub struct GpuSequenceRun {
    /// The last frame.
    pub image: RenderOutput,
    pub frames: Vec<GpuFrameStats>,
    /// One-off setup, wall clock (includes `receiver_setup_seconds`).
    pub setup_seconds: f64,
    /// Posed on the device: the frames whose tree was built on the host (the rebuild rule).
    pub host_rebuilds: usize,
    /// Frames in flight: the host seconds of the trees built on a host thread, off the frames'
    /// path (0 otherwise).
    pub background_build_seconds: f64,
    /// Device time of the per-receiver setup (k-table scaling and rotations, 25 600 receivers
    /// for the bench scenes).
    pub receiver_setup_seconds: f64,
}

/// Median GPU times of BSV sampling and SH conversion for one mesh, layout, order and `H` on a
/// sampling sphere (`repeats` frames after one warm-up), for experiment rows.
#[derive(Clone, Debug)]
pub struct GpuBsvTiming {
    pub sampling_seconds: f64,
    pub conversion_seconds: f64,
    pub device: String,
}

/// Time GPU BSV sampling of `mesh` (see [`GpuBsvTiming`]).
pub fn time_gpu_bsv(
    ctx: &GpuContext,
    mesh: &Mesh,
    layout: Layout,
    order: usize,
    h: usize,
    sampling: Sphere,
    repeats: usize,
) -> Result<GpuBsvTiming, Error> {
    let (a, b) = shscale_gpu::sequence::time_bsv(
        ctx,
        mesh,
        order,
        h,
        sampling,
        &layout.directions(),
        repeats.max(1),
    )?;
    Ok(GpuBsvTiming {
        sampling_seconds: a,
        conversion_seconds: b,
        device: ctx.describe(),
    })
}
