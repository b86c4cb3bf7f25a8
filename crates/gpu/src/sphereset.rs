//! Sphere sets on the GPU: every receiver's visibility as the closed-form caps of a set of
//! spheres multiplied near to far with the order-N Gaunt product (or combined by SH
//! exponentiation, [`GpuSphereSet::shexp`], shexp.wgsl), shaded with the light's
//! transfer — the twin of the CPU's `SphereVisibility` fields through `near_to_far` and
//! `Shader::shade` (sphereset.wgsl). Built once per receiver set and light ([`GpuSphereSet`]);
//! per frame only the spheres (refitted to the posed mesh on the host) are uploaded, or the
//! meshes are posed and their spheres fitted on the device ([`GpuSphereSet::frame_on_device`],
//! [`crate::fit`]) and only their poses are. Two
//! combinations: the plain chain (internal order = N, [`GpuSphereSet::new`]) and the exact union
//! of the caps ([`GpuSphereSet::union`], union.wgsl: the CPU's `SphereSetUnion` ring by ring in
//! f32, shaded against the light's transfer taken into the union's local frame by an exact
//! quadrature); at most [`MAX_GPU_SPHERES`] spheres; `N ≤ 8`.

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuSetParams, SH_WGSL};
use crate::timing::{grid_64, StageTimer};
use glam::DVec3;
use shscale_field::union::RingGrid;
use shscale_geometry::Sphere;
use shscale_sh::GauntTensor;

const SPHERESET_WGSL: &str = include_str!("sphereset.wgsl");
/// The truncated Gaunt product of the multiplying kernels.
pub(crate) const PRODUCT_WGSL: &str = include_str!("product.wgsl");
const UNION_WGSL: &str = include_str!("union.wgsl");
const SHEXP_WGSL: &str = include_str!("shexp.wgsl");

/// The most z-rings the GPU union takes (its private arrays' size).
pub const MAX_GPU_RINGS: usize = 32;

pub use crate::layout::MAX_GPU_SPHERES;

/// The sphere-set shading kernel's source.
pub fn source() -> String {
    shader(&[SH_WGSL, SPHERESET_WGSL, PRODUCT_WGSL])
}

/// The SH-exponentiation kernel's source (it reuses the sphere-set kernel's bindings).
pub(crate) fn shexp_source() -> String {
    shader(&[SH_WGSL, SPHERESET_WGSL, PRODUCT_WGSL, SHEXP_WGSL])
}

/// The union kernel's source.
pub fn union_source() -> String {
    shader(&[SH_WGSL, UNION_WGSL])
}

/// A receiver set and light on the GPU, shaded from a sphere set per frame.
pub struct GpuSphereSet {
    receivers: usize,
    order: usize,
    channels: usize,
    entries: usize,
    /// The union's rings (0: the product chain).
    rings: usize,
    params_buf: wgpu::Buffer,
    spheres_buf: wgpu::Buffer,
    image_buf: wgpu::Buffer,
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    /// The frame's one stage, timed (its query set made once, not per frame).
    timer: StageTimer,
    /// A frame posed and fitted on the device: deform, sphere fit, shading.
    device_timer: StageTimer,
}

impl GpuSphereSet {
    /// Receivers at `points`, light transfer `transfer` (per channel, N² each; grey when the
    /// three are equal), the caps multiplied near to far at the order N of `gaunt`.
    pub fn new(
        ctx: &GpuContext,
        points: &[DVec3],
        transfer: &[Vec<f64>; 3],
        gaunt: &GauntTensor<f64>,
    ) -> Result<Self, GpuError> {
        let g = gaunt_words(gaunt);
        let table = ctx.storage_init("set gaunt", bytemuck::cast_slice(&g));
        let pipe = ctx.pipeline("sphere set", &source(), "shade_set");
        Self::build(
            ctx,
            points,
            transfer,
            gaunt.order(),
            (g.len(), 0),
            (pipe, table),
            None,
        )
    }

