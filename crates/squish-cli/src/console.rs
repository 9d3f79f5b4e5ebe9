//! Printing for people on stdout that never panics: when the reader goes away
//! (`squish run shot.toml | head -1`), the job goes on and its files and report are still
//! written; only the rest of the printout is lost.

/// `println!` that ignores write errors (a closed pipe).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

pub(crate) use say;

/// Prints a frame's warnings (`warning: …`, with the frame number in a shot); returns how many.
pub fn print_warnings(frame: Option<i64>, warnings: &[squish::pipeline::FrameWarning]) -> usize {
    for w in warnings {
        match frame {
            Some(f) => say!("warning: frame {f}: {}", w.message),
            None => say!("warning: {}", w.message),
        }
    }
    warnings.len()
}
