//! Provenance and `manifest.toml`: the columns the runner adds to every row, the machine and
//! revision a config version ran on, and every config version that produced rows (appended once
//! a run of it has succeeded, never rewritten).

use crate::error::Error;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Columns the runner adds to every row after the kind's (docs/provenance.md).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RowProvenance {
    pub threads: usize,
    /// Whether the row's times were taken while other runs executed (not comparable).
    pub timing_concurrent: bool,
    pub timing_warmup: usize,
    pub timing_repeats: usize,
    /// The numerical fingerprint of the binary that computed the row ([`CODE_FINGERPRINT`]):
    /// a row whose `code` is not the binary's is stale.
    pub code: String,
    /// The digest of the content of every input the run read ([`crate::inputs::digest`];
    /// `none` without inputs): a row whose inputs changed is stale.
    pub inputs: String,
    /// Cores other processes used on average while the run was measured
    /// ([`crate::contention`]).
    pub other_cpu: f64,
    /// Share of the machine's time the hypervisor stole meanwhile.
    pub steal: f64,
    /// The 1-minute load average when the run finished.
    pub load_1m: f64,
    /// Whether the run was measured on a busy machine (`other_cpu` ≥ 0.5 or `steal` ≥ 0.1):
    /// its times are not comparable.
    pub contended: bool,
    pub git_revision: String,
    pub git_dirty: bool,
}

/// The numerical fingerprint of this binary: 16 hex digits of BLAKE3 over the sources that
/// compute numbers ([`crate::fingerprint`]), recorded by the build script; "unknown" when built
/// out of the workspace.
pub const CODE_FINGERPRINT: &str = env!("SHSCALE_CODE_FINGERPRINT");

/// Where a plan's run writes, and the machine.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Provenance {
    /// The numerical fingerprint ([`CODE_FINGERPRINT`]).
    #[serde(default)]
    pub code: String,
    pub git_revision: String,
    /// Whether the checkout had local changes.
    pub git_dirty: bool,
    pub shscale_version: String,
    pub cpu_model: String,
    pub threads: usize,
    pub gpu_device: String,
    pub os: String,
    pub arch: String,
    pub unix_time: u64,
}

/// The git revision this crate was built from (12 hex digits, `+dirty` when the checkout had
/// changes to tracked files at build time; "unknown" outside a checkout), recorded by the build
/// script. Provenance is the binary's, whatever repository the working directory is in.
pub const BUILD_REVISION: &str = env!("SHSCALE_GIT_REVISION");

/// Unix seconds as an ISO 8601 UTC time, `YYYY-MM-DDThh:mm:ssZ` (the proleptic Gregorian
/// calendar; days to a civil date by the era algorithm of H. Hinnant, "chrono-compatible
/// low-level date algorithms"). Domain: every u64 second up to year 9999; later ones are
/// written with more year digits.
pub(crate) fn iso8601_utc(unix: u64) -> String {
    let (days, secs) = (unix / 86_400, unix % 86_400);
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        secs / 3600,
        secs % 3600 / 60,
        secs % 60
    )
}

pub(crate) fn unix_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

impl Provenance {
    /// Read off this process and machine; the revision is the binary's ([`BUILD_REVISION`]).
    pub fn here(gpu_device: &str) -> Self {
        let (rev, dirty) = match BUILD_REVISION.strip_suffix("+dirty") {
            Some(r) => (r, true),
            None => (BUILD_REVISION, false),
        };
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|t| {
                t.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        Self {
            code: CODE_FINGERPRINT.into(),
            git_revision: rev.into(),
            git_dirty: dirty,
            shscale_version: env!("CARGO_PKG_VERSION").into(),
            cpu_model: cpu,
            threads: rayon::current_num_threads(),
            gpu_device: gpu_device.into(),
            os: std::env::consts::OS.into(),
            arch: std::env::consts::ARCH.into(),
            unix_time: unix_now(),
        }
    }
}

/// One config version that produced rows.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Version {
    /// Hash of the config text, the overrides, the numerical fingerprint and the inputs' content
    /// (not the git revision: a docs-only commit is the same version).
    pub id: String,
    pub config_file: String,
    pub overrides: Vec<String>,
    pub axes: Vec<String>,
    pub runs_in_plan: usize,
    pub first_unix_time: u64,
    pub last_unix_time: u64,
    pub provenance: Provenance,
    /// Every input the plan's runs read, by label (path, or `bundled:<name>`), with its
    /// content hash (32 hex digits of BLAKE3).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub inputs: std::collections::BTreeMap<String, String>,
    pub config_text: String,
}

