//! The `probe` kind's pictures: the papers' Fig. 5 image of one run (true vs extrapolated
//! visibility per probe radius) and the plots of a results directory (the error against every
//! varying numeric parameter, and the speed/accuracy Pareto scatter).

use shscale_geometry::Occluder;
use shscale_present::plots::{words, Labels};
use shscale_runner::records::Results as Table;
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::path::Path;
use std::path::PathBuf;

/// The papers' Fig. 5 for one run: per probe radius (rows), the ray-traced full-frequency
/// visibility (left) and the extrapolated band-limited visibility (right) at one probe point,
/// lat-long maps in the entity frame (row 0 = +z). Written as
/// `visibility_truth_vs_extrapolated_<run id>.exr` (the values, both columns side by side) and a
/// `.png` with labelled panels (what each shows, the radius and the point's direction), φ/θ axes
/// in degrees and a grey-scale bar (0 occluded … 1 visible; extrapolated values outside [0, 1]
/// are clipped in the picture, not in the EXR).
pub(crate) fn visibility_figure(
    dir: &Path,
    run_id: &str,
    order: usize,
    occ: &dyn Occluder,
    examples: &[super::driver::Example],
) -> Result<(), Error> {
    const W: usize = 256;
    const H: usize = 128;
    if examples.is_empty() {
        return Ok(());
    }
    let basis = shscale_sh::ShBasis::<f64>::new(order).map_err(Error::from)?;
    let set = shscale_sh::DirectionSet::latlong(H, W);
    let mut px = vec![[0f32; 3]; 2 * W * H * examples.len()];
    let mut rows = Vec::new();
    let mut y = vec![0.0; order * order];
    let centre = occ.bounding_sphere().center;
    for (row, ex) in examples.iter().enumerate() {
        let truth = shscale_field::truth::visibility_map(occ, ex.point, W, H);
        let mut extrapolated = vec![0f32; W * H];
        for j in 0..H {
            for i in 0..W {
                let base = (row * H + j) * 2 * W;
                let t = truth[j * W + i];
                px[base + i] = [t; 3];
                basis.eval(set.dirs[j * W + i], &mut y);
                let v: f64 = ex.extrapolated.iter().zip(&y).map(|(a, b)| a * b).sum();
                px[base + W + i] = [v as f32; 3];
                extrapolated[j * W + i] = v as f32;
            }
        }
        let d = (ex.point - centre).normalize_or_zero();
        let where_ = format!(
            "{}r, at θ = {:.0}°, φ = {:.0}°",
            ex.radius,
            d.z.clamp(-1.0, 1.0).acos().to_degrees(),
            d.y.atan2(d.x).to_degrees().rem_euclid(360.0)
        );
        let truth_title = if ex.inside {
            format!("inside the mesh (no truth), {where_}")
        } else {
            format!("ray-traced (full frequency), {where_}")
        };
        rows.push(vec![
            shscale_present::figure::Panel {
                title: truth_title,
                width: W,
                height: H,
                values: truth.clone(),
            },
            shscale_present::figure::Panel {
                title: format!("extrapolated (SH order {order}), {where_}"),
                width: W,
                height: H,
                values: extrapolated,
            },
        ]);
    }
    let exr = dir.join(format!("visibility_truth_vs_extrapolated_{run_id}.exr"));
    shscale_present::image::write_exr(&exr, 2 * W, H * examples.len(), &px)?;
    Ok(shscale_present::figure::write_png(
        &exr.with_extension("png"),
        &shscale_present::figure::Grid {
            title:
                "visibility at the probe radii: ray-traced vs extrapolated from the bounding sphere",
            rows,
            x: (0.0, 360.0, "azimuth φ (°)"),
            y: (0.0, 180.0, "polar angle θ from +z (°)"),
            colours: shscale_present::figure::ColourMap::Grey,
            range: (0.0, 1.0),
            scale_label: "visibility (1 = unoccluded)",
            panel_px: (384, 192),
        },
    )?)
}

/// The numeric parameters a probe sweep can plot against.
pub(crate) const NUMERIC_PARAMS: &[&str] = &[
    "order",
    "hemisphere_res",
    "k_count",
    "alpha_deg",
    "sampling_radius",
    "on_surface_eps",
];

