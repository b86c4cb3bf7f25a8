//! The frame's pose and BVH refit on the device (`pose.wgsl`), so that a frame of the papers'
//! sequence uploads one 32-byte uniform instead of its tree and triangles:
//!
//! 1. **deform**: every rest vertex mapped by the frame's deformer (`shscale_geometry::deform`'s
//!    maps in f32; the bend in a form without the host's cancellation as κ → 0, see the shader);
//! 2. **refit**: the leaves gather their triangles from the posed vertices into the traversal's
//!    triangle buffer (the tree's order) and take their boxes; the inner nodes take the union of
//!    their children's, one level per dispatch, deepest first (WebGPU orders the dispatches of a
//!    pass, so a level reads the boxes the one before wrote); the topology is the host's tree;
//! 3. **rebuild rule** (`UpdateStrategy::Adaptive`, and `Rebuild` here, which a device refit
//!    cannot honour every frame): one workgroup sums every node's half area over the root's
//!    (f32), copied back after the frame (16 bytes); when the tree has grown past
//!    `shscale_geometry::ray::rebuild_due`'s rule the **next** frame is posed on the host (all
//!    cores), its tree built there and uploaded with its refit schedule — one frame later than
//!    the host path decides, which changes the tree's shape, never the rays' answers.
//!
//! Valid domain: the deformers' (any `t`; the bend for any κ, `|κ| < 1e-12` being the identity as
//! on the host), trees at most [`crate::bvh::MAX_GPU_BVH_DEPTH`] deep (so at most 63 levels of
//! inner nodes), meshes whose buffers fit the adapter's storage binding (checked by name). The
//! f32 pose differs from the host's f64 pose by rounding (the parity test states the tolerance).

use crate::bvh::{FlatBvh, RefitSchedule, MAX_GPU_BVH_DEPTH};
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuLevel, GpuPose};
use crate::sampling::GpuSampler;
use crate::timing::grid_64;
use shscale_geometry::deform::Deformer;
use shscale_geometry::ray::{rebuild_due, UpdateStrategy};
use shscale_geometry::Mesh;
use std::time::Instant;

const POSE_WGSL: &str = include_str!("pose.wgsl");

/// The pose kernels' source.
pub fn pose_source() -> String {
    shader(&[POSE_WGSL])
}

/// The kind's number in `GpuPose::kind`.
fn kind_code(d: Option<&Deformer>) -> u32 {
    match d {
        None => 0,
        Some(Deformer::Bend { .. }) => 1,
        Some(Deformer::Twist { .. }) => 2,
        Some(Deformer::Morph { .. }) => 3,
        Some(Deformer::Flap { .. }) => 4,
    }
}

fn v4s(m: &Mesh) -> Vec<[f32; 4]> {
    (m.positions.iter())
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0])
        .collect()
}

/// `rest` posed at time `t` by `deformer` on the host (f64; the rest pose without one).
fn host_pose(rest: &Mesh, deformer: Option<&Deformer>, t: f64) -> Mesh {
    let mut posed = rest.clone();
    if let Some(d) = deformer {
        d.apply(rest, t, &mut posed);
    }
    posed
}

/// A mesh's rest pose on the device and its frame's pose: what `pose.wgsl`'s `deform` kernel
/// reads (bindings 0–2: the pose uniform, the rest vertices, a morph's target) and writes (3:
/// the posed vertices). The tree's pose ([`GpuPoser`]) and the sphere fit's
/// (`crate::fit::GpuSphereFit`) are each one of these.
pub(crate) struct DeviceDeform {
    deformer: Option<Deformer>,
    /// The uniform's value: kind, vertex count, the frame's scalar and constant (and, for the
    /// tree's pose, its leaf and node counts).
    pub(crate) pose: GpuPose,
    pub(crate) pose_buf: wgpu::Buffer,
    pub(crate) posed: wgpu::Buffer,
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
}

