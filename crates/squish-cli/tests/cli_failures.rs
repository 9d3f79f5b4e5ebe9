//! What a shot and a deformation do when part of them fails (issue 28, item 3): a bad frame is
//! recorded and the other frames are still computed and written; a write failure stops the shot
//! with a count of the frames on disk; `deform` writes all of its outputs or none.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec3;
use squish::mesh::shapes;

fn squish() -> Command {
    Command::new(env!("CARGO_BIN_EXE_squish"))
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A ball sequence of 4 frames sinking into a slab (frame `bad`, if any, a corrupt file) and its
/// scene, writing OBJ files.
fn write_sequence_scene(dir: &Path, bad: Option<i64>) -> PathBuf {
    let ball = shapes::icosphere(0.6, 2);
    for frame in 1..=4 {
        let path = dir.join(format!("ball_{frame:04}.obj"));
        if Some(frame) == bad {
            std::fs::write(&path, "v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap();
            continue;
        }
        let mut moved = ball.clone();
        moved.map_positions(|p| p + DVec3::new(0.0, 0.0, 0.6 - 0.05 * frame as f64));
        squish_io::write_mesh(&path, &moved).unwrap();
    }
    let mut slab = shapes::cuboid(DVec3::new(3.0, 3.0, 0.5), 6);
    slab.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&dir.join("slab.obj"), &slab).unwrap();
    let scene = r#"frames = { start = 1, end = 4 }
output = { dir = "out", format = "obj" }

[[objects]]
name = "ball"
mesh = "ball_{frame:04}.obj"

[[objects]]
name = "slab"
mesh = "slab.obj"

[[pairs]]
objects = ["ball", "slab"]
"#;
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    path
}

fn read_report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// The frames of `object` on disk (file stems), sorted; fails on a temporary file left over.
fn frames_on_disk(out: &Path, object: &str) -> Vec<i64> {
    let mut frames: Vec<i64> = std::fs::read_dir(out.join(object))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .inspect(|name| assert!(!name.ends_with(".tmp"), "left over: {name}"))
        .filter_map(|name| name.strip_suffix(".obj").and_then(|s| s.parse().ok()))
        .collect();
    frames.sort();
    frames
}

#[test]
fn a_corrupt_frame_is_recorded_and_the_other_frames_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_sequence_scene(dir.path(), Some(3));
    let out = dir.path().join("out");
    let output = squish().arg("run").arg(&scene).arg("-o").arg(&out).args(["--threads", "2"]).output().unwrap();
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(message.contains("frame 3 failed: ") && message.contains("ball_0003.obj:3"), "{message}");
    assert!(message.contains("1 of 4 frames failed") && message.contains("3 frames written"), "{message}");
    assert!(message.contains("run the frames left: --frames 3:3"), "{message}");
    // The other frames are computed and written, and the report says what failed and why.
    for object in ["ball", "slab"] {
        assert_eq!(frames_on_disk(&out, object), vec![1, 2, 4], "{object}");
    }
    let report = read_report(&out);
    assert_eq!(report["run"]["status"], "failed");
    assert_eq!(report["run"]["missing_frames"], serde_json::json!(["3:3"]));
    let failed = report["run"]["failed_frames"].as_array().unwrap();
    assert_eq!(failed.len(), 1);
    assert_eq!(failed[0]["frame"], 3);
    assert!(failed[0]["error"].as_str().unwrap().contains("ball_0003.obj:3"), "{}", failed[0]);
    let done: Vec<i64> = report["per_frame"].as_array().unwrap().iter().map(|f| f["frame"].as_i64().unwrap()).collect();
    assert_eq!(done, vec![1, 2, 4]);

    // Fixing the file and running the frames the message gave completes the shot.
    write_sequence_scene(dir.path(), None);
    let output = squish().arg("run").arg(&scene).arg("-o").arg(&out).args(["--frames", "3:3"]).output().unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(read_report(&out)["missing_frames"], serde_json::json!([]));
    assert_eq!(frames_on_disk(&out, "ball"), vec![1, 2, 3, 4]);
}

#[test]
fn a_write_failure_stops_the_shot_and_counts_the_frames_on_disk() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_sequence_scene(dir.path(), None);
    let out = dir.path().join("out");
    // A folder where frame 3's file goes: its rename fails (any user, any file system).
    std::fs::create_dir_all(out.join("slab/0003.obj")).unwrap();
    let output = squish().arg("run").arg(&scene).arg("-o").arg(&out).args(["--threads", "1"]).output().unwrap();
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(message.contains("0003.obj") && message.contains("no more frames were started"), "{message}");
    // One thread computes the frames in order: 1 and 2 are whole on disk, 4 was not started.
    assert!(message.contains("2 frames written"), "{message}");
    assert!(message.contains("--frames 3:4"), "{message}");
    assert_eq!(frames_on_disk(&out, "ball"), vec![1, 2, 3]); // frame 3's ball was written before its slab failed
    let report = read_report(&out);
    let done: Vec<i64> = report["per_frame"].as_array().unwrap().iter().map(|f| f["frame"].as_i64().unwrap()).collect();
    assert_eq!(done, vec![1, 2]);
    assert_eq!(report["run"]["missing_frames"], serde_json::json!(["3:4"]));
    assert_eq!(report["run"]["failed_frame"], 3);
}

