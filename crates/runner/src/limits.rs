//! Bounds on the work one command or plan may start, stated once (the per-value bounds — orders,
//! resolutions, counts — live beside the code that checks them and are listed in
//! `docs/limits.md`). A command or plan whose estimated work exceeds [`MAX_RAYS`] rays or
//! [`MAX_BYTES`] bytes is refused with the estimate and the values that drive it, unless the user
//! passes `--allow-large`.

use crate::error::Error;

pub use crate::timing::{MAX_PLAN_BYTES as MAX_BYTES, MAX_PLAN_RAYS as MAX_RAYS};

/// Refuse `what` when its estimated `rays` or `bytes` exceed the limits (unless `allow_large`);
/// `drivers` says which values drive the estimate, in words.
pub fn check_work(
    what: &str,
    rays: f64,
    bytes: f64,
    drivers: &str,
    allow_large: bool,
) -> Result<(), Error> {
    if allow_large {
        return Ok(());
    }
    if rays.is_nan() || rays > MAX_RAYS {
        return Err(Error::Config(format!(
            "{what}: an estimated {rays:.2e} rays, more than the limit {MAX_RAYS:.0e} ({drivers}); pass --allow-large to run it anyway"
        )));
    }
    if bytes.is_nan() || bytes > MAX_BYTES {
        return Err(Error::Config(format!(
            "{what}: an estimated {:.1} GiB held at once, more than the limit {:.0} GiB ({drivers}); pass --allow-large to run it anyway",
            bytes / (1u64 << 30) as f64,
            MAX_BYTES / (1u64 << 30) as f64
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_at_their_edges() {
        assert!(check_work("x", MAX_RAYS, MAX_BYTES, "", false).is_ok());
        let e = check_work("render", MAX_RAYS * 1.01, 0.0, "4096² receivers", false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("render") && e.contains("4096² receivers") && e.contains("--allow-large"),
            "{e}"
        );
        assert!(check_work("x", 0.0, MAX_BYTES * 2.0, "", false).is_err());
        assert!(check_work("x", f64::NAN, 0.0, "", false).is_err());
        assert!(check_work("x", 1e30, 1e30, "", true).is_ok());
    }
}
