//! The results of `squish bench` (see [`crate::cmd_bench`]): serializable records, derived
//! figures (medians, shares, ratios to the thesis) and the text table.

use std::time::Duration;

use serde::Serialize;
use squish::pipeline::FrameStats;
use squish::stage::{PerStage, Stage, StageTimes, StageWork, Work};
use squish_scenes::bench::{BenchSize, ThesisRow};
use squish_scenes::timing::FactorizationTiming;

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub command: String,
    pub data_directory: String,
    /// Timed frames per scene and run.
    pub frames: usize,
    /// Rounds (`--rounds`): every scene and the shot ran this many times, round after round.
    pub rounds: usize,
    pub memory_method: String,
    /// The machine when the run started and when it ended (load averages tell whether other
    /// work competed for the cores).
    pub machine_before: MachineReport,
    pub machine_after: MachineReport,
    pub scenes: Vec<SceneReport>,
    /// Single-thread median frame of `press-100k` (whole objects) over `press-100k-automatic`
    /// (automatic working regions, same result up to round-off).
    pub automatic_region_speedup: Option<f64>,
    pub shot: Option<ShotReport>,
}

/// Cores, load and build.
#[derive(Clone, Debug, Serialize)]
pub struct MachineReport {
    /// Cores available to the process.
    pub cores: usize,
    /// Threads of the multi-threaded runs.
    pub threads: usize,
    /// 1, 5 and 15-minute load averages (`/proc/loadavg`), when the system reports them.
    pub load_average: Option<[f64; 3]>,
    pub quick: bool,
    /// False for a debug build, whose times mean little.
    pub optimized_build: bool,
}

impl MachineReport {
    pub fn now(cores: usize, threads: usize, size: BenchSize) -> Self {
        let load_average = std::fs::read_to_string("/proc/loadavg").ok().and_then(|text| {
            let values: Vec<f64> = text.split_whitespace().take(3).filter_map(|v| v.parse().ok()).collect();
            <[f64; 3]>::try_from(values).ok()
        });
        Self { cores, threads, load_average, quick: size == BenchSize::Quick, optimized_build: !cfg!(debug_assertions) }
    }
}

/// The thesis row a scene is compared with.
#[derive(Clone, Debug, Serialize)]
pub struct ThesisReport {
    pub table: String,
    pub scene: String,
    /// |𝒲| per side (table 7.3).
    pub working: [usize; 2],
    /// |𝒟| per side.
    pub deformable: [usize; 2],
    /// Average ms per frame of the C++ prototype, one core of an i7-4790K.
    pub ms: f64,
    /// The row's breakdown in ms (its % of `ms`), per stage; `null` where the table has no
    /// column (table 7.1 has no factorization column).
    pub stages_ms: PerStage<Option<f64>>,
}

impl From<ThesisRow> for ThesisReport {
    fn from(row: ThesisRow) -> Self {
        Self {
            table: row.table.to_string(),
            scene: row.scene.to_string(),
            working: row.working,
            deformable: row.deformable,
            ms: row.ms,
            stages_ms: row.stage_ms(),
        }
    }
}

/// Our stage times (ms) over the thesis' (ms), stage by stage (`None` where the thesis has no
/// figure, or timed the stage at 0 %).
fn ratios_to_thesis(ours: &Breakdown, thesis: &PerStage<Option<f64>>) -> PerStage<Option<f64>> {
    thesis.map(|stage, t| t.filter(|&t| t > 0.0).map(|t| ours.stages[stage] / t))
}

/// One object of a scene.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectReport {
    pub name: String,
    pub vertices: usize,
    pub rigid: bool,
    /// |𝒟| and |𝒞| in the single-thread median frame.
    pub deformable_vertices: usize,
    pub contact_vertices: usize,
}

/// Stage times in milliseconds: every stage (the thesis' columns, our setup and working regions,
/// and the nested factorizations and analyses) and the remainder.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Breakdown {
    #[serde(flatten)]
    pub stages: PerStage<f64>,
    /// The frame minus the stages that are spans of their own (gathering zones, statistics,
    /// copies). Negative in a multi-threaded run, whose stage times add up the work of concurrent
    /// pairs and objects.
    pub other: f64,
}

impl Breakdown {
    fn new(total: Duration, t: &StageTimes) -> Self {
        let stages = t.millis();
        let named: f64 = Stage::spans().map(|s| stages[s]).sum();
        Self { stages, other: ms(total) - named }
    }

