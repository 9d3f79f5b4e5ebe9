//! A shot: a batch of independent frames, computed in parallel.
//!
//! The deformer is time-independent (every frame is computed from scratch), so frames can run
//! in any order on any thread. [`run_shot`] runs a range of frames from a [`ShotSource`] on one
//! rayon pool (the library's own parallel loops run on the same pool, so `--threads N` bounds
//! the whole job), writes each frame's files as soon as it is done, measures its quality
//! figures, and keeps what the report and the pictures need.
//!
//! Determinism: a [`Deformer`] only caches what depends on connectivity, and gives bit-identical
//! results with a fresh or a reused cache, so the output of a frame does not depend on which
//! worker computed it, on the thread count, or on how the range was split between jobs.
//!
//! Deformers (and the quality measure's caches) are reused through a small pool rather than one
//! per OS thread: rayon may run a stolen frame *inside* another frame's parallel loop on the
//! same thread, and two frames must never share one deformer.

use std::collections::{BTreeMap, BTreeSet};
use std::io::IsTerminal;
use std::ops::RangeInclusive;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use glam::DVec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use rayon::prelude::*;
use squish::pipeline::{Deformer, Frame, FrameResult, FrameStats, OwnedFrame};
use squish::{ObjectParams, TriMesh};

use crate::error::ShotError;
use crate::frame_quality::{self, ObjectQuality, PairQuality};
use crate::interrupt::Interrupt;

/// Where frames come from: a scene file, or a procedural animation. Must give the same objects
/// (names, order, vertex counts, triangles) at every frame.
pub trait ShotSource: Sync {
    /// The frame `frame`. Errors name the frame and what is wrong with it.
    fn frame(&self, frame: i64) -> Result<OwnedFrame, ShotError>;
}

/// Writes one frame's results (called on worker threads, once per frame).
pub type FrameWriter<'a> = dyn Fn(i64, &OwnedFrame, &[Vec<DVec3>]) -> Result<(), ShotError> + Sync + 'a;

/// How to run a shot.
#[derive(Clone, Debug)]
pub struct ShotSettings {
    /// The frames to compute (inclusive).
    pub frames: RangeInclusive<i64>,
    /// Frames whose meshes and labels are kept for pictures.
    pub preview_frames: BTreeSet<i64>,
    /// Keep every frame's output positions (for animated files written at the end).
    pub keep_outputs: bool,
    /// Shown before the progress bar.
    pub label: String,
}

/// What the pictures need of a frame: input and output meshes, and per-vertex labels.
#[derive(Clone, Debug)]
pub struct PreviewFrame {
    pub inputs: Vec<TriMesh>,
    pub outputs: Vec<TriMesh>,
    /// Per object: the contact region 𝒞, the deformable region 𝒟 and the radial parameter u
    /// (`None` when the object was not deformed).
    pub contact: Vec<Option<Vec<bool>>>,
    pub deformable: Vec<Option<Vec<bool>>>,
    pub u: Vec<Option<Vec<f64>>>,
    /// Per object: its intersection regions with the other objects (input meshes).
    pub intersection: Vec<Vec<bool>>,
    /// Per object with self-contact: the output's faces that still pass through another of
    /// its faces beyond the rest pose's (drawn red on the output); empty for the others.
    pub self_intersection_left: Vec<Vec<bool>>,
}

