//! `squish bench`: times the whole pipeline on reproducible animated scenes at the sizes of the
//! thesis' performance tables (ch. 7 §5, tables 7.1–7.3) and compares with the C++ prototype.
//!
//! For every scene of [`squish_scenes::bench`] (two of them read `bunny_29834.obj` and
//! `hand_7993.obj` from the data directory and are skipped with a note when it is absent), and
//! `cesium-man-walk`: the glTF sample CesiumMan's walk (`rigged/CesiumMan.glb`, 48 frames at 24
//! fps, looped) with `self_contact = "auto"`, posed through a scene file as `squish run` poses it:
//! - one [`Deformer`] runs a warm-up frame (it builds the caches: topology, trees, symbolic
//!   analyses) and then `--frames` frames of the animation, reused as an animation would, inside a
//!   local rayon pool of one thread, then again (fresh deformer) in a pool of `--threads`;
//! - the median frame time of each run, and the stage breakdown of the single-thread median frame
//!   (every [`Stage`](squish::stage::Stage); the thesis' columns i., m., c., p., di., g., de., s.), the numeric factorizations of that
//!   frame and the rows they ran on (fewer than the regions' sizes when the rows outside 𝒫 or 𝒟
//!   are decoupled and left out, see [`squish::linalg::NumericFactor`]), and the symbolic
//!   analyses (the regions' own, and those of coupled-row submatrices);
//! - one numeric sparse Cholesky of the largest deformable object's Laplacian (the heat operator
//!   on its pattern, [`time_laplacian_factorization`]), measured in the same run, and the ratio
//!   frame time / factorization time;
//! - an edit (see [`measure_edit`]): the time of a frame that changes a parameter of §5.4–5.5
//!   only (`bulge` 1 → 1.2 on every deformable object), which a deformer that keeps its last
//!   frame for edits computes from that frame's contacts and fields, against the full frame;
//! - the peak resident memory of the scene (see [`memory`]);
//! - for a scene given frame by frame whose objects have self-contact parts (CesiumMan), every
//!   frame of its animation on one deformer, single thread: frame time, touching part pairs and
//!   the part stage's time, grouped by the number of touching pairs ([`measure_self_contact`]).
//!   Such scenes have no edit (the deformer never edits a frame with self-contact).
//!   `cesium-man-15k-walk` is the same walk on CesiumMan subdivided 1-to-9 with interpolated
//!   weights (21 026 vertices; every 12th frame with `--quick`); `humanoid-squat`,
//!   `humanoid-crouch` and `humanoid-arms-crossed` the procedural humanoid of
//!   [`squish_scenes::characters`] going into its extreme poses (32 frames; 8 frames of a coarser
//!   humanoid with `--quick`). Issue 36's other figures for these shots (jitter, locality):
//!   `cargo run --release -p squish-scenes --example self_contact_shots`.
//!
//! Then a shot of `--shot-frames` frames of one scene is processed with frames in parallel (one
//! deformer per worker, contiguous chunks) with all threads and with one thread: frames per second.
//!
//! `--rounds R` repeats all of it R times, round after round (each round runs every scene and the
//! shot once), so that a slow spell of a shared machine spreads over the scenes instead of hitting
//! all of one scene's runs. Each scene then reports the round with the median single-thread time
//! (its breakdown and counts), the multi-threaded run and the reference factorization of their own
//! median rounds, every round's medians and the fastest round; the shot reports its median round.
//!
//! Performance targets are read in the output; nothing here asserts them.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;
use rayon::prelude::*;
use squish::Topology;
use squish::pipeline::{Deformer, FrameStats};
use squish::stage::StageWork;
use squish_scenes::bench::{self as bench_scenes, BenchScene, BenchSize};
use squish_scenes::timing::time_laplacian_factorization;

