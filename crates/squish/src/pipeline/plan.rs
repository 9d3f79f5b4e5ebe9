//! The frame plan: every source of contact of a frame as jobs between two regions, run by one
//! scheduler over one list of stages (thesis ch. 3, Fig. 3.1; docs/architecture.md, "The frame
//! plan").
//!
//! **Jobs.** A job is one contact between two regions: two working regions of a
//! [`FramePair`](super::FramePair) ([`JobKind::Regions`], ch. 4–5), the two truncated regions of a
//! skinned articulation ([`JobKind::Articulation`], ch. 6) or two parts of a skinned mesh
//! ([`JobKind::Parts`]). Jobs come in two levels, run one after the other: the self-contacts of
//! skinned objects ([`JobLevel::SelfContact`]), then the contacts between objects
//! ([`JobLevel::Objects`]) on their result. *Decision:* a skinned character that folds onto
//! itself and touches another object is first freed of its own folds, then deformed by the other
//! object; each level preserves the volume of its own input, so the frame does.
//!
//! **Stages.** Within a level every job runs chapter 4 (in parallel), then every region with zones
//! chapter 5 (in parallel), then the level's own composition (the blend of articulations; the
//! separation pass between objects); the results are assembled once, then the quality and
//! warnings pass. Each stage adds its wall-clock time and its [`Work`] to the frame's
//! [`StageTimes`] and [`StageWork`] and to the record of each job it ran ([`JobRecord`]).
//!
//! Deterministic: jobs are listed in a fixed order (objects, then their articulations or region
//! pairs in order), parallel maps collect in that order, and every sum runs in it.

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize, Serializer};

use crate::stage::{PerStage, Stage, StageTimes, StageWork, Work};

/// The level of a job (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JobLevel {
    /// The self-contacts of skinned objects, run first.
    #[default]
    SelfContact,
    /// The contacts between objects, on the self-contacts' result.
    Objects,
}

/// What a job brings into contact.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JobKind {
    /// Two working regions of a frame pair (ch. 4–5).
    #[default]
    Regions,
    /// The two truncated regions of a skinned articulation (ch. 6).
    Articulation,
    /// Two parts of a skinned mesh, or the two sheets of a fold.
    Parts,
}

/// One job of a frame and what it did: the trace of the frame plan in `report.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    pub level: JobLevel,
    pub kind: JobKind,
    /// The job's name: the pair's objects and regions, the articulation's or the parts' names.
    pub name: String,
    /// The objects of its two sides (indices into the frame's objects).
    pub objects: [usize; 2],
    /// True if its sides are in contact (non-empty zones).
    pub in_contact: bool,
    /// Why the job was left without effect at this frame, if it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The stages it ran and their time (its share of the frame's).
    #[serde(default, serialize_with = "nonzero_times")]
    pub stages: StageTimes,
    /// The stages it ran and their work.
    #[serde(default, serialize_with = "nonzero_work")]
    pub work: StageWork,
}

/// Serializes only the stages with a time (missing stages read back as zero).
fn nonzero_times<S: Serializer>(times: &StageTimes, serializer: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = serializer.serialize_map(None)?;
    for (stage, time) in times.iter().filter(|(_, t)| !t.is_zero()) {
        map.serialize_entry(stage.name(), time)?;
    }
    map.end()
}

/// Serializes only the stages with some work.
fn nonzero_work<S: Serializer>(work: &StageWork, serializer: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = serializer.serialize_map(None)?;
    for (stage, w) in work.iter().filter(|(_, w)| **w != Work::default()) {
        map.serialize_entry(stage.name(), w)?;
    }
    map.end()
}

impl JobRecord {
    pub fn new(level: JobLevel, kind: JobKind, name: String, objects: [usize; 2]) -> Self {
        Self { level, kind, name, objects, ..Self::default() }
    }
}

/// What the frame's stages did: their times and work, every job's record, and the figures of
/// the self-contacts' jobs.
#[derive(Clone, Debug, Default)]
pub(super) struct Trace {
    pub stages: StageTimes,
    pub work: StageWork,
    pub jobs: Vec<JobRecord>,
    pub articulations: Vec<crate::skinning::ArticulationStats>,
    pub part_pairs: Vec<super::PartPairStats>,
}

impl Trace {
    /// Adds `time` to `stage`.
    pub fn time(&mut self, stage: Stage, time: Duration) {
        self.stages[stage] += time;
    }

    /// Runs `f` as stage `stage`: adds its time and the work it recorded ([`Work::measure`]).
    pub fn run<R>(&mut self, stage: Stage, f: impl FnOnce() -> R) -> R {
        let timer = Instant::now();
        let (result, work) = Work::measure(f);
        self.stages[stage] += timer.elapsed();
        self.work[stage] += work;
        result
    }

    /// Adds a job's stage times (and work) to job `job`'s record and to the frame's.
    pub fn add_to_job(&mut self, job: usize, times: &StageTimes, work: &PerStage<Work>) {
        self.stages += times;
        self.work += work;
        if let Some(record) = self.jobs.get_mut(job) {
            record.stages += times;
            record.work += work;
        }
    }

    /// Adds stage times (and work) shared by the frame, not owned by one job.
    pub fn add(&mut self, times: &StageTimes, work: &PerStage<Work>) {
        self.stages += times;
        self.work += work;
    }

    /// Appends a job and returns its index.
    pub fn push_job(&mut self, record: JobRecord) -> usize {
        self.jobs.push(record);
        self.jobs.len() - 1
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn a_job_record_lists_only_the_stages_it_ran_and_reads_back() {
        let mut trace = Trace::default();
        let job = trace.push_job(JobRecord::new(JobLevel::Objects, JobKind::Regions, "a–b".into(), [0, 1]));
        let mut times = StageTimes::default();
        times[Stage::Mapping] = Duration::from_millis(2);
        let mut work = StageWork::default();
        work[Stage::Mapping].queries = 7;
        trace.add_to_job(job, &times, &work);
        trace.add_to_job(job, &times, &work);
        assert_eq!(trace.stages[Stage::Mapping], Duration::from_millis(4));
        assert_eq!(trace.jobs[0].work[Stage::Mapping].queries, 14);
        let json = serde_json::to_string(&trace.jobs[0]).unwrap();
        assert!(json.contains("\"mapping\"") && !json.contains("\"guide\""), "{json}");
        assert!(json.contains("\"level\":\"objects\"") && json.contains("\"kind\":\"regions\""), "{json}");
        let back: JobRecord = serde_json::from_str(&json).unwrap();
        assert_eq!(back, trace.jobs[0]);
    }
}
