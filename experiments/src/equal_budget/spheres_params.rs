//! The `budget` kind's parameters: one method at one budget on spherical receivers, with the
//! method keys handed to the vocabulary and the receiver layout's checks.

use super::receivers::{check_layout, CONTINUOUS};
use serde::{Deserialize, Serialize};
use shscale_runner::records::list;
use shscale_runner::KeyError;
use shscale_scene::method::{Keys, Spec};

/// Parameters of one run (one method at one budget).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    pub mesh: String,
    pub order: usize,
    /// `extrapolated`, `full_field`, `ray_traced`, `sub_volumes` or `sphere_set`.
    pub method: String,
    /// Parts of the `sub_volumes` method, or spheres of `sphere_set`, 1..=64 (k-means on
    /// triangle centroids).
    pub parts: usize,
    /// Base-sphere layout (extrapolation) or per-shell layout (full field).
    pub layout: String,
    /// H: H² rays per BSV or shell sample.
    pub hemisphere_res: usize,
    /// Shells of the full field, 2..=64.
    pub shells: usize,
    /// The outermost shell in sampling radii, (1, 1e3] (the innermost is the sampling radius).
    pub shell_max: f64,
    /// `uniform` (the papers') or `exp`.
    pub shell_spacing: String,
    /// `trilinear` (the papers', grid layouts) or `barycentric`.
    pub field_interp: String,
    /// T of the ray-traced method (4T² rays per receiver).
    pub rt_res: usize,
    pub alpha_deg: f64,
    /// `fixed` or `fit` (α by distance at the BSV's effective cap, as in `probe`).
    pub alpha_mode: String,
    /// `none` or `clamp` (the plausibility mitigation, as in `probe`).
    pub plausibility: String,
    /// The extrapolation's sampling sphere (and the full field's innermost shell) in bounding
    /// radii, [1, 1e3].
    pub sampling_radius: f64,
    /// Where each base-sphere sample lies along its direction: `uniform` (the papers'),
    /// `clearance` (at least `radial_delta`·r from the surface) or `occlusion` (facing
    /// occlusion at most `radial_tau`, searched up to `radial_max`·r).
    pub radial: String,
    pub radial_delta: f64,
    pub radial_tau: f64,
    pub radial_max: f64,
    /// How `sphere_set` combines its spheres: `product` (the truncated SH products near to
    /// far, as every multi-occluder method here), `quadrature` (the set's joint visibility
    /// projected by a quadrature, no truncated products), `union` (the same joint visibility,
    /// exact in φ, by rings in z, no rays) or `shexp` (SH exponentiation).
    pub sphere_combine: String,
    /// Which spheres `sphere_set` takes: `area` (one per k-means part, refitted every frame) or
    /// `inscribed` (the mesh's greedy inscribed balls, a one-off fit timed in
    /// `partition_seconds`).
    pub sphere_fit: String,
    /// How `sub_volumes` combines its parts: `product` (each part's scaled visibility
    /// multiplied near to far) or `shexp` (each part's scaled log-visibility summed and
    /// exponentiated once, SH exponentiation's HYB).
    pub part_combine: String,
    /// The order M a `sphere_set` multiplies its caps at before truncating to `order` (0: the
    /// run's order, the plain chain; else order ≤ M ≤ 16).
    pub sphere_order: usize,
    pub k_count: usize,
    /// `grid` (as many seeded directions as `receivers` at each of `radii`) or `continuous`
    /// (`receivers` points, each with its own seeded direction and its own radius, ρ − 1
    /// log-uniform over [`rho_min` − 1, `rho_max` − 1], stratified).
    pub receiver_layout: String,
    /// Receivers: directions per radius (`grid`) or points (`continuous`).
    pub receivers: usize,
    /// The continuous layout's radius range, bounding radii.
    pub rho_min: f64,
    pub rho_max: f64,
    pub probe_seed: u64,
    pub truth_res: usize,
    pub truth_seed: u64,
    /// The occluder's orientation against the world-fixed sampling grids: 0 keeps the mesh as
    /// loaded; any other seed turns it by a uniformly random rotation about its bounding
    /// sphere's centre (Shoemake's, from the seed).
    pub orientation_seed: u64,
    #[serde(with = "list")]
    pub radii: Vec<f64>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            mesh: "bunny".into(),
            order: 4,
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
            alpha_mode: "fixed".into(),
            plausibility: "none".into(),
            sampling_radius: 1.0,
            radial: "uniform".into(),
            radial_delta: 0.1,
            radial_tau: 0.5,
            radial_max: 2.0,
            sphere_combine: "product".into(),
            sphere_fit: "area".into(),
            part_combine: "product".into(),
            sphere_order: 0,
            k_count: 40,
            receiver_layout: "grid".into(),
            receivers: 240,
            rho_min: 1.02,
            rho_max: 3.0,
            probe_seed: 1,
            truth_res: shscale_field::truth::DEFAULT_TRUTH_RES,
            truth_seed: shscale_field::truth::DEFAULT_TRUTH_SEED,
            orientation_seed: 0,
            radii: vec![1.1, 1.3, 1.6, 2.0, 3.0],
        }
    }
}

impl Params {
    /// The method keys, for the vocabulary.
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
            alpha_mode: Some(&self.alpha_mode),
            plausibility: &self.plausibility,
            sampling_radius: self.sampling_radius,
            radial: &self.radial,
            radial_delta: self.radial_delta,
            radial_tau: Some(self.radial_tau),
            radial_max: Some(self.radial_max),
            sphere_combine: Some(&self.sphere_combine),
            sphere_fit: Some(&self.sphere_fit),
            part_combine: Some(&self.part_combine),
            sphere_order: Some(self.sphere_order),
            k_count: Some(self.k_count),
        }
    }

    /// Receiver points: `receivers` per radius on the grid, `receivers` in all when continuous.
    pub(super) fn receiver_count(&self) -> usize {
        if self.receiver_layout == CONTINUOUS {
            self.receivers
        } else {
            self.receivers * self.radii.len()
        }
    }

    /// The receiver radii's extremes (the k-table's range): `radii`, or [`rho_min`, `rho_max`].
    pub(super) fn radius_span(&self) -> Vec<f64> {
        if self.receiver_layout == CONTINUOUS {
            vec![self.rho_min, self.rho_max]
        } else {
            self.radii.clone()
        }
    }

    /// The receiver layout's keys checked ([`check_layout`]).
    pub(super) fn check_receivers(&self) -> Result<(), KeyError> {
        let d = Params::default();
        check_layout(
            &self.receiver_layout,
            self.radii == d.radii,
            (self.rho_min, self.rho_max),
            (d.rho_min, d.rho_max),
        )
    }

    /// The method, parsed (the unread-key rule against the defaults).
    pub(crate) fn spec(&self) -> Result<Spec, KeyError> {
        let rt_max = shscale_field::truth::MAX_TRUTH_RES;
        Spec::parse(&self.keys(), &Params::default().keys(), rt_max)
    }
}
