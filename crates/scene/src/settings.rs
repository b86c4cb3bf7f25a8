//! How a scene is rendered: the method and every parameter the methods read
//! ([`RenderSettings`]). A [`crate::scene::Scene`] is what is there to be seen; a render is
//! [`crate::render::render`]`(&scene, &settings)`. The scene file's top-level keys (`order`,
//! `alpha_deg`, `layout`, `hemisphere_res`, `truth_res`, `plausibility`, `k_count`,
//! `sampling_radius`) give the defaults ([`crate::scene::Scene::load`]); a budget study sets a
//! method's own parameters through [`crate::method::Spec::apply`], `shscale render` through its
//! flags.

use crate::combine::{Combine, SphereFit};
use crate::method::name::Method;
use shscale_field::bsv::{Layout, RadialRule};
use shscale_field::evaluator::Shells;
use shscale_field::extrapolate::Plausibility;

/// The default truth resolution of a scene (`4T²` rays per receiver).
pub(crate) const DEFAULT_SCENE_TRUTH_RES: usize = 32;

/// The method of a render and every parameter the methods read. A method reads only its own
/// (docs/methods.md lists which); the others keep their defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// The method computing each receiver's visibility.
    pub method: Method,
    /// SH order N of the light, the fields and the shading, 1..=16.
    pub order: usize,
    /// Cone half-angle α of the k-tables (radians, in (0, π/2)).
    pub alpha: f64,
    /// The base-sphere layout (extrapolation, sub-volumes, the full field's shells, the local
    /// lights' radiance fields).
    pub layout: Layout,
    /// H: H² rays per base-sphere sample.
    pub hemisphere_res: usize,
    /// T of the ray-traced truths (band-limited: `4T²` stratified rays per receiver and occluder;
    /// full-frequency: `4T²` plus the sun's `4·max(4, T/2)²` per receiver).
    pub truth_res: usize,
    /// The extrapolation's plausibility mitigation (docs/conventions.md §6).
    pub plausibility: Plausibility,
    /// k-table entries.
    pub k_count: usize,
    /// The sampling sphere (and innermost shell) in bounding radii.
    pub sampling_radius: f64,
    /// The full field's construction (no scene-file key); `None`: the papers'
    /// ([`crate::render::full_field_shells`]).
    pub full_field: Option<Shells>,
    /// Parts of every mesh occluder for [`Method::SubVolumes`] and spheres per mesh for
    /// [`Method::SphereSet`] (no scene-file key); 1 otherwise.
    pub parts: usize,
    /// The internal order of a [`Method::SphereSet`]'s products (its caps multiplied at this
    /// order, truncated to `order` once; no scene-file key); 0 (the render's order) otherwise.
    pub sphere_order: usize,
    /// How a [`Method::SphereSet`] combines its spheres: products (at `sphere_order`), the
    /// quadrature, the exact union of its caps (`shscale_field::union`) or SH exponentiation
    /// (`shscale_field::shexp_ol`), set by experiments and `render --sphere-combine`; products
    /// otherwise. Every combination renders through [`crate::method::SetTables`].
    pub sphere_combine: Combine,
    /// Which spheres a [`Method::SphereSet`] takes: one per k-means part (area-weighted), or the
    /// mesh's inscribed balls (`shscale_geometry::inscribed`, fitted to each pose), set by
    /// experiments and `render --sphere-fit`; area otherwise.
    pub sphere_fit: SphereFit,
    /// How extrapolated fields combine — a sub-volume's parts, or a scene's several occluders
    /// under [`Method::Extrapolated`]: products near to far, or `Combine::Shexp` (each field's
    /// base-sphere log-visibility scaled, summed, exponentiated once:
    /// `shscale_field::shexp_ol::SubVolumeLog`), set by experiments and `render
    /// --part-combine`; products otherwise.
    pub part_combine: Combine,
    /// Where the extrapolation's base-sphere samples lie along their directions (no scene-file
    /// key); [`RadialRule::Uniform`] otherwise.
    pub radial: RadialRule,
}

impl Default for RenderSettings {
    /// The scene file's defaults (docs/config.md) under [`Method::Extrapolated`].
    fn default() -> Self {
        Self {
            method: Method::Extrapolated,
            order: 4,
            alpha: 45f64.to_radians(),
            layout: Layout::LatLong { rows: 12, cols: 20 },
            hemisphere_res: 32,
            truth_res: DEFAULT_SCENE_TRUTH_RES,
            plausibility: Plausibility::None,
            k_count: 40,
            sampling_radius: 1.0,
            full_field: None,
            parts: 1,
            sphere_order: 0,
            sphere_combine: Combine::Product,
            sphere_fit: SphereFit::Area,
            part_combine: Combine::Product,
            radial: RadialRule::Uniform,
        }
    }
}

impl RenderSettings {
    /// These settings with `method` (every parameter kept).
    pub fn with(&self, method: Method) -> Self {
        Self {
            method,
            ..self.clone()
        }
    }
}
