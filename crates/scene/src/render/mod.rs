//! Rendering a scene's receiver plane (normal +z) with one of the three visibility evaluators
//! (docs/conventions.md §4–5): extrapolated (BSV + k-table), full field (the papers' construction:
//! 16 shells at uniform radial intervals over [s, 8s]·r, trilinear; [`full_field_shells`]) or
//! ray-traced truth (the converged `TruthSampler`, 4T² rays per receiver per occluder; or, for
//! `raytraced-full`, exact visibility lit by the environment itself, `irradiance_exact`).
//! Irradiance per pixel in linear RGB.
//! Stage times are reported so methods can be compared on the same scene.
//!
//! [`sequence`]: deforming sequences, frame by frame, with each entity's state carried over.

pub(crate) mod form;
mod sequence;

pub use sequence::*;

use crate::error::Error;
use crate::frame::{
    build_emitters, build_occluder_at, light_of, receiver_grid, sequence_sphere, table_for,
    LightSource,
};
use crate::method::Combine;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use form::{Built, Stages};
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::evaluator::{ConvergedTruth, FullField, VisibilityField};
use shscale_field::extrapolate::Extrapolator;
use shscale_field::shading::{EnvLight, Shader};
use shscale_field::shexp_ol::{log_bsv, SubVolumeLog, ZonalLogTable, SHEXP_EPS};
use shscale_field::sphereset::SphereVisibility;
use shscale_field::{Bsv, Emitter, VisibilitySampler};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{deform, AnalyticSphere, Mesh, MeshBvh, Occluder, Sphere};
use shscale_scaling::{Eta, KTable};
use std::time::Instant;

/// The visibility evaluator used for every occluder: the project's one method vocabulary
/// ([`crate::method`]).
pub use crate::method::Method;

/// The renderer's full field where the scene names none (the full field's own file).
pub use crate::method::full_field_shells;

/// A rendered receiver plane.
pub struct RenderOutput {
    pub width: usize,
    pub height: usize,
    /// Row-major, row 0 at +y (top of the image).
    pub pixels: Vec<[f32; 3]>,
    /// `(stage, seconds)` in execution order.
    pub stages: Vec<(String, f64)>,
    /// SH products computed and occluder evaluations skipped as unoccluded.
    pub products: usize,
    pub skipped: usize,
    /// A truth's own estimated error per pixel: `|A − B|/2` of the full-frequency truth's two
    /// estimates ([`shscale_field::shading::irradiance_exact`]), or `|⟨T, (A − B)/2⟩|` of the
    /// band-limited truth of a single occluder without local lights; empty otherwise.
    pub error: Vec<[f32; 3]>,
}

impl RenderOutput {
    /// The receiver plane of `scene` as `pixels` with nothing else recorded (the GPU sequences'
    /// last frame).
    pub fn plane(scene: &Scene, pixels: Vec<[f32; 3]>) -> Self {
        Self {
            width: scene.resolution[0],
            height: scene.resolution[1],
            pixels,
            stages: Vec::new(),
            products: 0,
            skipped: 0,
            error: Vec::new(),
        }
    }
}

/// Estimated rays and peak bytes of one [`render`] of `scene` with the settings `rs` (for the work limits
/// of `shscale render`): the BSV of every occluder (one per shell for the full field), 4T² rays per
/// receiver and occluder for band-limited ray tracing, 4T² plus the sun's cap per receiver for
/// full-frequency truth.
pub fn estimated_work(scene: &Scene, rs: &RenderSettings) -> (f64, f64) {
    let w = form::Work {
        rs,
        samples: rs.layout.sample_count().unwrap_or(usize::MAX) as f64,
        h2: (rs.hemisphere_res * rs.hemisphere_res) as f64,
        t2: (rs.truth_res * rs.truth_res) as f64,
        receivers: (scene.resolution[0] * scene.resolution[1]) as f64,
        occluders: scene.occluders.len().max(1) as f64,
        nn: (rs.order * rs.order) as f64,
    };
    (crate::method::cpu_form(rs.method).work)(&w)
}