/// Plots of a probe results directory: for every numeric parameter P that varies in the CSV,
/// `occ_rel_l2` against P — one series per combination of the other varying parameters
/// (averaged over the probe radii), or one series per probe radius when nothing else varies —
/// and the speed/accuracy scatter with its Pareto front (rows timed concurrently with other
/// runs are left out of it). Returns the files written.
pub(crate) fn probe_plots(
    dir: &Path,
    t: &Table,
    varying: &[String],
) -> Result<Vec<PathBuf>, Error> {
    let numeric: Vec<&str> = varying
        .iter()
        .map(String::as_str)
        .filter(|k| NUMERIC_PARAMS.contains(k))
        .collect();
    let params: Vec<&str> = if numeric.is_empty() {
        vec!["radius"]
    } else {
        numeric.clone()
    };
    let mut files = Vec::new();
    for &param in &params {
        files.extend(error_against(dir, t, varying, param)?);
    }
    // Exactly two swept parameters (nothing else varies): the error over both at once.
    if let [a, b] = numeric.as_slice() {
        if varying.iter().filter(|v| v.as_str() != "radii").count() == 2 {
            files.extend(heat_map(dir, t, a, b)?);
        }
    }
    files.extend(pareto(dir, t, varying)?);
    Ok(files)
}

/// `occ_rel_l2` (mean over probes) over two swept parameters, one panel per probe radius: a heat
/// map with every cell's value written in it.
fn heat_map(dir: &Path, t: &Table, x: &str, y: &str) -> Result<Vec<PathBuf>, Error> {
    let values = |c: &str| t.distinct_in(0..t.rows.len(), c);
    let (xs, ys, radii) = (values(x), values(y), values("radius"));
    if radii.len() > shscale_present::plots::MAX_PANELS {
        return Ok(Vec::new());
    }
    let panels: Vec<shscale_present::heatmap::HeatPanel> = (radii.iter())
        .map(|rho| {
            let mut cells = vec![vec![None; xs.len()]; ys.len()];
            for r in (0..t.rows.len()).filter(|&r| t.cell(r, "radius") == rho) {
                let v = t.num(r, "occ_rel_l2_mean");
                let i = xs.iter().position(|s| s == t.cell(r, x));
                let j = ys.iter().position(|s| s == t.cell(r, y));
                if let (Some(i), Some(j)) = (i, j) {
                    cells[j][i] = v.is_finite().then_some(v);
                }
            }
            shscale_present::heatmap::HeatPanel {
                title: format!("probe radius ρ = {rho}"),
                cells,
            }
        })
        .collect();
    let title = format!(
        "occlusion error (relative L2, mean over probes) over {} and {}",
        words(x),
        words(y)
    );
    Ok(shscale_present::heatmap::write_heatmap(
        dir,
        &format!("occ_rel_l2_heatmap_{x}_{y}"),
        &title,
        (&words(x), &xs),
        (&words(y), &ys),
        &panels,
    )?)
}

/// `occ_rel_l2` (mean over probes, with its interquartile band) against `param`: one series per
/// combination of the other varying parameters and the probe radius (nothing is averaged),
/// faceted into one panel per probe radius when that would make more than eight series.
fn error_against(
    dir: &Path,
    t: &Table,
    varying: &[String],
    param: &str,
) -> Result<Vec<PathBuf>, Error> {
    // A run whose probes are all inside the occluder (or all see nothing occluded) has no error
    // to plot; the summary says what it has.
    let plotted = |r: usize| t.num(r, "occ_rel_l2_mean").is_finite() && t.num(r, param).is_finite();
    if !(0..t.rows.len()).any(plotted) {
        return Ok(Vec::new());
    }
    let mut keys: Vec<String> = (varying.iter())
        .filter(|k| k.as_str() != "radii")
        .cloned()
        .collect();
    keys.push("radius".to_string());
    let title = format!("extrapolation error against {}", words(param));
    let stem = format!("occ_rel_l2_vs_{param}");
    let spec = shscale_present::column_plot::PlotSpec {
        metric: "occ_rel_l2_mean",
        x: param,
        series: &[],
        facet: None,
        filters: &[],
        log_y: None,
        log_x: false,
        stem: Some(&stem),
        title: Some(&title),
    };
    Ok(shscale_present::column_plot::plot_column(
        dir, t, &keys, &spec,
    )?)
}

