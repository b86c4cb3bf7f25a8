//! Plots of a run directory's `runs.csv` (plotters; PNG and SVG, written to a temporary name and
//! renamed): the error against the swept parameter with one series per probe radius, and the
//! speed/accuracy scatter of all runs with its Pareto front. Every plot: the Okabe–Ito palette
//! (colour-blind safe), a log y axis when the data span two decades or more ([`log_axis`]),
//! integer ticks when x is an integer parameter, and a y range that never clips ([`y_range`]). Text uses the bundled DejaVu Sans
//! (assets/fonts, Bitstream Vera licence), so nothing is needed from the system at run time.

use crate::error::Error;
use crate::font::{caption_size, significant};
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use crate::font::ensure_font;

/// A results CSV (read through the `csv` crate).
pub type Table = crate::records::Results;

pub(crate) fn err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

pub(crate) fn finish(tmp: &Path, path: &Path) -> Result<(), Error> {
    crate::atomic::rename_durable(tmp, path)
}

/// Title and axis labels (with units) of a plot.
pub struct Labels<'a> {
    pub title: &'a str,
    pub x: &'a str,
    pub y: &'a str,
}

/// The axes of a line plot: ranges, whether y is drawn as log10 y, and the x ticks.
struct Axes {
    log_x: bool,
    log_y: bool,
    integer_x: bool,
    x: (f64, f64),
    y: (f64, f64),
    x_ticks: usize,
}

impl Axes {
    /// A tick label of the x (`x_axis`) or y axis at drawn coordinate `v`: a log axis over two
    /// decades or more is labelled at the decades, a narrower one at every tick with its value;
    /// an integer x axis without decimals; else rounded to 1e-6.
    fn tick(&self, v: f64, x_axis: bool) -> String {
        let (log, (lo, hi)) = if x_axis {
            (self.log_x, self.x)
        } else {
            (self.log_y, self.y)
        };
        if log && hi - lo >= 2.0 {
            if (v - v.round()).abs() < 1e-9 {
                format!("1e{}", v.round())
            } else {
                String::new()
            }
        } else if log {
            significant(10f64.powf(v), 3)
        } else if x_axis && self.integer_x {
            format!("{v:.0}")
        } else {
            format!("{}", (v * 1e6).round() / 1e6)
        }
    }

    /// The axes of the finite points of `series`. Data spanning two decades or more (all > 0)
    /// are drawn on a log axis unless `log` says otherwise: y becomes log10 y and the ticks are
    /// labelled as powers of ten.
    /// With `log_x`, x is drawn as log10 x (every x must be > 0).
    fn of_xy(
        series: &BTreeMap<String, Vec<(f64, f64)>>,
        log: Option<bool>,
        log_x: bool,
    ) -> Result<Self, String> {
        let pts: Vec<(f64, f64)> = (series.values().flatten().copied())
            .filter(|&(x, y)| drawable(x) && drawable(y))
            .collect();
        if log_x && pts.iter().any(|p| p.0 <= 0.0) {
            return Err("a log x axis needs values > 0".into());
        }
        let pts: Vec<(f64, f64)> = if log_x {
            pts.iter().map(|&(x, y)| (x.log10(), y)).collect()
        } else {
            pts
        };
        if pts.is_empty() {
            return Err(format!(
                "no finite data to plot (values beyond ±{MAX_DRAWN:e} are left out)"
            ));
        }
        let log_y = log.unwrap_or_else(|| log_axis(&pts.iter().map(|p| p.1).collect::<Vec<_>>()));
        if log_y && pts.iter().any(|p| p.1 <= 0.0) {
            return Err("a log y axis needs values > 0".into());
        }
        let pts: Vec<(f64, f64)> = pts
            .iter()
            .map(|&(x, y)| (x, if log_y { y.log10() } else { y }))
            .collect();
        let integer_x = !log_x && pts.iter().all(|p| p.0.fract() == 0.0 && p.0.abs() < 1e9);
        let span = |f: fn(&(f64, f64)) -> f64, relative: bool| {
            let (lo, hi) =
                (pts.iter().map(f)).fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
            degenerate_span(lo, hi, relative)
        };
        // (x keeps ±0.5 around a single value: integer parameters are labelled at integers.)
        let (x, (y0, y1)) = (span(|p| p.0, false), span(|p| p.1, !log_y));
        let y = if log_y {
            let pad = 0.05 * (y1 - y0);
            (y0 - pad, y1 + pad)
        } else {
            y_range(y0, y1)
        };
        // Integer parameters get integer ticks (one per value when there are few).
        // A log axis under two decades is labelled at every tick with its value: fewer of them,
        // so the labels (up to six characters) never run into each other.
        let x_ticks = if integer_x && x.1 - x.0 <= 12.0 {
            (x.1 - x.0).round() as usize + 1
        } else if log_x && x.1 - x.0 < 2.0 {
            5
        } else {
            10
        };
        Ok(Self {
            log_x,
            log_y,
            integer_x,
            x,
            y,
            x_ticks,
        })
    }

    /// An x value as drawn.
    fn tx(&self, x: f64) -> f64 {
        if self.log_x {
            x.log10()
        } else {
            x
        }
    }

