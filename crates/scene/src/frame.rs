//! One frame's set-up, shared by the CPU ([`crate::render`]) and GPU ([`crate::gpu_path`])
//! paths: the occluders built from their specs, the light (sky or map) projected to SH, the local
//! lights' emitters, the receiver grid, the cone k-table covering every receiver, and the posed
//! mesh of a deformer at time t with the sampling sphere fixed for a whole sequence.

use crate::error::Error;
use crate::scene::{LightSpec, Scene};
use crate::settings::RenderSettings;
use glam::DVec3;
use shscale_field::shading::EnvLight;
use shscale_field::Emitter;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{deform, shapes, Mesh, MeshBvh, Occluder, Sphere};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};

/// The mesh of an occluder at the deformers' time `pose_t` ([`Scene::pose_t`]): placed, and
/// posed by its deformer ([`pose_mesh`]) when a time is given; `None` for the analytic sphere.
pub fn occluder_mesh_at(
    o: &crate::scene::OccluderSpec,
    pose_t: Option<f64>,
) -> Result<Option<Mesh>, Error> {
    if o.mesh == "sphere" {
        return Ok(None);
    }
    let rest = o.placed()?;
    Ok(Some(match (pose_t, o.deformer) {
        (Some(_), Some(_)) => posed(&rest, o, pose_t),
        _ => rest,
    }))
}

/// The inscribed fit's seconds for the scene's mesh occluders at their pose at
/// [`Scene::pose_t`], in the runner's reference seconds (`shscale_geometry::inscribed::
/// inscribed_fit_seconds` of each one's work, cells × triangles); with `check`, each mesh is
/// first checked by `inscribable`, before any render: a mesh with no inside (an open fan, a
/// flat sheet), or one above the fit's bound, is refused naming `sphere_fit`, the occluder's
/// mesh and the scene. A deforming sequence's later poses are checked by their own fit (an error
/// of the same words, never an empty set).
pub fn inscribed_seconds(scene: &Scene, check: bool) -> Result<f64, Error> {
    use shscale_geometry::inscribed;
    let mut seconds = 0.0;
    for o in &scene.occluders {
        if let Some(m) = occluder_mesh_at(o, scene.pose_t)? {
            let work = if check {
                inscribed::inscribable(&m)
            } else {
                inscribed::inscribed_work(&m)
            };
            let work = work.map_err(|e| {
                Error::config(format!(
                    "{}: sphere_fit = \"inscribed\" on mesh \"{}\": {e}",
                    scene.file, o.mesh
                ))
            })?;
            seconds += inscribed::inscribed_fit_seconds(work);
        }
    }
    Ok(seconds)
}

/// `rest` (an occluder's placed mesh, [`crate::scene::OccluderSpec::placed`]) posed by the
/// occluder's deformer at `pose_t`; a copy of `rest` without a deformer or time. A turned
/// occluder deforms in its own frame and is turned after: the turn is undone about the rest's
/// bounding sphere's centre, the deformer applied, the turn redone (the deformers act in world
/// axes, so a bird turned on its side still flaps its wings).
pub fn posed(rest: &Mesh, o: &crate::scene::OccluderSpec, pose_t: Option<f64>) -> Mesh {
    let mut out = rest.clone();
    let (Some(t), Some((kind, amount))) = (pose_t, o.deformer) else {
        return out;
    };
    let Some(q) = o.turn else {
        pose_mesh(rest, kind, amount, t, &mut out);
        return out;
    };
    let c = rest.bounding_sphere().center;
    let mut own = rest.clone();
    own.rotate_about(c, q.inverse());
    pose_mesh(&own, kind, amount, t, &mut out);
    out.rotate_about(c, q);
    out
}

/// An occluder of a scene at the deformers' time `pose_t` ([`occluder_mesh_at`]), bounded by the
/// posed mesh's own minimal sphere (a frame rendered on its own, not as part of a sequence).
pub fn build_occluder_at(
    o: &crate::scene::OccluderSpec,
    pose_t: Option<f64>,
) -> Result<Box<dyn Occluder>, Error> {
    match occluder_mesh_at(o, pose_t)? {
        Some(m) => Ok(Box::new(MeshBvh::build(&m, UpdateStrategy::Rebuild))),
        None => o.build(),
    }
}

