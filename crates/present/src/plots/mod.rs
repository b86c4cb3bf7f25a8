//! Plots of a run directory's `runs.csv` (plotters; PNG and SVG, written to a temporary name and
//! renamed): the error against the swept parameter with one series per probe radius, and the
//! speed/accuracy scatter of all runs with its Pareto front. Every plot: the Okabe–Ito palette
//! (colour-blind safe), a log y axis when the data span two decades or more ([`log_axis`]),
//! integer ticks when x is an integer parameter, and a y range that never clips ([`y_range`]). Text uses the bundled DejaVu Sans
//! (assets/fonts, Bitstream Vera licence), so nothing is needed from the system at run time.
//!
//! [`axes`]: axis ranges, log axes and ticks; [`draw`]: one chart's series, bands, bars,
//! legend and notes; [`panels`]: multi-panel figures and scatter plots; [`names`]: file stems
//! and the words of series names.

mod axes;
mod draw;
mod names;
mod panels;
#[cfg(test)]
mod tests;

pub use axes::*;
pub use draw::*;
pub use names::*;
pub use panels::*;

use crate::error::Error;
use crate::font::{caption_size, significant};
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use crate::font::ensure_font;

/// A results CSV (read through the `csv` crate).
pub type Table = shscale_files::Table;

pub(crate) fn err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

pub(crate) fn finish(tmp: &Path, path: &Path) -> Result<(), Error> {
    Ok(shscale_files::atomic::rename_durable(tmp, path)?)
}

/// Title and axis labels (with units) of a plot.
pub struct Labels<'a> {
    pub title: &'a str,
    pub x: &'a str,
    pub y: &'a str,
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

/// The most points one plot draws (markers, and the vertices of its lines): a plot of 10⁵ rows
/// would otherwise be an SVG of megabytes that a browser draws slowly and nobody can read.
pub const MAX_POINTS: usize = 4000;