    /// A y value as drawn.
    fn ty(&self, y: f64) -> f64 {
        if self.log_y {
            y.log10()
        } else {
            y
        }
    }
}

pub(crate) type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Named series of points (name → (x, y)).
type Series = BTreeMap<String, Vec<(f64, f64)>>;

/// Spread bands of a panel: series name → (x, low, high), drawn shaded in the series' colour.
pub type Bands = BTreeMap<String, Vec<(f64, f64, f64)>>;

/// Draw `series` (name → points) as lines with markers; x and y labelled with units.
#[allow(clippy::too_many_arguments)]
fn line_plot<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    labels: &Labels,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    scatter_only: bool,
    front: &[(f64, f64)],
    log: Option<bool>,
    log_x: bool,
    xbars: &[(f64, f64, f64)],
    notes: &[Note],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE).map_err(|e| e.to_string())?;
    // A title too long for the figure's width at the usual size is drawn smaller, never clipped.
    let caption = caption_size(labels.title, area.dim_in_pixel().0);
    panel_plot(
        &area,
        labels,
        series,
        &Bands::new(),
        scatter_only,
        front,
        log,
        log_x,
        caption,
        xbars,
        notes,
    )?;
    area.present().map_err(|e| e.to_string())
}

/// One panel on `area` (already filled): axes, bands, lines or markers, the front, the legend.
#[allow(clippy::too_many_arguments)]
fn panel_plot<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    labels: &Labels,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    bands: &Bands,
    scatter_only: bool,
    front: &[(f64, f64)],
    log: Option<bool>,
    log_x: bool,
    caption: u32,
    xbars: &[(f64, f64, f64)],
    notes: &[Note],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let ax = Axes::of_xy(&ranged(series, bands, xbars), log, log_x)?;
    let (title, legend_w) = title_and_legend(labels, series, front, area.dim_in_pixel().0);
    let mut chart = ChartBuilder::on(area)
        .caption(&title, ("sans-serif", caption))
        .margin(12)
        .margin_right(12 + legend_w)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(ax.x.0..ax.x.1, ax.y.0..ax.y.1)
        .map_err(|e| e.to_string())?;
    let (x_fmt, y_fmt) = (|v: &f64| ax.tick(*v, true), |v: &f64| ax.tick(*v, false));
    chart
        .configure_mesh()
        .x_desc(axis_desc(labels.x, ax.log_x))
        .y_desc(axis_desc(labels.y, ax.log_y))
        .x_labels(ax.x_ticks)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| e.to_string())?;
    draw_bands(&mut chart, &ax, series, bands)?;
    draw_xbars(&mut chart, &ax, xbars)?;
    for (i, points) in series.values().enumerate() {
        let mut pts: Vec<(f64, f64)> = (points.iter().copied())
            .filter(|&(x, y)| drawable(x) && drawable(y))
            .filter(|&(x, _)| !(ax.log_x && x <= 0.0))
            .map(|(x, y)| (ax.tx(x), ax.ty(y)))
            .filter(|(_, y)| y.is_finite())
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        draw_series(&mut chart, i, &pts, scatter_only)?;
    }
    if !front.is_empty() {
        let front: Vec<(f64, f64)> = (front.iter())
            .filter(|&&(x, y)| drawable(x) && drawable(y))
            .map(|&(x, y)| (ax.tx(x), ax.ty(y)))
            .collect();
        chart
            .draw_series(LineSeries::new(front, BLACK.stroke_width(1)))
            .map_err(|e| e.to_string())?;
    }
    draw_notes(area, &chart, &ax, notes)?;
    let (px, py) = chart.plotting_area().get_base_pixel();
    let (bx, by) = area.get_base_pixel();
    let at = (
        px - bx + chart.plotting_area().dim_in_pixel().0 as i32 + 10,
        py - by + 8,
    );
    if legend_w == 0 {
        return Ok(());
    }
    let names: Vec<&str> = series.keys().map(String::as_str).collect();
    draw_legend(area, at, legend_w, &names, scatter_only, !front.is_empty())
    // Not presented here: an SVG backend writes its file once, when the whole figure is drawn.
}

/// A panel's title and the width of its legend margin. The legend goes right of the data, in a
/// margin as wide as its longest entry (at most 40 % of the panel `area_w`): it never covers a
/// point. One series and no front: no legend (width 0), the series' name joins the title unless
/// it only repeats the axis or the title.
fn title_and_legend(
    labels: &Labels,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    front: &[(f64, f64)],
    area_w: u32,
) -> (String, u32) {
    if let (1, true) = (series.len(), front.is_empty()) {
        let name = series.keys().next().map_or("", String::as_str);
        let says_more = !name.is_empty() && name != labels.y && !labels.title.contains(name);
        return match says_more {
            true => (format!("{} ({name})", labels.title), 0),
            false => (labels.title.to_string(), 0),
        };
    }
    let longest = (series.keys().map(|k| k.chars().count()))
        .chain((!front.is_empty()).then_some(12))
        .max()
        .unwrap_or(0);
    let legend_w = ((longest as u32) * 7 + 44).min(area_w * 2 / 5);
    (labels.title.to_string(), legend_w)
}