use crate::bench_report::{
    BenchReport, EditReport, FactorizationReport, MachineReport, ObjectReport, RunFigures, RunReport, SceneReport,
    SelfContactFrame, SelfContactReport, ShotReport, ThesisReport, print_table,
};
use crate::error::CliError;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Print the results as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Also write the JSON results to this file.
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Smaller scenes (≈ ¼ of the vertices) and fewer frames: a smoke run of well under a minute.
    #[arg(long)]
    pub quick: bool,
    /// Threads of the multi-threaded runs (default: every available core).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Timed frames per scene and run (default 9; 3 with --quick).
    #[arg(long, value_name = "K")]
    pub frames: Option<usize>,
    /// Frames of the parallel shot (default 48; 8 with --quick).
    #[arg(long, value_name = "K")]
    pub shot_frames: Option<usize>,
    /// Scene of the parallel shot.
    #[arg(long, value_name = "SCENE", default_value = "small-big-spheres")]
    pub shot: String,
    /// Data directory holding `meshes/` (default: $SQUISH_DATA, else ../shared/data).
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Only the scenes whose name contains one of these words (comma-separated).
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Runs every scene and the shot this many times, round after round, and reports each
    /// scene's median round and fastest round (for a noisy or shared machine).
    #[arg(long, value_name = "R", default_value_t = 1)]
    pub rounds: usize,
}

/// Everything a run needs besides the scenes.
struct Settings {
    frames: usize,
    threads: usize,
}

pub fn run(args: &BenchArgs) -> Result<(), CliError> {
    let size = if args.quick { BenchSize::Quick } else { BenchSize::Full };
    let frames = args.frames.unwrap_or(if args.quick { 3 } else { 9 });
    let shot_frames = args.shot_frames.unwrap_or(if args.quick { 8 } else { 48 });
    if frames == 0 || shot_frames == 0 || args.rounds == 0 {
        return Err(CliError::input("--frames, --shot-frames and --rounds must be at least 1"));
    }
    let available = std::thread::available_parallelism().map_or(1, usize::from);
    let threads = args.threads.unwrap_or(available);
    if threads == 0 {
        return Err(CliError::input("--threads must be at least 1"));
    }
    let settings = Settings { frames, threads };
    let data = data_directory(args.data.as_deref());
    let machine_before = MachineReport::now(available, threads, size);

    let entries = scene_list(size, &data);
    let Some(shot_entry) = entries.iter().find(|e| e.name == args.shot) else {
        let names: Vec<&str> = entries.iter().map(|e| e.name).collect();
        return Err(CliError::input(format!("--shot {}: no such scene (one of {})", args.shot, names.join(", "))));
    };
    // Every word must select a scene: a misspelt one would otherwise time nothing and exit 0.
    if let Some(word) = args.scenes.iter().find(|s| !entries.iter().any(|e| e.name.contains(s.as_str()))) {
        let names: Vec<&str> = entries.iter().map(|e| e.name).collect();
        return Err(CliError::input(format!(
            "--scenes {word}: no scene's name contains \"{word}\"; the scenes are {}",
            names.join(", ")
        )));
    }
    let selected: Vec<&SceneEntry> = entries
        .iter()
        .filter(|e| args.scenes.is_empty() || args.scenes.iter().any(|s| e.name.contains(s.as_str())))
        .collect();
    let mut rounds: Vec<Vec<SceneReport>> = selected.iter().map(|_| Vec::with_capacity(args.rounds)).collect();
    let mut shots = Vec::with_capacity(args.rounds);
    for round in 0..args.rounds {
        let label = if args.rounds > 1 { format!("round {}/{}: ", round + 1, args.rounds) } else { String::new() };
        for (entry, runs) in selected.iter().zip(&mut rounds) {
            // A scene that cannot be built (a missing file) would not be built in later rounds either.
            if runs.first().is_some_and(|r: &SceneReport| r.skipped.is_some()) {
                continue;
            }
            progress(args, &format!("{label}{} …", entry.name));
            memory::reset_peak();
            let report = match (entry.build)() {
                Ok(scene) => measure_scene(&scene, &settings),
                Err(reason) => SceneReport::skipped(entry.name, entry.thesis.map(ThesisReport::from), reason),
            };
            progress(args, &report.one_line());
            runs.push(report);
        }
        // Built after the scenes of the round, so that their peak memory does not hold it.
        let shot_scene = (shot_entry.build)().map_err(CliError::input)?;
        progress(args, &format!("{label}shot: {} frames of {} …", shot_frames, shot_scene.name));
        shots.push(measure_shot(&shot_scene, shot_frames, threads)?);
    }
    let scenes: Vec<SceneReport> = rounds.into_iter().filter_map(SceneReport::from_rounds).collect();
    let shot = ShotReport::from_rounds(shots);
    let report = BenchReport {
        command: std::env::args().collect::<Vec<_>>().join(" "),
        data_directory: data.display().to_string(),
        frames,
        rounds: args.rounds,
        memory_method: memory::METHOD.to_string(),
        machine_before,
        machine_after: MachineReport::now(available, threads, size),
        automatic_region_speedup: automatic_region_speedup(&scenes),
        scenes,
        shot,
    };
    let json = serde_json::to_string_pretty(&report)?;
    if let Some(path) = &args.output {
        squish_shot::files::write_text(path, &json)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_table(&report);
    }
    let failed: Vec<&str> = report.scenes.iter().filter(|s| s.error.is_some()).map(|s| s.name.as_str()).collect();
    if failed.is_empty() { Ok(()) } else { Err(CliError::failure(format!("scenes failed: {}", failed.join(", ")))) }
}

