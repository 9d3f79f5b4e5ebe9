//! Issue 36's figures for `self_contact = "auto"` on rigged characters in extreme poses:
//!
//! ```text
//! cargo run --release -p squish-scenes --example self_contact_shots -- OUTDIR [options]
//!   --shots a,b,…   shots to run (default: all): humanoid-squat, humanoid-crouch,
//!                   humanoid-arms-crossed, cesium-man-walk, cesium-man-15k-walk
//!   --frames N      frames of the humanoid's shots (default 32); --first N runs only the
//!                   first N frames of every shot
//!   --cell H        the humanoid's grid cell (default 0.024, 4 314 vertices)
//!   --threads N     threads (default 1: issue 36 times one thread)
//!   --data DIR      the shared data (default ../shared/data next to the repository, or
//!                   $SQUISH_DATA); CesiumMan's shots are skipped with a note without it
//!   --no-obj        do not write the OBJ folders
//! ```
//!
//! Per shot it writes `OUTDIR/<shot>/plain/frame_NNNN.obj` (plain skinning) and
//! `OUTDIR/<shot>/auto/frame_NNNN.obj` (`self_contact = "auto"`), so that
//! `python3 ../shared/tools/motion_quality.py OUTDIR/<shot>/plain OUTDIR/<shot>/auto` gives the
//! same excess acceleration and moved share as the table, and prints a line per frame and a
//! markdown table (squish_scenes::shots).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use squish_scenes::characters::{self, CharacterShot};
use squish_scenes::shots::{self, ShotFigures};

struct Options {
    out: PathBuf,
    shots: Option<Vec<String>>,
    frames: usize,
    first: Option<usize>,
    cell: f64,
    threads: usize,
    data: PathBuf,
    obj: bool,
}

fn parse() -> Result<Options, String> {
    let mut args = std::env::args().skip(1);
    let default_data = std::env::var_os("SQUISH_DATA")
        .map_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"), PathBuf::from);
    let mut options = Options {
        out: PathBuf::new(),
        shots: None,
        frames: 32,
        first: None,
        cell: characters::HUMANOID_CELL,
        threads: 1,
        data: default_data,
        obj: true,
    };
    let mut out = None;
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or_else(|| format!("{name} needs a value"));
        match arg.as_str() {
            "--shots" => options.shots = Some(value("--shots")?.split(',').map(str::to_string).collect()),
            "--frames" => options.frames = value("--frames")?.parse().map_err(|e| format!("--frames: {e}"))?,
            "--first" => options.first = Some(value("--first")?.parse().map_err(|e| format!("--first: {e}"))?),
            "--cell" => options.cell = value("--cell")?.parse().map_err(|e| format!("--cell: {e}"))?,
            "--threads" => options.threads = value("--threads")?.parse().map_err(|e| format!("--threads: {e}"))?,
            "--data" => options.data = PathBuf::from(value("--data")?),
            "--no-obj" => options.obj = false,
            other if other.starts_with("--") => return Err(format!("unknown option {other}")),
            other => out = Some(PathBuf::from(other)),
        }
    }
    options.out = out.ok_or("usage: self_contact_shots OUTDIR [--shots a,b] [--frames N] [--first N] [--cell H] [--threads N] [--data DIR] [--no-obj]")?;
    Ok(options)
}

fn wanted(options: &Options, name: &str) -> bool {
    options.shots.as_ref().is_none_or(|list| list.iter().any(|s| s == name))
}

fn run(options: &Options, shot: &CharacterShot) -> Result<ShotFigures, String> {
    let dir = options.out.join(shot.name);
    if options.obj {
        for side in ["plain", "auto"] {
            std::fs::create_dir_all(dir.join(side)).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
    }
    println!("{}: {} vertices, {} frames", shot.name, shot.character.rest.num_vertices(), shot.frames);
    let figures = shots::measure(shot, options.first, |f, input, output| {
        let k = f.frame;
        if options.obj {
            let file = format!("frame_{:04}.obj", k + 1);
            squish_io::write_obj(&dir.join("plain").join(&file), input).map_err(|e| e.to_string())?;
            squish_io::write_obj(&dir.join("auto").join(&file), output).map_err(|e| e.to_string())?;
        }
        println!(
            "  frame {:>3}: {:>8.1} ms, faces {:>5} → {:>5}, moved {:>5.1}%, ΔV/V {:>9.1e}, offset {:>7.2} edges",
            k + 1,
            f.ms,
            f.faces_before,
            f.faces_after,
            100.0 * f.moved,
            f.volume_change,
            f.offset,
        );
        Ok(())
    })?;
    let accelerations: Vec<String> = figures.excess_acceleration.iter().map(|a| format!("{a:.2}")).collect();
    println!(
        "  excess acceleration, frames 2 to {}: {}",
        figures.frames.len().saturating_sub(1),
        accelerations.join(" ")
    );
    Ok(figures)
}

fn main() {
    let options = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(options.threads.max(1)).build_global() {
        eprintln!("threads: {e}");
    }
    let mut list: Vec<CharacterShot> = Vec::new();
    if characters::Pose::ALL.iter().any(|p| wanted(&options, &format!("humanoid-{}", p.name()))) {
        let humanoid = Arc::new(characters::humanoid(options.cell));
        for pose in characters::Pose::ALL {
            let shot = characters::humanoid_shot(humanoid.clone(), pose, options.frames);
            if wanted(&options, shot.name) {
                list.push(shot);
            }
        }
    }
    let glb = options.data.join("rigged").join("CesiumMan.glb");
    for (name, subdivided) in [("cesium-man-walk", false), ("cesium-man-15k-walk", true)] {
        if !wanted(&options, name) {
            continue;
        }
        if !glb.is_file() {
            println!("{name}: skipped, {} not found (--data or SQUISH_DATA)", glb.display());
            continue;
        }
        match characters::cesium_man_walk(&glb, subdivided) {
            Ok(shot) => list.push(shot),
            Err(e) => println!("{name}: skipped, {e}"),
        }
    }
    let mut rows = Vec::new();
    for shot in &list {
        match run(&options, shot) {
            Ok(figures) => rows.push(shots::table_row(&figures)),
            Err(e) => rows.push(format!("| {} | failed: {e} |", shot.name)),
        }
    }
    println!(
        "\n{} thread(s); excess acceleration in mean edges of the first input frame (motion_quality.py)\n",
        options.threads
    );
    println!("{}", shots::TABLE_HEADER);
    for row in rows {
        println!("{row}");
    }
}
