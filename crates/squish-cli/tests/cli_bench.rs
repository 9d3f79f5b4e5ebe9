//! `squish bench --quick --json` end to end: it runs and its JSON is complete and consistent.
//! Performance targets are read in the bench output, never asserted here.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;
use squish::stage::{Stage, StageWork};

/// Every row of the table, in order.
const SCENES: [&str; 17] = [
    "fingers-ball",
    "fingers-palm",
    "sphere-plane",
    "small-big-spheres",
    "bunny-jelly",
    "bunny-whole-jelly",
    "feet-plane",
    "hat-egg",
    "hand-pillow",
    "stress-100k",
    "press-100k",
    "press-100k-automatic",
    "cesium-man-walk",
    "cesium-man-15k-walk",
    "humanoid-squat",
    "humanoid-crouch",
    "humanoid-arms-crossed",
];

fn shared_data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
}

fn bench_json(extra: &[&str]) -> Value {
    let output = Command::new(env!("CARGO_BIN_EXE_squish"))
        .args(["bench", "--quick", "--json", "--frames", "2", "--shot-frames", "4", "--threads", "2"])
        .arg("--data")
        .arg(shared_data())
        .args(extra)
        .output()
        .expect("run squish bench");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("valid JSON on stdout")
}

fn number(value: &Value, what: &str) -> f64 {
    value.as_f64().unwrap_or_else(|| panic!("{what} is not a number: {value}"))
}