/// Single-thread median frame of `press-100k` (whole objects) over `press-100k-automatic`.
fn automatic_region_speedup(scenes: &[SceneReport]) -> Option<f64> {
    let median =
        |name: &str| scenes.iter().find(|s| s.name == name).and_then(|s| s.single.as_ref()).map(|r| r.median_ms);
    let (whole, automatic) = (median("press-100k")?, median("press-100k-automatic")?);
    (automatic > 0.0).then(|| whole / automatic)
}

fn progress(args: &BenchArgs, message: &str) {
    if args.json {
        eprintln!("{message}");
    } else {
        eprintln!("  {message}");
    }
}

/// `--data`, else `$SQUISH_DATA`, else `../shared/data` (relative to the working directory,
/// i.e. beside the repository when run from its root).
fn data_directory(flag: Option<&Path>) -> PathBuf {
    if let Some(dir) = flag {
        return dir.to_path_buf();
    }
    match std::env::var_os("SQUISH_DATA") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => PathBuf::from("../shared/data"),
    }
}

/// A scene of the list, built on demand (so that a scene's peak memory holds its own meshes
/// only), or the reason it cannot be.
struct SceneEntry {
    name: &'static str,
    thesis: Option<bench_scenes::ThesisRow>,
    build: Box<dyn Fn() -> Result<BenchScene, String>>,
}

impl SceneEntry {
    fn procedural(
        name: &'static str,
        thesis: Option<bench_scenes::ThesisRow>,
        build: fn(BenchSize) -> BenchScene,
        size: BenchSize,
    ) -> Self {
        Self { name, thesis, build: Box::new(move || Ok(build(size))) }
    }
}

/// CesiumMan's walk with `self_contact = "auto"`, its 48 frames (2 s at 24 fps) posed as
/// `squish run` poses them (the scene file's own evaluation), or why it cannot be built.
fn cesium_man_walk(data: &Path) -> Result<BenchScene, String> {
    let glb = data.join("rigged").join("CesiumMan.glb");
    if !glb.is_file() {
        return Err(format!("{} not found (set --data or SQUISH_DATA)", glb.display()));
    }
    // Absolute: the scene file's folder (relative paths start there) is only a name here.
    let glb = std::path::absolute(&glb).map_err(|e| format!("{}: {e}", glb.display()))?;
    let file = glb.display().to_string().replace('\\', "/").replace('"', "\\\"");
    let text = format!(
        "frames = {{ start = 1, end = 48, fps = 24 }}\n\n[[objects]]\nname = \"cesium_man\"\n\
         mesh = {{ file = \"{file}\", repeat = true }}\nself_contact = \"auto\"\n"
    );
    let scene =
        squish_io::scene::Scene::from_toml(&text, &data.join("cesium_man_walk.toml")).map_err(|e| e.to_string())?;
    let poses = (1..=48)
        .map(|frame| {
            let spec = scene.evaluate(f64::from(frame)).map_err(|e| e.to_string())?;
            let objects = spec
                .objects
                .into_iter()
                .map(|o| squish::OwnedObject { name: o.name, mesh: o.mesh, params: o.params })
                .collect();
            Ok(squish_scenes::procedural::ProceduralScene::new("cesium-man-walk".into(), objects, Vec::new()))
        })
        .collect::<Result<Vec<_>, String>>()?;
    BenchScene::from_poses("cesium-man-walk", poses).ok_or_else(|| "no frame".to_string())
}

