//! Rendering a deforming sequence: every frame's pose, each entity (occluder or light) rebuilt
//! as its method requires, the frames' statistics.

use super::*;

/// Timings of one frame of a sequence.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    pub frame: usize,
    pub t: f64,
    pub deform_seconds: f64,
    pub bvh_update_seconds: f64,
    pub bsv_sampling_seconds: f64,
    pub shading_seconds: f64,
    /// Occluders whose BSV was resampled / reused because their shape did not change.
    pub resampled: usize,
    pub reused: usize,
}

/// Render `frames ≥ 1` frames of a deforming scene with the extrapolated method and the
/// parameters of `rs` (t = f/frames).
///
/// What is computed only when needed: the sampling sphere of each occluder is fixed for the
/// sequence (the minimal sphere enclosing all of its poses, found once up front), so the k-table
/// and — for a single occluder — the per-receiver cache ([`shscale_field::receivers`]) are built
/// once; per frame, only deforming occluders are deformed, their BVH updated (rebuild or refit as
/// [`deform::DeformerKind::preferred_update`] prescribes) and their BSV resampled; static occluders
/// reuse their BSV. Returns the last frame's image and per-frame statistics.
pub fn render_sequence(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
) -> Result<(RenderOutput, Vec<FrameStats>), Error> {
    render_sequence_each(scene, rs, frames, &mut |_, _| Ok(()))
}

/// [`render_sequence`], with `each` called after every frame (outside its times) with the
/// frame's stats and pixels: a per-frame error, progress.
#[allow(clippy::type_complexity)]
pub(crate) fn render_sequence_each(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    each: &mut dyn FnMut(&FrameStats, &[[f32; 3]]) -> Result<(), Error>,
) -> Result<(RenderOutput, Vec<FrameStats>), Error> {
    let frames = frames.max(1);
    let light = light_of(scene, rs.order)?;
    let [w, h] = scene.resolution;
    let recv = receiver_grid(scene);
    let sampler = VisibilitySampler::new(rs.order, rs.hemisphere_res)?;
    let mut ents = (scene.occluders.iter())
        .map(|o| Entity::new(rs.sampling_radius, o, frames))
        .collect::<Result<Vec<_>, _>>()?;
    // Tables: one per occluder over the receivers' k range.
    let tables: Vec<KTable> = ents
        .iter()
        .map(|e| table_for((scene, rs), e.sampling, &recv, Eta::Plain))
        .collect::<Result<_, _>>()?;
    let shader = Shader::new(rs.order)?;
    let transfer = shader.transfer(&light, DVec3::Z);
    let mut cache: Option<shscale_field::receivers::ReceiverCache> = None;
    let mut stats = Vec::new();
    let mut pixels = vec![[0f32; 3]; recv.len()];
    let (mut products, mut skipped) = (0, 0);
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let mut st = FrameStats {
            frame: f,
            t,
            ..Default::default()
        };
        for e in ents.iter_mut() {
            e.advance(rs.layout, &sampler, t, &mut st)?;
        }
        let t0 = Instant::now();
        // The receiver cache is linear in the visibility; the clamp mitigation is not, so a
        // clamped sequence takes the direct path.
        if ents.len() == 1 && rs.plausibility == shscale_field::extrapolate::Plausibility::None {
            let bsv = ents[0].bsv.as_ref().expect("sampled");
            let c = cache.get_or_insert_with(|| {
                shscale_field::receivers::ReceiverCache::build(bsv, &tables[0], &transfer, &recv)
            });
            let mut out = vec![[0.0; 3]; recv.len()];
            c.shade(bsv, &mut out);
            pixels = out.iter().map(|e| e.map(|x| x as f32)).collect();
        } else {
            (pixels, products, skipped) =
                shade_direct(rs.plausibility, &ents, &tables, &shader, &transfer, &recv);
        }
        st.shading_seconds = t0.elapsed().as_secs_f64();
        each(&st, &pixels)?;
        stats.push(st);
    }
    let out = RenderOutput {
        width: w,
        height: h,
        pixels,
        stages: Vec::new(),
        products,
        skipped,
        error: Vec::new(),
    };
    Ok((out, stats))
}

/// One occluder of a sequence: its rest and posed mesh with their BVH and deformer (none for the
/// analytic sphere), the sampling sphere fixed for the sequence, and its current BSV.
pub(super) struct Entity {
    rest: Option<Mesh>,
    posed: Option<Mesh>,
    occ: Box<dyn Occluder>,
    bvh: Option<MeshBvh>,
    deformer: Option<(deform::DeformerKind, f64)>,
    /// The deformer with its rest-pose constants (meshes with a deformer).
    poser: Option<crate::frame::Poser>,
    sampling: Sphere,
    bsv: Option<Bsv>,
}

