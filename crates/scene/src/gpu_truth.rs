//! The band-limited ray-traced reference (`ray_traced`) on the GPU path, so that every method of
//! the vocabulary but the full-frequency truth has a GPU form: every receiver casts both
//! hemispheres about the vertical — two samples of the sampling kernels at the receiver, one
//! facing up and one facing down, each taking the hemisphere behind it as unoccluded in closed
//! form — and one far sample that sees nothing supplies that closed form's sum, the whole
//! sphere (`√(4π) e₀`), to subtract: `V = V↑ + V↓ − V_far`, each receiver shaded from its three
//! weights `(1, 1, −1)` by the full field's kernel. The samples never move (the receivers are
//! fixed and the split need not face the entity), so a frame is the BVH update and three device
//! stages.
//!
//! The quadrature is not the CPU's: the CPU's truth casts `4T²` stratified rays over the sphere
//! (`T = truth_res`, `shscale_field::truth`), this one two Gauss hemispheres of `H × H` rays
//! with `H = round(√2 · T)` — about as many rays, placed otherwise; both estimate the same
//! band-limited projection, so they differ by the two quadratures' errors, of which the CPU
//! reports its own (`RenderOutput::error`).
//!
//! Domain: one mesh occluder, no local lights, at most [`MAX_GPU_TRUTH_RECEIVERS`] receivers
//! (the samples of one dispatch), and a frame's per-ray visibility within the adapter's storage
//! binding (checked by name).

use crate::error::Error;
use crate::gpu_field::GpuFieldFrame;
use crate::render::RenderOutput;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use shscale_gpu::field::{GpuFullField, WeightSlots};
use shscale_gpu::GpuContext;

/// The most receivers: two samples each and the far one within one dispatch's 65,535.
pub const MAX_GPU_TRUTH_RECEIVERS: usize = 32_767;

/// The Gauss hemisphere's `H` for the CPU truth's `T`: `round(√2 · T)`, so that two hemispheres
/// of `H²` rays are about the CPU's `4T²`.
pub fn gauss_res(truth_res: usize) -> usize {
    ((std::f64::consts::SQRT_2 * truth_res as f64).round() as usize).max(1)
}

/// Whether the GPU ray-traced reference takes `scene`, or why not.
pub fn check(scene: &Scene, rs: &RenderSettings) -> Result<(), Error> {
    crate::gpu_path::single_mesh(scene, rs.order)?;
    let why = if !scene.light_sources.is_empty() {
        Some("local lights are shaded on the CPU only".to_string())
    } else if scene.resolution[0] * scene.resolution[1] > MAX_GPU_TRUTH_RECEIVERS {
        Some(format!(
            "{}×{} receivers: the GPU reference takes at most {MAX_GPU_TRUTH_RECEIVERS} (two samples each in one dispatch)",
            scene.resolution[0], scene.resolution[1]
        ))
    } else {
        None
    };
    match why {
        Some(w) => Err(Error::config(format!(
            "{}: --gpu with ray_traced: {w}",
            scene.file
        ))),
        None => Ok(()),
    }
}

/// Receiver `i`'s two samples `2i` (facing up) and `2i + 1` (facing down) at the receiver, and
/// the last one far beyond every pose (`sphere` encloses them) facing away: the points and the
/// point each casts toward.
fn split_samples(recv: &[DVec3], sphere: shscale_geometry::Sphere) -> (Vec<DVec3>, Vec<DVec3>) {
    let far = sphere.center + 1e3 * sphere.radius.max(1.0) * DVec3::X;
    let mut points: Vec<DVec3> = recv.iter().flat_map(|&p| [p, p]).collect();
    let mut target: Vec<DVec3> = (recv.iter())
        .flat_map(|&p| [p + DVec3::Z, p - DVec3::Z])
        .collect();
    points.push(far);
    target.push(far + DVec3::X);
    (points, target)
}

/// Each of `n` receivers' weights over [`split_samples`]: `V = V↑ + V↓ − V_far`.
fn split_weights(n: usize) -> Vec<WeightSlots> {
    let one = 1.0f32.to_bits();
    (0..n as u32)
        .map(|i| {
            let mut w = [[0u32; 2]; 8];
            w[0] = [2 * i, one];
            w[1] = [2 * i + 1, one];
            w[2] = [2 * n as u32, (-1.0f32).to_bits()];
            w
        })
        .collect()
}

/// `frames` poses of `scene` ray traced on the GPU (module documentation); the last frame's
/// image and every frame's times. `each` sees every frame and its pixels after it is done.
pub fn render_sequence_ray_traced_gpu(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    each: &mut dyn FnMut(&GpuFieldFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuFieldFrame>), Error> {
    check(scene, rs)?;
    let frames = frames.max(1);
    let seq = crate::gpu_path::MeshSequence::of(scene, rs.order)?;
    let n = seq.recv.len();
    let h = gauss_res(rs.truth_res);
    let bytes = (2 * n + 1) as u64 * (h * h) as u64 * 4;
    let max = ctx.device.limits().max_storage_buffer_binding_size;
    if bytes > max {
        return Err(Error::config(format!(
            "{}: --gpu with ray_traced: {n} receivers × 2 hemispheres × {h}² rays (truth_res = {} → H = {h}) need {bytes} bytes of per-ray visibility, above the adapter's storage binding of {max}: lower truth_res or the receiver resolution",
            scene.file, rs.truth_res
        )));
    }
    let mut gpu = GpuFullField::new(
        ctx,
        &seq.rest,
        seq.strategy,
        (rs.order, h),
        2 * n + 1,
        n,
        &seq.transfer,
    )?;
    let s = crate::frame::sequence_sphere(&seq.rest, seq.occluder.deformer, frames);
    let (points, target) = split_samples(&seq.recv, s);
    gpu.place_samples(ctx, |i| target[i], &points)?;
    let slots = split_weights(n);
    let mut posed = seq.rest.clone();
    let (mut stats, mut pixels) = (Vec::with_capacity(frames), Vec::new());
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let deform_seconds = seq.pose(t, &mut posed);
        let (img, times) = gpu.frame(ctx, &posed, None, &slots)?;
        let st = GpuFieldFrame {
            frame: f,
            t,
            deform_seconds,
            weights_seconds: 0.0,
            gpu: times,
        };
        each(&st, &img);
        pixels = img;
        stats.push(st);
    }
    Ok((RenderOutput::plane(scene, pixels), stats))
}