#[test]
fn quick_bench_reports_every_scene_with_consistent_figures() {
    let report = bench_json(&[]);
    let scenes = report["scenes"].as_array().expect("scenes");
    let names: Vec<&str> = scenes.iter().map(|s| s["name"].as_str().expect("name")).collect();
    assert_eq!(names, SCENES);
    let data_present = shared_data().join("meshes/bunny_3301.obj").is_file();
    // Scenes whose named stages explain less than 70% of the median frame (see below).
    let mut thin_coverage = Vec::new();
    for scene in scenes {
        let name = scene["name"].as_str().unwrap_or_default();
        assert!(scene["error"].is_null(), "{name}: {}", scene["error"]);
        match name {
            "cesium-man-walk" => {
                check_self_contact_row(scene, 48, true, true);
                continue;
            }
            // Issue 36's test characters: their figures are the new algorithm's targets, not
            // the bench's, so frames worse than the input are allowed here.
            "cesium-man-15k-walk" => {
                check_self_contact_row(scene, 4, true, false);
                continue;
            }
            _ if name.starts_with("humanoid-") => {
                check_self_contact_row(scene, 8, false, false);
                continue;
            }
            _ => {}
        }
        if !scene["skipped"].is_null() {
            assert!(!data_present, "{name} skipped although the shared data is present: {}", scene["skipped"]);
            assert!(scene["skipped"].as_str().is_some_and(|s| s.contains("not found")), "{name}");
            continue;
        }
        for run in ["single", "multi"] {
            let r = &scene[run];
            let median = number(&r["median_ms"], "median_ms");
            assert!(median > 0.0, "{name} {run}: median {median}");
            assert!(number(&r["min_ms"], "min_ms") <= median && median <= number(&r["max_ms"], "max_ms"));
            assert_eq!(r["frame_ms"].as_array().map(Vec::len), Some(2), "{name} {run}");
            assert!(number(&r["numeric_factorizations_per_frame"], "factorizations") >= 3.0, "{name} {run}");
            // Caches are reused: the timed frames run no symbolic analysis, except where automatic
            // working regions follow the moving contact (a region whose face set changes is
            // rebuilt, at most one analysis per region and frame).
            if name.ends_with("-automatic") {
                assert!(number(&r["symbolic_analyses_timed_frames"], "analyses") <= 2.0 * 2.0, "{name} {run}");
            } else {
                assert_eq!(r["symbolic_analyses_timed_frames"], 0, "{name} {run}");
            }
        }
        // The single-thread breakdown adds up to the frame: stages are disjoint in time, so the
        // named stages cannot exceed the total, and what they miss (zone gathering, statistics)
        // is small.
        let single = &scene["single"];
        let total = number(&single["median_ms"], "median_ms");
        let b = &single["breakdown_ms"];
        let stages: Vec<&str> = Stage::spans().map(Stage::name).collect();
        let named: f64 = stages.iter().map(|k| number(&b[*k], k)).sum();
        assert!(stages.iter().all(|k| number(&b[*k], k) >= 0.0), "{name}: {b}");
        assert!(named <= total * 1.001 + 1e-6, "{name}: stages {named} ms > frame {total} ms");
        if named < 0.7 * total {
            thin_coverage.push(name.to_string());
        }
        assert!((named + number(&b["other"], "other") - total).abs() <= 1e-6 * total.max(1.0), "{name}");
        let percent = &single["breakdown_percent"];
        let shares: f64 = stages.iter().chain(&["other"]).map(|k| number(&percent[*k], k)).sum();
        assert!((shares - 100.0).abs() < 1e-6, "{name}: shares sum to {shares}");
        let factorization_share = number(&percent["factorization"], "factorization share");
        assert!(factorization_share > 0.0 && factorization_share <= 100.0, "{name}: {factorization_share}");
        // The reference factorization and the ratios.
        let f = &scene["factorization"];
        assert!(number(&f["numeric_ms"], "numeric_ms") > 0.0, "{name}");
        assert!(number(&f["factor_nonzeros"], "factor_nonzeros") >= number(&f["matrix_nonzeros"], "matrix_nonzeros"));
        assert!(number(&scene["frame_over_factorization"], "ratio") > 0.0, "{name}");
        if scene["thesis"].is_null() {
            assert!(scene["stages_over_thesis"].is_null() && scene["outside_thesis_columns_ms"].is_null(), "{name}");
        } else {
            let thesis = &scene["thesis"];
            assert!(number(&scene["thesis_ratio"], "thesis ratio") > 0.0, "{name}");
            // Stage by stage: our median frame's ms over the thesis' ms (its % of its total), in
            // the thesis' columns (ours but setup and regions) and its factorization column.
            let thesis_columns: Vec<&str> = Stage::spans().filter(|s| s.in_thesis_tables()).map(Stage::name).collect();
            let columns = thesis_columns.iter().copied().chain([Stage::Factorization.name()]);
            let thesis_stages = &thesis["stages_ms"];
            let ratios = &scene["stages_over_thesis"];
            let thesis_sum: f64 = thesis_columns.iter().map(|k| number(&thesis_stages[*k], k)).sum();
            let thesis_ms = number(&thesis["ms"], "thesis ms");
            assert!((thesis_sum / thesis_ms - 1.0).abs() <= 0.0105, "{name}: the thesis' stages sum to {thesis_sum}");
            for column in columns {
                match (thesis_stages[column].as_f64(), ratios[column].as_f64()) {
                    (Some(t), Some(r)) if t > 0.0 => {
                        let ours = number(&b[column], column);
                        assert!((r - ours / t).abs() <= 1e-9 * r.abs().max(1.0), "{name} {column}: {r} ≠ {ours}/{t}");
                    }
                    // No thesis figure (table 7.1 has no factorization column) or a 0 % stage.
                    (t, None) => assert!(t.is_none_or(|t| t == 0.0), "{name} {column}"),
                    (t, r) => panic!("{name} {column}: thesis {t:?}, ratio {r:?}"),
                }
            }
            let outside =
                Stage::spans().filter(|s| !s.in_thesis_tables()).map(|s| number(&b[s.name()], s.name())).sum::<f64>()
                    + number(&b["other"], "other");
            let reported = number(&scene["outside_thesis_columns_ms"], "outside");
            assert!((reported - outside).abs() <= 1e-9 * outside.abs().max(1.0), "{name}");
        }
        let working = scene["working"].as_array().expect("working");
        assert!(working.iter().all(|w| w.as_u64().is_some()), "{name}");
        if let Some(peak) = scene["peak_memory_mb"].as_f64() {
            assert!(peak > 0.0, "{name}");
        }
    }
    assert_eq!(report["rounds"], 1);
    let shot = &report["shot"];
    assert_eq!(shot["frames"], 4);
    assert!(number(&shot["single_fps"], "single fps") > 0.0 && number(&shot["multi_fps"], "multi fps") > 0.0);
    assert_eq!(report["machine_before"]["threads"], 2);
    // The frames are wall-clock times of two frames, measured while the other tests of this file
    // run too: a thread descheduled for a time slice (a few ms) between two stages puts a whole
    // slice into "other". A stage left out of the breakdown shows in every measurement, so a
    // scene that fails the check is measured once more and must pass then.
    if !thin_coverage.is_empty() {
        let again = bench_json(&["--scenes", &thin_coverage.join(",")]);
        for scene in again["scenes"].as_array().expect("scenes") {
            let name = scene["name"].as_str().unwrap_or_default();
            let single = &scene["single"];
            let total = number(&single["median_ms"], "median_ms");
            let b = &single["breakdown_ms"];
            let other = number(&b["other"], "other");
            assert!(other <= 0.3 * total, "{name}: stages explain too little of {total} ms (other {other} ms), twice");
        }
    }
}

