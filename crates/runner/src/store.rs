//! The results store of one directory: its advisory lock, the CSV header of a kind, and the rows
//! read back and validated (a row with the wrong cell count, a cell of the wrong type, or a run id
//! its own parameter cells do not reproduce is set aside into `runs.csv.rejected`, never lost).

use crate::error::Error;
use crate::kind::DynKind;
use crate::manifest::RowProvenance;
use crate::records;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// The exclusive advisory lock of a results directory, held while alive.
pub struct DirLock(std::fs::File);

impl DirLock {
    /// Take `dir/.lock`, waiting for another process (`waiting` is called once if it must wait).
    pub(crate) fn acquire(dir: &Path, waiting: &dyn Fn(&Path)) -> Result<Self, Error> {
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

/// Read and validate a kind's CSV (`Ok(default)` when absent or empty — an empty file holds no
/// rows, and the next append writes its header). A header of another version is an error (the
/// file is left alone); invalid rows are returned in `rejected`.
pub fn load_rows(kind: &dyn DynKind, path: &Path) -> Result<Loaded, Error> {
    if !shscale_files::input::regular_file(path)? {
        return Ok(Loaded::default());
    }
    if std::fs::metadata(path).is_ok_and(|m| m.len() == 0) {
        return Ok(Loaded::default());
    }
    let (columns, raw) = records::read_raw(path)?;
    let want = header(kind);
    check_header(kind, path, &columns, &want)?;
    Ok(validate(kind, &want, raw))
}

/// The rows `raw` of a kind's CSV (header `want`) validated: valid rows of complete runs, the
/// complete runs, and what was set aside (wrong cell count, another kind, parameters that do
/// not reproduce the run id, cells of the wrong type, runs with fewer rows than they write).
/// Linear in the rows.
pub(crate) fn validate(kind: &dyn DynKind, want: &[String], raw: Vec<records::CsvLine>) -> Loaded {
    let np = kind.param_columns().len();
    let nr = kind.row_columns().len();
    let (ph, rh, vh) = (
        &want[2..2 + np],
        &want[2 + np..2 + np + nr],
        &want[2 + np + nr..],
    );
    let mut out = Loaded::default();
    // Each row checked on its own (in parallel: this is most of a resume's or merge's time),
    // then grouped in file order.
    use rayon::prelude::*;
    let check = |r: &Vec<String>| -> Result<usize, String> {
        if r.len() != want.len() {
            return Err(format!("{} cells, the header has {}", r.len(), want.len()));
        }
        if r[1] != kind.name() {
            return Err(format!("experiment {:?} is not {:?}", r[1], kind.name()));
        }
        let (id, rows) =
            (kind.id_of_cells(ph, &r[2..2 + np])).map_err(|m| format!("parameters: {m}"))?;
        if id != r[0] {
            return Err(format!(
                "run id {} does not match its parameters (they hash to {id})",
                r[0]
            ));
        }
        kind.check_row(rh, &r[2 + np..2 + np + nr])
            .and_then(|_| records::from_cells::<RowProvenance>(vh, &r[2 + np + nr..]).map(|_| ()))
            .map_err(|m| format!("cells: {m}"))?;
        Ok(rows)
    };
    let verdicts: Vec<Result<usize, String>> = raw.par_iter().map(|(_, r)| check(r)).collect();
    // Runs in the order they first appear, with their rows; `index` finds a run's slot.
    let mut by_run: Vec<(String, usize, Vec<records::CsvLine>)> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for ((line, r), verdict) in raw.into_iter().zip(verdicts) {
        match verdict {
            Err(why) => out.rejected.push((line, why, r)),
            Ok(rows) => {
                let slot = *index.entry(r[0].clone()).or_insert_with(|| {
                    by_run.push((r[0].clone(), rows, Vec::new()));
                    by_run.len() - 1
                });
                by_run[slot].2.push((line, r));
            }
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
    out
}

/// The rows appended to a results file since byte `offset` (where a row starts), numbered from
/// line `first_line`, and the file's length: what other processes added since this one last
/// read or wrote it.
pub(crate) fn read_tail(
    path: &Path,
    offset: u64,
    first_line: u64,
) -> Result<(Vec<records::CsvLine>, u64), Error> {
    use std::io::{Read, Seek, SeekFrom};
    shscale_files::input::regular_file(path)?;
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut bytes = Vec::new();
    f.seek(SeekFrom::Start(offset.min(len)))
        .and_then(|_| f.read_to_end(&mut bytes))
        .map_err(|e| Error::io(path, e))?;
    let mut r = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(bytes.as_slice());
    let mut rows = Vec::new();
    let mut rec = csv::StringRecord::new();
    loop {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {
                let line = first_line + rec.position().map_or(1, |p| p.line()) - 1;
                rows.push((line, rec.iter().map(String::from).collect()));
            }
            Err(e) => return Err(Error::io(path, e)),
        }
    }
    Ok((rows, len))
}

/// Append `rows` to a results file, then flush and sync it: a finished run's rows reach the disk
/// once, whole. A new (or empty) file is written whole through a synced temporary and a rename
/// (its header and rows), so no reader ever sees it empty or with half a header. Returns the
/// new length.
pub(crate) fn append_rows(
    path: &Path,
    header: &[String],
    rows: &[Vec<String>],
) -> Result<u64, Error> {
    use std::io::Write;
    let fresh = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
    let bytes = records::csv_bytes(fresh.then_some(header), rows)?;
    if fresh {
        shscale_files::atomic::write_atomic_bytes(path, &bytes)?;
        return Ok(bytes.len() as u64);
    }
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .read(true)
        .append(true)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    // A torn last line (a writer killed mid-append) is closed first: it is set aside on the
    // next load, and these rows start on a line of their own.
    let torn = !fresh && last_byte(&mut f).map_err(|e| Error::io(path, e))? != Some(b'\n');
    let newline: &[u8] = if torn { b"\n" } else { b"" };
    f.write_all(newline)
        .and_then(|_| f.write_all(&bytes))
        .and_then(|_| f.flush())
        .and_then(|_| f.sync_data())
        .map_err(|e| Error::io(path, e))?;
    f.metadata()
        .map(|m| m.len())
        .map_err(|e| Error::io(path, e))
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

/// Append set-aside rows to `<csv>.rejected` (never lost): [`set_aside`] with that suffix.
pub(crate) fn keep_rejected(
    csv: &Path,
    rejected: &[(u64, String, Vec<String>)],
) -> Result<(), Error> {
    set_aside(csv, "rejected", rejected)
}

/// The header of a file of set-aside rows: the line the row had, why it was set aside, then the
/// row's own cells (as many as it had; under the results file's header when it had as many).
pub(crate) const SET_ASIDE_HEAD: [&str; 2] = ["set_aside_line", "set_aside_reason"];

/// Append rows set aside from `csv` to `<csv>.<suffix>` (`rejected`: invalid rows; `stale`: rows
/// of other numerical code or input content) as valid CSV written by the `csv` crate — each
/// record its line in `csv`, the reason, then the row's cells, quoted where they hold a comma,
/// a quote or a line break — so [`read_set_aside`] gives back every cell byte for byte. The
/// header (`set_aside_line,set_aside_reason,` and `csv`'s own header when readable) starts a
/// new file; the append is flushed and synced.
pub(crate) fn set_aside(
    csv: &Path,
    suffix: &str,
    rows: &[(u64, String, Vec<String>)],
) -> Result<(), Error> {
    if rows.is_empty() {
        return Ok(());
    }
    use std::io::Write;
    let p = PathBuf::from(format!("{}.{suffix}", csv.display()));
    let fresh = std::fs::metadata(&p).map_or(true, |m| m.len() == 0);
    let mut w = csv::WriterBuilder::new()
        .flexible(true)
        .from_writer(Vec::new());
    let e = |e: csv::Error| Error::io(&p, format!("writing CSV: {e}"));
    if fresh {
        let mut head: Vec<String> = SET_ASIDE_HEAD.iter().map(|s| s.to_string()).collect();
        if let Ok(columns) = records::read_raw_header(csv) {
            head.extend(columns);
        }
        w.write_record(&head).map_err(e)?;
    }
    for (line, why, cells) in rows {
        let mut rec = vec![line.to_string(), why.clone()];
        rec.extend(cells.iter().cloned());
        w.write_record(&rec).map_err(e)?;
    }
    let bytes = w.into_inner().map_err(|e| Error::io(&p, e.to_string()))?;
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&p)
        .map_err(|e| Error::io(&p, e))?;
    f.write_all(&bytes)
        .and_then(|_| f.sync_data())
        .map_err(|e| Error::io(&p, e))?;
    if fresh {
        shscale_files::atomic::sync_parent(&p)?;
    }
    Ok(())
}

/// The rows of a file of set-aside rows ([`set_aside`]): `(line, reason, cells)` each, the
/// cells exactly as the results file held them.
pub fn read_set_aside(path: &Path) -> Result<Vec<(u64, String, Vec<String>)>, Error> {
    let bytes = shscale_files::input::read_regular(path)?;
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(bytes.as_slice());
    let mut out = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| Error::io(path, e))?;
        let at = rec.position().map_or(0, |p| p.line());
        let line = (rec.get(0).unwrap_or("").parse::<u64>()).map_err(|_| {
            Error::io(
                path,
                format!("line {at}: {:?} is not a line number", rec.get(0)),
            )
        })?;
        let why = rec.get(1).unwrap_or("").to_string();
        out.push((line, why, rec.iter().skip(2).map(String::from).collect()));
    }
    Ok(out)
}

/// The last byte of an open file, if any (appends still go to the end after the seek).
fn last_byte(f: &mut std::fs::File) -> std::io::Result<Option<u8>> {
    use std::io::{Read, Seek, SeekFrom};
    let len = f.metadata()?.len();
    if len == 0 {
        return Ok(None);
    }
    let mut b = [0u8; 1];
    f.seek(SeekFrom::Start(len - 1))?;
    f.read_exact(&mut b)?;
    Ok(Some(b[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shscale-store-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d.join("runs.csv")
    }

    #[test]
    fn appends_start_with_the_header_and_close_a_torn_line() {
        let p = tmp("append");
        let h = vec!["a".to_string(), "b".to_string()];
        let row = |x: &str| vec![x.to_string(), "1".to_string()];
        let len = append_rows(&p, &h, &[row("x")]).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "a,b\nx,1\n");
        assert_eq!(len, 8);
        // A writer killed mid-row leaves a torn last line: the next rows start on their own.
        std::fs::write(&p, "a,b\nx,1\ny,").unwrap();
        append_rows(&p, &h, &[row("z"), row("w")]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "a,b\nx,1\ny,\nz,1\nw,1\n"
        );
        // The tail from a row's start: the rows after it, numbered from the given line.
        let (rows, end) = read_tail(&p, 8, 3).unwrap();
        assert_eq!(end, std::fs::metadata(&p).unwrap().len());
        let lines: Vec<u64> = rows.iter().map(|(l, _)| *l).collect();
        assert_eq!(lines, [3, 4, 5]);
        assert_eq!(rows[1].1, row("z"));
        std::fs::remove_dir_all(p.parent().unwrap()).ok();
    }

    /// An empty results file (a writer killed between creating it and writing, or a reader
    /// that looked before the first commit) holds no rows: it loads as none and the next append
    /// writes the header. A new file appears whole: its header and first rows come by one rename,
    /// and no temporary is left beside it.
    #[test]
    fn an_empty_results_file_holds_no_rows_and_a_new_one_appears_whole() {
        let p = tmp("empty");
        let kind: &dyn DynKind = &crate::bench::TALLY;
        std::fs::write(&p, "").unwrap();
        let l = load_rows(kind, &p).unwrap();
        assert!(l.rows.is_empty() && l.rejected.is_empty());
        let h = vec!["a".to_string(), "b".to_string()];
        append_rows(&p, &h, &[vec!["x".into(), "1".into()]]).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "a,b\nx,1\n");
        let q = p.with_file_name("fresh.csv");
        append_rows(&q, &h, &[vec!["y".into(), "2".into()]]).unwrap();
        assert_eq!(std::fs::read_to_string(&q).unwrap(), "a,b\ny,2\n");
        let names: Vec<String> = std::fs::read_dir(p.parent().unwrap())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().to_string())
            .collect();
        assert!(names.iter().all(|n| !n.contains(".tmp-")), "{names:?}");
        std::fs::remove_dir_all(p.parent().unwrap()).ok();
    }

