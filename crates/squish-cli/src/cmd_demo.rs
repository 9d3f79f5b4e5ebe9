//! `squish demo [-o DIR] [--quick]`: animated scenes built in memory (no input files), run like
//! `squish run` runs a scene file — frames in parallel, OBJ per frame and object, a report and
//! quality plots per scene, pictures — plus a top-level summary (`summary.json`,
//! `overview.png`) and a short printed report.
//!
//! The scenes (z up, every object closed, so volumes and penetrations are measurable):
//! - `press`: a soft ball pressed into soft ground and released, from a gap through first
//!   contact to the deepest press and back;
//! - `squeeze`: a soft ball squeezed between two stiffer ones (three objects, two pairs);
//! - `two-balls`: two balls of different sizes pushed together;
//! - `elbow`: an arm bending to 150° at its elbow, whose skin folds onto itself (self-contact,
//!   thesis ch. 6);
//! - `capsules`: two crossed capsules pushed together.

use std::collections::BTreeSet;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use clap::Args;
use glam::DVec3;
use serde::Serialize;
use squish::ObjectParams;
use squish::PairParams;
use squish::mesh::shapes;
use squish::pipeline::FramePair;
use squish::pipeline::OwnedObject;
use squish_io::scene::{OutputFormat, OutputSpec};
use squish_render::vstack;
use squish_scenes::procedural::{self as scenes, ProceduralScene};

use crate::console::say;
use crate::error::CliError;
use crate::preview::{PictureSettings, strip, write_png, write_previews};
use crate::signals;
use squish::pipeline::OwnedFrame;
use squish_shot::ShotError;
use squish_shot::files::{create_dir, write_text};
use squish_shot::quality::{ShotSummary, percent, write_report};
use squish_shot::shot::{ShotSettings, ShotSource, run_shot, worker_pool};

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output directory.
    #[arg(short, long, default_value = "squish-demo")]
    pub output: PathBuf,
    /// Coarse meshes and few frames (a few seconds; for tests and a first look).
    #[arg(long)]
    pub quick: bool,
    /// Worker threads. Default: all cores.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
}

/// Mesh resolution and frame counts.
#[derive(Clone, Copy, Debug, Serialize)]
struct Detail {
    /// Icosphere subdivisions (3: 642 vertices, 4: 2562).
    subdivisions: u32,
    /// Cells along each side of the ground slab.
    ground_cells: u32,
    /// Segments around a capsule.
    capsule_segments: u32,
    /// Frames of the long animations (press, squeeze) and of the short ones.
    long_frames: i64,
    short_frames: i64,
}

impl Detail {
    fn new(quick: bool) -> Self {
        if quick {
            Self { subdivisions: 3, ground_cells: 12, capsule_segments: 16, long_frames: 10, short_frames: 3 }
        } else {
            Self { subdivisions: 4, ground_cells: 32, capsule_segments: 40, long_frames: 48, short_frames: 6 }
        }
    }
}

/// One demo animation: a procedural scene as a function of the overlap depth, and the depth
/// as a function of the frame.
struct DemoScene {
    /// Folder name.
    slug: &'static str,
    title: &'static str,
    detail: Detail,
    frames: RangeInclusive<i64>,
    /// The animated value at a frame: the overlap depth (world units, negative: a gap), or the
    /// bend of the elbow in degrees.
    depth: Box<dyn Fn(i64) -> f64 + Sync>,
    build: Box<dyn Fn(f64) -> ProceduralScene + Sync>,
}

impl ShotSource for DemoScene {
    fn frame(&self, frame: i64) -> Result<OwnedFrame, ShotError> {
        Ok((self.build)((self.depth)(frame)).contents)
    }
}

/// Position in `[0, 1]` of `frame` within `1..=count`.
fn phase(frame: i64, count: i64) -> f64 {
    if count <= 1 { 1.0 } else { (frame - 1) as f64 / (count - 1) as f64 }
}

