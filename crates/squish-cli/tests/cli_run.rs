//! `squish run` end to end: procedural meshes written to a temporary folder, a scene file with a
//! keyframed translation, and the properties a render farm relies on — identical files whatever
//! the threads and the split, continuity through first contact, clean errors, clean Ctrl-C,
//! pictures that show the objects.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use glam::DVec3;
use squish::mesh::shapes;

fn squish() -> Command {
    Command::new(env!("CARGO_BIN_EXE_squish"))
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A unit ball (icosphere with `subdivisions`) at the origin and a 4 × 4 × 0.5 slab whose top
/// is at z = 0, as OBJ files in `dir`.
fn write_meshes(dir: &Path, subdivisions: u32) {
    squish_io::write_mesh(&dir.join("ball.obj"), &shapes::icosphere(1.0, subdivisions)).unwrap();
    let mut ground = shapes::cuboid(DVec3::new(4.0, 4.0, 0.5), 10);
    ground.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&dir.join("ground.obj"), &ground).unwrap();
}

/// A scene where the ball starts 0.15 above the ground and moves down at constant speed to
/// 0.25 deep at the last frame (first contact around a third of the way).
fn write_scene(dir: &Path, frames: i64, format: &str) -> PathBuf {
    let scene = format!(
        r#"frames = {{ start = 1, end = {frames}, fps = 24 }}
output = {{ dir = "out", format = "{format}" }}

[[objects]]
name = "ball"
mesh = "ball.obj"
transform = {{ translate = [[1, [0, 0, 1.15]], [{frames}, [0, 0, 0.75]]] }}

[[objects]]
name = "ground"
mesh = "ground.obj"
stiffness = 2.0

[[pairs]]
objects = ["ball", "ground"]
"#
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    path
}

fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let output = squish().arg("run").arg(scene).arg("-o").arg(out).args(extra).output().unwrap();
    assert!(output.status.success(), "{extra:?}: {}", stderr(&output));
    output
}

/// Every mesh file under `dir` (relative path → bytes).
fn mesh_files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    for object in std::fs::read_dir(dir).unwrap() {
        let object = object.unwrap().path();
        if !object.is_dir() || object.ends_with("preview") {
            continue;
        }
        for file in std::fs::read_dir(&object).unwrap() {
            let file = file.unwrap().path();
            files.insert(file.strip_prefix(dir).unwrap().to_path_buf(), std::fs::read(&file).unwrap());
        }
    }
    files
}

fn read_report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn frames_are_bit_identical_whatever_the_threads_and_the_split() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 3);
    let scene = write_scene(dir.path(), 48, "ply");
    let (parallel, sequential, split) = (dir.path().join("p"), dir.path().join("s"), dir.path().join("split"));
    run(&scene, &parallel, &["--threads", "2"]);
    run(&scene, &sequential, &["--threads", "1"]);
    run(&scene, &split, &["--frames", "1:20", "--threads", "2"]);
    run(&scene, &split, &["--frames", "21:48", "--threads", "2"]);

    let reference = mesh_files(&parallel);
    assert_eq!(reference.len(), 2 * 48, "{:?}", reference.keys().collect::<Vec<_>>());
    assert!(reference.contains_key(Path::new("ball/0048.ply")));
    for other in [&sequential, &split] {
        let files = mesh_files(other);
        assert_eq!(files.keys().collect::<Vec<_>>(), reference.keys().collect::<Vec<_>>());
        for (path, bytes) in &reference {
            assert!(files[path] == *bytes, "{} differs in {}", path.display(), other.display());
        }
    }
    // The shot is not trivial: the ball reaches the ground and both objects deform.
    let report = read_report(&parallel);
    let deformed = |name: &str| {
        report["per_frame"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|f| f["objects"].as_array().unwrap().iter().any(|o| o["name"] == name && o["deformed"] == true))
            .count()
    };
    assert!(deformed("ball") > 20 && deformed("ground") > 20, "{} {}", deformed("ball"), deformed("ground"));
    // Outputs keep the input's vertex count and triangles.
    let ball_in = squish_io::read_mesh(&dir.path().join("ball.obj")).unwrap();
    let ball_out = squish_io::read_mesh(&parallel.join("ball/0048.ply")).unwrap();
    assert_eq!(ball_out.triangles, ball_in.triangles);
    // Each part keeps its own report, and report.json merges them: every frame, none missing.
    for part in ["report.1-20.json", "report.21-48.json"] {
        assert!(split.join(part).is_file(), "{part}");
    }
    let report = read_report(&split);
    assert_eq!((report["frames"]["start"].as_i64(), report["frames"]["end"].as_i64()), (Some(1), Some(48)));
    assert_eq!(report["per_frame"].as_array().unwrap().len(), 48);
    assert_eq!(report["missing_frames"], serde_json::json!([]));
    assert_eq!(report["summary"]["frames_computed"], 48);
}