impl DeviceDeform {
    /// `rest` (placed) and `deformer` on the device; a morph target of another vertex count and
    /// vertices beyond the adapter's storage binding are refused by name.
    pub(crate) fn new(
        ctx: &GpuContext,
        rest: &Mesh,
        deformer: Option<&Deformer>,
    ) -> Result<Self, GpuError> {
        let nv = rest.positions.len();
        let target = match deformer {
            Some(Deformer::Morph { target }) if target.positions.len() != nv => {
                return Err(GpuError::Input(format!(
                    "the morph's target has {} vertices, the mesh {nv}",
                    target.positions.len()
                )))
            }
            Some(Deformer::Morph { target }) => v4s(target),
            _ => vec![[0.0; 4]],
        };
        ctx.check_binding("the pose's vertices", 16 * nv as u64)?;
        let pose = GpuPose {
            kind: kind_code(deformer),
            vertices: nv as u32,
            ..Default::default()
        };
        let pose_buf = ctx.uniform("pose", bytemuck::bytes_of(&pose));
        let rest_buf = ctx.storage_init("pose rest", bytemuck::cast_slice(&v4s(rest)));
        let target_buf = ctx.storage_init("pose target", bytemuck::cast_slice(&target));
        let posed = ctx.storage("posed", 16 * nv as u64);
        let pipe = ctx.pipeline("deform", &pose_source(), "deform");
        let bind = ctx.bind_at(
            &pipe,
            &[
                (0, pose_buf.as_entire_binding()),
                (1, rest_buf.as_entire_binding()),
                (2, target_buf.as_entire_binding()),
                (3, posed.as_entire_binding()),
            ],
        );
        Ok(Self {
            deformer: deformer.cloned(),
            pose,
            pose_buf,
            posed,
            pipe,
            bind,
        })
    }

    /// The deformer (none: every frame is the rest pose).
    pub(crate) fn deformer(&self) -> Option<&Deformer> {
        self.deformer.as_ref()
    }

    /// Write frame time `t`'s pose (the whole 32-byte uniform).
    pub(crate) fn write(&mut self, ctx: &GpuContext, t: f64) {
        self.pose.scalar = self.deformer.as_ref().map_or(0.0, |d| d.scalar(t)) as f32;
        self.pose.constant = self.deformer.as_ref().map_or(0.0, Deformer::constant) as f32;
        ctx.queue
            .write_buffer(&self.pose_buf, 0, bytemuck::bytes_of(&self.pose));
    }

    /// Record the deformation pass.
    pub(crate) fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.pose.vertices);
        pass.set_pipeline(&self.pipe);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// The posed vertices of the last frame (tests).
    pub(crate) fn read_posed(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        let raw = ctx.read_buffer(&self.posed)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 4]>(&raw)[..self.pose.vertices as usize].to_vec())
    }
}

/// The device buffers of a [`GpuPoser`] besides its [`DeviceDeform`]'s (the node and triangle
/// buffers are the sampler's).
struct PoseBuffers {
    nodes: wgpu::Buffer,
    tris: wgpu::Buffer,
    tri_verts: wgpu::Buffer,
    leaves: wgpu::Buffer,
    inner: wgpu::Buffer,
    area: wgpu::Buffer,
    area_out: wgpu::Buffer,
    area_staging: wgpu::Buffer,
    /// One uniform slot per tree level, `stride` bytes apart (the adapter's uniform offset
    /// alignment).
    levels: wgpu::Buffer,
    stride: u64,
}

impl PoseBuffers {
    fn new(ctx: &GpuContext, rest: &Mesh, sampler: &GpuSampler) -> Result<Self, GpuError> {
        let nt = rest.triangles.len() as u64;
        ctx.check_binding("the pose's triangle indices", 16 * nt)?;
        let nodes = sampler.nodes_buf.clone();
        let stride = u64::from(ctx.device.limits().min_uniform_buffer_offset_alignment).max(16);
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        Ok(Self {
            tris: sampler.tris_buf.clone(),
            tri_verts: ctx.storage("tri verts", 16 * nt),
            leaves: ctx.storage("leaves", 4 * nt),
            inner: ctx.storage("inner nodes", 4 * nt),
            area: ctx.storage("node areas", 4 * (nodes.size() / 32)),
            nodes,
            area_out: ctx.storage("relative area", 16),
            area_staging: buffer("relative area readback", 16, U::MAP_READ | U::COPY_DST),
            levels: buffer(
                "refit levels",
                stride * MAX_GPU_BVH_DEPTH as u64,
                U::UNIFORM | U::COPY_DST,
            ),
            stride,
        })
    }

