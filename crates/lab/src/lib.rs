//! The lab: what touches files and configs. Scene files (TOML, raw → resolved, every error naming
//! the file, line and field), rendering a scene's receiver plane with any of the visibility
//! evaluators, and image outputs (EXR with a PNG preview) written atomically (temporary file, then
//! rename). The numerical crates stay free of files and configs.

pub mod bench;
pub mod experiment;
pub mod gpu_path;
pub mod io;
pub mod plots;
pub mod render;
pub mod runner;
pub mod scene;

/// Errors of the lab.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    #[error("{0}")]
    Config(String),
    #[error("{path}: {reason}")]
    Io { path: String, reason: String },
    #[error(transparent)]
    Geometry(#[from] shscale_geometry::GeometryError),
    #[error(transparent)]
    Field(#[from] shscale_field::FieldError),
    #[error(transparent)]
    Gpu(#[from] shscale_gpu::GpuError),
}
