//! Image files: EXR (linear RGB, f32) and PNG previews, written to a temporary file in the target
//! directory and renamed into place, so an interrupted run never leaves a partial image under the
//! final name; an EXR and its PNG are written as a unit ([`write_exr_and_png`]): both temporaries
//! first, renamed only when both succeeded, temporaries removed on every error path. Lat-long EXR
//! environment maps are read back with their header checked before any pixel is allocated
//! ([`MAX_IMAGE_SIDE`], [`MAX_IMAGE_PIXELS`]) and every pixel checked finite and ≥ 0 (up to
//! [`NEGATIVE_TOLERANCE`] of ringing, clamped).

use crate::error::Error;
use shscale_files::atomic::tmp_path;
use std::path::{Path, PathBuf};

/// The largest side of an image read or written, in pixels.
pub const MAX_IMAGE_SIDE: usize = 16_384;
/// The most pixels of an image read or written (2²⁶: 768 MiB of f32 RGB).
pub const MAX_IMAGE_PIXELS: usize = 1 << 26;

fn check_dims(path: &Path, width: usize, height: usize) -> Result<(), Error> {
    if width == 0
        || height == 0
        || width > MAX_IMAGE_SIDE
        || height > MAX_IMAGE_SIDE
        || width * height > MAX_IMAGE_PIXELS
    {
        return Err(crate::error::Error::io(
            path,
            format!(
                "{width}×{height} pixels: each side must be 1..={MAX_IMAGE_SIDE} and the image at most {MAX_IMAGE_PIXELS} pixels"
            ),
        ));
    }
    Ok(())
}

/// Refuse to write over a directory (renaming onto one fails only after the work is done).
fn check_target(path: &Path) -> Result<(), Error> {
    if path.is_dir() {
        return Err(crate::error::Error::io(path, "is a directory"));
    }
    Ok(())
}

/// Run `write` on the temporary path of `path`; the temporary is removed if it fails.
fn to_tmp(path: &Path, write: impl FnOnce(&Path) -> Result<(), Error>) -> Result<PathBuf, Error> {
    check_target(path)?;
    let tmp = tmp_path(path);
    match write(&tmp) {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Rename finished temporaries onto their targets; on failure remove those not yet renamed.
fn commit(pairs: &[(PathBuf, &Path)]) -> Result<(), Error> {
    for (i, (tmp, path)) in pairs.iter().enumerate() {
        if let Err(e) = shscale_files::atomic::rename_durable(tmp, path) {
            for (t, _) in &pairs[i..] {
                let _ = std::fs::remove_file(t);
            }
            return Err(e.into());
        }
    }
    Ok(())
}

/// Write `pixels` (row-major, row 0 at the top) as a float RGB EXR, atomically. Compressed on one
/// thread so the bytes are reproducible (parallel compression writes chunks in completion order).
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), Error> {
    let tmp = to_tmp(path, |tmp| exr_to(tmp, path, width, height, pixels))?;
    commit(&[(tmp, path)])
}

/// How the PNG beside an EXR maps values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Png {
    /// Exposure normalised to the mean, tone mapped ([`write_png_preview`]).
    Preview,
    /// Values in [0, 1] linearly ([`write_png_unit`]; visibility).
    Unit,
}

/// Write `exr` and the PNG beside it (`exr` with the extension `png`) as a unit: both are
/// written to temporaries, then renamed; when either fails neither target is touched (a
/// directory in either place is refused before any work) and no temporary is left. Returns
/// the PNG's path.
pub fn write_exr_and_png(
    exr: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
    png: Png,
) -> Result<PathBuf, Error> {
    let png_path = exr.with_extension("png");
    check_target(exr)?;
    check_target(&png_path)?;
    let t_exr = to_tmp(exr, |tmp| exr_to(tmp, exr, width, height, pixels))?;
    let t_png = match to_tmp(&png_path, |tmp| match png {
        Png::Preview => png_to(tmp, &png_path, width, height, preview_bytes(pixels)),
        Png::Unit => png_to(tmp, &png_path, width, height, unit_bytes(pixels)),
    }) {
        Ok(t) => t,
        Err(e) => {
            let _ = std::fs::remove_file(&t_exr);
            return Err(e);
        }
    };
    commit(&[(t_png, png_path.as_path()), (t_exr, exr)])?;
    Ok(png_path)
}

fn exr_to(
    tmp: &Path,
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), Error> {
    check_dims(path, width, height)?;
    if pixels.len() != width * height {
        return Err(crate::error::Error::io(
            path,
            format!("{} pixels for {width}×{height}", pixels.len()),
        ));
    }
    if let Some(i) = pixels.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(crate::error::Error::io(
            path,
            format!(
                "pixel ({}, {}) is {:?}: not written (an input drove the result out of range)",
                i % width,
                i / width,
                pixels[i]
            ),
        ));
    }
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let p = pixels[pos.y() * width + pos.x()];
        (p[0], p[1], p[2])
    });
    Image::from_channels((width, height), channels)
        .write()
        .non_parallel()
        .to_file(tmp)
        .map_err(|e| crate::error::Error::io(path, e))
}