    /// The bind groups of the refit's three kernels (`pose.wgsl`'s binding numbers, the pose
    /// uniform and posed vertices `deform`'s): leaves and the area sum; then the inner nodes',
    /// one per level slot.
    fn bind_groups(
        &self,
        ctx: &GpuContext,
        deform: &DeviceDeform,
        pipelines: &[wgpu::ComputePipeline; 3],
    ) -> ([wgpu::BindGroup; 2], Vec<wgpu::BindGroup>) {
        fn whole(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
            b.as_entire_binding()
        }
        let b = self;
        let pose = &deform.pose_buf;
        let binds = [
            (
                0,
                vec![
                    (0, pose),
                    (3, &deform.posed),
                    (4, &b.tri_verts),
                    (5, &b.leaves),
                    (6, &b.nodes),
                    (7, &b.tris),
                    (8, &b.area),
                ],
            ),
            (2, vec![(0, pose), (8, &b.area), (11, &b.area_out)]),
        ]
        .map(|(p, list)| {
            let res: Vec<_> = list.into_iter().map(|(i, buf)| (i, whole(buf))).collect();
            ctx.bind_at(&pipelines[p], &res)
        });
        let levels = (0..MAX_GPU_BVH_DEPTH as u64)
            .map(|l| {
                let level = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &b.levels,
                    offset: l * b.stride,
                    size: wgpu::BufferSize::new(16),
                });
                let res = [
                    (6, whole(&b.nodes)),
                    (8, whole(&b.area)),
                    (9, level),
                    (10, whole(&b.inner)),
                ];
                ctx.bind_at(&pipelines[1], &res)
            })
            .collect();
        (binds, levels)
    }
}

/// A tree built in the background: the tree, the pose it was built for, the build's seconds.
type Built = (FlatBvh, Mesh, f64);

/// One deforming mesh posed and its tree refitted on the device, writing the sampler's node and
/// triangle buffers in place.
pub struct GpuPoser {
    rest: Mesh,
    bvh: FlatBvh,
    /// Whether the tree is ever rebuilt (`Refit`: never, as on the host).
    adaptive: bool,
    deform: DeviceDeform,
    bufs: PoseBuffers,
    /// Each level's inner-node count, deepest first (the schedule last uploaded).
    level_counts: Vec<u32>,
    /// leaves, inner nodes, area sum.
    pipelines: [wgpu::ComputePipeline; 3],
    /// leaves, area sum; then one inner-node bind group per level slot.
    binds: [wgpu::BindGroup; 2],
    level_binds: Vec<wgpu::BindGroup>,
    rebuild_next: bool,
    /// Frames whose tree was built on the host (the first build not counted).
    pub rebuilds: usize,
    /// The relative area the device read last (`NaN` before the first frame or without the rule).
    pub last_area: f64,
    /// Build due trees on a host thread while frames go on with the old one
    /// ([`Self::rebuild_in_background`]).
    background: bool,
    /// The tree being built in the background: the build and the pose it was built for.
    pending: Option<std::thread::JoinHandle<Result<Built, GpuError>>>,
    /// Host seconds of the trees built in the background (off every frame's path).
    pub background_seconds: f64,
}

