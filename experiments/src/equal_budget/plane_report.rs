//! The `budget_plane` kind's report, figure, verdict and discussion, from its rows: the fronts
//! per scene and frame count, the verdict table per regime, equal accuracy in words.

use super::plane_images::{figure_runs, write_plane_figure};
use super::plane_params::Params;
use super::verdict::{
    by_config, config_keys, distinct_pairs, equal_accuracy, plot_name, specs_of, speed_claim,
    splits_by, variant, verdict_table, write_front, Front, Split,
};
use super::NEAR_RHO;
use shscale_runner::records::Results;
use shscale_scene::method::Spec;
use shscale_scene::Error;
use std::path::{Path, PathBuf};

/// The rows as splits (still, or a sequence's frame count) of groups (one per scene) of
/// configurations.
fn plane_splits(t: &Results) -> Vec<Split> {
    let keys = config_keys::<Params>(&PLANE_GROUPING);
    let place = |scene: &str, frames: &str| {
        let label = if frames == "1" {
            "still".to_string()
        } else {
            format!("{frames} frames")
        };
        (label, plot_name(scene))
    };
    splits_by(t, ("scene", "frames"), &keys, &specs(t), &place)
}

/// The plane's regimes with intervals: (column, words).
fn plane_regimes() -> Vec<(String, String)> {
    let bins = (0..=super::surface::SURFACE_EDGES.len()).map(|k| {
        (
            format!("rmse_s{k}_vs_full_frequency"),
            super::surface::bin_words(k),
        )
    });
    [
        ("rmse_vs_full_frequency", "all, full-frequency truth"),
        ("rmse_near_vs_full_frequency", "near (ρ ≤ 1.3)"),
        ("rmse_far_vs_full_frequency", "far"),
    ]
    .map(|(c, w)| (c.to_string(), w.to_string()))
    .into_iter()
    .chain(bins)
    .chain(std::iter::once((
        "rmse_vs_band_limited".to_string(),
        "all, band-limited truth".to_string(),
    )))
    .collect()
}

/// The receivers in words when the rows hold several placements (`None` with one: no interval).
fn placements_grid(t: &Results) -> Option<String> {
    let placements = t.distinct_in(0..t.rows.len(), "placement_seed").len();
    (placements > 1).then(|| format!(
        "The receiver plane: {} receivers per scene, near = within {NEAR_RHO} bounding radii of an occluder's centre, d = distance to the nearest occluder's surface in its radii (each frame's pose); shade_rmse_rel against full-frequency truth unless said, sequences meaned over their frames; {placements} placements (each its own random rotation of every mesh occluder, truths rendered per placement)",
        t.cell(0, "receivers"),
    ))
}

/// The columns a plane configuration repeats over (or is split by): the scene, its frames, the
/// placement seed.
const PLANE_GROUPING: [&str; 3] = ["scene", "frames", "placement_seed"];

/// Every row's method, parsed once from its cells.
fn specs(t: &Results) -> Vec<Option<Spec>> {
    specs_of::<Params>(t, |p| p.spec().ok())
}

pub(super) fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
    let specs = specs(t);
    let mut files = Vec::new();
    for (si, (scene, frames)) in distinct_pairs(t, "scene", "frames").iter().enumerate() {
        let rows: Vec<usize> = (0..t.rows.len())
            .filter(|&r| t.cell(r, "scene") == scene && t.cell(r, "frames") == frames)
            .collect();
        let name = Path::new(scene)
            .file_stem()
            .map_or(scene.clone(), |s| s.to_string_lossy().into_owned());
        let title = if frames == "1" {
            name
        } else {
            format!("{name}, {frames} frames")
        };
        for (x, stem, x_label, short) in [
            ("rays", format!("plane_rays_{si}"), "rays per frame", "rays"),
            (
                "frame_seconds",
                format!("plane_time_{si}"),
                "time per frame (s; bars: interval of the median)",
                "time",
            ),
        ] {
            let front = Front {
                stem,
                title: format!("{title}: error against {short}"),
                x,
                x_label,
                y: "rmse_vs_full_frequency",
                y_label: "shade_rmse_rel vs full-frequency truth",
            };
            files.extend(write_front(dir, t, &rows, &front, &|r| specs[r])?);
        }
        // Against the GPU path's frame where rows were timed there (`device`).
        let timed = (rows.iter()).find(|&&r| t.num(r, "gpu_frame_seconds").is_finite());
        if let Some(&r) = timed {
            let front = Front {
                stem: format!("plane_gpu_time_{si}"),
                title: format!(
                    "{title}: error against GPU time ({})",
                    t.cell(r, "gpu_adapter")
                ),
                x: "gpu_frame_seconds",
                x_label: "GPU path's time per frame (s; the methods with a GPU form)",
                y: "rmse_vs_full_frequency",
                y_label: "shade_rmse_rel vs full-frequency truth",
            };
            files.extend(write_front(dir, t, &rows, &front, &|r| specs[r])?);
        }
    }
    Ok(files)
}