    /// Every figure as a percentage of `total_ms`.
    fn percent_of(&self, total_ms: f64) -> Self {
        let p = |x: f64| if total_ms > 0.0 { 100.0 * x / total_ms } else { 0.0 };
        Self { stages: self.stages.map(|_, &x| p(x)), other: p(self.other) }
    }

    /// The time outside the thesis' columns: our stages it has no column for, and the rest.
    fn outside_thesis_columns(&self) -> f64 {
        Stage::spans().filter(|s| !s.in_thesis_tables()).map(|s| self.stages[s]).sum::<f64>() + self.other
    }
}

/// One run of a scene's animation (one thread or several).
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    pub threads: usize,
    pub median_ms: f64,
    pub min_ms: f64,
    pub max_ms: f64,
    /// The warm-up frame (builds topology, trees and symbolic analyses; not in the median).
    pub first_frame_ms: f64,
    /// Every timed frame, in animation order.
    pub frame_ms: Vec<f64>,
    /// Index of the median frame in `frame_ms`.
    pub median_frame: usize,
    /// Stages of the median frame.
    pub breakdown_ms: Breakdown,
    /// The same in % of the median frame (the stages that are not nested, and `other`, sum to
    /// 100).
    pub breakdown_percent: Breakdown,
    /// Numeric factorizations in the median frame (3 per deformed object: heat, Poisson, guide).
    pub numeric_factorizations_per_frame: usize,
    /// Rows those factorizations ran on, summed: the regions' sizes when factorized whole, fewer
    /// when the rows outside 𝒫 or 𝒟 are decoupled and left out.
    pub factorized_rows_per_frame: usize,
    /// Of those, the rows whose factor was recomputed in the median frame (the parts of a system
    /// that did not change keep their factor: partial refactorization).
    pub recomputed_rows_per_frame: usize,
    /// Symbolic analyses of those coupled-row submatrices over all timed frames (one each time a
    /// system's coupled rows change).
    pub reduced_analyses_timed_frames: usize,
    /// Symbolic analyses in the warm-up frame and in all timed frames (0: reused).
    pub symbolic_analyses_first_frame: usize,
    pub symbolic_analyses_timed_frames: usize,
    /// The work of each stage in the median frame ([`squish::stage::Work`]: the same on every
    /// machine and thread count).
    pub work: StageWork,
    /// Each timed frame's work, summed over the stages, in animation order.
    pub work_per_frame: Vec<Work>,
    /// The work of each stage summed over the timed frames: with `--quick`, the figures the work
    /// guard (`crates/squish-scenes/tests/bench_work.rs`) holds the scenes to.
    pub work_timed_frames: StageWork,
}

/// What a run measured, for [`RunReport::new`].
pub struct RunFigures<'a> {
    pub threads: usize,
    pub stats: &'a [FrameStats],
    pub first_frame: Duration,
    pub numeric_factorizations: &'a [usize],
    pub factorized_rows: &'a [usize],
    pub recomputed_rows: &'a [usize],
    pub reduced_analyses_timed_frames: usize,
    pub symbolic_analyses_first_frame: usize,
    pub symbolic_analyses_timed_frames: usize,
}

impl RunReport {
    /// `median` is the index of the median frame of `figures.stats` (non-empty).
    pub fn new(figures: &RunFigures, median: usize) -> Self {
        let frame_ms: Vec<f64> = figures.stats.iter().map(|s| ms(s.total)).collect();
        let median_stats = &figures.stats[median];
        let breakdown_ms = Breakdown::new(median_stats.total, &median_stats.stages);
        let median_ms = frame_ms[median];
        Self {
            threads: figures.threads,
            median_ms,
            min_ms: frame_ms.iter().copied().fold(f64::INFINITY, f64::min),
            max_ms: frame_ms.iter().copied().fold(0.0, f64::max),
            first_frame_ms: ms(figures.first_frame),
            breakdown_percent: breakdown_ms.percent_of(median_ms),
            breakdown_ms,
            frame_ms,
            median_frame: median,
            numeric_factorizations_per_frame: figures.numeric_factorizations.get(median).copied().unwrap_or(0),
            factorized_rows_per_frame: figures.factorized_rows.get(median).copied().unwrap_or(0),
            recomputed_rows_per_frame: figures.recomputed_rows.get(median).copied().unwrap_or(0),
            reduced_analyses_timed_frames: figures.reduced_analyses_timed_frames,
            symbolic_analyses_first_frame: figures.symbolic_analyses_first_frame,
            symbolic_analyses_timed_frames: figures.symbolic_analyses_timed_frames,
            work: median_stats.work,
            work_per_frame: figures.stats.iter().map(|s| total_work(&s.work)).collect(),
            work_timed_frames: figures.stats.iter().fold(StageWork::default(), |mut sum, s| {
                sum += &s.work;
                sum
            }),
        }
    }
}

