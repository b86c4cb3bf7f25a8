//! Range checks that state the range they test: one helper per kind of bound, so the range in
//! an error message (and in `docs/limits.md` / the config reference, which quote these) is the
//! range the check applies — they cannot drift apart. Messages read `"{value} is outside
//! {range}"`: integer ranges as `lo..=hi`, real intervals as `[lo, hi]`, `(lo, hi)`, `(lo, hi]`
//! or `[lo, hi)`; a non-finite real is always outside.

use crate::kind::KeyError;
use std::fmt::Display;

/// Which ends of a real interval belong to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ends {
    /// `[lo, hi]`
    Closed,
    /// `(lo, hi)`
    Open,
    /// `(lo, hi]`
    OpenClosed,
    /// `[lo, hi)`
    ClosedOpen,
}

/// A real number for messages: plain where that is short and exact, else in `e` notation
/// (`1e-6`, `1e20`).
pub fn num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A bound for messages: [`num`], with powers of ten from 10⁴ up written `1e4`, `1e6`, ….
fn bound(v: f64) -> String {
    let e = v.abs().log10();
    if v.abs() >= 1e4 && e.fract() == 0.0 && v.abs() == 10f64.powi(e as i32) {
        format!("{}1e{}", if v < 0.0 { "-" } else { "" }, e as i32)
    } else {
        num(v)
    }
}

/// `v` when `lo ≤ v ≤ hi`, else `"{v} is outside {lo}..={hi}"`.
pub fn int<T: PartialOrd + Display + Copy>(v: T, lo: T, hi: T) -> Result<T, String> {
    if lo <= v && v <= hi {
        Ok(v)
    } else {
        Err(format!("{v} is outside {lo}..={hi}"))
    }
}

/// `v` when it is finite and in the interval, else `"{v} is outside {interval}"`.
pub fn real(v: f64, lo: f64, hi: f64, ends: Ends) -> Result<f64, String> {
    let (lo_in, hi_in) = match ends {
        Ends::Closed => (v >= lo, v <= hi),
        Ends::Open => (v > lo, v < hi),
        Ends::OpenClosed => (v > lo, v <= hi),
        Ends::ClosedOpen => (v >= lo, v < hi),
    };
    if v.is_finite() && lo_in && hi_in {
        return Ok(v);
    }
    let (l, r) = match ends {
        Ends::Closed => ('[', ']'),
        Ends::Open => ('(', ')'),
        Ends::OpenClosed => ('(', ']'),
        Ends::ClosedOpen => ('[', ')'),
    };
    Err(format!(
        "{} is outside {l}{}, {}{r}",
        num(v),
        bound(lo),
        bound(hi)
    ))
}

impl KeyError {
    /// [`int`] of the parameter `key`.
    pub fn int<T: PartialOrd + Display + Copy>(key: &str, v: T, lo: T, hi: T) -> Result<T, Self> {
        int(v, lo, hi).map_err(|m| Self::new(key, m))
    }

    /// [`real`] of the parameter `key`.
    pub fn real(key: &str, v: f64, lo: f64, hi: f64, ends: Ends) -> Result<f64, Self> {
        real(v, lo, hi, ends).map_err(|m| Self::new(key, m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_ranges_include_both_ends_and_say_so() {
        assert_eq!(int(1usize, 1, 16), Ok(1));
        assert_eq!(int(16usize, 1, 16), Ok(16));
        assert_eq!(int(0usize, 1, 16), Err("0 is outside 1..=16".into()));
        assert_eq!(int(17usize, 1, 16), Err("17 is outside 1..=16".into()));
    }

    #[test]
    fn real_intervals_at_their_edges() {
        let e = f64::EPSILON;
        assert!(real(0.0, 0.0, 90.0, Ends::Open).is_err());
        assert!(real(90.0, 0.0, 90.0, Ends::Open).is_err());
        assert_eq!(real(e, 0.0, 90.0, Ends::Open), Ok(e));
        assert_eq!(real(90.0, 0.0, 90.0, Ends::OpenClosed), Ok(90.0));
        assert!(real(0.0, 0.0, 90.0, Ends::OpenClosed).is_err());
        assert_eq!(real(0.0, 0.0, 1.0, Ends::ClosedOpen), Ok(0.0));
        assert!(real(1.0, 0.0, 1.0, Ends::ClosedOpen).is_err());
        assert_eq!(real(1.0, 0.0, 1.0, Ends::Closed), Ok(1.0));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(real(bad, f64::NEG_INFINITY, f64::INFINITY, Ends::Closed).is_err());
        }
        assert_eq!(
            real(95.0, 0.0, 90.0, Ends::Open),
            Err("95 is outside (0, 90)".into())
        );
        assert_eq!(
            real(2e6, 0.0, 1e6, Ends::OpenClosed),
            Err("2000000 is outside (0, 1e6]".into())
        );
        assert_eq!(
            real(-1.0, 1e-6, 1e6, Ends::Closed),
            Err("-1 is outside [1e-6, 1e6]".into())
        );
        assert_eq!(
            real(f64::NAN, 0.0, 1.0, Ends::Closed),
            Err("NaN is outside [0, 1]".into())
        );
    }

    #[test]
    fn key_errors_name_the_key() {
        let e = KeyError::int("order", 0usize, 1, 16).unwrap_err();
        assert_eq!(
            (e.key.as_str(), e.message.as_str()),
            ("order", "0 is outside 1..=16")
        );
    }
}