/// What the full-frequency truth of `scene` lights with ([`EnvLight::truth_light`]) at SH
/// order `order`.
pub fn truth_light(scene: &Scene, order: usize) -> Result<&'static str, Error> {
    Ok(light_of(scene, order)?.truth_light())
}

/// The scene's light projected to SH order `order`.
pub(crate) fn light_of(scene: &Scene, order: usize) -> Result<EnvLight, Error> {
    Ok(match &scene.light {
        LightSpec::Sky {
            ambient,
            zenith,
            sun,
            sun_dir,
            sun_radius,
        } => EnvLight::sky(
            order,
            *ambient,
            *zenith,
            DVec3::Z,
            *sun,
            *sun_dir,
            *sun_radius,
        )?,
        LightSpec::Exr { path, intensity } => {
            // Finite, ≥ 0 (ringing clamped) and within the image bounds: read_radiance_exr.
            let (w, h, px) = shscale_present::image::read_radiance_exr(path)?;
            let max = px.iter().flatten().fold(0f32, |a, v| a.max(*v)) as f64;
            if max * *intensity > crate::scene::MAX_RADIANCE {
                return Err(Error::config(format!(
                    "light.intensity: {} × the map's largest value {max:e} ({}) exceeds {:e}",
                    shscale_runner::check::num(*intensity),
                    path.display(),
                    crate::scene::MAX_RADIANCE
                )));
            }
            let px: Vec<[f32; 3]> = px
                .into_iter()
                .map(|p| p.map(|v| v * *intensity as f32))
                .collect();
            EnvLight::from_latlong(order, w, h, &px)?
        }
    })
}

/// The receiver plane's points (normal +z), row-major, row 0 at +y.
pub fn receiver_grid(scene: &Scene) -> Vec<DVec3> {
    let [w, h] = scene.resolution;
    let [sx, sy] = scene.receiver_size;
    let c = scene.receiver_center;
    (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            DVec3::new(
                c.x + sx * (i as f64 / (w - 1) as f64 - 0.5),
                c.y + sy * (0.5 - j as f64 / (h - 1) as f64),
                c.z,
            )
        })
        .collect()
}

/// The cone k-table (α, order and entries of `rs`) covering every receiver's
/// `k = |p − c| / r_s` for a sampling sphere; errors name `scene`'s file.
pub(crate) fn table_for(
    (scene, rs): (&Scene, &RenderSettings),
    sampling: Sphere,
    recv: &[DVec3],
    eta: Eta,
) -> Result<KTable, Error> {
    table_for_radii((scene, rs), sampling, sampling.radius, recv, eta)
}

/// [`table_for`] for samples at radii between `sampling.radius` and `outer` (a
/// [`shscale_field::bsv::RadialRule`]): `k = d / r(q)` spans `d_min / outer … d_max / r`.
pub(crate) fn table_for_radii(
    (scene, rs): (&Scene, &RenderSettings),
    sampling: Sphere,
    outer: f64,
    recv: &[DVec3],
    eta: Eta,
) -> Result<KTable, Error> {
    let (lo, hi) = recv
        .iter()
        .map(|p| (*p - sampling.center).length())
        .fold((f64::MAX, f64::MIN), |(a, z), d| {
            (a.min(d / outer), z.max(d / sampling.radius))
        });
    let (lo, hi) = (lo.max(1e-3), hi.max(lo.max(1e-3) * 1.01));
    KTable::build(
        TauFamily::Cone { alpha: rs.alpha },
        eta,
        rs.order,
        rs.k_count,
        lo,
        hi,
        Spacing::Exp,
        Interp::Linear,
    )
    .map_err(|e| Error::config(format!("{}: k-table: {e}", scene.file)))
}

/// A local light: one emitter per non-black channel (radiance per triangle) and its bounds.
pub struct LightSource {
    pub channels: [Option<Emitter>; 3],
    pub sphere: Sphere,
    pub energy: bool,
}

