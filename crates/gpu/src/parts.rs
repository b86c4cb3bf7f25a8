//! Sub-volumes on the GPU (TR §6, SHS §5: "partitioning a deformable object into a small number
//! of sub-volumes that are handled separately"): per frame every part's base-sphere samples are
//! cast against that part alone and projected (the sampling kernels, one sampler and flattened
//! BVH per part), the parts' coefficients gathered into one buffer, and every receiver shaded
//! from the parts' extrapolated visibilities multiplied near to far (parts.wgsl, the twin of
//! `SubVolumeField`). The parts' spheres, k-tables and the receivers' locations in each part's
//! triangulation are the host's, written into buffers made once. Device time: the frame's one
//! submission by the synchronised wall clock (its passes are many: a pair per part).

use crate::bvh::FlatBvh;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuPartsParams, GpuReceiver, SH_WGSL};
use crate::sampling::GpuSampler;
use crate::timing::grid_64;
use glam::DVec3;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{Mesh, Sphere, RAY_EPS};
use shscale_scaling::KTable;
use shscale_sh::{DirectionSet, GauntTensor};
use std::time::Instant;

const PARTS_WGSL: &str = include_str!("parts.wgsl");

/// The most parts the kernel sorts and multiplies per receiver.
pub const MAX_GPU_PARTS: usize = 16;

/// The sub-volumes kernel's source.
pub fn source() -> String {
    shader(&[SH_WGSL, PARTS_WGSL, crate::sphereset::PRODUCT_WGSL])
}

/// One frame's host inputs per part: its sampling sphere (centre, `s·r_p`), its samples' points,
/// its k-table over the receivers, and every receiver's three samples and weights.
pub struct PartFrame<'a> {
    pub mesh: &'a Mesh,
    pub sampling: Sphere,
    pub points: &'a [DVec3],
    pub table: &'a KTable,
    pub locations: &'a [[(u32, f64); 3]],
}

/// Host and device times of one frame, in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuPartsTimes {
    /// Host: the parts' BVH updates; the BVHs, samples, tables and locations uploaded.
    pub bvh_seconds: f64,
    pub upload_seconds: f64,
    /// Device: every part's rays and projection and the shading, one submission (wall clock).
    pub device_seconds: f64,
}

/// The kernel's constant tables.
struct Constants {
    /// The transfer (grey once, else RGB), `channels × N²`.
    transfer: Vec<f32>,
    /// The Gaunt entries `(i, j, k, bits of the value)`.
    gaunt: Vec<[u32; 4]>,
    /// The Gauss sphere rule of the order (direction, weight).
    quad: Vec<[f32; 4]>,
    channels: usize,
}

/// The [`Constants`] of a light's `transfer` at the order of `gaunt`.
fn constants(transfer: &[Vec<f64>; 3], gaunt: &GauntTensor<f64>) -> Constants {
    let channels = if transfer[0] == transfer[1] && transfer[1] == transfer[2] {
        1
    } else {
        3
    };
    let t: Vec<f32> = (transfer[..channels].iter())
        .flat_map(|c| c.iter().map(|&v| v as f32))
        .collect();
    let g: Vec<[u32; 4]> = (gaunt.entries().iter())
        .map(|&(i, j, k, v)| [i, j, k, (v as f32).to_bits()])
        .collect();
    let q = DirectionSet::gauss_sphere_for_order(gaunt.order());
    let quad: Vec<[f32; 4]> = (q.dirs.iter().zip(&q.weights))
        .map(|(d, &w)| [d[0] as f32, d[1] as f32, d[2] as f32, w as f32])
        .collect();
    Constants {
        transfer: t,
        gaunt: g,
        quad,
        channels,
    }
}

/// 1 to [`MAX_GPU_PARTS`] parts, some receivers, two or more k values.
fn check_sizes(parts: usize, receivers: usize, k_count: usize) -> Result<(), GpuError> {
    if parts == 0 || parts > MAX_GPU_PARTS || receivers == 0 || k_count < 2 {
        return Err(GpuError::Input(format!(
            "{parts} parts (1 to {MAX_GPU_PARTS}), {receivers} receivers and {k_count} k values (≥ 2)"
        )));
    }
    Ok(())
}