/// The notes beside their points: each label starts 7 px right of its point and 16 px above it;
/// a label that would overlap one already placed moves up a line at a time (a grey leader joins
/// it to its point), so crowded front points stay readable.
fn draw_notes<'a, DB: DrawingBackend + 'a>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart<'a, DB>,
    ax: &Axes,
    notes: &[Note],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    const LINE: i32 = 14;
    let (bx, by) = area.get_base_pixel();
    let mut pts: Vec<((i32, i32), &str)> = (notes.iter())
        .filter(|((x, y), _)| drawable(*x) && drawable(*y) && !(ax.log_x && *x <= 0.0))
        .map(|((x, y), t)| {
            let (px, py) = chart.backend_coord(&(ax.tx(*x), ax.ty(*y)));
            ((px - bx, py - by), t.as_str())
        })
        .collect();
    // Lowest points first: their labels move up into the free space above.
    pts.sort_by_key(|&((_, y), _)| std::cmp::Reverse(y));
    let mut placed: Vec<(i32, i32, i32)> = Vec::new();
    let font = ("sans-serif", 12).into_font();
    for ((px, py), text) in pts {
        let w = (text.chars().count() as f64 * 6.8) as i32;
        let (x, mut y) = (px + 7, py - 16);
        while placed
            .iter()
            .any(|&(ox, oy, ow)| x < ox + ow && ox < x + w && (y - oy).abs() < LINE)
        {
            y -= LINE;
        }
        if y != py - 16 {
            area.draw(&PathElement::new(
                vec![(px, py), (x, y + LINE / 2)],
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(|e| e.to_string())?;
        }
        area.draw(&Text::new(text.to_string(), (x, y), font.clone()))
            .map_err(|e| e.to_string())?;
        placed.push((x, y, w));
    }
    Ok(())
}

/// An axis's description, saying when it is drawn on a log scale.
fn axis_desc(label: &str, log: bool) -> String {
    if log {
        format!("{label} — log scale")
    } else {
        label.to_string()
    }
}

/// The points that set a panel's ranges: the series, the bands' ends (a band is never clipped)
/// and the bars' ends.
fn ranged(
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    bands: &Bands,
    xbars: &[(f64, f64, f64)],
) -> BTreeMap<String, Vec<(f64, f64)>> {
    let mut ranged = series.clone();
    for (name, b) in bands {
        let e = ranged.entry(format!("{name}\u{1f}band")).or_default();
        e.extend(b.iter().flat_map(|&(x, lo, hi)| [(x, lo), (x, hi)]));
    }
    if !xbars.is_empty() {
        let e = ranged.entry("\u{1f}bars".into()).or_default();
        e.extend(xbars.iter().flat_map(|&(y, lo, hi)| [(lo, y), (hi, y)]));
    }
    ranged
}

/// The bands of `series` (by name), under the lines: the polygon of (x, low) forward and
/// (x, high) back, at most `MAX_POINTS / 4` vertices a side.
fn draw_bands<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    ax: &Axes,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    bands: &Bands,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    for (i, name) in series.keys().enumerate() {
        let Some(band) = bands.get(name) else {
            continue;
        };
        let mut b: Vec<(f64, f64, f64)> = (band.iter().copied())
            .filter(|&(x, lo, hi)| drawable(x) && drawable(lo) && drawable(hi))
            .filter(|&(x, lo, _)| !((ax.log_x && x <= 0.0) || (ax.log_y && lo <= 0.0)))
            .map(|(x, lo, hi)| (ax.tx(x), ax.ty(lo), ax.ty(hi)))
            .collect();
        if b.len() < 2 {
            continue;
        }
        b.sort_by(|a, c| a.0.total_cmp(&c.0));
        // At most MAX_POINTS / 4 vertices a side (1 in s, the last kept).
        let s = b.len().div_ceil(MAX_POINTS / 4).max(1);
        if s > 1 {
            let last = b[b.len() - 1];
            b = b.into_iter().step_by(s).collect();
            if b.last() != Some(&last) {
                b.push(last);
            }
        }
        let poly: Vec<(f64, f64)> = (b.iter().map(|p| (p.0, p.1)))
            .chain(b.iter().rev().map(|p| (p.0, p.2)))
            .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(
                poly,
                palette(i).mix(0.18).filled(),
            )))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Horizontal error bars (y, x low, x high), grey, under the markers; clipped to the axis in
/// drawn coordinates (a log axis has no place for x ≤ 0).
fn draw_xbars<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    ax: &Axes,
    xbars: &[(f64, f64, f64)],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    for &(y, lo, hi) in xbars {
        if !(drawable(y) && drawable(lo) && drawable(hi)) || (ax.log_y && y <= 0.0) {
            continue;
        }
        let a = if ax.log_x && lo <= 0.0 {
            ax.x.0
        } else {
            ax.tx(lo).max(ax.x.0)
        };
        let (yy, b) = (ax.ty(y), ax.tx(hi));
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(a, yy), (b, yy)],
                RGBColor(120, 120, 120).stroke_width(1),
            )))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// The legend, drawn by hand in the right margin at `(x, y)` of `area` (plotters draws its own
