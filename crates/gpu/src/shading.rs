//! GPU receiver shading (Table 1 "shadowing"): the twin of `ReceiverCache::shade`, reading this
//! frame's BSV coefficients straight from the projection stage's buffer — nothing returns to the
//! host between stages. The cache (indices, weights, `U = R M_kᵀ Rᵀ T`) is uploaded once per
//! sequence; per frame only the coefficients change.

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuCacheParams, GpuParams, GpuReceiver, SH_WGSL};
use crate::timing::grid_64;
use glam::DVec3;
use shscale_field::receivers::ReceiverCache;
use shscale_geometry::Sphere;
use shscale_scaling::{Interp, KTable};
use shscale_sh::DirectionSet;

const SHADING_WGSL: &str = include_str!("shading.wgsl");
const CACHE_WGSL: &str = include_str!("cache.wgsl");

/// The shading shader.
pub fn source() -> String {
    shader(&[SHADING_WGSL])
}

/// The receiver-setup shader.
pub fn cache_source() -> String {
    shader(&[SH_WGSL, CACHE_WGSL])
}

/// Everything the GPU receiver setup needs besides the sample location, which stays on the host
/// (spherical Delaunay point location, `Bsv::locate`).
pub struct ReceiverSetup<'a> {
    /// The k-table (linear interpolation; ln k or k as it was built).
    pub table: &'a KTable,
    /// Per-channel transfer vector `T` of the shared normal (grey: identical channels).
    pub transfer: &'a [Vec<f64>; 3],
    pub receivers: &'a [DVec3],
    /// Per receiver: the three sample indices and weights.
    pub locations: &'a [[(u32, f64); 3]],
    /// The sampling sphere the BSV is taken on.
    pub sampling: Sphere,
    /// Per receiver, the sampling surface's radius at its direction when the samples were placed
    /// by a radial rule (`Bsv::radius_at`); `None`: the sphere's radius for every receiver.
    pub radii: Option<&'a [f64]>,
}

/// Receiver rows of a cache in GPU layout.
pub(crate) fn receiver_rows(cache: &ReceiverCache) -> Vec<GpuReceiver> {
    let (idx, w, _, constant) = cache.rows();
    idx.iter()
        .zip(w)
        .zip(constant)
        .map(|((i, w), c)| GpuReceiver {
            idx: *i,
            flag: u32::from(c.is_some()),
            w: [w[0] as f32, w[1] as f32, w[2] as f32, 0.0],
            constant: c.map_or([0.0; 4], |e| [e[0] as f32, e[1] as f32, e[2] as f32, 0.0]),
        })
        .collect()
}

/// GPU shading of one cached receiver set.
pub struct GpuShader {
    pub receivers: usize,
    pub channels: usize,
    pub(crate) image_buf: wgpu::Buffer,
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    /// Receiver rows and `U` (kept for readback).
    _cache: [wgpu::Buffer; 2],
}

/// The receiver setup checked against the sampler: a linear k-table of a GPU order matching
/// `params`, and one location per receiver. Returns the order and the receiver count.
fn check_setup(setup: &ReceiverSetup<'_>, params: &GpuParams) -> Result<(usize, usize), GpuError> {
    let table = setup.table;
    let (_, _, _, interp) = table.spec();
    if interp != Interp::Linear {
        return Err(GpuError::Input(
            "the GPU receiver setup interpolates k-tables linearly; this table is cubic".into(),
        ));
    }
    let order = table.order();
    crate::sampling::check_gpu_order(order)?;
    let nn = order * order;
    if params.nn as usize != nn {
        return Err(GpuError::Input(format!(
            "k-table of order {order} for a sampler of N² = {}",
            params.nn
        )));
    }
    let n = setup.receivers.len();
    let radii = setup.radii.map_or(n, <[f64]>::len);
    if n == 0 || setup.locations.len() != n || radii != n {
        return Err(GpuError::Input(format!(
            "{n} receivers with {} locations and {radii} radii",
            setup.locations.len()
        )));
    }
    Ok((order, n))
}

