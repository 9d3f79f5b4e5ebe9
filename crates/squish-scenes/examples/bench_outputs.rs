//! Writes the output positions of every bench scene, frame after frame on one deformer, to
//! `DIR/<scene>.<frame>.bin` (little-endian f64 triples, objects in order) and prints a digest
//! per frame: two builds are compared bit for bit by their digests, and by how much they differ
//! from the files (`cargo run --release -p squish-scenes --example bench_outputs -- DIR [quick|full] [FRAMES] [NAMES]`).
#![allow(clippy::unwrap_used)]

use std::io::Write;
use std::path::{Path, PathBuf};

use squish::pipeline::Deformer;
use squish_scenes::bench::{self, BenchScene, BenchSize};

fn data_mesh(name: &str) -> Option<squish::TriMesh> {
    let dir = std::env::var_os("SQUISH_DATA").map_or_else(|| PathBuf::from("../shared/data"), PathBuf::from);
    squish_io::read_obj(&dir.join("meshes").join(name)).ok()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(args.get(1).map_or("bench-outputs", String::as_str));
    let size = if args.get(2).is_some_and(|s| s == "full") { BenchSize::Full } else { BenchSize::Quick };
    let frames: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(3);
    let names: Vec<String> = args.get(4).map(|s| s.split(',').map(str::to_string).collect()).unwrap_or_default();
    std::fs::create_dir_all(&dir).unwrap();
    let mut scenes = bench::procedural_scenes(size);
    if let Some(bunny) = data_mesh("bunny_29834.obj") {
        scenes.push(bench::bunny_jelly(bunny.clone(), size));
        scenes.push(bench::bunny_whole_jelly(bunny, size));
    }
    if let Some(hand) = data_mesh("hand_7993.obj") {
        scenes.push(bench::hand_pillow(hand, size));
    }
    for scene in &scenes {
        if !names.is_empty() && !names.iter().any(|n| scene.name.contains(n.as_str())) {
            continue;
        }
        run(scene, frames, &dir);
    }
}

fn run(scene: &BenchScene, frames: usize, dir: &Path) {
    let mut deformer = Deformer::new();
    for k in 0..frames {
        let pose = scene.pose(BenchScene::frame_time(k, frames));
        let result = deformer.deform(&pose.frame()).unwrap();
        let mut bytes = Vec::new();
        for positions in &result.positions {
            for p in positions {
                for c in p.to_array() {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        let digest =
            bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3));
        std::fs::File::create(dir.join(format!("{}.{k}.bin", scene.name))).unwrap().write_all(&bytes).unwrap();
        let work: Vec<String> = result
            .stats
            .work
            .iter()
            .filter(|(_, w)| **w != squish::stage::Work::default())
            .map(|(s, w)| format!("{s}:{w:?}"))
            .collect();
        println!("{} {k} {digest:016x} {:.2}ms {}", scene.name, result.stats.total.as_secs_f64() * 1e3, work.join(" "));
    }
}
