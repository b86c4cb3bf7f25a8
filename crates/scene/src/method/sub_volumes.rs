//! `sub_volumes` (TR §6, SHS §5 future work): every mesh occluder split into parts, each part
//! extrapolated from its own bounding sphere, multiplied near to far — or, with
//! `part_combine = "shexp"`, each part's log-visibility extrapolated, summed and exponentiated
//! once. Its parameters, keys, domains, cost and how it sets a render's settings.

use super::{product_work, Extrapolation, Keys, MethodSpec, Spec, SHEXP_SECONDS};
use crate::combine::Combine;
use crate::error::Error;
use crate::render::form::{partitioned, Built, CpuForm, Inputs, LocalLights};
use crate::settings::RenderSettings;
use shscale_field::extrapolate::Plausibility;
use shscale_runner::KeyError;

/// The cost model's time of one base-sphere sample's product-algebra log (an N² × N²
/// eigenproblem, one thread) at N = 4, growing as `(N/4)⁶`: 43 µs from `part_combine = "shexp"`
/// at P = 16 in `configs/experiments/subvolumes_log.toml` (2.4 ms at N = 8) on the development
/// VM.
pub(crate) const LOG_SAMPLE_SECONDS: f64 = 43e-6;

/// Sub-volumes' parameters: `parts` parts, each extrapolated by `ex`; `combine`:
/// [`Combine::Product`] (each part's scaled visibility multiplied near to far) or
/// [`Combine::Shexp`] (each part's log-visibility scaled, summed, exponentiated once).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubVolumeSpec {
    pub parts: usize,
    pub ex: Extrapolation,
    pub combine: Combine,
}

impl SubVolumeSpec {
    pub(crate) fn parse(k: &Keys) -> Result<Self, KeyError> {
        Ok(Self {
            parts: super::parts(k.parts)?,
            ex: Extrapolation::parse(k)?,
            combine: {
                let s = k.part_combine.unwrap_or("product");
                Combine::from_name(s)
                    .filter(|c| matches!(c, Combine::Product | Combine::Shexp))
                    .ok_or_else(|| {
                        KeyError::new(
                            "part_combine",
                            format!("{s:?} is not one of [\"product\", \"shexp\"]"),
                        )
                    })?
            },
        })
    }
}

/// Extrapolated fields combined in log space (sub-volumes' parts, or a scene's occluders, with
/// `part_combine = "shexp"`) at order N: SH exponentiation's order limit, and no plausibility
/// clamp (it bounds visibilities, not logs). The one check of it, for the budget kinds at plan
/// time and for `render`.
pub(crate) fn check_log_space(order: usize, plausibility: Plausibility) -> Result<(), KeyError> {
    super::check_shexp_order("part_combine", order)?;
    if plausibility != Plausibility::None {
        return Err(KeyError::new(
            "plausibility",
            "the clamp bounds visibilities, not the logs `part_combine = \"shexp\"` extrapolates: leave it at \"none\"",
        ));
    }
    Ok(())
}

impl MethodSpec for SubVolumeSpec {
    fn reads(&self) -> Vec<&'static str> {
        [vec!["parts", "part_combine"], self.ex.reads()].concat()
    }
    fn check_order(&self, order: usize) -> Result<(), KeyError> {
        match self.combine {
            Combine::Shexp => check_log_space(order, self.ex.plausibility),
            _ => Ok(()),
        }
    }
    /// Every part's base-sphere visibility.
    fn rays(&self, occluders: f64, _receivers: f64) -> f64 {
        occluders * (self.parts as f64 * self.ex.bsv_rays())
    }
    /// Every part's base-sphere visibility and k-table.
    fn memory_bytes(&self, order: usize, occluders: f64, k_count: usize) -> f64 {
        occluders * (self.parts as f64 * self.ex.bytes(order, k_count))
    }
    /// In log space the parts' logs cost about what their visibilities do
    /// ([`LOG_SAMPLE_SECONDS`] per sample and part) and the exponential is added
    /// ([`SHEXP_SECONDS`] per receiver); by products, the rays.
    fn seconds(&self, order: usize, rays: f64, receivers: f64, rays_per_second: f64) -> f64 {
        match self.combine {
            Combine::Shexp => {
                let logs = self.parts as f64
                    * super::samples(self.ex.layout)
                    * LOG_SAMPLE_SECONDS
                    * (order as f64 / 4.0).powi(6);
                rays / rays_per_second + receivers * SHEXP_SECONDS * product_work(order) + logs
            }
            _ => rays / rays_per_second,
        }
    }
    fn apply(&self, rs: &mut RenderSettings) {
        self.ex.set_on(rs);
        rs.parts = self.parts;
        rs.part_combine = self.combine;
    }
    fn into_spec(self) -> Spec {
        Spec::SubVolumes(self)
    }
}

/// Sub-volumes' CPU render: every mesh occluder split into `parts` (timed as `partition`), each
/// part extrapolated from its own bounding sphere as [`super::extrapolated::extrapolate`] does.
/// No local lights.
pub(crate) const CPU: CpuForm = CpuForm {
    build: |i, stages| {
        let parts = stages.time("partition", || parts_of(i))?;
        let mut b = Built::default();
        (b.bsvs, b.tables) = super::extrapolated::extrapolate(i, &parts, stages)?;
        Ok(b)
    },
    work: |w| {
        let parts = w.rs.parts.max(1) as f64;
        (parts * w.bsv_rays(), w.bytes(parts, 0.0))
    },
    local_lights: LocalLights::Refused,
    truth_sampler: false,
    basis: false,
    full_frequency: false,
    extrapolates: true,
};

/// The parts of every occluder, each as its own BVH: a mesh split into `RenderSettings::parts`
/// by k-means on the rest pose's triangle centroids (per triangle, so a deforming mesh keeps its
/// partition over a sequence), posed at the scene's `pose_t`; the analytic sphere is one part.
fn parts_of(i: &Inputs) -> Result<Vec<Box<dyn shscale_geometry::Occluder>>, Error> {
    use shscale_geometry::ray::UpdateStrategy;
    use shscale_geometry::{MeshBvh, Occluder};
    let n = i.rs.parts;
    let mut parts: Vec<Box<dyn Occluder>> = Vec::new();
    for (o, split) in i.scene.occluders.iter().zip(partitioned(i.scene, n)?) {
        match split {
            Some((posed, labels)) => {
                for p in shscale_geometry::partition::split(&posed, &labels, n) {
                    parts.push(Box::new(MeshBvh::build(&p, UpdateStrategy::Rebuild)));
                }
            }
            None => parts.push(o.build()?),
        }
    }
    Ok(parts)
}