/// A shot split into parts in the formats holding every frame: each part writes
/// `<object>.A-B.<ext>`, and the run that completes the shot merges the folder's parts into the
/// files an unsplit run writes, byte for byte (squish-shot's tests check glTF assets frame by
/// frame).
#[test]
fn split_shots_merge_into_the_unsplit_files() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 2);
    let scene = write_scene(dir.path(), 12, "obj");
    for format in ["pc2", "glb"] {
        let (whole, split) = (dir.path().join(format!("whole_{format}")), dir.path().join(format!("split_{format}")));
        run(&scene, &whole, &["--format", format]);
        for (k, frames) in ["1:5", "6:6", "7:12"].into_iter().enumerate() {
            let output = run(&scene, &split, &["--format", format, "--frames", frames]);
            let stdout = String::from_utf8_lossy(&output.stdout);
            assert_eq!(stdout.contains("merged the parts"), k == 2, "{stdout}");
            assert_eq!(stdout.contains("frames 7:12 missing"), k == 1, "{stdout}");
        }
        for object in ["ball", "ground"] {
            let file = format!("{object}.{format}");
            assert!(split.join(format!("{object}.6-6.{format}")).is_file());
            let (a, b) = (std::fs::read(whole.join(&file)).unwrap(), std::fs::read(split.join(&file)).unwrap());
            assert!(a == b, "{file}: merged parts differ from the unsplit run's");
        }
        let report = read_report(&split);
        assert_eq!(report["missing_frames"], serde_json::json!([]));
        assert_eq!(report["outputs"]["merged_files"].as_array().map(Vec::len), Some(2), "{}", report["outputs"]);
    }
}

#[test]
fn frame_to_frame_steps_follow_the_input_through_first_contact() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 3);
    let scene = write_scene(dir.path(), 48, "obj");
    let out = dir.path().join("out");
    let output = run(&scene, &out, &["--threads", "2"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("48 frames") && stdout.contains("max |ΔV/V|"), "{stdout}");

    let report = read_report(&out);
    assert_eq!(report["run"]["status"], "complete");
    let frames = report["per_frame"].as_array().unwrap();
    assert_eq!(frames.len(), 48);
    let ball =
        |f: &serde_json::Value| f["objects"].as_array().unwrap().iter().find(|o| o["name"] == "ball").cloned().unwrap();
    let in_contact: Vec<bool> = frames.iter().map(|f| f["pairs"][0]["in_contact"].as_bool().unwrap()).collect();
    let first_contact = in_contact.iter().position(|&c| c).expect("the ball reaches the ground");
    assert!(first_contact > 5 && in_contact[first_contact..].iter().all(|&c| c), "{in_contact:?}");
    assert!(ball(&frames[0])["output_step"].is_null(), "no step into the first frame");
    let step = 0.4 / 47.0;
    for f in &frames[1..] {
        let b = ball(f);
        let (output_step, input_step) = (b["output_step"].as_f64().unwrap(), b["input_step"].as_f64().unwrap());
        assert!((input_step - step).abs() < 1e-9, "frame {}: input step {input_step}", f["frame"]);
        assert!(output_step <= 5.0 * input_step, "frame {}: output step {output_step} vs {input_step}", f["frame"]);
        let volume = b["relative_volume_change"].as_f64().unwrap();
        assert!(volume.abs() < 1e-9, "frame {}: volume change {volume}", f["frame"]);
    }
    // The frames around first contact, where vertices enter the contact zone, are covered.
    let around = &frames[first_contact - 1..=first_contact + 1];
    assert!(around.iter().all(|f| ball(f)["output_step"].as_f64().is_some()));
    let summary = &report["summary"];
    assert!(summary["max_step_ratio"]["value"].as_f64().unwrap() <= 5.0);
    assert!(summary["max_penetration_ratio"]["value"].as_f64().unwrap() < 0.2);
    assert!(summary["frames_per_second"].as_f64().unwrap() > 0.0);
    for plot in ["quality.svg", "quality.png"] {
        assert!(std::fs::metadata(out.join(plot)).unwrap().len() > 1000, "{plot}");
    }
}

