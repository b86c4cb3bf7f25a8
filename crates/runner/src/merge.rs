//! The merge of shard files: every row validated as on resume, runs deduplicated by id, the
//! manifests' versions united, then the report. Linear in the rows: each file is read and
//! validated once, and the runs already taken are a hash set.
//!
//! **Never mixed silently.** Shards of different config versions (text, overrides, numerical
//! code or input content, as `manifest.toml` records them) or rows of different numerical codes
//! (their `code` cells, docs/provenance.md) are refused, naming both, unless the caller allows
//! mixing ([`MergeOptions::allow_mixed`]: the rows still carry every parameter and code). Rows
//! all of one code that is not this binary's are merged and named stale
//! ([`MergeSummary::notes`]).
//!
//! **Never overwrites by accident.** An existing `<out>/runs.csv` is refused unless
//! [`MergeOptions::replace`] (the merge job of a script `shscale slurm` wrote, which owns its
//! output): then `runs.csv` and `manifest.toml` are replaced together, atomically.

use crate::error::Error;
use crate::kind::DynKind;
use crate::manifest::Manifest;
use crate::records;
use crate::store::{header, load_rows};
use shscale_files::atomic::write_atomic_all;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// How [`merge`] treats an existing output and mixed inputs.
#[derive(Clone, Copy, Debug, Default)]
pub struct MergeOptions {
    /// Replace an existing `<out>/runs.csv` (and its manifest) atomically instead of refusing.
    pub replace: bool,
    /// Merge inputs of different config versions or code revisions.
    pub allow_mixed: bool,
    /// Merge although shard files or runs of the plan are missing (recorded in the manifest's
    /// `missing`), instead of refusing.
    pub allow_partial: bool,
}

/// What [`merge`] did.
pub struct MergeSummary {
    pub out: PathBuf,
    pub files: usize,
    pub rows: usize,
    pub kind: &'static dyn DynKind,
    /// Stale or mixed rows and rows timed on a busy machine, in words
    /// ([`crate::manifest::row_notes`]).
    pub notes: Vec<String>,
}

