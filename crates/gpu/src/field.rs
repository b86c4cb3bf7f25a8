//! The papers' baseline, the fully sampled shadow field (Zhou et al. 2005), on the GPU: per
//! frame the shells' samples are cast and projected by the sampling kernels (every shell's
//! samples in one dispatch, each casting its facing hemisphere toward the entity's centre — the
//! CPU's `FullField::build`), and every receiver is shaded from its interpolation weights
//! (field.wgsl; the weights computed on the host by `FullField::weights`, since they depend on
//! the frame's bounding sphere and the receivers only). Three device stages, timed as the papers'
//! Table 1 names them: BSV sampling (the shells' rays), SH conversion, shadowing.

use crate::bvh::FlatBvh;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuSetParams};
use crate::sampling::GpuSampler;
use crate::timing::{grid_64, StageTimer};
use glam::DVec3;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::Mesh;

const FIELD_WGSL: &str = include_str!("field.wgsl");

/// The full-field shading kernel's source.
pub fn source() -> String {
    shader(&[FIELD_WGSL])
}

/// The weight slot of a receiver beyond the outermost shell (see field.wgsl).
pub const BEYOND: [u32; 2] = [u32::MAX, 0];

/// One receiver's interpolation weights as the kernel reads them: eight `(flat sample index,
/// f32 bits of the weight)` slots, unused ones of weight 0; [`BEYOND`] first for a receiver the
/// entity does not occlude.
pub type WeightSlots = [[u32; 2]; 8];

/// Host and device times of one full-field frame, in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuFieldTimes {
    /// Host: BVH update, the shells' sample positions and the BVH uploaded.
    pub bvh_seconds: f64,
    pub upload_seconds: f64,
    /// Device: the three stages (timestamps where available, else each stage's synchronised
    /// wall clock).
    pub sampling_seconds: f64,
    pub projection_seconds: f64,
    pub shading_seconds: f64,
}

/// A deforming entity's full field on the GPU, shading a fixed receiver set.
pub struct GpuFullField {
    bvh: FlatBvh,
    sampler: GpuSampler,
    receivers: usize,
    weights_buf: wgpu::Buffer,
    image_buf: wgpu::Buffer,
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    timer: StageTimer,
}

impl GpuFullField {
    /// Set up for `mesh` (any pose of the sequence: same topology throughout), `samples` shell
    /// samples (shell-major, as `FullField`'s flat index) cast with `H × H` rays each at order
    /// `N ≤ 8`, shading `receivers` points with the light's `transfer` (per channel, N² each;
    /// grey when the three are equal).
    pub fn new(
        ctx: &GpuContext,
        mesh: &Mesh,
        strategy: UpdateStrategy,
        (order, h): (usize, usize),
        samples: usize,
        receivers: usize,
        transfer: &[Vec<f64>; 3],
    ) -> Result<Self, GpuError> {
        crate::sampling::check_gpu_order(order)?;
        let nn = order * order;
        if receivers == 0 || transfer.iter().any(|t| t.len() != nn) {
            return Err(GpuError::Input(format!(
                "{receivers} receivers with transfers of {:?} coefficients for order {order}",
                transfer.iter().map(Vec::len).collect::<Vec<_>>()
            )));
        }
        ctx.check_binding("the receivers' weights", 64 * receivers as u64)?;
        let bvh = FlatBvh::build(mesh, strategy)?;
        let ntris = mesh.triangles.len();
        // Placeholder positions (moved every frame): unit points about the origin.
        let dirs = vec![DVec3::Z; samples];
        let sampler = GpuSampler::at_points(ctx, order, h, DVec3::ZERO, &dirs, (2 * ntris, ntris))?;
        let channels = if transfer[0] == transfer[1] && transfer[1] == transfer[2] {
            1
        } else {
            3
        };
        let t: Vec<f32> = (transfer[..channels].iter())
            .flat_map(|c| c.iter().map(|&v| v as f32))
            .collect();
        let params = GpuSetParams {
            receivers: receivers as u32,
            order: order as u32,
            nn: nn as u32,
            channels: channels as u32,
            ..Default::default()
        };
        let params_buf = ctx.uniform("field params", bytemuck::bytes_of(&params));
        let weights_buf = ctx.storage("field weights", (64 * receivers) as u64);
        let transfer_buf = ctx.storage_init("field transfer", bytemuck::cast_slice(&t));
        let image_buf = ctx.storage("field image", (16 * receivers) as u64);
        let pipe = ctx.pipeline("full field", &source(), "shade_field");
        let bind = ctx.bind(
            &pipe,
            &[
                &params_buf,
                &weights_buf,
                sampler.coeffs_buffer(),
                &transfer_buf,
                &image_buf,
            ],
        );
        Ok(Self {
            bvh,
            sampler,
            receivers,
            weights_buf,
            image_buf,
            pipe,
            bind,
            timer: StageTimer::new(ctx, 3),
        })
    }

    /// Place the samples once, each at `points[i]` casting toward `target(i)` (frames then
    /// render with `samples = None`): fields whose samples do not follow the entity, as the
    /// ray-traced receivers (`shscale_scene::gpu_truth`).
    pub fn place_samples(
        &self,
        ctx: &GpuContext,
        target: impl Fn(usize) -> DVec3,
        points: &[DVec3],
    ) -> Result<(), GpuError> {
        self.sampler.move_samples_toward(ctx, target, points)
    }

    /// Render one frame: the posed `mesh`, its shells' sample `points` casting toward `center`
    /// (the frame's bounding sphere's; `None`: the samples stay where they are), every
    /// receiver's `weights` for this frame. Returns the image (RGB per receiver) and the frame's
    /// times.
    pub fn frame(
        &mut self,
        ctx: &GpuContext,
        mesh: &Mesh,
        samples: Option<(DVec3, &[DVec3])>,
        weights: &[WeightSlots],
    ) -> Result<(Vec<[f32; 3]>, GpuFieldTimes), GpuError> {
        if weights.len() != self.receivers {
            return Err(GpuError::Input(format!(
                "{} receivers' weights for {} receivers",
                weights.len(),
                self.receivers
            )));
        }
        let mut times = GpuFieldTimes::default();
        let t1;
        (times.bvh_seconds, t1) = self.sampler.follow(ctx, &mut self.bvh, mesh, samples)?;
        ctx.queue
            .write_buffer(&self.weights_buf, 0, bytemuck::cast_slice(weights));
        times.upload_seconds = t1.elapsed().as_secs_f64();
        let labels = ["bsv sampling", "sh conversion", "shadowing"];
        let device = self.timer.run(ctx, labels, |i, pass| match i {
            0 => self.sampler.record_cast(pass),
            1 => self.sampler.record_project(pass),
            _ => {
                let (x, y) = grid_64(self.receivers as u32);
                pass.set_pipeline(&self.pipe);
                pass.set_bind_group(0, &self.bind, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
        })?;
        [
            times.sampling_seconds,
            times.projection_seconds,
            times.shading_seconds,
        ] = device;
        Ok((ctx.read_image(&self.image_buf, self.receivers)?, times))
    }

    /// Rays cast per frame.
    pub fn rays(&self) -> usize {
        self.sampler.samples * self.sampler.rays
    }
}
