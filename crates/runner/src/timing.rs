//! The one timing procedure of every time column of an experiment: `warmup` untimed calls, then
//! `repeats` timed calls; the median is the column, the relative spread `(max − min) / median` is
//! recorded beside it. Work that runs on the GPU is synchronised inside the timed closure (the
//! GPU path's timers wait for the queue). Times taken while other runs of the same process ran
//! concurrently are marked (`timing_concurrent = true` in every row) and left out of Pareto plots.
//!
//! Also the cost model of `--dry-run`: rates measured on the development VM (AMD EPYC, 2 vCPUs,
//! release build) with `shscale run configs/quickstart.toml` and `shscale bench`, see
//! docs/BENCHMARKS.md. They only size plans; they never appear in results.

use std::time::Instant;

/// Warm-up and repeat counts (config keys `timing_warmup`, `timing_repeats`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Procedure {
    pub warmup: usize,
    pub repeats: usize,
}

impl Default for Procedure {
    fn default() -> Self {
        Self {
            warmup: 1,
            repeats: 3,
        }
    }
}

/// The most repeats (and warm-up calls) a config may ask for.
pub(crate) const MAX_REPEATS: usize = 100;

/// A measured time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    pub repeats: usize,
    /// A distribution-free confidence interval of the median ([`median_interval`]): the
    /// narrowest pair of order statistics covering it with probability ≥ 95 %, or (min, max) when
    /// no pair reaches 95 % (fewer than 6 repeats; coverage [`Timing::coverage`]).
    pub lo: f64,
    pub hi: f64,
    /// The interval's coverage probability (`1 − 2·P(Bin(n, ½) ≤ j)` for the order statistics
    /// j + 1 and n − j, 1-based; 0.9375 at n = 5, 0.961 at n = 9; 0 for one repeat).
    pub coverage: f64,
}

/// The order-statistic interval of a median: for `n` sorted samples the largest `j` with
/// `1 − 2·P(Bin(n, ½) ≤ j) ≥ level` (the interval `[s_j, s_{n−1−j}]`, 0-based), or `j = 0`
/// (min, max) when none reaches `level`; returns `(j, coverage)`. Distribution-free: it needs
/// only independent samples of one continuous distribution (Hahn & Meeker, *Statistical
/// Intervals*, §5.2). Domain: `n ≥ 1`, `level` in (0, 1).
pub fn median_interval(n: usize, level: f64) -> (usize, f64) {
    // P(Bin(n, ½) ≤ i) by summing binomial coefficients in f64 (exact to rounding for n ≤ 1000).
    let cdf = |i: usize| -> f64 {
        let mut c = 1.0f64;
        let mut sum = 0.0;
        for k in 0..=i {
            if k > 0 {
                c = c * (n + 1 - k) as f64 / k as f64;
            }
            sum += c;
        }
        sum / 2f64.powi(n as i32)
    };
    let cover = |j: usize| 1.0 - 2.0 * cdf(j);
    let mut j = 0;
    while 2 * (j + 1) < n && cover(j + 1) >= level {
        j += 1;
    }
    (j, if n == 1 { 0.0 } else { cover(j) })
}

impl Timing {
    /// `(max − min) / median` (0 for a single repeat).
    pub fn spread(&self) -> f64 {
        if self.median > 0.0 {
            (self.max - self.min) / self.median
        } else {
            0.0
        }
    }

    /// Median, min and max of samples (seconds).
    pub fn of(samples: &[f64]) -> Self {
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        if n == 0 {
            return Self::default();
        }
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        let (j, coverage) = median_interval(n, 0.95);
        Self {
            median,
            min: s[0],
            max: s[n - 1],
            repeats: n,
            lo: s[j],
            hi: s[n - 1 - j],
            coverage,
        }
    }
}

impl Procedure {
    /// Run `f` `warmup + repeats` times; the last result and the timing of the repeats.
    pub fn measure<T, E>(&self, mut f: impl FnMut() -> Result<T, E>) -> Result<(T, Timing), E> {
        for _ in 0..self.warmup {
            f()?;
        }
        let mut samples = Vec::with_capacity(self.repeats.max(1));
        let mut last = None;
        for _ in 0..self.repeats.max(1) {
            let t0 = Instant::now();
            let v = f()?;
            samples.push(t0.elapsed().as_secs_f64());
            last = Some(v);
        }
        let v = last.expect("at least one repeat ran");
        Ok((v, Timing::of(&samples)))
    }