/// `manifest.toml`: the kind, the name and every config version that produced rows.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    pub experiment: String,
    pub name: String,
    #[serde(default)]
    pub versions: Vec<Version>,
    /// What a merge run with `--allow-partial` left out (missing shard files, runs of the plan
    /// without rows), in words; empty for a complete result.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub missing: Vec<String>,
}

impl Manifest {
    /// Read `dir/manifest.toml` (`None` when absent).
    pub fn read(dir: &Path) -> Result<Option<Self>, Error> {
        let p = dir.join("manifest.toml");
        if !shscale_files::input::regular_file(&p)? {
            return Ok(None);
        }
        let text = shscale_files::input::read_regular_string(&p)?;
        toml::from_str(&text).map(Some).map_err(|e| Error::Io {
            path: p.display().to_string(),
            reason: format!(
                "not a manifest of this shscale version ({}); move it (and its runs.csv) away or choose another name",
                e.message().trim()
            ),
        })
    }

    pub(crate) fn add(&mut self, v: &Version) {
        match self.versions.iter_mut().find(|x| x.id == v.id) {
            Some(x) => x.last_unix_time = v.last_unix_time,
            None => self.versions.push(v.clone()),
        }
    }
}

/// What a table's provenance columns say of its rows, one sentence each, in the words `merge`,
/// `report`, `compare` and Python's `load_results` all use: rows of several numerical codes
/// (mixed), rows of another code than this binary's (stale), and timed rows measured on a busy
/// machine (`has_times`: the kind has time columns). Empty when there is nothing to say.
pub fn row_notes(t: &crate::records::Results, has_times: bool) -> Vec<String> {
    row_notes_of(
        t.col("code")
            .map(|c| t.rows.iter().map(move |r| r[c].as_str())),
        t.col("contended")
            .map(|c| t.rows.iter().map(move |r| r[c].as_str())),
        t.rows.len(),
        has_times,
    )
}

/// [`row_notes`] of the `code` and `contended` cells.
pub fn row_notes_of<'a>(
    codes: Option<impl Iterator<Item = &'a str>>,
    contended: Option<impl Iterator<Item = &'a str>>,
    rows: usize,
    has_times: bool,
) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(codes) = codes {
        let mut by: std::collections::BTreeMap<&str, usize> = Default::default();
        for c in codes {
            *by.entry(c).or_default() += 1;
        }
        let here = CODE_FINGERPRINT;
        let stale: usize = (by.iter())
            .filter(|(c, _)| **c != here)
            .map(|(_, n)| n)
            .sum();
        if by.len() > 1 {
            let list: Vec<String> = by.iter().map(|(c, n)| format!("{c} ({n} rows)")).collect();
            out.push(format!(
                "mixed: the rows were computed by {} numerical codes — {}; {stale} of the {rows} are stale (this binary's code is {here}): compare them with care, or re-run with `shscale run` (docs/provenance.md)",
                by.len(),
                list.join(", ")
            ));
        } else if stale > 0 {
            let code = by.keys().next().copied().unwrap_or("");
            out.push(format!(
                "stale: all {rows} rows were computed by numerical code {code}, not this binary's {here} (`shscale run` re-runs them; docs/provenance.md)"
            ));
        }
    }
    if let (Some(cells), true) = (contended, has_times) {
        let busy = cells.filter(|c| *c == "true").count();
        if busy > 0 {
            out.push(format!(
                "contended: {busy} of the {rows} rows were timed on a busy machine (other processes used ≥ {} core or the hypervisor stole ≥ {:.0} % of the time; columns `other_cpu`, `steal`, `contended`): their times are not comparable",
                crate::contention::CONTENDED_OTHER_CPU,
                crate::contention::CONTENDED_STEAL * 100.0
            ));
        }
    }
    out
}

#[cfg(test)]
mod iso_tests {
    /// Against Python's `datetime.fromtimestamp(t, UTC)`: the epoch, two leap days (one in a
    /// year divisible by 400), a 2026 time with seconds, the turn of 2100 (not a leap year).
    #[test]
    fn unix_seconds_as_iso_8601() {
        for (t, want) in [
            (0, "1970-01-01T00:00:00Z"),
            (68_169_600, "1972-02-29T00:00:00Z"),
            (951_782_400, "2000-02-29T00:00:00Z"),
            (1_796_360_377, "2026-12-04T04:59:37Z"),
            (4_102_444_800, "2100-01-01T00:00:00Z"),
            (4_102_444_799, "2099-12-31T23:59:59Z"),
        ] {
            assert_eq!(super::iso8601_utc(t), want, "{t}");
        }
    }
}