/// A ball 0.2 deep into a slab, as OBJ files.
fn write_pair(dir: &Path) {
    let mut ball = shapes::icosphere(0.6, 2);
    ball.map_positions(|p| p + DVec3::new(0.0, 0.0, 0.4));
    squish_io::write_mesh(&dir.join("ball.obj"), &ball).unwrap();
    let mut slab = shapes::cuboid(DVec3::new(3.0, 3.0, 0.5), 6);
    slab.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&dir.join("slab.obj"), &slab).unwrap();
}

fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

/// Runs `command` (deform or contact) on the ball and slab with `--preview` twice: first with a
/// folder where its output `blocked` goes and an earlier run's `report` file, which must fail
/// leaving the folder as it was; then without the obstacle, which must write exactly `outputs`.
fn writes_all_of_its_outputs_or_none(command: &str, blocked: &str, report: &str, outputs: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    write_pair(dir.path());
    let out = dir.path().join("out");
    std::fs::create_dir_all(out.join(blocked)).unwrap();
    std::fs::write(out.join(report), "earlier").unwrap();
    let run = || {
        squish()
            .current_dir(dir.path())
            .args([command, "ball.obj", "slab.obj", "-o", "out", "--preview"])
            .output()
            .unwrap()
    };
    let output = run();
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{command}: {message}");
    assert!(message.contains(blocked) && message.contains("nothing was written"), "{command}: {message}");
    // None of the other outputs, no new report, no staging folder left.
    let mut before = vec![report.to_string(), blocked.to_string()];
    before.sort();
    assert_eq!(entries(&out), before, "{command}");
    assert_eq!(std::fs::read_to_string(out.join(report)).unwrap(), "earlier", "{command}");

    std::fs::remove_dir(out.join(blocked)).unwrap();
    let output = run();
    assert!(output.status.success(), "{command}: {}", stderr(&output));
    assert_eq!(entries(&out), outputs.iter().map(|s| s.to_string()).collect::<Vec<_>>(), "{command}");
}

#[test]
fn deform_writes_all_of_its_outputs_or_none() {
    writes_all_of_its_outputs_or_none(
        "deform",
        "slab.obj",
        "report.json",
        &["ball.obj", "preview.png", "report.json", "slab.obj"],
    );
}

#[test]
fn contact_writes_all_of_its_outputs_or_none() {
    writes_all_of_its_outputs_or_none(
        "contact",
        "slab.ply",
        "contact.json",
        &["ball.ply", "boundary_points.ply", "contact.json", "preview.png", "slab.ply"],
    );
}

#[test]
fn an_output_folder_that_cannot_be_created_is_bad_usage_for_every_command() {
    let dir = tempfile::tempdir().unwrap();
    write_pair(dir.path());
    std::fs::write(dir.path().join("taken"), "a file").unwrap();
    let scene = write_sequence_scene(dir.path(), None);
    for out in ["taken", "taken/sub"] {
        let deform =
            squish().current_dir(dir.path()).args(["deform", "ball.obj", "slab.obj", "-o", out]).output().unwrap();
        let run = squish().current_dir(dir.path()).arg("run").arg(&scene).args(["-o", out]).output().unwrap();
        for (command, output) in [("deform", deform), ("run", run)] {
            let message = stderr(&output);
            assert_eq!(output.status.code(), Some(2), "{command} -o {out}: {message}");
            assert!(message.contains(out) && message.contains("-o"), "{command} -o {out}: {message}");
        }
    }
    // A folder nobody may create in (as root too): /sys refuses new entries.
    let refused = Path::new("/sys/kernel/squish-test");
    if Path::new("/sys/kernel").is_dir() && std::fs::create_dir(refused).is_err() {
        let deform = squish()
            .current_dir(dir.path())
            .args(["deform", "ball.obj", "slab.obj", "-o"])
            .arg(refused)
            .output()
            .unwrap();
        let run = squish().current_dir(dir.path()).arg("run").arg(&scene).arg("-o").arg(refused).output().unwrap();
        assert_eq!(deform.status.code(), run.status.code(), "{} / {}", stderr(&deform), stderr(&run));
        assert_eq!(deform.status.code(), Some(2), "{}", stderr(&deform));
        assert!(stderr(&run).contains("choose a folder you can write"), "{}", stderr(&run));
    }
}