/// The inputs of the cache-building pass in f32: the table's nodes (`ln k` for a log table) and
/// dense matrices, the transfer of `channels` channels, the exact quadrature, the receivers and
/// their BSV locations.
struct CacheInputs {
    xs: Vec<f32>,
    mats: Vec<f32>,
    transfer: Vec<f32>,
    quad: Vec<[f32; 4]>,
    points: Vec<[f32; 4]>,
    rows: Vec<GpuReceiver>,
}

impl CacheInputs {
    fn of(setup: &ReceiverSetup<'_>, channels: usize) -> Self {
        let table = setup.table;
        let order = table.order();
        let nn = order * order;
        let log_k = table.log_k();
        let xs: Vec<f32> = (table.ks().iter())
            .map(|&k| if log_k { k.ln() as f32 } else { k as f32 })
            .collect();
        let mut mats = Vec::with_capacity(xs.len() * nn * nn);
        for m in table.matrices() {
            for row in m.to_dense() {
                mats.extend(row.iter().map(|&v| v as f32));
            }
        }
        let transfer: Vec<f32> = (setup.transfer[..channels].iter())
            .flat_map(|c| c.iter().map(|&v| v as f32))
            .collect();
        let q = DirectionSet::gauss_sphere_for_order(order);
        let quad: Vec<[f32; 4]> = (q.dirs.iter().zip(&q.weights))
            .map(|(d, &w)| [d[0] as f32, d[1] as f32, d[2] as f32, w as f32])
            .collect();
        let radius = |i: usize| setup.radii.map_or(setup.sampling.radius, |r| r[i]) as f32;
        let points: Vec<[f32; 4]> = (setup.receivers.iter().enumerate())
            .map(|(i, p)| [p.x as f32, p.y as f32, p.z as f32, radius(i)])
            .collect();
        let rows: Vec<GpuReceiver> = (setup.locations.iter())
            .map(|l| GpuReceiver {
                idx: l.map(|x| x.0),
                flag: 0,
                w: [l[0].1 as f32, l[1].1 as f32, l[2].1 as f32, 0.0],
                constant: [0.0; 4],
            })
            .collect();
        Self {
            xs,
            mats,
            transfer,
            quad,
            points,
            rows,
        }
    }
}

/// One pass of the cache-building pipeline over `n` receivers; its device time in seconds
/// (timestamps where available, else the synchronised wall clock).
fn run_setup_pass(
    ctx: &GpuContext,
    pipe: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    n: usize,
) -> Result<f64, GpuError> {
    let timer = crate::timing::StageTimer::new(ctx, 1);
    let t0 = std::time::Instant::now();
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&timer.pass("receiver setup", 0));
        let (x, y) = grid_64(n as u32);
        pass.set_pipeline(pipe);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
    timer.resolve(&mut enc);
    ctx.queue.submit([enc.finish()]);
    ctx.wait()?;
    let wall = t0.elapsed().as_secs_f64();
    Ok(timer.read(ctx)?.map_or(wall, |s| s[0]))
}

/// The receiver-setup pass kept for reuse: its pipeline, bind group and buffers, so a frame
/// whose receivers' k or sample locations change (per-direction radii resampled every frame)
/// rewrites the inputs ([`Self::write`]) and runs it again ([`Self::run`]) with no new buffer
/// or pipeline. The k-table's size is fixed at creation.
pub struct GpuReceiverBuilder {
    receivers: usize,
    channels: usize,
    k_count: usize,
    cp_buf: wgpu::Buffer,
    points_buf: wgpu::Buffer,
    xs_buf: wgpu::Buffer,
    mats_buf: wgpu::Buffer,
    rec_buf: wgpu::Buffer,
    u_buf: wgpu::Buffer,
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
}

