//! Multi-panel figures and noted scatter plots, each written as PNG and SVG.

use super::*;

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
    let mut tmps = shscale_files::atomic::Temporaries::new();
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
    let mut tmps = shscale_files::atomic::Temporaries::new();
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
pub(super) fn panels_figure<DB: DrawingBackend>(
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
    let mut tmps = shscale_files::atomic::Temporaries::new();
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
