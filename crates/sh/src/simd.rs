//! Run-time CPU-feature dispatch for the batched kernels (SH evaluation here, ray traversal in
//! `shscale-geometry`).
//!
//! Binaries are portable: nothing is compiled for `target-cpu=native`. Each batched kernel is
//! written once as `#[inline(always)]` lane-array code and instantiated twice — inside a
//! `#[target_feature(enable = "avx2,fma")]` function (x86-64 with AVX2 and FMA, detected at run
//! time; the ray kernels also enable POPCNT, BMI1 and BMI2, which the detection requires too)
//! and as a portable function (SSE2 on x86-64, NEON on aarch64, whatever the target has by
//! default elsewhere). The ray kernels have a third instantiation of the same code, compiled
//! with AVX-512 F, VL, BW and DQ enabled as well ([`Level::Avx512`]): still 256-bit vectors,
//! but EVEX-encoded, so LLVM has 32 vector registers instead of 16 (fewer spills) and mask
//! registers for the compares. [`level`] picks one, once per process.
//!
//! `SHSCALE_SIMD=portable` forces the portable path (CI runs the test suite both ways);
//! `SHSCALE_SIMD=avx2` caps the level at [`Level::Avx2Fma`] on a CPU with AVX-512;
//! `SHSCALE_SIMD=auto` or unset detects. The `shscale` command refuses any other value at start
//! (exit 2, the variable named); the library, which cannot report, takes an unknown value as
//! `portable` — the choice that runs everywhere.

use std::sync::OnceLock;

/// Directions per SIMD batch of `ShBasis::eval_batch` (the `eval` module).
pub const LANES: usize = 8;

/// The instruction set a batched kernel runs with, in increasing order (each level's CPUs have
/// every lower level's instructions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// The target's default features only.
    Portable,
    /// x86-64 AVX2 + FMA (256-bit lanes, fused multiply-add), with the bit-manipulation
    /// instructions every AVX2 CPU has (POPCNT, BMI1, BMI2), which the ray kernels' mask loops
    /// use.
    Avx2Fma,
    /// [`Level::Avx2Fma`] plus AVX-512 F, VL, BW and DQ: the ray kernels' code compiled with
    /// them (256-bit vectors, 32 registers, mask registers); kernels without such an
    /// instantiation (SH evaluation) run their AVX2 code at this level.
    Avx512,
}

impl Level {
    /// This level where the CPU has it, [`Level::Portable`] otherwise: what a caller asking for
    /// a level may safely run.
    pub fn usable(self) -> Level {
        if self <= detected() {
            self
        } else {
            Level::Portable
        }
    }

    /// Lower-case name (`portable`, `avx2+fma`, `avx512`), as reported by benchmarks.
    pub fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2Fma => "avx2+fma",
            Level::Avx512 => "avx512",
        }
    }
}

/// Parse `SHSCALE_SIMD` (`None` = unset): the highest level it allows (`None`: whatever the CPU
/// has).
pub fn parse_setting(v: Option<&str>) -> Result<Option<Level>, String> {
    match v.map(str::trim) {
        None | Some("") | Some("auto") => Ok(None),
        Some("portable") => Ok(Some(Level::Portable)),
        Some("avx2") => Ok(Some(Level::Avx2Fma)),
        Some(other) => Err(format!(
            "SHSCALE_SIMD={other:?}: expected \"auto\", \"avx2\" or \"portable\""
        )),
    }
}

/// What this CPU supports, ignoring the environment (detected once per process).
pub fn detected() -> Level {
    static DETECTED: OnceLock<Level> = OnceLock::new();
    *DETECTED.get_or_init(detect)
}

fn detect() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx2") && has!("fma") && has!("popcnt") && has!("bmi1") && has!("bmi2") {
            if has!("avx512f") && has!("avx512vl") && has!("avx512bw") && has!("avx512dq") {
                return Level::Avx512;
            }
            return Level::Avx2Fma;
        }
    }
    Level::Portable
}

/// The level every batched kernel uses in this process: [`detected`], capped by
/// `SHSCALE_SIMD`.
pub fn level() -> Level {
    static LEVEL: OnceLock<Level> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let v = std::env::var("SHSCALE_SIMD").ok();
        match parse_setting(v.as_deref()) {
            Ok(None) => detected(),
            Ok(Some(cap)) => detected().min(cap),
            Err(_) => Level::Portable,
        }
    })
}

/// Every level this CPU can run, lowest first (tests compare them).
pub fn supported() -> Vec<Level> {
    [Level::Portable, Level::Avx2Fma, Level::Avx512]
        .into_iter()
        .filter(|&l| l <= detected())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setting_is_parsed_strictly() {
        assert_eq!(parse_setting(None), Ok(None));
        assert_eq!(parse_setting(Some("auto")), Ok(None));
        assert_eq!(parse_setting(Some(" portable ")), Ok(Some(Level::Portable)));
        assert_eq!(parse_setting(Some("avx2")), Ok(Some(Level::Avx2Fma)));
        let e = parse_setting(Some("avx9")).unwrap_err();
        assert!(e.contains("SHSCALE_SIMD") && e.contains("avx9"), "{e}");
    }

    #[test]
    fn level_is_supported_by_this_cpu() {
        // The chosen level never exceeds what the CPU has, and asking for a level gives one
        // the CPU has.
        assert!(level() <= detected());
        assert_eq!(Level::Portable.usable(), Level::Portable);
        for l in [Level::Avx2Fma, Level::Avx512] {
            let want = if l <= detected() { l } else { Level::Portable };
            assert_eq!(l.usable(), want, "{l:?}");
        }
        assert_eq!(supported().last(), Some(&detected()));
    }
}
