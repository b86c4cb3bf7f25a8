//! The `budget` kind's report, verdict and discussion, from its rows: the fronts per mesh and
//! order, the verdict table per regime, the papers' speed claim and equal accuracy in words.

use super::receivers::{continuous_words, CONTINUOUS};
use super::spheres_params::Params;
use super::verdict::{
    by_config, config_keys, distinct_pairs, equal_accuracy, params_of, plot_name, specs_of,
    speed_claim, splits_by, verdict_table, write_front, Front, Split,
};
use super::NEAR_RHO;
use shscale_runner::records::Results;
use shscale_scene::method::Spec;
use shscale_scene::Error;
use std::path::{Path, PathBuf};

pub(super) fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
    let specs = specs(t);
    let mut files = Vec::new();
    let continuous = (0..t.rows.len()).any(|r| t.cell(r, "receiver_layout") == CONTINUOUS);
    if continuous {
        let tag = |label: &str| label.replace("N = ", "n");
        files.extend(super::surface::figures(dir, t, &splits(t), &tag)?);
    }
    for (mesh, order) in distinct_pairs(t, "mesh", "order") {
        let rows: Vec<usize> = (0..t.rows.len())
            .filter(|&r| t.cell(r, "mesh") == mesh && t.cell(r, "order") == order)
            .collect();
        // A mesh given as a path is named by its file stem in the plot's file name.
        let m = plot_name(&mesh);
        for (x, axis, x_label, short) in [
            ("rays", "rays", "rays per frame", "rays"),
            ("memory_bytes", "memory", "memory (bytes)", "memory"),
            (
                "frame_seconds",
                "time",
                "time per frame (s; bars: interval of the median)",
                "time",
            ),
        ] {
            let front = Front {
                stem: format!("pareto_{axis}_{m}_n{order}"),
                title: format!("{mesh}, N = {order}: error against {short}"),
                x,
                x_label,
                y: "occ_rel_l2_mean",
                y_label: "mean occ_rel_l2 (spherical receivers)",
            };
            files.extend(write_front(dir, t, &rows, &front, &|r| specs[r])?);
        }
    }
    Ok(files)
}

pub(super) fn verdict(t: &Results) -> Result<String, Error> {
    let splits = splits(t);
    if splits.is_empty() {
        return Ok(String::new());
    }
    let p0: Params = params_of(t, 0).unwrap_or_default();
    if let Some(grid) = continuous_grid(t, &p0) {
        let regimes = super::surface::sphere_regimes();
        return Ok(super::surface::verdict(t, &splits, &regimes, &grid));
    }
    let radii: Vec<String> = p0.radii.iter().map(|r| format!("{r}")).collect();
    let seeds = t.distinct_in(0..t.rows.len(), "probe_seed").len();
    let grid = format!(
        "Spherical receivers: {} directions at ρ = {} bounding radii (near: ρ ≤ {NEAR_RHO}, far: ρ > {NEAR_RHO}; contact: directions whose base-sphere point is ≥ 40 % occluded), {seeds} receiver seed(s)",
        p0.receivers,
        radii.join(", "),
    );
    Ok(verdict_table(
        t,
        &splits,
        &[
            ("occ_rel_l2_mean", "all receivers"),
            ("occ_rel_l2_near_mean", "near"),
            ("occ_rel_l2_far_mean", "far"),
            ("occ_rel_l2_contact_mean", "contact"),
        ],
        &grid,
        seeds > 1,
    ))
}

pub(super) fn discussion(t: &Results) -> Result<String, Error> {
    let specs = specs(t);
    let mut s = String::new();
    let p0: Params = params_of(t, 0).unwrap_or_default();
    if let Some(grid) = continuous_grid(t, &p0) {
        let regimes = super::surface::sphere_regimes();
        s.push_str(&super::surface::tables(t, &splits(t), &regimes, &grid));
        s.push('\n');
    }
    for (mesh, order) in distinct_pairs(t, "mesh", "order") {
        let rows: Vec<usize> = (0..t.rows.len())
            .filter(|&r| t.cell(r, "mesh") == mesh && t.cell(r, "order") == order)
            .collect();
        let keys = config_keys::<Params>(&CONFIG_GROUPING);
        let configs = by_config(t, &rows, &keys, &|r| specs[r]);
        let seeds = t.distinct_in(rows.iter().copied(), "probe_seed").len();
        s.push_str(&format!(
            "**{mesh}, N = {order}** ({} configurations, {seeds} receiver seed(s); errors are means over the seeds, in brackets their range).\n\n",
            configs.len()
        ));
        s.push_str(&speed_claim(t, &configs, "occ_rel_l2_mean"));
        for (col, regime) in [
            ("occ_rel_l2_mean", "all receivers, mean occ_rel_l2"),
            ("occ_rel_l2_near_mean", "near (ρ ≤ 1.3), mean occ_rel_l2"),
            ("occ_rel_l2_far_mean", "far (ρ > 1.3), mean occ_rel_l2"),
            (
                "occ_rel_l2_contact_mean",
                "contact directions, mean occ_rel_l2",
            ),
            ("occ_weighted", "all receivers, occlusion-weighted"),
        ] {
            s.push_str(&equal_accuracy(t, &configs, col, regime));
        }
        s.push('\n');
    }
    Ok(s)
}

/// The columns a configuration repeats over (or is split by): what is not the method.
const CONFIG_GROUPING: [&str; 10] = [
    "mesh",
    "probe_seed",
    "receivers",
    "truth_res",
    "truth_seed",
    "radii",
    "receiver_layout",
    "rho_min",
    "rho_max",
    "orientation_seed",
];

/// The rows as splits (one per order) of groups (one per mesh) of configurations.
fn splits(t: &Results) -> Vec<Split> {
    let keys = config_keys::<Params>(&CONFIG_GROUPING);
    let place = |mesh: &str, order: &str| (format!("N = {order}"), mesh.to_string());
    splits_by(t, ("mesh", "order"), &keys, &specs(t), &place)
}

/// The receivers in words when the rows' first run has receivers at every distance (`None` on
/// the grid).
fn continuous_grid(t: &Results, p0: &Params) -> Option<String> {
    (p0.receiver_layout == CONTINUOUS).then(|| {
        let seeds = super::surface::distinct_seeds(t);
        continuous_words(p0.receivers, (p0.rho_min, p0.rho_max), seeds)
    })
}

/// Every row's method, parsed once from its cells.
fn specs(t: &Results) -> Vec<Option<Spec>> {
    specs_of::<Params>(t, |p| p.spec().ok())
}
