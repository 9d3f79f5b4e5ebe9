//! What the bench tests share: the bench scenes with the meshes they read from
//! `../shared/data/meshes` (skipped with a note when absent).

use std::path::PathBuf;

use squish_scenes::bench::{self, BenchScene, BenchSize};

/// Every scene of `squish bench` at `size` but the skinned character's, in its order.
pub fn scenes(size: BenchSize) -> Vec<BenchScene> {
    let mut scenes = bench::procedural_scenes(size);
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/meshes");
    let read = |file: &str| squish_io::read_mesh(&data.join(file)).ok();
    let bunny = read(if size == BenchSize::Full { "bunny_29834.obj" } else { "bunny_3301.obj" });
    match bunny {
        Some(bunny) => {
            scenes.push(bench::bunny_jelly(bunny.clone(), size));
            scenes.push(bench::bunny_whole_jelly(bunny, size));
        }
        None => eprintln!("skipped bunny-jelly: ../shared/data/meshes has no bunny"),
    }
    match read("hand_7993.obj") {
        Some(hand) => scenes.push(bench::hand_pillow(hand, size)),
        None => eprintln!("skipped hand-pillow: ../shared/data/meshes/hand_7993.obj is absent"),
    }
    scenes
}
