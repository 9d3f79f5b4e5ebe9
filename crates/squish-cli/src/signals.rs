//! Stop requests for long jobs (`squish run`, `squish demo`): Ctrl-C (SIGINT), SIGTERM (what
//! job schedulers and `kill` send) and SIGHUP (a closed terminal or SSH session). The first asks
//! the job to stop scheduling frames ([`squish_shot::Interrupt`]) — frames in progress finish and
//! write their files, then the job writes its report and exits with 128 + the signal (130, 143,
//! 129: the shell convention, so a farm can tell a stop from a failure and from its own kill);
//! the second aborts the process at once, with the same code.
//!
//! Files are written atomically (temporary file + rename), so stopping never leaves a truncated
//! result; only an abort can leave a `.<name>.XXXXXX.tmp` file behind.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicI32, Ordering};

use squish_shot::Interrupt;

/// SIGINT's number, the stop assumed when no signal was received (a stop requested otherwise).
const SIGINT: i32 = 2;

static INTERRUPT: OnceLock<Interrupt> = OnceLock::new();
/// The signal of the first stop request (0: none yet).
static FIRST_SIGNAL: AtomicI32 = AtomicI32::new(0);

/// The exit code of a job stopped by a signal: 128 + the first signal received (130 when none
/// was, as for Ctrl-C).
pub fn stop_exit_code() -> u8 {
    match FIRST_SIGNAL.load(Ordering::SeqCst) {
        0 => 128 + SIGINT as u8,
        signal => 128u8.saturating_add(u8::try_from(signal).unwrap_or(u8::MAX - 128)),
    }
}

/// Installs the handler of the stop signals (once per process) and returns the shared stop
/// request. If the handler cannot be installed, the signals keep their default behaviour and the
/// request is never made.
pub fn install() -> &'static Interrupt {
    static LISTENING: std::sync::Once = std::sync::Once::new();
    let interrupt = INTERRUPT.get_or_init(Interrupt::new);
    LISTENING.call_once(|| {
        if let Err(error) = listen() {
            eprintln!("warning: Ctrl-C will abort at once ({error})");
        }
    });
    interrupt
}

/// A stop signal arrived.
fn on_signal(signal: i32) {
    let Some(interrupt) = INTERRUPT.get() else { return };
    let _ = FIRST_SIGNAL.compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
    if interrupt.request() == 0 {
        eprintln!(
            "\nstop requested ({}): finishing the frames in progress, then writing the report (press Ctrl-C again to abort)",
            name(signal)
        );
    } else {
        eprintln!("\nsecond stop request: aborting (frames in progress are lost)");
        std::process::exit(i32::from(stop_exit_code()));
    }
}

fn name(signal: i32) -> &'static str {
    match signal {
        1 => "SIGHUP",
        15 => "SIGTERM",
        _ => "Ctrl-C",
    }
}

/// A thread that waits for SIGINT, SIGTERM and SIGHUP and tells which arrived.
#[cfg(unix)]
fn listen() -> std::io::Result<()> {
    use signal_hook::consts::signal::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])?;
    std::thread::Builder::new().name("squish-signals".into()).spawn(move || {
        for signal in signals.forever() {
            on_signal(signal);
        }
    })?;
    Ok(())
}

/// Ctrl-C (and the console's close events) where there are no Unix signals.
#[cfg(not(unix))]
fn listen() -> Result<(), ctrlc::Error> {
    ctrlc::set_handler(|| on_signal(SIGINT))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exit_code_is_128_plus_the_signal() {
        assert_eq!(stop_exit_code(), 130);
        FIRST_SIGNAL.store(15, Ordering::SeqCst);
        assert_eq!(stop_exit_code(), 143);
        FIRST_SIGNAL.store(1, Ordering::SeqCst);
        assert_eq!(stop_exit_code(), 129);
        FIRST_SIGNAL.store(0, Ordering::SeqCst);
    }
}
