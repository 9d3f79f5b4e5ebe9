//! `squish run` with `[[objects.self_contact]]`: a procedural skinned cylinder that bends at its
//! elbow (written by the test as a .glb), and, when `../shared/data` is present, the glTF sample
//! RiggedCylinder4. The run must succeed and `report.json` must carry the articulations' figures
//! per frame and over the shot.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

// The glTF fixtures and the shared-data lookup of squish-io's integration tests.
#[path = "../../squish-io/tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn squish() -> Command {
    Command::new(env!("CARGO_BIN_EXE_squish"))
}

/// A cylinder of 61 rings of 24 vertices ([`common::bending_cylinder`]) whose weights blend the
/// root and the elbow over −0.3 < x < 0.3, written as `dir/arm.glb`, and a 25-frame scene of it,
/// `dir/arm.toml`, whose object ends with the lines `self_contact`.
/// Returns the scene's path.
fn write_bending_cylinder(dir: &Path, self_contact: &str) -> PathBuf {
    common::bending_cylinder(61, 24, |x| {
        let w = ((x + 0.3) / 0.6).clamp(0.0, 1.0);
        ([0.0, 1.0], [1.0 - w, w])
    })
    .write_glb(dir, "arm");
    let scene = dir.join("arm.toml");
    let text = format!(
        "frames = {{ start = 1, end = 25, fps = 24 }}\n\n[[objects]]\nname = \"arm\"\nmesh = \"arm.glb\"\n{self_contact}"
    );
    std::fs::write(&scene, text).unwrap();
    scene
}

fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let output = squish().arg("run").arg(scene).arg("-o").arg(out).args(extra).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    output
}

/// The articulation figures of every frame of a report, checked for shape.
fn articulations(report: &Value, name: &str, object: &str) -> Vec<Value> {
    let frames = report["per_frame"].as_array().unwrap();
    assert!(!frames.is_empty());
    frames
        .iter()
        .map(|f| {
            let list = f["articulations"].as_array().unwrap_or_else(|| panic!("no articulations in {f}"));
            let a = list.iter().find(|a| a["name"] == name).unwrap_or_else(|| panic!("no articulation {name} in {f}"));
            assert_eq!(a["object"], object);
            for key in [
                "in_contact",
                "self_intersecting_faces_before",
                "self_intersecting_faces_after",
                "contact_area",
                "bulge_height",
                "volume_exact",
                "time_ms",
            ] {
                assert!(!a[key].is_null(), "{key} in {a}");
            }
            a.clone()
        })
        .collect()
}

/// `--dry-run` says what a scene with self-contact and no pair will compute, rather than that
/// its objects are copied unchanged.
#[test]
fn a_dry_run_lists_the_self_contact_it_will_compute() {
    let dir = tempfile::tempdir().unwrap();
    let dry_run = |scene: &Path| {
        let output = squish().arg("run").arg(scene).arg("--dry-run").output().unwrap();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        String::from_utf8_lossy(&output.stdout).into_owned()
    };
    let scene = write_bending_cylinder(
        dir.path(),
        "\n[[objects.self_contact]]\nname = \"elbow\"\njoints = [\"root\", \"elbow\"]\n",
    );
    let text = dry_run(&scene);
    assert!(text.contains("self-contact \"elbow\"") && text.contains("the self-contact of arm"), "{text}");
    assert!(!text.contains("copied unchanged"), "{text}");
    let still = write_bending_cylinder(dir.path(), "");
    assert!(dry_run(&still).contains("none (the objects are copied unchanged)"));
}

#[test]
fn a_bending_skinned_cylinder_runs_with_self_contact() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_bending_cylinder(
        dir.path(),
        "\n[[objects.self_contact]]\nname = \"elbow\"\njoints = [\"root\", \"elbow\"]\n",
    );
    let out = dir.path().join("out");
    let output = run(&scene, &out, &["--frames", "19:25"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("arm/elbow: self-intersecting faces"), "{stdout}");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let figures = articulations(&report, "elbow", "arm");
    // Bent by 150° at the last frame, the skin passes through itself: the input has
    // self-intersections, and the sides are in contact.
    let last = figures.last().unwrap();
    assert!(last["self_intersecting_faces_before"].as_u64().unwrap() > 0, "{last}");
    assert_eq!(last["in_contact"], true, "{last}");
    let summary = &report["summary"]["articulations"][0];
    assert_eq!(summary["name"], "elbow");
    assert_eq!(summary["frames"], 7);
    let before: u64 = figures.iter().map(|a| a["self_intersecting_faces_before"].as_u64().unwrap()).sum();
    let after: u64 = figures.iter().map(|a| a["self_intersecting_faces_after"].as_u64().unwrap()).sum();
    assert_eq!(summary["self_intersecting_faces_before"], before);
    assert_eq!(summary["self_intersecting_faces_after"], after);
    eprintln!("bending cylinder, frames 19–25: self-intersecting faces {before} → {after}");
    assert!(before > 0);
    assert_eq!(after, 0, "the self-contact removes every self-intersection: {before} → {after}");
    for frame in report["per_frame"].as_array().unwrap() {
        let dv = frame["objects"][0]["relative_volume_change"].as_f64().unwrap();
        assert!(dv.abs() < 1e-6, "the volume is preserved: {dv} at frame {}", frame["frame"]);
    }
    // The per-object figures still work, and the output keeps the file's vertex count.
    assert_eq!(report["per_frame"][0]["objects"][0]["name"], "arm");
    assert!(out.join("arm/0025.obj").is_file());
}

