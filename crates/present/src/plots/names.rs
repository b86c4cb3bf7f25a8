//! Plot file stems (checked) and the words of series and panel names.

use super::*;

/// A column name as part of a file name: letters, digits, `_`, `-` and `.` kept, anything else
/// (a `/`, a space) as `_`, at most 64 characters. Column names come from files; they are data,
/// never path parts.
pub(crate) fn stem_part(name: &str) -> String {
    name.chars()
        .take(64)
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A file stem written into a results directory: a plain name — not empty, no path separator,
/// not starting with `.` — so the file stays in that directory.
pub(crate) fn check_stem(dir: &Path, stem: &str) -> Result<(), Error> {
    let plain = !stem.is_empty()
        && !stem.starts_with('.')
        && !stem.contains(['/', '\\', '\0'])
        && Path::new(stem).components().count() == 1;
    if plain {
        Ok(())
    } else {
        Err(Error::Io {
            path: dir.display().to_string(),
            reason: format!(
                "{stem:?} is not a plain file name: a plot is written only inside its directory"
            ),
        })
    }
}

/// A parameter's name in words, for titles and legends.
pub fn words(key: &str) -> String {
    match key {
        "alpha_deg" => "cone angle α (°)".into(),
        "order" => "SH order N".into(),
        "hemisphere_res" => "hemisphere resolution H".into(),
        "k_count" => "k-table size K".into(),
        "k_spacing" => "k spacing".into(),
        "k_interp" => "k interpolation".into(),
        "sampling_radius" => "sampling radius s".into(),
        "on_surface_eps" => "on-surface threshold ε".into(),
        "layout" => "layout".into(),
        "mesh" => "mesh".into(),
        "radius" => "probe radius ρ".into(),
        "k" => "scaling factor k".into(),
        "occ_rel_l2_mean" => "occlusion error (relative L2, mean over probes)".into(),
        "occ_rel_l2_max" => "occlusion error (relative L2, max over probes)".into(),
        "occ_rel_l2_p50" => "occlusion error (relative L2, median over probes)".into(),
        "vis_rel_l2_mean" => "visibility error (relative L2, mean over probes)".into(),
        "truth_rel_err_mean" => "truth's own error (relative, mean)".into(),
        "extrapolation_seconds" => "extrapolation time (s)".into(),
        "table_build_seconds" => "k-table build time (s)".into(),
        "bsv_sampling_seconds" => "BSV sampling time (s)".into(),
        "truth_seconds" => "truth time (s)".into(),
        "truth_res" => "truth resolution T".into(),
        "nonzeros" => "non-zero elements".into(),
        "shells" => "full-field shells".into(),
        "rays" => "rays per frame".into(),
        other => other.replace('_', " "),
    }
}