impl GpuPoser {
    /// Set up for `rest` (the mesh's rest pose, placed) deformed by `deformer` (none: every frame
    /// is the rest pose), writing `sampler`'s tree buffers; `strategy` `Refit` never rebuilds,
    /// the others rebuild by the host's rule (module docs).
    pub fn new(
        ctx: &GpuContext,
        rest: &Mesh,
        deformer: Option<&Deformer>,
        strategy: UpdateStrategy,
        sampler: &GpuSampler,
    ) -> Result<Self, GpuError> {
        let deform = DeviceDeform::new(ctx, rest, deformer)?;
        let bvh = FlatBvh::build(rest, UpdateStrategy::Refit)?;
        let bufs = PoseBuffers::new(ctx, rest, sampler)?;
        let src = pose_source();
        let pipelines = ["refit_leaves", "refit_inner", "area_sum"]
            .map(|entry| ctx.pipeline(entry, &src, entry));
        let (binds, level_binds) = bufs.bind_groups(ctx, &deform, &pipelines);
        let mut out = Self {
            rest: rest.clone(),
            bvh,
            adaptive: strategy != UpdateStrategy::Refit,
            deform,
            bufs,
            level_counts: Vec::new(),
            pipelines,
            binds,
            level_binds,
            rebuild_next: false,
            rebuilds: 0,
            last_area: f64::NAN,
            background: false,
            pending: None,
            background_seconds: 0.0,
        };
        out.upload_tree(ctx, rest)?;
        Ok(out)
    }

    /// From now on, build a due tree on a host thread (posed at the frame it was found due for)
    /// while frames go on refitting the old one, and swap it in at the first frame after it is
    /// done: the frame pays the tree's upload, not its build. The tree's shape changes frames
    /// later than built in place; a ray's answer never does.
    pub fn rebuild_in_background(&mut self) {
        self.background = true;
    }

    /// Write the host tree's topology (its nodes; the device refits their boxes), its refit
    /// schedule and the tree's sizes.
    fn upload_tree(&mut self, ctx: &GpuContext, mesh: &Mesh) -> Result<(), GpuError> {
        let RefitSchedule {
            tri_verts,
            leaves,
            inner,
            levels,
        } = self.bvh.schedule(mesh)?;
        if 32 * self.bvh.nodes.len() as u64 > self.bufs.nodes.size() {
            return Err(GpuError::Input(format!(
                "a tree of {} nodes exceeds the sampler's node buffer",
                self.bvh.nodes.len()
            )));
        }
        let q = &ctx.queue;
        q.write_buffer(&self.bufs.nodes, 0, bytemuck::cast_slice(&self.bvh.nodes));
        q.write_buffer(&self.bufs.tri_verts, 0, bytemuck::cast_slice(&tri_verts));
        q.write_buffer(&self.bufs.leaves, 0, bytemuck::cast_slice(&leaves));
        if !inner.is_empty() {
            q.write_buffer(&self.bufs.inner, 0, bytemuck::cast_slice(&inner));
        }
        for (l, &(start, count)) in levels.iter().enumerate() {
            let level = GpuLevel {
                start,
                count,
                ..Default::default()
            };
            q.write_buffer(
                &self.bufs.levels,
                l as u64 * self.bufs.stride,
                bytemuck::bytes_of(&level),
            );
        }
        self.level_counts = levels.iter().map(|&(_, c)| c).collect();
        self.deform.pose.leaves = leaves.len() as u32;
        self.deform.pose.nodes = self.bvh.nodes.len() as u32;
        Ok(())
    }

    /// The host's half of frame time `t`: build the tree on the host first when the last frame
    /// found it due (posing this frame on the host for it), then write the frame's pose. Returns
    /// the host seconds of the rebuild (0 without one).
    pub fn prepare(&mut self, ctx: &GpuContext, t: f64) -> Result<f64, GpuError> {
        let mut host = 0.0;
        if self.background {
            host = self.background_step(ctx, t)?;
        } else if self.rebuild_next {
            let t0 = Instant::now();
            let posed = host_pose(&self.rest, self.deform.deformer(), t);
            self.bvh.rebuild(&posed)?;
            self.upload_tree(ctx, &posed)?;
            self.rebuild_next = false;
            self.rebuilds += 1;
            host = t0.elapsed().as_secs_f64();
        }
        self.deform.write(ctx, t);
        Ok(host)
    }

