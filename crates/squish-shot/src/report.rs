//! Reports written next to the results: the library's `FrameStats` with durations in
//! milliseconds, ready for JSON.

use serde::Serialize;
use squish::pipeline::{FrameStats, ObjectStats, PairStats};
use squish::stage::PerStage;

/// One frame's figures for a JSON report.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameReport {
    pub total_ms: f64,
    /// Per-stage times in milliseconds, `{ "setup": ms, … }` in the order of
    /// [`squish::stage::Stage::ALL`] (thesis tables 7.1–7.2 breakdown).
    pub stages_ms: PerStage<f64>,
    pub objects: Vec<ObjectStats>,
    pub pairs: Vec<PairStats>,
    /// What the frame did not do that it was asked to (empty contact zone, containment,
    /// reduced parameters, no bulge, residual penetration above the tolerance).
    pub warnings: Vec<squish::pipeline::FrameWarning>,
}

impl From<&FrameStats> for FrameReport {
    fn from(stats: &FrameStats) -> Self {
        Self {
            total_ms: stats.total.as_secs_f64() * 1e3,
            stages_ms: stats.stages.millis(),
            objects: stats.objects.clone(),
            pairs: stats.pairs.clone(),
            warnings: stats.warnings.clone(),
        }
    }
}