/// The work of every stage, summed.
pub fn total_work(work: &StageWork) -> Work {
    let mut total = Work::ZERO;
    for (_, w) in work.iter() {
        total += *w;
    }
    total
}

/// One numeric factorization of the largest deformable object's heat operator `M + tK`.
#[derive(Clone, Debug, Serialize)]
pub struct FactorizationReport {
    pub object: String,
    pub vertices: usize,
    pub matrix_nonzeros: usize,
    pub factor_nonzeros: usize,
    /// Supernodes of the factor (dense column blocks).
    pub supernodes: usize,
    /// The symbolic analysis (once per region).
    pub symbolic_ms: f64,
    /// The fastest of 5 in-place numeric refactorizations: what a frame pays per system.
    pub numeric_ms: f64,
}

impl FactorizationReport {
    pub fn new(object: &str, t: &FactorizationTiming) -> Self {
        Self {
            object: object.to_string(),
            vertices: t.vertices,
            matrix_nonzeros: t.matrix_nonzeros,
            factor_nonzeros: t.factor_nonzeros,
            supernodes: t.supernodes,
            symbolic_ms: ms(t.symbolic),
            numeric_ms: ms(t.refactorization),
        }
    }
}

/// One scene's row.
#[derive(Clone, Debug, Serialize)]
pub struct SceneReport {
    pub name: String,
    pub thesis: Option<ThesisReport>,
    /// Why the scene was not run (e.g. a missing mesh file).
    pub skipped: Option<String>,
    /// Why the scene failed.
    pub error: Option<String>,
    pub objects: Vec<ObjectReport>,
    /// |𝒲| and |𝒟| per side (objects first in a pair, the others), like the thesis rows.
    pub working: [usize; 2],
    pub deformable: [usize; 2],
    pub frames: usize,
    pub single: Option<RunReport>,
    pub multi: Option<RunReport>,
    /// Single-thread median / multi-thread median.
    pub speedup: Option<f64>,
    pub factorization: Option<FactorizationReport>,
    /// Single-thread median frame / one numeric factorization of the largest region.
    pub frame_over_factorization: Option<f64>,
    /// The same for the multi-threaded median frame.
    pub frame_over_factorization_all_threads: Option<f64>,
    /// Single-thread median frame / the thesis' time.
    pub thesis_ratio: Option<f64>,
    /// The single-thread median frame's stages over the thesis' (ms / ms, column by column):
    /// where the time goes compared with the prototype.
    pub stages_over_thesis: Option<PerStage<Option<f64>>>,
    /// The part of that frame outside the thesis' columns (setup, working regions, other), ms.
    pub outside_thesis_columns_ms: Option<f64>,
    /// Peak resident memory while the scene ran (see `memory_method`), MB, in the first round.
    pub peak_memory_mb: Option<f64>,
    /// Every round's figures; `single`, `multi` and `factorization` are each the round with the
    /// median of theirs.
    pub rounds: Option<RoundsReport>,
    /// The time of an edit of a parameter of §5.4–5.5 against the full frame (single thread).
    pub edit: Option<EditReport>,
    /// A skinned character with self-contact parts: every frame of its animation, and the
    /// frame time by number of touching part pairs (single thread).
    pub self_contact: Option<SelfContactReport>,
    /// True when the multi-threaded run's outputs are the single-thread run's, bit for bit,
    /// frame by frame.
    pub same_output_across_threads: Option<bool>,
    /// True when its work counts are the same too, frame by frame and stage by stage.
    pub same_work_across_threads: Option<bool>,
}

/// Every frame of a skinned character's animation on one deformer (after a warm-up frame),
/// single thread: how the time grows with the number of touching part pairs.
#[derive(Clone, Debug, Serialize)]
pub struct SelfContactReport {
    pub frames: Vec<SelfContactFrame>,
    /// Per number of touching part pairs (ascending): its frames and their median times.
    pub by_touching_pairs: Vec<SelfContactGroup>,
}