#[test]
fn a_missing_sequence_frame_is_an_error_naming_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    let ball = shapes::icosphere(1.0, 1);
    for frame in [1, 2, 4, 5] {
        squish_io::write_mesh(&dir.path().join(format!("ball_{frame:04}.obj")), &ball).unwrap();
    }
    squish_io::write_mesh(&dir.path().join("ground.obj"), &shapes::cube(1.0, 2)).unwrap();
    let scene = dir.path().join("seq.toml");
    std::fs::write(
        &scene,
        "frames = { start = 1, end = 5 }\n[[objects]]\nname = \"ball\"\nmesh = \"ball_{frame:04}.obj\"\n[[objects]]\nname = \"ground\"\nmesh = \"ground.obj\"\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = squish().arg("run").arg(&scene).arg("-o").arg(&out).output().unwrap();
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(message.contains("frame 3") && message.contains("ball_0003.obj"), "{message}");
    assert!(!out.exists(), "nothing is written before the check");
    // A dry run lists the missing file and succeeds.
    let output = squish().arg("run").arg(&scene).arg("--dry-run").output().unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let listing = String::from_utf8_lossy(&output.stdout);
    assert!(listing.contains("frame 3") && listing.contains("objects:") && listing.contains("ball"), "{listing}");
}

#[test]
fn a_misspelled_key_is_an_error_naming_the_key_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 1);
    let scene = dir.path().join("typo.toml");
    std::fs::write(
        &scene,
        "frames = { start = 1, end = 3 }\n\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\nstifness = 2.0\n",
    )
    .unwrap();
    let output = squish().arg("run").arg(&scene).output().unwrap();
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(
        message.contains("typo.toml:6") && message.contains("stifness") && message.contains("stiffness"),
        "{message}"
    );
    assert!(!message.contains("panicked"), "{message}");
}

/// Method A's ball testing against a rigid ground and an automatic working region on the ball
/// run through `squish run`; a ball pair without a rigid side and bad arguments are clean errors.
#[test]
fn ball_testing_and_working_regions_run_and_bad_arguments_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 3);
    let scene = write_scene(dir.path(), 4, "obj");
    let text = std::fs::read_to_string(&scene).unwrap() + "contact_method = \"ball\"\nball_radius = 0.1\n";
    let ball = dir.path().join("ball_method.toml");
    let method_a = text
        .replace("stiffness = 2.0", "rigid = true")
        .replace("mesh = \"ball.obj\"", "mesh = \"ball.obj\"\nregion = \"distance\"\nregion_distance = 0.6");
    std::fs::write(&ball, method_a).unwrap();
    let out = dir.path().join("ball_out");
    run(&ball, &out, &[]);
    let report = read_report(&out);
    let last = &report["per_frame"][3];
    assert_eq!(last["pairs"][0]["in_contact"], true, "{last}");
    let ratio = last["pairs"][0]["penetration_ratio"].as_f64().unwrap();
    assert!(ratio < 0.05, "residual penetration {ratio} of the input's");
    let volume = last["objects"][0]["relative_volume_change"].as_f64().unwrap();
    assert!(volume.abs() < 1e-9, "volume change {volume}");

    // Ball testing needs a rigid side: the library's error names the pair.
    let both_soft = dir.path().join("both_soft.toml");
    std::fs::write(&both_soft, &text).unwrap();
    let output = squish().arg("run").arg(&both_soft).arg("-o").arg(dir.path().join("soft_out")).output().unwrap();
    assert!(!output.status.success());
    assert!(stderr(&output).contains("rigid") && stderr(&output).contains("ground"), "{}", stderr(&output));
    for args in [&["--frames", "3:9"][..], &["--threads", "0"], &["--preview=7"]] {
        let output = squish().arg("run").arg(&scene).args(args).output().unwrap();
        assert_eq!(output.status.code(), Some(2), "{args:?}: {}", stderr(&output));
    }
}

/// The README's example scene runs: frames around the deepest press, clean contact, volume kept.
#[test]
fn the_example_scene_runs() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/press/press.toml");
    let dir = tempfile::tempdir().unwrap();
    run(&scene, dir.path(), &["--frames", "22:26"]);
    let summary = &read_report(dir.path())["summary"];
    assert_eq!(summary["frames_computed"], 5);
    assert!(summary["max_volume_change"]["value"].as_f64().unwrap() < 1e-9, "{summary}");
    assert!(summary["max_penetration_ratio"]["value"].as_f64().unwrap() < 0.05, "{summary}");
    assert!(summary["max_step_ratio"]["value"].as_f64().unwrap() < 3.0, "{summary}");
}

#[test]
fn ctrl_c_stops_cleanly_with_a_report_of_the_frames_done() {
    stops_cleanly_on("INT", 130);
}

/// What a job scheduler sends (`kill`, a farm's time limit): handled like Ctrl-C.
#[test]
fn sigterm_stops_cleanly_with_a_report_of_the_frames_done() {
    stops_cleanly_on("TERM", 143);
}

/// A closed terminal or SSH session: handled like Ctrl-C.
#[test]
fn sighup_stops_cleanly_with_a_report_of_the_frames_done() {
    stops_cleanly_on("HUP", 129);
}

