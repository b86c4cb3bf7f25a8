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
