//! Repeats the bench's edit (`bulge` 1 → 1.2 on every deformable object of the middle frame) on
//! one deformer, for profiling (`cargo run --release -p squish-scenes --example edit_profile --
//! SCENE [EDITS] [full]`; `full`: repeat the full frame instead), with its mean stage times, on
//! `RAYON_NUM_THREADS` threads (1 by default).
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::time::Instant;

use squish::pipeline::Deformer;
use squish_scenes::bench::{self, BenchScene, BenchSize};

fn main() {
    // Inside a pool, as `squish bench` times: a parallel map started from outside one waits on
    // another thread, which a profile would count as the frame's.
    let threads = std::env::var("RAYON_NUM_THREADS").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(profile);
}

fn profile() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).cloned().unwrap_or_else(|| "fingers-ball".into());
    let edits: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(50);
    let full = args.get(3).is_some_and(|s| s == "full");
    let dir = std::env::var_os("SQUISH_DATA").map_or_else(|| PathBuf::from("../shared/data"), PathBuf::from);
    let mesh = |n: &str| squish_io::read_obj(&dir.join("meshes").join(n)).ok();
    let mut scenes = bench::procedural_scenes(BenchSize::Full);
    if let Some(bunny) = mesh("bunny_29834.obj") {
        scenes.push(bench::bunny_jelly(bunny.clone(), BenchSize::Full));
        scenes.push(bench::bunny_whole_jelly(bunny, BenchSize::Full));
    }
    if let Some(hand) = mesh("hand_7993.obj") {
        scenes.push(bench::hand_pillow(hand, BenchSize::Full));
    }
    let scene = scenes.iter().find(|s| s.name == name).unwrap();
    let mut pose = scene.pose(BenchScene::frame_time(4, 9));
    let set = |pose: &mut squish_scenes::procedural::ProceduralScene, bulge: f64| {
        for o in pose.objects.iter_mut().filter(|o| !o.params.rigid) {
            o.params.bulge = bulge;
        }
    };
    let deformer = Deformer::new().without_quality();
    let mut deformer = if full { deformer } else { deformer.keep_for_edits() };
    set(&mut pose, 1.0);
    deformer.deform(&pose.frame()).unwrap();
    set(&mut pose, if full { 1.0 } else { 1.2 });
    let start = Instant::now();
    let mut stages = squish::stage::StageTimes::default();
    for _ in 0..edits {
        let r = deformer.deform(&pose.frame()).unwrap();
        assert_eq!(r.stats.edit, !full);
        stages += &r.stats.stages;
    }
    println!(
        "{name}: {:.3} ms per {}",
        start.elapsed().as_secs_f64() * 1e3 / edits as f64,
        if full { "frame" } else { "edit" }
    );
    for (stage, ms) in stages.millis().iter().filter(|(_, ms)| **ms > 0.0) {
        println!("  {stage:?}: {:.3} ms", ms / edits as f64);
    }
}