/// inside the data): per series its line and marker, then its name, cut to the margin's width
/// `legend_w`; then the Pareto front's line where there is one.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    (lx, y0): (i32, i32),
    legend_w: u32,
    names: &[&str],
    scatter_only: bool,
    front: bool,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let fits = ((legend_w.saturating_sub(34)) / 7).max(4) as usize;
    let cut = |s: &str| -> String {
        if s.chars().count() <= fits {
            s.to_string()
        } else {
            s.chars()
                .take(fits - 1)
                .chain(std::iter::once('…'))
                .collect()
        }
    };
    let font = ("sans-serif", 12).into_font();
    for (i, name) in names.iter().enumerate() {
        let y = y0 + 18 * i as i32;
        let color = palette(i);
        if !scatter_only {
            area.draw(&PathElement::new(
                vec![(lx, y), (lx + 18, y)],
                color.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
        }
        match (i / 8) % 3 {
            0 => area.draw(&Circle::new((lx + 9, y), 4, color.filled())),
            1 => area.draw(&TriangleMarker::new((lx + 9, y), 6, color.filled())),
            _ => area.draw(&Cross::new((lx + 9, y), 5, color.stroke_width(2))),
        }
        .map_err(|e| e.to_string())?;
        area.draw(&Text::new(cut(name), (lx + 24, y - 7), font.clone()))
            .map_err(|e| e.to_string())?;
    }
    if front {
        let y = y0 + 18 * names.len() as i32;
        area.draw(&PathElement::new(
            vec![(lx, y), (lx + 18, y)],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;
        area.draw(&Text::new("Pareto front", (lx + 24, y - 7), font))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// A text drawn beside a point of a scatter (data coordinates): what a front point is.
pub type Note = ((f64, f64), String);

/// Write `stem.png` and `stem.svg`: a scatter of `series` with the black `front`, a horizontal
/// grey bar per `(y, x low, x high)` of `xbars` (the spread of each point's time; none: no
/// bars) and a short text beside each of `notes` (the configuration a front point is, say);
/// `log_x` draws x as log10 x (for budgets spanning decades). Written as a unit like
/// [`write_both`].
#[allow(clippy::too_many_arguments)]
pub fn write_scatter_noted(
    dir: &Path,
    stem: &str,
    labels: &Labels,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    front: &[(f64, f64)],
    xbars: &[(f64, f64, f64)],
    log_x: bool,
    notes: &[Note],
) -> Result<Vec<PathBuf>, Error> {
    check_stem(dir, stem)?;
    ensure_font();
    // Above MAX_POINTS points, every s-th point and its bar (the title says so); the front whole.
    let n: usize = series
        .values()
        .map(Vec::len)
        .sum::<usize>()
        .max(xbars.len());
    let s = n.div_ceil(MAX_POINTS).max(1);
    let (series, xbars, title): (Series, Vec<(f64, f64, f64)>, String) = if s > 1 {
        (
            (series.iter())
                .map(|(k, v)| (k.clone(), v.iter().step_by(s).copied().collect()))
                .collect(),
            xbars.iter().step_by(s).copied().collect(),
            format!("{} (1 in {s} of {n} points drawn)", labels.title),
        )
    } else {
        (series.clone(), xbars.to_vec(), labels.title.to_string())
    };
    let labels = &Labels {
        title: &title,
        ..*labels
    };
    let (series, xbars) = (&series, &xbars[..]);
    let mut tmps = crate::atomic::Temporaries::new();
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let (tmp_png, tmp_svg) = (tmps.beside(&png), tmps.beside(&svg));
    let png_area = BitMapBackend::new(&tmp_png, (900, 600)).into_drawing_area();
    line_plot(
        png_area, labels, series, true, front, None, log_x, xbars, notes,
    )
    .map_err(|e| err(&png, e))?;
    let svg_area = SVGBackend::new(&tmp_svg, (900, 600)).into_drawing_area();
    line_plot(
        svg_area, labels, series, true, front, None, log_x, xbars, notes,
    )
    .map_err(|e| err(&svg, e))?;
    finish(&tmp_png, &png)?;
    finish(&tmp_svg, &svg)?;
    Ok(vec![png, svg])
}

/// One panel of a faceted figure.
pub struct Panel {
    /// What the panel holds (`probe radius ρ = 0.5`).
    pub title: String,
    pub series: BTreeMap<String, Vec<(f64, f64)>>,
    pub bands: Bands,
    /// Markers only, no lines (points that are not a curve: configurations of a front).
    pub scatter: bool,
}

/// The most panels one faceted figure draws.
pub const MAX_PANELS: usize = 16;

/// Write `stem.png` and `stem.svg`: the panels in a grid (up to three a row), sharing the x and
/// y labels, each with its own axes and legend; `log_y` as in [`write_both_log`], `log_x`
/// draws x as log10 x. Written as a unit like [`write_both`].
#[allow(clippy::too_many_arguments)]
pub fn write_panels(
    dir: &Path,
    stem: &str,
    title: &str,
    x: &str,
    y: &str,
    panels: &[Panel],
    log_y: Option<bool>,
    log_x: bool,
) -> Result<Vec<PathBuf>, Error> {
    check_stem(dir, stem)?;
    ensure_font();
    if panels.is_empty() || panels.len() > MAX_PANELS {
        return Err(Error::Config(format!(
            "a figure draws 1 to {MAX_PANELS} panels, not {}",
            panels.len()
        )));
    }
    let cols = panels.len().min(3);
    let rows = panels.len().div_ceil(cols);
    let size = if panels.len() == 1 {
        (900, 600)
    } else {
        ((cols * 620) as u32, (rows * 440 + 40) as u32)
    };
    // A title that would not fit its width is drawn smaller.
    let title_font = if title.chars().count() * 11 > size.0 as usize {
        16
    } else {
        22
    };
    let mut tmps = crate::atomic::Temporaries::new();
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let (tmp_png, tmp_svg) = (tmps.beside(&png), tmps.beside(&svg));
    let shape = (rows, cols);
    panels_figure(
        BitMapBackend::new(&tmp_png, size).into_drawing_area(),
        title,
        (x, y),
        panels,
        shape,
        (log_y, log_x, title_font),
    )
    .map_err(|e| err(&png, e))?;
    panels_figure(
        SVGBackend::new(&tmp_svg, size).into_drawing_area(),
        title,
        (x, y),
        panels,
        shape,
        (log_y, log_x, title_font),
    )
    .map_err(|e| err(&svg, e))?;
    finish(&tmp_png, &png)?;
    finish(&tmp_svg, &svg)?;
    Ok(vec![png, svg])
}

/// The panels figure on one backend: the title, then `rows × cols` panels ([`panel_plot`]).
fn panels_figure<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    (x, y): (&str, &str),
    panels: &[Panel],
    (rows, cols): (usize, usize),
    (log_y, log_x, title_font): (Option<bool>, bool, u32),
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE).map_err(|e| e.to_string())?;
    let area = area
        .titled(title, ("sans-serif", title_font))
        .map_err(|e| e.to_string())?;
    for (cell, p) in area.split_evenly((rows, cols)).iter().zip(panels) {
        let (series, panel_title) = capped(&p.series, &p.title);
        let labels = Labels {
            title: &panel_title,
            x,
            y,
        };
        panel_plot(
            cell,
            &labels,
            &series,
            &p.bands,
            p.scatter,
            &[],
            log_y,
            log_x,
            16,
            &[],
            &[],
        )?;
    }
    area.present().map_err(|e| e.to_string())
}

/// Series `i` (`pts` as drawn, sorted by x): a line unless `scatter_only`, and markers (the
/// legend is drawn by `panel_plot`). Colours repeat every eight series; the marker shape tells
/// the repeats apart (circles, then triangles, then crosses).
fn draw_series<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    i: usize,
    pts: &[(f64, f64)],
    scatter_only: bool,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let color = palette(i);
    let shape = (i / 8) % 3;
    if !scatter_only {
        chart
            .draw_series(LineSeries::new(pts.to_vec(), color.stroke_width(2)))
            .map_err(|e| e.to_string())?;
    }
    match shape {
        0 => chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, color.filled()))),
        1 => chart.draw_series(
            pts.iter()
                .map(|p| TriangleMarker::new(*p, 6, color.filled())),
        ),
        _ => chart.draw_series(pts.iter().map(|p| Cross::new(*p, 5, color.stroke_width(2)))),
    }
    .map_err(|e| e.to_string())?;
    Ok(())
}

