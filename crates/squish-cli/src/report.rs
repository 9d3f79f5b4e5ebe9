//! Reports written next to the results: the library's `FrameStats` with durations in
//! milliseconds, ready for JSON.

use serde::Serialize;
use squish::pipeline::{FrameStats, ObjectStats, PairStats, StageTimes};

/// Per-stage times in milliseconds (thesis tables 7.1–7.2 breakdown).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StageMillis {
    pub setup: f64,
    pub intersection: f64,
    pub mapping: f64,
    pub contact_zone: f64,
    pub parametrization: f64,
    pub directions: f64,
    pub guide: f64,
    pub deformation: f64,
    pub factorization: f64,
    /// Of the factorizations: symbolic analyses of coupled-row submatrices.
    pub analysis: f64,
}

impl From<&StageTimes> for StageMillis {
    fn from(t: &StageTimes) -> Self {
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        Self {
            setup: ms(t.setup),
            intersection: ms(t.intersection),
            mapping: ms(t.mapping),
            contact_zone: ms(t.contact_zone),
            parametrization: ms(t.parametrization),
            directions: ms(t.directions),
            guide: ms(t.guide),
            deformation: ms(t.deformation),
            factorization: ms(t.factorization),
            analysis: ms(t.analysis),
        }
    }
}

/// One frame's figures for a JSON report.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameReport {
    pub total_ms: f64,
    pub stages_ms: StageMillis,
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
            stages_ms: StageMillis::from(&stats.stages),
            objects: stats.objects.clone(),
            pairs: stats.pairs.clone(),
            warnings: stats.warnings.clone(),
        }
    }
}