fn unit_bytes(pixels: &[[f32; 3]]) -> Vec<u8> {
    pixels
        .iter()
        .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
        .collect()
}

fn preview_bytes(pixels: &[[f32; 3]]) -> Vec<u8> {
    let mean = pixels
        .iter()
        .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum::<f64>()
        / pixels.len().max(1) as f64;
    let exposure = if mean > 0.0 && mean.is_finite() {
        0.5 / mean
    } else {
        1.0
    };
    pixels
        .iter()
        .flat_map(|p| {
            p.map(|v| {
                let x = (v.max(0.0) as f64) * exposure;
                ((x / (1.0 + x)).powf(1.0 / 2.2) * 255.0)
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
        })
        .collect()
}

/// Write an 8-bit PNG of values in [0, 1] mapped linearly (clamped) — for visibility, where 1 must
/// read as white. Atomic like [`write_exr`].
pub fn write_png_unit(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), Error> {
    let tmp = to_tmp(path, |tmp| {
        png_to(tmp, path, width, height, unit_bytes(pixels))
    })?;
    commit(&[(tmp, path)])
}

/// Write an 8-bit sRGB-ish PNG preview: exposure normalised to the mean luminance, Reinhard
/// `x/(1+x)`, gamma 1/2.2. Atomic like [`write_exr`].
pub fn write_png_preview(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), Error> {
    let tmp = to_tmp(path, |tmp| {
        png_to(tmp, path, width, height, preview_bytes(pixels))
    })?;
    commit(&[(tmp, path)])
}

/// Read the first RGBA layer of an EXR as `(width, height, rgb)`, row 0 at the top. The header
/// is read first: a layer over [`MAX_IMAGE_SIDE`] or [`MAX_IMAGE_PIXELS`] is refused before any
/// pixel is allocated; then every pixel must be finite, else the error names the first bad one.
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), Error> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| crate::error::Error::io(path, e))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| crate::error::Error::io(path, "no layer"))?;
    let size = header.layer_size;
    check_dims(path, size.width(), size.height())?;
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
    .map_err(|e| crate::error::Error::io(path, e))?;
    let (w, h, px) = img.layer_data.channel_data.pixels;
    let bad = |i: usize, what: &str| {
        crate::error::Error::io(
            path,
            format!("pixel ({}, {}) is {:?}: {what}", i % w, i / w, px[i]),
        )
    };
    if let Some(i) = px.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(bad(i, "not finite"));
    }
    Ok((w, h, px))
}

/// [`read_exr`] for radiance (environment maps): additionally every pixel ≥ 0, up to
/// [`NEGATIVE_TOLERANCE`] of ringing, which is clamped to 0.
pub fn read_radiance_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), Error> {
    let (w, h, mut px) = read_exr(path)?;
    let bad = |i: usize, what: &str, px: &[[f32; 3]]| {
        crate::error::Error::io(
            path,
            format!("pixel ({}, {}) is {:?}: {what}", i % w, i / w, px[i]),
        )
    };
    // Filtered HDR maps ring slightly below 0 (the bundled courtyard map reaches −3.2e-3 against
    // a maximum of 55.6): values down to −NEGATIVE_TOLERANCE × the largest value are clamped to 0;
    // anything more negative is not radiance.
    let max = px.iter().flatten().fold(0f32, |a, v| a.max(*v));
    if let Some(i) = px
        .iter()
        .position(|p| p.iter().any(|v| *v < -NEGATIVE_TOLERANCE * max))
    {
        return Err(bad(
            i,
            &format!("radiance must be ≥ 0 (down to −{NEGATIVE_TOLERANCE:e} × the maximum {max:e} is clamped)"),
            &px,
        ));
    }
    for p in &mut px {
        for v in p.iter_mut() {
            *v = v.max(0.0);
        }
    }
    Ok((w, h, px))
}

/// How far below 0 (relative to the largest value) an EXR map's pixels may ring before
/// [`read_exr`] refuses the map.
pub const NEGATIVE_TOLERANCE: f32 = 1e-3;