#[test]
fn rounds_report_the_median_round_and_every_round() {
    let report = bench_json(&["--rounds", "3", "--scenes", "sphere-plane"]);
    assert_eq!(report["rounds"], 3);
    let scenes = report["scenes"].as_array().expect("scenes");
    assert_eq!(scenes.len(), 1);
    let scene = &scenes[0];
    let rounds = &scene["rounds"];
    let values =
        |key: &str| -> Vec<f64> { rounds[key].as_array().expect(key).iter().map(|v| number(v, key)).collect() };
    let (single, multi, factorization) = (values("single_ms"), values("multi_ms"), values("factorization_ms"));
    assert!(single.len() == 3 && multi.len() == 3 && factorization.len() == 3, "{rounds}");
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[1]
    };
    // The reported runs are the median rounds, each of its own figure.
    assert_eq!(number(&scene["single"]["median_ms"], "single"), median(&single));
    assert_eq!(number(&scene["multi"]["median_ms"], "multi"), median(&multi));
    assert_eq!(number(&scene["factorization"]["numeric_ms"], "factorization"), median(&factorization));
    let fastest = number(&rounds["single_fastest_ms"], "fastest");
    assert_eq!(fastest, single.iter().copied().fold(f64::INFINITY, f64::min));
    let thesis_ms = number(&scene["thesis"]["ms"], "thesis ms");
    assert!((number(&scene["thesis_ratio"], "ratio") - median(&single) / thesis_ms).abs() < 1e-12);
    assert!((number(&rounds["fastest_thesis_ratio"], "fastest ratio") - fastest / thesis_ms).abs() < 1e-12);
    let shot = &report["shot"];
    let shot_single: Vec<f64> =
        shot["single_seconds_per_round"].as_array().expect("shot rounds").iter().map(|v| number(v, "s")).collect();
    assert_eq!(shot_single.len(), 3);
    assert!((number(&shot["single_seconds"], "shot") - median(&shot_single)).abs() < 1e-9);
}

/// A row of a character with self-contact (CesiumMan's, skipped without
/// `rigged/CesiumMan.glb` when `needs_data`): `frames` frames with self-contact, no edit (never
/// an edit with self-contact), every frame's figures consistent and grouped by touching part
/// pairs, and with `no_worse` no frame worse than the input; for CesiumMan's walk, the work
/// guard of its self-contact. The breakdown checks of the other rows do not apply (its stages
/// are the self-contact level's).
fn check_self_contact_row(scene: &Value, count: usize, needs_data: bool, no_worse: bool) {
    if needs_data && !shared_data().join("rigged/CesiumMan.glb").is_file() {
        assert!(scene["skipped"].as_str().is_some_and(|s| s.contains("not found")), "{scene}");
        return;
    }
    assert!(scene["skipped"].is_null(), "{}", scene["skipped"]);
    assert!(number(&scene["single"]["median_ms"], "median_ms") > 0.0);
    assert!(scene["edit"].is_null());
    let growth = &scene["self_contact"];
    let frames = growth["frames"].as_array().expect("self_contact.frames");
    assert_eq!(frames.len(), count);
    for (k, f) in frames.iter().enumerate() {
        assert_eq!(f["frame"], k);
        let ms = number(&f["ms"], "ms");
        assert!(number(&f["pairs_in_contact"], "in contact") <= number(&f["touching_pairs"], "touching"), "{f}");
        assert!(number(&f["part_pairs_ms"], "part ms") + number(&f["articulations_ms"], "art. ms") <= ms, "{f}");
        let faces = f["faces"].as_array().expect("faces");
        assert!(
            !no_worse || number(&faces[1], "after") <= number(&faces[0], "before"),
            "no frame worse than the input: {f}"
        );
    }
    let groups = growth["by_touching_pairs"].as_array().expect("by_touching_pairs");
    let counts: Vec<f64> = groups.iter().map(|g| number(&g["touching_pairs"], "pairs")).collect();
    assert!(counts.windows(2).all(|w| w[0] < w[1]), "{counts:?}");
    let grouped: f64 = groups.iter().map(|g| number(&g["frames"], "frames")).sum();
    assert_eq!(grouped, count as f64);
    // CesiumMan's walk always has a pair of parts touching (the legs, the arms against the torso).
    assert!(!needs_data || counts[0] >= 1.0, "{counts:?}");
    if scene["name"] == "cesium-man-walk" {
        guard_self_contact_work(scene);
    }
}

