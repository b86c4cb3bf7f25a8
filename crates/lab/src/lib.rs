//! The lab: what touches files and configs. Scene files (TOML, raw → resolved, every error naming
//! the file, line and field), rendering a scene's receiver plane with any of the visibility
//! evaluators, and image outputs (EXR with a PNG preview) written atomically (temporary file, then
//! rename). The numerical crates stay free of files and configs.

pub mod bench;
pub mod camera;
pub mod exp;
pub mod figure;
pub mod gpu_path;
pub mod io;
pub mod kernels;
pub mod limits;
pub mod plots;
pub mod render;
pub mod runner;
pub mod scene;
pub mod vocab;

/// Errors of the lab.
/// A TOML parse error of `file` (whose text is `text`) as a [`LabError::Config`] naming the file,
/// the line and — when the message does not already — the field written on that line.
pub fn toml_error(file: &str, text: &str, e: &toml::de::Error) -> LabError {
    let line = e.span().map_or(0, |s| {
        text[..s.start.min(text.len())].matches('\n').count() + 1
    });
    let msg = e.message().trim();
    let key = text
        .lines()
        .nth(line.saturating_sub(1))
        .and_then(|l| l.split_once('='))
        .map(|(k, _)| k.trim())
        .filter(|k| line > 0 && !k.is_empty() && !msg.contains(k));
    match key {
        Some(k) => LabError::Config(format!("{file}:{line}: {k}: {msg}")),
        None => LabError::Config(format!("{file}:{line}: {msg}")),
    }
}

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