/// Render `scene` with the method and parameters of `rs` (its occluders posed at
/// [`Scene::pose_t`] when set). Only what the method uses is built: the truth sampler for the
/// band-limited truth, the SH basis and the sphere-set tables for sphere sets, base-sphere
/// samples and tables for the extrapolations, shells for the full field.
pub fn render(scene: &Scene, rs: &RenderSettings) -> Result<RenderOutput, Error> {
    let form = crate::method::cpu_form(rs.method);
    let mut stages = Stages::default();
    let light = stages.time("light_projection", || light_of(scene, rs.order))?;
    let occs: Vec<Box<dyn Occluder>> = stages.time("bvh_build", || {
        (scene.occluders.iter())
            .map(|o| build_occluder_at(o, scene.pose_t))
            .collect::<Result<_, _>>()
    })?;
    let recv = receiver_grid(scene);
    let sampler = VisibilitySampler::new(rs.order, rs.hemisphere_res)?;
    // Per-occluder fields (kept alive for the borrows below).
    let basis = (form.basis)
        .then(|| shscale_sh::ShBasis::<f64>::new(rs.order))
        .transpose()
        .map_err(|e| Error::config(format!("{}: {e}", scene.file)))?;
    let set_tables = SetTables::new((scene, rs), form, basis.as_ref())?;
    let inputs = form::Inputs {
        scene,
        rs,
        occs: &occs,
        sampler: &sampler,
        recv: &recv,
    };
    let built = (form.build)(&inputs, &mut stages)?;
    let built = set_tables.to_logs(built, &mut stages);
    let exs = extrapolators(&built, rs.plausibility);
    let truth = (form.truth_sampler)
        .then(|| {
            let seed = shscale_field::truth::DEFAULT_TRUTH_SEED;
            shscale_field::truth::TruthSampler::new(rs.order, rs.truth_res, seed)
        })
        .transpose()?;
    let rts = converged_truths(&occs, truth.as_ref());
    let spheres: Vec<SphereVisibility> = match &basis {
        Some(basis) => (built.spheres.iter())
            .map(|s| SphereVisibility::new(*s, basis))
            .collect(),
        None => Vec::new(),
    };
    // A sphere set combined at a higher internal order, as its caps' union or by SH
    // exponentiation, and extrapolated fields combined in log space, are one field (the shader
    // then multiplies nothing more).
    let one_set = set_tables.field(&built.spheres, basis.as_ref(), &exs);
    let mut fields = fields_of(&spheres, &exs, &built.fulls, &rts);
    let mut centers = field_centers(&built, &occs);
    if let Some(set) = &one_set {
        fields = vec![set.as_ref()];
        centers.truncate(1);
    }
    let common = Common {
        light: &light,
        occs: &occs,
        recv: &recv,
        sampler: &sampler,
    };
    shade_render(
        (scene, rs, form),
        common,
        truth.as_ref(),
        (&fields, &centers),
        stages,
    )
}

/// What every method's render shares, built before its fields: the light projected, the posed
/// occluders, the receivers and the base-sphere sampler.
struct Common<'a> {
    light: &'a EnvLight,
    occs: &'a [Box<dyn Occluder>],
    recv: &'a [DVec3],
    sampler: &'a VisibilitySampler,
}

/// The second half of [`render`]: the local lights built, then every receiver shaded from the
/// method's `fields` multiplied near to far about their `centers` (the full-frequency truth by
/// its own quadrature, the band-limited truth of one occluder with its own error).
fn shade_render(
    (scene, rs, form): (&Scene, &RenderSettings, &form::CpuForm),
    c: Common,
    truth: Option<&shscale_field::truth::TruthSampler>,
    (fields, centers): (&[&dyn VisibilityField], &[DVec3]),
    mut stages: Stages,
) -> Result<RenderOutput, Error> {
    let Common {
        light,
        occs,
        recv,
        sampler,
    } = c;
    let t = Instant::now();
    let emitters = build_emitters(scene)?;
    if !emitters.is_empty() {
        stages.push("light_sources_build", t);
    }
    if form.full_frequency {
        return Ok(render_full_frequency(
            scene, rs, light, occs, &emitters, recv, stages,
        ));
    }
    let t = Instant::now();
    let light_fields = light_fields((scene, rs, form), &emitters, sampler, recv)?;
    if !emitters.is_empty() {
        stages.push("light_fields", t);
    }
    let t = Instant::now();
    let shader = Shader::new(rs.order)?;
    let transfer = shader.transfer(light, DVec3::Z);
    // Band-limited truth of one occluder and no local lights: the truth's own error per receiver,
    // |⟨T, (A − B)/2⟩| (irradiance is linear in the visibility), beside the pixel.
    if let (Some(truth), [o], true) = (truth, occs, emitters.is_empty()) {
        let out = truth_with_error(scene, o.as_ref(), truth, &transfer, recv);
        stages.push("shading", t);
        return Ok(RenderOutput {
            stages: stages.0,
            ..out
        });
    }
    let local = LocalLights::new(&emitters, &light_fields, sampler);
    let mut out = shade_all(
        scene,
        rs.order,
        fields,
        centers,
        (&shader, &transfer),
        &local,
        recv,
    );
    stages.push("shading", t);
    out.stages = stages.0;
    Ok(out)
}

