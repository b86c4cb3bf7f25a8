//! The papers' full field on the GPU path (`render --frames --method full_field --gpu`): per
//! frame the mesh is posed on the host, its bounding sphere found, and the field's shells about
//! it — the CPU render's own construction ([`crate::render::full_field_shells`] or the scene's
//! `full_field`) — sampled, projected and shaded on the GPU (`shscale_gpu::field`); each
//! receiver's interpolation weights are computed on the host from a template field moved to the
//! frame's sphere (`FullField::recentre`, the CPU's `FullField::weights`). Every frame is the CPU
//! render of its pose within f32 rounding and the rays that graze an edge (tested on lavapipe).
//!
//! Scope: one mesh occluder (the analytic sphere has no triangles), `N ≤ 8`, no local lights;
//! anything else is refused by name.

use crate::error::Error;
use crate::render::{full_field_shells, RenderOutput};
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use shscale_field::evaluator::FullField;
use shscale_gpu::field::{GpuFieldTimes, GpuFullField, WeightSlots, BEYOND};
use shscale_gpu::GpuContext;
use std::time::Instant;

/// Per-frame times of the GPU full-field sequence, in seconds.
#[derive(Clone, Debug, Default)]
pub struct GpuFieldFrame {
    pub frame: usize,
    pub t: f64,
    /// Host: posing the mesh and finding its bounding sphere.
    pub deform_seconds: f64,
    /// Host: every receiver's interpolation weights about this frame's sphere.
    pub weights_seconds: f64,
    /// The GPU frame's own: BVH update and uploads on the host, the three device stages.
    pub gpu: GpuFieldTimes,
}

impl GpuFieldFrame {
    /// As a [`crate::sequence::SequenceFrame`] (the stages above by name), the form every
    /// sequence's frames are printed and benchmarked in.
    pub(crate) fn as_sequence_frame(&self) -> crate::sequence::SequenceFrame {
        crate::sequence::SequenceFrame::of_stages(
            self.frame,
            self.t,
            &[
                ("deform", self.deform_seconds),
                ("field_weights", self.weights_seconds),
                ("bvh_update", self.gpu.bvh_seconds),
                ("upload", self.gpu.upload_seconds),
                ("bsv_sampling", self.gpu.sampling_seconds),
                ("sh_conversion", self.gpu.projection_seconds),
                ("shading", self.gpu.shading_seconds),
            ],
        )
    }
}

/// Whether the GPU full-field path takes `scene`, or why not.
pub fn check(scene: &Scene, rs: &RenderSettings) -> Result<(), Error> {
    crate::gpu_path::single_mesh(scene, rs.order)?;
    if !scene.light_sources.is_empty() {
        return Err(Error::config(format!(
            "{}: --gpu with full_field: local lights are shaded on the CPU only",
            scene.file
        )));
    }
    Ok(())
}

/// The receivers' weight slots about the field's current sphere.
fn weight_slots(field: &FullField, recv: &[DVec3], out: &mut Vec<WeightSlots>) {
    out.clear();
    out.extend(recv.iter().map(|p| {
        let mut slots = [[0u32; 2]; 8];
        match field.weights(*p) {
            None => slots[0] = BEYOND,
            Some((w, n)) => {
                for (slot, (i, wi)) in slots.iter_mut().zip(&w[..n]) {
                    *slot = [*i, (*wi as f32).to_bits()];
                }
            }
        }
        slots
    }));
}

/// `frames` poses of `scene` rendered with the full field on the GPU; the last frame's image
/// and every frame's times. `each` sees every frame and its pixels after it is done.
pub fn render_sequence_full_field_gpu(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    each: &mut dyn FnMut(&GpuFieldFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuFieldFrame>), Error> {
    check(scene, rs)?;
    let frames = frames.max(1);
    let seq = crate::gpu_path::MeshSequence::of(scene, rs.order)?;
    let rest = &seq.rest;
    let shells = rs.full_field.unwrap_or_else(|| full_field_shells(rs));
    let err = |e: shscale_field::FieldError| Error::config(format!("{}: {e}", scene.file));
    let dirs = rs.layout.directions();
    let radii = shells.radii();
    let nn = rs.order * rs.order;
    let zeros = vec![vec![vec![0.0; nn]; dirs.len()]; radii.len()];
    let mut template = FullField::from_samples(
        rest.bounding_sphere(),
        rs.layout,
        &shells,
        zeros,
        rs.order,
        0,
    )
    .map_err(err)?;
    let recv = &seq.recv;
    let mut gpu = GpuFullField::new(
        ctx,
        rest,
        seq.strategy,
        (rs.order, rs.hemisphere_res),
        radii.len() * dirs.len(),
        recv.len(),
        &seq.transfer,
    )?;
    let mut posed = rest.clone();
    let (mut points, mut slots) = (Vec::new(), Vec::new());
    let mut stats = Vec::with_capacity(frames);
    let mut pixels = Vec::new();
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let mut st = GpuFieldFrame {
            frame: f,
            t,
            ..Default::default()
        };
        let t0 = Instant::now();
        seq.pose(t, &mut posed);
        let sphere = posed.bounding_sphere();
        st.deform_seconds = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        // The CPU's FullField::build: shell-major, `centre + ρ·R·u`.
        points.clear();
        for rho in &radii {
            let r = rho * sphere.radius;
            points.extend(dirs.iter().map(|&u| sphere.center + r * u));
        }
        template.recentre(sphere);
        weight_slots(&template, recv, &mut slots);
        st.weights_seconds = t0.elapsed().as_secs_f64();
        let (img, times) = gpu.frame(ctx, &posed, Some((sphere.center, &points)), &slots)?;
        st.gpu = times;
        each(&st, &img);
        pixels = img;
        stats.push(st);
    }
    Ok((RenderOutput::plane(scene, pixels), stats))
}