#[test]
fn rigged_cylinder_from_the_shared_data_runs_with_self_contact() {
    let Some(glb) = common::shared_data("rigged/RiggedCylinder4.glb") else { return };
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("cylinder.toml");
    std::fs::write(
        &scene,
        format!(
            r#"frames = {{ start = 1, end = 160, fps = 24 }}

[[objects]]
name = "cylinder"
mesh = "{}"

[[objects.self_contact]]
name = "middle"
joints = ["Root.001", "Root.002"]
"#,
            glb.display().to_string().replace('\\', "/")
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = run(&scene, &out, &[]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("cylinder/middle: self-intersecting faces"), "{stdout}");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["run"]["status"], "complete");
    let figures = articulations(&report, "middle", "cylinder");
    assert_eq!(figures.len(), 160);
    let summary = &report["summary"]["articulations"][0];
    assert_eq!(summary["frames"], 160);
    // The file's own animation bends the cylinder gently: its skin never passes through itself,
    // and the self-contact then leaves every frame as the skinning gave it.
    assert_eq!(summary["self_intersecting_faces_before"], 0, "{summary}");
    assert_eq!(summary["self_intersecting_faces_after"], 0, "{summary}");
    for frame in report["per_frame"].as_array().unwrap() {
        let object = &frame["objects"][0];
        assert_eq!(object["relative_volume_change"].as_f64().unwrap(), 0.0, "{object}");
        assert_eq!(object["output_step"], object["input_step"], "{object}");
    }
}

/// The glTF sample CesiumMan walking (examples/cesium_man_articulations.toml: knees, hips and
/// elbows). Measured
/// with this test: the skin of each knee passes through itself on 9 and 8 frames of the walk
/// (149 and 129 self-intersecting faces over the shot) and none remain; the elbows never fold
/// enough to touch. The hips' counts take the faces of the pelvis and of the whole leg, knees
/// included: what remains there (≤ 5 faces on frames 35–39) is inside the pelvis region, between
/// faces of the hip's first region only; across the hips' creases the walk never intersects
/// (0 → 0), and across every configured joint nothing remains.
#[test]
fn cesium_man_walks_with_self_contact_at_its_knees_hips_and_elbows() {
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/cesium_man_articulations.toml");
    if common::shared_data("rigged/CesiumMan.glb").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    run(&scene, &out, &[]);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["run"]["status"], "complete");
    assert_eq!(report["summary"]["frames_computed"], 48);
    assert!(report["summary"]["max_volume_change"]["value"].as_f64().unwrap() < 1e-12, "{}", report["summary"]);
    assert!(report["summary"]["max_step_ratio"]["value"].as_f64().unwrap() <= 5.0, "{}", report["summary"]);
    for knee in ["left knee", "right knee"] {
        let figures = articulations(&report, knee, "cesium_man");
        let before: u64 = figures.iter().map(|a| a["self_intersecting_faces_before"].as_u64().unwrap()).sum();
        assert!(before > 100, "{knee}: the walk folds the knee ({before} faces)");
        for a in &figures {
            assert_eq!(a["self_intersecting_faces_after"], 0, "{knee}: {a}");
        }
    }
    for elbow in ["left elbow", "right elbow"] {
        for a in &articulations(&report, elbow, "cesium_man") {
            assert_eq!(a["self_intersecting_faces_after"], 0, "{elbow}: {a}");
        }
    }
    for hip in ["left hip", "right hip"] {
        for a in &articulations(&report, hip, "cesium_man") {
            assert!(a["self_intersecting_faces_after"].as_u64().unwrap() <= 5, "{hip}: {a}");
        }
    }
    // Across every configured joint (pairs joining its two sides), nothing remains.
    for summary in report["summary"]["articulations"].as_array().unwrap() {
        assert_eq!(summary["self_intersecting_faces_across_after"], 0, "{summary}");
    }
    for knee in ["left knee", "right knee"] {
        let summary =
            report["summary"]["articulations"].as_array().unwrap().iter().find(|a| a["name"] == knee).unwrap();
        assert_eq!(summary["self_intersecting_faces_across_before"], summary["self_intersecting_faces_before"]);
    }
}

