//! The bounds of the work guard (issue 37, target 6): a stage's deterministic work
//! ([`squish::stage::Work`]) against committed figures, allowed [`RATIO`] either way plus a small
//! absolute slack per kind ([`SLACK`]), so that a change which multiplies a stage's work fails and
//! one that removes work asks for the figures to be brought down with it. Used by the guard of the
//! procedural and mesh scenes (`tests/bench_work.rs`) and by that of the skinned character's walk
//! (`squish-cli/tests/cli_bench.rs`).

use squish::stage::{Stage, StageWork};

/// Largest factor a count may grow or shrink by.
pub const RATIO: f64 = 1.25;

/// Absolute slack per kind of work, in the order of [`squish::stage::Work::fields`]: small
/// counts may move by this much (a round more, a few queries) without failing.
pub const SLACK: [u64; 5] = [64, 256, 2, 64, 4096];

/// The counts of `actual` out of the bounds of `expected`, one line each, named after `scene`.
pub fn departures(scene: &str, expected: &StageWork, actual: &StageWork) -> Vec<String> {
    let mut lines = Vec::new();
    for stage in Stage::ALL {
        let fields = expected[stage].fields().into_iter().zip(actual[stage].fields()).zip(SLACK);
        for (((kind, e), (_, a)), slack) in fields {
            let (low, high) = (e as f64 / RATIO - slack as f64, e as f64 * RATIO + slack as f64);
            if (a as f64) < low || (a as f64) > high {
                lines.push(format!("{scene}, {stage}: {kind} {a}, committed {e} (allowed {low:.0}–{high:.0})"));
            }
        }
    }
    lines
}