fn demo_scenes(detail: Detail) -> Vec<DemoScene> {
    let d = detail;
    let (long, short) = (d.long_frames, d.short_frames);
    vec![
        DemoScene {
            slug: "press",
            title: "a soft ball pressed into soft ground and released",
            detail: d,
            frames: 1..=long,
            // From a gap of 0.1, through first contact, down to 0.35 deep and back up.
            depth: Box::new(move |f| -0.1 + 0.45 * (std::f64::consts::PI * phase(f, long)).sin()),
            build: Box::new(move |depth| {
                let mut scene = scenes::ball_on_ground(depth, d.subdivisions, d.ground_cells);
                if let Some(ground) = scene.object_mut("ground") {
                    ground.params = ObjectParams::default().with_stiffness(2.0);
                }
                scene
            }),
        },
        DemoScene {
            slug: "squeeze",
            title: "a soft ball squeezed between two stiffer ones",
            detail: d,
            frames: 1..=long,
            depth: Box::new(move |f| -0.05 + 0.35 * (std::f64::consts::PI * phase(f, long)).sin()),
            build: Box::new(move |depth| squeezed_ball(depth, d.subdivisions)),
        },
        DemoScene {
            slug: "two-balls",
            title: "two balls of different sizes pushed together",
            detail: d,
            frames: 1..=short,
            depth: Box::new(move |f| 0.1 + 0.25 * phase(f, short)),
            build: Box::new(move |depth| scenes::two_balls(depth, d.subdivisions)),
        },
        DemoScene {
            slug: "elbow",
            title: "an arm bending to 150° at its elbow until its skin folds onto itself (self-contact)",
            detail: d,
            frames: 1..=long,
            // Here the animated value is the bend in degrees.
            depth: Box::new(move |f| 150.0 * phase(f, long)),
            build: Box::new(move |degrees| scenes::bent_arm(degrees, d.capsule_segments)),
        },
        DemoScene {
            slug: "capsules",
            title: "two crossed capsules pushed together",
            detail: d,
            frames: 1..=short,
            depth: Box::new(move |f| 0.1 + 0.25 * phase(f, short)),
            build: Box::new(move |depth| scenes::crossed_capsules(depth, d.capsule_segments)),
        },
    ]
}

/// A soft unit ball at the origin between two stiffer balls of radius 0.8 above and below it,
/// each overlapping it by `depth`. Pairs (top, middle) and (bottom, middle).
fn squeezed_ball(depth: f64, subdivisions: u32) -> ProceduralScene {
    let ball = |radius: f64, z: f64| {
        let mut mesh = shapes::icosphere(radius, subdivisions);
        mesh.map_positions(|p| p + DVec3::new(0.0, 0.0, z));
        mesh
    };
    let offset = 1.8 - depth;
    let object = |name: &str, mesh, stiffness| OwnedObject {
        name: name.to_string(),
        mesh,
        params: ObjectParams::default().with_stiffness(stiffness),
    };
    ProceduralScene::new(
        "squeeze".into(),
        vec![
            object("top", ball(0.8, offset), 2.0),
            object("middle", ball(1.0, 0.0), 1.0),
            object("bottom", ball(0.8, -offset), 2.0),
        ],
        vec![
            FramePair { objects: [0, 1], params: PairParams::default() },
            FramePair { objects: [2, 1], params: PairParams::default() },
        ],
    )
}

/// What `report.json` says about a demo scene.
#[derive(Serialize)]
struct DemoDescription<'a> {
    name: &'a str,
    title: &'a str,
    frames: [i64; 2],
    detail: Detail,
    /// Overlap depth of the input at each frame.
    depth: Vec<(i64, f64)>,
    objects: Vec<DemoObject>,
    pairs: Vec<[String; 2]>,
}

#[derive(Serialize)]
struct DemoObject {
    name: String,
    vertices: usize,
    triangles: usize,
    params: ObjectParams,
}

/// One line of the top-level summary.
#[derive(Serialize)]
struct SceneResult {
    name: String,
    title: String,
    dir: String,
    frames: usize,
    vertices: usize,
    summary: ShotSummary,
}

pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    let detail = Detail::new(args.quick);
    let pool = worker_pool(args.threads)?;
    let root = std::path::absolute(&args.output).unwrap_or_else(|_| args.output.clone());
    create_dir(&root)?;
    let interrupt = signals::install();
    let demos = demo_scenes(detail);
    say!(
        "squish demo{}: {} animated scenes → {}",
        if args.quick { " --quick" } else { "" },
        demos.len(),
        root.display()
    );
    let start = std::time::Instant::now();
    let mut results = Vec::new();
    let mut strips = Vec::new();
    for (k, demo) in demos.iter().enumerate() {
        let (result, strip_image) = run_scene(demo, &root, &pool, interrupt, k, demos.len())?;
        results.push(result);
        strips.extend(strip_image);
        if interrupt.requested() {
            break;
        }
    }
    let overview = if strips.is_empty() {
        None
    } else {
        let refs: Vec<_> = strips.iter().collect();
        Some(write_png(&root.join("overview.png"), &vstack(&refs, 8, [255, 255, 255, 255]))?)
    };
    let summary_path = root.join("summary.json");
    write_text(
        &summary_path,
        &serde_json::to_string_pretty(&serde_json::json!({
            "squish_version": env!("CARGO_PKG_VERSION"),
            "quick": args.quick,
            "threads": pool.current_num_threads(),
            "total_time_s": start.elapsed().as_secs_f64(),
            "scenes": results,
        }))?,
    )?;
    if interrupt.requested() {
        return Err(CliError::interrupted(format!(
            "interrupted after {} of {} scenes (reports written for the frames done; summary: {})",
            results.len(),
            demos.len(),
            summary_path.display()
        )));
    }
    say!("done in {:.1} s", start.elapsed().as_secs_f64());
    if let Some(path) = overview {
        say!("overview: {}", path.display());
    }
    say!("summary: {}", summary_path.display());
    Ok(())
}

/// Runs one demo scene into `root/<slug>`; returns its summary line and its strip of frames.
fn run_scene(
    demo: &DemoScene,
    root: &Path,
    pool: &rayon::ThreadPool,
    interrupt: &squish_shot::Interrupt,
    index: usize,
    count: usize,
) -> Result<(SceneResult, Option<squish_render::Image>), CliError> {
    let dir = root.join(demo.slug);
    let output = OutputSpec { dir: dir.clone(), format: OutputFormat::Obj };
    let first = demo.frame(*demo.frames.start())?;
    for object in &first.objects {
        create_dir(&output.object_dir(&object.name))?;
    }
    let vertices: usize = first.objects.iter().map(|o| o.mesh.num_vertices()).sum();
    let frame_count = demo.frames.clone().count();
    say!(
        "[{}/{count}] {}: {} ({} frame{}, {} objects, {vertices} vertices)",
        index + 1,
        demo.slug,
        demo.title,
        frame_count,
        if frame_count == 1 { "" } else { "s" },
        first.objects.len()
    );
    let shown = shown_frames(&demo.frames, 6);
    let settings = ShotSettings {
        frames: demo.frames.clone(),
        preview_frames: shown.clone(),
        keep_outputs: false,
        label: format!("  {}", demo.slug),
    };
    let write = |frame: i64, shot: &OwnedFrame, positions: &[Vec<DVec3>]| -> Result<(), ShotError> {
        for (object, p) in shot.objects.iter().zip(positions) {
            let mesh = squish::TriMesh { positions: p.clone(), triangles: object.mesh.triangles.clone() };
            squish_io::write_mesh(&output.path_for(&object.name, frame), &mesh)?;
        }
        Ok(())
    };
    let outcome = run_shot(demo, &settings, pool, interrupt, &write)?;
    let description = DemoDescription {
        name: demo.slug,
        title: demo.title,
        frames: [*demo.frames.start(), *demo.frames.end()],
        detail: demo.detail,
        depth: demo.frames.clone().map(|f| (f, (demo.depth)(f))).collect(),
        objects: first
            .objects
            .iter()
            .map(|o| DemoObject {
                name: o.name.clone(),
                vertices: o.mesh.num_vertices(),
                triangles: o.mesh.num_triangles(),
                params: o.params.clone(),
            })
            .collect(),
        pairs: first.pairs.iter().map(|p| p.objects.map(|i| first.objects[i].name.clone())).collect(),
    };
    let (previews, pictures) =
        pool.install(|| write_previews(&dir.join("preview"), &outcome, &PictureSettings::default()))?;
    let strip_image = strip(&pictures);
    if let Some(image) = &strip_image {
        write_png(&dir.join("strip.png"), image)?;
    }
    let outputs = serde_json::json!({
        "dir": dir.display().to_string(),
        "format": "obj",
        "objects": first.objects.iter().map(|o| output.object_dir(&o.name).join("{frame:04}.obj").display().to_string()).collect::<Vec<_>>(),
        "previews": previews.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    });
    let summary = write_report(&dir, "report.json", &description, &outputs, &outcome)?;
    if let Some(failure) = outcome.failures.into_iter().next() {
        return Err(failure.error.into());
    }
    say!("      {}", demo_line(&summary));
    say!("      → {}/ (meshes, report.json, quality.png, preview/, strip.png)", dir.display());
    let result = SceneResult {
        name: demo.slug.to_string(),
        title: demo.title.to_string(),
        dir: dir.display().to_string(),
        frames: outcome.records.len(),
        vertices,
        summary,
    };
    Ok((result, strip_image))
}