    /// Run `f` once per (warm-up + repeat) where each call yields several named times; the
    /// median etc. per name.
    pub fn measure_parts<T, E, const P: usize>(
        &self,
        mut f: impl FnMut() -> Result<(T, [f64; P]), E>,
    ) -> Result<(T, [Timing; P]), E> {
        for _ in 0..self.warmup {
            f()?;
        }
        let mut samples: [Vec<f64>; P] = std::array::from_fn(|_| Vec::new());
        let mut last = None;
        for _ in 0..self.repeats.max(1) {
            let (v, t) = f()?;
            for (s, x) in samples.iter_mut().zip(t) {
                s.push(x);
            }
            last = Some(v);
        }
        let v = last.expect("at least one repeat ran");
        Ok((v, std::array::from_fn(|i| Timing::of(&samples[i]))))
    }
}

impl Procedure {
    /// [`Procedure::measure_parts`] for a number of parts known at run time (a time per probe
    /// radius, say): every call yields the same number of named times; the median etc. per
    /// part. A call yielding a different count is an error of the caller's closure.
    pub fn measure_each<T, E>(
        &self,
        mut f: impl FnMut() -> Result<(T, Vec<f64>), E>,
    ) -> Result<(T, Vec<Timing>), E> {
        for _ in 0..self.warmup {
            f()?;
        }
        let mut samples: Vec<Vec<f64>> = Vec::new();
        let mut last = None;
        for _ in 0..self.repeats.max(1) {
            let (v, t) = f()?;
            samples.resize(samples.len().max(t.len()), Vec::new());
            for (s, x) in samples.iter_mut().zip(t) {
                s.push(x);
            }
            last = Some(v);
        }
        let v = last.expect("at least one repeat ran");
        Ok((v, samples.iter().map(|s| Timing::of(s)).collect()))
    }
}

/// Occlusion rays per second of the CPU path on this machine (2 threads, bunny BSV workload:
/// 12×20 × 32² rays in ≈ 29 ms, docs/BENCHMARKS.md).
pub const CPU_RAYS_PER_SECOND: f64 = 8.0e6;

/// Rays per second of the converged ray-traced truths (4T² stratified rays per probe, computed
/// once per probe and radius, never timed), on the development VM with 2 threads: the
/// quickstart's `truth_seconds` column gives 1.2e7 rays/s for the bunny's probes at 0.5r and
/// 4.2e7 at 2r (`shscale run configs/quickstart.toml`); the model takes the middle.
pub const TRUTH_RAYS_PER_SECOND: f64 = 2.6e7;

/// The calibration workload's rate on the machine the rates above describe
/// (`shscale_scene::calibrate::rays_per_second`: the bundled bunny's occlusion rays from 1.1r,
/// every thread). A machine that measures `k` times this rate is estimated to take `1/k` of the
/// development VM's seconds. The rates above were fitted on an earlier sitting's VM, which is
/// gone; this reference was set on the development VM of 2026-12-04, evening (AMD EPYC, family
/// 26 model 2 (Zen 5), 2 vCPUs): its calibration rate (6.2·10⁷ rays/s, the median of seven
/// `--dry-run`s) divided by 1.79, the geometric middle of the smallest and largest ratio of
/// estimated to measured seconds over every shipped config there (1.06 and 3.01,
/// `SHSCALE_SPEED=1 shscale bench estimates …`, docs/BENCHMARKS.md "Dry-run estimates"), the
/// factor that keeps the worst ratio nearest to 1.
pub const CALIBRATION_REFERENCE_RAYS_PER_SECOND: f64 = 3.46e7;

static MACHINE_SPEED: std::sync::OnceLock<f64> = std::sync::OnceLock::new();

/// Record this machine's speed against the development VM (its calibration rate over
/// [`CALIBRATION_REFERENCE_RAYS_PER_SECOND`]), once per process: every estimate after it is in
/// this machine's seconds. A speed that is not finite and positive is ignored. Returns the speed
/// in force.
pub fn set_machine_speed(speed: f64) -> Option<f64> {
    if speed.is_finite() && speed > 0.0 {
        let _ = MACHINE_SPEED.set(speed);
    }
    machine_speed()
}

static CALIBRATION_CONTENTION: std::sync::OnceLock<crate::contention::Reading> =
    std::sync::OnceLock::new();

/// Record how busy the machine was while its speed was measured (once per process).
pub fn set_calibration_contention(r: crate::contention::Reading) {
    let _ = CALIBRATION_CONTENTION.set(r);
}

/// What `--dry-run` says of a calibration measured on a busy machine: the other processes'
/// cores, the load, and how far the estimate can move when the load changes — by up to
/// `n / (n − c)` on `n` CPUs with `c` cores taken by others (their share freed, or doubled);
/// `None` for a quiet calibration or none.
pub fn calibration_warning() -> Option<String> {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    calibration_warning_of(CALIBRATION_CONTENTION.get()?, n)
}

