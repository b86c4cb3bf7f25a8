//! The merge of shard files: every row validated as on resume, runs deduplicated by id, the
//! manifests' versions united, then the report.

use crate::atomic::write_atomic_all;
use crate::error::Error;
use crate::kind::DynKind;
use crate::manifest::Manifest;
use crate::records;
use crate::store::{header, load_rows};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// What [`merge`] did.
pub struct MergeSummary {
    pub out: PathBuf,
    pub files: usize,
    pub rows: usize,
    pub kind: &'static dyn DynKind,
}

/// Merge the `runs*.csv` of `dirs` into `out` (default `<dirs[0]>/merged`), a new directory:
/// every row validated as on resume (an invalid one is an error naming its file and line), runs
/// deduplicated by id (the first file's rows win), the manifests' versions united, then the
/// report. Never overwrites an input: `out/runs.csv` must not exist.
pub fn merge(
    dirs: &[PathBuf],
    out: Option<&Path>,
    registry: &[&'static dyn DynKind],
) -> Result<MergeSummary, Error> {
    let first = dirs
        .first()
        .ok_or_else(|| Error::Config("merge: give at least one directory".into()))?;
    let out = out.map_or_else(|| first.join("merged"), Path::to_path_buf);
    let files = shard_files(dirs)?;
    let target = out.join("runs.csv");
    if target.exists() {
        return Err(Error::Io {
            path: target.display().to_string(),
            reason: "exists; merge never overwrites — choose another --out".into(),
        });
    }
    let kind = kind_of(first, &files[0], registry)?;
    let kind_name = kind.name().to_string();
    let mut seen = BTreeSet::new();
    let mut rows = Vec::new();
    let mut manifest = Manifest {
        experiment: kind_name.clone(),
        name: first
            .file_name()
            .map_or("merged".into(), |n| n.to_string_lossy().to_string()),
        versions: Vec::new(),
    };
    unite_manifests(dirs, &kind_name, &mut manifest)?;
    for f in &files {
        let l = load_rows(kind, f)?;
        if let Some((line, why, _)) = l.rejected.first() {
            return Err(Error::Io {
                path: format!("{}:{line}", f.display()),
                reason: format!("{why}; nothing merged"),
            });
        }
        let mut ids_here = BTreeSet::new();
        for r in l.rows {
            if !seen.contains(&r[0]) {
                ids_here.insert(r[0].clone());
                rows.push(r);
            }
        }
        seen.extend(ids_here);
    }
    std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
    write_atomic_all(&[
        (
            &out.join("manifest.toml"),
            &toml::to_string(&manifest).map_err(|e| Error::Config(e.to_string()))?,
        ),
        (&target, &records::write_text(&header(kind), &rows)?),
    ])?;
    Ok(MergeSummary {
        out,
        files: files.len(),
        rows: rows.len(),
        kind,
    })
}

/// The `runs*.csv` files of `dirs`, sorted within each directory; at least one.
fn shard_files(dirs: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for d in dirs {
        let rd = std::fs::read_dir(d).map_err(|e| Error::io(d, e))?;
        let mut here: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                let n = (p.file_name())
                    .map(|n| n.to_string_lossy().to_string())
                    .unwrap_or_default();
                n.starts_with("runs") && n.ends_with(".csv") && p.is_file()
            })
            .collect();
        here.sort();
        files.extend(here);
    }
    if files.is_empty() {
        return Err(Error::Config(format!(
            "merge: no runs*.csv in {}",
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(files)
}

/// The kind of the results: from the first directory's manifest, else from the first row of
/// its first file.
fn kind_of(
    first: &Path,
    first_file: &Path,
    registry: &[&'static dyn DynKind],
) -> Result<&'static dyn DynKind, Error> {
    let kind_name = match Manifest::read(first)? {
        Some(m) => m.experiment,
        None => {
            let (_, rows) = records::read_raw(first_file)?;
            rows.first()
                .and_then(|(_, r)| r.get(1).cloned())
                .ok_or_else(|| Error::Io {
                    path: first_file.display().to_string(),
                    reason: "no manifest.toml beside it and no rows to tell the experiment".into(),
                })?
        }
    };
    registry
        .iter()
        .find(|k| k.name() == kind_name)
        .copied()
        .ok_or_else(|| Error::Config(format!("merge: unknown experiment {kind_name:?}")))
}

/// Every directory's config versions into `manifest`; a directory of another kind is an error.
fn unite_manifests(
    dirs: &[PathBuf],
    kind_name: &str,
    manifest: &mut Manifest,
) -> Result<(), Error> {
    for d in dirs {
        if let Some(m) = Manifest::read(d)? {
            if m.experiment != kind_name {
                return Err(Error::Io {
                    path: d.join("manifest.toml").display().to_string(),
                    reason: format!(
                        "experiment {:?}, not {kind_name:?}: results of different kinds do not merge",
                        m.experiment
                    ),
                });
            }
            for v in &m.versions {
                manifest.add(v);
            }
        }
    }
    Ok(())
}