/// A column name as part of a file name: letters, digits, `_`, `-` and `.` kept, anything else
/// (a `/`, a space) as `_`, at most 64 characters. Column names come from files; they are data,
/// never path parts.
pub fn stem_part(name: &str) -> String {
    name.chars()
        .take(64)
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A file stem written into a results directory: a plain name — not empty, no path separator,
/// not starting with `.` — so the file stays in that directory.
pub(crate) fn check_stem(dir: &Path, stem: &str) -> Result<(), Error> {
    let plain = !stem.is_empty()
        && !stem.starts_with('.')
        && !stem.contains(['/', '\\', '\0'])
        && Path::new(stem).components().count() == 1;
    if plain {
        Ok(())
    } else {
        Err(Error::Io {
            path: dir.display().to_string(),
            reason: format!(
                "{stem:?} is not a plain file name: a plot is written only inside its directory"
            ),
        })
    }
}

/// A parameter's name in words, for titles and legends.
pub fn words(key: &str) -> String {
    match key {
        "alpha_deg" => "cone angle α (°)".into(),
        "order" => "SH order N".into(),
        "hemisphere_res" => "hemisphere resolution H".into(),
        "k_count" => "k-table size K".into(),
        "k_spacing" => "k spacing".into(),
        "k_interp" => "k interpolation".into(),
        "sampling_radius" => "sampling radius s".into(),
        "on_surface_eps" => "on-surface threshold ε".into(),
        "layout" => "layout".into(),
        "mesh" => "mesh".into(),
        "radius" => "probe radius ρ".into(),
        "k" => "scaling factor k".into(),
        "occ_rel_l2_mean" => "occlusion error (relative L2, mean over probes)".into(),
        "occ_rel_l2_max" => "occlusion error (relative L2, max over probes)".into(),
        "occ_rel_l2_p50" => "occlusion error (relative L2, median over probes)".into(),
        "vis_rel_l2_mean" => "visibility error (relative L2, mean over probes)".into(),
        "truth_rel_err_mean" => "truth's own error (relative, mean)".into(),
        "extrapolation_seconds" => "extrapolation time (s)".into(),
        "table_build_seconds" => "k-table build time (s)".into(),
        "bsv_sampling_seconds" => "BSV sampling time (s)".into(),
        "truth_seconds" => "truth time (s)".into(),
        "truth_res" => "truth resolution T".into(),
        "nonzeros" => "non-zero elements".into(),
        "shells" => "full-field shells".into(),
        "rays" => "rays per frame".into(),
        other => other.replace('_', " "),
    }
}

/// The Okabe–Ito palette (colour-blind safe), in order; series beyond eight repeat it.
const OKABE_ITO: [(u8, u8, u8); 8] = [
    (0, 114, 178),
    (230, 159, 0),
    (0, 158, 115),
    (213, 94, 0),
    (86, 180, 233),
    (204, 121, 167),
    (240, 228, 66),
    (0, 0, 0),
];

/// The colour of series `i`.
pub fn palette(i: usize) -> RGBAColor {
    let (r, g, b) = OKABE_ITO[i % OKABE_ITO.len()];
    RGBColor(r, g, b).to_rgba()
}

/// The largest magnitude a plot draws: beyond it a padded range would overflow to infinity
/// (±1e308 once made plotters' tick search spin forever). Larger values are left out, as
/// non-finite ones are.
pub const MAX_DRAWN: f64 = 1e300;

/// Whether a value can be drawn: finite and within ±[`MAX_DRAWN`].
pub(crate) fn drawable(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_DRAWN
}

/// Whether values should be drawn on a log axis: all finite and > 0, spanning ≥ 100×.
pub fn log_axis(ys: &[f64]) -> bool {
    let finite: Vec<f64> = ys.iter().copied().filter(|y| y.is_finite()).collect();
    if finite.is_empty() || finite.iter().any(|y| *y <= 0.0) {
        return false;
    }
    let (lo, hi) = finite
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(*y), b.max(*y)));
    hi / lo >= 100.0
}