/// CesiumMan subdivided 1-to-9 with interpolated weights (21 026 vertices,
/// [`squish_scenes::characters::cesium_man_subdivided`]) walking with `self_contact = "auto"`:
/// the 48 frames of `cesium-man-walk` (4 of them, every 12th, with `--quick`), or why it cannot
/// be built.
fn cesium_man_15k_walk(data: &Path, size: BenchSize) -> Result<BenchScene, String> {
    let glb = data.join("rigged").join("CesiumMan.glb");
    if !glb.is_file() {
        return Err(format!("{} not found (set --data or SQUISH_DATA)", glb.display()));
    }
    let shot = squish_scenes::characters::cesium_man_walk(&glb, true)?;
    let mut scene = shot.bench_scene()?;
    if size == BenchSize::Quick {
        scene.poses = scene.poses.into_iter().step_by(12).collect();
    }
    Ok(scene)
}

/// The procedural humanoid (4 314 vertices; 2 714 with `--quick`) going from rest into an
/// extreme pose with `self_contact = "auto"`, 32 frames (8 with `--quick`).
fn humanoid(pose: squish_scenes::characters::Pose, size: BenchSize) -> Result<BenchScene, String> {
    use squish_scenes::characters;
    let (cell, frames) = match size {
        BenchSize::Full => (characters::HUMANOID_CELL, 32),
        BenchSize::Quick => (0.03, 8),
    };
    characters::humanoid_shot(std::sync::Arc::new(characters::humanoid(cell)), pose, frames).bench_scene()
}

/// Every scene in table order; three read their mesh from `data/meshes`, two a glTF from
/// `data/rigged`.
fn scene_list(size: BenchSize, data: &Path) -> Vec<SceneEntry> {
    let data_dir = data.to_path_buf();
    let data_15k = data.to_path_buf();
    use squish_scenes::characters::Pose;
    let mesh = |file: &str| -> Result<squish::TriMesh, String> {
        let path = data.join("meshes").join(file);
        if !path.is_file() {
            return Err(format!("{} not found (set --data or SQUISH_DATA)", path.display()));
        }
        squish_io::read_mesh(&path).map_err(|e| format!("{}: {e}", path.display()))
    };
    // The quick run uses the small shared bunny.
    let bunny = mesh(match size {
        BenchSize::Full => "bunny_29834.obj",
        BenchSize::Quick => "bunny_3301.obj",
    });
    let hand = mesh("hand_7993.obj");
    let with_mesh = |name: &'static str,
                     thesis: bench_scenes::ThesisRow,
                     mesh: &Result<squish::TriMesh, String>,
                     build: fn(squish::TriMesh, BenchSize) -> BenchScene| {
        let mesh = mesh.clone();
        SceneEntry { name, thesis: Some(thesis), build: Box::new(move || mesh.clone().map(|m| build(m, size))) }
    };
    use bench_scenes as b;
    vec![
        SceneEntry::procedural("fingers-ball", Some(b::FINGERS_BALL), b::fingers_ball, size),
        SceneEntry::procedural("fingers-palm", Some(b::FINGERS_PALM), b::fingers_palm, size),
        SceneEntry::procedural("sphere-plane", Some(b::PLANE_SPHERE), b::sphere_plane, size),
        SceneEntry::procedural("small-big-spheres", Some(b::SMALL_BIG_SPHERES), b::small_big_spheres, size),
        with_mesh("bunny-jelly", b::BUNNY_JELLY, &bunny, b::bunny_jelly),
        with_mesh("bunny-whole-jelly", b::BUNNY_JELLY, &bunny, b::bunny_whole_jelly),
        SceneEntry::procedural("feet-plane", Some(b::WALK), b::feet_plane, size),
        SceneEntry::procedural("hat-egg", Some(b::HAT_EGG), b::hat_egg, size),
        with_mesh("hand-pillow", b::HAND_PILLOW, &hand, b::hand_pillow),
        SceneEntry::procedural("stress-100k", None, b::stress_100k, size),
        SceneEntry::procedural("press-100k", None, b::press_100k, size),
        SceneEntry::procedural("press-100k-automatic", None, b::press_100k_automatic, size),
        SceneEntry { name: "cesium-man-walk", thesis: None, build: Box::new(move || cesium_man_walk(&data_dir)) },
        SceneEntry {
            name: "cesium-man-15k-walk",
            thesis: None,
            build: Box::new(move || cesium_man_15k_walk(&data_15k, size)),
        },
        SceneEntry { name: "humanoid-squat", thesis: None, build: Box::new(move || humanoid(Pose::Squat, size)) },
        SceneEntry { name: "humanoid-crouch", thesis: None, build: Box::new(move || humanoid(Pose::Crouch, size)) },
        SceneEntry {
            name: "humanoid-arms-crossed",
            thesis: None,
            build: Box::new(move || humanoid(Pose::ArmsCrossed, size)),
        },
    ]
}

