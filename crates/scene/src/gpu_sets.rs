//! Sphere sets on the GPU path (`render --frames --method sphere_set --gpu`): per frame the
//! mesh is posed and one sphere fitted per part on the host (the partition made once, on the
//! rest pose, as the CPU render makes it) — or the pose's inscribed balls
//! (`sphere_fit = "inscribed"`, a one-off fit per pose) —, then every receiver is shaded on the GPU from the
//! spheres' closed-form caps multiplied near to far, combined as their exact union
//! (`sphere_combine = "union"`) or by SH exponentiation (`"shexp"`, the HYB exponential;
//! `shscale_gpu::sphereset`). With [`SetPose::Device`]
//! (`--device-pose`) the meshes are posed and the area fit's spheres fitted on the device
//! (`shscale_gpu::fit`), and a frame uploads each mesh's 32-byte pose. The image of a frame is
//! the CPU render's of the same pose within f32 rounding either way (tested on lavapipe); it is
//! read back after the frame's stages, not as one of them.
//!
//! Scope: the plain chain (`sphere_order` at most the scene's order), SH exponentiation and the union
//! ([`crate::method::UNION_RINGS`] rings), `N ≤ 8`, at most [`MAX_GPU_SPHERES`] spheres over
//! all occluders, no local lights; anything else is refused by name.

use crate::error::Error;
use crate::frame::{light_of, receiver_grid, Poser};
use crate::render::RenderOutput;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use shscale_field::shading::Shader;
use shscale_field::union::RingGrid;
use shscale_geometry::{Mesh, Sphere};
use shscale_gpu::sphereset::{GpuSphereSet, MAX_GPU_SPHERES};
use shscale_gpu::GpuContext;
use std::time::Instant;

/// Per-frame times of the GPU sphere-set sequence.
#[derive(Clone, Debug, Default)]
pub struct GpuSetFrame {
    pub frame: usize,
    pub t: f64,
    /// Posing the meshes, fitting the spheres: host seconds, or device seconds where the frame
    /// was posed on the device ([`SetPose::Device`]).
    pub deform_seconds: f64,
    pub sphere_fit_seconds: f64,
    /// Host: writing the spheres (or, posed on the device, the poses), submitting and waiting,
    /// beyond the device stages.
    pub upload_seconds: f64,
    /// Device: the shading kernel (timestamps where available).
    pub shading_seconds: f64,
    /// Host: the image read back for the caller, after the frame (not one of its stages: a
    /// real-time renderer keeps the image on the device, as the papers' GPU sequence does).
    pub readback_seconds: f64,
}

impl GpuSetFrame {
    /// As a [`crate::sequence::SequenceFrame`] (stages `deform`, `sphere_fit`, `upload`,
    /// `shading`; the read-back is not a stage), the form every sequence's frames are printed
    /// and benchmarked in.
    pub(crate) fn as_sequence_frame(&self) -> crate::sequence::SequenceFrame {
        crate::sequence::SequenceFrame::of_stages(
            self.frame,
            self.t,
            &[
                ("deform", self.deform_seconds),
                ("sphere_fit", self.sphere_fit_seconds),
                ("upload", self.upload_seconds),
                ("shading", self.shading_seconds),
            ],
        )
    }
}

/// One occluder as the sequence needs it: the rest pose, its poser, the part of each triangle;
/// or the analytic sphere (its own set, fixed).
enum SetOccluder {
    Mesh(Box<PosedParts>),
    Sphere(Sphere),
}

/// A mesh occluder of the set: rest pose, current pose, deformer, part of each triangle.
struct PosedParts {
    rest: Mesh,
    posed: Mesh,
    poser: Option<Poser>,
    labels: Vec<u32>,
}