/// The range `[lo, hi]` of data on an axis, widened where it is narrower than 10⁻⁹ of its
/// magnitude (one value, or values equal to the last digits): plotters' tick search needs a
/// finite, non-empty range. With `relative` (a linear y axis) ±10 % of the value (±0.5 at 0),
/// so a single positive error is not drawn on an axis reaching below zero; otherwise ±0.5 (half
/// a decade of a log axis, whose `lo`, `hi` are log10 values; a unit either side of an integer
/// parameter).
pub fn degenerate_span(lo: f64, hi: f64, relative: bool) -> (f64, f64) {
    let least = 1e-9 * lo.abs().max(hi.abs());
    if hi - lo > least {
        return (lo, hi);
    }
    let mid = 0.5 * lo + 0.5 * hi;
    let half = if !relative || mid == 0.0 {
        0.5
    } else {
        0.1 * mid.abs()
    };
    (mid - half.max(least), mid + half.max(least))
}

/// The drawn y range of data spanning `[y0, y1]` (`y0 < y1`): 5 % padding each side, the lower
/// end not below 0 when the data are non-negative (errors start at the axis) — and never above
/// the smallest value, so negative data are drawn where they are.
pub fn y_range(y0: f64, y1: f64) -> (f64, f64) {
    let pad = 0.05 * (y1 - y0);
    let lo = if y0 >= 0.0 {
        (y0 - pad).max(0.0)
    } else {
        y0 - pad
    };
    (lo, y1 + pad)
}

/// Write `stem.png` and `stem.svg` in `dir` (each to a temporary file, then renamed): one line
/// (or, with `scatter`, marker) series per entry of `series`, plus an optional black `front`.
pub fn write_both(
    dir: &Path,
    stem: &str,
    labels: &Labels,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    scatter: bool,
    front: &[(f64, f64)],
) -> Result<Vec<PathBuf>, Error> {
    write_both_log(dir, stem, labels, series, scatter, front, None)
}

/// The most series one plot draws: a legend of more is unreadable (and the file grows with it).
pub const MAX_SERIES: usize = 24;

/// The most points one plot draws (markers, and the vertices of its lines): a plot of 10⁵ rows
/// would otherwise be an SVG of megabytes that a browser draws slowly and nobody can read.
pub const MAX_POINTS: usize = 4000;

