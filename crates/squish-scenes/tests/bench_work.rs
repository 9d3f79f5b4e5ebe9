//! The work guard (issue 37, target 6): a clock-free check of what every stage of a frame does.
//!
//! Each quick bench scene runs as `squish bench --quick` times it ([`BenchScene::animate`]: a
//! warm-up frame, then [`FRAMES`] frames), and the work of each stage ([`squish::stage::Work`]:
//! spatial queries, triangle tests, rounds, rows solved, factorization multiply-adds), summed over
//! the timed frames, is compared with the figures committed in `bench_work.json` — the same
//! figures `squish bench --quick --json` reports as `work_timed_frames` of its single-thread run.
//! The counts are deterministic (the same on any machine and thread count), so the guard needs no
//! clock; it allows [`squish_scenes::work_guard::RATIO`] either way plus a small absolute slack per kind, so that a change
//! which multiplies a stage's work fails, and one that removes work asks for the figures to be
//! brought down with it.
//!
//! A change that means to cost more (or less) writes new figures with
//! `SQUISH_WRITE_WORK_FIGURES=1 cargo test -p squish-scenes --test bench_work` and says why in
//! its commit. The scenes that read a mesh from `../shared/data` are skipped with a note when it is
//! absent; the skinned character's walk is guarded by `squish-cli/tests/cli_bench.rs` (its scene is
//! posed from a file by the CLI), with the same bounds ([`squish_scenes::work_guard`]).
#![allow(clippy::unwrap_used)]

mod common;

use std::collections::BTreeMap;
use std::path::PathBuf;

use squish::stage::{Stage, StageWork, Work};
use squish_scenes::bench::{BenchScene, BenchSize};
use squish_scenes::work_guard::departures;

/// Timed frames per scene: those of `squish bench --quick`.
const FRAMES: usize = 3;
fn figures_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/bench_work.json")
}

/// The work of each stage of `scene`, summed over its timed frames.
fn scene_work(scene: &BenchScene) -> StageWork {
    let mut total = StageWork::default();
    scene.animate(FRAMES, |_, _| {}, |_, result, _| total += &result.stats.work).unwrap();
    total
}

#[test]
fn every_stage_of_the_quick_bench_scenes_does_the_work_committed() {
    let scenes = common::scenes(BenchSize::Quick);
    let measured: BTreeMap<String, StageWork> = scenes.iter().map(|s| (s.name.to_string(), scene_work(s))).collect();
    if std::env::var_os("SQUISH_WRITE_WORK_FIGURES").is_some() {
        let json = serde_json::to_string_pretty(&measured).unwrap();
        std::fs::write(figures_path(), json + "\n").unwrap();
        eprintln!("wrote {}", figures_path().display());
        return;
    }
    let text = std::fs::read_to_string(figures_path()).unwrap();
    let committed: BTreeMap<String, StageWork> = serde_json::from_str(&text).unwrap();
    let mut failures = Vec::new();
    for (name, actual) in &measured {
        match committed.get(name) {
            Some(expected) => failures.extend(departures(name, expected, actual)),
            None => failures.push(format!("{name}: no committed figures")),
        }
        // A stage that does work must count some: the whole frame is never silent.
        let total = actual.iter().fold(Work::ZERO, |mut sum, (_, w)| {
            sum += *w;
            sum
        });
        assert!(total.queries > 0 && total.rows > 0, "{name}: {total:?}");
    }
    for name in committed.keys().filter(|n| !measured.contains_key(*n)) {
        eprintln!("not run here: {name}");
    }
    assert!(
        failures.is_empty(),
        "work outside the committed figures (if meant, rewrite them with SQUISH_WRITE_WORK_FIGURES=1 and say why):\n{}",
        failures.join("\n")
    );
}

/// Every timed frame's work and output positions of `scene` on a pool of `threads` threads.
fn frames_on(scene: &BenchScene, threads: usize) -> Vec<(StageWork, Vec<Vec<glam::DVec3>>)> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let mut frames = Vec::new();
    pool.install(|| {
        scene.animate(FRAMES, |_, _| {}, |_, result, _| frames.push((result.stats.work, result.positions)))
    })
    .unwrap();
    frames
}

#[test]
fn the_work_and_the_outputs_are_the_same_on_one_and_two_threads() {
    // Every scene: regions factorized in parallel share their submatrix analyses, automatic
    // regions, contacts, open sides' winding numbers and the separation pass run parallel tasks.
    for scene in common::scenes(BenchSize::Quick) {
        let (one, two) = (frames_on(&scene, 1), frames_on(&scene, 2));
        assert_eq!(one.len(), two.len());
        for (k, ((work_1, positions_1), (work_2, positions_2))) in one.iter().zip(&two).enumerate() {
            for stage in Stage::ALL {
                assert_eq!(work_1[stage], work_2[stage], "{}, frame {k}, {stage}", scene.name);
            }
            let bits = |p: &Vec<Vec<glam::DVec3>>| -> Vec<u64> {
                p.iter().flatten().flat_map(|x| x.to_array().map(f64::to_bits)).collect()
            };
            assert!(bits(positions_1) == bits(positions_2), "{}, frame {k}: the outputs differ", scene.name);
        }
    }
}

#[test]
fn the_guard_fails_a_stage_whose_work_doubles_and_passes_small_moves() {
    let mut expected = StageWork::default();
    expected[Stage::Separation] = Work { queries: 10_000, triangle_tests: 50_000, rounds: 6, rows: 3000, flops: 0 };
    let mut close = expected;
    close[Stage::Separation].queries = 11_000;
    close[Stage::Separation].rounds = 7;
    assert!(departures("s", &expected, &close).is_empty());
    let mut doubled = expected;
    doubled[Stage::Separation].queries = 20_000;
    let lines = departures("s", &expected, &doubled);
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].contains("separation: queries 20000"), "{lines:?}");
    let mut more_rounds = expected;
    more_rounds[Stage::Separation].rounds = 24;
    assert_eq!(departures("s", &expected, &more_rounds).len(), 1);
}
