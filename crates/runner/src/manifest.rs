//! Provenance and `manifest.toml`: the columns the runner adds to every row, the machine and
//! revision a config version ran on, and every config version that produced rows (appended once
//! a run of it has succeeded, never rewritten).

use crate::error::Error;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Columns the runner adds to every row after the kind's.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RowProvenance {
    pub threads: usize,
    /// Whether the row's times were taken while other runs executed (not comparable).
    pub timing_concurrent: bool,
    pub timing_warmup: usize,
    pub timing_repeats: usize,
    pub git_revision: String,
    pub git_dirty: bool,
}

/// Where a plan's run writes, and the machine.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Provenance {
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
    /// Hash of the config text, the overrides and the revision.
    pub id: String,
    pub config_file: String,
    pub overrides: Vec<String>,
    pub axes: Vec<String>,
    pub runs_in_plan: usize,
    pub first_unix_time: u64,
    pub last_unix_time: u64,
    pub provenance: Provenance,
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
        if !crate::input::regular_file(&p)? {
            return Ok(None);
        }
        let text = crate::input::read_regular_string(&p)?;
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
