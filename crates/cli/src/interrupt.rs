//! A one-line message on Ctrl-C (SIGINT) or SIGTERM during `shscale run`: what was saved and how
//! to resume. Finished runs' rows are appended whole in group commits at most 100 ms apart, so an
//! interruption loses no committed row; the runs of the last commit interval, and the one in
//! progress, are redone by the next start of the same command (a torn last line is set aside).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;

static MESSAGE: OnceLock<Vec<u8>> = OnceLock::new();
/// The message when no run had finished (nothing saved, maybe no file at all).
static NOTHING_YET: OnceLock<Vec<u8>> = OnceLock::new();
/// Whether the results file holds finished runs: it held rows at the start, or a run finished.
static SAVED: AtomicBool = AtomicBool::new(false);
/// The results file, for the handler to look at: rows reach it before the run's "finished"
/// event does, so a signal in between finds the flag unset but the file written.
static CSV: OnceLock<std::ffi::CString> = OnceLock::new();

/// A run finished: its rows are (or within 100 ms will be) in the results file.
pub fn note_finished() {
    SAVED.store(true, Ordering::Release);
}

/// The handler: write the prepared message and exit with the conventional 128 + signal number.
/// Only async-signal-safe calls (an atomic load, `stat`, `write`, `_exit`).
extern "C" fn on_signal(sig: libc::c_int) {
    let written = CSV.get().is_some_and(|p| {
        // SAFETY: `stat` is async-signal-safe; `p` is a NUL-terminated static, `st` a local.
        unsafe {
            let mut st: libc::stat = std::mem::zeroed();
            libc::stat(p.as_ptr(), &mut st) == 0 && st.st_size > 0
        }
    });
    let m = if written || SAVED.load(Ordering::Acquire) {
        MESSAGE.get()
    } else {
        NOTHING_YET.get()
    };
    if let Some(m) = m {
        // SAFETY: `write` and `_exit` are async-signal-safe; `m` is never freed (a static).
        unsafe {
            libc::write(2, m.as_ptr().cast(), m.len());
        }
    }
    // SAFETY: as above.
    unsafe { libc::_exit(128 + sig) }
}

/// From now on, SIGINT and SIGTERM print a line naming `csv` (where the finished runs are) and
/// the command that resumes — or, before any run finished, that nothing was saved — then exit
/// (130 for Ctrl-C).
pub fn explain_on_interrupt(csv: &std::path::Path, resume: &str) {
    let text = format!(
        "\ninterrupted: the runs finished so far are saved in {} (those of the last 100 ms, and the one in progress, are redone); resume with: {resume}\n",
        csv.display()
    );
    let nothing = format!(
        "\ninterrupted before any run finished: nothing was saved; start again with: {resume}\n"
    );
    if MESSAGE.set(text.into_bytes()).is_err() || NOTHING_YET.set(nothing.into_bytes()).is_err() {
        return;
    }
    // The file is created by its first commit, header and rows in one write: not empty means
    // rows. (A path with a NUL byte cannot name a file; the flag alone then decides.)
    if let Ok(p) = std::ffi::CString::new(csv.as_os_str().as_encoded_bytes()) {
        let _ = CSV.set(p);
    }
    // Rows of an earlier start are saved whatever happens now.
    if std::fs::metadata(csv).is_ok_and(|m| m.is_file() && m.len() > 0) {
        SAVED.store(true, Ordering::Release);
    }
    let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: installing a handler that only makes async-signal-safe calls.
    unsafe {
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
    }
}
