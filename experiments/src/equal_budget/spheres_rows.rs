//! The `budget` kind's row: one frame's values scored against the group's truths, over all
//! receivers, near and far, contact directions and distance-to-surface bins.

use super::frames;
use super::stats::mean_ci95_clustered;
use super::surface::{surface_bin, SURFACE_EDGES};
use super::NEAR_RHO;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use shscale_field::metrics::{l2, l2_diff, mean_max, occlusion};
use shscale_field::truth::Truth;

/// One row per run.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    /// Receiver points (directions × radii).
    pub receiver_points: usize,
    /// Rays cast per frame (deterministic).
    pub rays: f64,
    /// Bytes the method holds (deterministic): BSV and k-table, the shells, or nothing.
    pub memory_bytes: f64,
    /// One frame (sampling, table if per frame, evaluation of every receiver): the median of the
    /// timing procedure's repeats and the order-statistic interval of that median.
    pub frame_seconds: f64,
    pub frame_seconds_lo: f64,
    pub frame_seconds_hi: f64,
    pub timing_coverage: f64,
    /// The sampling part and the evaluation part of the frame (medians).
    pub build_seconds: f64,
    pub eval_seconds: f64,
    /// `sub_volumes`: the partition (k-means, the parts' meshes and BVHs), once per run — for a
    /// deforming mesh once per sequence, as the partition is per triangle; `sphere_set`: its
    /// k-means partition, or with `sphere_fit = "inscribed"` the inscribed fit's own cost (made
    /// once per mesh and process, every run of the mesh given what it cost).
    pub partition_seconds: Option<f64>,
    /// Mean `occ_rel_l2` over the receivers, with the half-width of its 95 % interval clustered
    /// by direction (the radii of one direction are not independent receivers).
    pub occ_rel_l2_mean: Option<f64>,
    pub occ_rel_l2_ci95: Option<f64>,
    /// The same near the object (ρ ≤ 1.3) and beyond.
    pub occ_rel_l2_near_mean: Option<f64>,
    pub occ_rel_l2_near_ci95: Option<f64>,
    pub occ_rel_l2_far_mean: Option<f64>,
    pub occ_rel_l2_far_ci95: Option<f64>,
    /// Occlusion-weighted: `sqrt(Σ‖S − S_true‖² / Σ‖S_occ,true‖²)`, all, near, far.
    pub occ_weighted: Option<f64>,
    pub occ_weighted_near: Option<f64>,
    pub occ_weighted_far: Option<f64>,
    /// Receivers in contact directions ([`Shared::contact`]) and their mean `occ_rel_l2` with
    /// its 95 % interval: where the papers' base-sphere samples touch the surface.
    pub contact_points: usize,
    pub occ_rel_l2_contact_mean: Option<f64>,
    pub occ_rel_l2_contact_ci95: Option<f64>,
    pub truth_rel_err_mean: Option<f64>,
    /// Mean `occ_rel_l2` by distance to the surface d (bounding radii), with its interval, in
    /// the bins of [`SURFACE_EDGES`]: s0 d < 0.04, s1 [0.04, 0.08), … s6 d ≥ 1.28.
    /// Receivers in each distance bin (those with something occluded score in its mean).
    pub points_s0: usize,
    pub points_s1: usize,
    pub points_s2: usize,
    pub points_s3: usize,
    pub points_s4: usize,
    pub points_s5: usize,
    pub points_s6: usize,
    pub occ_rel_l2_s0_mean: Option<f64>,
    pub occ_rel_l2_s0_ci95: Option<f64>,
    pub occ_rel_l2_s1_mean: Option<f64>,
    pub occ_rel_l2_s1_ci95: Option<f64>,
    pub occ_rel_l2_s2_mean: Option<f64>,
    pub occ_rel_l2_s2_ci95: Option<f64>,
    pub occ_rel_l2_s3_mean: Option<f64>,
    pub occ_rel_l2_s3_ci95: Option<f64>,
    pub occ_rel_l2_s4_mean: Option<f64>,
    pub occ_rel_l2_s4_ci95: Option<f64>,
    pub occ_rel_l2_s5_mean: Option<f64>,
    pub occ_rel_l2_s5_ci95: Option<f64>,
    pub occ_rel_l2_s6_mean: Option<f64>,
    pub occ_rel_l2_s6_ci95: Option<f64>,
}

/// One receiver's error: its radius, `‖S − S_true‖²`, `‖S_occ,true‖²` and the truth's own error.
pub(super) struct Err2 {
    pub(super) rho: f64,
    /// Distance to the surface, bounding radii.
    pub(super) surface: f64,
    /// The receiver's direction (its radii share it: the intervals' cluster).
    pub(super) dir: usize,
    /// The receiver's direction is a contact direction ([`Shared::contact`]).
    pub(super) contact: bool,
    pub(super) diff2: f64,
    pub(super) occ2: f64,
    pub(super) truth_rel: Option<f64>,
}

/// The error columns over the receivers `e` passing `keep`: mean `occ_rel_l2` (receivers with
/// something occluded, ‖S_occ‖ > 1e-12) with its interval, and the occlusion-weighted error.
fn scores(e: &[Err2], keep: impl Fn(&Err2) -> bool) -> (Option<f64>, Option<f64>, Option<f64>) {
    let kept: Vec<&Err2> = e.iter().filter(|x| keep(x)).collect();
    let rel: Vec<(usize, f64)> = (kept.iter())
        .filter(|x| x.occ2 > 1e-24)
        .map(|x| (x.dir, (x.diff2 / x.occ2).sqrt()))
        .collect();
    let (m, ci) = mean_ci95_clustered(&rel);
    let (d, o) = (kept.iter()).fold((0.0, 0.0), |(d, o), x| (d + x.diff2, o + x.occ2));
    (m, ci, (o > 1e-24).then(|| (d / o).sqrt()))
}

