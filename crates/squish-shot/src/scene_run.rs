//! A scene file run into an output folder: what `squish run` does and what the Python module's
//! `Scene.run` (and so each of its Ray tasks) does, with the same code.
//!
//! [`RunPlan::new`] checks a [`RunRequest`] against the scene (frames, output folder and format,
//! sequence files) and evaluates the first frame, which fails early on what the scene cannot do;
//! [`RunPlan::run`] computes the frames in parallel, writes each frame's files as it is done
//! ([`crate::outputs`]), then the files holding every frame, the pictures the front end draws,
//! this run's report part `report.A-B.json`, and merges the parts of the folder
//! ([`crate::report_parts`], [`crate::parts`]). Frames that failed and a stop request are not
//! errors of `run`: the [`SceneRun`] holds them, and [`SceneRun::failed_error`] /
//! [`SceneRun::interrupted_error`] give them as [`ShotError`]s once the front end has shown what it
//! shows.

use std::collections::BTreeSet;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use serde_json::json;
use squish::pipeline::OwnedFrame;
use squish_io::Scene;
use squish_io::scene::{OutputFormat, OutputSpec};

use crate::error::{FailedFrames, MissingFile, ShotError, Stopped};
use crate::files::create_dir;
use crate::interrupt::Interrupt;
use crate::outputs::ShotOutputs;
use crate::parts::{Merged, merge_parts};
use crate::quality::{ShotSummary, write_report};
use crate::report_parts::{merge_reports, part_file_name};
use crate::scene_shot::{FileNumbering, SceneShot, file_numbering};
use crate::shot::{ShotOutcome, ShotSettings, ShotSource, run_shot, worker_pool};

/// What to run of a scene and where: what `squish run` reads from its arguments, and what other
/// front ends (the Python module, its Ray tasks) give to run a scene the same way.
#[derive(Clone, Debug, Default)]
pub struct RunRequest {
    /// The frames to compute, a part of the shot: its report is `report.A-B.json` and its files
    /// holding every frame `<object>.A-B.<ext>`. `None`: the scene's frames, as the whole shot.
    pub frames: Option<RangeInclusive<i64>>,
    /// The output folder instead of the scene's `output.dir`.
    pub output_dir: Option<PathBuf>,
    /// The output format instead of the scene's `output.format`.
    pub format: Option<OutputFormat>,
    /// Worker threads (`None`: every core).
    pub threads: Option<usize>,
    /// List missing sequence files rather than failing on them (a dry run).
    pub allow_missing_files: bool,
}

/// Draws the pictures of a shot's kept frames into a folder; returns the files written.
pub type DrawPictures<'a> = dyn Fn(&Path, &ShotOutcome) -> Result<Vec<PathBuf>, ShotError> + Sync + 'a;

/// Pictures of some frames, drawn by the front end once the frames are computed.
pub struct Previews<'a> {
    /// The frames whose meshes are kept for the pictures.
    pub frames: BTreeSet<i64>,
    /// Draws the kept frames (`ShotOutcome::previews`) into the folder given; returns the files
    /// written. Runs on the run's worker pool.
    pub draw: &'a DrawPictures<'a>,
}

/// A scene run checked and ready: its frames, outputs, pool, and its first frame, which checks
/// the whole mapping (unsupported features fail here, before any file is written) and gives the
/// objects' names and file numbering.
pub struct RunPlan<'a> {
    pub scene: &'a Scene,
    pub frames: RangeInclusive<i64>,
    /// `Some` for a part of the shot (see [`RunRequest::frames`]).
    pub part: Option<(i64, i64)>,
    pub output: OutputSpec,
    /// Sequence files missing for the frames.
    pub missing: Vec<MissingFile>,
    pub first: OwnedFrame,
    pub numbering: Vec<FileNumbering>,
    pool: rayon::ThreadPool,
}

