//! Typed errors of the scaling crate.

use thiserror::Error;

/// What can go wrong when building scaling functions, matrices or tables.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ScalingError {
    /// A parameter is outside its domain.
    #[error("{name} = {value} is outside its domain: {domain}")]
    Domain {
        name: &'static str,
        value: f64,
        domain: &'static str,
    },
    /// Tabulated τ samples are unusable.
    #[error("tabulated τ: {0}")]
    Tabulated(String),
    /// A table specification is unusable.
    #[error("k-table: {0}")]
    Table(String),
    /// Error from the SH core (order, coefficient count).
    #[error(transparent)]
    Sh(#[from] shscale_sh::ShError),
}