    /// Receivers at `points`, light transfer `transfer` (as [`Self::new`]), the caps combined as
    /// their exact union with the rings of `grid` (at most [`MAX_GPU_RINGS`]) at its order.
    pub fn union(
        ctx: &GpuContext,
        points: &[DVec3],
        transfer: &[Vec<f64>; 3],
        grid: &RingGrid,
    ) -> Result<Self, GpuError> {
        let (order, rings) = (grid.order(), grid.rings());
        if rings > MAX_GPU_RINGS {
            return Err(GpuError::Input(format!(
                "{rings} rings: the GPU union takes at most {MAX_GPU_RINGS}"
            )));
        }
        // The ring rules of 1..=rings nodes, then the order-N Gauss–Legendre rule in z.
        let mut rules: Vec<[f32; 2]> = Vec::new();
        for k in 1..=rings {
            let (c, w) = grid.rule(k);
            rules.extend(c.iter().zip(w).map(|(c, w)| [*c as f32, *w as f32]));
        }
        rules.extend(
            shscale_sh::GaussLegendre::new(order)
                .on(-1.0, 1.0)
                .map(|(z, w)| [z as f32, w as f32]),
        );
        let table = ctx.storage_init("union rules", bytemuck::cast_slice(&rules));
        let pipe = ctx.pipeline("sphere set union", &union_source(), "shade_union");
        Self::build(
            ctx,
            points,
            transfer,
            order,
            (0, rings),
            (pipe, table),
            None,
        )
    }

    /// Receivers at `points`, light transfer `transfer` (as [`Self::new`]), the caps combined by
    /// SH exponentiation: each sphere's zonal log from `table` (interpolated in t = 1 − cos A)
    /// rotated and summed, then the HYB exponential (halved below `min(HYB_MAGNITUDE, 0.96 ×
    /// the table's largest magnitude)`, OL, squared back by `gaunt`'s truncated products) — the
    /// CPU's `SphereSetShexp` with `Exp::Hyb` in f32. `gaunt` and `table` of one order, at most
    /// `MAX_SHEXP_ORDER` and the GPU's order.
    pub fn shexp(
        ctx: &GpuContext,
        points: &[DVec3],
        transfer: &[Vec<f64>; 3],
        gaunt: &GauntTensor<f64>,
        table: &shscale_field::shexp_ol::ZonalLogTable,
    ) -> Result<Self, GpuError> {
        if table.order() != gaunt.order() {
            return Err(GpuError::Input(format!(
                "a log table of order {} with a Gaunt tensor of order {}",
                table.order(),
                gaunt.order()
            )));
        }
        let g = gaunt_words(gaunt);
        let gaunt_buf = ctx.storage_init("shexp gaunt", bytemuck::cast_slice(&g));
        let (ol, logs) = (table.ol_rows(), table.log_rows());
        let limit = shscale_field::shexp_ol::HYB_MAGNITUDE.min(0.96 * table.max_magnitude());
        let mut words: Vec<f32> = vec![ol.len() as f32, (logs.len() - 1) as f32, limit as f32, 0.0];
        words.extend(
            ol.iter()
                .flat_map(|&(m, a, b)| [m as f32, a as f32, b as f32]),
        );
        words.extend(logs.iter().flatten().map(|&v| v as f32));
        let tables = ctx.storage_init("shexp tables", bytemuck::cast_slice(&words));
        let pipe = ctx.pipeline("sphere set shexp", &shexp_source(), "shade_shexp");
        Self::build(
            ctx,
            points,
            transfer,
            gaunt.order(),
            (g.len(), 0),
            (pipe, gaunt_buf),
            Some(&tables),
        )
    }