    /// [`Self::prepare`]'s rebuild in the background: swap in a finished tree (its upload is
    /// the frame's host seconds, returned), or start building one when due and none is under
    /// way.
    fn background_step(&mut self, ctx: &GpuContext, t: f64) -> Result<f64, GpuError> {
        let t0 = Instant::now();
        if self.pending.as_ref().is_some_and(|h| h.is_finished()) {
            let done = self.pending.take().expect("checked above");
            let (bvh, posed, seconds) = done
                .join()
                .map_err(|_| GpuError::Input("the background tree build panicked".into()))??;
            self.bvh = bvh;
            self.background_seconds += seconds;
            self.upload_tree(ctx, &posed)?;
            self.rebuilds += 1;
            self.rebuild_next = false;
            return Ok(t0.elapsed().as_secs_f64());
        }
        if self.rebuild_next && self.pending.is_none() {
            self.rebuild_next = false;
            let (rest, deformer) = (self.rest.clone(), self.deform.deformer().cloned());
            self.pending = Some(std::thread::spawn(move || {
                let t0 = Instant::now();
                let posed = host_pose(&rest, deformer.as_ref(), t);
                let bvh = FlatBvh::build(&posed, UpdateStrategy::Refit)?;
                Ok((bvh, posed, t0.elapsed().as_secs_f64()))
            }));
        }
        Ok(0.0)
    }

    /// Record the deformation pass.
    pub(crate) fn record_deform(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.deform.record(pass);
    }

    /// Record the refit: the leaves, every level of inner nodes deepest first, and (when the
    /// tree may be rebuilt) the relative area's sum.
    pub(crate) fn record_refit(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.deform.pose.leaves);
        pass.set_pipeline(&self.pipelines[0]);
        pass.set_bind_group(0, &self.binds[0], &[]);
        pass.dispatch_workgroups(x, y, 1);
        pass.set_pipeline(&self.pipelines[1]);
        for (l, &count) in self.level_counts.iter().enumerate() {
            let (x, y) = grid_64(count);
            pass.set_bind_group(0, &self.level_binds[l], &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        if self.adaptive {
            pass.set_pipeline(&self.pipelines[2]);
            pass.set_bind_group(0, &self.binds[1], &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
    }

    /// After the frame has completed: read its relative area and decide whether the next frame
    /// builds the tree on the host.
    pub(crate) fn after_frame(&mut self, ctx: &GpuContext) -> Result<(), GpuError> {
        if !self.adaptive {
            return Ok(());
        }
        let raw = ctx.copy_and_map(&self.bufs.area_out, &self.bufs.area_staging, 16)?;
        self.decide(&raw);
        Ok(())
    }

    /// Whether the tree may be rebuilt (its relative area is then summed every frame).
    pub fn adaptive(&self) -> bool {
        self.adaptive
    }

    /// Frames in flight: record the copy of this frame's relative area into `staging` (16
    /// bytes, `MAP_READ | COPY_DST`), read after the frame by [`Self::after_frame_read`].
    pub(crate) fn record_area_copy(&self, enc: &mut wgpu::CommandEncoder, staging: &wgpu::Buffer) {
        enc.copy_buffer_to_buffer(&self.bufs.area_out, 0, staging, 0, 16);
    }

    /// Frames in flight: the relative area a frame copied (its 16 bytes), and whether the next
    /// frame to be posed builds the tree on the host.
    pub fn after_frame_read(&mut self, raw: &[u8]) {
        self.decide(raw);
    }

    /// The rebuild rule on a frame's relative area (its 16 bytes as read back).
    fn decide(&mut self, raw: &[u8]) {
        let area = bytemuck::cast_slice::<u8, f32>(&raw[..4])[0];
        self.last_area = f64::from(area);
        self.rebuild_next = rebuild_due(self.last_area, self.bvh.built_area());
    }

    /// Pose at `t`, refit and wait, then read the relative area (tests and one-off use; a
    /// frame of the sequence is [`crate::GpuSequence::frame_at`]). Returns the host's rebuild
    /// seconds.
    pub fn run(&mut self, ctx: &GpuContext, t: f64) -> Result<f64, GpuError> {
        let host = self.prepare(ctx, t)?;
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            self.record_deform(&mut pass);
            self.record_refit(&mut pass);
        }
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        self.after_frame(ctx)?;
        Ok(host)
    }

    /// The posed vertices of the last frame (tests).
    pub fn read_posed(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        self.deform.read_posed(ctx)
    }

    /// The host tree (tests: its topology is the device's).
    pub fn host_tree(&self) -> &FlatBvh {
        &self.bvh
    }
}
