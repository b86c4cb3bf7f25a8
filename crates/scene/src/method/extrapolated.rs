//! The papers' method, `extrapolated`: SH-scaling extrapolation from one base-sphere visibility
//! per occluder (and, as [`Extrapolation`], each sub-volume's). Its parameters, the keys it
//! reads, their domains, its cost and how it sets a render's settings, in one file.

use super::{Keys, MethodSpec, Spec};
use crate::error::Error;
use crate::render::form::{Built, CpuForm, Inputs, LocalLights, Stages};
use crate::settings::RenderSettings;
use crate::vocab::AlphaDeg;
use shscale_field::bsv::{Layout, RadialRule, OCCLUSION_STEPS};
use shscale_field::extrapolate::Plausibility;
use shscale_runner::check::Ends;
use shscale_runner::KeyError;

/// How α of the extrapolation's k-table is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Alpha {
    /// One cone angle, checked.
    Fixed(AlphaDeg),
    /// α by distance at the BSV's effective cap (the table is then built per frame).
    Fit,
}

/// The extrapolation's parameters (one sphere, or each sub-volume's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extrapolation {
    pub layout: Layout,
    /// H: H² rays per base-sphere sample.
    pub hemisphere_res: usize,
    pub alpha: Alpha,
    pub plausibility: Plausibility,
    /// The sampling sphere in bounding radii, [1, 1000].
    pub sampling_radius: f64,
    pub radial: RadialRule,
    /// k-table entries; `None` where the scene's are used (`budget_plane`).
    pub k_count: Option<usize>,
}

impl Extrapolation {
    /// The extrapolation keys of `k`, each in its domain.
    pub(crate) fn parse(k: &Keys) -> Result<Self, KeyError> {
        let layout = super::layout(k.layout)?;
        let mode = k.alpha_mode.unwrap_or("fixed");
        let alpha = match AlphaMode::from_name(mode) {
            Some(AlphaMode::Fixed) => Alpha::Fixed(AlphaDeg::of_key("alpha_deg", k.alpha_deg)?),
            Some(AlphaMode::Fit) => Alpha::Fit,
            None => {
                return Err(KeyError::new(
                    "alpha_mode",
                    shscale_names::one_of(mode, AlphaMode::NAMES),
                ))
            }
        };
        Ok(Extrapolation {
            layout,
            hemisphere_res: super::hemisphere_res(k.hemisphere_res)?,
            alpha,
            plausibility: Plausibility::parse(k.plausibility)
                .map_err(|m| KeyError::new("plausibility", m))?,
            sampling_radius: super::sampling_radius(k.sampling_radius)?,
            radial: radial_rule(k)?,
            k_count: k
                .k_count
                .map(|k| KeyError::int("k_count", k, 2, crate::vocab::MAX_K_COUNT))
                .transpose()?,
        })
    }

    /// The keys the extrapolation reads (α only when fixed; the radial rule's own).
    pub(crate) fn reads(&self) -> Vec<&'static str> {
        let mut v = vec!["layout", "hemisphere_res", "alpha_mode"];
        if matches!(self.alpha, Alpha::Fixed(_)) {
            v.push("alpha_deg");
        }
        v.extend(["plausibility", "sampling_radius", "radial", "k_count"]);
        match self.radial {
            RadialRule::Uniform => {}
            RadialRule::Clearance { .. } => v.push("radial_delta"),
            RadialRule::Occlusion { .. } => v.extend(["radial_tau", "radial_max"]),
        }
        v
    }

    /// Rays of one base-sphere visibility: its samples' hemispheres, × the occlusion rule's
    /// search steps.
    pub(crate) fn bsv_rays(&self) -> f64 {
        let search = match self.radial {
            RadialRule::Occlusion { .. } => (2 + OCCLUSION_STEPS) as f64,
            _ => 1.0,
        };
        search * super::samples(self.layout) * (self.hemisphere_res * self.hemisphere_res) as f64
    }

    /// Bytes of one base-sphere visibility and its k-table at order N (`k_count` entries where
    /// the spec leaves them to the scene): N² doubles per sample, N × N doubles per entry.
    pub(crate) fn bytes(&self, order: usize, k_count: usize) -> f64 {
        let nn = (order * order) as f64;
        super::samples(self.layout) * nn * 8.0
            + self.k_count.unwrap_or(k_count) as f64 * nn * nn * 8.0
    }

    /// The extrapolation's keys set on the render settings `s`.
    pub(crate) fn set_on(&self, s: &mut RenderSettings) {
        s.layout = self.layout;
        s.hemisphere_res = self.hemisphere_res;
        if let Alpha::Fixed(a) = self.alpha {
            s.alpha = a.radians();
        }
        s.plausibility = self.plausibility;
        s.sampling_radius = self.sampling_radius;
        s.radial = self.radial;
        if let Some(k) = self.k_count {
            s.k_count = k;
        }
    }
}

