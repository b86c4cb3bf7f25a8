//! The errors of the field crate.

/// Errors of the field crate.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum FieldError {
    /// A layout string or parameter is invalid.
    #[error("{0}")]
    Spec(String),
    /// An SH-core error (order).
    #[error(transparent)]
    Sh(#[from] shscale_sh::ShError),
    /// A scaling-operator error (τ, k, order, k-table).
    #[error(transparent)]
    Scaling(#[from] shscale_scaling::ScalingError),
}
