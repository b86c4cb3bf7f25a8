//! The papers' extrapolation from per-direction radii on the GPU path (`render --frames
//! --method extrapolated --gpu` with `radial = "clearance"`): per frame the mesh is posed, its
//! bounding sphere found and every base-sphere sample's radius placed by the CPU's own rule
//! ([`shscale_field::bsv::clearance_radius`]: distance queries on a BVH of the pose), the
//! k-table built over those radii and every receiver located and given its radius r(q) — as
//! the CPU render of the pose does — on the host; the samples' rays, their projection, the
//! receivers' `U` (k = d / r(q)) and the shading run on the GPU (`shscale_gpu::radial`). Every
//! frame is the CPU render of its pose within f32 rounding (tested on lavapipe).
//!
//! Scope: `radial = "clearance"` (the occlusion rule searches with rays: CPU only), one mesh
//! occluder, `N ≤ 8`, no local lights.

use crate::error::Error;
use crate::frame::table_for_radii;
use crate::render::RenderOutput;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::bsv::{clearance_radius, RadialRule};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{MeshBvh, Occluder, Sphere};
use shscale_gpu::radial::{GpuRadial, GpuRadialTimes};
use shscale_gpu::{GpuContext, ReceiverSetup};
use shscale_scaling::Eta;
use std::time::Instant;

/// Per-frame times of the GPU radial sequence, in seconds.
#[derive(Clone, Debug, Default)]
pub struct GpuRadialFrame {
    pub frame: usize,
    pub t: f64,
    /// Host: posing the mesh; the BVH for distance queries; the radii; the k-table; locating
    /// the receivers and their radii.
    pub deform_seconds: f64,
    pub radii_seconds: f64,
    pub table_seconds: f64,
    pub locate_seconds: f64,
    /// The GPU frame's own: BVH update and uploads on the host, the four device stages.
    pub gpu: GpuRadialTimes,
}

impl GpuRadialFrame {
    /// As a [`crate::sequence::SequenceFrame`] (the stages above by name).
    pub(crate) fn as_sequence_frame(&self) -> crate::sequence::SequenceFrame {
        crate::sequence::SequenceFrame::of_stages(
            self.frame,
            self.t,
            &[
                ("deform", self.deform_seconds),
                ("radii", self.radii_seconds),
                ("table_build", self.table_seconds),
                ("locate", self.locate_seconds),
                ("bvh_update", self.gpu.bvh_seconds),
                ("upload", self.gpu.upload_seconds),
                ("bsv_sampling", self.gpu.sampling_seconds),
                ("sh_conversion", self.gpu.projection_seconds),
                ("receiver_setup", self.gpu.setup_seconds),
                ("shading", self.gpu.shading_seconds),
            ],
        )
    }
}

/// Whether the GPU radial path takes `scene` (its method the extrapolation), or why not.
pub fn check(scene: &Scene, rs: &RenderSettings) -> Result<(), Error> {
    crate::gpu_path::check(scene, rs)?;
    if !matches!(rs.radial, RadialRule::Clearance { .. }) {
        return Err(Error::config(format!(
            "{}: --gpu with per-direction radii takes radial = \"clearance\" (the occlusion rule searches with rays, on the CPU)",
            scene.file
        )));
    }
    Ok(())
}

/// One frame's host inputs: the samples' points, the table, the receivers' locations and radii.
struct HostFrame {
    sphere: Sphere,
    points: Vec<DVec3>,
    table: shscale_scaling::KTable,
    locations: Vec<[(u32, f64); 3]>,
    radii: Vec<f64>,
}

/// The host's share of a frame for the posed `occ` (see the module's documentation; the radii
/// and the receivers in parallel), timing its stages into `st`.
fn host_frame(
    scene: &Scene,
    rs: &RenderSettings,
    occ: &dyn Occluder,
    recv: &[DVec3],
    st: &mut GpuRadialFrame,
) -> Result<HostFrame, Error> {
    let RadialRule::Clearance { delta } = rs.radial else {
        unreachable!("checked");
    };
    let t0 = Instant::now();
    let sphere = occ.bounding_sphere();
    let dirs = rs.layout.directions();
    let s = rs.sampling_radius;
    let ts: Vec<f64> = (dirs.par_iter())
        .map(|&d| clearance_radius(occ, (sphere.center, sphere.radius), d, s, delta))
        .collect();
    let points = (dirs.iter().zip(&ts))
        .map(|(d, t)| sphere.center + *t * *d)
        .collect();
    st.radii_seconds = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let sampling = Sphere {
        center: sphere.center,
        radius: s * sphere.radius,
    };
    let outer = ts.iter().copied().fold(sampling.radius, f64::max);
    let table = table_for_radii((scene, rs), sampling, outer, recv, Eta::Plain)?;
    st.table_seconds = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let mut bsv = crate::gpu_path::layout_only_bsv(rs.layout, sampling)?;
    bsv.sphere = sphere;
    bsv.radii = ts;
    let (locations, radii) = (recv.par_iter())
        .map(|p| {
            let d = *p - sphere.center;
            let q = if d.length() > 0.0 {
                d.normalize()
            } else {
                DVec3::Z
            };
            (bsv.locate(q), bsv.radius_at(q))
        })
        .unzip();
    st.locate_seconds = t0.elapsed().as_secs_f64();
    Ok(HostFrame {
        sphere: sampling,
        points,
        table,
        locations,
        radii,
    })
}

/// `frames` poses of `scene` rendered by the extrapolation from per-direction radii on the
/// GPU; the last frame's image and every frame's times. `each` sees every frame and its pixels
/// after it is done.
pub fn render_sequence_radial_gpu(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    each: &mut dyn FnMut(&GpuRadialFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuRadialFrame>), Error> {
    check(scene, rs)?;
    let frames = frames.max(1);
    let seq = crate::gpu_path::MeshSequence::of(scene, rs.order)?;
    let (rest, transfer, recv, strategy) = (&seq.rest, &seq.transfer, &seq.recv, seq.strategy);
    let mut posed = rest.clone();
    let mut gpu: Option<GpuRadial> = None;
    let mut stats = Vec::with_capacity(frames);
    let mut pixels = Vec::new();
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let mut st = GpuRadialFrame {
            frame: f,
            t,
            ..Default::default()
        };
        let t0 = Instant::now();
        seq.pose(t, &mut posed);
        let occ = MeshBvh::build(&posed, UpdateStrategy::Rebuild);
        st.deform_seconds = t0.elapsed().as_secs_f64();
        let h = host_frame(scene, rs, &occ, recv, &mut st)?;
        let setup = ReceiverSetup {
            table: &h.table,
            transfer,
            receivers: recv,
            locations: &h.locations,
            sampling: h.sphere,
            radii: Some(&h.radii),
        };
        if gpu.is_none() {
            let samples = h.points.len();
            let g = GpuRadial::new(ctx, rest, strategy, (rs.hemisphere_res, samples), &setup)?;
            gpu = Some(g);
        }
        let g = gpu.as_mut().expect("made above");
        let (img, times) = g.frame(ctx, &posed, (h.sphere.center, &h.points), &setup)?;
        st.gpu = times;
        each(&st, &img);
        pixels = img;
        stats.push(st);
    }
    Ok((RenderOutput::plane(scene, pixels), stats))
}
