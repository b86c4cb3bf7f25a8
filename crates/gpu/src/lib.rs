//! The wgpu real-time path (docs/conventions.md §9, `crates/gpu`): per frame, a deforming entity's BSV is
//! sampled by ray casting a flattened BVH on the GPU, projected to SH on the GPU, and every
//! receiver of the plane is shaded on the GPU from those coefficients — the three stages of the
//! papers' Table 1 (BSV sampling, SH conversion, shadowing), each timed by timestamp queries.
//!
//! The stages mirror the CPU path one to one so their results can be compared (parity tests):
//! - [`sampling`] ↔ `shscale_field::VisibilitySampler::facing_hemisphere` over every base-sphere
//!   sample (same Gauss hemisphere directions, same local frames, same ray offset);
//! - [`sampling`] projection ↔ the quadrature sum of the same routine, plus the closed-form back
//!   hemisphere;
//! - [`shading`] ↔ `shscale_field::receivers::ReceiverCache::shade`, and its setup
//!   (`U = R M_kᵀ Rᵀ T` per receiver: k-table scaling and both rotations) ↔
//!   `ReceiverCache::build` — only the point location in the spherical triangulation stays on the
//!   host;
//! - [`sphereset`] ↔ `shscale_field::sphereset` (the chain) and `shscale_field::union` (the
//!   exact union of the caps) over a sphere set fitted on the host;
//! - [`field`] ↔ `shscale_field::evaluator::FullField` (its shells sampled by the two stages
//!   above, each receiver shaded from its interpolation weights);
//! - [`radial`] ↔ `shscale_field::Bsv::sample_radial` with clearance radii and the receiver
//!   cache with each receiver's `k = d / r(q)`;
//! - [`parts`] ↔ `shscale_field::subvolume::SubVolumeField` (every part sampled alone,
//!   extrapolated per receiver, the parts multiplied near to far);
//! - [`pose`] ↔ `shscale_geometry::deform` and [`bvh::FlatBvh`]'s refit (the frame's pose and
//!   the tree's boxes on the device, the host rebuilding when its rule says so).
//!
//! Precision: everything on the GPU is f32 (the CPU path ray casts in f32 too, through obvhs, and
//! projects in f64). GPU orders are limited to `N ≤ 8` ([`MAX_GPU_ORDER`]): the projection keeps
//! `N²` accumulators per invocation and reduces them through 16 KiB of workgroup memory.
//!
//! This crate never decides what to do without an adapter: [`GpuContext::new`] returns
//! [`GpuError::NoAdapter`] and the caller (`shscale-scene` or the CLI) prints the notice and goes on with
//! the CPU path, or fails when a GPU is required.

pub mod bvh;
pub mod context;
pub mod error;
pub mod field;
pub mod fit;
pub mod layout;
pub mod parts;
pub mod pose;
pub mod radial;
pub mod sampling;
pub mod sequence;
pub mod shading;
pub mod sphereset;
pub mod timing;

pub use context::{require_gpu_from_env, GpuContext};
pub use sequence::{GpuSequence, GpuStageTimes, Receivers};
pub use shading::ReceiverSetup;

pub use sampling::MAX_GPU_ORDER;

pub use error::GpuError;
