//! `squish run SCENE.toml`: every frame of an animated scene, in parallel, with outputs in the
//! input files' vertex order, a report (`report.json`, `quality.svg`, `quality.png`) and
//! optional previews.
//!
//! Frames are independent, so a shot can be split over machines with `--frames A:B`: the files
//! of a frame are the same bit for bit whatever the split and the thread count, each part
//! writes its report as `report.A-B.json` and `report.json` merges the parts present
//! (`report_parts`). Results are written into copies of the source files where the formats
//! match (`shot_outputs`). Ctrl-C stops cleanly (see `interrupt`): frames in progress finish,
//! the report covers the frames done and lists the missing ones for a re-run.

use std::collections::BTreeSet;
use std::ops::RangeInclusive;
use std::path::PathBuf;

use clap::Args;
use serde_json::json;
use squish_io::Scene;
use squish_io::scene::{MeshSource, OutputFormat, OutputSpec};

use crate::console::{print_warnings, say};
use crate::error::CliError;
use crate::input::create_dir;
use crate::interrupt::{self, Interrupt};
use crate::preview::{
    CameraPlacement, ColorMode, PictureArgs, PictureSettings, SceneDefaults, UpAxis, preview_frames, write_previews,
};
use crate::quality::{ShotSummary, write_report};
use crate::report_parts::{merge_reports, part_file_name};
use crate::scene_shot::{FileNumbering, SceneShot, file_numbering};
use crate::shot::{ShotOutcome, ShotSettings, ShotSource, run_shot, worker_pool};
use crate::shot_outputs::ShotOutputs;
use squish::pipeline::OwnedFrame;

#[derive(Args, Debug)]
pub struct RunArgs {
    /// The scene file (TOML; see docs/scene-format.md).
    pub scene: PathBuf,
    /// Output directory (default: the scene's `output.dir`, relative to the scene file).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Frames to compute: A:B (inclusive), A, A: or :B. Default: the scene's frames.
    #[arg(long, value_name = "A:B")]
    pub frames: Option<String>,
    /// Worker threads for everything (frames and the work inside a frame). Default: all cores.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Write PNG previews to DIR/preview: `--preview` alone renders the first, middle and last
    /// frames; `--preview=1,12,20:24` renders those.
    #[arg(long, value_name = "FRAMES", num_args = 0..=1, require_equals = true, default_missing_value = "auto")]
    pub preview: Option<String>,
    /// Colouring of the previews' output meshes.
    #[arg(long, value_enum, default_value_t = ColorMode::Deformable)]
    pub color: ColorMode,
    #[command(flatten)]
    pub pictures: PictureArgs,
    /// Output format, instead of the scene's `output.format`: obj or ply (a file per frame),
    /// glb or gltf (one animated file per object), pc2 (one point cache per object).
    #[arg(long, value_enum)]
    pub format: Option<RunFormat>,
    /// Check the scene and list objects, pairs, frames, outputs and missing sequence files,
    /// without computing anything.
    #[arg(long)]
    pub dry_run: bool,
    /// Exit with 1 (after writing everything) when a frame has a warning: a contact zone left
    /// empty, a mesh inside another, a reduced parameter, an open mesh without bulge, or a
    /// penetration deeper than 10% of the input's left.
    #[arg(long)]
    pub strict: bool,
}

/// `--format` of `squish run`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RunFormat {
    Obj,
    Ply,
    Glb,
    Gltf,
    Pc2,
}

impl From<RunFormat> for OutputFormat {
    fn from(f: RunFormat) -> Self {
        match f {
            RunFormat::Obj => Self::Obj,
            RunFormat::Ply => Self::Ply,
            RunFormat::Glb => Self::Glb,
            RunFormat::Gltf => Self::Gltf,
            RunFormat::Pc2 => Self::Pc2,
        }
    }
}