impl MethodSpec for Extrapolation {
    fn reads(&self) -> Vec<&'static str> {
        Extrapolation::reads(self)
    }
    fn rays(&self, occluders: f64, _receivers: f64) -> f64 {
        occluders * self.bsv_rays()
    }
    fn memory_bytes(&self, order: usize, occluders: f64, k_count: usize) -> f64 {
        occluders * self.bytes(order, k_count)
    }
    fn apply(&self, rs: &mut RenderSettings) {
        self.set_on(rs)
    }
    fn into_spec(self) -> Spec {
        Spec::Extrapolated(self)
    }
}

/// `uniform`, `clearance` (δ ∈ [0, 10]) or `occlusion` (τ ∈ [0, 1), ceiling ∈ [1, 10]), the
/// last only where the kind offers `radial_tau` and `radial_max`.
fn radial_rule(k: &Keys) -> Result<RadialRule, KeyError> {
    match (RadialName::from_name(k.radial), k.radial_tau.zip(k.radial_max)) {
        (Some(RadialName::Uniform), _) => Ok(RadialRule::Uniform),
        (Some(RadialName::Clearance), _) => Ok(RadialRule::Clearance {
            delta: KeyError::real("radial_delta", k.radial_delta, 0.0, 10.0, Ends::Closed)?,
        }),
        (Some(RadialName::Occlusion), Some((tau, t_max))) => Ok(RadialRule::Occlusion {
            tau: KeyError::real("radial_tau", tau, 0.0, 1.0, Ends::ClosedOpen)?,
            t_max: KeyError::real("radial_max", t_max, 1.0, 10.0, Ends::Closed)?,
        }),
        (Some(RadialName::Occlusion), None) => Err(KeyError::new(
            "radial",
            "\"occlusion\" is offered by `budget` only (its search rays are not in the plane's ray count); use \"uniform\" or \"clearance\"",
        )),
        (None, _) => Err(KeyError::new(
            "radial",
            shscale_names::one_of(k.radial, RadialName::NAMES),
        )),
    }
}

/// The names `alpha_mode` takes (the cone angle given, or fitted by distance).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum AlphaMode {
    Fixed,
    Fit,
}
shscale_names::names!(AlphaMode { Fixed = "fixed", Fit = "fit" });

/// The names `radial` takes ([`RadialRule`]'s variants, whose parameters are other keys).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RadialName {
    Uniform,
    Clearance,
    Occlusion,
}
shscale_names::names!(RadialName {
    Uniform = "uniform",
    Clearance = "clearance",
    Occlusion = "occlusion",
});

/// The extrapolation's CPU render: a base-sphere visibility on each occluder's own bounding
/// sphere (scaled by the sampling radius, the samples placed by the radial rule) and a k-table
/// over the receivers; local lights extrapolated too.
pub(crate) const CPU: CpuForm = CpuForm {
    build: |i, stages| {
        let mut b = Built::default();
        (b.bsvs, b.tables) = extrapolate(i, i.occs, stages)?;
        Ok(b)
    },
    work: |w| (w.bsv_rays(), w.bytes(1.0, 0.0)),
    local_lights: LocalLights::Extrapolated,
    truth_sampler: false,
    basis: false,
    full_frequency: false,
    extrapolates: true,
};

/// Each of `sources` (occluders, or sub-volumes' parts) sampled on its bounding sphere and its
/// k-table over the receivers (the tables span the samples' radii under a radial rule), timed
/// as the stages `bsv_sampling` and `table_build`.
pub(crate) fn extrapolate(
    i: &Inputs,
    sources: &[Box<dyn shscale_geometry::Occluder>],
    stages: &mut Stages,
) -> Result<(Vec<shscale_field::Bsv>, Vec<shscale_scaling::KTable>), Error> {
    let rs = i.rs;
    let bsvs: Vec<shscale_field::Bsv> = stages.time("bsv_sampling", || {
        (sources.iter())
            .map(|o| {
                Ok(shscale_field::Bsv::sample_radial(
                    o.as_ref(),
                    rs.layout,
                    i.sampler,
                    rs.sampling_radius,
                    rs.radial,
                )?)
            })
            .collect::<Result<_, Error>>()
    })?;
    let tables = stages.time("table_build", || {
        (bsvs.iter())
            .map(|b| {
                let s = shscale_geometry::Sphere {
                    center: b.sphere.center,
                    radius: b.sampling_radius,
                };
                let outer = b.radii.iter().copied().fold(s.radius, f64::max);
                crate::frame::table_for_radii(
                    (i.scene, rs),
                    s,
                    outer,
                    i.recv,
                    shscale_scaling::Eta::Plain,
                )
            })
            .collect()
    })?;
    Ok((bsvs, tables))
}