/// The work guard of the walk (the bounds of `squish_scenes::work_guard`): every self-contact
/// step counts its work, the same on one and two threads, within the committed figures
/// (`tests/cesium_man_work.json`, the `--frames 2` run of [`bench_json`]; rewritten with
/// `SQUISH_WRITE_WORK_FIGURES=1`, saying why in the commit).
fn guard_self_contact_work(scene: &Value) {
    assert_eq!(scene["same_work_across_threads"], true, "{}", scene["multi"]["work_timed_frames"]);
    let work: StageWork =
        serde_json::from_value(scene["single"]["work_timed_frames"].clone()).expect("work_timed_frames");
    // (`setup` asks nothing at the timed frames: its rest-pose caches are the first frame's, and
    // the articulations' interior flags are asked by chapter 4, in its stages.)
    for stage in [Stage::PartContacts, Stage::Quality] {
        assert!(work[stage].queries + work[stage].rows > 0, "{stage}: no work counted: {:?}", work[stage]);
    }
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/cesium_man_work.json");
    if std::env::var_os("SQUISH_WRITE_WORK_FIGURES").is_some() {
        let json = serde_json::to_string_pretty(&work).expect("figures");
        std::fs::write(&path, json + "\n").expect("write the figures");
        return;
    }
    let committed: StageWork =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("committed figures")).expect("figures");
    let failures = squish_scenes::work_guard::departures("cesium-man-walk", &committed, &work);
    assert!(
        failures.is_empty(),
        "work outside the committed figures (if meant, rewrite them with SQUISH_WRITE_WORK_FIGURES=1 and say why):\n{}",
        failures.join("\n")
    );
}

#[test]
fn missing_data_skips_the_file_scenes_with_a_note_and_the_table_prints() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let output = Command::new(env!("CARGO_BIN_EXE_squish"))
        .args(["bench", "--quick", "--frames", "1", "--shot-frames", "1", "--scenes", "bunny,sphere-plane,cesium"])
        .arg("--data")
        .arg(dir.path())
        .output()
        .expect("run squish bench");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let table = String::from_utf8_lossy(&output.stdout);
    assert!(table.contains("sphere-plane"), "{table}");
    assert!(table.contains("bunny-jelly") && table.contains("not found"), "{table}");
    assert!(table.lines().any(|l| l.starts_with("cesium-man-walk") && l.contains("not found")), "{table}");
    assert!(table.contains("shot: 1 frames of small-big-spheres"), "{table}");
    assert!(table.contains("--quick: smaller scenes than the thesis'"), "a quick table warns: {table}");
}

#[test]
fn bad_arguments_are_usage_errors() {
    for args in [
        &["bench", "--frames", "0"][..],
        &["bench", "--threads", "0"],
        &["bench", "--rounds", "0"],
        &["bench", "--quick", "--shot", "nope"],
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_squish")).args(args).output().expect("run squish bench");
        assert_eq!(output.status.code(), Some(2), "{args:?}: {}", String::from_utf8_lossy(&output.stderr));
    }
}
