//! The probe's one row type and how an assessed radius fills it.

use serde::{Deserialize, Serialize};
use shscale_field::metrics::{mean_max, quantiles, QUANTILE_LEVELS};
use shscale_field::probe::{Assessment, ProbeError};

/// One row: a run at one probe radius (metric names of docs/conventions.md §6). The one row type
/// of the probe: the CSV of `experiment = "probe"`, `shscale probe` and the Python `probe`.
/// Means and maxima are over the probes with a truth (outside the solid) and an occluded truth;
/// a column that does not apply to the run (the single sphere's decomposition, on-surface and
/// contact columns of sub-volumes) is empty, never 0.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ProbeRow {
    pub radius: f64,
    pub k: f64,
    /// Distance of k from the nearest table node in node spacings (in ln k for exp spacing),
    /// 0 = on a node, 0.5 = midway (one sphere's table; empty for sub-volumes, whose parts see
    /// other k).
    pub k_node_offset: Option<f64>,
    /// The cone angle used at this radius (degrees): `alpha_deg`, or with `alpha_mode = "fit"`
    /// the law's α(k) at the BSV's effective cap — for sub-volumes the mean over the parts and
    /// probes of each part's α at its own k.
    pub alpha_used_deg: f64,
    /// The BSV's effective cap θ₀, degrees (what `alpha_mode = "fit"` uses).
    pub effective_cap_deg: Option<f64>,
    pub probes: usize,
    pub inside_count: usize,
    pub unoccluded_truth_count: usize,
    /// Probes below the table's range, clamped to its first entry (empty for sub-volumes).
    pub clamped_count: Option<usize>,
    pub vis_rel_l2_mean: Option<f64>,
    pub vis_rel_l2_max: Option<f64>,
    pub occ_rel_l2_mean: Option<f64>,
    pub occ_rel_l2_max: Option<f64>,
    /// Quantiles of `occ_rel_l2` over the probes with a truth (p5, p25, median, p75, p95;
    /// linear rule, `metrics::quantiles`).
    pub occ_rel_l2_p05: Option<f64>,
    pub occ_rel_l2_p25: Option<f64>,
    pub occ_rel_l2_p50: Option<f64>,
    pub occ_rel_l2_p75: Option<f64>,
    pub occ_rel_l2_p95: Option<f64>,
    /// The truth's own error relative to its occlusion; 0 for the closed-form sphere.
    pub truth_rel_err_mean: Option<f64>,
    pub truth_rel_err_max: Option<f64>,
    /// Probes whose `occ_rel_l2` is within 3× the truth's own error (not resolved by it).
    pub truth_limited_count: usize,
    /// Error decomposition (one sphere), each replacing one more component by its exact
    /// counterpart: the k-table by the exact `M_k` …
    pub occ_rel_l2_exact_k_mean: Option<f64>,
    /// … and the interpolated BSV by the BSV sampled at the probe's own direction (same H) …
    pub occ_rel_l2_exact_dir_mean: Option<f64>,
    /// … and that sample by the converged truth at the same point: the cone model (and the
    /// band-limiting of its input).
    pub occ_rel_l2_model_mean: Option<f64>,
    /// The truth's own band-limiting, `√(1 − ‖P_N occ‖² / Ω_occ)`.
    pub band_limit_rel_mean: Option<f64>,
    /// Probes whose extrapolated occluded solid angle `Ω = 4π − √(4π) c₀` is negative or
    /// exceeds what the bounding sphere can cover from there.
    pub implausible_count: usize,
    pub occ_solid_angle_min: Option<f64>,
    pub occ_solid_angle_max: Option<f64>,
    /// Probes whose nearest base-sample lies on the surface (one sphere; empty for sub-volumes).
    pub on_surface_count: Option<usize>,
    pub vis_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_max: Option<f64>,
    /// Probes in contact directions (the BSV occludes ≥ `contact_occlusion` of the facing
    /// hemisphere; one sphere, empty for sub-volumes).
    pub contact_count: Option<usize>,
    pub occ_rel_l2_contact_mean: Option<f64>,
    pub occ_rel_l2_contact_max: Option<f64>,
    pub bsv_rays: usize,
    /// Rays per probe of the truth (0: closed form).
    pub truth_rays: usize,
    /// Median over the timing procedure; `*_spread` = (max − min) / median.
    pub bsv_sampling_seconds: f64,
    pub bsv_sampling_spread: f64,
    pub table_build_seconds: f64,
    pub table_build_spread: f64,
    pub extrapolation_seconds: f64,
    pub extrapolation_spread: f64,
    /// The truth at this radius, measured once (it is the reference, not a method under test).
    pub truth_seconds: f64,
    pub gpu_bsv_sampling_seconds: Option<f64>,
    pub gpu_sh_conversion_seconds: Option<f64>,
    pub gpu_device: String,
    /// `parts > 1`: the partition's time (k-means, the parts' meshes and BVHs), once per run.
    pub partition_seconds: Option<f64>,
}

