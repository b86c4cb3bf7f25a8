//! The image helpers the scene kinds share (`shadows`, `budget_plane`): a render's pixels as
//! numbers, a truth's own error, luminance, and the irradiance figure of the receiver plane
//! (images on one scale, differences from the truth below them).

use shscale_scene::render::RenderOutput;
use shscale_scene::Error;
use std::path::Path;

/// A render's pixels flattened, RGB per receiver.
pub(crate) fn flat(img: &RenderOutput) -> Vec<f64> {
    img.pixels.iter().flat_map(|p| p.map(f64::from)).collect()
}

/// A truth's own error: RMS over receivers and channels of its per-pixel estimate `e`, over the
/// mean unshadowed irradiance (NaN where the render has no estimate).
pub(crate) fn own_err(e: &[[f32; 3]], mean_open: f64) -> f64 {
    let ms = e
        .iter()
        .flat_map(|p| p.map(|v| (v as f64) * (v as f64)))
        .sum::<f64>()
        / (3 * e.len()).max(1) as f64;
    if mean_open > 0.0 && !e.is_empty() {
        ms.sqrt() / mean_open
    } else {
        f64::NAN
    }
}

/// Mean of the three channels per pixel.
pub(crate) fn lum(pixels: &[[f32; 3]]) -> Vec<f32> {
    pixels.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).collect()
}

/// An irradiance figure of the receiver plane: the images `top` (title, luminance) on one heat
/// scale, then below each of `methods` (name, luminance) its difference from `truth` on a
/// symmetric diverging scale, its RMS in the title. Panels `px` pixels square; `axes` the x and
/// y ranges with their labels.
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_irradiance_figure(
    png: &Path,
    (w, h): (usize, usize),
    (x, y): ((f64, f64, &str), (f64, f64, &str)),
    title: &str,
    top: Vec<(String, Vec<f32>)>,
    truth: &[f32],
    methods: Vec<(String, Vec<f32>)>,
    px: u32,
) -> Result<(), Error> {
    use shscale_present::figure::{ColourMap, Grid, Panel};
    let max = (top.iter().flat_map(|(_, v)| v)).fold(0f32, |a, v| a.max(*v)) as f64;
    let diffs: Vec<(String, Vec<f32>)> = (methods.into_iter())
        .map(|(n, v)| (n, v.iter().zip(truth).map(|(a, t)| a - t).collect()))
        .collect();
    let dmax = (diffs.iter().flat_map(|(_, v)| v)).fold(0f32, |a, v| a.max(v.abs())) as f64;
    let rms = |e: &[f32]| {
        (e.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / e.len().max(1) as f64).sqrt()
    };
    let panel = |title: String, values: Vec<f32>| Panel {
        title,
        width: w,
        height: h,
        values,
    };
    let images = Grid {
        title,
        rows: vec![top.into_iter().map(|(t, v)| panel(t, v)).collect()],
        x,
        y,
        colours: ColourMap::Heat,
        range: (0.0, max),
        scale_label: "irradiance (scene radiance units)",
        panel_px: (px, px),
    };
    let differences = Grid {
        title: "difference from the full-frequency truth",
        rows: vec![(diffs.into_iter())
            .map(|(n, d)| panel(format!("{n} − truth (RMS {:.3})", rms(&d)), d))
            .collect()],
        x,
        y,
        colours: ColourMap::Diverging,
        range: (-dmax, dmax),
        scale_label: "irradiance difference",
        panel_px: (px, px),
    };
    Ok(shscale_present::figure::write_png_stack(
        png,
        &[images, differences],
    )?)
}
