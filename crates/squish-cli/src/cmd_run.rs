//! `squish run SCENE.toml`: every frame of an animated scene, in parallel, with outputs in the
//! input files' vertex order, a report (`report.json`, `quality.svg`, `quality.png`) and
//! optional previews.
//!
//! The run itself is [`squish_shot::scene_run`], which the Python module shares: frames are
//! independent, so a shot can be split over machines with `--frames A:B` (the files of a frame
//! are the same bit for bit whatever the split and the thread count; the parts' reports and
//! files holding every frame are merged). This module reads the arguments, draws the pictures
//! and prints. Ctrl-C, SIGTERM and SIGHUP stop cleanly (see `signals`): frames in progress
//! finish, the report covers the frames done and lists the missing ones for a re-run.

use std::path::PathBuf;

use clap::Args;
use squish_io::Scene;
use squish_io::scene::{MeshSource, OutputFormat};
use squish_shot::ShotError;
use squish_shot::scene_run::{Previews, RunPlan, RunRequest};
use squish_shot::shot::{ShotOutcome, has_self_contact};

use crate::console::{print_warnings, say};
use crate::error::CliError;
use crate::preview::{CameraPlacement, ColorMode, PictureArgs, SceneDefaults, UpAxis, preview_frames, write_previews};
use crate::signals;

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
                .map_err(|error| ShotError::Frames { scene: args.scene.clone(), error })?,
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
    let pictures = args.pictures.settings(args.color, &scene_defaults(&scene), any_gltf(&scene));
    let draw = |dir: &std::path::Path, outcome: &ShotOutcome| -> Result<Vec<PathBuf>, ShotError> {
        write_previews(dir, outcome, &pictures).map(|(files, _)| files)
    };
    let previews = match &args.preview {
        Some(text) => Some(Previews { frames: preview_frames(text, &plan.frames)?, draw: &draw }),
        None => None,
    };
    let mut run = plan.run(previews, false, signals::install())?;
    let output = &plan.output;
    if let Some(error) = run.animated_error.take() {
        return Err(error.into());
    }
    if let Some(error) = run.failed_error() {
        print_failures(&run.outcome);
        print_shot_warnings(&run.outcome);
        for articulation in run.summary.articulations_to_show() {
            eprintln!("  {}", articulation.line());
        }
        for object in &run.summary.self_contact {
            eprintln!("  {}", object.line());
        }
        return Err(error.into());
    }
    if let Some(error) = run.interrupted_error() {
        return Err(error.into());
    }
    say!("{}", run.summary.one_line());
    let warnings = print_shot_warnings(&run.outcome);
    for articulation in run.summary.articulations_to_show() {
        say!("  {}", articulation.line());
    }
    for object in &run.summary.self_contact {
        say!("  {}", object.line());
    }
    for tight in &run.summary.tight_regions {
        say!("  {}", tight.line());
    }
    say!("results: {} ({}), report: {}", output.dir.display(), output.format.extension(), run.report.display());
    for file in &run.merged.files {
        say!("merged the parts of the shot into {}", file.display());
    }
    for (object, missing) in &run.merged.incomplete {
        say!(
            "parts of \"{object}\": frames {} missing; its parts are merged into one file once they hold every frame",
            missing.join(", ")
        );
    }
    if !run.previews.is_empty() {
        say!("previews: {} pictures in {}", run.previews.len(), output.dir.join("preview").display());
    }
    if args.strict && warnings > 0 {
        return Err(CliError::strict(warnings));
    }
    Ok(())
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
        if let Some(parts) = &object.params.self_contact_parts {
            say!(
                "  {:<16} self-contact between its {} parts (self_contact = \"auto\"): the part pairs touching beyond the rest pose, at each frame",
                "",
                parts.names.len()
            );
        }
    }
    say!("pairs:");
    if description.pairs.is_empty() {
        let folding: Vec<&str> =
            first.objects.iter().filter(|o| has_self_contact(&o.params)).map(|o| o.name.as_str()).collect();
        if folding.is_empty() {
            say!("  none (the objects are copied unchanged)");
        } else {
            say!("  none; the self-contact of {} (above) is computed", folding.join(", "));
        }
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
        for m in missing {
            say!("  object \"{}\", frame {}: {}", m.object, m.frame, m.path.display());
        }
    }
}
