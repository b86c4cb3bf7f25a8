//! What a method costs per frame — rays, bytes held and the cost model's seconds — for the
//! budget kinds' columns and `--dry-run` estimates (docs/methods.md, "Rays, bytes and time").
//! The rates are the development VM's; `--dry-run` scales them by the running machine's
//! measured ray rate.

use crate::combine::Combine;
use crate::method::{Extrapolation, Spec, SPHERE_QUADRATURE_RES};
use shscale_field::bsv::{Layout, RadialRule, OCCLUSION_STEPS};

/// The cost model's time per receiver of [`Combine::Union`] on the 2-core development VM
/// (both threads): a fixed part (the frame, the rotation back) and a part per sphere, from
/// one thread's 2.1 / 3.1 / 5.6 / 8.4 µs at S = 2 / 8 / 32 / 64, N = 4, 32 rings.
pub(crate) const UNION_SECONDS: f64 = 0.9e-6;
pub(crate) const UNION_SPHERE_SECONDS: f64 = 0.05e-6;

/// The cost model's time per receiver of [`Combine::Shexp`] on the 2-core development VM (both
/// threads), per sphere (a table lookup and a zonal rotation) and per receiver (the HYB
/// exponential: its squarings are truncated products, about `(N/4)⁵` times an order-4 one's).
pub(crate) const SHEXP_SECONDS: f64 = 1.0e-6;
pub(crate) const SHEXP_SPHERE_SECONDS: f64 = 0.05e-6;

/// The cost model's time of one base-sphere sample's product-algebra log (an N² × N²
/// eigenproblem, one thread) at N = 4, growing as `(N/4)⁶`: 43 µs from `part_combine = "shexp"`
/// at P = 16 in `configs/experiments/subvolumes_log.toml` (2.4 ms at N = 8) on the development
/// VM.
pub(crate) const LOG_SAMPLE_SECONDS: f64 = 43e-6;

/// The cost model's time per receiver of a sphere set, per sphere (a cap's projection and
/// rotation and a truncated product at N = 4): 0.36 µs on spherical receivers, 0.57–0.63 µs on
/// the plane, at S = 16 and 64 in `configs/experiments/budget.toml` and `budget_plane.toml`
/// on the development VM.
pub const SPHERE_SECONDS: f64 = 5e-7;

/// The cost model's time of the quadrature combination: per direction and receiver, and per
/// ray–sphere test, fitted to `sphere_combine = "quadrature"` in `configs/experiments/
/// budget.toml` (S = 2 / 16 / 64: 0.06 / 0.17 / 0.60 s per frame of 1,200 receivers) on the
/// development VM.
pub const SPHERE_DIRECTION_SECONDS: f64 = 4.3e-9;
pub const SPHERE_TEST_SECONDS: f64 = 0.9e-9;

impl Spec {
    /// Rays of one frame for `occluders` occluders and `receivers` receivers: the base-sphere
    /// samples' hemispheres (× the occlusion rule's search steps, × the parts of sub-volumes),
    /// the full field's shells of them, `4T²` per receiver and occluder for ray tracing, the
    /// quadrature's `2Q²` directions per receiver for sphere sets combined by quadrature (0 by
    /// products).
    pub fn rays(&self, occluders: f64, receivers: f64) -> f64 {
        let bsv = |e: &Extrapolation| {
            let search = match e.radial {
                RadialRule::Occlusion { .. } => (2 + OCCLUSION_STEPS) as f64,
                _ => 1.0,
            };
            search * samples(e.layout) * (e.hemisphere_res * e.hemisphere_res) as f64
        };
        occluders
            * match self {
                Spec::Extrapolated(e) => bsv(e),
                Spec::SubVolumes { parts, ex, .. } => *parts as f64 * bsv(ex),
                Spec::FullField(f) => {
                    f.count as f64
                        * samples(f.layout)
                        * (f.hemisphere_res * f.hemisphere_res) as f64
                }
                Spec::RayTraced { rt_res } => receivers * 4.0 * (rt_res * rt_res) as f64,
                Spec::SphereSet {
                    combine: Combine::Quadrature,
                    ..
                } => receivers * (2 * SPHERE_QUADRATURE_RES * SPHERE_QUADRATURE_RES) as f64,
                Spec::SphereSet { .. } => 0.0,
            }
    }