/// One run of the animation on a fresh deformer: warm-up frame, then the timed frames.
struct Run {
    first_frame: Duration,
    stats: Vec<FrameStats>,
    /// Numeric factorizations per timed frame (summed over objects).
    numeric_factorizations: Vec<usize>,
    /// Rows factorized per timed frame (summed over the factorizations and objects).
    factorized_rows: Vec<usize>,
    /// Of those, rows recomputed per timed frame.
    recomputed_rows: Vec<usize>,
    /// Symbolic analyses of coupled-row submatrices over the timed frames.
    reduced_analyses_timed: usize,
    /// Symbolic analyses over the timed frames (0 when the caches are reused).
    symbolic_analyses_timed: usize,
    symbolic_analyses_warm_up: usize,
    /// A digest of each timed frame's output positions (to compare runs bit for bit).
    digests: Vec<u64>,
}

fn run_animation(scene: &BenchScene, frames: usize) -> Result<Run, String> {
    let mut run = Run {
        first_frame: Duration::ZERO,
        stats: Vec::with_capacity(frames),
        numeric_factorizations: Vec::with_capacity(frames),
        factorized_rows: Vec::with_capacity(frames),
        recomputed_rows: Vec::with_capacity(frames),
        reduced_analyses_timed: 0,
        symbolic_analyses_timed: 0,
        symbolic_analyses_warm_up: 0,
        digests: Vec::with_capacity(frames),
    };
    let mut symbolic_analyses = 0;
    scene.animate(
        frames,
        |deformer, time| {
            run.first_frame = time;
            run.symbolic_analyses_warm_up = deformer.symbolic_analyses();
        },
        |_, result, deformer| {
            let deformations = || result.deformations.iter().flatten();
            run.numeric_factorizations.push(deformations().map(|d| d.stats.numeric_factorizations).sum());
            run.factorized_rows.push(deformations().map(|d| d.stats.factorized_rows).sum());
            run.recomputed_rows.push(deformations().map(|d| d.stats.recomputed_rows).sum());
            run.reduced_analyses_timed += deformations().map(|d| d.stats.reduced_analyses).sum::<usize>();
            run.digests.push(positions_digest(&result.positions));
            run.stats.push(result.stats);
            symbolic_analyses = deformer.symbolic_analyses();
        },
    )?;
    run.symbolic_analyses_timed = symbolic_analyses.saturating_sub(run.symbolic_analyses_warm_up);
    Ok(run)
}

