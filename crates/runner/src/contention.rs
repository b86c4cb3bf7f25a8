//! How busy the machine was while a run was measured: the CPU time other processes took (from
//! `/proc/stat` less this process's own, from `/proc/self/stat`), the time the hypervisor stole,
//! and the load average — recorded in every row, so a time measured on a busy machine says so
//! (docs/provenance.md, "Contention"). Linux only; elsewhere every reading is 0 and nothing is
//! flagged (said in the docs).
//!
//! Both files count in the same clock ticks (`USER_HZ`), so the share of the machine other
//! processes used is `(Δbusy − Δself) / Δtotal`, times the CPU count for cores, with no tick
//! rate needed. A tick is 10 ms: a window shorter than [`MIN_WINDOW`] reaches back to an older
//! sample (kept in a ring of the last 256, at most one per 20 ms; [`tick`] adds one at least
//! every 100 ms while a plan runs), so a sub-millisecond run reads the contention of the last
//! quarter second around it.

use std::sync::Mutex;
use std::time::{Duration, Instant};

/// A window shorter than this reaches back to an older sample.
pub const MIN_WINDOW: Duration = Duration::from_millis(250);
/// A row is flagged `contended` when other processes used at least this many cores on average
/// during its window…
pub const CONTENDED_OTHER_CPU: f64 = 0.5;
/// …or the hypervisor stole at least this share of the machine's time.
pub const CONTENDED_STEAL: f64 = 0.10;

/// One reading of the counters.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub at: Instant,
    /// Ticks of all CPUs: busy (user, nice, system, irq, softirq), stolen, and in all.
    busy: u64,
    steal: u64,
    total: u64,
    /// Ticks of this process (user + system, all threads, children waited for included).
    own: u64,
    /// The 1-minute load average when read.
    load_1m: f64,
}

/// What a window measured: the row's contention cells.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reading {
    /// Cores other processes used on average.
    pub other_cpu: f64,
    /// Share of the machine's time stolen by the hypervisor.
    pub steal: f64,
    /// The 1-minute load average at the window's end.
    pub load_1m: f64,
    /// [`CONTENDED_OTHER_CPU`] or [`CONTENDED_STEAL`] reached.
    pub contended: bool,
    /// Seconds the reading covers (at least [`MIN_WINDOW`] when older samples exist).
    pub window_s: f64,
}

static RING: Mutex<Vec<Sample>> = Mutex::new(Vec::new());
const RING_LEN: usize = 256;

fn parse_stat(text: &str) -> Option<(u64, u64, u64)> {
    let line = text.lines().find(|l| l.starts_with("cpu "))?;
    let v: Vec<u64> = line
        .split_whitespace()
        .skip(1)
        .map(|x| x.parse().unwrap_or(0))
        .collect();
    let at = |i: usize| v.get(i).copied().unwrap_or(0);
    // user nice system idle iowait irq softirq steal (guest is inside user).
    let busy = at(0) + at(1) + at(2) + at(5) + at(6);
    let total = busy + at(3) + at(4) + at(7);
    Some((busy, at(7), total))
}

