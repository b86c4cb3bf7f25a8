//! Labelled image figures (PNG, plotters): a grid of panels, each with its title and axes in
//! units (lat-long maps: φ and θ in degrees; receiver planes: x and y in scene units), sharing one
//! colour scale drawn as a colour bar with its ticks and label. The raw values go to an EXR beside
//! it; this is the picture for a paper. Colour maps: grey (0 black … 1 white — visibility, the
//! papers' convention), `magma`-like for irradiance, and blue–white–red for signed differences.

use crate::error::Error;
use plotters::prelude::*;
use std::path::Path;

/// How values map to colours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColourMap {
    /// Black (low) to white (high).
    Grey,
    /// Dark purple through orange to light yellow (perceptually ordered, colour-blind safe).
    Heat,
    /// Blue (negative) – white (0) – red (positive); the range is made symmetric about 0.
    Diverging,
}

impl ColourMap {
    /// The colour of `t` in [0, 1].
    pub fn at(self, t: f64) -> RGBColor {
        let t = t.clamp(0.0, 1.0);
        let lerp = |a: (f64, f64, f64), b: (f64, f64, f64), s: f64| {
            RGBColor(
                (a.0 + (b.0 - a.0) * s).round() as u8,
                (a.1 + (b.1 - a.1) * s).round() as u8,
                (a.2 + (b.2 - a.2) * s).round() as u8,
            )
        };
        let stops: &[(f64, f64, f64)] = match self {
            Self::Grey => &[(0.0, 0.0, 0.0), (255.0, 255.0, 255.0)],
            Self::Heat => &[
                (0.0, 0.0, 4.0),
                (81.0, 18.0, 124.0),
                (183.0, 55.0, 121.0),
                (252.0, 137.0, 97.0),
                (252.0, 253.0, 191.0),
            ],
            Self::Diverging => &[
                (33.0, 102.0, 172.0),
                (247.0, 247.0, 247.0),
                (178.0, 24.0, 43.0),
            ],
        };
        let n = stops.len() - 1;
        let x = t * n as f64;
        let i = (x.floor() as usize).min(n - 1);
        lerp(stops[i], stops[i + 1], x - i as f64)
    }
}

/// One panel: `values` row-major, row 0 at the top; `x` and `y` the axis ranges and labels.
pub struct Panel {
    pub title: String,
    pub width: usize,
    pub height: usize,
    pub values: Vec<f32>,
}

/// A grid of panels sharing one colour scale.
pub struct Grid<'a> {
    pub title: &'a str,
    /// Rows of panels (each row the same number of panels).
    pub rows: Vec<Vec<Panel>>,
    /// Axis ranges `(x0, x1)`, `(y_top, y_bottom)` and labels with units.
    pub x: (f64, f64, &'a str),
    pub y: (f64, f64, &'a str),
    pub colours: ColourMap,
    /// The colour scale's range (a `Diverging` one is made symmetric) and its label with units.
    pub range: (f64, f64),
    pub scale_label: &'a str,
    /// Pixel size of one panel's image area.
    pub panel_px: (u32, u32),
}

/// The width of a grid's colour bar with its ticks and rotated label (the label's line sits
/// inside it, never at the figure's edge).
const COLOUR_BAR_W: u32 = 160;

/// The colour scale of a grid: its range, symmetric for a diverging map, never empty.
fn scale(g: &Grid) -> (f64, f64) {
    let (mut lo, mut hi) = g.range;
    if g.colours == ColourMap::Diverging {
        let m = lo.abs().max(hi.abs());
        (lo, hi) = (-m, m);
    }
    if hi.is_nan() || lo.is_nan() || hi <= lo {
        hi = lo + 1.0;
    }
    (lo, hi)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    g: &Grid,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: &dyn std::fmt::Display| x.to_string();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let (title, body) = root.split_vertically(44);
    title
        .titled(g.title, ("sans-serif", 22))
        .map_err(|x| e(&x))?;
    let (w, _) = body.dim_in_pixel();
    let (grid, bar) = body.split_horizontally(w - COLOUR_BAR_W);
    let rows = g.rows.len().max(1);
    let cols = g.rows.first().map_or(1, |r| r.len().max(1));
    let (lo, hi) = scale(g);
    for (ri, area_row) in grid.split_evenly((rows, cols)).chunks(cols).enumerate() {
        for (ci, area) in area_row.iter().enumerate() {
            let Some(p) = g.rows.get(ri).and_then(|r| r.get(ci)) else {
                continue;
            };
            let mut chart = ChartBuilder::on(area)
                .caption(&p.title, ("sans-serif", 16))
                .margin(6)
                .x_label_area_size(34)
                .y_label_area_size(46)
                .build_cartesian_2d(g.x.0..g.x.1, g.y.1..g.y.0)
                .map_err(|x| e(&x))?;
            let whole = |v: &f64| format!("{v:.0}");
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(g.x.2)
                .y_desc(g.y.2)
                .x_labels(5)
                .y_labels(5)
                .x_label_formatter(&whole)
                .y_label_formatter(&whole)
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(|x| e(&x))?;
            // The image, resampled (nearest) to the plotting area's pixels.
            let (pw, ph) = chart.plotting_area().dim_in_pixel();
            let mut buf = vec![0u8; (pw * ph * 3) as usize];
            for y in 0..ph as usize {
                let sy = (y * p.height / ph as usize).min(p.height - 1);
                for x in 0..pw as usize {
                    let sx = (x * p.width / pw as usize).min(p.width - 1);
                    let v = p.values[sy * p.width + sx] as f64;
                    let c = g.colours.at((v - lo) / (hi - lo));
                    let o = (y * pw as usize + x) * 3;
                    buf[o..o + 3].copy_from_slice(&[c.0, c.1, c.2]);
                }
            }
            if let Some(img) = BitMapElement::with_owned_buffer((g.x.0, g.y.0), (pw, ph), buf) {
                chart.draw_series(std::iter::once(img)).map_err(|x| e(&x))?;
            }
        }
    }
    colour_bar(&bar, g, lo, hi)?;
    root.present().map_err(|x| e(&x))
}

/// The colour bar of a grid, `lo..hi` with its label.
fn colour_bar<DB: DrawingBackend>(
    bar: &DrawingArea<DB, plotters::coord::Shift>,
    g: &Grid,
    lo: f64,
    hi: f64,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: &dyn std::fmt::Display| x.to_string();
    let mut cb = ChartBuilder::on(bar)
        .margin_top(30)
        .margin_bottom(50)
        .margin_right(4)
        .margin_left(24)
        .right_y_label_area_size(COLOUR_BAR_W as i32 - 70)
        .build_cartesian_2d(0f64..1f64, lo..hi)
        .map_err(|x| e(&x))?;
    let tick = |v: &f64| {
        let a = v.abs();
        if a != 0.0 && !(1e-2..1e4).contains(&a) {
            format!("{v:.1e}")
        } else {
            format!("{}", (v * 1000.0).round() / 1000.0)
        }
    };
    let steps = 200;
    cb.draw_series((0..steps).map(|i| {
        let (a, b) = (
            lo + (hi - lo) * i as f64 / steps as f64,
            lo + (hi - lo) * (i + 1) as f64 / steps as f64,
        );
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            g.colours.at((i as f64 + 0.5) / steps as f64).filled(),
        )
    }))
    .map_err(|x| e(&x))?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(g.scale_label)
        .y_labels(6)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(|x| e(&x))?;
    Ok(())
}

