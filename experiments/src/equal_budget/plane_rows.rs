//! The `budget_plane` kind's row: one run's budgets, its errors against both truths (all,
//! near, far, distance-to-surface bins), its stability over frames, and its GPU timing.

use serde::{Deserialize, Serialize};

/// One row per run.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    pub receivers: usize,
    /// Receivers within 1.3 bounding radii of an occluder's centre.
    pub near_receivers: usize,
    pub rays: f64,
    pub memory_bytes: f64,
    pub frame_seconds: f64,
    pub frame_seconds_lo: f64,
    pub frame_seconds_hi: f64,
    pub timing_coverage: f64,
    /// Errors: means over the frames.
    pub rmse_vs_band_limited: f64,
    pub rmse_vs_full_frequency: f64,
    /// The worst frame's `rmse_vs_full_frequency`.
    pub rmse_vs_full_frequency_max: f64,
    /// Temporal flicker ([`flicker`]) of the error against full-frequency truth (none for one
    /// frame).
    pub flicker: Option<f64>,
    pub rmse_near_vs_full_frequency: Option<f64>,
    pub rmse_far_vs_full_frequency: Option<f64>,
    /// `1 − SSIM` of the luminance against the full-frequency truth's (0 = identical).
    pub one_minus_ssim: Option<f64>,
    /// The truths' own errors in the unit of `rmse_vs_*` (as in `shadows`; the worst frame's).
    pub full_frequency_truth_err: f64,
    pub band_limited_truth_err: f64,
    /// The frame through a per-receiver cache (`shscale_scene::cached`: the field re-sampled,
    /// every receiver shaded from the cache), for the extrapolation and the full field on a
    /// still scene of one occluder (none elsewhere): the median of the timing procedure's repeats
    /// and its interval, the cache's one-off build time, and the largest difference of its image
    /// from the direct render's in the unit of the mean unshadowed irradiance.
    /// Receivers by distance to the nearest occluder's surface (in that occluder's radii; the
    /// first frame's), in the bins of `surface::SURFACE_EDGES`, and the error against
    /// full-frequency truth over each bin's receivers (mean over the frames; each frame bins its
    /// own pose).
    pub receivers_s0: usize,
    pub receivers_s1: usize,
    pub receivers_s2: usize,
    pub receivers_s3: usize,
    pub receivers_s4: usize,
    pub receivers_s5: usize,
    pub receivers_s6: usize,
    pub rmse_s0_vs_full_frequency: Option<f64>,
    pub rmse_s1_vs_full_frequency: Option<f64>,
    pub rmse_s2_vs_full_frequency: Option<f64>,
    pub rmse_s3_vs_full_frequency: Option<f64>,
    pub rmse_s4_vs_full_frequency: Option<f64>,
    pub rmse_s5_vs_full_frequency: Option<f64>,
    pub rmse_s6_vs_full_frequency: Option<f64>,
    pub cached_frame_seconds: Option<f64>,
    pub cached_frame_seconds_lo: Option<f64>,
    pub cached_frame_seconds_hi: Option<f64>,
    pub cache_seconds: Option<f64>,
    pub cached_max_diff: Option<f64>,
    /// The frame on the GPU path (`device` = `gpu` or `auto`; `plane_timings`): the mean frame of
    /// the sequence, host stages included, its interval, the adapter (or why none timed it), and
    /// the largest difference of its images from the CPU's in the unit of the mean unshadowed
    /// irradiance.
    pub gpu_frame_seconds: Option<f64>,
    pub gpu_frame_seconds_lo: Option<f64>,
    pub gpu_frame_seconds_hi: Option<f64>,
    pub gpu_adapter: String,
    pub gpu_max_diff: Option<f64>,
}