/// A clear error for a mesh given where a scene file is expected (a common first try).
fn check_is_scene_file(path: &std::path::Path) -> Result<(), CliError> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let gltf = ext == "glb"
        || ext == "gltf"
        || std::fs::File::open(path).ok().and_then(|mut f| {
            let mut magic = [0u8; 4];
            std::io::Read::read_exact(&mut f, &mut magic).ok().map(|_| &magic == b"glTF")
        }) == Some(true);
    if gltf {
        return Err(CliError::input(format!(
            "{} is a glTF file, not a scene file: use `squish deform A B` for one frame, or write a scene file (docs/scene-format.md) whose object reads it with mesh = {{ file = \"{}\" }}",
            path.display(),
            path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned())
        )));
    }
    if matches!(ext.as_str(), "obj" | "ply") {
        return Err(CliError::input(format!(
            "{} is a mesh, not a scene file: use `squish deform A B` for one frame, or write a scene file (docs/scene-format.md)",
            path.display()
        )));
    }
    Ok(())
}

pub fn run(args: &RunArgs) -> Result<(), CliError> {
    check_is_scene_file(&args.scene)?;
    let scene = Scene::load(&args.scene)?;
    let frames = match &args.frames {
        Some(text) => Some(
            squish_io::parse_frame_selection(text, &scene.frame_range())
                .map_err(|e| CliError::input(format!("{}: {e}", args.scene.display())))?,
        ),
        None => None,
    };
    let request = RunRequest {
        frames,
        output_dir: args.output.clone(),
        format: args.format.map(OutputFormat::from),
        threads: args.threads,
        allow_missing_files: args.dry_run,
    };
    let plan = RunPlan::new(&scene, &request)?;
    if args.dry_run {
        print_dry_run(&scene, &plan);
        return Ok(());
    }
    let previews = match &args.preview {
        Some(text) => {
            let frames = preview_frames(text, &plan.frames)?;
            Some((frames, args.pictures.settings(args.color, &scene_defaults(&scene), any_gltf(&scene))))
        }
        None => None,
    };
    let mut run = plan.run(previews, false, interrupt::install())?;
    let output = &plan.output;
    if let Some(error) = run.animated_error.take() {
        return Err(error);
    }
    if let Some(error) = run.failed_error() {
        print_failures(&run.outcome);
        print_shot_warnings(&run.outcome);
        for articulation in &run.summary.articulations {
            eprintln!("  {}", articulation.line());
        }
        for object in &run.summary.self_contact {
            eprintln!("  {}", object.line());
        }
        return Err(error);
    }
    if let Some(error) = run.interrupted_error() {
        return Err(error);
    }
    say!("{}", run.summary.one_line());
    let warnings = print_shot_warnings(&run.outcome);
    for articulation in &run.summary.articulations {
        say!("  {}", articulation.line());
    }
    for object in &run.summary.self_contact {
        say!("  {}", object.line());
    }
    for tight in &run.summary.tight_regions {
        say!("  {}", tight.line());
    }
    say!("results: {} ({}), report: {}", output.dir.display(), output.format.extension(), run.report.display());
    if !run.previews.is_empty() {
        say!("previews: {} pictures in {}", run.previews.len(), output.dir.join("preview").display());
    }
    if args.strict && warnings > 0 {
        return Err(CliError::strict(warnings));
    }
    Ok(())
}

/// What to run of a scene and where: what `squish run` reads from its arguments, and what other
/// front ends (the Python module, its Ray tasks) give to run a scene the same way.
#[derive(Clone, Debug, Default)]
pub struct RunRequest {
    /// The frames to compute, a part of the shot (`--frames`): its report is
    /// `report.A-B.json` and its files holding every frame `<object>.A-B.<ext>`. `None`: the
    /// scene's frames, as the whole shot.
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

/// A scene run checked and ready: its frames, outputs, pool, and its first frame, which checks
/// the whole mapping (unsupported features fail here, before any file is written) and gives the
/// objects' names and file numbering.
pub struct RunPlan<'a> {
    pub scene: &'a Scene,
    pub frames: RangeInclusive<i64>,
    /// `Some` for a part of the shot (see [`RunRequest::frames`]).
    pub part: Option<(i64, i64)>,
    pub output: OutputSpec,
    /// Sequence files missing for the frames: (object, frame, expected path).
    pub missing: Vec<(String, i64, PathBuf)>,
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
    /// Why those files could not be written (the frames and the report are).
    pub animated_error: Option<CliError>,
    pub previews: Vec<PathBuf>,
    /// True when the output format writes a file per frame (obj, ply).
    pub per_frame_files: bool,
}