/// The pixel size of a grid.
fn size_of(g: &Grid) -> (u32, u32) {
    let rows = g.rows.len().max(1) as u32;
    let cols = g.rows.first().map_or(1, |r| r.len().max(1)) as u32;
    let (pw, ph) = g.panel_px;
    (cols * (pw + 60) + COLOUR_BAR_W, rows * (ph + 60) + 44)
}

/// Write the grid as a PNG at `path` (atomically: a temporary beside it, then renamed).
pub fn write_png(path: &Path, g: &Grid) -> Result<(), Error> {
    write_png_stack(path, std::slice::from_ref(g))
}

/// Write several grids, one above the other (each with its own title and colour scale), as one
/// PNG at `path`, atomically.
pub fn write_png_stack(path: &Path, grids: &[Grid]) -> Result<(), Error> {
    crate::font::ensure_font();
    let sizes: Vec<(u32, u32)> = grids.iter().map(size_of).collect();
    let size = (
        sizes.iter().map(|s| s.0).max().unwrap_or(1),
        sizes.iter().map(|s| s.1).sum::<u32>().max(1),
    );
    let tmp = shscale_files::atomic::tmp_keeping_extension(path);
    let stacked = || -> Result<(), String> {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut rest = root.clone();
        for (g, s) in grids.iter().zip(&sizes) {
            let (top, below) = rest.split_vertically(s.1);
            let (area, _) = top.split_horizontally(s.0);
            draw(area, g)?;
            rest = below;
        }
        root.present().map_err(|e| e.to_string())
    };
    let r = stacked()
        .map_err(|m| Error::Io {
            path: path.display().to_string(),
            reason: m,
        })
        .and_then(|_| Ok(shscale_files::atomic::rename_durable(&tmp, path)?));
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_maps_at_their_ends() {
        assert_eq!(ColourMap::Grey.at(0.0), RGBColor(0, 0, 0));
        assert_eq!(ColourMap::Grey.at(1.0), RGBColor(255, 255, 255));
        assert_eq!(ColourMap::Grey.at(7.0), RGBColor(255, 255, 255));
        assert_eq!(ColourMap::Diverging.at(0.5), RGBColor(247, 247, 247));
        let (a, b) = (ColourMap::Heat.at(0.2), ColourMap::Heat.at(0.8));
        let lum = |c: RGBColor| 0.3 * c.0 as f64 + 0.59 * c.1 as f64 + 0.11 * c.2 as f64;
        assert!(lum(a) < lum(b), "heat map luminance must increase");
    }

    /// A two-panel grid with a colour bar is written; its pixels show both ends of the scale.
    #[test]
    fn grid_png_is_written_with_its_scale() {
        let d = std::env::temp_dir().join(format!("shscale-figure-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("g.png");
        let panel = |t: &str, v: f32| Panel {
            title: t.into(),
            width: 8,
            height: 4,
            values: (0..32).map(|i| if i % 2 == 0 { v } else { 0.0 }).collect(),
        };
        write_png(
            &p,
            &Grid {
                title: "test",
                rows: vec![vec![panel("a", 1.0), panel("b", 0.5)]],
                x: (0.0, 360.0, "φ (°)"),
                y: (0.0, 180.0, "θ (°)"),
                colours: ColourMap::Grey,
                range: (0.0, 1.0),
                scale_label: "visibility (1)",
                panel_px: (240, 120),
            },
        )
        .unwrap();
        let len = std::fs::metadata(&p).unwrap().len();
        assert!(len > 2000, "{len} bytes");
        std::fs::remove_dir_all(&d).ok();
    }
}
