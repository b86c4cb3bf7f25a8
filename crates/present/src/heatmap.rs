//! Heat maps: a value over two swept parameters, one panel per value of a third (the probe's
//! error over α and the sampling radius per probe radius), every cell's value written in it,
//! written as PNG + SVG together like every plot.

use crate::error::Error;
use crate::plots::{check_stem, drawable, ensure_font, err, finish, Chart, MAX_PANELS};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One panel of a heat map: its title and the value of each (x, y) cell, `None` where no row
/// gives one.
pub struct HeatPanel {
    pub title: String,
    /// `cells[j][i]`: the value at the `i`-th x and `j`-th y.
    pub cells: Vec<Vec<Option<f64>>>,
}

/// Write `stem.png` and `stem.svg`: heat maps of a metric over two swept parameters, one panel
/// each (up to three a row), the parameters' values as categories on the axes, every cell in the
/// `Heat` colour map on one scale shared by the panels and labelled with its value (so no colour
/// bar is needed to read it); an empty cell is grey. Written as a unit like [`write_both`].
#[allow(clippy::too_many_arguments)]
pub fn write_heatmap(
    dir: &Path,
    stem: &str,
    title: &str,
    (x_name, xs): (&str, &[String]),
    (y_name, ys): (&str, &[String]),
    panels: &[HeatPanel],
) -> Result<Vec<PathBuf>, Error> {
    check_stem(dir, stem)?;
    ensure_font();
    if panels.is_empty() || panels.len() > MAX_PANELS || xs.is_empty() || ys.is_empty() {
        return Err(Error::Config(format!(
            "a heat map draws 1 to {MAX_PANELS} panels of at least one cell, not {} panels of {}×{}",
            panels.len(),
            xs.len(),
            ys.len()
        )));
    }
    let (lo, hi) = heat_range(panels);
    let cols = panels.len().min(3);
    let rows = panels.len().div_ceil(cols);
    let size = ((cols * 560) as u32, (rows * 440 + 40) as u32);
    let mut tmps = shscale_files::atomic::Temporaries::new();
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let (tmp_png, tmp_svg) = (tmps.beside(&png), tmps.beside(&svg));
    let shape = (rows, cols, lo, hi);
    heat_figure(
        BitMapBackend::new(&tmp_png, size).into_drawing_area(),
        title,
        (x_name, xs),
        (y_name, ys),
        panels,
        shape,
    )
    .map_err(|x| err(&png, x))?;
    heat_figure(
        SVGBackend::new(&tmp_svg, size).into_drawing_area(),
        title,
        (x_name, xs),
        (y_name, ys),
        panels,
        shape,
    )
    .map_err(|x| err(&svg, x))?;
    finish(&tmp_png, &png)?;
    finish(&tmp_svg, &svg)?;
    Ok(vec![png, svg])
}

/// The colour range of heat-map panels: the drawable values' extremes, widened to a unit range
/// about a single value.
fn heat_range(panels: &[HeatPanel]) -> (f64, f64) {
    let (lo, hi) = (panels.iter())
        .flat_map(|p| p.cells.iter().flatten().flatten().copied())
        .filter(|v| drawable(*v))
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    }
}

/// The heat-map figure on one backend: the title, then `rows × cols` panels of labelled cells.
fn heat_figure<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    (x_name, xs): (&str, &[String]),
    (y_name, ys): (&str, &[String]),
    panels: &[HeatPanel],
    (rows, cols, lo, hi): (usize, usize, f64, f64),
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: &dyn std::fmt::Display| x.to_string();
    area.fill(&WHITE).map_err(|x| e(&x))?;
    let area = area.titled(title, ("sans-serif", 20)).map_err(|x| e(&x))?;
    for (cell, p) in area.split_evenly((rows, cols)).iter().zip(panels) {
        let mut chart = ChartBuilder::on(cell)
            .caption(&p.title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..xs.len() as f64, 0f64..ys.len() as f64)
            .map_err(|x| e(&x))?;
        let label = |names: &[String], v: f64| {
            let i = (v - 0.5).round();
            if (v - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                names.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(x_name)
            .y_desc(y_name)
            .x_labels(2 * xs.len() + 1)
            .y_labels(2 * ys.len() + 1)
            .x_label_formatter(&|v| label(xs, *v))
            .y_label_formatter(&|v| label(ys, *v))
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(|x| e(&x))?;
        for (j, row) in p.cells.iter().enumerate() {
            for (i, v) in row.iter().enumerate() {
                heat_cell(&mut chart, (i as f64, j as f64), *v, (lo, hi))?;
            }
        }
    }
    area.present().map_err(|x| e(&x))
}

/// One heat-map cell at `(x, y)`: its colour on the heat scale over `(lo, hi)` (grey without a
/// value) and its value written in it, dark on the light end of the map, light on the dark end.
fn heat_cell<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    (x, y): (f64, f64),
    v: Option<f64>,
    (lo, hi): (f64, f64),
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: &dyn std::fmt::Display| x.to_string();
    let colour = match v {
        Some(v) if drawable(v) => crate::figure::ColourMap::Heat
            .at((v - lo) / (hi - lo))
            .to_rgba(),
        _ => RGBColor(200, 200, 200).to_rgba(),
    };
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(x, y), (x + 1.0, y + 1.0)],
            colour.filled(),
        )))
        .map_err(|x| e(&x))?;
    let text = v.map_or("—".to_string(), |v| format!("{v:.3}"));
    let light = v.is_some_and(|v| (v - lo) / (hi - lo) > 0.55);
    let ink = if light { BLACK } else { WHITE };
    let centred = plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Center,
        plotters::style::text_anchor::VPos::Center,
    );
    chart
        .draw_series(std::iter::once(Text::new(
            text,
            (x + 0.5, y + 0.5),
            ("sans-serif", 12).into_font().color(&ink).pos(centred),
        )))
        .map_err(|x| e(&x))?;
    Ok(())
}
