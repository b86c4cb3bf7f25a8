//! What several kinds share: the cost model of computing two scaling matrices, and writing a
//! text file into a figure's folder.

use shscale_scene::Error;
use std::path::{Path, PathBuf};

/// The cost of a run that computes the plain and the energy matrix of one τ at `order` by
/// adaptive quadrature (≈ 2e-4 s per element at N = 4 here; extreme k need more panels).
pub(crate) fn two_matrices_cost(order: usize) -> (shscale_runner::Cost, shscale_runner::Cost) {
    let nn = (order * order) as f64;
    (
        shscale_runner::Cost::default(),
        shscale_runner::Cost {
            bytes: nn * nn * 8.0 * 4.0,
            seconds: 2.0 * 2e-4 * nn * nn,
            drivers: format!("order = {order} → 2 matrices of {nn}² elements"),
            ..shscale_runner::Cost::default()
        },
    )
}

/// Write `text` to `out/name` atomically and return the path.
pub(crate) fn write_text(out: &Path, name: &str, text: &str) -> Result<PathBuf, Error> {
    let p = out.join(name);
    shscale_runner::write_atomic(&p, text)?;
    Ok(p)
}
