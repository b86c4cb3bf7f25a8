//! `ray_traced`: band-limited ray-traced visibility (the stratified truth at `4T²` rays per
//! receiver and occluder), shaded through SH like the others. Its one key, its cost and how it
//! sets a render's settings.

use super::{MethodSpec, Spec};
use crate::render::form::{Built, CpuForm, LocalLights};
use crate::settings::RenderSettings;
use shscale_runner::KeyError;

/// Ray tracing's parameters: `T`, for `4T²` stratified rays per receiver and occluder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayTracedSpec {
    pub rt_res: usize,
}

impl RayTracedSpec {
    /// `rt_res` within `1..=rt_res_max` (the kind's largest; below its truth's).
    pub(crate) fn parse(rt_res: usize, rt_res_max: usize) -> Result<Self, KeyError> {
        Ok(Self {
            rt_res: KeyError::int("rt_res", rt_res, 1, rt_res_max)?,
        })
    }
}

impl MethodSpec for RayTracedSpec {
    fn reads(&self) -> Vec<&'static str> {
        vec!["rt_res"]
    }
    /// `4T²` per receiver and occluder.
    fn rays(&self, occluders: f64, receivers: f64) -> f64 {
        occluders * (receivers * 4.0 * (self.rt_res * self.rt_res) as f64)
    }
    /// Nothing held.
    fn memory_bytes(&self, _order: usize, _occluders: f64, _k_count: usize) -> f64 {
        0.0
    }
    /// The render's truth resolution (the kinds check at plan time that it is below the
    /// reference's).
    fn apply(&self, rs: &mut RenderSettings) {
        rs.truth_res = self.rt_res;
    }
    fn into_spec(self) -> Spec {
        Spec::RayTraced(self)
    }
}

/// The band-limited truth's CPU render: nothing built; every receiver's visibility the converged
/// stratified truth of each occluder at the settings' `truth_res` (`4T²` rays per receiver and
/// occluder); local lights ray traced.
pub(crate) const CPU: CpuForm = CpuForm {
    build: |_, _| Ok(Built::default()),
    work: |w| (w.receivers * w.occluders * 4.0 * w.t2, w.bytes(1.0, 0.0)),
    local_lights: LocalLights::Traced,
    truth_sampler: true,
    basis: false,
    full_frequency: false,
    extrapolates: false,
};
