//! The loop shared by the fuzzing targets (`squish-io/tests/fuzz_readers.rs`, the readers;
//! `squish-cli/tests/fuzz_inputs.rs`, scene files and `--set`): seeds, the limits of one case,
//! and the settings of a long run. Each target brings its generator and what it exercises.

#![allow(dead_code, clippy::unwrap_used)]

use std::sync::mpsc;
use std::time::Duration;

/// Longest processor time one case may take (a file of at most a few hundred KB, or a scene of
/// small meshes). Processor time, not wall time: the long runs are niced on a shared machine,
/// where a case can wait for a processor far longer than it computes.
pub const CASE_LIMIT: Duration = Duration::from_secs(20);
/// Longest wall time one case may take whatever the load (a case blocked without computing).
pub const WALL_LIMIT: Duration = Duration::from_secs(600);
/// Largest peak resident memory of the test process.
pub const MEMORY_LIMIT_KB: u64 = 3 << 20;
pub const MEMORY_LIMIT: &str = "3 GiB";

/// Peak resident memory of this process, in KB (0 where `/proc` is missing).
pub fn peak_memory_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

/// Processor time used by this process so far (user + system, every thread), from
/// `/proc/self/stat` in clock ticks of 1/100 s (Linux's USER_HZ); zero where `/proc` is missing.
pub fn process_cpu_time() -> Duration {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // The fields after the command name (which may hold spaces) start with the state, field 3:
    // utime and stime are fields 14 and 15.
    let fields: Vec<&str> = stat.rsplit_once(')').map_or("", |(_, rest)| rest).split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<u64>().ok()).unwrap_or(0);
    Duration::from_millis(10 * (ticks(11) + ticks(12)))
}

/// Runs `work` on a thread of its own: its result, or why the case failed (a panic, more than
/// [`CASE_LIMIT`] of processor time or [`WALL_LIMIT`] of wall time, memory past
/// [`MEMORY_LIMIT`]).
pub fn guarded<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + std::panic::UnwindSafe + 'static,
) -> Result<T, String> {
    let (send, receive) = mpsc::channel();
    let (cpu_start, wall_start) = (process_cpu_time(), std::time::Instant::now());
    std::thread::spawn(move || {
        let _ = send.send(std::panic::catch_unwind(work).ok());
    });
    let result = loop {
        match receive.recv_timeout(Duration::from_millis(500)) {
            Ok(Some(result)) => break result,
            Ok(None) => return Err("panicked".to_string()),
            Err(mpsc::RecvTimeoutError::Disconnected) => return Err("its thread ended without a result".to_string()),
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if process_cpu_time().saturating_sub(cpu_start) > CASE_LIMIT {
                    return Err(format!("took more than {CASE_LIMIT:?} of processor time"));
                }
                if wall_start.elapsed() > WALL_LIMIT {
                    return Err(format!("took longer than {WALL_LIMIT:?}"));
                }
            }
        }
    };
    if peak_memory_kb() > MEMORY_LIMIT_KB {
        return Err(format!("pushed the peak resident memory past {MEMORY_LIMIT}"));
    }
    Ok(result)
}

/// The seed of case `k` of a run seeded `base` (spread so that neighbouring runs differ).
pub fn case_seed(base: u64, k: u64) -> u64 {
    base.wrapping_add(k.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// A long run's length and base seed: `SQUISH_FUZZ_SECONDS` (default 600) and
/// `SQUISH_FUZZ_SEED` (default: the clock, printed in the summary so a run can be replayed).
pub fn long_run_settings() -> (f64, u64) {
    let seconds: f64 = std::env::var("SQUISH_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(600.0);
    let seed: u64 = std::env::var("SQUISH_FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or_else(|| {
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(1, |d| d.as_nanos() as u64)
    });
    (seconds, seed)
}