/// At most [`MAX_SERIES`] of `series`, evenly spaced over their (sorted) names so the first and
/// the last are kept; then, when they hold more than [`MAX_POINTS`] points, every `s`-th point of
/// each (in x order, its first and last kept); the title says what was left out.
fn capped(
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    title: &str,
) -> (BTreeMap<String, Vec<(f64, f64)>>, String) {
    let n = series.len();
    let (mut kept, mut title) = if n <= MAX_SERIES {
        (series.clone(), title.to_string())
    } else {
        let keep: Vec<usize> = (0..MAX_SERIES)
            .map(|i| i * (n - 1) / (MAX_SERIES - 1))
            .collect();
        let kept = (series.iter().enumerate())
            .filter(|(i, _)| keep.contains(i))
            .map(|(_, (k, v))| (k.clone(), v.clone()))
            .collect();
        (
            kept,
            format!("{title} ({MAX_SERIES} of {n} series shown, evenly spaced)"),
        )
    };
    let total: usize = kept.values().map(Vec::len).sum();
    if total > MAX_POINTS {
        let step = total.div_ceil(MAX_POINTS);
        let mut drawn = 0;
        for pts in kept.values_mut() {
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let last = pts.len().saturating_sub(1);
            *pts = (pts.iter().enumerate())
                .filter(|(i, _)| i % step == 0 || *i == last)
                .map(|(_, p)| *p)
                .collect();
            drawn += pts.len();
        }
        title = format!("{title} (1 point in {step} drawn: {drawn} of {total})");
    }
    (kept, title)
}

/// [`write_both`] with the y axis forced linear (`Some(false)`) or logarithmic (`Some(true)`);
/// `None` decides by the data ([`log_axis`]).
pub fn write_both_log(
    dir: &Path,
    stem: &str,
    labels: &Labels,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    scatter: bool,
    front: &[(f64, f64)],
    log: Option<bool>,
) -> Result<Vec<PathBuf>, Error> {
    check_stem(dir, stem)?;
    ensure_font();
    let (series, title) = capped(series, labels.title);
    let (series, labels) = (
        &series,
        &Labels {
            title: &title,
            ..*labels
        },
    );
    // Both files to temporaries first, then both renamed: a failure leaves neither a new
    // file nor a temporary (the guard removes them on every path out).
    let mut tmps = crate::atomic::Temporaries::new();
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let (tmp_png, tmp_svg) = (tmps.beside(&png), tmps.beside(&svg));
    line_plot(
        BitMapBackend::new(&tmp_png, (900, 600)).into_drawing_area(),
        labels,
        series,
        scatter,
        front,
        log,
        false,
        &[],
        &[],
    )
    .map_err(|e| err(&png, e))?;
    line_plot(
        SVGBackend::new(&tmp_svg, (900, 600)).into_drawing_area(),
        labels,
        series,
        scatter,
        front,
        log,
        false,
        &[],
        &[],
    )
    .map_err(|e| err(&svg, e))?;
    finish(&tmp_png, &png)?;
    finish(&tmp_svg, &svg)?;
    Ok(vec![png, svg])
}

#[cfg(test)]
mod tests {
    #[test]
    fn tick_labels_keep_three_significant_digits() {
        for (x, want) in [
            (63095.734, "6.31e4"),
            (251.188, "251"),
            (0.0123456, "0.0123"),
            (1.0, "1"),
            (2.5, "2.5"),
            (-2.5, "-2.5"),
            (0.001234, "1.23e-3"),
            (1e-9, "1e-9"),
            (1e6, "1e6"),
            (0.0, "0"),
        ] {
            assert_eq!(super::significant(x, 3), want, "{x}");
        }
    }

    #[test]
    fn plots_cap_their_series_and_say_so() {
        use std::collections::BTreeMap;
        let series: BTreeMap<String, Vec<(f64, f64)>> = (0..100)
            .map(|i| (format!("s{i:03}"), vec![(0.0, i as f64)]))
            .collect();
        let (kept, title) = super::capped(&series, "t");
        assert_eq!(kept.len(), super::MAX_SERIES);
        assert!(kept.contains_key("s000") && kept.contains_key("s099"));
        assert_eq!(title, "t (24 of 100 series shown, evenly spaced)");
        let few: BTreeMap<String, Vec<(f64, f64)>> = series.into_iter().take(24).collect();
        let (kept, title) = super::capped(&few, "t");
        assert_eq!((kept.len(), title.as_str()), (24, "t"));
        // 3 × 5000 points: 1 in 4 drawn per series (x order), first and last kept.
        let many: BTreeMap<String, Vec<(f64, f64)>> = (0..3)
            .map(|s| {
                let pts = (0..5000).rev().map(|i| (i as f64, s as f64)).collect();
                (format!("s{s}"), pts)
            })
            .collect();
        let (kept, title) = super::capped(&many, "t");
        let drawn: usize = kept.values().map(Vec::len).sum();
        assert!(drawn <= super::MAX_POINTS, "{drawn}");
        assert_eq!(title, format!("t (1 point in 4 drawn: {drawn} of 15000)"));
        for pts in kept.values() {
            assert_eq!(
                (pts[0].0, pts[pts.len() - 1].0, pts[1].0),
                (0.0, 4999.0, 4.0)
            );
        }
    }