/// Sends `signal` to a running `squish run` once its first frame is written: it exits with
/// `code` (128 + the signal) after the frames in progress, its report lists the frames done and
/// the missing ones, exactly the frames reported are on disk and no temporary file is left.
fn stops_cleanly_on(signal: &str, code: i32) {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 3);
    let scene = write_scene(dir.path(), 400, "obj");
    let out = dir.path().join("out");
    let child = squish()
        .arg("run")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(["--threads", "2"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Signal once work is under way (the handler is installed before the first frame).
    let start = Instant::now();
    while !out.join("ball/0001.obj").exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "no frame written");
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap();
    assert!(status.success());
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(code), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(message.contains("interrupted") && message.contains("--frames"), "{message}");

    let report = read_report(&out);
    assert_eq!(report["run"]["status"], "interrupted");
    let done: Vec<i64> = report["per_frame"].as_array().unwrap().iter().map(|f| f["frame"].as_i64().unwrap()).collect();
    assert!(!done.is_empty() && done.len() < 400, "{} frames done", done.len());
    assert!(!report["run"]["missing_frames"].as_array().unwrap().is_empty());
    // Exactly the frames reported are on disk, whole; no temporary file is left.
    let ball_in = squish_io::read_mesh(&dir.path().join("ball.obj")).unwrap();
    for object in ["ball", "ground"] {
        let mut on_disk = Vec::new();
        for entry in std::fs::read_dir(out.join(object)).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.starts_with('.') && !name.ends_with(".tmp"), "left over: {name}");
            on_disk.push(name.trim_end_matches(".obj").parse::<i64>().unwrap());
        }
        on_disk.sort();
        assert_eq!(on_disk, done, "{object}");
    }
    for &frame in &done {
        let mesh = squish_io::read_mesh(&out.join(format!("ball/{frame:04}.obj"))).unwrap();
        assert_eq!(mesh.num_vertices(), ball_in.num_vertices());
    }
    for entry in std::fs::read_dir(&out).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "left over: {name}");
    }
}

#[test]
fn previews_show_the_objects_at_the_chosen_frames() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path(), 2);
    let scene = write_scene(dir.path(), 12, "obj");
    let out = dir.path().join("out");
    run(&scene, &out, &["--preview=1,12", "--color", "u"]);
    let mut names: Vec<String> = std::fs::read_dir(out.join("preview"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["0001.png", "0001_compare.png", "0012.png", "0012_compare.png"]);
    for (name, size) in [("0012.png", (640, 480)), ("0012_compare.png", (1284, 964))] {
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(out.join("preview").join(name)).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        assert_eq!((info.width, info.height), size, "{name}");
        let pixels = &pixels[..info.buffer_size()];
        // The objects are visible: many distinct colours, and the centre is not background.
        let distinct: std::collections::HashSet<&[u8]> = pixels.chunks(4).collect();
        assert!(distinct.len() > 500, "{name}: {} colours", distinct.len());
        let at = |x: u32, y: u32| {
            let o = 4 * (y * info.width + x) as usize;
            &pixels[o..o + 3]
        };
        let corner = at(info.width - 1, 1);
        let centre = at(info.width / 4, info.height / 4);
        assert_ne!(centre, corner, "{name}: the centre shows the background");
    }
}

/// Issue 28: `run --strict` exits 1 when a frame has a warning (here a small ball wholly inside
/// the ground slab on every frame: a containment), after writing every frame and the report;
/// the warnings are printed with their frame and kept per frame in report.json.
#[test]
fn strict_run_fails_on_warnings_after_writing_everything() {
    let dir = tempfile::tempdir().unwrap();
    let mut ball = shapes::icosphere(0.1, 2);
    ball.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&dir.path().join("ball.obj"), &ball).unwrap();
    let mut ground = shapes::cuboid(DVec3::new(4.0, 4.0, 0.5), 10);
    ground.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    squish_io::write_mesh(&dir.path().join("ground.obj"), &ground).unwrap();
    let scene = dir.path().join("scene.toml");
    let text = "frames = { start = 1, end = 3 }\n\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\n\n\
                [[objects]]\nname = \"ground\"\nmesh = \"ground.obj\"\n\n[[pairs]]\nobjects = [\"ball\", \"ground\"]\n";
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("out");
    let output = squish().arg("run").arg(&scene).arg("-o").arg(&out).arg("--strict").output().unwrap();
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("warning: frame 1: pair (\"ball\", \"ground\"): \"ball\" lies wholly inside"), "{stdout}");
    // Per frame: the containment and the penetration left (all of it).
    assert!(stderr(&output).contains("--strict: 6 warnings"), "{}", stderr(&output));
    assert!(out.join("ball/0003.obj").is_file());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let frames = report["per_frame"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[2]["stats"]["warnings"][0]["kind"], "containment");
    assert!(run(&scene, &out, &[]).status.success());
}
