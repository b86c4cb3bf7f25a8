//! The equal-budget study: for the rays, bytes and time a frame allows, which method is most
//! accurate — on spherical receivers ([`spheres`], the kind `budget`) and on a scene's receiver
//! plane in image space ([`plane`], the kind `budget_plane`). Both kinds parse their method keys
//! once into the one vocabulary ([`shscale_scene::method::Spec`]: the keys each method reads,
//! its rays, bytes and cost-model time); the frames of spherical receivers are built in
//! [`frames`]; the verdicts (Pareto fronts, the papers' speed claim, equal accuracy per regime)
//! are computed from the rows in [`verdict`].
//!
//! | module | what it owns | imports (inside the folder) |
//! |---|---|---|
//! | `verdict` | configurations, fronts, the claim, equal accuracy, names in words | — |
//! | `frames` | one frame of each method on spherical receivers | — |
//! | `spheres` | the kind `budget` | `frames`, `receivers`, `surface`, `verdict` |
//! | `receivers` | the continuous layout's radii and keys, the occluder's orientation seeds, the plane's receivers by distance to the surface | `surface` (the bins) |
//! | `surface_tests` | the continuous verdict on tables whose answers are known (tests only) | `spheres`, `surface`, `verdict` |
//! | `surface` | the verdict and figures of receivers at every distance: distance bins, seed intervals, per-method fronts | `verdict` |
//! | `plane` | the kind `budget_plane` | `plane_images`, `receivers`, `surface`, `verdict` |
//! | `plane_images` | the plane's image measures (flicker, RMSE over a subset) and its figure | `verdict` |

mod frames;
pub mod plane;
mod plane_images;
mod plane_params;
mod plane_report;
mod plane_rows;
mod plane_timings;
mod receivers;
pub mod spheres;
mod spheres_params;
mod spheres_report;
mod spheres_rows;
mod stats;
mod surface;
#[cfg(test)]
mod surface_tests;
mod verdict;

pub use stats::{mean_ci95, pareto};

/// The near regime: receivers within 1.3 bounding radii (of the occluder's centre).
pub(crate) const NEAR_RHO: f64 = 1.3;
