//! GPU BSV sampling and SH projection of one entity on a fixed sampling sphere (the two first
//! stages of Table 1), twins of `Bsv::sample_on` with `VisibilitySampler::facing_hemisphere`.
//!
//! Static per sequence (uploaded once): sample positions `c + s·dir` and local frames
//! (`LocalFrame::toward(pos, c)`, computed on the host in f64 exactly as the CPU does), the
//! `H × H` Gauss hemisphere directions and weights, the SH normalisation table and each sample's
//! closed-form back-hemisphere coefficients. Per frame: the flattened BVH (nodes and triangles)
//! and the ray offset `tmin = RAY_EPS · r`.

use crate::bvh::FlatBvh;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuNode, GpuParams, GpuSample, GpuTri, SH_WGSL};
use crate::timing::grid_64;
use glam::DVec3;
use shscale_field::LocalFrame;
use shscale_geometry::{Mesh, RAY_EPS};
use shscale_sh::{cap_zonal, rotate_zonal, DirectionSet, ShBasis};

/// Highest SH order the GPU kernels support (`N² ≤ 64` accumulators).
pub const MAX_GPU_ORDER: usize = 8;

const CAST_WGSL: &str = include_str!("sampling.wgsl");
const PROJECT_WGSL: &str = include_str!("projection.wgsl");
const SH_TEST: &str = include_str!("sh_test.wgsl");

/// The ray-casting shader.
pub fn cast_source() -> String {
    shader(&[CAST_WGSL])
}
/// The projection shader.
pub fn project_source() -> String {
    shader(&[SH_WGSL, PROJECT_WGSL])
}
/// The SH test shader.
pub fn sh_test_source() -> String {
    shader(&[SH_WGSL, SH_TEST])
}

/// `K_l^m` (times √2 for m > 0) at `l·l + l + m`, m ≥ 0, from the factorial formula
/// `K_l^m = √((2l+1)/(4π) · (l−m)!/(l+m)!)` in f64 (independent of the CPU recurrence tables).
pub(crate) fn knorm_table(order: usize) -> Vec<f32> {
    let mut k = vec![0f32; order * order];
    for l in 0..order {
        for m in 0..=l {
            let mut ratio = 1.0f64; // (l−m)!/(l+m)!
            for f in (l - m + 1)..=(l + m) {
                ratio /= f as f64;
            }
            let v = ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * ratio).sqrt();
            k[l * l + l + m] = if m == 0 {
                v as f32
            } else {
                (v * std::f64::consts::SQRT_2) as f32
            };
        }
    }
    k
}