/// Runs an example with `self_contact = "auto"` and checks what issue 27 asks of a skinned
/// character's shot: the volume kept (≤ 1e-9), the largest step of the output no more than 3×
/// the input's, no frame with more self-intersecting faces (beyond the rest pose's) than plain
/// skinning, and at least 95% of them removed over the shot. Returns the report.
fn check_automatic_self_contact(example: &str) -> Value {
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples").join(example);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    run(&scene, &out, &[]);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["run"]["status"], "complete");
    assert!(report["summary"]["max_volume_change"]["value"].as_f64().unwrap() <= 1e-9, "{}", report["summary"]);
    let frames = report["per_frame"].as_array().unwrap();
    let largest = |key: &str| {
        frames.iter().flat_map(|f| f["objects"].as_array().unwrap()).filter_map(|o| o[key].as_f64()).fold(0.0, f64::max)
    };
    assert!(largest("output_step") <= 3.0 * largest("input_step"));
    let (mut input, mut output) = (0, 0);
    for f in frames {
        let counts = &f["self_intersecting_faces"][0][1];
        let (before, after) = (counts[0].as_u64().unwrap(), counts[1].as_u64().unwrap());
        assert!(after <= before, "frame {}: {before} → {after}", f["frame"]);
        input += before;
        output += after;
    }
    assert!(input > 0 && 20 * output <= input, "{example}: {input} → {output}, less than 95% removed");
    report
}

/// examples/cesium_man.toml: `self_contact = "auto"` on CesiumMan's walk (issue 27). Besides
/// [`check_automatic_self_contact`], the articulations of the skeleton resolve the knees as the
/// explicit ones do. (Figures: docs/self-contact.md.)
#[test]
fn cesium_man_walks_with_automatic_self_contact() {
    if common::shared_data("rigged/CesiumMan.glb").is_none() {
        return;
    }
    let report = check_automatic_self_contact("cesium_man.toml");
    for knee in ["leg_joint_L_1 / leg_joint_L_2", "leg_joint_R_1 / leg_joint_R_2"] {
        for a in &articulations(&report, knee, "cesium_man") {
            assert_eq!(a["self_intersecting_faces_after"], 0, "{knee}: {a}");
        }
    }
    // Every frame traced through the plan (issue 35): one self-contact job per articulation and
    // per touching part pair, each with the stages it ran, none taking more of a stage than the
    // frame spent on it.
    for f in report["per_frame"].as_array().unwrap() {
        let stats = &f["stats"];
        let jobs = stats["jobs"].as_array().unwrap();
        let of_kind = |kind: &str| jobs.iter().filter(|j| j["kind"] == kind && j["level"] == "self_contact").count();
        assert_eq!(of_kind("articulation"), f["articulations"].as_array().unwrap().len(), "frame {}", f["frame"]);
        assert_eq!(of_kind("parts"), f["part_pairs"].as_array().unwrap().len(), "frame {}", f["frame"]);
        let frame_stages = stats["stages_ms"].as_object().unwrap();
        let mut summed: std::collections::BTreeMap<&str, f64> = Default::default();
        for job in jobs {
            for (stage, ms) in job["stages_ms"].as_object().unwrap() {
                *summed.entry(stage.as_str()).or_default() += ms.as_f64().unwrap();
            }
        }
        for (stage, ms) in summed {
            let total = frame_stages[stage].as_f64().unwrap();
            assert!(
                ms <= total * (1.0 + 1e-9) + 1e-6,
                "frame {}: jobs spent {ms} ms on {stage}, the frame {total}",
                f["frame"]
            );
        }
    }
}

/// examples/fox_walk.toml and fox_run.toml: the Fox's coarse skin (576 faces) walking and
/// running, with [`check_automatic_self_contact`].
#[test]
fn the_fox_walks_and_runs_with_automatic_self_contact() {
    if common::shared_data("rigged/Fox.glb").is_none() {
        return;
    }
    for example in ["fox_walk.toml", "fox_run.toml"] {
        check_automatic_self_contact(example);
    }
}

