//! Per-run outputs shared by the experiment kinds and the figures: the papers' Fig. 5 image of
//! one probe run. The runner itself is [`crate::exp::runner`].

use crate::LabError;
use shscale_geometry::Occluder;
use std::path::Path;

pub use crate::exp::runner::write_atomic;

/// The papers' Fig. 5 for one run: per probe radius (rows), the ray-traced full-frequency
/// visibility (left) and the extrapolated band-limited visibility (right) at one probe point,
/// lat-long maps in the entity frame (row 0 = +z). Written as
/// `visibility_truth_vs_extrapolated_<run id>.exr` (the values, both columns side by side) and a
/// `.png` with labelled panels (what each shows, the radius and the point's direction), φ/θ axes
/// in degrees and a grey-scale bar (0 occluded … 1 visible; extrapolated values outside [0, 1]
/// are clipped in the picture, not in the EXR).
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
    let mut rows = Vec::new();
    let mut y = vec![0.0; order * order];
    let centre = occ.bounding_sphere().center;
    for (row, ex) in examples.iter().enumerate() {
        let truth = shscale_field::truth::visibility_map(occ, ex.point, W, H);
        let mut extrapolated = vec![0f32; W * H];
        for j in 0..H {
            for i in 0..W {
                let base = (row * H + j) * 2 * W;
                let t = truth[j * W + i];
                px[base + i] = [t; 3];
                basis.eval(set.dirs[j * W + i], &mut y);
                let v: f64 = ex.extrapolated.iter().zip(&y).map(|(a, b)| a * b).sum();
                px[base + W + i] = [v as f32; 3];
                extrapolated[j * W + i] = v as f32;
            }
        }
        let d = (ex.point - centre).normalize_or_zero();
        let where_ = format!(
            "{}r, at θ = {:.0}°, φ = {:.0}°",
            ex.radius,
            d.z.clamp(-1.0, 1.0).acos().to_degrees(),
            d.y.atan2(d.x).to_degrees().rem_euclid(360.0)
        );
        rows.push(vec![
            crate::figure::Panel {
                title: format!("ray-traced (full frequency), {where_}"),
                width: W,
                height: H,
                values: truth.clone(),
            },
            crate::figure::Panel {
                title: format!("extrapolated (SH order {order}), {where_}"),
                width: W,
                height: H,
                values: extrapolated,
            },
        ]);
    }
    let exr = dir.join(format!("visibility_truth_vs_extrapolated_{run_id}.exr"));
    crate::io::write_exr(&exr, 2 * W, H * examples.len(), &px)?;
    crate::figure::write_png(
        &exr.with_extension("png"),
        &crate::figure::Grid {
            title:
                "visibility at the probe radii: ray-traced vs extrapolated from the bounding sphere",
            rows,
            x: (0.0, 360.0, "azimuth φ (°)"),
            y: (0.0, 180.0, "polar angle θ from +z (°)"),
            colours: crate::figure::ColourMap::Grey,
            range: (0.0, 1.0),
            scale_label: "visibility (1 = unoccluded)",
            panel_px: (384, 192),
        },
    )
}
