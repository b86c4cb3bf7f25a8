//! A CSV table read back (a results file): its header, its rows of cells, the file it came from;
//! cells looked up by column name, a missing column recorded and reported
//! ([`Table::check_read`]), never NaN.

use crate::error::Error;
use std::path::Path;

/// A results CSV read through the `csv` crate.
///
/// **A missing column is an error, never NaN.** Every lookup of a cell by column name through
/// [`Table::cell`], [`Table::num`] or [`Table::distinct`] in a column the table lacks is
/// recorded; whoever computes from the table (the report, the verdicts, `figs`, `compare`)
/// calls [`Table::check_read`] after, which fails naming the columns and the file — so a
/// renamed row field makes the verdict fail instead of filling it with NaN. Test a column's
/// presence with [`Table::col`] (not recorded).
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// The file the rows came from (for errors; empty when built in memory).
    pub source: String,
    /// Columns looked up by name that the table lacks.
    missing: std::sync::Arc<std::sync::Mutex<std::collections::BTreeSet<String>>>,
}

impl Table {
    /// A table built in memory (tests, merged rows).
    pub fn new(columns: Vec<String>, rows: Vec<Vec<String>>) -> Self {
        Self {
            columns,
            rows,
            ..Self::default()
        }
    }

    /// `Ok` when every column looked up by name so far exists; else an error naming each
    /// missing column and the file (what read them: `what`, e.g. "the verdict of kind budget").
    pub fn check_read(&self, what: &str) -> Result<(), Error> {
        let m = self.missing.lock().unwrap_or_else(|e| e.into_inner());
        if m.is_empty() {
            return Ok(());
        }
        let names: Vec<String> = m.iter().map(|c| format!("{c:?}")).collect();
        Err(Error {
            path: if self.source.is_empty() {
                "(rows in memory)".into()
            } else {
                self.source.clone()
            },
            reason: format!(
                "{what} read column(s) {} that the file does not have; nothing was written from it (a renamed row field, or rows of another version)",
                names.join(", ")
            ),
        })
    }

    fn note_missing(&self, name: &str) {
        let mut m = self.missing.lock().unwrap_or_else(|e| e.into_inner());
        if !m.contains(name) {
            m.insert(name.to_string());
        }
    }

    /// Read a CSV; every row must have the header's length (else an error naming the line).
    pub fn read(path: &Path) -> Result<Self, Error> {
        let (columns, rows) = read_raw(path)?;
        let mut out = Vec::new();
        for (line, r) in rows {
            if r.len() != columns.len() {
                return Err(Error {
                    path: format!("{}:{line}", path.display()),
                    reason: format!("{} cells, the header has {}", r.len(), columns.len()),
                });
            }
            out.push(r);
        }
        Ok(Self {
            columns,
            rows: out,
            source: path.display().to_string(),
            ..Self::default()
        })
    }

    pub fn col(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// The cell of `name` in row `r` ("" when the column is missing, which
    /// [`Table::check_read`] then reports).
    pub fn cell(&self, r: usize, name: &str) -> &str {
        match self.col(name) {
            Some(c) => self.rows[r].get(c).map_or("", String::as_str),
            None => {
                self.note_missing(name);
                ""
            }
        }
    }

    /// The distinct cells of column `name`, sorted (text order).
    pub fn distinct(&self, name: &str) -> Vec<String> {
        if self.col(name).is_none() {
            self.note_missing(name);
        }
        let mut v: Vec<String> = (0..self.rows.len())
            .map(|r| self.cell(r, name).to_string())
            .collect();
        v.sort();
        v.dedup();
        v
    }

    /// Numeric value (NaN when empty or not a number).
    pub fn num(&self, r: usize, name: &str) -> f64 {
        self.cell(r, name).parse().unwrap_or(f64::NAN)
    }

    /// The distinct cells of column `c` over `rows`, in [`cmp_cells`] order (numbers by value;
    /// [`Table::distinct`] is text order over every row).
    pub fn distinct_in(&self, rows: impl Iterator<Item = usize>, c: &str) -> Vec<String> {
        let mut v: Vec<String> = rows.map(|r| self.cell(r, c).to_string()).collect();
        v.sort_by(|a, b| cmp_cells(a, b));
        v.dedup();
        v
    }

    /// The columns among `candidates` whose cells take more than one value, in order.
    pub fn varying(&self, candidates: &[String]) -> Vec<String> {
        candidates
            .iter()
            .filter(|c| {
                let Some(i) = self.col(c) else { return false };
                let first = self.rows.first().map(|r| &r[i]);
                self.rows.iter().any(|r| Some(&r[i]) != first)
            })
            .cloned()
            .collect()
    }
}

/// The order of cells in tables and on axes: two numbers by value (`1.5` before `10`), anything
/// else by its text.
pub fn cmp_cells(a: &str, b: &str) -> std::cmp::Ordering {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x.total_cmp(&y),
        _ => a.cmp(b),
    }
}

/// One CSV record with its line number.
pub type CsvLine = (u64, Vec<String>);

/// The header of a CSV file alone.
pub fn read_raw_header(path: &Path) -> Result<Vec<String>, Error> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(std::io::BufReader::new(f));
    let h = r.headers().map_err(|e| Error::io(path, e))?;
    Ok(h.iter().map(String::from).collect())
}

/// Header and records with their line numbers (records of any length).
pub fn read_raw(path: &Path) -> Result<(Vec<String>, Vec<CsvLine>), Error> {
    let io = |e: &dyn std::fmt::Display| Error::io(path, e);
    let bytes = crate::input::read_regular(path)?;
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(bytes.as_slice());
    let columns: Vec<String> = r
        .headers()
        .map_err(|e| io(&e))?
        .iter()
        .map(String::from)
        .collect();
    let mut rows = Vec::new();
    let mut rec = csv::StringRecord::new();
    loop {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {
                let line = rec.position().map_or(0, |p| p.line());
                rows.push((line, rec.iter().map(String::from).collect()));
            }
            Err(e) => {
                // Invalid UTF-8 or similar: report it as a row of no cells at that line.
                let line = e.position().map_or(0, |p| p.line());
                rows.push((line, Vec::new()));
            }
        }
    }
    Ok((columns, rows))
}
