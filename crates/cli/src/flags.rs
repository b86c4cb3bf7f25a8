//! Range checks of command-line flags through the runner's one range-check helper
//! (`shscale_runner::check`), so every "is outside" message states the range it tests:
//! `--order: 0 is outside 1..=16`.

use shscale_runner::check::{self, Ends};
use std::fmt::Display;

/// `v` when `lo ≤ v ≤ hi`, else the error `"{flag}: {v} is outside {lo}..={hi}"`.
/// An output folder given by `flag`: refused, naming the flag, where it (or the nearest part of
/// its path that exists) is not a folder — `run --out-dir FILE` said only "Not a directory".
pub fn out_folder(flag: &str, path: &std::path::Path) -> anyhow::Result<()> {
    let mut p = path.to_path_buf();
    loop {
        if let Ok(m) = std::fs::metadata(&p) {
            if m.is_dir() {
                return Ok(());
            }
            if p == path {
                anyhow::bail!("{flag} {}: exists and is not a folder", path.display());
            }
            anyhow::bail!("{flag} {}: {} is not a folder", path.display(), p.display());
        }
        match p.parent() {
            Some(q) if !q.as_os_str().is_empty() => p = q.to_path_buf(),
            _ => return Ok(()),
        }
    }
}

pub fn int<T: PartialOrd + Display + Copy>(flag: &str, v: T, lo: T, hi: T) -> anyhow::Result<T> {
    check::int(v, lo, hi).map_err(|m| anyhow::anyhow!("{flag}: {m}"))
}

/// `v` when it is finite and in the interval, else `"{flag}: {v} is outside {interval}"`.
pub fn real(flag: &str, v: f64, lo: f64, hi: f64, ends: Ends) -> anyhow::Result<f64> {
    check::real(v, lo, hi, ends).map_err(|m| anyhow::anyhow!("{flag}: {m}"))
}

/// Measure this machine's speed against the development VM for `--dry-run`'s estimates
/// (`shscale_scene::calibrate`, about 0.15 s), or take it from `SHSCALE_SPEED` (a positive
/// number; `1` keeps the development VM's seconds, for reproducible listings). A value that is
/// not a positive number is refused naming the variable.
pub fn calibrate_estimates() -> anyhow::Result<()> {
    let speed = match std::env::var("SHSCALE_SPEED") {
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(k) if k.is_finite() && k > 0.0 && k <= 1e6 => k,
            _ => anyhow::bail!(
                "SHSCALE_SPEED={v:?}: give this machine's speed against the development VM as a positive number (1 = the development VM), or unset it to measure"
            ),
        },
        Err(_) => {
            let s0 = shscale_runner::contention::sample();
            let rate = shscale_scene::calibrate::rays_per_second();
            shscale_runner::timing::set_calibration_contention(
                shscale_runner::contention::since(s0),
            );
            match rate {
                Some(rate) => {
                    rate / shscale_runner::timing::CALIBRATION_REFERENCE_RAYS_PER_SECOND
                }
                None => return Ok(()),
            }
        }
    };
    shscale_runner::timing::set_machine_speed(speed);
    Ok(())
}