/// Whether the GPU sphere-set path takes `scene`, or why not.
pub fn check(scene: &Scene, rs: &RenderSettings) -> Result<(), Error> {
    use crate::combine::Combine;
    let why = if !matches!(
        rs.sphere_combine,
        Combine::Product | Combine::Union | Combine::Shexp
    ) {
        Some(format!(
            "sphere_combine \"{}\" has no GPU form; the GPU sphere set is the plain chain, the union or SH exponentiation",
            rs.sphere_combine.name()
        ))
    } else if rs.sphere_combine == Combine::Product && rs.sphere_order > rs.order {
        Some(format!(
            "sphere_order {} multiplies above the scene's order; the GPU sphere set is the plain chain",
            rs.sphere_order
        ))
    } else if !scene.light_sources.is_empty() {
        Some("local lights are shaded on the CPU only".to_string())
    } else if scene.occluders.len() * rs.parts > MAX_GPU_SPHERES {
        Some(format!(
            "{} occluders × {} parts: the GPU sphere set takes at most {MAX_GPU_SPHERES} spheres",
            scene.occluders.len(),
            rs.parts
        ))
    } else {
        None
    };
    match why {
        Some(w) => Err(Error::config(format!(
            "{}: --gpu with sphere_set: {w}",
            scene.file
        ))),
        None => shscale_gpu::sampling::check_gpu_order(rs.order).map_err(Error::from),
    }
}

/// Every occluder of `scene` as the sequence needs it: meshes placed, partitioned once on the
/// rest pose (as the CPU render partitions them), with their posers.
fn set_occluders(scene: &Scene, rs: &RenderSettings) -> Result<Vec<SetOccluder>, Error> {
    let mut occs = Vec::new();
    for o in &scene.occluders {
        if o.mesh == "sphere" {
            let b = o.build()?;
            occs.push(SetOccluder::Sphere(b.bounding_sphere()));
            continue;
        }
        let rest = o.placed()?;
        let labels = shscale_geometry::partition::kmeans_parts(&rest, rs.parts)
            .map_err(|e| Error::config(format!("{}: {e}", scene.file)))?;
        occs.push(SetOccluder::Mesh(Box::new(PosedParts {
            poser: (o.deformer).map(|(k, a)| Poser::new(&rest, k, a)),
            posed: rest.clone(),
            rest,
            labels,
        })));
    }
    Ok(occs)
}

/// Where a sphere-set sequence poses its meshes and fits their spheres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetPose {
    /// On the host (all cores), the spheres uploaded every frame.
    Host,
    /// On the device (`shscale_gpu::fit`): the frame uploads each mesh's 32-byte pose; the area
    /// fit only (`sphere_fit = "area"`).
    Device,
}

