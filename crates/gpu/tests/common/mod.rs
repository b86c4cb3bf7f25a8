//! What the GPU tests share: the adapter, or a notice and a skip.

use shscale_gpu::{require_gpu_from_env, GpuContext};

/// The adapter; without one a notice and `None` (the test returns), unless
/// `SHSCALE_REQUIRE_GPU=1` (CI, Mesa lavapipe), where it fails.
pub fn ctx() -> Option<GpuContext> {
    match GpuContext::new() {
        Ok(c) => {
            eprintln!("GPU adapter: {}", c.describe());
            Some(c)
        }
        Err(e) if require_gpu_from_env() => panic!("SHSCALE_REQUIRE_GPU=1 but {e}"),
        Err(e) => {
            eprintln!("SKIPPED (no GPU adapter: {e}); set SHSCALE_REQUIRE_GPU=1 to fail instead");
            None
        }
    }
}
