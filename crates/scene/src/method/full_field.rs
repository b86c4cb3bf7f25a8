//! `full_field`: the fully sampled shadow field (Zhou et al. 2005) — shells of base-sphere
//! samples, interpolated. Its parameters, keys, domains, cost and how it sets a render's settings.

use super::{Keys, MethodSpec, Spec};
use crate::error::Error;
use crate::render::form::{Built, CpuForm, LocalLights};
use crate::settings::RenderSettings;
use shscale_field::bsv::Layout;
use shscale_field::evaluator::{FieldInterp, ShellSpacing, Shells};
use shscale_runner::check::Ends;
use shscale_runner::KeyError;

/// The most shells of a full field.
pub(crate) const MAX_SHELLS: usize = 64;

/// The keys the full field reads (its GPU form carries out every one of them).
pub(crate) const FULL_FIELD_KEYS: &[&str] = &[
    "layout",
    "hemisphere_res",
    "shells",
    "shell_max",
    "shell_spacing",
    "field_interp",
    "sampling_radius",
];

/// The fully sampled field's parameters: shells over `[s, shell_max·s]·r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldSpec {
    pub layout: Layout,
    pub hemisphere_res: usize,
    pub count: usize,
    pub shell_max: f64,
    pub spacing: ShellSpacing,
    pub interp: FieldInterp,
    /// The innermost shell in bounding radii.
    pub sampling_radius: f64,
}

impl FieldSpec {
    /// The shells, over `[s, shell_max·s]` bounding radii.
    pub fn shells(&self) -> Shells {
        Shells {
            count: self.count,
            rho_min: self.sampling_radius,
            rho_max: self.shell_max * self.sampling_radius,
            spacing: self.spacing,
            interp: self.interp,
        }
    }

    /// The full field's keys of `k`, each in its domain, the shells checked against the layout.
    pub(crate) fn parse(k: &Keys) -> Result<Self, KeyError> {
        let f = FieldSpec {
            layout: super::layout(k.layout)?,
            hemisphere_res: super::hemisphere_res(k.hemisphere_res)?,
            count: KeyError::int("shells", k.shells, 2, MAX_SHELLS)?,
            shell_max: KeyError::real("shell_max", k.shell_max, 1.0, 1e3, Ends::OpenClosed)?,
            spacing: ShellSpacing::parse(k.shell_spacing)
                .map_err(|e| KeyError::new("shell_spacing", e.to_string()))?,
            interp: FieldInterp::parse(k.field_interp)
                .map_err(|e| KeyError::new("field_interp", e.to_string()))?,
            sampling_radius: super::sampling_radius(k.sampling_radius)?,
        };
        (f.shells().check(f.layout)).map_err(|e| KeyError::new("field_interp", e.to_string()))?;
        Ok(f)
    }
}

impl MethodSpec for FieldSpec {
    fn reads(&self) -> Vec<&'static str> {
        FULL_FIELD_KEYS.to_vec()
    }
    /// Every shell's base-sphere samples' hemispheres.
    fn rays(&self, occluders: f64, _receivers: f64) -> f64 {
        occluders
            * (self.count as f64
                * super::samples(self.layout)
                * (self.hemisphere_res * self.hemisphere_res) as f64)
    }
    /// N² doubles per sample per shell.
    fn memory_bytes(&self, order: usize, occluders: f64, _k_count: usize) -> f64 {
        let nn = (order * order) as f64;
        occluders * (self.count as f64 * super::samples(self.layout) * nn * 8.0)
    }
    fn apply(&self, rs: &mut RenderSettings) {
        rs.layout = self.layout;
        rs.hemisphere_res = self.hemisphere_res;
        rs.sampling_radius = self.sampling_radius;
        rs.full_field = Some(self.shells());
    }
    fn into_spec(self) -> Spec {
        Spec::FullField(self)
    }
}

/// The renderer's full field where the settings name none: the papers' construction
/// ([`Shells::PAPERS`]: 16 shells at uniform radial intervals, trilinear) over `[s, 8s]·r` for
/// the sampling radius `s`; on a Fibonacci layout, which has no grid, barycentric in angle.
pub fn full_field_shells(rs: &RenderSettings) -> Shells {
    let s = rs.sampling_radius;
    Shells {
        rho_min: s,
        rho_max: 8.0 * s,
        interp: match rs.layout {
            shscale_field::Layout::Fibonacci { .. } => FieldInterp::Barycentric,
            _ => FieldInterp::Trilinear,
        },
        ..Shells::PAPERS
    }
}

/// The full field's CPU render: its shells about each occluder's bounding sphere (the
/// settings' construction, else the papers', [`full_field_shells`]), timed as
/// `full_field_build`. No local lights.
pub(crate) const CPU: CpuForm = CpuForm {
    build: |i, stages| {
        let rs = i.rs;
        let shells = rs.full_field.unwrap_or_else(|| full_field_shells(rs));
        let fulls = stages.time("full_field_build", || {
            (i.occs.iter())
                .map(|o| {
                    Ok(shscale_field::evaluator::FullField::build(
                        o.as_ref(),
                        rs.layout,
                        i.sampler,
                        &shells,
                    )?)
                })
                .collect::<Result<_, Error>>()
        })?;
        Ok(Built {
            fulls,
            ..Built::default()
        })
    },
    work: |w| {
        let rs = w.rs;
        let shells = rs.full_field.unwrap_or_else(|| full_field_shells(rs)).count as f64;
        (shells * w.bsv_rays(), w.bytes(shells, 0.0))
    },
    local_lights: LocalLights::Refused,
    truth_sampler: false,
    basis: false,
    full_frequency: false,
    extrapolates: false,
};