impl ProbeRow {
    /// The accuracy columns of one radius from its assessment (means and maxima over the probes
    /// with a truth; the decomposition, on-surface and contact columns where it has them).
    pub(crate) fn assessed(rho: f64, k: f64, a: &Assessment) -> Self {
        let per = &a.per;
        let mm = |f: &dyn Fn(&ProbeError) -> Option<f64>| mean_max(per.iter().map(f));
        let occ_and = |f: fn(&ProbeError) -> Option<f64>| mm(&|x| x.occ.and(f(x))).0;
        let q = quantiles(per.iter().map(|x| x.occ), &QUANTILE_LEVELS);
        let decomposed = a.decomposed;
        let on_surface = |x: &&ProbeError| x.on_surface == Some(true);
        let contact = |x: &&ProbeError| x.contact == Some(true);
        let sub = |keep: &dyn Fn(&&ProbeError) -> bool, f: fn(&ProbeError) -> Option<f64>| {
            mean_max(per.iter().filter(|x| keep(x)).map(f))
        };
        let (vm, vx, _) = mm(&|x| x.vis);
        let (om, ox, _) = mm(&|x| x.occ);
        let (tm, tx, _) = mm(&|x| x.occ.and(x.truth_err));
        let (osm, osx, _) = sub(&on_surface, |x| x.occ);
        let (ocm, ocx, _) = sub(&contact, |x| x.occ);
        ProbeRow {
            radius: rho,
            k,
            probes: a.probes,
            inside_count: a.inside,
            unoccluded_truth_count: a.unoccluded_truth,
            clamped_count: a.clamped,
            vis_rel_l2_mean: vm,
            vis_rel_l2_max: vx,
            occ_rel_l2_mean: om,
            occ_rel_l2_max: ox,
            occ_rel_l2_p05: q[0],
            occ_rel_l2_p25: q[1],
            occ_rel_l2_p50: q[2],
            occ_rel_l2_p75: q[3],
            occ_rel_l2_p95: q[4],
            truth_rel_err_mean: tm,
            truth_rel_err_max: tx,
            truth_limited_count: a.truth_limited,
            occ_rel_l2_exact_k_mean: occ_and(|x| x.exact_k),
            occ_rel_l2_exact_dir_mean: occ_and(|x| x.exact_dir),
            occ_rel_l2_model_mean: occ_and(|x| x.model),
            band_limit_rel_mean: occ_and(|x| x.band),
            implausible_count: a.implausible,
            occ_solid_angle_min: a.solid_min,
            occ_solid_angle_max: a.solid_max,
            on_surface_count: decomposed.then(|| per.iter().filter(on_surface).count()),
            vis_rel_l2_on_surface_mean: sub(&on_surface, |x| x.vis).0,
            occ_rel_l2_on_surface_mean: osm,
            occ_rel_l2_on_surface_max: osx,
            contact_count: decomposed.then(|| per.iter().filter(contact).count()),
            occ_rel_l2_contact_mean: ocm,
            occ_rel_l2_contact_max: ocx,
            ..ProbeRow::default()
        }
    }
}