/// The flattened BVH and sampler of every part (`samples` placeholder points, moved per frame).
fn part_samplers(
    ctx: &GpuContext,
    meshes: &[Mesh],
    (order, h, samples): (usize, usize, usize),
) -> Result<Vec<(FlatBvh, GpuSampler)>, GpuError> {
    let placeholder = vec![DVec3::Z; samples];
    (meshes.iter())
        .map(|m| {
            let bvh = FlatBvh::build(m, UpdateStrategy::Refit)?;
            let n = m.triangles.len();
            let s = GpuSampler::at_points(ctx, order, h, DVec3::ZERO, &placeholder, (2 * n, n))?;
            Ok((bvh, s))
        })
        .collect()
}

/// Sub-volumes of a deforming entity on the GPU, shading a fixed receiver set.
pub struct GpuSubVolumes {
    /// The uniform (its `log_k` written with each frame's tables).
    params: GpuPartsParams,
    params_buf: wgpu::Buffer,
    parts: Vec<(FlatBvh, GpuSampler)>,
    geo_buf: wgpu::Buffer,
    locs_buf: wgpu::Buffer,
    tables_buf: wgpu::Buffer,
    coeffs_buf: wgpu::Buffer,
    image_buf: wgpu::Buffer,
    transfer: Vec<f32>,
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
}

impl GpuSubVolumes {
    /// Set up for the parts `meshes` (any pose: their topology fixed), `samples` base-sphere
    /// samples per part cast with `H × H` rays, `k_count` k values per part's table, shading
    /// `receivers` with the light's `transfer` at the order N of `gaunt` (≤ 8).
    pub fn new(
        ctx: &GpuContext,
        meshes: &[Mesh],
        (h, samples, k_count): (usize, usize, usize),
        receivers: &[DVec3],
        transfer: &[Vec<f64>; 3],
        gaunt: &GauntTensor<f64>,
    ) -> Result<Self, GpuError> {
        let order = gaunt.order();
        crate::sampling::check_gpu_order(order)?;
        let nn = order * order;
        let p = meshes.len();
        check_sizes(p, receivers.len(), k_count)?;
        let tables_len = p * k_count * (1 + nn * nn) + 3 * nn;
        for (what, bytes) in [
            ("the receivers' locations", 48 * p * receivers.len()),
            ("the parts' tables", 4 * tables_len),
            ("the parts' coefficients", 4 * p * samples * nn),
        ] {
            ctx.check_binding(what, bytes as u64)?;
        }
        let parts = part_samplers(ctx, meshes, (order, h, samples))?;
        let c = constants(transfer, gaunt);
        let (g, quad, channels) = (&c.gaunt, &c.quad, c.channels);
        let params = GpuPartsParams {
            receivers: receivers.len() as u32,
            order: order as u32,
            nn: nn as u32,
            parts: p as u32,
            samples: samples as u32,
            entries: g.len() as u32,
            quad: quad.len() as u32,
            k_count: k_count as u32,
            channels: channels as u32,
            ..Default::default()
        };
        let params_buf = ctx.uniform("parts params", bytemuck::bytes_of(&params));
        // The receivers, then the parts' spheres (written per frame).
        let geo: Vec<[f32; 4]> = (receivers.iter())
            .map(|r| [r.x as f32, r.y as f32, r.z as f32, 1.0])
            .chain(std::iter::repeat_n([0.0f32; 4], p))
            .collect();
        let geo_buf = ctx.storage_init("parts geo", bytemuck::cast_slice(&geo));
        let locs_buf = ctx.storage("parts locations", (48 * p * receivers.len()) as u64);
        let tables_buf = ctx.storage("parts tables", (4 * tables_len) as u64);
        let coeffs_buf = ctx.storage("parts coeffs", (4 * p * samples * nn) as u64);
        let image_buf = ctx.storage("parts image", (16 * receivers.len()) as u64);
        let pipe = ctx.pipeline("sub-volumes", &source(), "shade_parts");
        let bind = ctx.bind(
            &pipe,
            &[
                &params_buf,
                &geo_buf,
                &locs_buf,
                &tables_buf,
                &coeffs_buf,
                &ctx.storage_init("parts gaunt", bytemuck::cast_slice(g)),
                &ctx.storage_init("parts quad", bytemuck::cast_slice(quad)),
                &ctx.storage_init(
                    "knorm",
                    bytemuck::cast_slice(&crate::sampling::knorm_table(order)),
                ),
                &image_buf,
            ],
        );
        Ok(Self {
            params,
            params_buf,
            parts,
            geo_buf,
            locs_buf,
            tables_buf,
            coeffs_buf,
            image_buf,
            transfer: c.transfer,
            pipe,
            bind,
        })
    }