impl<'a> RunPlan<'a> {
    /// Checks `request` against `scene` and evaluates the first frame (see [`RunPlan`]).
    pub fn new(scene: &'a Scene, request: &RunRequest) -> Result<Self, CliError> {
        let frames = request.frames.clone().unwrap_or_else(|| scene.frames());
        let pool = worker_pool(request.threads)?;
        let mut output = scene.output().clone();
        if let Some(dir) = &request.output_dir {
            output.dir = std::path::absolute(dir).unwrap_or_else(|_| dir.clone());
        }
        if let Some(format) = request.format {
            output.format = format;
        }
        let missing = scene.missing_files(frames.clone());
        if !request.allow_missing_files && !missing.is_empty() {
            return Err(missing_error(scene.path(), &missing));
        }
        // A dry run lists missing files rather than failing on them, so it probes the first
        // frame whose files exist.
        let probe = frames.clone().find(|f| !missing.iter().any(|m| m.1 == *f)).unwrap_or(*frames.start());
        let first = SceneShot { scene }.frame(probe)?;
        let numbering = file_numbering(scene, &first);
        let part = request.frames.as_ref().map(|f| (*f.start(), *f.end()));
        Ok(Self { scene, frames, part, output, missing, first, numbering, pool })
    }

    /// Computes the frames on the plan's pool, writing each frame's files as it is done, then the
    /// files holding every frame, the previews (`previews`: the frames and how to draw them), this
    /// run's report part and the merged report. `keep_outputs` keeps every frame's positions in
    /// the outcome. Stops scheduling frames when `interrupt` is requested or a frame fails.
    pub fn run(
        &self,
        previews: Option<(BTreeSet<i64>, PictureSettings)>,
        keep_outputs: bool,
        interrupt: &Interrupt,
    ) -> Result<SceneRun, CliError> {
        let (scene, output) = (self.scene, &self.output);
        create_dir(&output.dir)?;
        if output.format.per_frame() {
            for object in &self.first.objects {
                create_dir(&output.object_dir(&object.name))?;
            }
        }
        let (preview_frames, pictures) = previews.unzip();
        let settings = ShotSettings {
            frames: self.frames.clone(),
            preview_frames: preview_frames.unwrap_or_default(),
            keep_outputs: keep_outputs || !output.format.per_frame(),
            label: "squish run".into(),
        };
        let writers = ShotOutputs::new(scene, output, &self.numbering, self.part)?;
        let write =
            |frame: i64, shot: &OwnedFrame, positions: &[Vec<glam::DVec3>]| writers.write_frame(frame, shot, positions);
        let outcome = run_shot(&SceneShot { scene }, &settings, &self.pool, interrupt, &write)?;

        let mut animated = Vec::new();
        let mut animated_error = None;
        if !output.format.per_frame() && outcome.complete() {
            // The report is written even when these files cannot be: the frames are done.
            match writers.write_shot(&self.first, &outcome) {
                Ok(written) => animated = written,
                Err(e) => animated_error = Some(e),
            }
        }
        let previews = match &pictures {
            Some(pictures) => self.pool.install(|| write_previews(&output.dir.join("preview"), &outcome, pictures))?.0,
            None => Vec::new(),
        };
        let scene_json: serde_json::Value = serde_json::from_str(&scene.to_json()?)?;
        let outputs = outputs_json(output, &writers, &self.first, &self.numbering, &animated, &previews);
        let part_name = part_file_name(*self.frames.start(), *self.frames.end());
        let summary = write_report(&output.dir, &part_name, &scene_json, &outputs, &outcome)?;
        let range = scene.frame_range();
        let report = merge_reports(&output.dir, range.start, range.end)?;
        let part_report = output.dir.join(part_name);
        let per_frame_files = output.format.per_frame();
        Ok(SceneRun { outcome, summary, report, part_report, animated, animated_error, previews, per_frame_files })
    }
}