    /// Rows with hostile cells (commas, quotes, line breaks, non-ASCII, an empty cell) set aside
    /// on load come back from `runs.csv.rejected` cell for cell, and written again by the `csv`
    /// crate they are the bytes the results file held, byte for byte.
    #[test]
    fn rejected_rows_round_trip_hostile_cells_byte_for_byte() {
        let p = tmp("rejected");
        let kind: &dyn DynKind = &crate::bench::TALLY;
        let want = header(kind);
        let hostile = [
            "a,b",
            "say \"hi\"",
            "two\nlines",
            "crlf\r\nend",
            "ρ = 1.02r, α=45°",
            "",
            " lead and trail ",
            "\"",
        ];
        let rows: Vec<Vec<String>> = vec![
            hostile.iter().map(|c| c.to_string()).collect(),
            vec!["mesh,with,commas.obj".into(); want.len() + 3],
            (0..want.len()).map(|i| format!("x{i}\"\n,")).collect(),
        ];
        let mut w = csv::WriterBuilder::new()
            .flexible(true)
            .from_writer(Vec::new());
        w.write_record(&want).unwrap();
        let mut spans = Vec::new();
        for r in &rows {
            w.flush().unwrap();
            let start = w.get_ref().len();
            w.write_record(r).unwrap();
            w.flush().unwrap();
            spans.push(start..w.get_ref().len());
        }
        let bytes = w.into_inner().unwrap();
        std::fs::write(&p, &bytes).unwrap();
        let l = load_rows(kind, &p).unwrap();
        assert_eq!(
            l.rejected.len(),
            rows.len(),
            "every hostile row is set aside"
        );
        keep_rejected(&p, &l.rejected).unwrap();
        let rej = PathBuf::from(format!("{}.rejected", p.display()));
        let back = read_set_aside(&rej).unwrap();
        assert_eq!(back.len(), rows.len());
        for ((line, why, cells), (r, span)) in back.iter().zip(rows.iter().zip(&spans)) {
            assert!(!why.is_empty() && *line >= 2, "{line} {why}");
            assert_eq!(cells, r, "cells of line {line}");
            let mut again = csv::WriterBuilder::new()
                .flexible(true)
                .from_writer(Vec::new());
            again.write_record(cells).unwrap();
            let again = again.into_inner().unwrap();
            assert_eq!(again, bytes[span.clone()], "bytes of line {line}");
        }
        // The file is valid CSV with a header naming the columns.
        let head = records::read_raw_header(&rej).unwrap();
        assert_eq!(&head[..2], &SET_ASIDE_HEAD.map(String::from));
        assert_eq!(&head[2..], &want[..]);
        // A second set-aside appends records, not a second header.
        keep_rejected(&p, &l.rejected[..1]).unwrap();
        assert_eq!(read_set_aside(&rej).unwrap().len(), rows.len() + 1);
        std::fs::remove_dir_all(p.parent().unwrap()).ok();
    }