impl PreviewFrame {
    /// The pictures' data of a computed frame. Objects with self-contact (articulations or
    /// parts) also get their self-intersecting input faces marked as overlaps (drawn red on the
    /// input): those beyond the rest pose's own, as report.json counts them; and those that are
    /// left on the output.
    pub fn new(shot: &OwnedFrame, result: &FrameResult) -> Self {
        let outputs: Vec<TriMesh> = shot
            .objects
            .iter()
            .zip(&result.positions)
            .map(|(o, p)| TriMesh { positions: p.clone(), triangles: o.mesh.triangles.clone() })
            .collect();
        let mut intersection: Vec<Vec<bool>> = shot
            .objects
            .iter()
            .map(|o| match self_intersections_beyond_rest(&o.mesh, &o.params) {
                Some(faces) => face_vertex_flags(&o.mesh, &faces),
                None => vec![false; o.mesh.num_vertices()],
            })
            .collect();
        let self_intersection_left = shot
            .objects
            .iter()
            .zip(&outputs)
            .map(|(o, out)| {
                self_intersections_beyond_rest(out, &o.params).map_or_else(Vec::new, |f| face_vertex_flags(out, &f))
            })
            .collect();
        for (pair, contact) in shot.pairs.iter().zip(&result.contacts) {
            let Some(contact) = contact else { continue };
            for (side, &object) in pair.objects.iter().enumerate() {
                for (flag, &inside) in intersection[object].iter_mut().zip(contact.sides[side].intersection.inside()) {
                    *flag |= inside;
                }
            }
        }
        let deformations = &result.deformations;
        Self {
            inputs: shot.objects.iter().map(|o| o.mesh.clone()).collect(),
            outputs,
            contact: deformations
                .iter()
                .zip(&result.self_contact)
                .map(|(d, s)| merged_flags(d.as_ref().map(|d| &d.contact), s.as_ref().map(|s| s.contact.clone())))
                .collect(),
            deformable: deformations
                .iter()
                .zip(&result.self_contact)
                .map(|(d, s)| {
                    let moved = s.as_ref().map(|s| s.moved.iter().zip(&s.contact).map(|(&m, &c)| m && !c).collect());
                    merged_flags(d.as_ref().map(|d| &d.deformable), moved)
                })
                .collect(),
            u: deformations.iter().map(|d| d.as_ref().map(|d| d.u.clone())).collect(),
            intersection,
            self_intersection_left,
        }
    }
}

/// The faces of `mesh` (an object's input or output) that pass through another of its faces,
/// for an object with self-contact: beyond the self-intersections of its rest pose when it has
/// one (the asset's own are not the animation's), else all. `None` without self-contact. A
/// picture is not worth failing a frame over: a mesh the test cannot read shows no overlap.
pub fn self_intersections_beyond_rest(mesh: &TriMesh, params: &ObjectParams) -> Option<Vec<u32>> {
    if !has_self_contact(params) {
        return None;
    }
    let faces = match &params.rest_positions {
        Some(rest) if rest.len() == mesh.num_vertices() => {
            let rest = TriMesh { positions: rest.clone(), triangles: mesh.triangles.clone() };
            squish::skinning::RestIntersections::new(&rest).and_then(|r| r.faces_beyond(mesh))
        }
        _ => squish::spatial::self_intersections(mesh).map(|found| found.faces),
    };
    Some(faces.unwrap_or_default())
}

/// True if the object has self-contact to resolve: articulations or parts, and not rigid (as
/// the deformer decides).
pub fn has_self_contact(params: &ObjectParams) -> bool {
    !params.rigid && (!params.self_contact.is_empty() || params.self_contact_parts.is_some())
}

/// Per vertex of `mesh`: a corner of one of `faces`.
pub fn face_vertex_flags(mesh: &TriMesh, faces: &[u32]) -> Vec<bool> {
    let mut flags = vec![false; mesh.num_vertices()];
    for &f in faces {
        if let Some(t) = mesh.triangles.get(f as usize) {
            for &v in t {
                flags[v as usize] = true;
            }
        }
    }
    flags
}

/// Per-vertex flags of the contacts between objects and of the self-contacts (ch. 6), or'ed.
fn merged_flags(between: Option<&Vec<bool>>, own: Option<Vec<bool>>) -> Option<Vec<bool>> {
    match (between, own) {
        (Some(b), Some(mut o)) => {
            for (x, &y) in o.iter_mut().zip(b) {
                *x |= y;
            }
            Some(o)
        }
        (Some(b), None) => Some(b.clone()),
        (None, own) => own,
    }
}

/// The figures of one computed frame.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    pub frame: i64,
    pub stats: FrameStats,
    pub objects: Vec<ObjectQuality>,
    pub pairs: Vec<PairQuality>,
    /// Points that bound the frame's output (extreme vertices along 26 directions per object),
    /// for a camera that frames the whole shot.
    pub support: Vec<DVec3>,
}

/// A frame that failed, and why.
#[derive(Debug)]
pub struct FrameFailure {
    pub frame: i64,
    pub error: ShotError,
    /// True when writing its files failed (the frame was computed): the shot stopped scheduling
    /// frames then, since the next frames would most likely fail to write too (a full disk, a
    /// folder that cannot be written). A frame that cannot be read or deformed does not stop the
    /// shot.
    pub writing: bool,
}

