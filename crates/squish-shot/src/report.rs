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
    /// Per-stage counts of work (`{ "setup": { "queries": …, … }, … }`, see
    /// [`squish::stage::Work`]).
    pub work: squish::stage::StageWork,
    /// The frame plan's jobs, level by level: what each brought into contact and the stages it
    /// ran (see [`squish::pipeline::JobRecord`]).
    pub jobs: Vec<JobReport>,
}

/// A job of the frame plan for a JSON report: [`squish::pipeline::JobRecord`] with its stage times
/// in milliseconds, only the stages it ran.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct JobReport {
    pub level: squish::pipeline::JobLevel,
    pub kind: squish::pipeline::JobKind,
    pub name: String,
    pub objects: [usize; 2],
    pub in_contact: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    pub stages_ms: std::collections::BTreeMap<&'static str, f64>,
    pub work: std::collections::BTreeMap<&'static str, squish::stage::Work>,
}

impl From<&squish::pipeline::JobRecord> for JobReport {
    fn from(job: &squish::pipeline::JobRecord) -> Self {
        Self {
            level: job.level,
            kind: job.kind,
            name: job.name.clone(),
            objects: job.objects,
            in_contact: job.in_contact,
            error: job.error.clone(),
            stages_ms: job.stages.millis().iter().filter(|(_, ms)| **ms > 0.0).map(|(s, ms)| (s.name(), *ms)).collect(),
            work: job.work.iter().filter(|(_, w)| **w != Default::default()).map(|(s, w)| (s.name(), *w)).collect(),
        }
    }
}

impl From<&FrameStats> for FrameReport {
    fn from(stats: &FrameStats) -> Self {
        Self {
            total_ms: stats.total.as_secs_f64() * 1e3,
            stages_ms: stats.stages.millis(),
            objects: stats.objects.clone(),
            pairs: stats.pairs.clone(),
            warnings: stats.warnings.clone(),
            work: stats.work,
            jobs: stats.jobs.iter().map(JobReport::from).collect(),
        }
    }
}