impl Entity {
    /// The occluder `o` of a sequence of `frames` frames, sampled on its sphere scaled by the
    /// sampling radius `sampling_radius` (in bounding radii).
    pub(super) fn new(
        sampling_radius: f64,
        o: &crate::scene::OccluderSpec,
        frames: usize,
    ) -> Result<Self, Error> {
        if o.mesh == "sphere" {
            return Ok(Entity {
                rest: None,
                posed: None,
                occ: o.build()?,
                bvh: None,
                deformer: None,
                poser: None,
                sampling: Sphere {
                    center: o.center,
                    radius: o.radius * sampling_radius,
                },
                bsv: None,
            });
        }
        let rest = o.placed()?;
        let s = sequence_sphere(&rest, o.deformer, frames);
        let strategy = (o.deformer).map_or(UpdateStrategy::Rebuild, |(k, _)| k.preferred_update());
        let bvh = MeshBvh::build(&rest, strategy);
        Ok(Entity {
            poser: (o.deformer).map(|(k, a)| crate::frame::Poser::new(&rest, k, a)),
            posed: Some(rest.clone()),
            rest: Some(rest),
            occ: Box::new(AnalyticSphere { sphere: s }),
            bvh: Some(bvh),
            deformer: o.deformer,
            sampling: Sphere {
                center: s.center,
                radius: s.radius * sampling_radius,
            },
            bsv: None,
        })
    }

    /// Pose the occluder at time `t` (deformers only), update its BVH, and resample its BSV
    /// when its shape changed (or was never sampled); the times and counts go to `st`.
    pub(super) fn advance(
        &mut self,
        layout: shscale_field::Layout,
        sampler: &VisibilitySampler,
        t: f64,
        st: &mut FrameStats,
    ) -> Result<(), Error> {
        let changed = self.deformer.is_some() || self.bsv.is_none();
        if let (Some(poser), Some(rest), Some(posed)) =
            (self.poser.as_ref(), self.rest.as_ref(), self.posed.as_mut())
        {
            let t0 = Instant::now();
            poser.pose(rest, t, posed);
            st.deform_seconds += t0.elapsed().as_secs_f64();
            let t0 = Instant::now();
            self.bvh.as_mut().expect("meshes have a BVH").update(posed);
            st.bvh_update_seconds += t0.elapsed().as_secs_f64();
        }
        if !changed {
            st.reused += 1;
            return Ok(());
        }
        let t0 = Instant::now();
        let occ: &dyn Occluder = match &self.bvh {
            Some(b) => b,
            None => self.occ.as_ref(),
        };
        self.bsv = Some(Bsv::sample_on(occ, layout, sampler, self.sampling, 0.0)?);
        st.bsv_sampling_seconds += t0.elapsed().as_secs_f64();
        st.resampled += 1;
        Ok(())
    }
}

/// A frame shaded receiver by receiver through the extrapolators of every occluder (no cache):
/// the pixels, SH products computed and evaluations skipped.
pub(super) fn shade_direct(
    plausibility: shscale_field::extrapolate::Plausibility,
    ents: &[Entity],
    tables: &[KTable],
    shader: &Shader,
    transfer: &[Vec<f64>; 3],
    recv: &[DVec3],
) -> (Vec<[f32; 3]>, usize, usize) {
    let exs: Vec<Extrapolator> = (ents.iter().zip(tables))
        .map(|(e, t)| {
            Extrapolator::new(e.bsv.as_ref().expect("sampled"), t).with_plausibility(plausibility)
        })
        .collect();
    let fields: Vec<&dyn VisibilityField> = exs.iter().map(|e| e as &dyn VisibilityField).collect();
    let centers: Vec<DVec3> = ents.iter().map(|e| e.sampling.center).collect();
    let shaded: Vec<([f32; 3], usize, usize)> = recv
        .par_iter()
        .map(|p| {
            let (v, pr, sk) = shader.combined_visibility_counted(&fields, &centers, *p);
            (Shader::shade(transfer, &v).map(|x| x as f32), pr, sk)
        })
        .collect();
    (
        shaded.iter().map(|s| s.0).collect(),
        shaded.iter().map(|s| s.1).sum(),
        shaded.iter().map(|s| s.2).sum(),
    )
}
