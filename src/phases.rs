//! Start-up phase timings for diagnosing where a render's start goes: with the environment
//! variable `LUMO_PHASES` set (to anything), [`mark`] prints to stderr the time since the first
//! mark and since the previous one, with the process's current resident set size (Linux).
//!
//! ```sh
//! LUMO_PHASES=1 lumo render model.glb -o out.png --spp 1
//! ```

use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// `Some(previous mark)` when `LUMO_PHASES` is set.
fn state() -> Option<&'static Mutex<(Instant, Instant)>> {
    static STATE: OnceLock<Option<Mutex<(Instant, Instant)>>> = OnceLock::new();
    STATE
        .get_or_init(|| {
            std::env::var_os("LUMO_PHASES").map(|_| {
                let now = Instant::now();
                Mutex::new((now, now))
            })
        })
        .as_ref()
}

/// Notes that phase `what` has ended (prints only when `LUMO_PHASES` is set).
pub fn mark(what: &str) {
    let Some(state) = state() else {
        return;
    };
    let now = Instant::now();
    let Ok(mut s) = state.lock() else {
        return;
    };
    let (start, last) = *s;
    s.1 = now;
    eprintln!(
        "phase {:8.1} ms {:+8.1} ms  rss {:6} MiB  {what}",
        (now - start).as_secs_f64() * 1e3,
        (now - last).as_secs_f64() * 1e3,
        rss_mib().map_or("?".to_string(), |m| m.to_string()),
    );
}

/// The resident set size in MiB, from /proc/self/statm (Linux), else `None`.
fn rss_mib() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096 / (1 << 20))
}