/// FNV-1a over the bits of every output position: equal for outputs equal bit for bit.
fn positions_digest(positions: &[Vec<glam::DVec3>]) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for bits in positions.iter().flatten().flat_map(|p| p.to_array().map(f64::to_bits)) {
        for byte in bits.to_le_bytes() {
            hash = (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    hash
}

impl Run {
    fn figures(&self, threads: usize) -> RunFigures<'_> {
        RunFigures {
            threads,
            stats: &self.stats,
            first_frame: self.first_frame,
            numeric_factorizations: &self.numeric_factorizations,
            factorized_rows: &self.factorized_rows,
            recomputed_rows: &self.recomputed_rows,
            reduced_analyses_timed_frames: self.reduced_analyses_timed,
            symbolic_analyses_first_frame: self.symbolic_analyses_warm_up,
            symbolic_analyses_timed_frames: self.symbolic_analyses_timed,
        }
    }
}

/// Index of the median frame time (the lower median for an even count).
fn median_index(stats: &[FrameStats]) -> usize {
    let mut order: Vec<usize> = (0..stats.len()).collect();
    order.sort_by_key(|&i| stats[i].total);
    order[(order.len() - 1) / 2]
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, String> {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| format!("thread pool: {e}"))
}

/// Runs `scene` (the caller resets the memory peak before building it).
fn measure_scene(scene: &BenchScene, settings: &Settings) -> SceneReport {
    let thesis = scene.thesis.map(ThesisReport::from);
    let objects: Vec<ObjectReport> = scene
        .rest
        .objects
        .iter()
        .map(|o| ObjectReport {
            name: o.name.clone(),
            vertices: o.mesh.num_vertices(),
            rigid: o.params.rigid,
            deformable_vertices: 0,
            contact_vertices: 0,
        })
        .collect();
    let mut report = SceneReport::new(scene.name, thesis, objects, settings.frames);
    let outcome = (|| -> Result<(), String> {
        let single = pool(1)?.install(|| run_animation(scene, settings.frames))?;
        let median = median_index(&single.stats);
        for (object, stats) in report.objects.iter_mut().zip(&single.stats[median].objects) {
            object.deformable_vertices = stats.deformable_vertices;
            object.contact_vertices = stats.contact_vertices;
        }
        report.single = Some(RunReport::new(&single.figures(1), median));
        let (single_digests, single_work): (Vec<u64>, Vec<StageWork>) =
            (single.digests.clone(), single.stats.iter().map(|s| s.work).collect());
        drop(single);
        if scene.rest.objects.iter().any(|o| squish_shot::shot::has_self_contact(&o.params)) {
            if !scene.poses.is_empty() {
                report.self_contact = Some(pool(1)?.install(|| measure_self_contact(scene))?);
            }
        } else {
            report.edit = Some(pool(1)?.install(|| measure_edit(scene, median, settings.frames))?);
        }
        let multi = pool(settings.threads)?.install(|| run_animation(scene, settings.frames))?;
        report.multi = Some(RunReport::new(&multi.figures(settings.threads), median_index(&multi.stats)));
        report.same_output_across_threads = Some(multi.digests == single_digests);
        report.same_work_across_threads = Some(multi.stats.iter().map(|s| s.work).eq(single_work));
        drop(multi);
        if let Some(largest) = scene.largest_deformable() {
            let topology = Topology::new(&largest.mesh);
            let timing = pool(1)?
                .install(|| time_laplacian_factorization(&largest.mesh, &topology, 5))
                .map_err(|e| format!("factorization timing: {e}"))?;
            report.factorization = Some(FactorizationReport::new(&largest.name, &timing));
        }
        Ok(())
    })();
    if let Err(error) = outcome {
        report.error = Some(error);
    }
    report.peak_memory_mb = memory::peak_mb();
    report.finish(&scene.sides());
    report
}

/// Every pose of a scene given frame by frame, on one deformer after a warm-up frame (the last
/// pose), in the caller's pool: per frame its time and its self-contact figures.
fn measure_self_contact(scene: &BenchScene) -> Result<SelfContactReport, String> {
    let mut deformer = Deformer::new().without_quality();
    let warm_up = scene.poses.last().ok_or("no poses")?;
    deformer.deform(&warm_up.frame()).map_err(|e| format!("self-contact warm-up frame: {e}"))?;
    let mut frames = Vec::with_capacity(scene.poses.len());
    for (frame, pose) in scene.poses.iter().enumerate() {
        let result = deformer.deform(&pose.frame()).map_err(|e| format!("self-contact frame {frame}: {e}"))?;
        let stats = &result.stats;
        let faces = stats
            .objects
            .iter()
            .filter_map(|o| o.self_intersecting_faces)
            .fold([0, 0], |s, f| [s[0] + f[0], s[1] + f[1]]);
        frames.push(SelfContactFrame {
            frame,
            touching_pairs: stats.part_pairs.len(),
            pairs_in_contact: stats.part_pairs.iter().filter(|p| p.in_contact).count(),
            articulations: stats.articulations.iter().filter(|a| a.error.is_none()).count(),
            ms: stats.total.as_secs_f64() * 1e3,
            part_pairs_ms: stats.part_pairs.iter().map(|p| p.time.as_secs_f64() * 1e3).sum(),
            articulations_ms: stats.articulations.iter().map(|a| a.total_time.as_secs_f64() * 1e3).sum(),
            untangle_ms: stats.objects.iter().filter_map(|o| o.untangled).map(|u| u.time.as_secs_f64() * 1e3).sum(),
            faces,
        });
    }
    Ok(SelfContactReport::new(frames))
}

/// The edit of the bench: `bulge` 1 → 1.2 → 1 … on every deformable object of frame `frame` (of
/// `frames`), `EDITS` times on a deformer that keeps its frames for edits (after one full frame),
/// each edit's result checked against a fresh deformer's once (same bits), and the full frame on
/// that deformer timed as often (it copies what edits reuse). Run in the caller's pool.
fn measure_edit(scene: &BenchScene, frame: usize, frames: usize) -> Result<EditReport, String> {
    const EDITS: usize = 9;
    const VALUES: [f64; 2] = [1.0, 1.2];
    let mut pose = scene.pose(BenchScene::frame_time(frame, frames));
    let set_bulge = |pose: &mut squish_scenes::procedural::ProceduralScene, bulge: f64| {
        for object in pose.objects.iter_mut().filter(|o| !o.params.rigid) {
            object.params.bulge = bulge;
        }
    };
    set_bulge(&mut pose, VALUES[0]);
    let mut edits = Vec::with_capacity(EDITS);
    let mut full = Vec::with_capacity(EDITS);
    for k in 0..EDITS {
        let mut deformer = Deformer::new().without_quality().keep_for_edits();
        set_bulge(&mut pose, VALUES[0]);
        let start = Instant::now();
        deformer.deform(&pose.frame()).map_err(|e| format!("edit's frame: {e}"))?;
        full.push(start.elapsed());
        set_bulge(&mut pose, VALUES[1]);
        let start = Instant::now();
        let edited = deformer.deform(&pose.frame()).map_err(|e| format!("edit: {e}"))?;
        edits.push(start.elapsed());
        if !edited.stats.edit {
            return Err("the edit of bulge was computed as a full frame".into());
        }
        if k == 0 {
            let fresh =
                Deformer::new().without_quality().deform(&pose.frame()).map_err(|e| format!("edit's check: {e}"))?;
            let bits = |r: &squish::pipeline::FrameResult| -> Vec<u64> {
                r.positions.iter().flatten().flat_map(|p| p.to_array().map(f64::to_bits)).collect()
            };
            if bits(&edited) != bits(&fresh) {
                return Err("the edit's positions differ from a full computation's".into());
            }
        }
    }
    Ok(EditReport::new("bulge", VALUES, &edits, &full))
}

/// `frames` frames of `scene` with frames in parallel: the frames are cut into one contiguous
/// chunk per worker, each with its own deformer (caches reused within the chunk).
fn measure_shot(scene: &BenchScene, frames: usize, threads: usize) -> Result<ShotReport, CliError> {
    let shot = |workers: usize| -> Result<Duration, String> {
        let chunk = frames.div_ceil(workers);
        let chunks: Vec<std::ops::Range<usize>> =
            (0..frames).step_by(chunk.max(1)).map(|s| s..(s + chunk).min(frames)).collect();
        pool(workers)?.install(|| {
            let start = Instant::now();
            chunks
                .par_iter()
                .map(|range| {
                    let mut deformer = Deformer::new().without_quality();
                    for k in range.clone() {
                        let pose = scene.pose(BenchScene::frame_time(k, frames));
                        deformer.deform(&pose.frame()).map_err(|e| format!("shot frame {k}: {e}"))?;
                    }
                    Ok(())
                })
                .collect::<Result<(), String>>()?;
            Ok(start.elapsed())
        })
    };
    let single = shot(1).map_err(CliError::failure)?;
    let multi = shot(threads).map_err(CliError::failure)?;
    Ok(ShotReport::new(scene.name, frames, threads, single, multi))
}

/// Peak resident memory per scene, from Linux's `/proc/self/status`.
pub mod memory {
    /// How the peak is measured (copied into the report).
    pub const METHOD: &str = "VmHWM of /proc/self/status (peak resident set size of the process), \
        reset before each scene by writing 5 to /proc/self/clear_refs; where the reset is refused, \
        the process' peak so far";

    /// Resets the process' peak resident set size to its current size (Linux ≥ 4.0).
    pub fn reset_peak() {
        // A refused reset only makes the figure an upper bound (the process' peak so far).
        let _ = std::fs::write("/proc/self/clear_refs", "5");
    }

    /// The peak resident set size in MB since the last reset, if the system reports it.
    pub fn peak_mb() -> Option<f64> {
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
        let kb: f64 = line.trim_start_matches("VmHWM:").trim().trim_end_matches("kB").trim().parse().ok()?;
        Some(kb / 1024.0)
    }
}