/// A finished scene run: the frames computed, the report written, the files holding every frame.
pub struct SceneRun {
    pub outcome: ShotOutcome,
    pub summary: ShotSummary,
    /// The merged `report.json`.
    pub report: PathBuf,
    /// This run's part (`report.A-B.json`).
    pub part_report: PathBuf,
    /// The files holding every frame (glb, gltf, pc2), written when every frame is done.
    pub animated: Vec<PathBuf>,
    /// For a part: the parts of the folder merged into the whole shot's files (once they hold
    /// every frame).
    pub merged: Merged,
    /// Why those files could not be written (the frames and the report are).
    pub animated_error: Option<ShotError>,
    pub previews: Vec<PathBuf>,
    /// True when the output format writes a file per frame (obj, ply).
    pub per_frame_files: bool,
}

impl<'a> RunPlan<'a> {
    /// Checks `request` against `scene` and evaluates the first frame (see [`RunPlan`]).
    pub fn new(scene: &'a Scene, request: &RunRequest) -> Result<Self, ShotError> {
        let frames = request.frames.clone().unwrap_or_else(|| scene.frames());
        let pool = worker_pool(request.threads)?;
        let mut output = scene.output().clone();
        if let Some(dir) = &request.output_dir {
            output.dir = std::path::absolute(dir).unwrap_or_else(|_| dir.clone());
        }
        if let Some(format) = request.format {
            output.format = format;
        }
        let missing: Vec<MissingFile> = scene
            .missing_files(frames.clone())
            .into_iter()
            .map(|(object, frame, path)| MissingFile { object, frame, path })
            .collect();
        if !request.allow_missing_files && !missing.is_empty() {
            return Err(ShotError::MissingSequenceFiles { scene: scene.path().to_path_buf(), missing });
        }
        // A dry run lists missing files rather than failing on them, so it probes the first
        // frame whose files exist.
        let probe = frames.clone().find(|f| !missing.iter().any(|m| m.frame == *f)).unwrap_or(*frames.start());
        let first = SceneShot { scene }.frame(probe)?;
        let numbering = file_numbering(scene, &first);
        let part = request.frames.as_ref().map(|f| (*f.start(), *f.end()));
        Ok(Self { scene, frames, part, output, missing, first, numbering, pool })
    }

    /// Computes the frames on the plan's pool, writing each frame's files as it is done, then the
    /// files holding every frame, the pictures (`previews`), this run's report part and the
    /// merged report. `keep_outputs` keeps every frame's positions in the outcome. Stops
    /// scheduling frames when `interrupt` is requested or writing a frame fails.
    pub fn run(
        &self,
        previews: Option<Previews>,
        keep_outputs: bool,
        interrupt: &Interrupt,
    ) -> Result<SceneRun, ShotError> {
        let (scene, output) = (self.scene, &self.output);
        create_dir(&output.dir)?;
        if output.format.per_frame() {
            for object in &self.first.objects {
                create_dir(&output.object_dir(&object.name))?;
            }
        }
        let settings = ShotSettings {
            frames: self.frames.clone(),
            preview_frames: previews.as_ref().map(|p| p.frames.clone()).unwrap_or_default(),
            keep_outputs,
            label: "squish run".into(),
        };
        let writers = ShotOutputs::new(scene, output, &self.numbering, self.frames.clone(), self.part)?;
        let write =
            |frame: i64, shot: &OwnedFrame, positions: &[Vec<glam::DVec3>]| writers.write_frame(frame, shot, positions);
        let outcome = run_shot(&SceneShot { scene }, &settings, &self.pool, interrupt, &write)?;

        let mut animated = Vec::new();
        let mut animated_error = None;
        let mut merged = Merged::default();
        if !output.format.per_frame() && outcome.complete() {
            // The report is written even when these files cannot be: the frames are done.
            match writers.write_shot() {
                Ok(written) => animated = written,
                Err(e) => animated_error = Some(e),
            }
            // A part completes the shot when the folder's parts hold every frame.
            if self.part.is_some() && animated_error.is_none() {
                match merge_parts(scene, output) {
                    Ok(m) => merged = m,
                    Err(e) => animated_error = Some(e),
                }
            }
        }
        let previews = match &previews {
            Some(previews) => self.pool.install(|| (previews.draw)(&output.dir.join("preview"), &outcome))?,
            None => Vec::new(),
        };
        let scene_json: serde_json::Value = serde_json::from_str(&scene.to_json()?)?;
        let outputs = outputs_json(output, &writers, &self.first, &self.numbering, &animated, &merged, &previews);
        let part_name = part_file_name(*self.frames.start(), *self.frames.end());
        let summary = write_report(&output.dir, &part_name, &scene_json, &outputs, &outcome)?;
        let range = scene.frame_range();
        let report = merge_reports(&output.dir, range.start, range.end)?;
        let part_report = output.dir.join(part_name);
        let per_frame_files = output.format.per_frame();
        Ok(SceneRun {
            outcome,
            summary,
            report,
            part_report,
            animated,
            merged,
            animated_error,
            previews,
            per_frame_files,
        })
    }
}