    /// Upload a frame's inputs: every part's BVH and samples, the tables (abscissae, matrices,
    /// the transfer), the receivers' locations and the parts' spheres.
    fn write_inputs(&mut self, ctx: &GpuContext, parts: &[PartFrame<'_>]) -> Result<(), GpuError> {
        let nn = self.params.nn as usize;
        let (mut xs, mut mats, mut locs, mut centres) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut log_k = None;
        for ((bvh, sampler), f) in self.parts.iter_mut().zip(parts) {
            let tmin = RAY_EPS * f.mesh.bounding_sphere().radius;
            sampler.upload(ctx, bvh, tmin)?;
            sampler.move_samples(ctx, f.sampling.center, f.points)?;
            let (ks, lk) = (f.table.ks(), f.table.log_k());
            if ks.len() != self.params.k_count as usize || f.table.order() * f.table.order() != nn {
                return Err(GpuError::Input(format!(
                    "a part's table of {} k at order {} for a set-up of {} at N² = {nn}",
                    ks.len(),
                    f.table.order(),
                    self.params.k_count as usize
                )));
            }
            if *log_k.get_or_insert(lk) != lk {
                return Err(GpuError::Input("the parts' tables mix k and ln k".into()));
            }
            xs.extend(
                ks.iter()
                    .map(|&k| if lk { k.ln() as f32 } else { k as f32 }),
            );
            for m in f.table.matrices() {
                for row in m.to_dense() {
                    mats.extend(row.iter().map(|&v| v as f32));
                }
            }
            if f.locations.len() != self.params.receivers as usize {
                return Err(GpuError::Input(format!(
                    "{} locations for {} receivers",
                    f.locations.len(),
                    self.params.receivers as usize
                )));
            }
            locs.extend(f.locations.iter().map(|l| GpuReceiver {
                idx: l.map(|x| x.0),
                flag: 0,
                w: [l[0].1 as f32, l[1].1 as f32, l[2].1 as f32, 0.0],
                constant: [0.0; 4],
            }));
            let c = f.sampling.center;
            centres.push([c.x as f32, c.y as f32, c.z as f32, f.sampling.radius as f32]);
        }
        let mut tables = xs;
        tables.extend(mats);
        tables.extend(&self.transfer);
        self.params.log_k = u32::from(log_k.unwrap_or(false));
        ctx.queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        ctx.queue
            .write_buffer(&self.tables_buf, 0, bytemuck::cast_slice(&tables));
        ctx.queue
            .write_buffer(&self.locs_buf, 0, bytemuck::cast_slice(&locs));
        ctx.queue.write_buffer(
            &self.geo_buf,
            (16 * self.params.receivers as usize) as u64,
            bytemuck::cast_slice(&centres),
        );
        Ok(())
    }

    /// Render one frame: every part's posed mesh, sampling sphere, samples, table and the
    /// receivers' locations ([`PartFrame`], in the order the set-up's meshes came). Returns the
    /// image (RGB per receiver) and the frame's times.
    pub fn frame(
        &mut self,
        ctx: &GpuContext,
        parts: &[PartFrame<'_>],
    ) -> Result<(Vec<[f32; 3]>, GpuPartsTimes), GpuError> {
        let nn = self.params.nn as usize;
        if parts.len() != self.parts.len() {
            return Err(GpuError::Input(format!(
                "{} parts for a set-up of {}",
                parts.len(),
                self.parts.len()
            )));
        }
        let mut times = GpuPartsTimes::default();
        let t0 = Instant::now();
        for ((bvh, _), f) in self.parts.iter_mut().zip(parts) {
            bvh.update(f.mesh)?;
        }
        times.bvh_seconds = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        self.write_inputs(ctx, parts)?;
        times.upload_seconds = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        let part_bytes = (4 * self.params.samples as usize * nn) as u64;
        for (i, (_, sampler)) in self.parts.iter().enumerate() {
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
                sampler.record_cast(&mut pass);
                sampler.record_project(&mut pass);
            }
            enc.copy_buffer_to_buffer(
                sampler.coeffs_buffer(),
                0,
                &self.coeffs_buf,
                i as u64 * part_bytes,
                part_bytes,
            );
        }
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            let (x, y) = grid_64(self.params.receivers);
            pass.set_pipeline(&self.pipe);
            pass.set_bind_group(0, &self.bind, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        times.device_seconds = t0.elapsed().as_secs_f64();
        Ok((
            ctx.read_image(&self.image_buf, self.params.receivers as usize)?,
            times,
        ))
    }
}
