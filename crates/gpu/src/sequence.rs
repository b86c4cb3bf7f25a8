//! One deforming entity over a receiver plane, frame by frame on the GPU: host BVH update
//! (obvhs rebuild or refit, flattened), upload, then three compute passes — ray casting, SH
//! projection, receiver shading — in one submission, each pass timed by timestamps (or, without
//! them, submitted alone and timed by the synchronised wall clock). Or, posed on the device
//! ([`GpuSequence::pose_on_device`], `crate::pose`): the deformation and the BVH refit are two
//! more timed passes before those three, and a frame uploads only the pose's uniform; such
//! frames may also run [`FRAMES_IN_FLIGHT`] at a time ([`GpuSequence::submit_at`],
//! [`GpuSequence::finish_oldest`]): the host submits the next frame before the device has
//! finished the last, waits for each frame alone, and reads its timestamps and relative area
//! from staging copies recorded in the frame's own submission.

use crate::bvh::FlatBvh;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::pose::GpuPoser;
use crate::sampling::GpuSampler;
use crate::shading::{GpuShader, ReceiverSetup};
use crate::timing::StageTimer;
use glam::DVec3;
use shscale_field::receivers::ReceiverCache;
use shscale_geometry::deform::Deformer;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{Mesh, Sphere, RAY_EPS};
use std::collections::VecDeque;
use std::time::Instant;

/// Device-posed frames submitted before the oldest is waited for ([`GpuSequence::submit_at`]):
/// two, the double buffering of a real-time renderer.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// The five timed passes of a frame posed on the device.
const DEVICE_POSED_STAGES: [&str; 5] = [
    "deform",
    "bvh refit",
    "bsv sampling",
    "sh conversion",
    "shadowing",
];

/// Record stage `i` of [`DEVICE_POSED_STAGES`] into `pass`.
fn record_posed_stage(
    (poser, sampler, shader): (&GpuPoser, &GpuSampler, &GpuShader),
    i: usize,
    pass: &mut wgpu::ComputePass<'_>,
) {
    match i {
        0 => poser.record_deform(pass),
        1 => poser.record_refit(pass),
        2 => sampler.record_cast(pass),
        3 => sampler.record_project(pass),
        _ => shader.record(pass),
    }
}

/// One slot of the frames in flight: its timer and relative-area staging buffer.
struct FlightSlot {
    timer: StageTimer,
    area: wgpu::Buffer,
}

/// A submitted frame not yet finished.
struct Submitted {
    slot: usize,
    index: wgpu::SubmissionIndex,
    /// The host's rebuild and upload seconds.
    host: (f64, f64),
    /// The poser's rebuild count at submission: a frame measured on a tree rebuilt since says
    /// nothing about the current tree, and its area is not read.
    generation: usize,
}

/// Frames in flight: [`FRAMES_IN_FLIGHT`] slots and the frames submitted, oldest first.
struct Flight {
    slots: Vec<FlightSlot>,
    queue: VecDeque<Submitted>,
    next: usize,
}

/// Timings of one GPU frame, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuStageTimes {
    /// Host: BVH rebuild/refit and flattening (posed on the device: the host's rebuilds only).
    pub bvh_seconds: f64,
    /// Device: the pose (posed on the device, else 0: the host's pose is the caller's).
    pub deform_seconds: f64,
    /// Device: the BVH refit (posed on the device, else 0).
    pub refit_seconds: f64,
    /// Host → device: nodes, triangles, parameters (posed on the device: the pose's uniform).
    pub upload_seconds: f64,
    /// Device: ray casting at every base-sphere sample ("BSV sampling").
    pub sampling_seconds: f64,
    /// Device: projection to SH ("SH conversion").
    pub projection_seconds: f64,
    /// Device: every receiver ("shadowing").
    pub shading_seconds: f64,
    /// Wall clock of the whole frame, BVH update to completion.
    pub frame_seconds: f64,
    /// Device stages from timestamp queries (else the wall clock).
    pub timestamps: bool,
}