/// Check an order for the GPU kernels.
pub fn check_gpu_order(order: usize) -> Result<(), GpuError> {
    if (1..=MAX_GPU_ORDER).contains(&order) {
        Ok(())
    } else {
        Err(GpuError::Input(format!(
            "SH order {order} is outside the GPU path's 1..={MAX_GPU_ORDER}"
        )))
    }
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// GPU sampler of one entity's BSV on a fixed sphere.
pub struct GpuSampler {
    pub order: usize,
    pub samples: usize,
    pub rays: usize,
    pub(crate) params: GpuParams,
    pub(crate) params_buf: wgpu::Buffer,
    pub(crate) nodes_buf: wgpu::Buffer,
    pub(crate) tris_buf: wgpu::Buffer,
    pub(crate) vis_buf: wgpu::Buffer,
    pub(crate) coeffs_buf: wgpu::Buffer,
    samples_buf: wgpu::Buffer,
    back_buf: wgpu::Buffer,
    cast: wgpu::ComputePipeline,
    project: wgpu::ComputePipeline,
    cast_bind: wgpu::BindGroup,
    project_bind: wgpu::BindGroup,
}

/// The `H × H` Gauss hemisphere as `[x, y, z, weight]` rays, after checking the order, the
/// sample count and that a frame's visibility fits the adapter's storage binding.
fn hemisphere_rays(
    ctx: &GpuContext,
    order: usize,
    h: usize,
    samples: usize,
) -> Result<Vec<[f32; 4]>, GpuError> {
    check_gpu_order(order)?;
    if h == 0 || samples == 0 || samples > 65_535 {
        return Err(GpuError::Input(format!(
            "need H ≥ 1 and 1..=65535 samples, got H = {h}, {samples} samples"
        )));
    }
    let hemi = DirectionSet::gauss_hemisphere(h);
    let total = samples as u64 * hemi.dirs.len() as u64;
    let max_binding = ctx.device.limits().max_storage_buffer_binding_size;
    if 4 * total > max_binding {
        return Err(GpuError::Input(format!(
            "{total} rays per frame need {} bytes of visibility, above the adapter's {max_binding}",
            4 * total
        )));
    }
    Ok((hemi.dirs.iter().zip(&hemi.weights))
        .map(|(d, &w)| [d[0] as f32, d[1] as f32, d[2] as f32, w as f32])
        .collect())
}

/// Per sample at `points[i]`: its position and local frame (z toward `target(i)`), and the back
/// hemisphere's closed-form visibility (the zonal half-sphere cap rotated to −z of the frame) in
/// f32.
fn sample_frames(
    order: usize,
    target: impl Fn(usize) -> DVec3,
    points: &[DVec3],
) -> Result<(Vec<GpuSample>, Vec<f32>), GpuError> {
    let nn = order * order;
    let basis = ShBasis::<f64>::new(order).map_err(|e| GpuError::Input(e.to_string()))?;
    let cap = cap_zonal(order, std::f64::consts::FRAC_PI_2)
        .map_err(|e| GpuError::Input(e.to_string()))?;
    let mut samples = Vec::with_capacity(points.len());
    let mut back = Vec::with_capacity(points.len() * nn);
    let mut b = vec![0.0; nn];
    for (i, &pos) in points.iter().enumerate() {
        let f = LocalFrame::toward(pos, target(i));
        samples.push(GpuSample {
            pos: v4(pos, 1.0),
            fx: v4(f.x, 0.0),
            fy: v4(f.y, 0.0),
            fz: v4(f.z, 0.0),
        });
        rotate_zonal(&basis, &cap, (-f.z).to_array(), &mut b)
            .map_err(|e| GpuError::Input(e.to_string()))?;
        back.extend(b.iter().map(|&x| x as f32));
    }
    Ok((samples, back))
}

impl GpuSampler {
    /// Set up for samples at `center + radius · dir` (unit `dirs`), order `N ≤ 8`, `H × H` rays
    /// per sample; `capacity` is the largest BVH (nodes, triangles) the sequence will upload.
    pub fn new(
        ctx: &GpuContext,
        order: usize,
        h: usize,
        center: DVec3,
        radius: f64,
        dirs: &[DVec3],
        capacity: (usize, usize),
    ) -> Result<Self, GpuError> {
        let points: Vec<DVec3> = dirs.iter().map(|d| center + radius * *d).collect();
        Self::at_points(ctx, order, h, center, &points, capacity)
    }

    /// Set up for samples at any `points` (none at `center`), each casting its hemisphere toward
    /// `center` (the fully sampled field's shells: [`Self::move_samples`] moves them per frame);
    /// the rest as [`Self::new`].
    pub(crate) fn at_points(
        ctx: &GpuContext,
        order: usize,
        h: usize,
        center: DVec3,
        points: &[DVec3],
        capacity: (usize, usize),
    ) -> Result<Self, GpuError> {
        let nn = order * order;
        let hemi4 = hemisphere_rays(ctx, order, h, points.len())?;
        let (samples, back) = sample_frames(order, |_| center, points)?;
        let rays = hemi4.len();
        let total = points.len() as u64 * rays as u64;
        let params = GpuParams {
            order: order as u32,
            nn: nn as u32,
            samples: points.len() as u32,
            rays: rays as u32,
            ..Default::default()
        };
        let params_buf = ctx.uniform("params", bytemuck::bytes_of(&params));
        let samples_buf = ctx.storage_init("samples", bytemuck::cast_slice(&samples));
        let hemi_buf = ctx.storage_init("hemisphere", bytemuck::cast_slice(&hemi4));
        let knorm_buf = ctx.storage_init("knorm", bytemuck::cast_slice(&knorm_table(order)));
        let back_buf = ctx.storage_init("back", bytemuck::cast_slice(&back));
        let nodes_buf = ctx.storage("nodes", 32 * capacity.0 as u64);
        let tris_buf = ctx.storage("tris", 48 * capacity.1 as u64);
        let vis_buf = ctx.storage("vis", 4 * total);
        let coeffs_buf = ctx.storage("coeffs", 4 * (points.len() * nn) as u64);
        let cast = ctx.pipeline("cast", &cast_source(), "cast_rays");
        let project = ctx.pipeline("project", &project_source(), "project");
        let (cast_bind, project_bind) = (
            ctx.bind(
                &cast,
                &[
                    &params_buf,
                    &samples_buf,
                    &hemi_buf,
                    &nodes_buf,
                    &tris_buf,
                    &vis_buf,
                ],
            ),
            ctx.bind(
                &project,
                &[
                    &params_buf,
                    &samples_buf,
                    &hemi_buf,
                    &vis_buf,
                    &knorm_buf,
                    &back_buf,
                    &coeffs_buf,
                ],
            ),
        );
        Ok(Self {
            order,
            samples: points.len(),
            rays,
            params,
            params_buf,
            nodes_buf,
            tris_buf,
            vis_buf,
            coeffs_buf,
            samples_buf,
            back_buf,
            cast,
            project,
            cast_bind,
            project_bind,
        })
    }

    /// Move the samples to `points` (as many as set up), casting toward `center`: their
    /// positions, frames and back hemispheres rewritten (the caller submits afterwards).
    pub fn move_samples(
        &self,
        ctx: &GpuContext,
        center: DVec3,
        points: &[DVec3],
    ) -> Result<(), GpuError> {
        self.move_samples_toward(ctx, |_| center, points)
    }

    /// [`Self::move_samples`] with each sample `i` casting its facing hemisphere toward
    /// `target(i)` (the other hemisphere taken as unoccluded, in closed form).
    pub(crate) fn move_samples_toward(
        &self,
        ctx: &GpuContext,
        target: impl Fn(usize) -> DVec3,
        points: &[DVec3],
    ) -> Result<(), GpuError> {
        if points.len() != self.samples {
            return Err(GpuError::Input(format!(
                "{} sample points for a sampler of {}",
                points.len(),
                self.samples
            )));
        }
        let (samples, back) = sample_frames(self.order, target, points)?;
        ctx.queue
            .write_buffer(&self.samples_buf, 0, bytemuck::cast_slice(&samples));
        ctx.queue
            .write_buffer(&self.back_buf, 0, bytemuck::cast_slice(&back));
        Ok(())
    }

    /// The coefficients' buffer (`samples × N²` f32, entity frame), for kernels that read the
    /// samples where they lie.
    pub(crate) fn coeffs_buffer(&self) -> &wgpu::Buffer {
        &self.coeffs_buf
    }

    /// A posed mesh's frame, host half: `bvh` follows `mesh` (its rebuild or refit), is uploaded
    /// with the CPU's ray offset rule — `RAY_EPS` times the frame's bounding radius — and the
    /// samples move to `points` casting toward `center` when given. Returns the BVH update's
    /// seconds and when the uploads began (the caller adds its own and submits afterwards).
    pub fn follow(
        &mut self,
        ctx: &GpuContext,
        bvh: &mut FlatBvh,
        mesh: &Mesh,
        samples: Option<(DVec3, &[DVec3])>,
    ) -> Result<(f64, std::time::Instant), GpuError> {
        let t0 = std::time::Instant::now();
        bvh.update(mesh)?;
        let bvh_seconds = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        self.upload(ctx, bvh, RAY_EPS * mesh.bounding_sphere().radius)?;
        if let Some((center, points)) = samples {
            self.move_samples(ctx, center, points)?;
        }
        Ok((bvh_seconds, t1))
    }

    /// Upload this frame's BVH and ray offset (the caller submits afterwards).
    pub fn upload(&mut self, ctx: &GpuContext, bvh: &FlatBvh, tmin: f64) -> Result<(), GpuError> {
        let (nb, tb) = (32 * bvh.nodes.len() as u64, 48 * bvh.gpu_tris.len() as u64);
        if nb > self.nodes_buf.size() || tb > self.tris_buf.size() {
            return Err(GpuError::Input(format!(
                "BVH of {} nodes / {} triangles exceeds the capacity set up ({} / {})",
                bvh.nodes.len(),
                bvh.gpu_tris.len(),
                self.nodes_buf.size() / 32,
                self.tris_buf.size() / 48
            )));
        }
        ctx.queue
            .write_buffer(&self.nodes_buf, 0, bytemuck::cast_slice(&bvh.nodes));
        ctx.queue
            .write_buffer(&self.tris_buf, 0, bytemuck::cast_slice(&bvh.gpu_tris));
        self.params.tmin = tmin as f32;
        ctx.queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        Ok(())
    }

    /// Set the ray offset alone (the tree written on the device, `crate::pose`).
    pub(crate) fn set_tmin(&mut self, ctx: &GpuContext, tmin: f64) {
        self.params.tmin = tmin as f32;
        ctx.queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
    }

    /// Record the ray-casting pass.
    pub(crate) fn record_cast(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.params.samples * self.params.rays);
        pass.set_pipeline(&self.cast);
        pass.set_bind_group(0, &self.cast_bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Record the projection pass.
    pub(crate) fn record_project(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.project);
        pass.set_bind_group(0, &self.project_bind, &[]);
        pass.dispatch_workgroups(self.params.samples, 1, 1);
    }

    /// Overwrite the visibility buffer (tests: project given visibilities).
    pub fn write_visibility(&self, ctx: &GpuContext, vis: &[u32]) -> Result<(), GpuError> {
        if vis.len() != self.samples * self.rays {
            return Err(GpuError::Input(format!(
                "{} visibilities for {} rays",
                vis.len(),
                self.samples * self.rays
            )));
        }
        ctx.queue
            .write_buffer(&self.vis_buf, 0, bytemuck::cast_slice(vis));
        Ok(())
    }

    /// Overwrite the BSV coefficients (tests: shade given coefficients).
    pub fn write_coeffs(&self, ctx: &GpuContext, coeffs: &[f32]) -> Result<(), GpuError> {
        if coeffs.len() != self.samples * self.order * self.order {
            return Err(GpuError::Input(format!(
                "{} coefficients for {} samples of order {}",
                coeffs.len(),
                self.samples,
                self.order
            )));
        }
        ctx.queue
            .write_buffer(&self.coeffs_buf, 0, bytemuck::cast_slice(coeffs));
        Ok(())
    }

    /// The per-ray visibilities of the last frame (`samples × H²`, 1 = escapes).
    pub fn read_visibility(&self, ctx: &GpuContext) -> Result<Vec<u32>, GpuError> {
        Ok(bytemuck::cast_slice(&ctx.read_buffer(&self.vis_buf)?).to_vec())
    }

    /// The BSV coefficients of the last frame (`samples × N²`, entity frame).
    pub fn read_coeffs(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        let all: Vec<f32> = bytemuck::cast_slice(&ctx.read_buffer(&self.coeffs_buf)?).to_vec();
        Ok(all[..self.samples * self.order * self.order].to_vec())
    }

    /// The first `nodes` nodes and `tris` triangles of the tree buffers (tests: a tree written on
    /// the device, `crate::pose`).
    pub fn read_tree(
        &self,
        ctx: &GpuContext,
        nodes: usize,
        tris: usize,
    ) -> Result<(Vec<GpuNode>, Vec<GpuTri>), GpuError> {
        let n = ctx.read_buffer(&self.nodes_buf)?;
        let t = ctx.read_buffer(&self.tris_buf)?;
        Ok((
            bytemuck::cast_slice::<u8, GpuNode>(&n)[..nodes].to_vec(),
            bytemuck::cast_slice::<u8, GpuTri>(&t)[..tris].to_vec(),
        ))
    }

    /// Run cast (unless `skip_cast`) and projection now and wait (tests and one-off use).
    pub fn run(&self, ctx: &GpuContext, skip_cast: bool) -> Result<(), GpuError> {
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            if !skip_cast {
                self.record_cast(&mut pass);
            }
            self.record_project(&mut pass);
        }
        ctx.queue.submit([enc.finish()]);
        ctx.wait()
    }
}

