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

/// One deforming mesh posed and its tree refitted on the device, writing the sampler's node and
/// triangle buffers in place.
pub struct GpuPoser {
    deformer: Option<Deformer>,
    rest: Mesh,
    bvh: FlatBvh,
    /// Whether the tree is ever rebuilt (`Refit`: never, as on the host).
    adaptive: bool,
    pose: GpuPose,
    pose_buf: wgpu::Buffer,
    posed_buf: wgpu::Buffer,
    nodes_buf: wgpu::Buffer,
    tri_verts_buf: wgpu::Buffer,
    leaves_buf: wgpu::Buffer,
    inner_buf: wgpu::Buffer,
    level_buf: wgpu::Buffer,
    area_out_buf: wgpu::Buffer,
    area_staging: wgpu::Buffer,
    /// Bytes between two levels' uniforms (the adapter's uniform offset alignment).
    level_stride: u64,
    /// Each level's inner-node count, deepest first (the schedule last uploaded).
    level_counts: Vec<u32>,
    pipelines: [wgpu::ComputePipeline; 4],
    /// deform, leaves, area sum; then one inner-node bind group per level slot.
    binds: [wgpu::BindGroup; 3],
    level_binds: Vec<wgpu::BindGroup>,
    rebuild_next: bool,
    /// Frames whose tree was built on the host (the first build not counted).
    pub rebuilds: usize,
    /// The relative area the device read last (`NaN` before the first frame or without the rule).
    pub last_area: f64,
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
        if let Some(Deformer::Morph { target }) = deformer {
            if target.positions.len() != rest.positions.len() {
                return Err(GpuError::Input(format!(
                    "the morph's target has {} vertices, the mesh {}",
                    target.positions.len(),
                    rest.positions.len()
                )));
            }
        }
        let bvh = FlatBvh::build(rest, UpdateStrategy::Refit)?;
        let (nv, nt) = (rest.positions.len() as u64, rest.triangles.len() as u64);
        ctx.check_binding("the pose's vertices", 16 * nv)?;
        ctx.check_binding("the pose's triangle indices", 16 * nt)?;
        let (nodes_buf, tris_buf) = (sampler.nodes_buf.clone(), sampler.tris_buf.clone());
        let node_capacity = nodes_buf.size() / 32;
        let rest_buf = ctx.storage_init("pose rest", bytemuck::cast_slice(&v4s(rest)));
        let target = match deformer {
            Some(Deformer::Morph { target }) => v4s(target),
            _ => vec![[0.0; 4]],
        };
        let target_buf = ctx.storage_init("pose target", bytemuck::cast_slice(&target));
        let posed_buf = ctx.storage("posed", 16 * nv);
        let tri_verts_buf = ctx.storage("tri verts", 16 * nt);
        let leaves_buf = ctx.storage("leaves", 4 * nt);
        let inner_buf = ctx.storage("inner nodes", 4 * nt);
        let area_buf = ctx.storage("node areas", 4 * node_capacity);
        let area_out_buf = ctx.storage("relative area", 16);
        let area_staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("relative area readback"),
            size: 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pose = GpuPose {
            kind: kind_code(deformer),
            vertices: nv as u32,
            ..Default::default()
        };
        let pose_buf = ctx.uniform("pose", bytemuck::bytes_of(&pose));
        let level_stride =
            u64::from(ctx.device.limits().min_uniform_buffer_offset_alignment).max(16);
        let level_buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("refit levels"),
            size: level_stride * MAX_GPU_BVH_DEPTH as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let src = pose_source();
        let pipelines = ["deform", "refit_leaves", "refit_inner", "area_sum"]
            .map(|entry| ctx.pipeline(entry, &src, entry));
        fn whole(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
            b.as_entire_binding()
        }
        let binds = [
            ctx.bind_at(
                &pipelines[0],
                &[
                    (0, whole(&pose_buf)),
                    (1, whole(&rest_buf)),
                    (2, whole(&target_buf)),
                    (3, whole(&posed_buf)),
                ],
            ),
            ctx.bind_at(
                &pipelines[1],
                &[
                    (0, whole(&pose_buf)),
                    (3, whole(&posed_buf)),
                    (4, whole(&tri_verts_buf)),
                    (5, whole(&leaves_buf)),
                    (6, whole(&nodes_buf)),
                    (7, whole(&tris_buf)),
                    (8, whole(&area_buf)),
                ],
            ),
            ctx.bind_at(
                &pipelines[3],
                &[
                    (0, whole(&pose_buf)),
                    (8, whole(&area_buf)),
                    (11, whole(&area_out_buf)),
                ],
            ),
        ];
        let level_binds = (0..MAX_GPU_BVH_DEPTH as u64)
            .map(|l| {
                let level = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &level_buf,
                    offset: l * level_stride,
                    size: wgpu::BufferSize::new(16),
                });
                ctx.bind_at(
                    &pipelines[2],
                    &[
                        (6, whole(&nodes_buf)),
                        (8, whole(&area_buf)),
                        (9, level),
                        (10, whole(&inner_buf)),
                    ],
                )
            })
            .collect();
        let mut out = Self {
            deformer: deformer.cloned(),
            rest: rest.clone(),
            bvh,
            adaptive: strategy != UpdateStrategy::Refit,
            pose,
            pose_buf,
            posed_buf,
            nodes_buf,
            tri_verts_buf,
            leaves_buf,
            inner_buf,
            level_buf,
            area_out_buf,
            area_staging,
            level_stride,
            level_counts: Vec::new(),
            pipelines,
            binds,
            level_binds,
            rebuild_next: false,
            rebuilds: 0,
            last_area: f64::NAN,
        };
        out.upload_tree(ctx, rest)?;
        Ok(out)
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
        if 32 * self.bvh.nodes.len() as u64 > self.nodes_buf.size() {
            return Err(GpuError::Input(format!(
                "a tree of {} nodes exceeds the sampler's node buffer",
                self.bvh.nodes.len()
            )));
        }
        let q = &ctx.queue;
        q.write_buffer(&self.nodes_buf, 0, bytemuck::cast_slice(&self.bvh.nodes));
        q.write_buffer(&self.tri_verts_buf, 0, bytemuck::cast_slice(&tri_verts));
        q.write_buffer(&self.leaves_buf, 0, bytemuck::cast_slice(&leaves));
        if !inner.is_empty() {
            q.write_buffer(&self.inner_buf, 0, bytemuck::cast_slice(&inner));
        }
        for (l, &(start, count)) in levels.iter().enumerate() {
            let level = GpuLevel {
                start,
                count,
                ..Default::default()
            };
            q.write_buffer(
                &self.level_buf,
                l as u64 * self.level_stride,
                bytemuck::bytes_of(&level),
            );
        }
        self.level_counts = levels.iter().map(|&(_, c)| c).collect();
        self.pose.leaves = leaves.len() as u32;
        self.pose.nodes = self.bvh.nodes.len() as u32;
        Ok(())
    }

    /// The host's half of frame time `t`: build the tree on the host first when the last frame
    /// found it due (posing this frame on the host for it), then write the frame's pose. Returns
    /// the host seconds of the rebuild (0 without one).
    pub fn prepare(&mut self, ctx: &GpuContext, t: f64) -> Result<f64, GpuError> {
        let mut host = 0.0;
        if self.rebuild_next {
            let t0 = Instant::now();
            let mut posed = self.rest.clone();
            if let Some(d) = &self.deformer {
                d.apply(&self.rest, t, &mut posed);
            }
            self.bvh.rebuild(&posed)?;
            self.upload_tree(ctx, &posed)?;
            self.rebuild_next = false;
            self.rebuilds += 1;
            host = t0.elapsed().as_secs_f64();
        }
        self.pose.scalar = self.deformer.as_ref().map_or(0.0, |d| d.scalar(t)) as f32;
        self.pose.constant = self.deformer.as_ref().map_or(0.0, Deformer::constant) as f32;
        ctx.queue
            .write_buffer(&self.pose_buf, 0, bytemuck::bytes_of(&self.pose));
        Ok(host)
    }

    /// Record the deformation pass.
    pub fn record_deform(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.pose.vertices);
        pass.set_pipeline(&self.pipelines[0]);
        pass.set_bind_group(0, &self.binds[0], &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Record the refit: the leaves, every level of inner nodes deepest first, and (when the
    /// tree may be rebuilt) the relative area's sum.
    pub fn record_refit(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.pose.leaves);
        pass.set_pipeline(&self.pipelines[1]);
        pass.set_bind_group(0, &self.binds[1], &[]);
        pass.dispatch_workgroups(x, y, 1);
        pass.set_pipeline(&self.pipelines[2]);
        for (l, &count) in self.level_counts.iter().enumerate() {
            let (x, y) = grid_64(count);
            pass.set_bind_group(0, &self.level_binds[l], &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        if self.adaptive {
            pass.set_pipeline(&self.pipelines[3]);
            pass.set_bind_group(0, &self.binds[2], &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
    }

    /// After the frame has completed: read its relative area and decide whether the next frame
    /// builds the tree on the host.
    pub fn after_frame(&mut self, ctx: &GpuContext) -> Result<(), GpuError> {
        if !self.adaptive {
            return Ok(());
        }
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.copy_buffer_to_buffer(&self.area_out_buf, 0, &self.area_staging, 0, 16);
        ctx.queue.submit([enc.finish()]);
        let slice = self.area_staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        ctx.wait()?;
        rx.recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let area = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            bytemuck::cast_slice::<u8, f32>(&view)[0]
        };
        self.area_staging.unmap();
        self.last_area = f64::from(area);
        self.rebuild_next = rebuild_due(self.last_area, self.bvh.built_area());
        Ok(())
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
        let raw = ctx.read_buffer(&self.posed_buf)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 4]>(&raw)[..self.pose.vertices as usize].to_vec())
    }

    /// The host tree (tests: its topology is the device's).
    pub fn host_tree(&self) -> &FlatBvh {
        &self.bvh
    }
}
