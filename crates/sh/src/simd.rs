//! Run-time CPU-feature dispatch for the batched kernels (SH evaluation here, ray traversal in
//! `shscale-geometry`).
//!
//! Binaries are portable: nothing is compiled for `target-cpu=native`. Each batched kernel is
//! written once as `#[inline(always)]` lane-array code and instantiated twice — inside a
//! `#[target_feature(enable = "avx2,fma")]` function (x86-64 with AVX2 and FMA, detected at run
//! time; the ray kernels also enable POPCNT, BMI1 and BMI2, which the detection requires too) and as a portable function (SSE2 on x86-64, NEON on aarch64, whatever the target has
//! by default elsewhere). [`level`] picks one, once per process.
//!
//! `SHSCALE_SIMD=portable` forces the portable path (CI runs the test suite both ways);
//! `SHSCALE_SIMD=auto` or unset detects. The `shscale` command refuses any other value at start
//! (exit 2, the variable named); the library, which cannot report, takes an unknown value as
//! `portable` — the choice that runs everywhere.

use std::sync::OnceLock;

/// The instruction set a batched kernel runs with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// The target's default features only.
    Portable,
    /// x86-64 AVX2 + FMA (256-bit lanes, fused multiply-add), with the bit-manipulation
    /// instructions every AVX2 CPU has (POPCNT, BMI1, BMI2), which the ray kernels' mask loops
    /// use.
    Avx2Fma,
}

impl Level {
    /// This level where the CPU has it, [`Level::Portable`] otherwise: what a caller asking for
    /// a level may safely run.
    pub fn usable(self) -> Level {
        if self == detected() {
            self
        } else {
            Level::Portable
        }
    }

    /// Lower-case name (`portable`, `avx2+fma`), as reported by benchmarks.
    pub fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2Fma => "avx2+fma",
        }
    }
}

/// Parse `SHSCALE_SIMD` (`None` = unset).
pub fn parse_setting(v: Option<&str>) -> Result<bool, String> {
    match v.map(str::trim) {
        None | Some("") | Some("auto") => Ok(false),
        Some("portable") => Ok(true),
        Some(other) => Err(format!(
            "SHSCALE_SIMD={other:?}: expected \"auto\" or \"portable\""
        )),
    }
}

/// What this CPU supports, ignoring the environment.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx2") && has!("fma") && has!("popcnt") && has!("bmi1") && has!("bmi2") {
            return Level::Avx2Fma;
        }
    }
    Level::Portable
}

/// The level every batched kernel uses in this process: [`detected`] unless
/// `SHSCALE_SIMD=portable`.
pub fn level() -> Level {
    static LEVEL: OnceLock<Level> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let v = std::env::var("SHSCALE_SIMD").ok();
        match parse_setting(v.as_deref()) {
            Ok(true) => Level::Portable,
            Ok(false) => detected(),
            Err(_) => Level::Portable,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setting_is_parsed_strictly() {
        assert_eq!(parse_setting(None), Ok(false));
        assert_eq!(parse_setting(Some("auto")), Ok(false));
        assert_eq!(parse_setting(Some(" portable ")), Ok(true));
        let e = parse_setting(Some("avx9")).unwrap_err();
        assert!(e.contains("SHSCALE_SIMD") && e.contains("avx9"), "{e}");
    }

    #[test]
    fn level_is_supported_by_this_cpu() {
        // The chosen level never exceeds what the CPU has, and asking for a level gives one
        // the CPU has.
        if level() == Level::Avx2Fma {
            assert_eq!(detected(), Level::Avx2Fma);
        }
        assert_eq!(Level::Portable.usable(), Level::Portable);
        assert_eq!(Level::Avx2Fma.usable(), detected());
    }
}