/// One frame of a [`SelfContactReport`].
#[derive(Clone, Debug, Serialize)]
pub struct SelfContactFrame {
    /// The frame's index in the animation (0-based).
    pub frame: usize,
    /// Part pairs touching beyond the rest pose's intersections, and of those, pushed apart.
    pub touching_pairs: usize,
    pub pairs_in_contact: usize,
    /// Articulations that were active (not left out for an error).
    pub articulations: usize,
    pub ms: f64,
    /// The part-pair stage: the sum of the pairs' times.
    pub part_pairs_ms: f64,
    /// The articulations: the sum of their times (the rest of the frame is mostly the
    /// counting of the faces intersecting beyond the rest pose's).
    pub articulations_ms: f64,
    /// The untangling after the part contacts (`untangle`), counting its own crossings.
    pub untangle_ms: f64,
    /// Faces intersecting beyond the rest pose's, before and after.
    pub faces: [usize; 2],
}

/// The frames of a [`SelfContactReport`] with the same number of touching part pairs.
#[derive(Clone, Debug, Serialize)]
pub struct SelfContactGroup {
    pub touching_pairs: usize,
    pub frames: usize,
    pub median_ms: f64,
    pub median_part_pairs_ms: f64,
    pub median_articulations_ms: f64,
    pub median_untangle_ms: f64,
}

impl SelfContactReport {
    pub fn new(frames: Vec<SelfContactFrame>) -> Self {
        let mut counts: Vec<usize> = frames.iter().map(|f| f.touching_pairs).collect();
        counts.sort_unstable();
        counts.dedup();
        let by_touching_pairs = counts
            .into_iter()
            .map(|touching_pairs| {
                let group: Vec<&SelfContactFrame> =
                    frames.iter().filter(|f| f.touching_pairs == touching_pairs).collect();
                let median = |value: fn(&SelfContactFrame) -> f64| {
                    median_value(&group.iter().map(|f| value(f)).collect::<Vec<f64>>())
                };
                SelfContactGroup {
                    touching_pairs,
                    frames: group.len(),
                    median_ms: median(|f| f.ms),
                    median_part_pairs_ms: median(|f| f.part_pairs_ms),
                    median_articulations_ms: median(|f| f.articulations_ms),
                    median_untangle_ms: median(|f| f.untangle_ms),
                }
            })
            .collect();
        Self { frames, by_touching_pairs }
    }
}

/// An edit of a parameter of §5.4–5.5 (`squish::pipeline::DOWNSTREAM_KEYS`) on every deformable
/// object of one frame, computed from the kept frame's contacts and fields, single thread.
#[derive(Clone, Debug, Serialize)]
pub struct EditReport {
    /// The parameter and its two values (the kept frame's, the edit's).
    pub parameter: String,
    pub from: f64,
    pub to: f64,
    /// Edits timed.
    pub edits: usize,
    /// Median time of one edit.
    pub median_ms: f64,
    /// Median time of the full frame it edits, on the deformer that keeps what edits reuse.
    pub full_frame_keeping_ms: f64,
    /// `median_ms` ÷ the scene's single-thread median frame (the target is ≤ 0.2).
    pub ratio_to_frame: Option<f64>,
}

impl EditReport {
    pub fn new(parameter: &str, [from, to]: [f64; 2], edits: &[Duration], full: &[Duration]) -> Self {
        let median = |d: &[Duration]| median_value(&d.iter().map(|&d| ms(d)).collect::<Vec<f64>>());
        Self {
            parameter: parameter.to_string(),
            from,
            to,
            edits: edits.len(),
            median_ms: median(edits),
            full_frame_keeping_ms: median(full),
            ratio_to_frame: None,
        }
    }
}

/// A scene's figures in every round (`--rounds`), in round order.
#[derive(Clone, Debug, Serialize)]
pub struct RoundsReport {
    /// The single-thread median frame of each round.
    pub single_ms: Vec<f64>,
    /// The multi-threaded median frame of each round.
    pub multi_ms: Vec<f64>,
    /// The reference factorization of each round (the fastest of its five).
    pub factorization_ms: Vec<f64>,
    /// The fastest round's single-thread median frame.
    pub single_fastest_ms: f64,
    /// The same over the thesis' time.
    pub fastest_thesis_ratio: Option<f64>,
}

/// Index of the median of `values` (the lower one for an even count; `None` when empty).
fn median_position(values: &[f64]) -> Option<usize> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    order.get(values.len().checked_sub(1)? / 2).copied()
}

/// The median of `values` (the lower one for an even count; 0 when empty).
fn median_value(values: &[f64]) -> f64 {
    median_position(values).map_or(0.0, |i| values[i])
}