impl SceneRun {
    /// The error of a run in which frames failed (`None` if none did): how many, the first
    /// error, how many frames are on disk, where the report is, and the frames left to run.
    pub fn failed_error(&self) -> Option<ShotError> {
        let outcome = &self.outcome;
        let first = outcome.failures.first()?;
        Some(ShotError::FramesFailed(Box::new(FailedFrames {
            failed: outcome.failures.len(),
            total: outcome.frames.clone().count(),
            first_frame: first.frame,
            first_error: first.error.to_string(),
            writing_stopped: outcome.failures.iter().any(|f| f.writing),
            written: outcome.records.len(),
            shot_files_missing: !(self.per_frame_files || outcome.complete()),
            report: self.report.clone(),
            left: runs(outcome),
        })))
    }

    /// The error of a run stopped before its last frame (`None` if every frame was computed):
    /// how many frames were done, where the report is, and the frames that finish the shot.
    pub fn interrupted_error(&self) -> Option<ShotError> {
        let outcome = &self.outcome;
        if outcome.complete() {
            return None;
        }
        Some(ShotError::Interrupted(Box::new(Stopped {
            done: outcome.records.len(),
            total: outcome.frames.clone().count(),
            report: self.report.clone(),
            shot_files_missing: !self.per_frame_files,
            missing: runs(outcome),
        })))
    }
}

/// The frames of `outcome` not computed, as inclusive runs.
fn runs(outcome: &ShotOutcome) -> Vec<(i64, i64)> {
    outcome.missing_runs().iter().map(|r| (*r.start(), *r.end())).collect()
}

/// The `outputs` section of the report.
fn outputs_json(
    output: &OutputSpec,
    writers: &ShotOutputs,
    first: &OwnedFrame,
    numbering: &[FileNumbering],
    animated: &[PathBuf],
    merged: &Merged,
    previews: &[PathBuf],
) -> serde_json::Value {
    let objects: Vec<serde_json::Value> = first
        .objects
        .iter()
        .zip(numbering)
        .map(|(o, n)| {
            let files = if output.format.per_frame() {
                output.object_dir(&o.name).join(format!("{{frame:04}}.{}", output.format.extension()))
            } else {
                writers.shot_path(&o.name)
            };
            json!({
                "name": o.name,
                "files": files.display().to_string(),
                "vertices_processed": o.mesh.num_vertices(),
                "vertices_written": n.vertex_count(o.mesh.num_vertices()),
                "note": n.note,
            })
        })
        .collect();
    let paths = |files: &[PathBuf]| files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>();
    let mut outputs = json!({
        "dir": output.dir.display().to_string(),
        "format": output.format.extension(),
        "objects": objects,
        "animated_files": paths(animated),
        "previews": paths(previews),
    });
    if !output.format.per_frame() {
        outputs["merged_files"] = json!(paths(&merged.files));
    }
    outputs
}
