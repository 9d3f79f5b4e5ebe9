//! `squish demo --quick` end to end: it finishes, writes the meshes, reports and pictures of
//! every scene, and its volumes are preserved to round-off.

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

use std::process::Command;

#[test]
fn the_quick_demo_writes_every_scene_and_preserves_volumes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let output = Command::new(env!("CARGO_BIN_EXE_squish")).args(["demo", "--quick", "-o"]).arg(&out).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let stdout = String::from_utf8_lossy(&output.stdout);

    // The printed summary: one volume error per scene, each at round-off level.
    let volumes: Vec<f64> = stdout
        .split("volume error ")
        .skip(1)
        .map(|rest| rest.split_whitespace().next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(volumes.len(), 5, "{stdout}");
    assert!(volumes.iter().all(|v| *v <= 1e-9), "{stdout}");

    for file in ["summary.json", "overview.png"] {
        assert!(out.join(file).is_file(), "{file}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let scenes = summary["scenes"].as_array().unwrap();
    let names: Vec<&str> = scenes.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["press", "squeeze", "two-balls", "elbow", "capsules"]);
    for scene in scenes {
        let name = scene["name"].as_str().unwrap();
        let dir = out.join(name);
        for file in
            ["report.json", "quality.svg", "quality.png", "strip.png", "preview/0001.png", "preview/0001_compare.png"]
        {
            assert!(dir.join(file).is_file(), "{name}/{file}");
        }
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
        let frames = report["per_frame"].as_array().unwrap();
        assert_eq!(frames.len() as u64, scene["frames"].as_u64().unwrap());
        let mut deformed = 0;
        for frame in frames {
            let f = frame["frame"].as_i64().unwrap();
            for object in frame["objects"].as_array().unwrap() {
                let object_name = object["name"].as_str().unwrap();
                assert!(dir.join(object_name).join(format!("{f:04}.obj")).is_file(), "{name}: {object_name} {f}");
                if object["deformed"] == true {
                    deformed += 1;
                    let change = object["relative_volume_change"].as_f64().unwrap();
                    assert!(change.abs() <= 1e-9, "{name} frame {f} {object_name}: {change}");
                }
            }
        }
        assert!(deformed > 0, "{name}: nothing was deformed");
        assert!(report["summary"]["max_volume_change"]["value"].as_f64().unwrap() <= 1e-9);
        if name == "elbow" {
            // The arm's skin passes through itself at the deepest bends; none of it remains.
            let elbow = &report["summary"]["articulations"][0];
            assert!(elbow["self_intersecting_faces_before"].as_u64().unwrap() > 0, "{elbow}");
            assert_eq!(elbow["self_intersecting_faces_after"], 0, "{elbow}");
            continue;
        }
        // Contacts are clean: what penetrated is (mostly) gone.
        assert!(report["summary"]["max_penetration_ratio"]["value"].as_f64().unwrap() < 0.25, "{name}");
    }
    // The press goes through first contact: its first frame has a gap.
    let press: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("press/report.json")).unwrap()).unwrap();
    assert_eq!(press["per_frame"][0]["pairs"][0]["in_contact"], false);
    assert_eq!(press["scene"]["objects"].as_array().unwrap().len(), 2);
}