/// The result of [`run_shot`].
#[derive(Debug)]
pub struct ShotOutcome {
    /// The frames asked for.
    pub frames: RangeInclusive<i64>,
    /// Computed frames, in frame order, with their frame-to-frame steps filled in.
    pub records: Vec<FrameRecord>,
    pub previews: BTreeMap<i64, PreviewFrame>,
    /// Output positions of every computed frame (only with [`ShotSettings::keep_outputs`]).
    pub kept: BTreeMap<i64, Vec<Vec<DVec3>>>,
    /// Ctrl-C stopped the shot.
    pub interrupted: bool,
    /// The frames that failed, in frame order (the other frames were computed and written,
    /// unless a write failure stopped the shot: see [`FrameFailure::writing`]).
    pub failures: Vec<FrameFailure>,
    /// Wall-clock time of the whole batch.
    pub wall: Duration,
    pub threads: usize,
}

impl ShotOutcome {
    /// True if every frame asked for was computed.
    pub fn complete(&self) -> bool {
        self.records.len() == self.frames.clone().count()
    }

    /// True when a frame failed.
    pub fn failed(&self) -> bool {
        !self.failures.is_empty()
    }

    /// The frames asked for but not computed, as inclusive runs (to re-run with `--frames`).
    pub fn missing_runs(&self) -> Vec<RangeInclusive<i64>> {
        let done: BTreeSet<i64> = self.records.iter().map(|r| r.frame).collect();
        let mut runs: Vec<RangeInclusive<i64>> = Vec::new();
        for f in self.frames.clone().filter(|f| !done.contains(f)) {
            match runs.last_mut() {
                Some(run) if *run.end() + 1 == f => *run = *run.start()..=f,
                _ => runs.push(f..=f),
            }
        }
        runs
    }
}

/// The worker pool of a job, `threads` wide (`None`: every core). Everything the job computes
/// runs on it — frames, the library's loops inside a frame, pictures — so `--threads` bounds
/// the whole job.
pub fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, ShotError> {
    let threads = match threads {
        Some(0) => return Err(ShotError::NoThreads),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, usize::from),
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| ShotError::ThreadPool { threads, message: e.to_string() })
}

/// One frame's end.
enum FrameOutcome {
    Done(Box<FrameDone>),
    Skipped,
    Failed(ShotError, Phase),
}

/// Where a frame failed: before its files were written (reading or deforming its meshes), or
/// while writing them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Compute,
    Write,
}

struct FrameDone {
    record: FrameRecord,
    preview: Option<PreviewFrame>,
    kept: Option<Vec<Vec<DVec3>>>,
}

/// Runs `settings.frames` of `source` in parallel on `pool` (see [`worker_pool`]); `write`
/// writes each frame's files. A frame that cannot be read or deformed is recorded and the others
/// go on; a frame whose files cannot be written, or Ctrl-C, stops the scheduling of frames (the
/// frames in progress finish and are written). The outcome says what happened.
pub fn run_shot(
    source: &dyn ShotSource,
    settings: &ShotSettings,
    pool: &rayon::ThreadPool,
    interrupt: &Interrupt,
    write: &FrameWriter,
) -> Result<ShotOutcome, ShotError> {
    let threads = pool.current_num_threads();
    let frames: Vec<i64> = settings.frames.clone().collect();
    let progress = progress_bar(frames.len() as u64, &settings.label);
    let workers: Mutex<Vec<Worker>> = Mutex::new(Vec::new());
    let continuity = Continuity::default();
    let write_failed = AtomicBool::new(false);
    let start = Instant::now();

    let outcomes: Vec<FrameOutcome> = pool.install(|| {
        frames
            .par_iter()
            .map(|&f| {
                if interrupt.requested() || write_failed.load(Ordering::SeqCst) {
                    return FrameOutcome::Skipped;
                }
                let mut worker = workers.lock().ok().and_then(|mut pool| pool.pop()).unwrap_or_default();
                let result = compute_frame(source, f, &mut worker, settings, &continuity, write);
                if let Ok(mut pool) = workers.lock() {
                    pool.push(worker);
                }
                match result {
                    Ok(done) => {
                        progress.inc(1);
                        FrameOutcome::Done(Box::new(done))
                    }
                    Err((error, phase)) => {
                        if phase == Phase::Write {
                            write_failed.store(true, Ordering::SeqCst);
                        }
                        progress.inc(1);
                        FrameOutcome::Failed(error, phase)
                    }
                }
            })
            .collect()
    });
    let wall = start.elapsed();
    progress.finish_and_clear();

    let mut outcome = ShotOutcome {
        frames: settings.frames.clone(),
        records: Vec::new(),
        previews: BTreeMap::new(),
        kept: BTreeMap::new(),
        interrupted: interrupt.requested(),
        failures: Vec::new(),
        wall,
        threads,
    };
    for (&frame, result) in frames.iter().zip(outcomes) {
        match result {
            FrameOutcome::Done(done) => {
                let FrameDone { record, preview, kept } = *done;
                if let Some(p) = preview {
                    outcome.previews.insert(frame, p);
                }
                if let Some(k) = kept {
                    outcome.kept.insert(frame, k);
                }
                outcome.records.push(record);
            }
            FrameOutcome::Failed(error, phase) => {
                outcome.failures.push(FrameFailure { frame, error, writing: phase == Phase::Write });
            }
            FrameOutcome::Skipped => {}
        }
    }
    continuity.fill(&mut outcome.records);
    Ok(outcome)
}

