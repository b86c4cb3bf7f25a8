//! The errors of the gpu crate.

/// Errors of the GPU path.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter: no GPU and no software device (install `mesa-vulkan-drivers` for lavapipe).
    #[error(
        "no GPU adapter found (install mesa-vulkan-drivers for the lavapipe software device): {0}"
    )]
    NoAdapter(String),
    #[error("GPU device request failed: {0}")]
    Device(String),
    #[error("GPU input: {0}")]
    Input(String),
    #[error("GPU readback failed: {0}")]
    Readback(String),
}