/// The row of one frame's values against the group's truths.
pub(super) fn row_of(
    sh: &Shared,
    (values, rays, memory): frames::Frame,
    t: [shscale_runner::timing::Timing; 3],
) -> Row {
    let [build, eval, total] = t;
    let errs: Vec<Err2> = (values.iter().zip(&sh.truth).zip(&sh.points))
        .zip(&sh.contact)
        .enumerate()
        .filter_map(|(i, (((v, t), (rho, _)), contact))| {
            let t = t.as_ref()?;
            Some(Err2 {
                rho: *rho,
                surface: sh.surface[i],
                dir: sh.dir_of[i],
                contact: *contact,
                diff2: l2_diff(v, &t.coeffs).powi(2),
                occ2: l2(&occlusion(&t.coeffs)).powi(2),
                truth_rel: t.rel_error(),
            })
        })
        .collect();
    let (m, ci, w) = scores(&errs, |_| true);
    let (mn, cin, wn) = scores(&errs, |e| e.rho <= NEAR_RHO);
    let (mf, cif, wf) = scores(&errs, |e| e.rho > NEAR_RHO);
    let (mc, cic, _) = scores(&errs, |e| e.contact);
    Row {
        receiver_points: sh.points.len(),
        rays,
        memory_bytes: memory,
        frame_seconds: total.median,
        frame_seconds_lo: total.lo,
        frame_seconds_hi: total.hi,
        timing_coverage: total.coverage,
        build_seconds: build.median,
        eval_seconds: eval.median,
        partition_seconds: None,
        occ_rel_l2_mean: m,
        occ_rel_l2_ci95: ci,
        occ_rel_l2_near_mean: mn,
        occ_rel_l2_near_ci95: cin,
        occ_rel_l2_far_mean: mf,
        occ_rel_l2_far_ci95: cif,
        occ_weighted: w,
        occ_weighted_near: wn,
        occ_weighted_far: wf,
        contact_points: sh.contact.iter().filter(|c| **c).count(),
        occ_rel_l2_contact_mean: mc,
        occ_rel_l2_contact_ci95: cic,
        truth_rel_err_mean: mean_max(errs.iter().filter(|e| e.occ2 > 1e-24).map(|e| e.truth_rel)).0,
        ..surface_bins(&errs, &sh.surface)
    }
}

/// The distance-to-surface columns of a row ([`SURFACE_EDGES`]): each bin's receivers (all of
/// `surface`) and its mean `occ_rel_l2` with its interval (receivers with a truth and something
/// occluded); every other column at its default.
fn surface_bins(errs: &[Err2], surface: &[f64]) -> Row {
    let bin = |k: usize| scores(errs, |e| surface_bin(e.surface) == k);
    let mut points = [0usize; SURFACE_EDGES.len() + 1];
    for d in surface {
        points[surface_bin(*d)] += 1;
    }
    let [b0, b1, b2, b3, b4, b5, b6] = std::array::from_fn(|k| {
        let (m, ci, _) = bin(k);
        (m, ci)
    });
    Row {
        points_s0: points[0],
        points_s1: points[1],
        points_s2: points[2],
        points_s3: points[3],
        points_s4: points[4],
        points_s5: points[5],
        points_s6: points[6],
        occ_rel_l2_s0_mean: b0.0,
        occ_rel_l2_s0_ci95: b0.1,
        occ_rel_l2_s1_mean: b1.0,
        occ_rel_l2_s1_ci95: b1.1,
        occ_rel_l2_s2_mean: b2.0,
        occ_rel_l2_s2_ci95: b2.1,
        occ_rel_l2_s3_mean: b3.0,
        occ_rel_l2_s3_ci95: b3.1,
        occ_rel_l2_s4_mean: b4.0,
        occ_rel_l2_s4_ci95: b4.1,
        occ_rel_l2_s5_mean: b5.0,
        occ_rel_l2_s5_ci95: b5.1,
        occ_rel_l2_s6_mean: b6.0,
        occ_rel_l2_s6_ci95: b6.1,
        ..Row::default()
    }
}

/// What runs of a group share: the occluder, the receivers and their truth.
pub struct Shared {
    pub(super) occ: Box<dyn shscale_geometry::Occluder>,
    /// The mesh (none for the analytic sphere), for the sub-volumes' partition.
    pub(super) mesh: Option<shscale_geometry::Mesh>,
    /// The receivers (ρ, point): on the grid radius by radius over the same directions, else
    /// each with its own.
    pub(super) points: Vec<(f64, DVec3)>,
    /// Each receiver's direction (its cluster: a grid's radii share one).
    pub(super) dir_of: Vec<usize>,
    /// Each receiver's distance to the occluder's surface, in bounding radii.
    pub(super) surface: Vec<f64>,
    pub(super) truth: Vec<Option<Truth>>,
    /// Per receiver: its direction is a contact direction — the bounding sphere's point in that
    /// direction has its facing hemisphere occluded at least
    /// [`shscale_field::probe::DEFAULT_CONTACT_OCCLUSION`] (docs/conventions.md §7), measured
    /// once per group with [`CONTACT_RES`]² rays. Every direction of the analytic sphere is.
    pub(super) contact: Vec<bool>,
}