/// `frames` poses of `scene` shaded on the GPU from their sphere sets, posed and fitted on the
/// host; the last frame's image and every frame's times. `each` sees every frame and its pixels
/// after it is done (read back after the frame's stages, not one of them).
pub fn render_sequence_sphere_set_gpu(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    each: &mut dyn FnMut(&GpuSetFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuSetFrame>), Error> {
    render_sequence_sphere_set_gpu_posed(scene, rs, frames, ctx, SetPose::Host, each)
}

/// [`render_sequence_sphere_set_gpu`] with the pose and fit where `pose` says; `Device` refuses
/// the inscribed fit by name (a one-off fit per pose, on the host).
pub fn render_sequence_sphere_set_gpu_posed(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    pose: SetPose,
    each: &mut dyn FnMut(&GpuSetFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuSetFrame>), Error> {
    check(scene, rs)?;
    if pose == SetPose::Device && rs.sphere_fit != crate::combine::SphereFit::Area {
        return Err(Error::config(format!(
            "{}: --device-pose with sphere_set: sphere_fit \"{}\" is fitted on the host (a one-off fit per pose); the device fits \"area\" spheres",
            scene.file,
            rs.sphere_fit.name()
        )));
    }
    let frames = frames.max(1);
    let mut occs = set_occluders(scene, rs)?;
    let light = light_of(scene, rs.order)?;
    let shader = Shader::new(rs.order)?;
    let transfer = shader.transfer(&light, glam::DVec3::Z);
    let recv = receiver_grid(scene);
    let gpu = gpu_set(scene, rs, ctx, &recv, &transfer)?;
    if pose == SetPose::Device {
        return device_frames(scene, rs, frames, ctx, (&gpu, &occs), each);
    }
    let mut stats = Vec::with_capacity(frames);
    let mut pixels = Vec::new();
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let mut st = GpuSetFrame {
            frame: f,
            t,
            ..Default::default()
        };
        let mut spheres = Vec::new();
        for o in occs.iter_mut() {
            match o {
                SetOccluder::Sphere(s) => spheres.push(*s),
                SetOccluder::Mesh(m) => {
                    let t0 = Instant::now();
                    if let Some(p) = &m.poser {
                        p.pose(&m.rest, t, &mut m.posed);
                    }
                    st.deform_seconds += t0.elapsed().as_secs_f64();
                    let t0 = Instant::now();
                    // The scene's fit: the parts' spheres every frame, or each pose's
                    // inscribed balls (a one-off fit per pose, kept for the poses seen last).
                    spheres.extend(
                        (rs.sphere_fit.spheres(&m.posed, &m.labels, rs.parts)).map_err(|e| {
                            Error::config(format!("{}: sphere_fit: {e}", scene.file))
                        })?,
                    );
                    st.sphere_fit_seconds += t0.elapsed().as_secs_f64();
                }
            }
        }
        let t0 = Instant::now();
        let (img, device, wall) = gpu.frame(ctx, &spheres)?;
        st.shading_seconds = device;
        st.upload_seconds = (wall - device).max(0.0);
        st.readback_seconds = (t0.elapsed().as_secs_f64() - wall).max(0.0);
        each(&st, &img);
        pixels = img;
        stats.push(st);
    }
    Ok((RenderOutput::plane(scene, pixels), stats))
}

/// The GPU sphere set of `scene`'s combination for receivers `recv` and the light's `transfer`.
fn gpu_set(
    scene: &Scene,
    rs: &RenderSettings,
    ctx: &GpuContext,
    recv: &[glam::DVec3],
    transfer: &[Vec<f64>; 3],
) -> Result<GpuSphereSet, Error> {
    let err = |e: shscale_sh::ShError| Error::config(format!("{}: {e}", scene.file));
    let set = match rs.sphere_combine {
        crate::combine::Combine::Union => {
            let basis = shscale_sh::ShBasis::<f64>::new(rs.order).map_err(err)?;
            let grid = RingGrid::new(&basis, crate::method::UNION_RINGS);
            GpuSphereSet::union(ctx, recv, transfer, &grid)?
        }
        crate::combine::Combine::Shexp => {
            // The CPU render's table (`SHEXP_EPS`) and exponential (HYB).
            use shscale_field::shexp_ol::{ZonalLogTable, SHEXP_EPS};
            let gaunt = shscale_sh::GauntTensor::<f64>::new(rs.order).map_err(err)?;
            let table = ZonalLogTable::new(&gaunt, SHEXP_EPS);
            GpuSphereSet::shexp(ctx, recv, transfer, &gaunt, &table)?
        }
        _ => {
            let gaunt = shscale_sh::GauntTensor::<f64>::new(rs.order).map_err(err)?;
            GpuSphereSet::new(ctx, recv, transfer, &gaunt)?
        }
    };
    Ok(set)
}

/// The frames of [`render_sequence_sphere_set_gpu_posed`] posed and fitted on the device: each
/// mesh occluder's parts fitted into its slots, the analytic spheres after them; per frame the
/// host writes the poses (`upload`), the device deforms, fits and shades (three timed stages),
/// and the image is read back after them.
fn device_frames(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    ctx: &GpuContext,
    (gpu, occs): (&GpuSphereSet, &[SetOccluder]),
    each: &mut dyn FnMut(&GpuSetFrame, &[[f32; 3]]),
) -> Result<(RenderOutput, Vec<GpuSetFrame>), Error> {
    let mut fits = Vec::new();
    let mut fixed = Vec::new();
    for o in occs {
        match o {
            SetOccluder::Sphere(s) => fixed.push(*s),
            SetOccluder::Mesh(m) => {
                let slot = fits.len() * rs.parts;
                fits.push(shscale_gpu::fit::GpuSphereFit::new(
                    ctx,
                    &m.rest,
                    m.poser.as_ref().map(Poser::deformer),
                    (&m.labels, rs.parts),
                    (gpu.spheres_buffer(), slot),
                )?);
            }
        }
    }
    let mut stats = Vec::with_capacity(frames);
    let mut pixels = Vec::new();
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let t0 = Instant::now();
        let [deform, fit, shading] = gpu.frame_on_device(ctx, &mut fits, &fixed, t)?;
        let wall = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let img = gpu.read_image(ctx)?;
        let st = GpuSetFrame {
            frame: f,
            t,
            deform_seconds: deform,
            sphere_fit_seconds: fit,
            shading_seconds: shading,
            upload_seconds: (wall - deform - fit - shading).max(0.0),
            readback_seconds: t1.elapsed().as_secs_f64(),
        };
        each(&st, &img);
        pixels = img;
        stats.push(st);
    }
    Ok((RenderOutput::plane(scene, pixels), stats))
}