impl SceneReport {
    pub fn new(name: &str, thesis: Option<ThesisReport>, objects: Vec<ObjectReport>, frames: usize) -> Self {
        Self {
            name: name.to_string(),
            thesis,
            skipped: None,
            error: None,
            objects,
            working: [0; 2],
            deformable: [0; 2],
            frames,
            single: None,
            multi: None,
            speedup: None,
            factorization: None,
            frame_over_factorization: None,
            frame_over_factorization_all_threads: None,
            thesis_ratio: None,
            stages_over_thesis: None,
            outside_thesis_columns_ms: None,
            peak_memory_mb: None,
            rounds: None,
            edit: None,
            self_contact: None,
            same_output_across_threads: None,
            same_work_across_threads: None,
        }
    }

    pub fn skipped(name: &str, thesis: Option<ThesisReport>, reason: String) -> Self {
        Self { skipped: Some(reason), ..Self::new(name, thesis, Vec::new(), 0) }
    }

    /// Sums per side and derives the ratios once the runs are in.
    pub fn finish(&mut self, sides: &[Vec<usize>; 2]) {
        for (s, side) in sides.iter().enumerate() {
            let objects = side.iter().filter_map(|&i| self.objects.get(i));
            self.working[s] = objects.clone().map(|o| o.vertices).sum();
            self.deformable[s] = objects.map(|o| o.deformable_vertices).sum();
        }
        self.derive_ratios();
    }

    /// The ratios between the runs, the factorization and the thesis.
    fn derive_ratios(&mut self) {
        if let (Some(single), Some(multi)) = (&self.single, &self.multi) {
            self.speedup = Some(single.median_ms / multi.median_ms);
        }
        let factorization_ms = self.factorization.as_ref().map(|f| f.numeric_ms).filter(|&ms| ms > 0.0);
        if let Some(single) = &self.single {
            self.thesis_ratio = self.thesis.as_ref().map(|t| single.median_ms / t.ms);
            let ours = &single.breakdown_ms;
            self.stages_over_thesis = self.thesis.as_ref().map(|t| ratios_to_thesis(ours, &t.stages_ms));
            self.outside_thesis_columns_ms = self.thesis.as_ref().map(|_| ours.outside_thesis_columns());
            self.frame_over_factorization = factorization_ms.map(|f| single.median_ms / f);
            if let Some(edit) = &mut self.edit {
                edit.ratio_to_frame = (single.median_ms > 0.0).then(|| edit.median_ms / single.median_ms);
            }
        }
        if let Some(multi) = &self.multi {
            self.frame_over_factorization_all_threads = factorization_ms.map(|f| multi.median_ms / f);
        }
    }

    /// One report from the same scene's rounds (in round order): the round with the median
    /// single-thread frame, with the multi-threaded run and the reference factorization of their
    /// own median rounds, the first round's peak memory and every round's figures. A round that was
    /// skipped or failed is reported instead. `None` without rounds.
    pub fn from_rounds(mut runs: Vec<SceneReport>) -> Option<Self> {
        if let Some(failed) = runs.iter().position(|r| r.skipped.is_some() || r.error.is_some()) {
            return Some(runs.swap_remove(failed));
        }
        let median_of = |run: &Option<RunReport>| run.as_ref().map_or(f64::NAN, |r| r.median_ms);
        let single_ms: Vec<f64> = runs.iter().map(|r| median_of(&r.single)).collect();
        let multi_ms: Vec<f64> = runs.iter().map(|r| median_of(&r.multi)).collect();
        let factorization_ms: Vec<f64> =
            runs.iter().filter_map(|r| r.factorization.as_ref().map(|f| f.numeric_ms)).collect();
        // The first round's: in later rounds the process also holds what the allocator kept
        // from every scene of the round before.
        let peak_memory_mb = runs.first().and_then(|r| r.peak_memory_mb);
        let every =
            |flag: fn(&SceneReport) -> Option<bool>| runs.iter().map(flag).try_fold(true, |all, f| f.map(|f| all && f));
        let same_output = every(|r| r.same_output_across_threads);
        let same_work = every(|r| r.same_work_across_threads);
        let multi = median_position(&multi_ms).and_then(|i| runs[i].multi.take());
        let factorization = if factorization_ms.len() == runs.len() {
            median_position(&factorization_ms).and_then(|i| runs[i].factorization.take())
        } else {
            None
        };
        let mut report = runs.swap_remove(median_position(&single_ms)?);
        report.multi = multi;
        report.factorization = factorization;
        report.peak_memory_mb = peak_memory_mb;
        report.same_output_across_threads = same_output;
        report.same_work_across_threads = same_work;
        let single_fastest_ms = single_ms.iter().copied().fold(f64::INFINITY, f64::min);
        report.rounds = Some(RoundsReport {
            fastest_thesis_ratio: report.thesis.as_ref().map(|t| single_fastest_ms / t.ms),
            single_ms,
            multi_ms,
            factorization_ms,
            single_fastest_ms,
        });
        report.derive_ratios();
        Some(report)
    }

