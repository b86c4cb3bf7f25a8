//! One chart's contents: its series, interval bands, x bars, legend, title and notes, within
//! the caps on series and points.

use super::*;

/// Draw `series` (name → points) as lines with markers; x and y labelled with units.
#[allow(clippy::too_many_arguments)]
pub(super) fn line_plot<DB: DrawingBackend>(
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
pub(super) fn panel_plot<DB: DrawingBackend>(
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
pub(super) fn title_and_legend(
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
pub(super) fn draw_notes<'a, DB: DrawingBackend + 'a>(
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

/// The bands of `series` (by name), under the lines: the polygon of (x, low) forward and
/// (x, high) back, at most `MAX_POINTS / 4` vertices a side.
pub(super) fn draw_bands<'a, DB: DrawingBackend + 'a>(
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
pub(super) fn draw_xbars<'a, DB: DrawingBackend + 'a>(
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
pub(super) fn draw_legend<DB: DrawingBackend>(
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

/// Series `i` (`pts` as drawn, sorted by x): a line unless `scatter_only`, and markers (the
/// legend is drawn by `panel_plot`). Colours repeat every eight series; the marker shape tells
/// the repeats apart (circles, then triangles, then crosses).
pub(super) fn draw_series<'a, DB: DrawingBackend + 'a>(
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

/// The Okabe–Ito palette (colour-blind safe), in order; series beyond eight repeat it.
pub(super) const OKABE_ITO: [(u8, u8, u8); 8] = [
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

/// The most series one plot draws: a legend of more is unreadable (and the file grows with it).
pub const MAX_SERIES: usize = 24;

/// At most [`MAX_SERIES`] of `series`, evenly spaced over their (sorted) names so the first and
/// the last are kept; then, when they hold more than [`MAX_POINTS`] points, every `s`-th point of
/// each (in x order, its first and last kept); the title says what was left out.
pub(super) fn capped(
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