/// The extrapolated field of every base-sphere visibility built (one per occluder, or per part
/// of sub-volumes), with the scene's plausibility mitigation.
fn extrapolators(
    built: &Built,
    plausibility: shscale_field::extrapolate::Plausibility,
) -> Vec<Extrapolator<'_>> {
    (built.bsvs.iter().zip(&built.tables))
        .map(|(b, t)| Extrapolator::new(b, t).with_plausibility(plausibility))
        .collect()
}

/// Ray tracing's field per occluder (the converged truth at `truth`'s resolution); none for
/// the other methods (which build no truth sampler).
fn converged_truths<'a>(
    occs: &'a [Box<dyn Occluder>],
    truth: Option<&'a shscale_field::truth::TruthSampler>,
) -> Vec<ConvergedTruth<'a>> {
    let Some(truth) = truth else {
        return Vec::new();
    };
    (occs.iter())
        .map(|o| ConvergedTruth {
            occ: o.as_ref(),
            truth,
        })
        .collect()
}

/// Several fields combined as one field, with the tables each way needs: none (the plain
/// chains, one field per sphere, part or occluder, multiplied by the shader near to far), a
/// sphere set's combination ([`SetTables`], the factory the budget frames use too: products at
/// its internal order, the quadrature, its caps' union or SH exponentiation), or extrapolated
/// fields — a sub-volume's parts, a scene's occluders — in log space
/// ([`RenderSettings::part_combine`];
/// SHEXP's Gaunt tensor and log table, within the domain of
/// [`crate::method::check_log_space`]).
enum SetTables {
    Plain,
    Set(crate::method::SetTables),
    LogSpace(shscale_sh::GauntTensor<f64>, ZonalLogTable),
}

impl SetTables {
    /// The tables of `rs`' method; `basis` is built for sphere sets only.
    fn new(
        (scene, rs): (&Scene, &RenderSettings),
        form: &form::CpuForm,
        basis: Option<&shscale_sh::ShBasis<f64>>,
    ) -> Result<Self, Error> {
        if form.extrapolates && rs.part_combine == Combine::Shexp {
            crate::method::check_log_space(rs.order, rs.plausibility)
                .map_err(|e| Error::config(format!("{}: {}: {}", scene.file, e.key, e.message)))?;
            let gaunt = shscale_sh::GauntTensor::<f64>::new(rs.order)?;
            let table = ZonalLogTable::new(&gaunt, SHEXP_EPS);
            return Ok(SetTables::LogSpace(gaunt, table));
        }
        let Some(basis) = basis else {
            return Ok(SetTables::Plain);
        };
        let set = crate::method::SetSpec::of_settings(rs);
        match crate::method::SetTables::new(&set, rs.order, basis) {
            Ok(crate::method::SetTables::Chain) => Ok(SetTables::Plain),
            Ok(t) => Ok(SetTables::Set(t)),
            Err(e) => Err(Error::config(format!("{}: {e}", scene.file))),
        }
    }

    /// Every BSV replaced by its samples' logs when extrapolated fields combine in log space
    /// (timed as its own stage); `built` as it is otherwise.
    fn to_logs(&self, mut built: Built, stages: &mut Stages) -> Built {
        if let SetTables::LogSpace(gaunt, _) = self {
            let t = Instant::now();
            built.bsvs = (built.bsvs.iter())
                .map(|b| log_bsv(b, gaunt, SHEXP_EPS))
                .collect();
            stages.push("log_samples", t);
        }
        built
    }

    /// The fields' one field, or `None` for the plain chains (and for no sphere or part).
    fn field<'a>(
        &'a self,
        spheres: &'a [shscale_geometry::Sphere],
        basis: Option<&'a shscale_sh::ShBasis<f64>>,
        exs: &'a [Extrapolator<'a>],
    ) -> Option<Box<dyn VisibilityField + 'a>> {
        match self {
            SetTables::Plain => None,
            SetTables::LogSpace(g, t) if !exs.is_empty() => {
                Some(Box::new(SubVolumeLog::new(exs, g, t)))
            }
            SetTables::LogSpace(..) => None,
            _ if spheres.is_empty() => None,
            SetTables::Set(t) => t
                .field(spheres, basis?, None)
                .map(|f| f.field as Box<dyn VisibilityField + 'a>),
        }
    }
}

