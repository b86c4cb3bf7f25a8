//! Typed errors of the SH core.

use thiserror::Error;

/// What can go wrong when calling into the SH core with user-supplied values.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ShError {
    /// The order is 0 or above `MAX_ORDER` (the `index` module).
    #[error("order {order} is outside the supported range 1..={max}")]
    Order { order: usize, max: usize },
    /// A coefficient vector does not have `N²` entries.
    #[error("expected {expected} coefficients (order {order} squared), got {got}")]
    CoeffCount {
        order: usize,
        expected: usize,
        got: usize,
    },
    /// A direction is zero, too short to normalise, or not finite.
    #[error("direction ({x}, {y}, {z}) cannot be normalised (zero length or not finite)")]
    Direction { x: f64, y: f64, z: f64 },
    /// An angle is outside its domain.
    #[error("{name} = {value} is outside its domain {domain}")]
    Domain {
        name: &'static str,
        value: f64,
        domain: &'static str,
    },
    /// Lengths of parallel slices disagree.
    #[error("{what}: lengths differ ({a} vs {b})")]
    Length {
        what: &'static str,
        a: usize,
        b: usize,
    },
}