/// What a frame in progress owns: a deformer, caching connectivity-only data (and its quality
/// pass's trees) across the frames it computes.
#[derive(Default)]
struct Worker {
    deformer: Deformer,
}

fn compute_frame(
    source: &dyn ShotSource,
    f: i64,
    worker: &mut Worker,
    settings: &ShotSettings,
    continuity: &Continuity,
    write: &FrameWriter,
) -> Result<FrameDone, (ShotError, Phase)> {
    let shot = source.frame(f).map_err(|e| (e, Phase::Compute))?;
    let frame = shot.frame();
    let result = worker
        .deformer
        .deform(&frame)
        .map_err(|error| (ShotError::Frame { frame: f, error: Box::new(error) }, Phase::Compute))?;
    write(f, &shot, &result.positions).map_err(|e| (e, Phase::Write))?;
    let record = frame_record(f, &frame, &result);
    let preview = settings.preview_frames.contains(&f).then(|| PreviewFrame::new(&shot, &result));
    let kept = settings.keep_outputs.then(|| result.positions.clone());
    let inputs = shot.objects.into_iter().map(|o| o.mesh.positions).collect();
    continuity.add(f, inputs, result.positions);
    Ok(FrameDone { record, preview, kept })
}

/// The figures of computed frame `frame` (its frame-to-frame steps, which need its neighbours,
/// are left unset).
pub fn frame_record(frame: i64, shot: &Frame, result: &FrameResult) -> FrameRecord {
    let (objects, pairs) = frame_quality::measure(shot, result);
    let support = result.positions.iter().flat_map(|p| support_points(p)).collect();
    FrameRecord { frame, stats: result.stats.clone(), objects, pairs, support }
}

/// The vertices farthest along the 26 directions of a 3 × 3 × 3 stencil (axes, edge and corner
/// diagonals): a few points whose projections bound the mesh's from any usual viewpoint.
fn support_points(positions: &[DVec3]) -> Vec<DVec3> {
    let mut best: Vec<(f64, DVec3)> = Vec::with_capacity(26);
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                if (x, y, z) == (0, 0, 0) {
                    continue;
                }
                let d = DVec3::new(f64::from(x), f64::from(y), f64::from(z));
                let mut top = (f64::NEG_INFINITY, DVec3::ZERO);
                for &p in positions {
                    let s = p.dot(d);
                    if s > top.0 {
                        top = (s, p);
                    }
                }
                if top.0.is_finite() {
                    best.push(top);
                }
            }
        }
    }
    best.into_iter().map(|(_, p)| p).collect()
}

/// A progress bar with frames per second and time left, on stderr; hidden when stderr is not
/// a terminal (logs of farm jobs get the one-line summary instead).
fn progress_bar(len: u64, label: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{prefix} [{bar:32}] {pos}/{len} frames  {fps}  {eta} left  ({elapsed})")
    {
        let fps = |state: &ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = write!(w, "{:.1} frames/s", state.per_sec());
        };
        bar.set_style(style.with_key("fps", fps).progress_chars("=> "));
    }
    bar.set_prefix(label.to_string());
    bar.tick();
    bar
}

/// Frame-to-frame steps: the largest vertex displacement of each object between the outputs
/// (and between the inputs) of consecutive frames.
///
/// Positions are kept only until both neighbours of a frame are done: rayon hands each worker a
/// contiguous block of frames, so only the frames at the blocks' ends wait, and memory stays
/// bounded whatever the length of the shot.
#[derive(Default)]
struct Continuity {
    state: Mutex<ContinuityState>,
}

/// Per object, the input and output positions of a frame.
struct FramePositions {
    inputs: Vec<Vec<DVec3>>,
    outputs: Vec<Vec<DVec3>>,
}

