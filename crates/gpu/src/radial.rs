//! The papers' extrapolation with per-direction radii on the GPU (`radial = "clearance"`: each
//! base-sphere sample moved outward along its direction until clear of the surface; the papers'
//! future work, TR §6): per frame the samples are moved to that frame's radii
//! ([`GpuSampler::move_samples`]), cast and projected; each receiver's `U = R M_kᵀ Rᵀ T` is
//! rebuilt on the device with `k = d / r(q)`, r(q) the radii interpolated at its direction
//! ([`GpuReceiverBuilder`], the same pass as the papers' path with the receiver's own radius),
//! and every receiver shaded from it. The radii, the k-table and the receivers' locations are
//! the host's (distance queries and the spherical triangulation), written into buffers made
//! once: a frame creates no buffer and no pipeline.

use crate::bvh::FlatBvh;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::sampling::GpuSampler;
use crate::shading::{GpuReceiverBuilder, GpuShader, ReceiverSetup};
use crate::timing::StageTimer;
use glam::DVec3;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::Mesh;

/// Host and device times of one frame, in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuRadialTimes {
    /// Host: BVH update; the BVH, sample positions and receiver inputs uploaded.
    pub bvh_seconds: f64,
    pub upload_seconds: f64,
    /// Device: the rays, their projection, the receivers' setup, the shading (timestamps where
    /// available, else each stage's synchronised wall clock).
    pub sampling_seconds: f64,
    pub projection_seconds: f64,
    pub setup_seconds: f64,
    pub shading_seconds: f64,
}

/// A deforming entity's extrapolation from per-direction radii on the GPU.
pub struct GpuRadial {
    bvh: FlatBvh,
    sampler: GpuSampler,
    builder: GpuReceiverBuilder,
    shader: GpuShader,
    timer: StageTimer,
}

impl GpuRadial {
    /// Set up for `mesh` (any pose: same topology throughout), `samples` base-sphere samples
    /// cast with `H × H` rays at the order of `setup`'s table, shading `setup`'s receivers (its
    /// table's size and light fixed over the sequence).
    pub fn new(
        ctx: &GpuContext,
        mesh: &Mesh,
        strategy: UpdateStrategy,
        (h, samples): (usize, usize),
        setup: &ReceiverSetup<'_>,
    ) -> Result<Self, GpuError> {
        let order = setup.table.order();
        let bvh = FlatBvh::build(mesh, strategy)?;
        let ntris = mesh.triangles.len();
        let placeholder = vec![DVec3::Z; samples];
        let mut sampler =
            GpuSampler::at_points(ctx, order, h, DVec3::ZERO, &placeholder, (2 * ntris, ntris))?;
        let builder = GpuReceiverBuilder::new(ctx, setup, &sampler.params)?;
        let coeffs = sampler.coeffs_buffer().clone();
        let params_buf = sampler.params_buf.clone();
        let shader = builder.shader(ctx, &params_buf, &mut sampler.params, &coeffs);
        Ok(Self {
            bvh,
            sampler,
            builder,
            shader,
            timer: StageTimer::new(ctx, 4),
        })
    }

    /// Render one frame: the posed `mesh`, its samples at `points` casting toward `center`
    /// (the frame's bounding sphere's), the receivers' `setup` for this frame. Returns the
    /// image (RGB per receiver) and the frame's times.
    pub fn frame(
        &mut self,
        ctx: &GpuContext,
        mesh: &Mesh,
        (center, points): (DVec3, &[DVec3]),
        setup: &ReceiverSetup<'_>,
    ) -> Result<(Vec<[f32; 3]>, GpuRadialTimes), GpuError> {
        let mut times = GpuRadialTimes::default();
        let t1;
        (times.bvh_seconds, t1) =
            (self.sampler).follow(ctx, &mut self.bvh, mesh, Some((center, points)))?;
        self.builder.write(ctx, setup, &self.sampler.params)?;
        times.upload_seconds = t1.elapsed().as_secs_f64();
        let labels = [
            "bsv sampling",
            "sh conversion",
            "receiver setup",
            "shadowing",
        ];
        let device = self.timer.run(ctx, labels, |i, pass| match i {
            0 => self.sampler.record_cast(pass),
            1 => self.sampler.record_project(pass),
            2 => self.builder.record(pass),
            _ => self.shader.record(pass),
        })?;
        [
            times.sampling_seconds,
            times.projection_seconds,
            times.setup_seconds,
            times.shading_seconds,
        ] = device;
        Ok((self.shader.read_image(ctx)?, times))
    }
}
