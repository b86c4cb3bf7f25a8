//! Full-frequency truth: `∫ L Π V cos⁺` by direct quadrature with exact ray-cast visibility per
//! receiver, with its own error estimate — the reference of every budget, not a method under one
//! (so no spec: nothing of it is swept). Its CPU form.

use crate::render::form::{Built, CpuForm, LocalLights};

/// Full-frequency truth's CPU render: nothing built; every receiver's `4T²` stratified rays
/// plus the sun's `4·max(4, T/2)²` (`shscale_field::shading::irradiance_exact`); local lights
/// ray traced.
pub(crate) const CPU: CpuForm = CpuForm {
    build: |_, _| Ok(Built::default()),
    work: |w| {
        let sun = shscale_field::shading::sun_bands(w.rs.truth_res).pow(2) as f64;
        (w.receivers * 4.0 * (w.t2 + sun), w.bytes(1.0, 0.0))
    },
    local_lights: LocalLights::Traced,
    truth_sampler: false,
    basis: false,
    full_frequency: true,
    extrapolates: false,
};
