//! A still frame of a scene's plane through a per-receiver cache: what a frame costs when the
//! receivers, the light and the sampling sphere stay fixed and only the occluder's samples change
//! (a deforming object on a fixed sphere), for the two sampled methods alike — the extrapolated
//! field through [`ReceiverCache`] and the fully sampled field through [`FieldShadingCache`].
//! The cache is built once (its time is reported apart); a frame re-samples the field (the BSV,
//! or every shell) and shades every receiver from the cache. The image equals the direct
//! render's ([`crate::render::render`]) up to the caches' f32 storage of U (extrapolation,
//! relative ~1e-7) and summation order.
//!
//! Applies to one occluder, no local lights, the extrapolation without the plausibility clamp
//! (the cache is linear in the visibility) and with base samples on the sampling sphere
//! (`radial = uniform`); [`CachedPlane::new`] returns `None` otherwise.

use crate::error::Error;
use crate::frame::{build_occluder_at, light_of, receiver_grid, table_for};
use crate::render::{full_field_shells, Method};
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::DVec3;
use shscale_field::bsv::RadialRule;
use shscale_field::evaluator::{FullField, Shells};
use shscale_field::extrapolate::Plausibility;
use shscale_field::receivers::{FieldShadingCache, ReceiverCache};
use shscale_field::shading::Shader;
use shscale_field::{Bsv, VisibilitySampler};
use shscale_geometry::{Occluder, Sphere};
use shscale_scaling::Eta;
use std::time::Instant;

/// The method's cached state.
enum Cache {
    Extrapolated(ReceiverCache),
    Full {
        shells: Shells,
        cache: FieldShadingCache,
    },
}

/// A scene's plane set up for cached frames ([`CachedPlane::frame`]).
pub struct CachedPlane {
    settings: RenderSettings,
    occ: Box<dyn Occluder>,
    sampler: VisibilitySampler,
    transfer: [Vec<f64>; 3],
    cache: Cache,
    /// Seconds to build the cache (with its first sampling and, for extrapolation, its table).
    pub build_seconds: f64,
}

impl CachedPlane {
    /// Set up the method of `rs` on `scene` (posed at its `pose_t`) with its cache; `None` where
    /// no cached path applies (module docs).
    pub fn new(scene: &Scene, rs: &RenderSettings) -> Result<Option<Self>, Error> {
        if !Self::applies(scene, rs) {
            return Ok(None);
        }
        let t0 = Instant::now();
        let occ = build_occluder_at(&scene.occluders[0], scene.pose_t)?;
        let sampler = VisibilitySampler::new(rs.order, rs.hemisphere_res)?;
        let light = light_of(scene, rs.order)?;
        let transfer = Shader::new(rs.order)?.transfer(&light, DVec3::Z);
        let recv = receiver_grid(scene);
        let cache = if rs.method == Method::Extrapolated {
            let bsv = sample_bsv(rs, occ.as_ref(), &sampler)?;
            let s = Sphere {
                center: bsv.sphere.center,
                radius: bsv.sampling_radius,
            };
            let table = table_for((scene, rs), s, &recv, Eta::Plain)?;
            Cache::Extrapolated(ReceiverCache::build(&bsv, &table, &transfer, &recv))
        } else {
            let shells = rs.full_field.unwrap_or_else(|| full_field_shells(rs));
            let field = FullField::build(occ.as_ref(), rs.layout, &sampler, &shells)?;
            let cache = FieldShadingCache::build(&field, &recv);
            Cache::Full { shells, cache }
        };
        Ok(Some(Self {
            settings: rs.clone(),
            occ,
            sampler,
            transfer,
            cache,
            build_seconds: t0.elapsed().as_secs_f64(),
        }))
    }

    /// Whether `scene` rendered with `rs` has a cached path (module docs): one occluder, no
    /// local lights, the full field, or the extrapolation without the clamp on its sampling
    /// sphere.
    pub fn applies(scene: &Scene, rs: &RenderSettings) -> bool {
        scene.occluders.len() == 1
            && scene.light_sources.is_empty()
            && match rs.method {
                Method::Extrapolated => {
                    rs.plausibility == Plausibility::None && rs.radial == RadialRule::Uniform
                }
                Method::FullField => true,
                _ => false,
            }
    }

    /// One frame: the field re-sampled, every receiver shaded from the cache (row-major
    /// irradiance, as [`crate::render::RenderOutput::pixels`]).
    pub fn frame(&self) -> Result<Vec<[f64; 3]>, Error> {
        Ok(match &self.cache {
            Cache::Extrapolated(cache) => {
                let bsv = sample_bsv(&self.settings, self.occ.as_ref(), &self.sampler)?;
                let mut out = vec![[0.0; 3]; cache.len()];
                cache.shade(&bsv, &mut out);
                out
            }
            Cache::Full { shells, cache } => {
                let field = FullField::build(
                    self.occ.as_ref(),
                    self.settings.layout,
                    &self.sampler,
                    shells,
                )?;
                let mut out = vec![[0.0; 3]; cache.len()];
                cache.shade(&field, &self.transfer, &mut out);
                out
            }
        })
    }
}

/// The BSV of the occluder on its sampling sphere (the layout and radius of `rs`).
fn sample_bsv(
    rs: &RenderSettings,
    occ: &dyn Occluder,
    sampler: &VisibilitySampler,
) -> Result<Bsv, Error> {
    Ok(Bsv::sample_radial(
        occ,
        rs.layout,
        sampler,
        rs.sampling_radius,
        RadialRule::Uniform,
    )?)
}
