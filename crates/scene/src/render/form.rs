//! What a method's file gives the CPU render (`CpuForm`): what it builds from the render
//! settings, what it needs besides (a truth sampler, an SH basis), how local lights are taken
//! under it, and its work for `render`'s limits. [`crate::render::render`] runs a method through
//! its form alone: no code of the render names a method. Each method's form is in its own file
//! under `crate::method` and registered once (`crate::method::cpu_form`).

use crate::error::Error;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use shscale_field::evaluator::FullField;
use shscale_field::{Bsv, VisibilitySampler};
use shscale_geometry::{Occluder, Sphere};
use shscale_scaling::KTable;
use std::time::Instant;

/// A method's CPU render, as its file describes it.
pub(crate) struct CpuForm {
    /// The fields the method builds for a frame (nothing for the truths).
    pub build: fn(&Inputs, &mut Stages) -> Result<Built, Error>,
    /// Rays and peak bytes of one render ([`Work`]).
    pub work: fn(&Work) -> (f64, f64),
    /// How the frame's local lights are taken.
    pub local_lights: LocalLights,
    /// Whether it renders through the band-limited truth's sampler (the converged stratified
    /// visibility per occluder), through an SH basis (a sphere set's caps), or by the
    /// full-frequency quadrature (not shaded through SH).
    pub truth_sampler: bool,
    pub basis: bool,
    pub full_frequency: bool,
    /// Whether its fields are extrapolations, which can combine in log space
    /// (`RenderSettings::part_combine`).
    pub extrapolates: bool,
}

/// How a method takes a scene's local lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LocalLights {
    /// Each light's source radiance field extrapolated like the occluders (its radiance BSV and
    /// η table).
    Extrapolated,
    /// Ray traced at every receiver (nothing built).
    Traced,
    /// Not modelled: a scene with local lights is refused, naming the methods that take them.
    Refused,
}

/// What a method's [`CpuForm::build`] reads: the scene, the settings, the posed occluders, the
/// base-sphere sampler and the receivers.
pub(crate) struct Inputs<'a> {
    pub scene: &'a Scene,
    pub rs: &'a RenderSettings,
    pub occs: &'a [Box<dyn Occluder>],
    pub sampler: &'a VisibilitySampler,
    pub recv: &'a [DVec3],
}

/// The fields a method built for a frame: base-sphere visibilities with their k-tables (the
/// extrapolations), full fields, or spheres (a sphere set); empty for the truths.
#[derive(Default)]
pub(crate) struct Built {
    pub bsvs: Vec<Bsv>,
    pub tables: Vec<KTable>,
    pub fulls: Vec<FullField>,
    pub spheres: Vec<Sphere>,
}

/// `(stage, seconds)` in execution order.
#[derive(Default)]
pub(crate) struct Stages(pub Vec<(String, f64)>);

impl Stages {
    /// Record the stage `name` as begun at `t0` and ended now.
    pub fn push(&mut self, name: &str, t0: Instant) {
        self.0.push((name.to_string(), t0.elapsed().as_secs_f64()));
    }

    /// Run `f` as the stage `name`.
    pub fn time<T>(
        &mut self,
        name: &str,
        f: impl FnOnce() -> Result<T, Error>,
    ) -> Result<T, Error> {
        let t = Instant::now();
        let out = f()?;
        self.push(name, t);
        Ok(out)
    }
}

/// The counts a method's work estimate is a formula of ([`CpuForm::work`]).
pub(crate) struct Work<'a> {
    pub rs: &'a RenderSettings,
    /// Base-sphere samples of the layout, H², T², receivers, occluders (at least 1) and N².
    pub samples: f64,
    pub h2: f64,
    pub t2: f64,
    pub receivers: f64,
    pub occluders: f64,
    pub nn: f64,
}

impl Work<'_> {
    /// The rays of one base-sphere visibility per occluder.
    pub fn bsv_rays(&self) -> f64 {
        self.occluders * self.samples * self.h2
    }

    /// Peak bytes: `fields` base-sphere-sized fields per occluder (N² doubles a sample), `extra`
    /// bytes of the method's own, and every receiver's N² coefficients and position.
    pub fn bytes(&self, fields: f64, extra: f64) -> f64 {
        self.occluders * fields * self.samples * self.nn * 8.0
            + extra
            + self.receivers * (self.nn * 8.0 + 16.0)
    }
}

/// A posed mesh and the part of each of its triangles.
pub(crate) type Partitioned = (shscale_geometry::Mesh, Vec<u32>);

/// Per occluder: its mesh posed at [`Scene::pose_t`] with the part of every triangle (`parts`
/// by k-means on the rest pose's triangle centroids, so a deforming mesh keeps its partition
/// over a sequence), or `None` for the analytic sphere (sub-volumes and sphere sets).
pub(crate) fn partitioned(scene: &Scene, parts: usize) -> Result<Vec<Option<Partitioned>>, Error> {
    (scene.occluders.iter())
        .map(|o| {
            let Some(rest) = crate::frame::occluder_mesh_at(o, None)? else {
                return Ok(None);
            };
            let labels = shscale_geometry::partition::kmeans_parts(&rest, parts)
                .map_err(|e| Error::config(format!("{}: {e}", scene.file)))?;
            Ok(Some((crate::frame::posed(&rest, o, scene.pose_t), labels)))
        })
        .collect()
}