    /// The buffers and bind group of any kernel: `(entries, rings)` of the kernel's table (the
    /// Gaunt tensor's entries, or the union's rings), its pipeline and table, and the
    /// exponentiation's tables (binding 7) for its kernel.
    fn build(
        ctx: &GpuContext,
        points: &[DVec3],
        transfer: &[Vec<f64>; 3],
        order: usize,
        (entries, rings): (usize, usize),
        (pipe, table): (wgpu::ComputePipeline, wgpu::Buffer),
        extra: Option<&wgpu::Buffer>,
    ) -> Result<Self, GpuError> {
        crate::sampling::check_gpu_order(order)?;
        let nn = order * order;
        if points.is_empty() || transfer.iter().any(|t| t.len() != nn) {
            return Err(GpuError::Input(format!(
                "{} receivers with transfers of {:?} coefficients for order {order}",
                points.len(),
                transfer.iter().map(Vec::len).collect::<Vec<_>>()
            )));
        }
        let channels = if transfer[0] == transfer[1] && transfer[1] == transfer[2] {
            1
        } else {
            3
        };
        let pts: Vec<[f32; 4]> = (points.iter())
            .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
            .collect();
        let t: Vec<f32> = (transfer[..channels].iter())
            .flat_map(|c| c.iter().map(|&v| v as f32))
            .collect();
        let params = GpuSetParams {
            receivers: points.len() as u32,
            order: order as u32,
            nn: nn as u32,
            entries: entries as u32,
            channels: channels as u32,
            rings: rings as u32,
            panel_rings: shscale_field::union::PANEL_RINGS as u32,
            ..Default::default()
        };
        let params_buf = ctx.uniform("set params", bytemuck::bytes_of(&params));
        let points_buf = ctx.storage_init("set points", bytemuck::cast_slice(&pts));
        let spheres_buf = ctx.storage("set spheres", (16 * MAX_GPU_SPHERES) as u64);
        let transfer_buf = ctx.storage_init("set transfer", bytemuck::cast_slice(&t));
        let knorm_buf = ctx.storage_init(
            "knorm",
            bytemuck::cast_slice(&crate::sampling::knorm_table(order)),
        );
        let image_buf = ctx.storage("set image", (16 * points.len()) as u64);
        let mut buffers = vec![
            &params_buf,
            &points_buf,
            &spheres_buf,
            &table,
            &transfer_buf,
            &knorm_buf,
            &image_buf,
        ];
        buffers.extend(extra);
        let bind = ctx.bind(&pipe, &buffers);
        Ok(Self {
            receivers: points.len(),
            order,
            channels,
            entries,
            rings,
            params_buf,
            spheres_buf,
            image_buf,
            pipe,
            bind,
            timer: StageTimer::new(ctx, 1),
            device_timer: StageTimer::new(ctx, 3),
        })
    }