/// Where a sequence's per-receiver data comes from.
pub enum Receivers<'a> {
    /// A cache built on the CPU (`ReceiverCache::build`), uploaded.
    Cache(&'a ReceiverCache),
    /// Built on the GPU (k-table scaling and rotations per receiver; location on the host).
    Build(ReceiverSetup<'a>),
}

/// The GPU pipeline of one deforming entity.
pub struct GpuSequence {
    bvh: FlatBvh,
    sampler: GpuSampler,
    shader: GpuShader,
    timer: StageTimer,
    /// Device seconds of the GPU receiver setup (0 for an uploaded cache).
    pub receiver_setup_seconds: f64,
    /// The prepared frame's ray offset ([`Self::prepare`]).
    tmin: f64,
    /// The pose and refit on the device ([`Self::pose_on_device`]).
    poser: Option<GpuPoser>,
    /// Device-posed frames in flight ([`Self::submit_at`]), made at the first submission.
    flight: Option<Flight>,
}

impl GpuSequence {
    /// Set up for `mesh` (any pose of the sequence: same topology throughout) sampled on the fixed
    /// `sampling` sphere along unit `dirs`, order `N ≤ 8`, `H × H` rays per sample, shading the
    /// receivers given (for the same sphere, layout and order).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        mesh: &Mesh,
        strategy: UpdateStrategy,
        order: usize,
        h: usize,
        sampling: Sphere,
        dirs: &[DVec3],
        receivers: Receivers<'_>,
    ) -> Result<Self, GpuError> {
        let bvh = FlatBvh::build(mesh, strategy)?;
        let ntris = mesh.triangles.len();
        let mut sampler = GpuSampler::new(
            ctx,
            order,
            h,
            sampling.center,
            sampling.radius,
            dirs,
            (2 * ntris, ntris),
        )?;
        let (shader, receiver_setup_seconds) = match receivers {
            Receivers::Cache(cache) => (
                GpuShader::new(
                    ctx,
                    cache,
                    &sampler.params_buf,
                    &mut sampler.params,
                    &sampler.coeffs_buf,
                )?,
                0.0,
            ),
            Receivers::Build(setup) => GpuShader::build_on_gpu(
                ctx,
                &setup,
                &sampler.params_buf,
                &mut sampler.params,
                &sampler.coeffs_buf,
            )?,
        };
        let timer = StageTimer::new(ctx, 3);
        Ok(Self {
            bvh,
            sampler,
            shader,
            timer,
            receiver_setup_seconds,
            tmin: 0.0,
            poser: None,
            flight: None,
        })
    }

    /// Render one frame for the posed `mesh`.
    pub fn frame(&mut self, ctx: &GpuContext, mesh: &Mesh) -> Result<GpuStageTimes, GpuError> {
        self.host_posed()?;
        let t0 = Instant::now();
        let (bvh_seconds, t1) = self.sampler.follow(ctx, &mut self.bvh, mesh, None)?;
        let upload_seconds = t1.elapsed().as_secs_f64();
        let mut times = GpuStageTimes {
            bvh_seconds,
            upload_seconds,
            timestamps: self.timer.uses_timestamps(),
            ..Default::default()
        };
        let stage = |i: u32, enc: &mut wgpu::CommandEncoder| {
            let labels = ["bsv sampling", "sh conversion", "shadowing"];
            let mut pass = enc.begin_compute_pass(&self.timer.pass(labels[i as usize], i));
            match i {
                0 => self.sampler.record_cast(&mut pass),
                1 => self.sampler.record_project(&mut pass),
                _ => self.shader.record(&mut pass),
            }
        };
        if self.timer.uses_timestamps() {
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            for i in 0..3 {
                stage(i, &mut enc);
            }
            self.timer.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            ctx.wait()?;
            times.frame_seconds = t0.elapsed().as_secs_f64();
            let s = self.timer.read(ctx)?.expect("timestamps enabled");
            times.sampling_seconds = s[0];
            times.projection_seconds = s[1];
            times.shading_seconds = s[2];
        } else {
            let mut wall = [0.0; 3];
            for i in 0..3 {
                let t = Instant::now();
                let mut enc = ctx
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
                stage(i, &mut enc);
                ctx.queue.submit([enc.finish()]);
                ctx.wait()?;
                wall[i as usize] = t.elapsed().as_secs_f64();
            }
            times.frame_seconds = t0.elapsed().as_secs_f64();
            [
                times.sampling_seconds,
                times.projection_seconds,
                times.shading_seconds,
            ] = wall;
        }
        Ok(times)
    }

    /// From now on pose `rest` by `deformer` and refit the tree on the device
    /// ([`crate::pose`]): frames are rendered by [`Self::frame_at`] from their time alone, and
    /// only the pose's uniform is uploaded (the tree is built on the host only when the rebuild
    /// rule finds it due, `strategy` `Refit` never). The ray offset is `RAY_EPS` times the rest
    /// pose's bounding radius (the host never sees the posed mesh; the host path's per-frame
    /// radius differs by the pose's change of it, and the offset matters only to rays starting
    /// within it of the surface).
    pub fn pose_on_device(
        &mut self,
        ctx: &GpuContext,
        rest: &Mesh,
        deformer: Option<&Deformer>,
        strategy: UpdateStrategy,
    ) -> Result<(), GpuError> {
        let poser = GpuPoser::new(ctx, rest, deformer, strategy, &self.sampler)?;
        self.sampler
            .set_tmin(ctx, RAY_EPS * rest.bounding_sphere().radius);
        self.timer = StageTimer::new(ctx, 5);
        self.poser = Some(poser);
        Ok(())
    }

    /// One frame at time `t` posed and refitted on the device ([`Self::pose_on_device`] first):
    /// five passes — deform, refit, ray casting, projection, shading — each timed.
    pub fn frame_at(&mut self, ctx: &GpuContext, t: f64) -> Result<GpuStageTimes, GpuError> {
        let t0 = Instant::now();
        let Some(poser) = self.poser.as_mut() else {
            return Err(GpuError::Input(
                "frame_at needs the pose on the device (pose_on_device)".into(),
            ));
        };
        let bvh_seconds = poser.prepare(ctx, t)?;
        let upload_seconds = t0.elapsed().as_secs_f64() - bvh_seconds;
        let stages = (&*poser, &self.sampler, &self.shader);
        let s = self.timer.run(ctx, DEVICE_POSED_STAGES, |i, pass| {
            record_posed_stage(stages, i, pass)
        })?;
        self.poser.as_mut().expect("set above").after_frame(ctx)?;
        Ok(GpuStageTimes {
            bvh_seconds,
            deform_seconds: s[0],
            refit_seconds: s[1],
            upload_seconds,
            sampling_seconds: s[2],
            projection_seconds: s[3],
            shading_seconds: s[4],
            frame_seconds: t0.elapsed().as_secs_f64(),
            timestamps: self.timer.uses_timestamps(),
        })
    }

    /// Posed on the device ([`Self::pose_on_device`] first): build due trees on a host thread
    /// while frames go on refitting the old one ([`GpuPoser::rebuild_in_background`]).
    pub fn rebuild_in_background(&mut self) -> Result<(), GpuError> {
        match self.poser.as_mut() {
            Some(p) => {
                p.rebuild_in_background();
                Ok(())
            }
            None => Err(GpuError::Input(
                "rebuilding in the background needs the pose on the device (pose_on_device)".into(),
            )),
        }
    }

    /// Frames in flight: pose frame time `t` on the device and submit its five passes without
    /// waiting (at most [`FRAMES_IN_FLIGHT`] submitted and not finished: [`Self::finish_oldest`]
    /// first). The pose's uniform is written on the queue after the previous frame's commands,
    /// so the frame still running reads its own. Timestamp queries needed.
    pub fn submit_at(&mut self, ctx: &GpuContext, t: f64) -> Result<(), GpuError> {
        let Some(poser) = self.poser.as_mut() else {
            return Err(GpuError::Input(
                "submit_at needs the pose on the device (pose_on_device)".into(),
            ));
        };
        if !ctx.timestamps {
            return Err(GpuError::Input(
                "frames in flight need timestamp queries, which this adapter lacks".into(),
            ));
        }
        let flight = self.flight.get_or_insert_with(|| Flight {
            slots: (0..FRAMES_IN_FLIGHT)
                .map(|_| FlightSlot {
                    timer: StageTimer::new(ctx, 5),
                    area: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("relative area in flight"),
                        size: 16,
                        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    }),
                })
                .collect(),
            queue: VecDeque::new(),
            next: 0,
        });
        if flight.queue.len() >= FRAMES_IN_FLIGHT {
            return Err(GpuError::Input(format!(
                "{FRAMES_IN_FLIGHT} frames are in flight: finish the oldest first"
            )));
        }
        let t0 = Instant::now();
        let rebuild = poser.prepare(ctx, t)?;
        let upload = t0.elapsed().as_secs_f64() - rebuild;
        let slot = flight.next % FRAMES_IN_FLIGHT;
        flight.next += 1;
        let poser = &*poser;
        let timer = &flight.slots[slot].timer;
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        for (i, label) in DEVICE_POSED_STAGES.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&timer.pass(label, i as u32));
            record_posed_stage((poser, &self.sampler, &self.shader), i, &mut pass);
        }
        timer.resolve_to_staging(&mut enc);
        if poser.adaptive() {
            poser.record_area_copy(&mut enc, &flight.slots[slot].area);
        }
        let index = ctx.queue.submit([enc.finish()]);
        flight.queue.push_back(Submitted {
            slot,
            index,
            host: (rebuild, upload),
            generation: poser.rebuilds,
        });
        Ok(())
    }

    /// Frames in flight: wait for the oldest submitted frame alone (later ones keep running),
    /// read its five device stages and, when its tree is still the current one, its relative
    /// area for the rebuild rule; its times (`frame_seconds` left 0: the caller's period). `None`
    /// when no frame is in flight.
    pub fn finish_oldest(&mut self, ctx: &GpuContext) -> Result<Option<GpuStageTimes>, GpuError> {
        let (Some(flight), Some(poser)) = (self.flight.as_mut(), self.poser.as_mut()) else {
            return Ok(None);
        };
        let Some(done) = flight.queue.pop_front() else {
            return Ok(None);
        };
        let slot = &flight.slots[done.slot];
        let s = (slot.timer.read_after(ctx, done.index.clone())?)
            .expect("submit_at requires timestamps");
        if poser.adaptive() && done.generation == poser.rebuilds {
            poser.after_frame_read(&ctx.map_after(&slot.area, 16, done.index)?);
        }
        Ok(Some(GpuStageTimes {
            bvh_seconds: done.host.0,
            upload_seconds: done.host.1,
            deform_seconds: s[0],
            refit_seconds: s[1],
            sampling_seconds: s[2],
            projection_seconds: s[3],
            shading_seconds: s[4],
            frame_seconds: 0.0,
            timestamps: true,
        }))
    }

    /// `Ok` unless frames are posed on the device (whose tree a host upload would overwrite).
    fn host_posed(&self) -> Result<(), GpuError> {
        match self.poser {
            Some(_) => Err(GpuError::Input(
                "this sequence is posed on the device: render its frames by frame_at".into(),
            )),
            None => Ok(()),
        }
    }

    /// The device pose, when set ([`Self::pose_on_device`]).
    pub fn poser(&self) -> Option<&GpuPoser> {
        self.poser.as_ref()
    }

    /// Pipelined frames, host half: update the BVH for the posed `mesh` (host only: the device
    /// may still be running the previous frame, which reads its own uploaded copy). Returns the
    /// seconds it took. Then [`Self::finish`] the previous frame, and [`Self::submit`] this one.
    pub fn prepare(&mut self, mesh: &Mesh) -> Result<f64, GpuError> {
        self.host_posed()?;
        let t0 = Instant::now();
        self.bvh.update(mesh)?;
        self.tmin = RAY_EPS * mesh.bounding_sphere().radius;
        Ok(t0.elapsed().as_secs_f64())
    }

    /// Pipelined frames, device half: upload the prepared BVH and submit the three passes with
    /// their timestamps, without waiting (timestamps only: without them each stage must be timed
    /// alone, which cannot overlap). Returns the upload's seconds.
    pub fn submit(&mut self, ctx: &GpuContext) -> Result<f64, GpuError> {
        if !self.timer.uses_timestamps() {
            return Err(GpuError::Input(
                "pipelined frames need timestamp queries, which this adapter lacks".into(),
            ));
        }
        let t0 = Instant::now();
        self.sampler.upload(ctx, &self.bvh, self.tmin)?;
        let upload = t0.elapsed().as_secs_f64();
        let labels = ["bsv sampling", "sh conversion", "shadowing"];
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        for (i, label) in labels.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&self.timer.pass(label, i as u32));
            match i {
                0 => self.sampler.record_cast(&mut pass),
                1 => self.sampler.record_project(&mut pass),
                _ => self.shader.record(&mut pass),
            }
        }
        self.timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        Ok(upload)
    }

    /// Pipelined frames: wait for the submitted frame and read its three device stages
    /// `(sampling, projection, shading)` in seconds.
    pub fn finish(&mut self, ctx: &GpuContext) -> Result<[f64; 3], GpuError> {
        ctx.wait()?;
        let s = self.timer.read(ctx)?.expect("submit requires timestamps");
        Ok([s[0], s[1], s[2]])
    }

    /// This frame's BSV coefficients (`samples × N²`).
    pub fn read_coeffs(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        self.sampler.read_coeffs(ctx)
    }

    /// This frame's per-ray visibilities.
    pub fn read_visibility(&self, ctx: &GpuContext) -> Result<Vec<u32>, GpuError> {
        self.sampler.read_visibility(ctx)
    }

    /// This frame's receiver irradiance (RGB).
    pub fn read_image(&self, ctx: &GpuContext) -> Result<Vec<[f32; 3]>, GpuError> {
        self.shader.read_image(ctx)
    }

    /// The shader (tests).
    pub fn shader(&self) -> &GpuShader {
        &self.shader
    }

    /// The sampler (tests).
    pub fn sampler(&self) -> &GpuSampler {
        &self.sampler
    }

    /// Run only the shading pass on the coefficients now in the sampler's buffer (tests).
    pub fn shade_only(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            self.shader.record(&mut pass);
        }
        ctx.queue.submit([enc.finish()]);
        ctx.wait()
    }
}