    /// Bytes the method holds at order N for `occluders` occluders, `k_count` table entries
    /// where the spec leaves them to the scene: N² doubles per base-sphere sample and k_count
    /// N × N-doubles matrices per table (per part for sub-volumes), N² doubles per sample per
    /// shell, 32 bytes per sphere; nothing for ray tracing.
    pub fn memory_bytes(&self, order: usize, occluders: f64, k_count: usize) -> f64 {
        let nn = (order * order) as f64;
        let ex = |e: &Extrapolation| {
            samples(e.layout) * nn * 8.0 + e.k_count.unwrap_or(k_count) as f64 * nn * nn * 8.0
        };
        occluders
            * match self {
                Spec::Extrapolated(e) => ex(e),
                Spec::SubVolumes { parts, ex: e, .. } => *parts as f64 * ex(e),
                Spec::FullField(f) => f.count as f64 * samples(f.layout) * nn * 8.0,
                Spec::SphereSet { parts, .. } => *parts as f64 * 32.0,
                Spec::RayTraced { .. } => 0.0,
            }
    }

    /// Seconds of one frame for the cost model: `rays` at `rays_per_second`, plus per receiver
    /// [`SPHERE_SECONDS`] per sphere for sphere sets by products; the quadrature's rays meet
    /// spheres, not a mesh, and are priced per direction ([`SPHERE_DIRECTION_SECONDS`]) and
    /// sphere test ([`SPHERE_TEST_SECONDS`]) instead.
    ///
    /// At an internal order M above 4 a sphere's time grows with its product's Gaunt entries,
    /// about `0.2·M⁵` (194 at M = 4, 51,814 at 12, 222,376 at 16): `(M/4)⁵` times
    /// [`SPHERE_SECONDS`].
    pub fn seconds(&self, order: usize, rays: f64, receivers: f64, rays_per_second: f64) -> f64 {
        // A truncated product's work at order M, against one at 4: its Gaunt entries, ~(M/4)⁵.
        let product_work = |m: usize| (m as f64 / 4.0).powi(5).max(1.0);
        match *self {
            Spec::SphereSet {
                parts,
                combine: Combine::Quadrature,
                ..
            } => rays * (SPHERE_DIRECTION_SECONDS + parts as f64 * SPHERE_TEST_SECONDS),
            Spec::SphereSet {
                parts,
                combine: Combine::Union,
                ..
            } => receivers * (UNION_SECONDS + parts as f64 * UNION_SPHERE_SECONDS),
            Spec::SphereSet {
                parts,
                combine: Combine::Shexp,
                ..
            } => {
                receivers
                    * (SHEXP_SECONDS * product_work(order) + parts as f64 * SHEXP_SPHERE_SECONDS)
            }
            Spec::SphereSet {
                parts,
                internal_order,
                ..
            } => {
                let work = product_work(internal_order.max(order));
                rays / rays_per_second + receivers * parts as f64 * SPHERE_SECONDS * work
            }
            // The parts' logs cost about what their visibilities do; the exponential is added.
            Spec::SubVolumes {
                combine: Combine::Shexp,
                parts,
                ex,
            } => {
                let logs = parts as f64
                    * samples(ex.layout)
                    * LOG_SAMPLE_SECONDS
                    * (order as f64 / 4.0).powi(6);
                rays / rays_per_second + receivers * SHEXP_SECONDS * product_work(order) + logs
            }
            _ => rays / rays_per_second,
        }
    }
}

/// Base-sphere samples of a layout (0 for one without a count).
fn samples(l: Layout) -> f64 {
    l.sample_count().unwrap_or(0) as f64
}
