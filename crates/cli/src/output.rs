//! Printing of coefficient vectors and matrices in the CLI's formats.

use crate::args::Format;
use serde::Serialize;
use shscale_sh::sh_lm;

/// Print a JSON value on one line.
pub fn print_json<T: Serialize>(v: &T) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string(v)?);
    Ok(())
}

/// Print a coefficient vector as CSV (`index,l,m,value`) or a readable table.
pub fn print_coeffs(values: &[f64], format: Format) {
    if format == Format::Csv {
        println!("index,l,m,value");
    } else {
        println!("{:>6} {:>4} {:>5}  value", "index", "l", "m");
    }
    for (i, v) in values.iter().enumerate() {
        let (l, m) = sh_lm(i);
        if format == Format::Csv {
            println!("{i},{l},{m},{v:e}");
        } else {
            println!("{i:>6} {l:>4} {m:>5}  {v:+.16e}");
        }
    }
}

/// Print a dense matrix as CSV (one row per line) or an aligned table with `.` for exact zeros.
pub fn print_matrix(rows: &[Vec<f64>], format: Format) {
    for row in rows {
        if format == Format::Csv {
            let line: Vec<String> = row.iter().map(|v| format!("{v:e}")).collect();
            println!("{}", line.join(","));
        } else {
            let line: Vec<String> = row
                .iter()
                .map(|v| {
                    if v.abs() <= 1e-12 {
                        format!("{:>10}", ".")
                    } else {
                        format!("{v:>10.6}")
                    }
                })
                .collect();
            println!("{}", line.join(" "));
        }
    }
}

/// Progress of a long command: a bar with ETA on a terminal; otherwise (logs, CI, pipes) one
/// line on stderr at most every [`Progress::every`] — `progress: 3/10 figures, 41 s elapsed,
/// ETA 95 s` — so a long job shows it is alive and short ones stay quiet.
pub struct Progress {
    bar: indicatif::ProgressBar,
    what: String,
    len: usize,
    start: std::time::Instant,
    last: std::sync::Mutex<std::time::Instant>,
}

impl Progress {
    /// The longest a non-terminal run goes without a progress line: 10 s, or
    /// `SHSCALE_PROGRESS_EVERY_S` seconds.
    pub fn every() -> std::time::Duration {
        std::env::var("SHSCALE_PROGRESS_EVERY_S")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .map_or(
                std::time::Duration::from_secs(10),
                std::time::Duration::from_secs_f64,
            )
    }

    pub fn new(len: usize, what: &str) -> Self {
        let bar = indicatif::ProgressBar::new(len as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(&format!(
                "  [{{elapsed_precise}}] {{bar:30}} {{pos}}/{{len}} {what}, ETA {{eta}} {{msg}}"
            ))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let now = std::time::Instant::now();
        Self {
            bar,
            what: what.to_string(),
            len,
            start: now,
            last: std::sync::Mutex::new(now),
        }
    }

    /// A line of output, above the bar on a terminal.
    pub fn println(&self, line: &str) {
        if self.bar.is_hidden() {
            println!("  {line}");
        } else {
            self.bar.println(format!("  {line}"));
        }
    }

    pub fn set_message(&self, m: String) {
        self.bar.set_message(m);
    }

    /// One step done.
    pub fn inc(&self) {
        self.bar.inc(1);
        if !self.bar.is_hidden() {
            return;
        }
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed() < Self::every() {
            return;
        }
        *last = std::time::Instant::now();
        let pos = self.bar.position() as usize;
        let secs = self.start.elapsed().as_secs_f64();
        let eta = if pos > 0 {
            secs / pos as f64 * self.len.saturating_sub(pos) as f64
        } else {
            f64::NAN
        };
        eprintln!(
            "progress: {pos}/{} {}, {secs:.0} s elapsed, ETA {eta:.0} s",
            self.len, self.what
        );
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
