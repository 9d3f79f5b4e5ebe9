//! A stop request for a shot: once requested, no further frame is started — the frames in
//! progress finish and write their files, then the shot writes its report (which lists the
//! missing frames) and ends with [`crate::ShotError::Interrupted`].
//!
//! Files are written atomically (temporary file + rename), so stopping never leaves a truncated
//! result. Who requests the stop is the front end's business: the command line on Ctrl-C,
//! SIGTERM and SIGHUP (its `signals` module), the Python module on `KeyboardInterrupt`.

use std::sync::atomic::{AtomicUsize, Ordering};

/// Counts stop requests.
#[derive(Debug, Default)]
pub struct Interrupt {
    presses: AtomicUsize,
}

impl Interrupt {
    /// A stop request not yet made.
    pub fn new() -> Self {
        Self::default()
    }

    /// True once a stop was requested.
    pub fn requested(&self) -> bool {
        self.presses.load(Ordering::SeqCst) > 0
    }

    /// Asks the job to stop scheduling frames; the frames in progress finish. Returns how many
    /// requests were made before this one.
    pub fn request(&self) -> usize {
        self.presses.fetch_add(1, Ordering::SeqCst)
    }
}
