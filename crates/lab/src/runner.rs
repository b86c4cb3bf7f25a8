//! Per-run outputs shared by the experiment kinds and the figures: the papers' Fig. 5 image of
//! one probe run. The runner itself is [`crate::exp::runner`].

use crate::LabError;
use shscale_geometry::Occluder;
use std::path::Path;

pub use crate::exp::runner::write_atomic;

/// The papers' Fig. 5 for one run: per probe radius (rows), the ray-traced full-frequency
/// visibility (left) and the extrapolated band-limited visibility (right) at one probe point,
/// lat-long maps in the entity frame (row 0 = +z), written as EXR + PNG.
pub fn visibility_figure(
    dir: &Path,
    run_id: &str,
    order: usize,
    occ: &dyn Occluder,
    examples: &[shscale_field::probe::ProbeExample],
) -> Result<(), LabError> {
    const W: usize = 256;
    const H: usize = 128;
    if examples.is_empty() {
        return Ok(());
    }
    let basis =
        shscale_sh::ShBasis::<f64>::new(order).map_err(|e| LabError::Config(e.to_string()))?;
    let set = shscale_sh::DirectionSet::latlong(H, W);
    let mut px = vec![[0f32; 3]; 2 * W * H * examples.len()];
    let mut y = vec![0.0; order * order];
    for (row, ex) in examples.iter().enumerate() {
        let truth = shscale_field::truth::visibility_map(occ, ex.point, W, H);
        for j in 0..H {
            for i in 0..W {
                let base = (row * H + j) * 2 * W;
                let t = truth[j * W + i];
                px[base + i] = [t; 3];
                basis.eval(set.dirs[j * W + i], &mut y);
                let v: f64 = ex.extrapolated.iter().zip(&y).map(|(a, b)| a * b).sum();
                px[base + W + i] = [v as f32; 3];
            }
        }
    }
    let exr = dir.join(format!("visibility_{run_id}.exr"));
    crate::io::write_exr_and_png(&exr, 2 * W, H * examples.len(), &px, crate::io::Png::Unit)
        .map(|_| ())
}
