//! Image files: EXR (linear RGB, f32) and PNG previews, written to a temporary file in the target
//! directory and renamed into place, so an interrupted run never leaves a partial image under the
//! final name; and lat-long EXR environment maps read back.

use crate::LabError;
use std::path::{Path, PathBuf};

fn tmp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> LabError {
    LabError::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

/// Write `pixels` (row-major, row 0 at the top) as a float RGB EXR, atomically. Compressed on one
/// thread so the bytes are reproducible (parallel compression writes chunks in completion order).
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), LabError> {
    assert_eq!(pixels.len(), width * height);
    let tmp = tmp_path(path);
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let p = pixels[pos.y() * width + pos.x()];
        (p[0], p[1], p[2])
    });
    Image::from_channels((width, height), channels)
        .write()
        .non_parallel()
        .to_file(&tmp)
        .map_err(|e| io_err(path, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}

/// Write an 8-bit PNG of values in [0, 1] mapped linearly (clamped) — for visibility, where 1 must
/// read as white. Atomic like [`write_exr`].
pub fn write_png_unit(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), LabError> {
    // Exposure 1 with the identity tone map: the preview writer with a pre-scaled copy would
    // renormalise, so encode directly.
    write_png_bytes(
        path,
        width,
        height,
        pixels
            .iter()
            .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
            .collect(),
    )
}

/// Write an 8-bit sRGB-ish PNG preview: exposure normalised to the mean luminance, Reinhard
/// `x/(1+x)`, gamma 1/2.2. Atomic like [`write_exr`].
pub fn write_png_preview(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), LabError> {
    let mean = pixels
        .iter()
        .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum::<f64>()
        / pixels.len().max(1) as f64;
    let exposure = if mean > 0.0 { 0.5 / mean } else { 1.0 };
    let data: Vec<u8> = pixels
        .iter()
        .flat_map(|p| {
            p.map(|v| {
                let x = (v.max(0.0) as f64) * exposure;
                ((x / (1.0 + x)).powf(1.0 / 2.2) * 255.0)
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
        })
        .collect();
    write_png_bytes(path, width, height, data)
}

/// Read the first RGBA layer of an EXR as `(width, height, rgb)`, row 0 at the top.
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), LabError> {
    let img = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| {
            (
                res.width(),
                res.height(),
                vec![[0f32; 3]; res.width() * res.height()],
            )
        },
        |px: &mut (usize, usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = px.0;
            px.2[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| io_err(path, e))?;
    Ok(img.layer_data.channel_data.pixels)
}

fn write_png_bytes(
    path: &Path,
    width: usize,
    height: usize,
    data: Vec<u8>,
) -> Result<(), LabError> {
    let tmp = tmp_path(path);
    {
        let file = std::fs::File::create(&tmp).map_err(|e| io_err(path, e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| io_err(path, e))?;
        w.write_image_data(&data).map_err(|e| io_err(path, e))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}