    /// Shade every receiver under `spheres`: the image (RGB per receiver), the kernel's device
    /// time in seconds (timestamps where available, else the synchronised wall clock of the
    /// upload and the dispatch) and the synchronised wall clock of the upload, the dispatch and
    /// the wait (the image's read-back not included).
    pub fn frame(
        &self,
        ctx: &GpuContext,
        spheres: &[Sphere],
    ) -> Result<(Vec<[f32; 3]>, f64, f64), GpuError> {
        if spheres.is_empty() || spheres.len() > MAX_GPU_SPHERES {
            return Err(GpuError::Input(format!(
                "{} spheres: the GPU sphere set takes 1 to {MAX_GPU_SPHERES}",
                spheres.len()
            )));
        }
        let s = sphere_words(spheres);
        let params = self.params(s.len());
        let t0 = std::time::Instant::now();
        ctx.queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&params));
        ctx.queue
            .write_buffer(&self.spheres_buf, 0, bytemuck::cast_slice(&s));
        let timer = &self.timer;
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        self.record(&mut enc.begin_compute_pass(&timer.pass("sphere set", 0)));
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        let wall = t0.elapsed().as_secs_f64();
        let device = timer.read(ctx)?.map_or(wall, |v| v[0]);
        Ok((self.read_image(ctx)?, device, wall))
    }

    /// The sphere buffer a device fit writes into ([`crate::fit::GpuSphereFit`]).
    pub fn spheres_buffer(&self) -> &wgpu::Buffer {
        &self.spheres_buf
    }

    /// Shade every receiver at time `t` with the spheres of `fits` (each mesh posed and fitted
    /// on the device into its slots) followed by `fixed` (spheres that do not move, written
    /// after the fits' slots): three device stages, their seconds — deform, sphere fit, shading
    /// (timestamps where available, else each stage alone by the synchronised wall clock).
    /// Nothing is read back ([`Self::read_image`] reads the frame).
    pub fn frame_on_device(
        &self,
        ctx: &GpuContext,
        fits: &mut [crate::fit::GpuSphereFit],
        fixed: &[Sphere],
        t: f64,
    ) -> Result<[f64; 3], GpuError> {
        let fitted: usize = fits.iter().map(crate::fit::GpuSphereFit::parts).sum();
        let count = fitted + fixed.len();
        if count == 0 || count > MAX_GPU_SPHERES {
            return Err(GpuError::Input(format!(
                "{count} spheres: the GPU sphere set takes 1 to {MAX_GPU_SPHERES}"
            )));
        }
        let params = self.params(count);
        ctx.queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&params));
        if !fixed.is_empty() {
            ctx.queue.write_buffer(
                &self.spheres_buf,
                16 * fitted as u64,
                bytemuck::cast_slice(&sphere_words(fixed)),
            );
        }
        for f in fits.iter_mut() {
            f.prepare(ctx, t);
        }
        let fits = &*fits;
        self.device_timer.run(
            ctx,
            ["deform", "sphere fit", "sphere set"],
            |i, pass| match i {
                0 => fits.iter().for_each(|f| f.record_deform(pass)),
                1 => fits.iter().for_each(|f| f.record_fit(pass)),
                _ => self.record(pass),
            },
        )
    }

    /// Record the shading pass (one invocation per receiver).
    fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.receivers as u32);
        pass.set_pipeline(&self.pipe);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// The last frame's image (RGB per receiver).
    pub fn read_image(&self, ctx: &GpuContext) -> Result<Vec<[f32; 3]>, GpuError> {
        ctx.read_image(&self.image_buf, self.receivers)
    }

    /// The spheres as the kernel reads them (tests: a device fit's output).
    pub fn read_spheres(&self, ctx: &GpuContext, n: usize) -> Result<Vec<[f32; 4]>, GpuError> {
        let raw = ctx.read_buffer(&self.spheres_buf)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 4]>(&raw)[..n.min(MAX_GPU_SPHERES)].to_vec())
    }

    /// The kernel's parameters for `spheres` spheres.
    fn params(&self, spheres: usize) -> GpuSetParams {
        GpuSetParams {
            receivers: self.receivers as u32,
            order: self.order as u32,
            nn: (self.order * self.order) as u32,
            spheres: spheres as u32,
            entries: self.entries as u32,
            channels: self.channels as u32,
            rings: self.rings as u32,
            panel_rings: shscale_field::union::PANEL_RINGS as u32,
        }
    }
}

/// The Gaunt tensor's entries as the kernels read them: `(i, j, k, bits of the f32 value)`.
fn gaunt_words(gaunt: &GauntTensor<f64>) -> Vec<[u32; 4]> {
    (gaunt.entries().iter())
        .map(|&(i, j, k, v)| [i, j, k, (v as f32).to_bits()])
        .collect()
}

/// Spheres as the kernel reads them: centre and radius in f32.
fn sphere_words(spheres: &[Sphere]) -> Vec<[f32; 4]> {
    (spheres.iter())
        .map(|s| {
            let c = s.center;
            [c.x as f32, c.y as f32, c.z as f32, s.radius as f32]
        })
        .collect()
}