pub(super) fn figure(
    dir: &Path,
    t: &Results,
    out: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, Error> {
    let specs = specs(t);
    let saved: Vec<usize> = (0..t.rows.len())
        .filter(|&r| t.cell(r, "save_image") == "true")
        .collect();
    let Some(panels) = figure_runs(t, &saved, &|r| specs[r]) else {
        return Ok(Vec::new());
    };
    let read = |name: &str, r: usize| {
        let path = dir.join(format!("{name}_{}.exr", t.cell(r, "run_id")));
        shscale_present::image::read_exr(&path).map_err(Error::from)
    };
    let (w, h, truth) = read("plane_truth", panels[0])?;
    let mut shown = Vec::new();
    for &r in &panels {
        let (_, _, px) = read("plane", r)?;
        let title = format!(
            "{} ({:.3} at {:.3e} rays)",
            specs[r].map_or_else(|| t.cell(r, "method").to_string(), |s| variant(&s)),
            t.num(r, "rmse_vs_full_frequency"),
            t.num(r, "rays")
        );
        shown.push((title, px));
    }
    let png = out.join(format!("{stem}.png"));
    write_plane_figure(&png, (w, h), &truth, &shown)?;
    Ok(vec![png])
}

pub(super) fn verdict(t: &Results) -> Result<String, Error> {
    let splits = plane_splits(t);
    if splits.is_empty() {
        return Ok(String::new());
    }
    if let Some(grid) = placements_grid(t) {
        return Ok(super::surface::verdict(t, &splits, &plane_regimes(), &grid));
    }
    // One placement: no interval; the single-run table.
    let grid = format!(
        "The receiver plane: {} receivers per scene, near = within {NEAR_RHO} bounding radii of an occluder ({} of them in the first scene); shade_rmse_rel against full-frequency truth unless said, sequences meaned over their frames",
        t.cell(0, "receivers"),
        t.cell(0, "near_receivers")
    );
    Ok(verdict_table(
        t,
        &splits,
        &[
            ("rmse_vs_full_frequency", "all, full-frequency truth"),
            ("rmse_near_vs_full_frequency", "near"),
            ("rmse_far_vs_full_frequency", "far"),
            ("rmse_vs_band_limited", "all, band-limited truth"),
        ],
        &grid,
        false,
    ))
}

pub(super) fn discussion(t: &Results) -> Result<String, Error> {
    let specs = specs(t);
    let keys = config_keys::<Params>(&PLANE_GROUPING);
    let mut s = String::new();
    if let Some(grid) = placements_grid(t) {
        let tables = super::surface::tables(t, &plane_splits(t), &plane_regimes(), &grid);
        s.push_str(&tables);
        s.push('\n');
    }
    for (scene, frames) in distinct_pairs(t, "scene", "frames") {
        let rows: Vec<usize> = (0..t.rows.len())
            .filter(|&r| t.cell(r, "scene") == scene && t.cell(r, "frames") == frames)
            .collect();
        let configs = by_config(t, &rows, &keys, &|r| specs[r]);
        let r0 = rows[0];
        let seq = if frames == "1" {
            String::new()
        } else {
            format!(", {frames} frames of its deformers, every method from scratch per frame; errors are means over the frames")
        };
        s.push_str(&format!(
            "**{scene}**{seq} ({} receivers, {} of them within {NEAR_RHO} bounding radii of an occluder; the truths' own errors: full-frequency {:.4}, band-limited {:.4}).\n\n",
            t.cell(r0, "receivers"),
            t.cell(r0, "near_receivers"),
            t.num(r0, "full_frequency_truth_err"),
            t.num(r0, "band_limited_truth_err"),
        ));
        s.push_str(&speed_claim(t, &configs, "rmse_vs_full_frequency"));
        for (col, regime) in [
            (
                "rmse_vs_full_frequency",
                "the plane against full-frequency truth (shade_rmse_rel)",
            ),
            (
                "rmse_near_vs_full_frequency",
                "near receivers, full-frequency truth",
            ),
            (
                "rmse_far_vs_full_frequency",
                "far receivers, full-frequency truth",
            ),
            (
                "rmse_vs_band_limited",
                "the plane against band-limited truth",
            ),
            ("one_minus_ssim", "1 − SSIM against full-frequency truth"),
            (
                "rmse_vs_full_frequency_max",
                "the worst frame, full-frequency truth",
            ),
            ("flicker", "temporal flicker of the error"),
        ] {
            if (col == "rmse_vs_full_frequency_max" || col == "flicker") && frames == "1" {
                continue;
            }
            s.push_str(&equal_accuracy(t, &configs, col, regime));
        }
    }
    Ok(s)
}