/// Build the scene's local lights, emitting toward −z from their centres.
pub(crate) fn build_emitters(scene: &Scene) -> Result<Vec<LightSource>, Error> {
    let mut out = Vec::new();
    for l in &scene.light_sources {
        let (mut mesh, rgb) = if l.hinge {
            shscale_field::srf::hinged_light(l.size, l.hinge_angle)
        } else {
            // Normal −z: the square emits downward.
            (shapes::quad(l.size, false), vec![[1.0; 3]; 2])
        };
        if l.hinge {
            // The hinge opens toward +z: turn it 180° about x so it emits downward.
            for p in &mut mesh.positions {
                *p = DVec3::new(p.x, -p.y, -p.z);
            }
        }
        let centre = mesh.bounding_sphere().center;
        for p in &mut mesh.positions {
            *p += l.center - centre;
        }
        let mut channels: [Option<Emitter>; 3] = [None, None, None];
        for (c, slot) in channels.iter_mut().enumerate() {
            let rad: Vec<f64> = rgb.iter().map(|t| t[c] * l.radiance[c]).collect();
            if rad.iter().all(|r| *r == 0.0) {
                continue; // compute only what the scene requires
            }
            *slot = Some(Emitter::new(
                &mesh,
                MeshBvh::build(&mesh, UpdateStrategy::Rebuild),
                rad,
            )?);
        }
        out.push(LightSource {
            channels,
            sphere: mesh.bounding_sphere(),
            energy: l.energy,
        });
    }
    Ok(out)
}

/// A deformer with what it derives from the rest pose computed once (its bounding radius, the
/// morph's target sphere), so that posing a frame is only the per-vertex map (in parallel,
/// `shscale_geometry::deform`).
pub struct Poser {
    deformer: deform::Deformer,
}

impl Poser {
    pub fn new(rest: &Mesh, kind: deform::DeformerKind, amount: f64) -> Self {
        let s = rest.bounding_sphere();
        let deformer = match kind {
            deform::DeformerKind::Flap => deform::Deformer::Flap {
                y0: 0.3 * s.radius / 2.3,
                amplitude: amount,
            },
            deform::DeformerKind::Bend => deform::Deformer::Bend {
                max_curvature: amount / s.radius,
            },
            deform::DeformerKind::Twist => deform::Deformer::Twist {
                max_turns: amount,
                h: deform::twist_height(rest),
            },
            deform::DeformerKind::Morph => {
                // The morph's target: a sphere fitted to the rest pose's bounding sphere.
                let mut target = shapes::uv_sphere(1.0, 22, 24);
                target.fit_to(&s);
                deform::Deformer::Morph { target }
            }
        };
        Poser { deformer }
    }

    /// Pose `rest` (the mesh this was made for) at time `t ∈ [0, 1)` into `out`.
    pub fn pose(&self, rest: &Mesh, t: f64, out: &mut Mesh) {
        self.deformer.apply(rest, t, out)
    }

    /// The deformer with its parameters (for posing on a device).
    pub fn deformer(&self) -> &deform::Deformer {
        &self.deformer
    }
}

/// Pose `rest` at time `t ∈ [0, 1)` of its deformer (strength `amount`) into `out` (a
/// [`Poser`] made and used once; sequences keep theirs).
pub fn pose_mesh(rest: &Mesh, kind: deform::DeformerKind, amount: f64, t: f64, out: &mut Mesh) {
    Poser::new(rest, kind, amount).pose(rest, t, out)
}

/// The minimal sphere enclosing every pose `t = f/frames` of a sequence (the rest pose alone
/// without a deformer): a sampling sphere fixed for the whole sequence keeps per-receiver caches
/// valid.
pub(crate) fn sequence_sphere(
    rest: &Mesh,
    deformer: Option<(deform::DeformerKind, f64)>,
    frames: usize,
) -> Sphere {
    let mut all = rest.positions.clone();
    if let Some((kind, amount)) = deformer {
        let mut p = rest.clone();
        let poser = Poser::new(rest, kind, amount);
        for f in 0..frames {
            poser.pose(rest, f as f64 / frames as f64, &mut p);
            all.extend_from_slice(&p.positions);
        }
    }
    shscale_geometry::min_enclosing_sphere(&all)
}
