//! GPU receiver shading (Table 1 "shadowing"): the twin of `ReceiverCache::shade`, reading this
//! frame's BSV coefficients straight from the projection stage's buffer — nothing returns to the
//! host between stages. The cache (indices, weights, `U = R M_kᵀ Rᵀ T`) is uploaded once per
//! sequence; per frame only the coefficients change.

use crate::layout::{shader, GpuReceiver};
use crate::timing::grid_64;
use crate::{GpuContext, GpuError};
use shscale_field::receivers::ReceiverCache;

const SHADING_WGSL: &str = include_str!("shading.wgsl");

/// The shading shader.
pub fn source() -> String {
    shader(&[SHADING_WGSL])
}

/// Receiver rows of a cache in GPU layout.
pub fn receiver_rows(cache: &ReceiverCache) -> Vec<GpuReceiver> {
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
}

impl GpuShader {
    /// Upload `cache` for coefficients in `coeffs_buf` (samples × N², f32), with the shared
    /// parameter uniform (`receivers` and `channels` are written into it here).
    pub fn new(
        ctx: &GpuContext,
        cache: &ReceiverCache,
        params_buf: &wgpu::Buffer,
        params: &mut crate::layout::GpuParams,
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
        params.receivers = rows.len() as u32;
        params.channels = cache.channels() as u32;
        ctx.queue
            .write_buffer(params_buf, 0, bytemuck::bytes_of(&*params));
        let rec_buf = ctx.storage_init("receivers", bytemuck::cast_slice(&rows));
        let u_buf = ctx.storage_init("u", bytemuck::cast_slice(u));
        let image_buf = ctx.storage("image", 16 * rows.len() as u64);
        let pipe = ctx.pipeline("shade", &source(), "shade");
        let bind = ctx.bind(
            &pipe,
            &[params_buf, &rec_buf, &u_buf, coeffs_buf, &image_buf],
        );
        Ok(Self {
            receivers: rows.len(),
            channels: cache.channels(),
            image_buf,
            pipe,
            bind,
        })
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
        let v: Vec<[f32; 4]> = bytemuck::cast_slice(&ctx.read_buffer(&self.image_buf)?).to_vec();
        Ok(v[..self.receivers]
            .iter()
            .map(|p| [p[0], p[1], p[2]])
            .collect())
    }
}