fn png_to(
    tmp: &Path,
    path: &Path,
    width: usize,
    height: usize,
    data: Vec<u8>,
) -> Result<(), Error> {
    check_dims(path, width, height)?;
    let file = std::fs::File::create(tmp).map_err(|e| crate::error::Error::io(path, e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc
        .write_header()
        .map_err(|e| crate::error::Error::io(path, e))?;
    w.write_image_data(&data)
        .map_err(|e| crate::error::Error::io(path, e))?;
    w.finish().map_err(|e| crate::error::Error::io(path, e))
}

/// Copy `dir/<from>.png` and `.exr` (those that exist) to `out/<stem>.*`, atomically; the files
/// written, PNG first.
pub fn copy_image(
    dir: &Path,
    from: &str,
    out: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, crate::error::Error> {
    let mut files = Vec::new();
    for ext in ["png", "exr"] {
        let from = dir.join(format!("{from}.{ext}"));
        if !from.exists() {
            continue;
        }
        let to = out.join(format!("{stem}.{ext}"));
        let tmp = shscale_files::atomic::tmp_keeping_extension(&to);
        std::fs::copy(&from, &tmp)
            .map_err(|e| crate::error::Error::io(&to, e))
            .and_then(|_| Ok(shscale_files::atomic::rename_durable(&tmp, &to)?))
            .inspect_err(|_| {
                let _ = std::fs::remove_file(&tmp);
            })?;
        files.push(to);
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shscale-io-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().to_string())
            .collect();
        v.sort();
        v
    }

    /// When the PNG cannot be written after the EXR's temporary was, neither target changes
    /// and no temporary is left; a directory at either target is refused before any work.
    #[test]
    fn exr_and_png_are_written_as_a_unit() {
        let d = dir("unit");
        let exr = d.join("a.exr");
        std::fs::write(&exr, b"old exr").unwrap();
        std::fs::write(d.join("a.png"), b"old png").unwrap();
        // The PNG's temporary path is taken by a directory: its creation fails mid-way.
        let blocker = tmp_path(&d.join("a.png"));
        std::fs::create_dir_all(&blocker).unwrap();
        let px = [[0.5f32, 1.0, 2.0]; 6];
        assert!(write_exr_and_png(&exr, 3, 2, &px, Png::Preview).is_err());
        assert_eq!(std::fs::read(&exr).unwrap(), b"old exr");
        assert_eq!(std::fs::read(d.join("a.png")).unwrap(), b"old png");
        std::fs::remove_dir(&blocker).unwrap();
        assert_eq!(names(&d), ["a.exr", "a.png"]);
        // Non-finite pixels are not written, naming the pixel.
        let mut bad = px;
        bad[4] = [f32::NAN, 0.0, 0.0];
        let e = write_exr_and_png(&exr, 3, 2, &bad, Png::Unit)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pixel (1, 1)"), "{e}");
        assert_eq!(names(&d), ["a.exr", "a.png"]);
        // A directory where the PNG goes: refused, the EXR untouched.
        std::fs::remove_file(d.join("a.png")).unwrap();
        std::fs::create_dir(d.join("a.png")).unwrap();
        let e = write_exr_and_png(&exr, 3, 2, &px, Png::Unit)
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.png") && e.contains("directory"), "{e}");
        assert_eq!(std::fs::read(&exr).unwrap(), b"old exr");
        // And the success path replaces both.
        std::fs::remove_dir(d.join("a.png")).unwrap();
        write_exr_and_png(&exr, 3, 2, &px, Png::Preview).unwrap();
        let (w, h, back) = read_exr(&exr).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(back[5], [0.5, 1.0, 2.0]);
        assert_eq!(names(&d), ["a.exr", "a.png"]);
        std::fs::remove_dir_all(&d).ok();
    }

    /// Image bounds at their edges, and radiance maps: ringing clamped, real negatives refused.
    #[test]
    fn image_bounds_and_radiance_maps() {
        let d = dir("bounds");
        assert!(check_dims(&d, MAX_IMAGE_SIDE, MAX_IMAGE_PIXELS / MAX_IMAGE_SIDE).is_ok());
        assert!(check_dims(&d, MAX_IMAGE_SIDE + 1, 1).is_err());
        assert!(check_dims(&d, 0, 1).is_err());
        assert!(check_dims(&d, MAX_IMAGE_SIDE, MAX_IMAGE_SIDE).is_err());
        let p = d.join("m.exr");
        write_exr(&p, 2, 1, &[[10.0, 10.0, 10.0], [-0.005, 1.0, 1.0]]).unwrap();
        let (_, _, px) = read_radiance_exr(&p).unwrap();
        assert_eq!(px[1][0], 0.0, "ringing of −5e-4 × max is clamped");
        write_exr(&p, 2, 1, &[[10.0, 10.0, 10.0], [-0.02, 1.0, 1.0]]).unwrap();
        let e = read_radiance_exr(&p).unwrap_err().to_string();
        assert!(e.contains("pixel (1, 0)"), "{e}");
        // read_exr itself keeps negative values (band-limited visibility images have them).
        assert_eq!(read_exr(&p).unwrap().2[1][0], -0.02);
        std::fs::remove_dir_all(&d).ok();
    }
}
