//! The `budget_plane` kind's parameters: one method at one budget on one scene's receiver
//! plane, with the method keys handed to the vocabulary.

use serde::{Deserialize, Serialize};
use shscale_runner::KeyError;
use shscale_scene::method::{Keys, Spec};

/// Parameters of one run (one method at one budget on one scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Scene file, relative to the config's folder.
    pub scene: String,
    /// Override of the scene's order (empty: the scene's).
    pub order: Option<usize>,
    /// Frames of the deformers' sequence (t = f / frames), each rendered from scratch by every
    /// method; 1: the rest pose.
    pub frames: usize,
    /// `extrapolated`, `full_field`, `ray_traced`, `sub_volumes` or `sphere_set`.
    pub method: String,
    /// Parts of every mesh occluder for `sub_volumes`, or its spheres for `sphere_set`, 1..=64.
    pub parts: usize,
    pub layout: String,
    pub hemisphere_res: usize,
    pub shells: usize,
    pub shell_max: f64,
    pub shell_spacing: String,
    pub field_interp: String,
    pub rt_res: usize,
    pub alpha_deg: f64,
    pub plausibility: String,
    pub sampling_radius: f64,
    /// `uniform` (the papers') or `clearance` (each base-sphere sample at least
    /// `radial_delta`·r from the surface), as in `budget`.
    pub radial: String,
    pub radial_delta: f64,
    /// The order M a `sphere_set` multiplies its caps at before truncating to the scene's order
    /// (0: that order, the plain chain; else order ≤ M ≤ 16), as in `budget`.
    pub sphere_order: usize,
    /// How a `sphere_set` combines its spheres: `product` (near to far, at `sphere_order`),
    /// `union` (the exact union of the caps, `shscale_field::union`) or `shexp` (SH
    /// exponentiation, `shscale_field::shexp_ol`).
    pub sphere_combine: String,
    /// Which spheres `sphere_set` takes: `area` or `inscribed` (fitted to each pose).
    pub sphere_fit: String,
    /// How `sub_volumes` combines its parts: `product` or `shexp` (scaling in log space), as in
    /// `budget`.
    pub part_combine: String,
    /// Keep the run's image (and the group's full-frequency truth) as EXR for the figure
    /// (`shscale figs`); one frame only.
    pub save_image: bool,
    /// The occluders' placement: 0 as the scene file has them; any other seed turns every mesh
    /// occluder by its own uniformly random rotation about its bounding sphere's centre (the
    /// sphere, and so the scene's clearance from the plane, unchanged).
    pub placement_seed: u64,
    /// Where the frame is timed besides the CPU: `cpu` (default), `gpu` (the GPU path too;
    /// refused without an adapter or a GPU form) or `auto` (the GPU path where both exist).
    pub device: String,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            scene: "../scene_bunny.toml".into(),
            order: None,
            frames: 1,
            method: shscale_scene::method::Method::Extrapolated.name().into(),
            parts: 4,
            layout: "latlong:12x20".into(),
            hemisphere_res: 32,
            shells: 16,
            shell_max: 8.0,
            shell_spacing: "uniform".into(),
            field_interp: "trilinear".into(),
            rt_res: 8,
            alpha_deg: 45.0,
            plausibility: "none".into(),
            sampling_radius: 1.0,
            radial: "uniform".into(),
            radial_delta: 0.1,
            sphere_order: 0,
            sphere_combine: "product".into(),
            sphere_fit: "area".into(),
            part_combine: "product".into(),
            save_image: false,
            placement_seed: 0,
            device: "cpu".into(),
        }
    }
}

impl Params {
    /// The method keys, for the vocabulary (α fixed, no occlusion rule, products, the scene's
    /// k-table entries).
    pub(super) fn keys(&self) -> Keys<'_> {
        Keys {
            method: &self.method,
            parts: self.parts,
            layout: &self.layout,
            hemisphere_res: self.hemisphere_res,
            shells: self.shells,
            shell_max: self.shell_max,
            shell_spacing: &self.shell_spacing,
            field_interp: &self.field_interp,
            rt_res: self.rt_res,
            alpha_deg: self.alpha_deg,
            alpha_mode: None,
            plausibility: &self.plausibility,
            sampling_radius: self.sampling_radius,
            radial: &self.radial,
            radial_delta: self.radial_delta,
            radial_tau: None,
            radial_max: None,
            sphere_combine: Some(&self.sphere_combine),
            sphere_fit: Some(&self.sphere_fit),
            part_combine: Some(&self.part_combine),
            sphere_order: Some(self.sphere_order),
            k_count: None,
        }
    }

    /// The method, parsed (the unread-key rule against the defaults).
    pub(super) fn spec(&self) -> Result<Spec, KeyError> {
        Spec::parse(&self.keys(), &Params::default().keys(), MAX_RT_RES)
    }
}

/// The largest `rt_res` of a plane (and below the scene's `truth_res`, checked at plan time).
pub(super) const MAX_RT_RES: usize = 255;
