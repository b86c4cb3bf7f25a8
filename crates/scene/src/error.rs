//! The error of scenes and of the experiment kinds built on them: the runner's (config and file
//! errors, which name the culprit) or one of the numerical crates' and the GPU's, carried as they
//! are (never flattened into a config string on the way up). At the runner's seam it becomes a [`shscale_runner::Error`].

use std::path::Path;

/// Errors of scenes, rendering and the kinds.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Runner(#[from] shscale_runner::Error),
    #[error(transparent)]
    Geometry(#[from] shscale_geometry::GeometryError),
    #[error(transparent)]
    Field(#[from] shscale_field::FieldError),
    #[error(transparent)]
    Gpu(#[from] shscale_gpu::GpuError),
    #[error(transparent)]
    Sh(#[from] shscale_sh::ShError),
    #[error(transparent)]
    Scaling(#[from] shscale_scaling::ScalingError),
}

impl Error {
    /// A config, parameter or input problem, in words that name the culprit.
    pub fn config(message: String) -> Self {
        Self::Runner(shscale_runner::Error::Config(message))
    }

    /// A file that could not be read or written, named.
    pub fn io(path: &Path, e: impl std::fmt::Display) -> Self {
        Self::Runner(shscale_runner::Error::io(path, e))
    }
}

/// A file error of the ground floor, as the runner's (named the same way).
impl From<shscale_files::Error> for Error {
    fn from(e: shscale_files::Error) -> Self {
        Self::Runner(e.into())
    }
}

/// A presentation error (a figure that cannot be drawn, a file), as the runner's.
impl From<shscale_present::Error> for Error {
    fn from(e: shscale_present::Error) -> Self {
        Self::Runner(e.into())
    }
}

impl From<Error> for shscale_runner::Error {
    fn from(e: Error) -> Self {
        match e {
            Error::Runner(r) => r,
            other => shscale_runner::Error::Kind(Box::new(other)),
        }
    }
}
