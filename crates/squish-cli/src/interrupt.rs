//! Ctrl-C for long jobs (`squish run`, `squish demo`): the first Ctrl-C asks the job to stop
//! scheduling frames — frames in progress finish and write their files, then the job writes its
//! report and exits with an error; the second Ctrl-C aborts the process at once.
//!
//! Files are written atomically (temporary file + rename), so stopping never leaves a truncated
//! result; only an abort can leave a `.<name>.XXXXXX.tmp` file behind.
//!
//! Front ends that own the signal themselves (the Python module, whose interpreter turns Ctrl-C
//! into `KeyboardInterrupt`) make their own [`Interrupt`] and [`Interrupt::request`] a stop.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Exit code of an aborted process: 128 + SIGINT, what shells report for a Ctrl-C.
const ABORT_EXIT_CODE: i32 = 130;

/// Counts stop requests (Ctrl-C presses since the handler was installed).
#[derive(Debug, Default)]
pub struct Interrupt {
    presses: AtomicUsize,
}

impl Interrupt {
    /// A stop request not yet made, not tied to the process's Ctrl-C (see [`install`] for that).
    pub fn new() -> Self {
        Self::default()
    }

    /// True once Ctrl-C was pressed (or a stop was requested).
    pub fn requested(&self) -> bool {
        self.presses.load(Ordering::SeqCst) > 0
    }

    /// Asks the job to stop scheduling frames; the frames in progress finish.
    pub fn request(&self) {
        self.presses.fetch_add(1, Ordering::SeqCst);
    }
}

static INTERRUPT: OnceLock<Interrupt> = OnceLock::new();

/// Installs the Ctrl-C handler (once per process) and returns the shared state. If the handler
/// cannot be installed (another library owns the signal), Ctrl-C keeps its default behaviour
/// and `requested()` stays false.
pub fn install() -> &'static Interrupt {
    INTERRUPT.get_or_init(|| {
        let result = ctrlc::set_handler(|| {
            let Some(state) = INTERRUPT.get() else { return };
            if state.presses.fetch_add(1, Ordering::SeqCst) == 0 {
                eprintln!(
                    "\nCtrl-C: finishing the frames in progress, then writing the report (press Ctrl-C again to abort)"
                );
            } else {
                eprintln!("\nCtrl-C again: aborting (frames in progress are lost)");
                std::process::exit(ABORT_EXIT_CODE);
            }
        });
        if let Err(error) = result {
            eprintln!("warning: Ctrl-C will abort at once ({error})");
        }
        Interrupt { presses: AtomicUsize::new(0) }
    })
}