    /// A progress line.
    pub fn one_line(&self) -> String {
        if let Some(reason) = self.skipped.as_ref().or(self.error.as_ref()) {
            return format!("{}: {reason}", self.name);
        }
        let median = |r: &Option<RunReport>| r.as_ref().map_or(f64::NAN, |r| r.median_ms);
        format!("{}: {:.2} ms (1 thread), {:.2} ms (all threads)", self.name, median(&self.single), median(&self.multi))
    }
}

/// The parallel shot.
#[derive(Clone, Debug, Serialize)]
pub struct ShotReport {
    pub scene: String,
    pub frames: usize,
    pub threads: usize,
    pub single_seconds: f64,
    pub multi_seconds: f64,
    pub single_fps: f64,
    pub multi_fps: f64,
    /// multi_fps / single_fps.
    pub speedup: f64,
    /// Every round's times (`--rounds`); the fields above are their medians.
    pub single_seconds_per_round: Vec<f64>,
    pub multi_seconds_per_round: Vec<f64>,
}

impl ShotReport {
    pub fn new(scene: &str, frames: usize, threads: usize, single: Duration, multi: Duration) -> Self {
        Self::from_seconds(scene, frames, threads, vec![single.as_secs_f64()], vec![multi.as_secs_f64()])
    }

    /// The median of each time over the rounds (`None` without rounds).
    pub fn from_rounds(shots: Vec<ShotReport>) -> Option<Self> {
        let first = shots.first()?;
        let single = shots.iter().map(|s| s.single_seconds).collect();
        let multi = shots.iter().map(|s| s.multi_seconds).collect();
        Some(Self::from_seconds(&first.scene, first.frames, first.threads, single, multi))
    }

    /// The figures of the median round of each time (seconds per round, in round order).
    fn from_seconds(scene: &str, frames: usize, threads: usize, single: Vec<f64>, multi: Vec<f64>) -> Self {
        let (s, m) = (median_value(&single), median_value(&multi));
        let fps = |seconds: f64| if seconds > 0.0 { frames as f64 / seconds } else { 0.0 };
        Self {
            scene: scene.to_string(),
            frames,
            threads,
            single_seconds: s,
            multi_seconds: m,
            single_fps: fps(s),
            multi_fps: fps(m),
            speedup: if m > 0.0 { s / m } else { 0.0 },
            single_seconds_per_round: single,
            multi_seconds_per_round: multi,
        }
    }
}

fn opt(value: Option<f64>, precision: usize) -> String {
    value.map_or_else(|| "–".to_string(), |v| format!("{v:.precision$}"))
}

fn sides(values: [usize; 2]) -> String {
    format!("{}+{}", values[0], values[1])
}