impl SceneRun {
    /// The error of a run in which frames failed (`None` if none did): how many, the first
    /// error, how many frames are on disk, where the report is, and the `--frames` to re-run.
    pub fn failed_error(&self) -> Option<CliError> {
        let outcome = &self.outcome;
        let first = outcome.failures.first()?;
        let total = outcome.frames.clone().count();
        let failed = outcome.failures.len();
        let done = outcome.records.len();
        let stopped = if outcome.failures.iter().any(|f| f.writing) {
            "; writing a frame failed, so no more frames were started"
        } else {
            ""
        };
        let animated = if self.per_frame_files || outcome.complete() {
            ""
        } else {
            "; the files holding every frame need every frame and were not written"
        };
        let reruns: Vec<String> =
            outcome.missing_runs().iter().map(|r| format!("--frames {}:{}", r.start(), r.end())).collect();
        Some(CliError::failure(format!(
            "{failed} of {total} frame{} failed (frame {}: {}){stopped}; {done} frame{} written{animated} (report: {}); once fixed, run the frames left: {}",
            plural(total),
            first.frame,
            first.error,
            plural(done),
            self.report.display(),
            reruns.join(", ")
        )))
    }

    /// The error of a run stopped before its last frame (`None` if every frame was computed):
    /// how many frames were done, where the report is, and the `--frames` that finish the shot.
    pub fn interrupted_error(&self) -> Option<CliError> {
        let outcome = &self.outcome;
        if outcome.complete() {
            return None;
        }
        let missing: Vec<String> =
            outcome.missing_runs().iter().map(|r| format!("--frames {}:{}", r.start(), r.end())).collect();
        let glb = if self.per_frame_files {
            ""
        } else {
            "; the files holding every frame need every frame and were not written"
        };
        Some(CliError::interrupted(format!(
            "interrupted: {} of {} frames done (report: {}){glb}; to finish, run the missing frames: {}",
            outcome.records.len(),
            outcome.frames.clone().count(),
            self.report.display(),
            missing.join(", ")
        )))
    }
}

/// "s" for a count other than one.
fn plural(count: usize) -> &'static str {
    if count == 1 { "" } else { "s" }
}

/// Prints every failed frame's error (the first [`SHOWN_WARNINGS`]) on stderr.
fn print_failures(outcome: &ShotOutcome) {
    for failure in outcome.failures.iter().take(SHOWN_WARNINGS) {
        eprintln!("frame {} failed: {}", failure.frame, failure.error);
    }
    if outcome.failures.len() > SHOWN_WARNINGS {
        eprintln!(
            "… and {} more failed frames (report.json, run.failed_frames)",
            outcome.failures.len() - SHOWN_WARNINGS
        );
    }
}

/// Prints the shot's warnings, the first [`SHOWN_WARNINGS`] in full; returns how many there are.
fn print_shot_warnings(outcome: &ShotOutcome) -> usize {
    let mut count = 0;
    for record in &outcome.records {
        let shown = SHOWN_WARNINGS.saturating_sub(count).min(record.stats.warnings.len());
        print_warnings(Some(record.frame), &record.stats.warnings[..shown]);
        count += record.stats.warnings.len();
    }
    if count > SHOWN_WARNINGS {
        say!("warning: … and {} more (report.json, frames[].stats.warnings)", count - SHOWN_WARNINGS);
    }
    count
}

/// Warnings of a shot printed in full.
const SHOWN_WARNINGS: usize = 10;

/// The error for missing sequence files: the first few, with the frame and the expected path.
fn missing_error(scene: &std::path::Path, missing: &[(String, i64, PathBuf)]) -> CliError {
    let list: Vec<String> = missing
        .iter()
        .take(5)
        .map(|(object, frame, path)| format!("  object \"{object}\", frame {frame}: {}", path.display()))
        .collect();
    let more = if missing.len() > 5 { format!("\n  … and {} more", missing.len() - 5) } else { String::new() };
    let (s, are) = if missing.len() == 1 { ("", "is") } else { ("s", "are") };
    CliError::input(format!(
        "{}: {} file{s} of mesh sequences {are} missing:\n{}{more}\nexport those frames, or choose other frames with --frames",
        scene.display(),
        missing.len(),
        list.join("\n")
    ))
}