/// examples/rigged_cylinder.toml: the sample's clip turned 1.8 times as far (`amplitude`) folds
/// its joints into contact. Frames 106–130 fold the last joint on its own: the input's skin
/// passes through itself and the automatic self-contact leaves no face through another; over the
/// whole example the output never has more such faces than the input, and far fewer in total.
#[test]
fn the_rigged_cylinder_example_folds_into_contact_and_is_resolved() {
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/rigged_cylinder.toml");
    if common::shared_data("rigged/RiggedCylinder4.glb").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let counts = |out: &Path| {
        let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
        assert_eq!(report["run"]["status"], "complete");
        assert!(report["summary"]["max_volume_change"]["value"].as_f64().unwrap() <= 1e-9, "{}", report["summary"]);
        let frames = report["per_frame"].as_array().unwrap().clone();
        frames
            .iter()
            .map(|f| {
                let c = &f["self_intersecting_faces"][0][1];
                (c[0].as_u64().unwrap(), c[1].as_u64().unwrap())
            })
            .collect::<Vec<_>>()
    };
    let fold = dir.path().join("fold");
    run(&scene, &fold, &["--frames", "106:130"]);
    let fold = counts(&fold);
    assert_eq!(fold.len(), 25);
    assert!(fold.iter().filter(|(before, _)| *before > 0).count() >= 20, "{fold:?}");
    assert!(fold.iter().all(|&(_, after)| after == 0), "{fold:?}");

    let whole = dir.path().join("whole");
    run(&scene, &whole, &[]);
    let whole = counts(&whole);
    assert_eq!(whole.len(), 100);
    assert!(whole.iter().all(|(before, after)| after <= before), "{whole:?}");
    let (input, output) = whole.iter().fold((0, 0), |(i, o), (b, a)| (i + b, o + a));
    assert!(input > 1000 && output * 20 <= input, "{input} → {output}");

    // Frame 101 (two joints folded at once): the preview draws the input's faces through each
    // other in red, and the output's (none left) not at all.
    let left = dir.path().join("left");
    run(&scene, &left, &["--frames", "101:101", "--preview=101"]);
    let counts = counts(&left);
    assert!(counts[0].0 > 0 && counts[0].1 == 0, "{counts:?}");
    let (pixels, width) = read_png(&left.join("preview/0101_compare.png"));
    let input_red = red_pixels(&pixels, width, (0, 640), (0, 430));
    let output_red = red_pixels(&pixels, width, (644, 1284), (0, 430));
    assert!(input_red > 100 && output_red < input_red / 10, "red pixels: input {input_red}, output {output_red}");
}

/// The pixels of a PNG (RGBA rows) and its width.
fn read_png(path: &Path) -> (Vec<u8>, u32) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba, "{}", path.display());
    pixels.truncate(info.buffer_size());
    (pixels, info.width)
}

/// Red pixels (the intersection label, shaded) in the columns `x0..x1` and rows `y0..y1`.
fn red_pixels(pixels: &[u8], width: u32, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> usize {
    (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| 4 * (y * width + x) as usize))
        .filter(|&o| {
            let [r, g, b] = [pixels[o], pixels[o + 1], pixels[o + 2]].map(u32::from);
            r >= 90 && r > 2 * g && r > 2 * b
        })
        .count()
}

/// `--preview` of a skinned object with self-contact draws the input's self-intersecting faces
/// in red and, when the output has none left, no red on the output: the bending cylinder with `self_contact = "auto"`, straight at
/// frame 1 (no overlap: the input picture's only red is its legend swatch) and folded by 150° at
/// frame 25 (the inside of the elbow passes through itself, resolved in the output).
#[test]
fn previews_draw_the_input_self_intersections_in_red() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_bending_cylinder(dir.path(), "self_contact = \"auto\"\n");
    let out = dir.path().join("out");
    run(&scene, &out, &["--frames", "1:25", "--preview=1,25"]);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let counts = |frame: usize| report["per_frame"][frame - 1]["self_intersecting_faces"][0][1].clone();
    assert_eq!(counts(1), serde_json::json!([0, 0]));
    let folded = counts(25);
    assert!(folded[0].as_u64().unwrap() > 0 && folded[1] == 0, "{folded}");
    // The compare picture: input | output above, their sections below (640 × 480 each, 4 apart).
    let (straight, width) = read_png(&out.join("preview/0001_compare.png"));
    let (bent, _) = read_png(&out.join("preview/0025_compare.png"));
    let (input, output) = ((0, 640), (644, 1284));
    let legend_only = red_pixels(&straight, width, input, (0, 480));
    let marked = red_pixels(&bent, width, input, (0, 480));
    assert!(marked > legend_only + 200, "red pixels of the folded input {marked}, of the straight one {legend_only}");
    assert_eq!(red_pixels(&straight, width, output, (0, 480)), 0);
    assert_eq!(red_pixels(&bent, width, output, (0, 480)), 0, "the output shows no overlap");
    assert_eq!(red_pixels(&bent, width, output, (484, 964)), 0, "nor does its section");
}