/// Prints the report as text tables.
pub fn print_table(report: &BenchReport) {
    let machine = &report.machine_before;
    let load = |m: &MachineReport| m.load_average.map_or_else(|| "unknown".to_string(), |l| format!("{:.2}", l[0]));
    println!(
        "squish bench{}: {} timed frames per scene, {}1 thread and {} threads ({} cores); load {} → {}{}",
        if machine.quick { " --quick" } else { "" },
        report.frames,
        if report.rounds > 1 {
            format!("{} rounds (medians of the rounds' medians), ", report.rounds)
        } else {
            String::new()
        },
        machine.threads,
        machine.cores,
        load(&report.machine_before),
        load(&report.machine_after),
        if machine.optimized_build { "" } else { "; DEBUG BUILD, times are not meaningful" },
    );
    if machine.quick {
        println!(
            "(--quick: smaller scenes than the thesis' (W, D below), so the ÷ thesis columns are not a comparison; \
             run without --quick for that)"
        );
    }
    println!();
    println!(
        "{:<18} {:>13} {:>11} {:>13} {:>11} {:>9} {:>9} {:>9} {:>7} {:>9} {:>7} {:>8}",
        "scene",
        "W ours",
        "D ours",
        "W thesis",
        "D thesis",
        "1 thread",
        "fastest",
        "N threads",
        "thesis",
        "÷ thesis",
        "factor.",
        "÷ factor."
    );
    println!(
        "{:<18} {:>13} {:>11} {:>13} {:>11} {:>9} {:>9} {:>9} {:>7} {:>9} {:>7} {:>8}",
        "", "", "", "", "", "ms", "ms", "ms", "ms", "", "ms", ""
    );
    for scene in &report.scenes {
        let thesis = scene.thesis.as_ref();
        if let Some(reason) = scene.skipped.as_ref().or(scene.error.as_ref()) {
            println!("{:<18} {}", scene.name, reason);
            continue;
        }
        println!(
            "{:<18} {:>13} {:>11} {:>13} {:>11} {:>9} {:>9} {:>9} {:>7} {:>9} {:>7} {:>8}",
            scene.name,
            sides(scene.working),
            sides(scene.deformable),
            thesis.map_or_else(|| "–".into(), |t| sides(t.working)),
            thesis.map_or_else(|| "–".into(), |t| sides(t.deformable)),
            opt(scene.single.as_ref().map(|r| r.median_ms), 2),
            opt(scene.rounds.as_ref().map(|r| r.single_fastest_ms), 2),
            opt(scene.multi.as_ref().map(|r| r.median_ms), 2),
            opt(thesis.map(|t| t.ms), 1),
            opt(scene.thesis_ratio, 3),
            opt(scene.factorization.as_ref().map(|f| f.numeric_ms), 2),
            opt(scene.frame_over_factorization, 2),
        );
    }
    println!();
    println!(
        "single-thread breakdown of the median frame, % (the thesis' columns, and reg. = choosing and updating the working regions, new regions' analyses included; s. = factorizations, part of p./di./g.; an. = submatrix analyses, part of s.)"
    );
    // The stages that are spans, `other`, then the nested stages (shares of the spans).
    let breakdown_columns =
        || Stage::spans().map(Some).chain([None]).chain(Stage::ALL.into_iter().filter(|s| s.is_nested()).map(Some));
    let header: String = breakdown_columns().map(|s| format!(" {:>6}", s.map_or("other", Stage::label))).collect();
    println!(
        "{:<18}{header} {:>6} {:>8} {:>8} {:>9} {:>5} {:>9}",
        "scene", "fact.", "rows", "recomp.", "symbolic", "sub", "peak MB"
    );
    for scene in &report.scenes {
        let Some(single) = &scene.single else { continue };
        let b = &single.breakdown_percent;
        let shares: String =
            breakdown_columns().map(|s| format!(" {:>6.1}", s.map_or(b.other, |s| b.stages[s]))).collect();
        println!(
            "{:<18}{shares} {:>6} {:>8} {:>8} {:>9} {:>5} {:>9}",
            scene.name,
            single.numeric_factorizations_per_frame,
            single.factorized_rows_per_frame,
            single.recomputed_rows_per_frame,
            format!("{}+{}", single.symbolic_analyses_first_frame, single.symbolic_analyses_timed_frames),
            single.reduced_analyses_timed_frames,
            opt(scene.peak_memory_mb, 0),
        );
    }
    println!(
        "(fact. = numeric factorizations per frame, rows = the rows they ran on, recomp. = the rows whose factor \
         changed and was recomputed (the rest kept its values); symbolic = the regions' analyses in \
         the warm-up frame + in all timed frames; sub = analyses of coupled-row submatrices in all timed frames)"
    );
    println!();
    println!(
        "single thread against the thesis, stage by stage: our ms ÷ the thesis' ms (its % × its total; s. = factorizations, \
         part of p./di./g., table 7.2 only; outside = our setup, reg. and other, ms, not in its columns)"
    );
    let thesis_columns = || Stage::ALL.into_iter().filter(|s| s.in_thesis_tables());
    let header: String = thesis_columns().map(|s| format!(" {:>6}", s.label())).collect();
    println!("{:<18}{header} {:>8}", "scene", "outside");
    for scene in &report.scenes {
        let (Some(ratios), Some(outside)) = (&scene.stages_over_thesis, scene.outside_thesis_columns_ms) else {
            continue;
        };
        let columns: String = thesis_columns().map(|s| format!(" {:>6}", opt(ratios[s], 2))).collect();
        println!("{:<18}{columns} {outside:>8.2}", scene.name);
    }
    println!();
    println!(
        "work of the single-thread median frame (the same on any machine and thread count): spatial queries, \
         triangle tests, rounds, rows solved and factorization Mflops (multiply-adds) over every stage; the \
         separation pass's share; same = the {}-thread run gave the same outputs and work, bit for bit",
        report.machine_before.threads
    );
    println!(
        "{:<18} {:>10} {:>10} {:>6} {:>9} {:>8} {:>10} {:>10} {:>6} {:>6}",
        "scene", "queries", "tri tests", "rounds", "rows", "Mflops", "sep. qu.", "sep. tests", "sep. r", "same"
    );
    for scene in &report.scenes {
        let Some(single) = &scene.single else { continue };
        let total = total_work(&single.work);
        let separation = single.work[Stage::Separation];
        let same = match (scene.same_output_across_threads, scene.same_work_across_threads) {
            (Some(true), Some(true)) => "yes",
            (Some(false), _) => "OUTPUT",
            (_, Some(false)) => "WORK",
            _ => "–",
        };
        println!(
            "{:<18} {:>10} {:>10} {:>6} {:>9} {:>8.1} {:>10} {:>10} {:>6} {:>6}",
            scene.name,
            total.queries,
            total.triangle_tests,
            total.rounds,
            total.rows,
            total.flops as f64 * 1e-6,
            separation.queries,
            separation.triangle_tests,
            separation.rounds,
            same,
        );
    }
    println!();
    println!(
        "edits: a parameter of §5.4–5.5 changed on every deformable object of a frame, recomputed from that frame's \
         contacts and fields (same bits), 1 thread; target ≤ 0.2 of the frame"
    );
    println!("{:<18} {:>14} {:>9} {:>9} {:>10} {:>9}", "scene", "edit", "edit ms", "frame ms", "keeping ms", "÷ frame");
    for scene in &report.scenes {
        let (Some(edit), Some(single)) = (&scene.edit, &scene.single) else { continue };
        println!(
            "{:<18} {:>14} {:>9.3} {:>9.2} {:>10.2} {:>9}",
            scene.name,
            format!("{} {}→{}", edit.parameter, edit.from, edit.to),
            edit.median_ms,
            single.median_ms,
            edit.full_frame_keeping_ms,
            opt(edit.ratio_to_frame, 3),
        );
    }
    for scene in &report.scenes {
        let Some(growth) = &scene.self_contact else { continue };
        println!();
        println!(
            "{}: {} frames of the animation, 1 thread, medians by touching part pairs per frame (part stage = the pairs' own time)",
            scene.name,
            growth.frames.len()
        );
        println!(
            "{:>14} {:>7} {:>9} {:>14} {:>16} {:>12}",
            "touching pairs", "frames", "frame ms", "part stage ms", "articulations ms", "untangle ms"
        );
        for group in &growth.by_touching_pairs {
            println!(
                "{:>14} {:>7} {:>9.1} {:>14.1} {:>16.1} {:>12.1}",
                group.touching_pairs,
                group.frames,
                group.median_ms,
                group.median_part_pairs_ms,
                group.median_articulations_ms,
                group.median_untangle_ms
            );
        }
    }
    if let Some(speedup) = report.automatic_region_speedup {
        println!();
        println!(
            "automatic working regions: press-100k takes ×{speedup:.2} the time of press-100k-automatic (1 thread)"
        );
    }
    if let Some(shot) = &report.shot {
        println!();
        println!(
            "shot: {} frames of {}, frames in parallel: 1 thread {:.2} fps, {} threads {:.2} fps (×{:.2})",
            shot.frames, shot.scene, shot.single_fps, shot.threads, shot.multi_fps, shot.speedup
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_position_takes_the_lower_median_and_handles_empty() {
        assert_eq!(median_position(&[]), None);
        assert_eq!(median_position(&[5.0]), Some(0));
        assert_eq!(median_position(&[3.0, 1.0, 2.0]), Some(2));
        // Even count: the lower of the two middle values.
        assert_eq!(median_position(&[4.0, 1.0, 3.0, 2.0]), Some(3));
        assert_eq!(median_value(&[4.0, 1.0, 3.0, 2.0]), 2.0);
    }

    #[test]
    fn a_failed_or_skipped_round_is_reported_instead_of_a_median() {
        let ok = |ms: f64| {
            let mut r = SceneReport::new("s", None, Vec::new(), 1);
            r.peak_memory_mb = Some(ms);
            r
        };
        let mut failed = SceneReport::new("s", None, Vec::new(), 1);
        failed.error = Some("frame 3: boom".into());
        let report = SceneReport::from_rounds(vec![ok(1.0), failed, ok(2.0)]).expect("a report");
        assert_eq!(report.error.as_deref(), Some("frame 3: boom"));
        let skipped = SceneReport::skipped("s", None, "mesh not found".into());
        let report = SceneReport::from_rounds(vec![skipped]).expect("a report");
        assert_eq!(report.skipped.as_deref(), Some("mesh not found"));
        assert!(SceneReport::from_rounds(Vec::new()).is_none());
    }
}
