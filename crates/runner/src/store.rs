//! The results store of one directory: its advisory lock, the CSV header of a kind, and the rows
//! read back and validated (a row with the wrong cell count, a cell of the wrong type, or a run id
//! its own parameter cells do not reproduce is set aside into `runs.csv.rejected`, never lost).

use crate::error::Error;
use crate::kind::DynKind;
use crate::manifest::RowProvenance;
use crate::records;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The exclusive advisory lock of a results directory, held while alive.
pub struct DirLock(std::fs::File);

impl DirLock {
    /// Take `dir/.lock`, waiting for another process (`waiting` is called once if it must wait).
    pub fn acquire(dir: &Path, waiting: &dyn Fn(&Path)) -> Result<Self, Error> {
        let p = dir.join(".lock");
        let f = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&p)
            .map_err(|e| Error::io(&p, e))?;
        match f.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                waiting(&p);
                f.lock().map_err(|e| Error::io(&p, e))?;
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(Error::io(&p, e)),
        }
        Ok(Self(f))
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        let _ = self.0.unlock();
    }
}

/// The full header of a kind's CSV.
pub fn header(kind: &dyn DynKind) -> Vec<String> {
    let mut h = vec!["run_id".to_string(), "experiment".to_string()];
    h.extend(kind.param_columns());
    h.extend(kind.row_columns());
    h.extend(
        records::to_cells(&RowProvenance::default())
            .map(|(h, _)| h)
            .unwrap_or_default(),
    );
    h
}

/// Valid rows of a results file, the complete runs, and what was set aside.
#[derive(Default)]
pub struct Loaded {
    pub rows: Vec<Vec<String>>,
    pub complete: BTreeSet<String>,
    /// `(line, reason)` of rows set aside.
    pub rejected: Vec<(u64, String, Vec<String>)>,
}

/// Read and validate a kind's CSV (`Ok(default)` when absent). A header of another version is an
/// error (the file is left alone); invalid rows are returned in `rejected`.
pub fn load_rows(kind: &dyn DynKind, path: &Path) -> Result<Loaded, Error> {
    if !path.exists() {
        return Ok(Loaded::default());
    }
    let (columns, raw) = records::read_raw(path)?;
    let want = header(kind);
    check_header(kind, path, &columns, &want)?;
    let np = kind.param_columns().len();
    let nr = kind.row_columns().len();
    let (ph, rh, vh) = (
        &want[2..2 + np],
        &want[2 + np..2 + np + nr],
        &want[2 + np + nr..],
    );
    let mut out = Loaded::default();
    let mut by_run: Vec<(String, usize, Vec<records::CsvLine>)> = Vec::new();
    for (line, r) in raw {
        let reason = if r.len() != want.len() {
            Some(format!("{} cells, the header has {}", r.len(), want.len()))
        } else if r[1] != kind.name() {
            Some(format!("experiment {:?} is not {:?}", r[1], kind.name()))
        } else {
            match kind.resolve_cells(ph, &r[2..2 + np]) {
                Err(m) => Some(format!("parameters: {m}")),
                Ok(res) if res.id != r[0] => Some(format!(
                    "run id {} does not match its parameters (they hash to {})",
                    r[0], res.id
                )),
                Ok(res) => kind
                    .check_row(rh, &r[2 + np..2 + np + nr])
                    .and_then(|_| {
                        records::from_cells::<RowProvenance>(vh, &r[2 + np + nr..]).map(|_| ())
                    })
                    .err()
                    .map(|m| format!("cells: {m}"))
                    .or_else(|| {
                        match by_run.iter_mut().find(|x| x.0 == res.id) {
                            Some(x) => x.2.push((line, r.clone())),
                            None => {
                                by_run.push((res.id.clone(), res.rows, vec![(line, r.clone())]))
                            }
                        }
                        None
                    }),
            }
        };
        if let Some(why) = reason {
            out.rejected.push((line, why, r));
        }
    }
    for (id, want_rows, rows) in by_run {
        if rows.len() == want_rows {
            out.complete.insert(id);
            out.rows.extend(rows.into_iter().map(|(_, r)| r));
        } else {
            let have = rows.len();
            for (line, r) in rows {
                out.rejected.push((
                    line,
                    format!("run {id} has {have} of its {want_rows} rows (partial); it is redone"),
                    r,
                ));
            }
        }
    }
    Ok(out)
}

/// A results file whose header is not this version's `want` is an error: it is left untouched.
fn check_header(
    kind: &dyn DynKind,
    path: &Path,
    columns: &[String],
    want: &[String],
) -> Result<(), Error> {
    if columns != want {
        let diff = want
            .iter()
            .zip(columns.iter().chain(std::iter::repeat(&String::new())))
            .position(|(a, b)| a != b)
            .unwrap_or(want.len().min(columns.len()));
        return Err(Error::Io {
            path: path.display().to_string(),
            reason: format!(
                "its columns are not this version's {} columns (column {}: {:?}, expected {:?}); it is left untouched — move it away or choose another name",
                kind.name(),
                diff + 1,
                columns.get(diff).map_or("", String::as_str),
                want.get(diff).map_or("", String::as_str),
            ),
        });
    }
    Ok(())
}

/// Append set-aside rows to `<csv>.rejected` (never lost).
pub(crate) fn keep_rejected(
    csv: &Path,
    rejected: &[(u64, String, Vec<String>)],
) -> Result<(), Error> {
    if rejected.is_empty() {
        return Ok(());
    }
    use std::io::Write;
    let p = PathBuf::from(format!("{}.rejected", csv.display()));
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&p)
        .map_err(|e| Error::io(&p, e))?;
    for (line, why, cells) in rejected {
        writeln!(f, "# line {line}: {why}\n{}", cells.join(",")).map_err(|e| Error::io(&p, e))?;
    }
    Ok(())
}