/// The method's visibility fields — whichever it built: one per sphere of a sphere set, per
/// extrapolated occluder or part, per full field, or per occluder's converged truth — multiplied
/// by the shader near to far; none for full-frequency truth, which is not shaded through SH.
fn fields_of<'a>(
    spheres: &'a [SphereVisibility],
    exs: &'a [Extrapolator],
    fulls: &'a [FullField],
    rts: &'a [ConvergedTruth],
) -> Vec<&'a dyn VisibilityField> {
    fn all<F: VisibilityField>(v: &[F]) -> impl Iterator<Item = &dyn VisibilityField> {
        v.iter().map(|f| f as &dyn VisibilityField)
    }
    (all(spheres)
        .chain(all(exs))
        .chain(all(fulls))
        .chain(all(rts)))
    .collect()
}

/// The centres the fields are multiplied near to far about: the spheres' of a sphere set, the
/// base spheres' of extrapolated occluders or parts (an occluder's base sphere is centred on its
/// bounding sphere), else the occluders'.
fn field_centers(built: &Built, occs: &[Box<dyn Occluder>]) -> Vec<DVec3> {
    if !built.spheres.is_empty() {
        built.spheres.iter().map(|s| s.center).collect()
    } else if !built.bsvs.is_empty() {
        built.bsvs.iter().map(|b| b.sphere.center).collect()
    } else {
        occs.iter().map(|o| o.bounding_sphere().center).collect()
    }
}

/// Every receiver shaded by the product of the occluders' visibility fields under the light's
/// transfer, plus the local lights.
fn shade_all(
    scene: &Scene,
    order: usize,
    fields: &[&dyn VisibilityField],
    centers: &[DVec3],
    (shader, transfer): (&Shader, &[Vec<f64>; 3]),
    local: &LocalLights,
    recv: &[DVec3],
) -> RenderOutput {
    let shaded: Vec<([f32; 3], usize, usize)> = recv
        .par_iter()
        .map(|p| {
            let (v, products, skipped) = shader.combined_visibility_counted(fields, centers, *p);
            let mut e = Shader::shade(transfer, &v);
            local.add(order, shader, *p, &v, &mut e);
            (e.map(|x| x as f32), products, skipped)
        })
        .collect();
    RenderOutput {
        width: scene.resolution[0],
        height: scene.resolution[1],
        pixels: shaded.iter().map(|s| s.0).collect(),
        stages: Vec::new(),
        products: shaded.iter().map(|s| s.1).sum(),
        skipped: shaded.iter().map(|s| s.2).sum(),
        error: Vec::new(),
    }
}

/// Full-frequency truth: `∫ L Π V cos⁺` by direct quadrature with exact visibility per receiver,
/// with the quadrature's own error estimate.
fn render_full_frequency(
    scene: &Scene,
    rs: &RenderSettings,
    light: &EnvLight,
    occs: &[Box<dyn Occluder>],
    emitters: &[LightSource],
    recv: &[DVec3],
    mut stages: Stages,
) -> RenderOutput {
    let t = Instant::now();
    let refs: Vec<&dyn Occluder> = occs.iter().map(|o| o.as_ref()).collect();
    let ems: Vec<[Option<&Emitter>; 3]> = (emitters.iter())
        .map(|e| [0, 1, 2].map(|c| e.channels[c].as_ref()))
        .collect();
    let both: Vec<shscale_field::shading::Irradiance> = recv
        .par_iter()
        .map(|p| {
            shscale_field::shading::irradiance_exact(
                light,
                &refs,
                &ems,
                *p,
                DVec3::Z,
                rs.truth_res,
                shscale_field::truth::DEFAULT_TRUTH_SEED,
            )
        })
        .collect();
    stages.push("full_frequency_truth", t);
    RenderOutput {
        width: scene.resolution[0],
        height: scene.resolution[1],
        pixels: both.iter().map(|x| x.e.map(|v| v as f32)).collect(),
        stages: stages.0,
        products: 0,
        skipped: 0,
        error: both.iter().map(|x| x.err.map(|v| v as f32)).collect(),
    }
}