fn parse_self(text: &str) -> Option<u64> {
    // The command name (field 2) may hold spaces and parentheses: fields after its last ')'.
    let rest = &text[text.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime, stime, cutime, cstime are fields 14..=17, here 11..=14 (after state at 0).
    let n = |i: usize| f.get(i).and_then(|x| x.parse::<u64>().ok()).unwrap_or(0);
    Some(n(11) + n(12) + n(13) + n(14))
}

/// The counters as of at most [`FRESH`] ago: the newest sample of the ring when it is that
/// recent, else read now — so a sweep of sub-millisecond runs reads `/proc` about every 20 ms,
/// not twice per run (a tick is 10 ms: nothing finer is lost). `None` off Linux.
pub fn sample() -> Option<Sample> {
    let recent = (RING
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .last()
        .copied())
    .filter(|l| l.at.elapsed() < FRESH);
    recent.or_else(read_now)
}

/// How old a sample may be for [`sample`] to reuse it.
pub const FRESH: Duration = Duration::from_millis(20);

/// Read the counters now and keep the sample in the ring.
fn read_now() -> Option<Sample> {
    let (busy, steal, total) = parse_stat(&std::fs::read_to_string("/proc/stat").ok()?)?;
    let own = parse_self(&std::fs::read_to_string("/proc/self/stat").ok()?)?;
    let s = Sample {
        at: Instant::now(),
        busy,
        steal,
        total,
        own,
        load_1m: load_1m(),
    };
    let mut r = RING.lock().unwrap_or_else(|e| e.into_inner());
    if r.last()
        .is_none_or(|l| s.at.duration_since(l.at) >= Duration::from_millis(100))
    {
        if r.len() >= RING_LEN {
            r.remove(0);
        }
        r.push(s);
    }
    Some(s)
}

/// Keep the ring fresh (called by the runner's commit timer; cheap: two small reads at most
/// every 100 ms).
pub fn tick() {
    let due = (RING.lock().unwrap_or_else(|e| e.into_inner()).last())
        .is_none_or(|l| l.at.elapsed() >= Duration::from_millis(100));
    if due {
        let _ = read_now();
    }
}

fn load_1m() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|t| t.split_whitespace().next().and_then(|x| x.parse().ok()))
        .unwrap_or(0.0)
}

/// The CPUs this process may use, read once (`available_parallelism` reads cgroup files on
/// every call: tens of µs, which a sweep of sub-millisecond runs would pay per run).
fn cpus() -> f64 {
    static N: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *N.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()) as f64)
}

/// The contention between `start` (a sample taken when the window opened) and now; a window
/// shorter than [`MIN_WINDOW`] starts at the newest older sample that makes it long enough
/// (or the oldest there is).
pub fn since(start: Option<Sample>) -> Reading {
    let (Some(start), Some(end)) = (start, sample()) else {
        return Reading::default();
    };
    let from = if end.at.duration_since(start.at) >= MIN_WINDOW {
        start
    } else {
        let r = RING.lock().unwrap_or_else(|e| e.into_inner());
        (r.iter().rev())
            .find(|s| end.at.duration_since(s.at) >= MIN_WINDOW)
            .or_else(|| r.first())
            .copied()
            .filter(|s| s.at < start.at)
            .unwrap_or(start)
    };
    between(&from, &end, cpus(), end.load_1m)
}

/// The reading of two samples on a machine of `cpus` CPUs.
pub fn between(a: &Sample, b: &Sample, cpus: f64, load_1m: f64) -> Reading {
    let total = b.total.saturating_sub(a.total) as f64;
    let window_s = b.at.duration_since(a.at).as_secs_f64();
    if total <= 0.0 {
        return Reading {
            load_1m,
            window_s,
            ..Reading::default()
        };
    }
    let busy = b.busy.saturating_sub(a.busy) as f64;
    let own = b.own.saturating_sub(a.own) as f64;
    let other_cpu = ((busy - own).max(0.0) / total * cpus).min(cpus);
    let steal = b.steal.saturating_sub(a.steal) as f64 / total;
    Reading {
        other_cpu,
        steal,
        load_1m,
        contended: other_cpu >= CONTENDED_OTHER_CPU || steal >= CONTENDED_STEAL,
        window_s,
    }
}