impl GpuReceiverBuilder {
    /// Buffers, pipeline and bind group for `setup`'s receivers, table size and light, its
    /// inputs written (run it with [`Self::run`]).
    pub fn new(
        ctx: &GpuContext,
        setup: &ReceiverSetup<'_>,
        params: &GpuParams,
    ) -> Result<Self, GpuError> {
        let (order, n) = check_setup(setup, params)?;
        let nn = order * order;
        let t = setup.transfer;
        let channels = if t[0] == t[1] && t[1] == t[2] { 1 } else { 3 };
        ctx.check_binding("the receivers' U", 4 * (n * channels * nn) as u64)?;
        let inputs = CacheInputs::of(setup, channels);
        use wgpu::util::DeviceExt;
        let cp_buf = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("cache params"),
                contents: bytemuck::bytes_of(&cache_params(setup, &inputs, channels)),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
        let points_buf = ctx.storage_init("points", bytemuck::cast_slice(&inputs.points));
        let xs_buf = ctx.storage_init("xs", bytemuck::cast_slice(&inputs.xs));
        let mats_buf = ctx.storage_init("mats", bytemuck::cast_slice(&inputs.mats));
        let rec_buf = ctx.storage_init("receivers", bytemuck::cast_slice(&inputs.rows));
        let u_buf = ctx.storage("u", 4 * (n * channels * nn) as u64);
        let pipe = ctx.pipeline("build_cache", &cache_source(), "build_cache");
        let bind = ctx.bind(
            &pipe,
            &[
                &cp_buf,
                &points_buf,
                &xs_buf,
                &mats_buf,
                &ctx.storage_init("transfer", bytemuck::cast_slice(&inputs.transfer)),
                &ctx.storage_init("quad", bytemuck::cast_slice(&inputs.quad)),
                &ctx.storage_init(
                    "knorm",
                    bytemuck::cast_slice(&crate::sampling::knorm_table(order)),
                ),
                &rec_buf,
                &u_buf,
            ],
        );
        Ok(Self {
            receivers: n,
            channels,
            k_count: inputs.xs.len(),
            cp_buf,
            points_buf,
            xs_buf,
            mats_buf,
            rec_buf,
            u_buf,
            pipe,
            bind,
        })
    }

    /// Rewrite the inputs for `setup`: the same receivers (count), light and table size; new
    /// sampling sphere, table values, locations and radii (the caller runs the pass).
    pub fn write(
        &self,
        ctx: &GpuContext,
        setup: &ReceiverSetup<'_>,
        params: &GpuParams,
    ) -> Result<(), GpuError> {
        let (_, n) = check_setup(setup, params)?;
        if n != self.receivers || setup.table.ks().len() != self.k_count {
            return Err(GpuError::Input(format!(
                "{n} receivers and a table of {} k for a setup of {} and {}",
                setup.table.ks().len(),
                self.receivers,
                self.k_count
            )));
        }
        let inputs = CacheInputs::of(setup, self.channels);
        let cp = cache_params(setup, &inputs, self.channels);
        ctx.queue
            .write_buffer(&self.cp_buf, 0, bytemuck::bytes_of(&cp));
        ctx.queue
            .write_buffer(&self.points_buf, 0, bytemuck::cast_slice(&inputs.points));
        ctx.queue
            .write_buffer(&self.xs_buf, 0, bytemuck::cast_slice(&inputs.xs));
        ctx.queue
            .write_buffer(&self.mats_buf, 0, bytemuck::cast_slice(&inputs.mats));
        ctx.queue
            .write_buffer(&self.rec_buf, 0, bytemuck::cast_slice(&inputs.rows));
        Ok(())
    }

    /// Record the pass into `pass`.
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.receivers as u32);
        pass.set_pipeline(&self.pipe);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Run the pass now; its device time in seconds (timestamps where available, else the
    /// synchronised wall clock).
    pub fn run(&self, ctx: &GpuContext) -> Result<f64, GpuError> {
        run_setup_pass(ctx, &self.pipe, &self.bind, self.receivers)
    }

    /// The shading stage over this builder's cache, for coefficients in `coeffs_buf`.
    pub fn shader(
        &self,
        ctx: &GpuContext,
        params_buf: &wgpu::Buffer,
        params: &mut GpuParams,
        coeffs_buf: &wgpu::Buffer,
    ) -> GpuShader {
        GpuShader::from_buffers(
            ctx,
            self.rec_buf.clone(),
            self.u_buf.clone(),
            self.receivers,
            self.channels,
            params_buf,
            params,
            coeffs_buf,
        )
    }
}