/// Source radiance fields of the local lights (docs/conventions.md §4): per channel a radiance
/// BSV and the η k-table for the extrapolated method; nothing to build for ray tracing.
fn light_fields(
    (scene, rs, form): (&Scene, &RenderSettings, &form::CpuForm),
    emitters: &[LightSource],
    sampler: &VisibilitySampler,
    recv: &[DVec3],
) -> Result<Vec<LightField>, Error> {
    if emitters.is_empty() {
        return Ok(Vec::new());
    }
    if form.local_lights == form::LocalLights::Refused {
        return Err(Error::config(format!("{}: local light sources are supported with the extrapolated, raytraced and raytraced-full methods", scene.file)));
    }
    let mut out = Vec::new();
    for e in emitters {
        let mut lf = LightField {
            bsvs: [None, None, None],
            table: None,
        };
        if form.local_lights == form::LocalLights::Extrapolated {
            for c in 0..3 {
                if let Some(em) = &e.channels[c] {
                    let b = shscale_field::srf::radiance_bsv(em, rs.layout, sampler, 1.0)?;
                    lf.bsvs[c] = Some(b);
                }
            }
            let eta = if e.energy { Eta::Energy } else { Eta::Plain };
            lf.table = Some(table_for((scene, rs), e.sphere, recv, eta)?);
        }
        out.push(lf);
    }
    Ok(out)
}

/// The band-limited truth of one occluder shaded per receiver, with its own error estimate
/// `|⟨T, (A − B)/2⟩|` and, as `skipped`, the receivers it leaves unoccluded.
fn truth_with_error(
    scene: &Scene,
    o: &dyn Occluder,
    truth: &shscale_field::truth::TruthSampler,
    transfer: &[Vec<f64>; 3],
    recv: &[DVec3],
) -> RenderOutput {
    let both: Vec<([f32; 3], [f32; 3], usize)> = recv
        .par_iter()
        .map(|p| {
            let t = truth.sample(o, *p);
            let e = Shader::shade(transfer, &t.coeffs);
            let d = Shader::shade(transfer, &t.half_diff);
            (
                e.map(|x| x as f32),
                d.map(|x| x.abs() as f32),
                usize::from(t.escaped == t.rays),
            )
        })
        .collect();
    RenderOutput {
        width: scene.resolution[0],
        height: scene.resolution[1],
        pixels: both.iter().map(|x| x.0).collect(),
        stages: Vec::new(),
        products: 0,
        skipped: both.iter().map(|x| x.2).sum(),
        error: both.iter().map(|x| x.1).collect(),
    }
}

/// The local lights of a render as the shading loop sees them.
struct LocalLights<'a> {
    emitters: &'a [LightSource],
    extrapolators: Vec<[Option<Extrapolator<'a>>; 3]>,
    sampler: &'a VisibilitySampler,
}

impl<'a> LocalLights<'a> {
    /// The lights with the extrapolators of their fields (built once for every receiver).
    fn new(
        emitters: &'a [LightSource],
        fields: &'a [LightField],
        sampler: &'a VisibilitySampler,
    ) -> Self {
        let extrapolators = (fields.iter())
            .map(|lf| {
                [0, 1, 2].map(|c| {
                    lf.bsvs[c].as_ref().map(|b| {
                        Extrapolator::for_light(b, lf.table.as_ref().expect("table with BSVs"))
                    })
                })
            })
            .collect();
        Self {
            emitters,
            extrapolators,
            sampler,
        }
    }

    /// Add every local light's radiance at `p` (extrapolated, or ray traced where no field was
    /// built), contracted with the lobe under visibility `v`, to the irradiance `e`.
    fn add(&self, order: usize, shader: &Shader, p: DVec3, v: &[f64], e: &mut [f64; 3]) {
        if self.emitters.is_empty() {
            return;
        }
        let mut l = vec![0.0; order * order];
        let mut m = shscale_scaling::ScalingMatrix::identity(order).expect("valid order");
        for (k, em) in self.emitters.iter().enumerate() {
            for c in 0..3 {
                let Some(emitter) = &em.channels[c] else {
                    continue;
                };
                match self.extrapolators.get(k).and_then(|x| x[c].as_ref()) {
                    Some(x) => {
                        x.eval(p, &mut m, &mut l);
                    }
                    None => l.copy_from_slice(
                        &(self.sampler)
                            .radiance_full_sphere(emitter, p, shscale_field::Frame::Entity)
                            .0,
                    ),
                }
                e[c] += shader.shade_local(&l, DVec3::Z, v);
            }
        }
    }
}

struct LightField {
    bsvs: [Option<Bsv>; 3],
    table: Option<KTable>,
}