/// Round to two decimals (the cells are readings, not measurements to 17 digits).
pub(crate) fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proc_lines_parse_with_spaces_and_parentheses_in_the_command() {
        let (busy, steal, total) =
            parse_stat("cpu  100 5 50 800 10 3 2 7 0 0\ncpu0 1 2 3 4\n").unwrap();
        assert_eq!((busy, steal, total), (160, 7, 977));
        let own = parse_self("42 (a b) c)) S 1 2 3 4 5 6 7 8 9 10 20 30 4 5 20 0").unwrap();
        assert_eq!(own, 20 + 30 + 4 + 5);
        let a = Sample {
            at: Instant::now(),
            busy: 0,
            steal: 0,
            total: 0,
            own: 0,
            load_1m: 0.0,
        };
        // 2 CPUs, 200 ticks: 150 busy of which 50 ours → others used 100/200·2 = 1 core.
        let b = Sample {
            at: a.at + Duration::from_secs(1),
            busy: 150,
            steal: 0,
            total: 200,
            own: 50,
            load_1m: 0.0,
        };
        let r = between(&a, &b, 2.0, 3.0);
        assert!((r.other_cpu - 1.0).abs() < 1e-12 && r.contended, "{r:?}");
        let quiet = Sample { own: 150, ..b };
        assert!(!between(&a, &quiet, 2.0, 0.1).contended);
        let stolen = Sample { steal: 30, ..quiet };
        assert!(between(&a, &stolen, 2.0, 0.1).contended);
        // Edges: no tick elapsed (a window inside one 10 ms tick) reads 0, not NaN; own ticks
        // above the machine's busy ones (counters read a moment apart) clamp at 0; others can
        // never exceed the CPU count.
        let none = between(&a, &a, 2.0, 0.5);
        assert_eq!(
            (none.other_cpu, none.steal, none.contended),
            (0.0, 0.0, false)
        );
        let ahead = Sample { own: 400, ..b };
        assert_eq!(between(&a, &ahead, 2.0, 0.0).other_cpu, 0.0);
        let all = Sample {
            own: 0,
            busy: 200,
            ..b
        };
        assert_eq!(between(&a, &all, 2.0, 0.0).other_cpu, 2.0);
    }

    /// `--dry-run`'s line for a calibration on a busy machine: one of two cores taken by others
    /// lets the estimate move by 2×; a quiet calibration says nothing.
    #[test]
    fn a_busy_calibration_says_how_far_the_estimate_can_move() {
        let busy = Reading {
            other_cpu: 1.0,
            steal: 0.0,
            load_1m: 3.0,
            contended: true,
            window_s: 1.0,
        };
        let w = crate::timing::calibration_warning_of(&busy, 2.0).unwrap();
        assert!(
            w.contains("1.0 of 2 cores") && w.contains("2.0× too long or too short"),
            "{w}"
        );
        let quiet = Reading {
            contended: false,
            ..busy
        };
        assert!(crate::timing::calibration_warning_of(&quiet, 2.0).is_none());
    }

    /// A window measured while two processes of this test spin (both cores of the development
    /// VM) is flagged; the same window without them is not. One test, so the load never overlaps
    /// the quiet window.
    #[test]
    fn a_window_under_load_is_flagged_and_a_quiet_one_is_not() {
        if sample().is_none() {
            eprintln!("notice: no /proc: the contention readings are 0 here; skipped");
            return;
        }
        let window = || {
            let s = sample();
            std::thread::sleep(Duration::from_millis(600));
            since(s)
        };
        // A shared machine (a CI host's neighbours) may be busy by itself now and then: the
        // first of up to five windows that is quiet, and the test fails if none is.
        let quiet = (0..5)
            .map(|_| window())
            .find(|r| !r.contended)
            .unwrap_or_else(window);
        println!("quiet: {quiet:?}");
        let n = cpus() as usize;
        let mut load: Vec<std::process::Child> = (0..n)
            .filter_map(|_| {
                std::process::Command::new("sh")
                    .args(["-c", "while :; do :; done"])
                    .spawn()
                    .ok()
            })
            .collect();
        std::thread::sleep(Duration::from_millis(200));
        let busy = window();
        for c in &mut load {
            let _ = c.kill();
            let _ = c.wait();
        }
        println!("busy ({n} spinning processes): {busy:?}");
        assert!(busy.contended, "{busy:?}");
        assert!(busy.other_cpu >= 0.8 * n as f64 - 0.3, "{busy:?}");
        assert!(!quiet.contended, "a quiet window was flagged: {quiet:?}");
    }
}