/// The cache pass's uniform for `setup`.
fn cache_params(
    setup: &ReceiverSetup<'_>,
    inputs: &CacheInputs,
    channels: usize,
) -> GpuCacheParams {
    let order = setup.table.order();
    let c = setup.sampling.center;
    GpuCacheParams {
        center: [
            c.x as f32,
            c.y as f32,
            c.z as f32,
            setup.sampling.radius as f32,
        ],
        receivers: setup.receivers.len() as u32,
        order: order as u32,
        nn: (order * order) as u32,
        channels: channels as u32,
        k_count: inputs.xs.len() as u32,
        quad: inputs.quad.len() as u32,
        log_k: u32::from(setup.table.log_k()),
        pad: 0,
    }
}

impl GpuShader {
    /// Build the receiver cache on the GPU (k-table scaling and both rotations per receiver;
    /// see cache.wgsl) and set up shading from it. Returns the shader and the device time of the
    /// setup in seconds (timestamps where available, else the synchronised wall clock).
    pub(crate) fn build_on_gpu(
        ctx: &GpuContext,
        setup: &ReceiverSetup<'_>,
        params_buf: &wgpu::Buffer,
        params: &mut GpuParams,
        coeffs_buf: &wgpu::Buffer,
    ) -> Result<(Self, f64), GpuError> {
        let builder = GpuReceiverBuilder::new(ctx, setup, params)?;
        let seconds = builder.run(ctx)?;
        let shader = builder.shader(ctx, params_buf, params, coeffs_buf);
        Ok((shader, seconds))
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_buffers(
        ctx: &GpuContext,
        rec_buf: wgpu::Buffer,
        u_buf: wgpu::Buffer,
        receivers: usize,
        channels: usize,
        params_buf: &wgpu::Buffer,
        params: &mut GpuParams,
        coeffs_buf: &wgpu::Buffer,
    ) -> Self {
        params.receivers = receivers as u32;
        params.channels = channels as u32;
        ctx.queue
            .write_buffer(params_buf, 0, bytemuck::bytes_of(&*params));
        let image_buf = ctx.storage("image", 16 * receivers as u64);
        let pipe = ctx.pipeline("shade", &source(), "shade");
        let bind = ctx.bind(
            &pipe,
            &[params_buf, &rec_buf, &u_buf, coeffs_buf, &image_buf],
        );
        Self {
            receivers,
            channels,
            image_buf,
            pipe,
            bind,
            _cache: [rec_buf, u_buf],
        }
    }

    /// The receiver rows and `U` values as the GPU holds them (tests).
    pub fn read_cache(&self, ctx: &GpuContext) -> Result<(Vec<GpuReceiver>, Vec<f32>), GpuError> {
        Ok((
            bytemuck::cast_slice(&ctx.read_buffer(&self._cache[0])?).to_vec(),
            bytemuck::cast_slice(&ctx.read_buffer(&self._cache[1])?).to_vec(),
        ))
    }

    /// Upload `cache` for coefficients in `coeffs_buf` (samples × N², f32), with the shared
    /// parameter uniform (`receivers` and `channels` are written into it here).
    pub fn new(
        ctx: &GpuContext,
        cache: &ReceiverCache,
        params_buf: &wgpu::Buffer,
        params: &mut GpuParams,
        coeffs_buf: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        if cache.is_empty() {
            return Err(GpuError::Input("no receivers".into()));
        }
        let rows = receiver_rows(cache);
        let (_, _, u, _) = cache.rows();
        let nn = params.nn as usize;
        if u.len() != rows.len() * cache.channels() * nn {
            return Err(GpuError::Input(format!(
                "receiver cache of order² {} does not match the sampler's N² = {nn}",
                u.len() / (rows.len() * cache.channels())
            )));
        }
        let rec_buf = ctx.storage_init("receivers", bytemuck::cast_slice(&rows));
        let u_buf = ctx.storage_init("u", bytemuck::cast_slice(u));
        Ok(Self::from_buffers(
            ctx,
            rec_buf,
            u_buf,
            rows.len(),
            cache.channels(),
            params_buf,
            params,
            coeffs_buf,
        ))
    }

    /// Record the shading pass.
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        let (x, y) = grid_64(self.receivers as u32);
        pass.set_pipeline(&self.pipe);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Irradiance per receiver (RGB) of the last frame.
    pub fn read_image(&self, ctx: &GpuContext) -> Result<Vec<[f32; 3]>, GpuError> {
        ctx.read_image(&self.image_buf, self.receivers)
    }
}