/// [`calibration_warning`] of a reading on `n` CPUs.
pub(crate) fn calibration_warning_of(r: &crate::contention::Reading, n: f64) -> Option<String> {
    if !r.contended {
        return None;
    }
    let factor = n / (n - r.other_cpu).max(0.5);
    Some(format!(
        "the calibration ran on a busy machine (other processes used {:.1} of {n:.0} cores, steal {:.0} %, load {:.1}): the estimate can be {factor:.1}× too long or too short when the load changes",
        r.other_cpu,
        r.steal * 100.0,
        r.load_1m
    ))
}

/// The speed recorded by [`set_machine_speed`], if any.
pub fn machine_speed() -> Option<f64> {
    MACHINE_SPEED.get().copied()
}

/// What the runner itself spends per run on the development VM (2 threads): the plan, the
/// rows appended and synced (group commits, about ten a second), resume, summary and report —
/// 12–21 µs per run from 10³ to 10⁵ runs of a kind that does no work (`shscale bench runner`,
/// docs/BENCHMARKS.md "Group commits"; 20–37 µs with the provenance columns on another VM,
/// "Rows that know what made them"), and about 50 µs per run through `shscale run`, which
/// also logs a line per run (a 10⁴-run `sparsity` sweep: 1.6–1.9 s, of which 1.1 s the runs' own
/// work). Part of every plan's estimated seconds.
pub const BOOKKEEPING_SECONDS_PER_RUN: f64 = 6e-5;

/// What a plan costs whatever its runs: the manifest, the summary, the report and its plots
/// (`configs/paper/fig2_sparsity.toml`, whose 12 runs' matrices take milliseconds: 0.04 s in
/// `shscale bench estimates` on the morning's development VM of 2026-12-04, 0.0074 s on the
/// evening's — 0.013 s in the morning VM's seconds after calibration; set between the two).
/// Part of the bookkeeping of every estimate.
pub(crate) const PLAN_OVERHEAD_SECONDS: f64 = 0.02;

/// The most rays a plan may trace without `--allow-large`.
pub const MAX_PLAN_RAYS: f64 = 1e10;

/// The most bytes a plan's largest group may hold without `--allow-large` (8 GiB).
pub const MAX_PLAN_BYTES: f64 = 8.0 * 1024.0 * 1024.0 * 1024.0;

#[cfg(test)]
mod tests {
    #[test]
    fn the_median_interval_has_its_binomial_coverage() {
        // Closed forms: n = 5 → (min, max), 1 − 2/32; n = 9 → 2nd and 8th, 1 − 2·10/512;
        // n = 20 → 6th and 15th, 1 − 2·P(Bin(20, ½) ≤ 5) = 1 − 2·21700/2²⁰.
        for (n, j, c) in [
            (5, 0, 1.0 - 2.0 / 32.0),
            (6, 0, 1.0 - 2.0 / 64.0),
            (9, 1, 1.0 - 20.0 / 512.0),
            (20, 5, 1.0 - 2.0 * 21700.0 / 1048576.0),
        ] {
            let (gj, gc) = super::median_interval(n, 0.95);
            println!("n = {n}: j = {gj}, coverage {gc:.6} (closed form {c:.6})");
            assert_eq!(gj, j, "n = {n}");
            assert!((gc - c).abs() < 1e-12, "n = {n}: {gc} vs {c}");
        }
        // Monte Carlo oracle: the interval of 9 uniform draws holds the true median 0.5 in
        // 96.1 % of 40 000 trials (binomial s.d. 0.1 %; tolerance 0.6 %).
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let trials = 40_000;
        let hits = (0..trials)
            .filter(|_| {
                let t = super::Timing::of(&(0..9).map(|_| next()).collect::<Vec<_>>());
                t.lo <= 0.5 && 0.5 <= t.hi
            })
            .count();
        let rate = hits as f64 / trials as f64;
        println!("empirical coverage {rate:.4} vs 0.9609");
        assert!((rate - 0.9609).abs() < 0.006, "{rate}");
        let one = super::Timing::of(&[2.0]);
        assert_eq!((one.lo, one.hi, one.coverage), (2.0, 2.0, 0.0));
    }

    use super::*;

    #[test]
    fn median_and_spread() {
        let t = Timing::of(&[3.0, 1.0, 2.0]);
        assert_eq!((t.median, t.min, t.max, t.repeats), (2.0, 1.0, 3.0, 3));
        assert_eq!(t.spread(), 1.0);
        assert_eq!(Timing::of(&[1.0, 3.0]).median, 2.0);
        let mut calls = 0;
        let p = Procedure {
            warmup: 2,
            repeats: 5,
        };
        let (v, t) = p
            .measure(|| {
                calls += 1;
                Ok::<_, ()>(calls)
            })
            .unwrap();
        assert_eq!((v, calls, t.repeats), (7, 7, 5));
    }
}