/// Merge the `runs*.csv` of `dirs` into `out` (default `<dirs[0]>/merged`), a new directory:
/// every row validated as on resume (an invalid one is an error naming its file and line), runs
/// deduplicated by id (the first file's rows win), the manifests' versions united, then the
/// report. `out/runs.csv` must not exist unless `opts.replace`; inputs of several config
/// versions or code revisions are refused unless `opts.allow_mixed` (module documentation).
pub fn merge(
    dirs: &[PathBuf],
    out: Option<&Path>,
    registry: &[&'static dyn DynKind],
    opts: MergeOptions,
) -> Result<MergeSummary, Error> {
    let first = dirs
        .first()
        .ok_or_else(|| Error::Config("merge: give at least one directory".into()))?;
    let out = out.map_or_else(|| first.join("merged"), Path::to_path_buf);
    let files = shard_files(dirs)?;
    let target = out.join("runs.csv");
    if target.exists() && !opts.replace {
        return Err(Error::Io {
            path: target.display().to_string(),
            reason: "exists; merge never overwrites — choose another --out".into(),
        });
    }
    let kind = kind_of(first, &files[0], registry)?;
    let kind_name = kind.name().to_string();
    let mut manifest = Manifest {
        experiment: kind_name.clone(),
        name: first
            .file_name()
            .map_or("merged".into(), |n| n.to_string_lossy().to_string()),
        versions: Vec::new(),
        missing: Vec::new(),
    };
    unite_manifests(dirs, &kind_name, &mut manifest)?;
    if !opts.allow_mixed {
        one_version(&manifest)?;
    }
    let (seen, rows) = union_rows(kind, &files, opts)?;
    // The plan is known: every shard of an `N`-way split, and every run of a one-version plan.
    manifest.missing = missing_shards(&files);
    if let [v] = manifest.versions.as_slice() {
        if seen.len() < v.runs_in_plan {
            manifest.missing.push(format!(
                "{} of the plan's {} runs have no rows",
                v.runs_in_plan - seen.len(),
                v.runs_in_plan
            ));
        }
    }
    if !manifest.missing.is_empty() && !opts.allow_partial {
        return Err(Error::Config(format!(
            "merge: the result would be partial: {}; nothing merged — complete the missing shards (resubmitting their runs), or pass --allow-partial to merge the rows there are (the manifest then records what is missing)",
            manifest.missing.join("; ")
        )));
    }
    std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
    write_atomic_all(&[
        (
            &out.join("manifest.toml"),
            &toml::to_string(&manifest).map_err(|e| Error::Config(e.to_string()))?,
        ),
        (&target, &records::write_text(&header(kind), &rows)?),
    ])?;
    // The merged rows' notes read off their `code` and `contended` cells in place (no copy of
    // the table).
    let h = header(kind);
    let at = |c: &str| h.iter().position(|x| x == c);
    let cells = |i: Option<usize>| i.map(|i| rows.iter().map(move |r| r[i].as_str()));
    let notes = crate::manifest::row_notes_of(
        cells(at("code")),
        cells(at("contended")),
        rows.len(),
        !kind.time_columns().is_empty(),
    );
    Ok(MergeSummary {
        notes,
        out,
        files: files.len(),
        rows: rows.len(),
        kind,
    })
}

/// The rows of every shard file, each run's first (a run in two files is kept once), and the
/// run ids seen; a file with an invalid row, or (unless `allow_mixed`) rows of two revisions,
/// refused.
fn union_rows(
    kind: &dyn DynKind,
    files: &[PathBuf],
    opts: MergeOptions,
) -> Result<(HashSet<String>, Vec<Vec<String>>), Error> {
    let want = header(kind);
    let code_at = want.iter().position(|c| c == "code");
    let mut revision: Option<(String, PathBuf)> = None;
    let mut seen: HashSet<String> = HashSet::new();
    let mut rows = Vec::new();
    for f in files {
        let l = load_rows(kind, f)?;
        if let Some((line, why, _)) = l.rejected.first() {
            return Err(Error::Io {
                path: format!("{}:{line}", f.display()),
                reason: format!("{why}; nothing merged"),
            });
        }
        if !opts.allow_mixed {
            if let Some(ci) = code_at {
                one_code(&l.rows, ci, f, &mut revision)?;
            }
        }
        let mut ids_here = HashSet::new();
        for r in l.rows {
            if !seen.contains(&r[0]) {
                ids_here.insert(r[0].clone());
                rows.push(r);
            }
        }
        seen.extend(ids_here);
    }
    Ok((seen, rows))
}

/// The united manifest holds one config version, else an error naming two of them.
fn one_version(m: &Manifest) -> Result<(), Error> {
    if let [a, b, ..] = m.versions.as_slice() {
        let what = |v: &crate::manifest::Version| {
            format!(
                "{} ({}{}, numerical code {}{})",
                v.id,
                v.config_file,
                if v.overrides.is_empty() {
                    String::new()
                } else {
                    format!(" {}", v.overrides.join(" "))
                },
                v.provenance.code,
                if v.inputs.is_empty() {
                    String::new()
                } else {
                    format!(", {} input(s)", v.inputs.len())
                }
            )
        };
        return Err(Error::Config(format!(
            "merge: the inputs hold {} config versions, e.g. {} and {}: results of different configs, numerical codes or input contents are not merged silently; merge each apart, or pass --allow-mixed (every row keeps its parameters, code and inputs)",
            m.versions.len(),
            what(a),
            what(b)
        )));
    }
    Ok(())
}

/// Every row of `file` has the numerical code (`code` at `ci`) of the rows before it (`first`:
/// the first one seen, with its file).
fn one_code(
    rows: &[Vec<String>],
    ci: usize,
    file: &Path,
    first: &mut Option<(String, PathBuf)>,
) -> Result<(), Error> {
    for r in rows {
        let code = &r[ci];
        match first {
            None => *first = Some((code.clone(), file.to_path_buf())),
            Some((want, f0)) if want != code => {
                return Err(Error::Io {
                    path: file.display().to_string(),
                    reason: format!(
                        "holds rows of numerical code {code}, {} rows of {want}: results of different numerical codes are not merged silently; merge each apart, or pass --allow-mixed",
                        f0.display()
                    ),
                })
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// The shard files an `N`-way split lacks, in words: for each `N` among the
/// `runs.shard-I-of-N.csv` names of `files`, every `I` in `0..N` not among them.
fn missing_shards(files: &[PathBuf]) -> Vec<String> {
    let mut seen: std::collections::BTreeMap<usize, std::collections::BTreeSet<usize>> =
        Default::default();
    for f in files {
        let n = f.file_name().map(|n| n.to_string_lossy().to_string());
        let parsed = n.as_deref().and_then(|n| {
            let (i, n) = n
                .strip_prefix("runs.shard-")?
                .strip_suffix(".csv")?
                .split_once("-of-")?;
            Some((i.parse::<usize>().ok()?, n.parse::<usize>().ok()?))
        });
        if let Some((i, n)) = parsed {
            seen.entry(n).or_default().insert(i);
        }
    }
    let mut out = Vec::new();
    for (n, have) in seen {
        let lacking: Vec<usize> = (0..n).filter(|i| !have.contains(i)).collect();
        if !lacking.is_empty() {
            // At most 20 named.
            let named: Vec<String> = (lacking.iter().take(20))
                .map(|i| format!("runs.shard-{i}-of-{n}.csv"))
                .collect();
            out.push(format!(
                "{} of {n} shard files missing ({}{})",
                lacking.len(),
                named.join(", "),
                if lacking.len() > named.len() {
                    ", …"
                } else {
                    ""
                }
            ));
        }
    }
    out
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
                n.starts_with("runs") && n.ends_with(".csv")
            })
            .collect();
        // A shard that is a FIFO, a device, a symlink loop or a link to nothing is an error
        // naming it, never skipped.
        for p in &here {
            shscale_files::input::regular_file(p)?;
        }
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