/// Per run not timed alongside others, in run-id order: its name (its `varying` parameters),
/// and (time in ms, the bound on its spread in ms, its error averaged over its radii). The time
/// is BSV sampling + k-table once plus the extrapolation at every radius; a stage's bound is
/// its median × its spread.
fn timed_runs(t: &Table, varying: &[String]) -> Vec<(String, (f64, f64, f64))> {
    // Per run: (time, the bound on its spread, error sum, error count), and its name.
    let mut runs: BTreeMap<String, (f64, f64, f64, usize)> = BTreeMap::new();
    let mut names: BTreeMap<String, String> = BTreeMap::new();
    let spread = |r: usize, c: &str| {
        let s = t.num(r, &format!("{c}_spread"));
        t.num(r, &format!("{c}_seconds")) * if s.is_finite() { s } else { 0.0 }
    };
    for r in 0..t.rows.len() {
        if t.cell(r, "timing_concurrent") == "true" {
            continue;
        }
        let id = t.rows[r][0].clone();
        names.entry(id.clone()).or_insert_with(|| {
            (varying.iter())
                .map(|c| format!("{c} = {}", t.cell(r, c)))
                .collect::<Vec<_>>()
                .join(", ")
        });
        let time = t.num(r, "bsv_sampling_seconds") + t.num(r, "table_build_seconds");
        let bound = spread(r, "bsv_sampling") + spread(r, "table_build");
        let e = runs.entry(id).or_insert((time, bound, 0.0, 0));
        let v = t.num(r, "occ_rel_l2_mean");
        if v.is_finite() {
            e.2 += v;
            e.3 += 1;
        }
        e.0 += t.num(r, "extrapolation_seconds");
        e.1 += spread(r, "extrapolation");
    }
    (runs.iter())
        .filter(|(_, v)| v.3 > 0 && v.0.is_finite())
        .map(|(id, v)| (names[id].clone(), (v.0 * 1e3, v.1 * 1e3, v.2 / v.3 as f64)))
        .collect()
}

/// Per run: total time of the extrapolation path against its error averaged over radii, with
/// the Pareto front, each front point named by the run's `varying` parameters; rows timed
/// alongside other runs are left out (none when all were).
fn pareto(dir: &Path, t: &Table, varying: &[String]) -> Result<Vec<PathBuf>, Error> {
    let named = timed_runs(t, varying);
    let runs: Vec<(f64, f64, f64)> = named.iter().map(|(_, v)| *v).collect();
    let pts: Vec<(f64, f64)> = runs.iter().map(|&(x, _, y)| (x, y)).collect();
    if pts.is_empty() {
        // Every run was timed alongside others (parallel_runs = true): no comparable times.
        return Ok(Vec::new());
    }
    // Each stage's median ± (max − min) of its repeats contains every repeat: the bar is the sum
    // of those bounds, so it covers what the repeats measured (and a front point whose bar
    // reaches past another's is not told apart from it by the timing).
    let bars: Vec<(f64, f64, f64)> = (runs.iter())
        .map(|&(x, b, y)| (y, (x - b).max(0.0), x + b))
        .collect();
    let mut sorted = pts.clone();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for p in sorted {
        if p.1 < best {
            best = p.1;
            front.push(p);
        }
    }
    let mut series = BTreeMap::new();
    series.insert("one point per run".to_string(), pts);
    let labels = Labels {
        title: "speed against accuracy per run, with the Pareto front (bars: spread of the timed repeats)",
        x: "time per run (ms: BSV sampling + k-table + extrapolation)",
        y: "occ_rel_l2, mean over the run's probe radii (1)",
    };
    // Each front point named by its run (the first run with those coordinates).
    let notes: Vec<((f64, f64), String)> = (front.iter())
        .filter_map(|&p| {
            let (name, _) = named.iter().find(|(_, v)| (v.0, v.2) == p)?;
            (!name.is_empty()).then(|| (p, name.clone()))
        })
        .collect();
    Ok(shscale_present::plots::write_scatter_noted(
        dir,
        "pareto_time_vs_error",
        &labels,
        &series,
        &front,
        &bars,
        false,
        &notes,
    )?)
}
