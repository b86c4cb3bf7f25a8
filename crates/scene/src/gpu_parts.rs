//! Sub-volumes on the GPU path (`render --frames --method sub_volumes --gpu`): per frame the mesh
//! is posed and split into its parts (the partition made once on the rest pose, as the CPU render
//! makes it), and for every part — on the host, as the CPU render of the pose does — its bounding
//! sphere, sampling sphere, k-table over the receivers and every receiver's location in its
//! layout; the parts' rays, projections, extrapolations and their product near to far run on the
//! GPU (`shscale_gpu::parts`). Every frame is the CPU render of its pose within f32 rounding
//! (tested on lavapipe).
//!
//! Scope: one mesh occluder, at most [`MAX_GPU_PARTS`] parts, `radial = "uniform"`, no
//! plausibility clamp, `part_combine = "product"`, `N ≤ 8`, no local lights.

use crate::combine::Combine;
use crate::error::Error;
use crate::frame::table_for_radii;
use crate::render::RenderOutput;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::bsv::RadialRule;
use shscale_field::extrapolate::Plausibility;
use shscale_geometry::partition::{kmeans_parts, split};
use shscale_geometry::{Mesh, Sphere};
use shscale_gpu::parts::{GpuPartsTimes, GpuSubVolumes, PartFrame, MAX_GPU_PARTS};
use shscale_gpu::GpuContext;
use shscale_scaling::{Eta, KTable};
use std::time::Instant;

/// Per-frame times of the GPU sub-volumes sequence, in seconds.
#[derive(Clone, Debug, Default)]
pub struct GpuPartsFrame {
    pub frame: usize,
    pub t: f64,
    /// Host: posing and splitting the mesh; the parts' spheres, tables and the receivers'
    /// locations.
    pub deform_seconds: f64,
    pub tables_seconds: f64,
    /// The GPU frame's own: the BVH updates and uploads, the device's one submission.
    pub gpu: GpuPartsTimes,
}

impl GpuPartsFrame {
    /// As a [`crate::sequence::SequenceFrame`] (the stages above by name).
    pub(crate) fn as_sequence_frame(&self) -> crate::sequence::SequenceFrame {
        crate::sequence::SequenceFrame::of_stages(
            self.frame,
            self.t,
            &[
                ("deform", self.deform_seconds),
                ("tables", self.tables_seconds),
                ("bvh_update", self.gpu.bvh_seconds),
                ("upload", self.gpu.upload_seconds),
                ("device", self.gpu.device_seconds),
            ],
        )
    }
}

/// Whether the GPU sub-volumes path takes `scene`, or why not.
pub fn check(scene: &Scene, rs: &RenderSettings) -> Result<(), Error> {
    crate::gpu_path::check(scene, rs)?;
    let why = if rs.parts > MAX_GPU_PARTS {
        Some(format!(
            "{} parts: the GPU sub-volumes take at most {MAX_GPU_PARTS}",
            rs.parts
        ))
    } else if rs.radial != RadialRule::Uniform {
        Some("per-direction radii of parts are sampled on the CPU only".into())
    } else if rs.plausibility != Plausibility::None {
        Some("the plausibility clamp runs on the CPU only".into())
    } else if rs.part_combine != Combine::Product {
        Some("part_combine \"shexp\" has no GPU form".into())
    } else {
        None
    };
    match why {
        Some(w) => Err(Error::config(format!(
            "{}: --gpu with sub_volumes: {w}",
            scene.file
        ))),
        None => Ok(()),
    }
}

/// One part's host inputs for a frame.
struct HostPart {
    sampling: Sphere,
    points: Vec<DVec3>,
    table: KTable,
    locations: Vec<[(u32, f64); 3]>,
}

/// A part's sampling sphere, samples, table and the receivers' locations (the CPU render's).
fn host_part(
    scene: &Scene,
    rs: &RenderSettings,
    part: &Mesh,
    recv: &[DVec3],
) -> Result<HostPart, Error> {
    let sphere = part.bounding_sphere();
    let sampling = Sphere {
        center: sphere.center,
        radius: rs.sampling_radius * sphere.radius,
    };
    let points = (rs.layout.directions().iter())
        .map(|&d| sampling.center + sampling.radius * d)
        .collect();
    let table = table_for_radii((scene, rs), sampling, sampling.radius, recv, Eta::Plain)?;
    let bsv = crate::gpu_path::layout_only_bsv(rs.layout, sampling)?;
    let locations = (recv.par_iter())
        .map(|p| {
            let d = *p - sampling.center;
            bsv.locate(if d.length() > 0.0 {
                d.normalize()
            } else {
                DVec3::Z
            })
        })
        .collect();
    Ok(HostPart {
        sampling,
        points,
        table,
        locations,
    })
}

/// `frames` poses of `scene` rendered by sub-volumes on the GPU; the last frame's image and
/// every frame's times. `each` sees every frame and its pixels after it is done.
pub fn render_sequence_sub_volumes_gpu(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    each: &mut dyn FnMut(&GpuPartsFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuPartsFrame>), Error> {
    check(scene, rs)?;
    let frames = frames.max(1);
    let seq = crate::gpu_path::MeshSequence::of(scene, rs.order)?;
    let (rest, recv) = (&seq.rest, &seq.recv);
    let err = |e: shscale_geometry::GeometryError| Error::config(format!("{}: {e}", scene.file));
    let labels = kmeans_parts(rest, rs.parts).map_err(err)?;
    let gaunt = shscale_sh::GauntTensor::<f64>::new(rs.order)
        .map_err(|e| Error::config(format!("{}: {e}", scene.file)))?;
    let samples = rs.layout.directions().len();
    let mut gpu = GpuSubVolumes::new(
        ctx,
        &split(rest, &labels, rs.parts),
        (rs.hemisphere_res, samples, rs.k_count),
        recv,
        &seq.transfer,
        &gaunt,
    )?;
    let mut posed = rest.clone();
    let mut stats = Vec::with_capacity(frames);
    let mut pixels = Vec::new();
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let mut st = GpuPartsFrame {
            frame: f,
            t,
            ..Default::default()
        };
        let t0 = Instant::now();
        seq.pose(t, &mut posed);
        let parts = split(&posed, &labels, rs.parts);
        st.deform_seconds = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let host = (parts.iter())
            .map(|m| host_part(scene, rs, m, recv))
            .collect::<Result<Vec<_>, Error>>()?;
        st.tables_seconds = t0.elapsed().as_secs_f64();
        let inputs: Vec<PartFrame<'_>> = (parts.iter().zip(&host))
            .map(|(m, h)| PartFrame {
                mesh: m,
                sampling: h.sampling,
                points: &h.points,
                table: &h.table,
                locations: &h.locations,
            })
            .collect();
        let (img, times) = gpu.frame(ctx, &inputs)?;
        st.gpu = times;
        each(&st, &img);
        pixels = img;
        stats.push(st);
    }
    Ok((RenderOutput::plane(scene, pixels), stats))
}
