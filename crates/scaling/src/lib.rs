//! SH scaling (Wang et al., "Spherical Harmonics Scaling", Sec. 2; docs/conventions.md §3): angular scaling
//! functions τ, the sparse scaling matrices `M` they induce on SH coefficient vectors, and tables
//! of `M_k` over the scale parameter `k` with interpolation.
//!
//! `S_d = M · S_r`, `M_ij = ∫∫ Ψ_j(τ(θ), φ) Ψ_i(θ, φ) η(θ) dθ dφ`, `η = sinθ` (plain, visibility) or
//! `η = sin τ(θ) · τ′(θ)` (energy preserving, radiance). The φ-integral is analytic, so `M` is
//! block diagonal in `m` with identical `±m` blocks, and each block is a 1-D θ-integral
//! ([`matrix`]). The crate knows nothing of meshes, configs or files.

pub mod alpha_law;
pub mod error;
pub mod matrix;
pub mod quad;
pub mod table;
pub mod tau;

pub use error::ScalingError;
pub use matrix::{
    distinct_count, structural_nonzeros, EnergyForm, Eta, QuadOptions, ScalingMatrix,
};
pub use quad::QuadReport;
pub use table::{Interp, KLookup, KTable, Spacing, TauFamily};
pub use tau::{AngularScaling, Cone, Identity, MidRange, Tabulated};
