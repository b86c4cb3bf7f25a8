//! Axis ranges and descriptions: linear or log, degenerate spans widened, the drawable values.

use super::*;

/// The axes of a line plot: ranges, whether y is drawn as log10 y, and the x ticks.
pub(super) struct Axes {
    pub(super) log_x: bool,
    pub(super) log_y: bool,
    pub(super) integer_x: bool,
    pub(super) x: (f64, f64),
    pub(super) y: (f64, f64),
    pub(super) x_ticks: usize,
}

impl Axes {
    /// A tick label of the x (`x_axis`) or y axis at drawn coordinate `v`: a log axis over two
    /// decades or more is labelled at the decades, a narrower one at every tick with its value;
    /// an integer x axis without decimals; else rounded to 1e-6.
    pub(super) fn tick(&self, v: f64, x_axis: bool) -> String {
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
    pub(super) fn of_xy(
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
    pub(super) fn tx(&self, x: f64) -> f64 {
        if self.log_x {
            x.log10()
        } else {
            x
        }
    }

    /// A y value as drawn.
    pub(super) fn ty(&self, y: f64) -> f64 {
        if self.log_y {
            y.log10()
        } else {
            y
        }
    }
}

/// An axis's description, saying when it is drawn on a log scale.
pub(super) fn axis_desc(label: &str, log: bool) -> String {
    if log {
        format!("{label} — log scale")
    } else {
        label.to_string()
    }
}

/// The points that set a panel's ranges: the series, the bands' ends (a band is never clipped)
/// and the bars' ends.
pub(super) fn ranged(
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
pub(crate) fn degenerate_span(lo: f64, hi: f64, relative: bool) -> (f64, f64) {
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