#[derive(Default)]
struct ContinuityState {
    /// Computed frames whose steps to a neighbour are not all known yet.
    waiting: BTreeMap<i64, FramePositions>,
    /// Steps into a frame from the previous one, per object: (output step, input step).
    steps: BTreeMap<i64, Vec<Option<(f64, f64)>>>,
    /// Every frame added.
    done: BTreeSet<i64>,
}

impl Continuity {
    fn add(&self, frame: i64, inputs: Vec<Vec<DVec3>>, outputs: Vec<Vec<DVec3>>) {
        let Ok(mut state) = self.state.lock() else { return };
        state.waiting.insert(frame, FramePositions { inputs, outputs });
        state.done.insert(frame);
        for (a, b) in [(frame - 1, frame), (frame, frame + 1)] {
            if let (Some(pa), Some(pb)) = (state.waiting.get(&a), state.waiting.get(&b)) {
                let steps = largest_steps(pa, pb);
                state.steps.insert(b, steps);
            }
        }
        // A frame is no longer needed once the steps on both its sides are known; a neighbour
        // that is never computed (outside the range, interrupted) keeps it until the end, which
        // is a handful of frames.
        for f in [frame - 1, frame, frame + 1] {
            let before_known = state.steps.contains_key(&f);
            let after_known = state.steps.contains_key(&(f + 1));
            if before_known && after_known {
                state.waiting.remove(&f);
            }
        }
    }

    /// Writes the steps into the records; a frame whose previous frame was not computed (the
    /// first of the range, or after a gap) has none.
    fn fill(&self, records: &mut [FrameRecord]) {
        let Ok(state) = self.state.lock() else { return };
        for record in records {
            let Some(steps) = state.steps.get(&record.frame) else { continue };
            for (object, step) in record.objects.iter_mut().zip(steps) {
                if let Some((output, input)) = *step {
                    object.set_steps(output, input);
                }
            }
        }
    }
}

/// Per object: the largest vertex displacement from `a` to `b` of the outputs and of the inputs
/// (`None` if the vertex counts differ).
fn largest_steps(a: &FramePositions, b: &FramePositions) -> Vec<Option<(f64, f64)>> {
    let largest = |p: &[DVec3], q: &[DVec3]| -> Option<f64> {
        (p.len() == q.len()).then(|| p.iter().zip(q).map(|(x, y)| (*x - *y).length()).fold(0.0, f64::max))
    };
    a.outputs
        .iter()
        .zip(&b.outputs)
        .zip(a.inputs.iter().zip(&b.inputs))
        .map(|((oa, ob), (ia, ib))| Some((largest(oa, ob)?, largest(ia, ib)?)))
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    fn positions(x: f64) -> Vec<Vec<DVec3>> {
        vec![vec![DVec3::new(x, 0.0, 0.0), DVec3::ZERO]]
    }

    #[test]
    fn steps_are_known_for_frames_whose_previous_frame_was_computed() {
        let continuity = Continuity::default();
        // Out of order, with a gap at frame 4.
        for f in [3, 1, 2, 5, 6] {
            continuity.add(f, positions(f as f64), positions(2.0 * f as f64));
        }
        let state = continuity.state.lock().unwrap();
        assert_eq!(state.steps.keys().copied().collect::<Vec<_>>(), vec![2, 3, 6]);
        assert_eq!(state.steps[&2][0], Some((2.0, 1.0)));
        // Frames with both steps known are dropped: 2 only (1 has no previous step, 3 and 5
        // border the gap, 6 is the last).
        assert_eq!(state.waiting.keys().copied().collect::<Vec<_>>(), vec![1, 3, 5, 6]);
    }

    #[test]
    fn missing_runs_group_consecutive_frames() {
        let record = |frame| FrameRecord {
            frame,
            stats: FrameStats::default(),
            objects: Vec::new(),
            pairs: Vec::new(),
            support: Vec::new(),
        };
        let outcome = ShotOutcome {
            frames: 1..=10,
            records: [1, 2, 5, 6, 9].into_iter().map(record).collect(),
            previews: BTreeMap::new(),
            kept: BTreeMap::new(),
            interrupted: true,
            failures: Vec::new(),
            wall: Duration::ZERO,
            threads: 1,
        };
        assert_eq!(outcome.missing_runs(), vec![3..=4, 7..=8, 10..=10]);
        assert!(!outcome.complete());
    }
}