    #[test]
    fn extreme_values_and_hostile_names_never_hang_or_escape() {
        use std::collections::BTreeMap;
        let d = std::env::temp_dir().join(format!("shscale-plots-extreme-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let labels = super::Labels {
            title: "t",
            x: "x",
            y: "y",
        };
        // ±1e308 once spun plotters' tick search forever: left out, the rest drawn.
        for pts in [
            vec![(0.0, 1e308), (1.0, -1e308), (2.0, 1.0), (3.0, 2.0)],
            vec![(0.0, 1e300), (1.0, -1e300)],
            vec![(1e300, 1.0), (1e300, 1.0)],
            vec![(0.0, 1.0), (1.0, 1.0 + 1e-15)],
            vec![(5.0, 3.0)],
        ] {
            let series: BTreeMap<String, Vec<(f64, f64)>> = [("s".to_string(), pts.clone())].into();
            let files = super::write_both(&d, "p", &labels, &series, false, &pts).unwrap();
            assert_eq!(files.len(), 2, "{pts:?}");
        }
        let only_huge: BTreeMap<String, Vec<(f64, f64)>> =
            [("s".to_string(), vec![(0.0, 1e308), (1.0, f64::MAX)])].into();
        let e = super::write_both(&d, "p", &labels, &only_huge, false, &[]).unwrap_err();
        assert!(e.to_string().contains("no finite data to plot"), "{e}");
        // A stem is a plain name; a column name is made one.
        let ok: BTreeMap<String, Vec<(f64, f64)>> = [("s".to_string(), vec![(0.0, 1.0)])].into();
        for bad in ["../up", "a/b", "", ".hidden", ".."] {
            let e = super::write_both(&d, bad, &labels, &ok, false, &[]).unwrap_err();
            assert!(
                e.to_string().contains("not a plain file name"),
                "{bad}: {e}"
            );
        }
        assert_eq!(super::stem_part("../../x y"), ".._.._x_y");
        assert!(!d.parent().unwrap().join("up.png").exists());
        // No temporary left behind by a refusal.
        let left: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .filter(|n| n.contains(".tmp-"))
            .collect();
        assert!(left.is_empty(), "{left:?}");
        std::fs::remove_dir_all(&d).ok();
    }

    use super::y_range;

    /// Data spanning two decades or more go on a log axis; negative, zero or narrow data do not.
    #[test]
    fn log_axis_when_data_span_decades() {
        assert!(super::log_axis(&[1e-6, 3e-4, 1e-2]));
        assert!(super::log_axis(&[1.0, 100.0]));
        assert!(!super::log_axis(&[1.0, 99.0]));
        assert!(!super::log_axis(&[0.0, 1e-6, 1.0]));
        assert!(!super::log_axis(&[-1.0, 1e3]));
        assert!(!super::log_axis(&[]));
        assert!(super::log_axis(&[f64::NAN, 1e-3, 1.0]));
    }

    /// One value (or values equal to the last digits) gets a drawable range around it: ±10 % on
    /// a linear y axis — a single error of 0.068 stays above zero —, ±0.5 otherwise (half a
    /// decade on a log axis, a unit around an integer parameter); 0 gets ±0.5; a real span is
    /// kept.
    #[test]
    fn a_single_value_gets_a_range_around_it() {
        for (v, relative, want) in [
            (0.068, true, (0.0612, 0.0748)),
            (-2.0, true, (-2.2, -1.8)),
            (0.0, true, (-0.5, 0.5)),
            (-0.4, false, (-0.9, 0.1)),
            (4.0, false, (3.5, 4.5)),
            (1e12, true, (0.9e12, 1.1e12)),
        ] {
            let (lo, hi) = super::degenerate_span(v, v, relative);
            println!("{v} (relative {relative}) → [{lo}, {hi}]");
            assert!((lo - want.0).abs() <= 1e-12 * want.0.abs().max(1.0), "{lo}");
            assert!((hi - want.1).abs() <= 1e-12 * want.1.abs().max(1.0), "{hi}");
        }
        assert_eq!(super::degenerate_span(0.1, 0.2, true), (0.1, 0.2));
        let (lo, hi) = super::degenerate_span(0.068, 0.068 * (1.0 + 1e-12), true);
        assert!(lo > 0.0 && hi > lo, "{lo} {hi}");
    }

    /// A series reaching −0.76 (an element of M_k, Fig. 3) stays inside the drawn range; data
    /// that are non-negative keep their axis at or above 0.
    #[test]
    fn negative_values_stay_inside_the_drawn_range() {
        for (y0, y1) in [
            (-0.76, 1.09),
            (-3.0, -1.0),
            (0.0, 2.0),
            (0.2, 0.3),
            (1e-9, 1e-8),
        ] {
            let (lo, hi) = y_range(y0, y1);
            println!("data [{y0}, {y1}] → drawn [{lo}, {hi}]");
            assert!(
                lo < y0 || (lo == 0.0 && y0 == 0.0),
                "{y0} below the drawn {lo}"
            );
            assert!(hi > y1, "{y1} above the drawn {hi}");
            if y0 >= 0.0 {
                assert!(lo >= 0.0, "non-negative data drawn from {lo}");
            }
        }
    }
}
