//! The `probe` kind's discussion, from its rows: a single run's table per radius, where each run
//! follows the actual occlusion, and the truth's own error.

use shscale_runner::records::Results;

/// A finite error to three decimals, `—` otherwise.
fn fmt3(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3}")
    } else {
        "—".into()
    }
}

/// The discussion's table of a single run: its setting, then per radius the mean errors.
pub(super) fn single_run_table(t: &Results, rows: &[usize]) -> String {
    let r0 = rows[0];
    let mut out = format!(
        "**Ours.** Mesh `{}`, N = {}, α = {}°, BSV on `{}` × {}² rays, K = {} ({} k, {} interpolation). Mean errors over the \
probe directions per radius (`probe_dirs = {}`: seeded directions between the samples unless `samples`; docs/conventions.md §6; \
`occ_rel_l2` is relative to the occluded part; both compare coefficients with the converged truth projected to order N — its own \
error is in the CSV's `truth_rel_err_mean` — so they measure the extrapolation alone, not band-limiting). Image: one probe direction \
per radius (rows), actual full-frequency visibility (left, white = visible; lat-long, +z at the top) beside the extrapolated \
visibility (right).\n\n\
| radius (× r) | k | probes | vis_rel_l2 | occ_rel_l2 | inside the mesh |\n|---:|---:|---:|---:|---:|---:|\n",
        t.cell(r0, "mesh"),
        t.cell(r0, "order"),
        t.cell(r0, "alpha_deg"),
        t.cell(r0, "layout"),
        t.cell(r0, "hemisphere_res"),
        t.cell(r0, "k_count"),
        t.cell(r0, "k_spacing"),
        t.cell(r0, "k_interp"),
        t.cell(r0, "probe_dirs"),
    );
    for &r in rows {
        out.push_str(&format!(
            "| {} | {:.2} | {} | {} | {} | {} |\n",
            t.cell(r, "radius"),
            t.num(r, "k"),
            t.cell(r, "probes"),
            fmt3(t.num(r, "vis_rel_l2_mean")),
            fmt3(t.num(r, "occ_rel_l2_mean")),
            t.cell(r, "inside_count")
        ));
    }
    out
}

/// Where one run (`who`, its rows) follows the actual occlusion (occ_rel_l2 < [`FOLLOWS`]) and
/// where it departs from it, with its best and worst radius.
pub(super) fn follows_sentence(t: &Results, who: &str, rows: &[usize]) -> String {
    let occ = |r: usize| t.num(r, "occ_rel_l2_mean");
    let finite: Vec<usize> = rows
        .iter()
        .copied()
        .filter(|&r| occ(r).is_finite())
        .collect();
    let list = |follows: bool| {
        let v: Vec<String> = (finite.iter())
            .filter(|&&r| (occ(r) < FOLLOWS) == follows)
            .map(|&r| format!("{}r", t.cell(r, "radius")))
            .collect();
        if v.is_empty() {
            "no radius".to_string()
        } else {
            v.join(", ")
        }
    };
    let best = finite
        .iter()
        .copied()
        .min_by(|&a, &b| occ(a).total_cmp(&occ(b)));
    let worst = finite
        .iter()
        .copied()
        .max_by(|&a, &b| occ(a).total_cmp(&occ(b)));
    match (best, worst) {
        (Some(b), Some(w)) => format!(
            "{who} follows the actual occlusion (occ_rel_l2 < {FOLLOWS}) at {} and departs from it at {}: best at {}r ({:.3}), worst at {}r \
({:.3}; above 1 is worse than predicting no occlusion).\n",
            list(true),
            list(false),
            t.cell(b, "radius"),
            occ(b),
            t.cell(w, "radius"),
            occ(w)
        ),
        _ => {
            let sum = |c: &str| rows.iter().map(|&r| t.num(r, c)).filter(|v| v.is_finite()).sum::<f64>();
            format!(
                "{who}: no radius has an occ_rel_l2 — of {} probe points over {} radii, {} lie inside the occluder (no truth there) and {} see nothing occluded; there is no error to report or plot.\n",
                sum("probes"),
                rows.len(),
                sum("inside_count"),
                sum("unoccluded_truth_count")
            )
        }
    }
}

/// The truth's own error against the method's: rows where the truth does not resolve the error
/// are flagged (docs/conventions.md §6).
pub(super) fn truth_note(t: &Results) -> String {
    let limited: Vec<String> = (0..t.rows.len())
        .filter(|&r| t.num(r, "truth_limited_count") > 0.0)
        .map(|r| {
            format!(
                "run `{}` at {}r ({} probes)",
                t.cell(r, "run_id"),
                t.cell(r, "radius"),
                t.cell(r, "truth_limited_count")
            )
        })
        .collect();
    let worst = (0..t.rows.len())
        .map(|r| t.num(r, "truth_rel_err_mean"))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    if limited.is_empty() {
        format!(
            "\n**Truth.** The converged truth's own error (mean per row) is at most {worst:.4} of the occlusion, and no probe's \
occ_rel_l2 is within 3× of its truth's error.\n"
        )
    } else {
        format!(
            "\n**Truth-limited** (occ_rel_l2 within 3× of the truth's own error; raise `truth_res`): {}. The truth's mean \
error per row is at most {worst:.4} of the occlusion.\n",
            limited.join(", ")
        )
    }
}

/// occ_rel_l2 below which the discussion says the extrapolation follows the actual occlusion.
pub const FOLLOWS: f64 = 0.5;
