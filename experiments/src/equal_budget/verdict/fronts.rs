//! The front plots: error against a budget column, one series per method variant.

use super::*;

/// What a front plot shows: its file stem and title, the budget column `x` and the error column
/// `y`, each with its axis label.
pub(crate) struct Front<'a> {
    pub stem: String,
    pub title: String,
    pub x: &'a str,
    pub x_label: &'a str,
    pub y: &'a str,
    pub y_label: &'a str,
}

/// A method's family: one colour and marker each on the front plots (at most eight).
fn family(s: &Spec) -> &'static str {
    match s {
        Spec::FullField(_) if is_papers_field(s) => "full field (papers')",
        Spec::FullField(_) => "full field (other shells)",
        Spec::RayTraced(RayTracedSpec { .. }) => "ray tracing",
        Spec::SphereSet(SetSpec { .. }) => "sphere sets",
        Spec::SubVolumes(SubVolumeSpec { .. }) => "sub-volumes",
        Spec::Extrapolated(_) if is_papers_extrapolation(s) => "extrapolation (papers')",
        Spec::Extrapolated(_) => "extrapolation (variants)",
    }
}

/// Points at x = 0 (a method that casts no rays) cannot sit on a log axis: they are drawn at
/// `x0` (a quarter of the smallest positive x of the figure), and (with `rename`) their series
/// says so. Returns whether any point moved.
pub(crate) fn place_zeros(
    series: &mut BTreeMap<String, Vec<(f64, f64)>>,
    x0: f64,
    rename: bool,
) -> bool {
    let zero_keys: Vec<String> = (series.iter())
        .filter(|(_, v)| v.iter().any(|p| p.0 == 0.0))
        .map(|(k, _)| k.clone())
        .collect();
    for k in &zero_keys {
        let mut v = series.remove(k).unwrap_or_default();
        for p in v.iter_mut().filter(|p| p.0 == 0.0) {
            p.0 = x0;
        }
        let k = if rename {
            format!("{k} (0 at the left edge)")
        } else {
            k.clone()
        };
        series.insert(k, v);
    }
    !zero_keys.is_empty()
}

/// One front plot: the error column `y` of `rows` against the budget column `x` (rays, bytes or
/// `frame_seconds`, then with the interval of each median as bars), one series per method
/// family ([`family`]: one colour and marker each), the Pareto front drawn over them; a method
/// at zero cost is drawn at the left edge (log axes have no 0), its legend entry says so. A
/// companion `<stem>_by_family` draws one panel per family, one series per variant
/// ([`variant`]). Nothing is written without a finite point.
pub(crate) fn write_front(
    dir: &Path,
    t: &Results,
    rows: &[usize],
    f: &Front,
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> Result<Vec<PathBuf>, Error> {
    let (variants, bars) = front_points(t, rows, f, spec_of);
    // One series per family: its variants' points together.
    let mut series: Series = (variants.iter())
        .map(|(fam, v)| (fam.to_string(), v.values().flatten().copied().collect()))
        .collect();
    let Some(min_pos) = (series.values().flatten())
        .map(|p| p.0)
        .filter(|&x| x > 0.0)
        .reduce(f64::min)
    else {
        return Ok(Vec::new());
    };
    let x0 = min_pos / 4.0;
    // The front over the true costs, then placed like its points.
    let mut front = pareto(series.values().flatten().copied());
    for p in front.iter_mut().filter(|p| p.0 == 0.0) {
        p.0 = x0;
    }
    let zeros = place_zeros(&mut series, x0, true);
    for v in series.values_mut() {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let title = if zeros {
        format!("{} (zero cost at the left edge)", f.title)
    } else {
        f.title.clone()
    };
    let labels = Labels {
        title: &title,
        x: f.x_label,
        y: f.y_label,
    };
    let bars = if f.x == "frame_seconds" {
        &bars[..]
    } else {
        &[]
    };
    let mut files = write_scatter_noted(dir, &f.stem, &labels, &series, &front, bars, true, &[])?;
    files.extend(write_by_family(dir, f, variants, x0)?);
    Ok(files)
}

/// The points of a front: per family ([`family`]) its variants' ([`variant`]) `(x, y)` with a
/// finite y and a finite x ≥ 0, and per point its `(y, time low, time high)` bar.
fn front_points(
    t: &Results,
    rows: &[usize],
    f: &Front,
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> (ByFamily, Vec<(f64, f64, f64)>) {
    let mut variants: ByFamily = BTreeMap::new();
    let mut bars = Vec::new();
    for &r in rows {
        let (xv, y) = (t.num(r, f.x), t.num(r, f.y));
        let Some(spec) = spec_of(r) else { continue };
        if xv.is_finite() && xv >= 0.0 && y.is_finite() {
            (variants.entry(family(&spec)).or_default())
                .entry(variant(&spec))
                .or_default()
                .push((xv, y));
            let (lo, hi) = (t.num(r, "frame_seconds_lo"), t.num(r, "frame_seconds_hi"));
            bars.push((y, lo, hi));
        }
    }
    (variants, bars)
}

/// The `<stem>_by_family` companion of a front: one panel per family, markers only, one series
/// per variant, zero-cost points at `x0` (said in the panel's title).
fn write_by_family(
    dir: &Path,
    f: &Front,
    variants: ByFamily,
    x0: f64,
) -> Result<Vec<PathBuf>, Error> {
    let panels: Vec<Panel> = (variants.into_iter())
        .map(|(fam, mut series)| {
            let zeros = place_zeros(&mut series, x0, false);
            Panel {
                title: if zeros {
                    format!("{fam} (zero cost at the left edge)")
                } else {
                    fam.to_string()
                },
                series,
                bands: Default::default(),
                scatter: true,
            }
        })
        .collect();
    Ok(write_panels(
        dir,
        &format!("{}_by_family", f.stem),
        &format!("{}: each family's variants", f.title),
        f.x_label,
        f.y_label,
        &panels,
        None,
        true,
    )?)
}