/// Evaluate the real SH basis of order `N ≤ 8` at unit `dirs` on the GPU (`dirs.len() × N²`,
/// f32) — the parity check of the WGSL recurrence against the CPU basis.
pub fn sh_eval_gpu(
    ctx: &GpuContext,
    order: usize,
    dirs: &[[f32; 3]],
) -> Result<Vec<f32>, GpuError> {
    check_gpu_order(order)?;
    let nn = order * order;
    let params = GpuParams {
        order: order as u32,
        nn: nn as u32,
        samples: dirs.len() as u32,
        ..Default::default()
    };
    use wgpu::util::DeviceExt;
    let params_buf = ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
    let d4: Vec<[f32; 4]> = dirs.iter().map(|d| [d[0], d[1], d[2], 0.0]).collect();
    let dirs_buf = ctx.storage_init("dirs", bytemuck::cast_slice(&d4));
    let knorm_buf = ctx.storage_init("knorm", bytemuck::cast_slice(&knorm_table(order)));
    let out = ctx.storage("values", 4 * (dirs.len() * nn) as u64);
    let pipe = ctx.pipeline("sh_eval", &sh_test_source(), "eval");
    let bind = ctx.bind(&pipe, &[&params_buf, &dirs_buf, &knorm_buf, &out]);
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_pipeline(&pipe);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((dirs.len() as u32).div_ceil(64), 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    let v: Vec<f32> = bytemuck::cast_slice(&ctx.read_buffer(&out)?).to_vec();
    Ok(v[..dirs.len() * nn].to_vec())
}
