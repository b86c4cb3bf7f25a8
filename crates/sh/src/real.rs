//! The floating-point abstraction the SH routines are generic over (`f32`, `f64`).

use num_traits::Float;

/// A floating-point scalar: `f32` or `f64`. Constants are formed in `f64` and rounded once by
/// [`Real::c`], so both precisions share one set of recurrence tables.
pub trait Real: Float + Default + Send + Sync + std::fmt::Debug + std::iter::Sum + 'static {
    /// Round an `f64` constant to this precision.
    fn c(x: f64) -> Self;
    /// Widen to `f64` (exact for both implementors).
    fn f64(self) -> f64;
}

impl Real for f64 {
    #[inline(always)]
    fn c(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self
    }
}

impl Real for f32 {
    #[inline(always)]
    fn c(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self as f64
    }
}