    use proptest::prelude::Strategy;

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Rows of arbitrary cells (any count, any text, numbers at the extremes) under the
        /// right header: each kept or set aside with a reason, never a panic, never both.
        #[test]
        fn arbitrary_rows_are_kept_or_set_aside(
            rows in proptest::collection::vec(
                proptest::collection::vec(
                    proptest::prop_oneof![
                        "\\PC{0,8}",
                        proptest::num::f64::ANY.prop_map(|x| x.to_string()),
                        (0u64..1000).prop_map(|x| x.to_string()),
                    ],
                    0..14,
                ),
                0..12,
            )
        ) {
            let kind: &dyn DynKind = &crate::bench::TALLY;
            let want = header(kind);
            let raw: Vec<records::CsvLine> = rows
                .iter()
                .enumerate()
                .map(|(i, r)| (i as u64 + 2, r.clone()))
                .collect();
            let l = validate(kind, &want, raw);
            proptest::prop_assert_eq!(l.rows.len() + l.rejected.len(), rows.len());
            for (_, why, _) in &l.rejected {
                proptest::prop_assert!(!why.is_empty());
            }
        }

        /// Arbitrary text as a manifest: parsed or refused, never a panic.
        #[test]
        fn arbitrary_manifests_parse_or_are_refused(text in "\\PC{0,80}") {
            let _ = toml::from_str::<crate::manifest::Manifest>(&text);
        }
    }
}