/// Median device times `(BSV sampling, SH conversion)` of one mesh sampled on `sampling` along
/// unit `dirs`, over `repeats` frames after one warm-up (wall clock between synchronisations
/// where the adapter has no timestamps).
pub fn time_bsv(
    ctx: &GpuContext,
    mesh: &Mesh,
    order: usize,
    h: usize,
    sampling: Sphere,
    dirs: &[DVec3],
    repeats: usize,
) -> Result<(f64, f64), GpuError> {
    let bvh = FlatBvh::build(mesh, UpdateStrategy::Rebuild)?;
    let mut sampler = GpuSampler::new(
        ctx,
        order,
        h,
        sampling.center,
        sampling.radius,
        dirs,
        (bvh.nodes.len(), bvh.gpu_tris.len()),
    )?;
    sampler.upload(ctx, &bvh, RAY_EPS * mesh.bounding_sphere().radius)?;
    let timer = StageTimer::new(ctx, 2);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for rep in 0..=repeats {
        let mut wall = [0.0; 2];
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        for i in 0..2u32 {
            let t = Instant::now();
            {
                let mut pass = enc.begin_compute_pass(&timer.pass("bsv", i));
                if i == 0 {
                    sampler.record_cast(&mut pass);
                } else {
                    sampler.record_project(&mut pass);
                }
            }
            if !timer.uses_timestamps() {
                let done = std::mem::replace(
                    &mut enc,
                    ctx.device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None }),
                );
                ctx.queue.submit([done.finish()]);
                ctx.wait()?;
                wall[i as usize] = t.elapsed().as_secs_f64();
            }
        }
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        let s = timer.read(ctx)?.map_or(wall, |s| [s[0], s[1]]);
        if rep > 0 {
            a.push(s[0]);
            b.push(s[1]);
        }
    }
    Ok((crate::timing::median(&a), crate::timing::median(&b)))
}