/// Picture defaults from the scene's `preview` key.
fn scene_defaults(scene: &Scene) -> SceneDefaults {
    let Some(spec) = &scene.description().preview else { return SceneDefaults::default() };
    SceneDefaults {
        up: spec.up.map(|u| match u {
            squish_io::scene::UpAxisName::Y => UpAxis::Y,
            squish_io::scene::UpAxisName::Z => UpAxis::Z,
        }),
        size: spec.size.map(|[w, h]| (w, h)),
        camera: spec.camera.map(|c| CameraPlacement {
            eye: glam::DVec3::from_array(c.eye),
            target: glam::DVec3::from_array(c.target),
            up: c.up.map(glam::DVec3::from_array),
            fov_deg: c.fov,
        }),
    }
}

/// True if an object of the scene is read from glTF (y-up by definition).
fn any_gltf(scene: &Scene) -> bool {
    scene.description().objects.iter().any(|o| matches!(o.mesh, MeshSource::Gltf(_)))
}

/// The `outputs` section of the report.
fn outputs_json(
    output: &OutputSpec,
    writers: &ShotOutputs,
    first: &OwnedFrame,
    numbering: &[FileNumbering],
    animated: &[PathBuf],
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
    json!({
        "dir": output.dir.display().to_string(),
        "format": output.format.extension(),
        "objects": objects,
        "animated_files": animated.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "previews": previews.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    })
}

fn print_dry_run(scene: &Scene, plan: &RunPlan) {
    let RunPlan { frames, output, first, numbering, missing, .. } = plan;
    let description = scene.description();
    let range = scene.frame_range();
    say!("scene: {}", scene.path().display());
    say!(
        "frames: {}:{} ({} frame{}) of the scene's {}:{} at {} fps",
        frames.start(),
        frames.end(),
        frames.clone().count(),
        if frames.clone().count() == 1 { "" } else { "s" },
        range.start,
        range.end,
        range.fps
    );
    say!("objects:");
    for ((spec, object), n) in description.objects.iter().zip(&first.objects).zip(numbering) {
        let source = match &spec.mesh {
            MeshSource::File { file, .. } => format!("file {}", file.display()),
            MeshSource::Sequence { pattern, .. } => format!("sequence {}", pattern.display()),
            MeshSource::Gltf(g) => format!("glTF {}", g.file.display()),
        };
        let kind =
            if object.params.rigid { "rigid".to_string() } else { format!("stiffness {}", object.params.stiffness) };
        let vertices = object.mesh.num_vertices();
        let written = n.vertex_count(vertices);
        let numbering = if written == vertices { String::new() } else { format!(", {written} in the file") };
        say!(
            "  {:<16} {} vertices{numbering}, {} triangles, {kind}; {source}",
            spec.name,
            vertices,
            object.mesh.num_triangles()
        );
        if let Some(note) = &n.note {
            say!("  {:<16} note: {note}", "");
        }
        for a in &object.params.self_contact {
            let direction = match a.params.direction {
                None => "direction from the joints".to_string(),
                Some(d) => format!("direction [{}, {}, {}]", d.x, d.y, d.z),
            };
            say!(
                "  {:<16} self-contact \"{}\": regions of {} and {} vertices, {direction}",
                "",
                a.name,
                a.regions[0].len(),
                a.regions[1].len()
            );
        }
    }
    say!("pairs:");
    if description.pairs.is_empty() {
        say!("  none (the objects are copied unchanged)");
    }
    for pair in &first.pairs {
        let [a, b] = pair.objects.map(|i| first.objects[i].name.as_str());
        say!("  {a} / {b}: {} contact", pair.params.contact_method.name());
    }
    let ext = output.format.extension();
    match output.format {
        OutputFormat::Glb | OutputFormat::Gltf | OutputFormat::Pc2 => {
            say!("outputs: {}/<object>.{ext} (one file per object holding every frame)", output.dir.display())
        }
        _ => say!(
            "outputs: {} to {} per object, e.g. {}",
            squish_io::scene::format_frame(*frames.start(), 4) + "." + ext,
            squish_io::scene::format_frame(*frames.end(), 4) + "." + ext,
            output.path_for(&first.objects[0].name, *frames.start()).display()
        ),
    }
    say!("report: {}", output.dir.join("report.json").display());
    if missing.is_empty() {
        say!("missing sequence files: none");
    } else {
        say!("missing sequence files: {}", missing.len());
        for (object, frame, path) in missing {
            say!("  object \"{object}\", frame {frame}: {}", path.display());
        }
    }
}
