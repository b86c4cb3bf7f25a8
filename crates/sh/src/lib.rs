//! Real orthonormal spherical harmonics (SH) for any order: evaluation, quadrature, projection,
//! rotation, products, the clamped-cosine lobe and spherical caps.
//!
//! Conventions (binding, `docs/conventions.md`): order `N` means bands `l = 0..N-1` and `N²`
//! coefficients; coefficient index `i = l·l + l + m`; θ is the polar angle from +z, φ the azimuth
//! from +x toward +y; the basis is the papers' real orthonormal SH with associated Legendre
//! functions *without* the Condon–Shortley phase, so `Y_1^{-1}, Y_1^0, Y_1^1 = √(3/4π)·(y, z, x)`.
//!
//! Everything numeric is generic over [`Real`] (`f32`, `f64`); recurrence coefficients are always
//! formed in `f64` and rounded once.

pub mod cap;
pub mod cpu;
pub mod error;
pub mod eval;
pub mod gaunt;
pub mod index;
pub mod legendre;
pub mod lobe;
pub mod project;
pub mod quadrature;
pub mod real;
pub mod rotation;
pub mod simd;
pub mod store;

pub use cap::{cap_coeffs, cap_zonal};
pub use error::ShError;
pub use eval::ShBasis;
pub use gaunt::GauntTensor;
pub use index::{check_coeffs, check_order, coeff_count, order_of_len, sh_index, sh_lm, MAX_ORDER};
pub use lobe::{clamped_cosine_zonal, irradiance, ClampedCosine};
pub use project::{dot, project_fn, project_samples, reconstruct};
pub use quadrature::{tile_order, DirectionSet, GaussLegendre};
pub use real::Real;
pub use rotation::{euler_zyz, rotate_zonal, EulerRotator, ShRotation, ShRotator};