/// The figures of a scene in one line: volume error, residual penetration, largest step, time.
fn demo_line(s: &ShotSummary) -> String {
    let volume = s.max_volume_change.as_ref().map_or(0.0, |e| e.value);
    let mut penetration = s.max_penetration_ratio.as_ref().map_or_else(
        || "no penetration".to_string(),
        |p| format!("residual penetration {} of the input's", percent(p.value)),
    );
    for a in &s.articulations {
        penetration = format!(
            "{}: self-intersecting faces {} → {}",
            a.name, a.self_intersecting_faces_before, a.self_intersecting_faces_after
        );
    }
    let step = s.max_step_ratio.as_ref().map_or_else(
        || "one frame".to_string(),
        |e| format!("largest frame-to-frame step {:.2}× the input's", e.value),
    );
    format!(
        "volume error {volume:.1e} · {penetration} · {step} · {:.1} s ({:.1} frames/s)",
        s.wall_time_s, s.frames_per_second
    )
}

/// Up to `count` frames spread evenly over `range`, first and last included.
fn shown_frames(range: &RangeInclusive<i64>, count: usize) -> BTreeSet<i64> {
    let (start, end) = (*range.start(), *range.end());
    let n = (end - start + 1).max(1) as usize;
    let count = count.min(n).max(1);
    if count == 1 {
        return [start].into_iter().collect();
    }
    (0..count).map(|k| start + ((end - start) as f64 * k as f64 / (count - 1) as f64).round() as i64).collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn shown_frames_spread_over_the_range() {
        assert_eq!(shown_frames(&(1..=48), 6).into_iter().collect::<Vec<_>>(), vec![1, 10, 20, 29, 39, 48]);
        assert_eq!(shown_frames(&(1..=3), 6).into_iter().collect::<Vec<_>>(), vec![1, 2, 3]);
        assert_eq!(shown_frames(&(5..=5), 6).into_iter().collect::<Vec<_>>(), vec![5]);
    }

    #[test]
    fn the_press_starts_apart_and_goes_through_first_contact() {
        let scenes = demo_scenes(Detail::new(true));
        let press = &scenes[0];
        let depths: Vec<f64> = press.frames.clone().map(|f| (press.depth)(f)).collect();
        assert!(depths[0] < 0.0 && *depths.last().unwrap() < 0.0);
        assert!(depths.iter().any(|&d| d > 0.2));
    }
}
