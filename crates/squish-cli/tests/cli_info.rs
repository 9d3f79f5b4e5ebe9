//! `squish info` end to end: the binary reads files, reports the topology and fails cleanly.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

use squish::mesh::shapes;

fn squish() -> Command {
    Command::new(env!("CARGO_BIN_EXE_squish"))
}

fn info_json(path: &Path) -> serde_json::Value {
    let output = squish().arg("info").arg(path).arg("--json").output().expect("run squish");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("valid JSON")
}

#[test]
fn info_reports_a_procedural_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sphere.ply");
    squish_io::write_mesh(&path, &shapes::icosphere(1.0, 3)).unwrap();
    let info = info_json(&path);
    assert_eq!(info["vertices"], 642);
    assert_eq!(info["faces"], 1280);
    assert_eq!(info["components"], 1);
    assert_eq!(info["closed"], true);
    assert_eq!(info["manifold"], true);
    assert_eq!(info["self_intersecting_faces"], 0);
    let volume = info["volume"].as_f64().unwrap();
    assert!((volume - 4.0 / 3.0 * std::f64::consts::PI).abs() < 0.05, "{volume}");
}

#[test]
fn info_counts_self_intersections_of_overlapping_spheres() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.obj");
    let mut mesh = shapes::icosphere(1.0, 2);
    let mut other = shapes::icosphere(1.0, 2);
    other.map_positions(|p| p + glam::DVec3::new(1.0, 0.0, 0.0));
    mesh.append(&other);
    squish_io::write_mesh(&path, &mesh).unwrap();
    let info = info_json(&path);
    assert_eq!(info["components"], 2);
    assert!(info["self_intersecting_faces"].as_u64().unwrap() > 0);
}

#[test]
fn info_on_the_stanford_bunny() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes/bunny_3301.obj"));
    if !path.exists() {
        eprintln!("skipped: {} is not available", path.display());
        return;
    }
    let info = info_json(path);
    assert_eq!(info["vertices"], 3301);
    assert_eq!(info["faces"], 6598);
    assert_eq!(info["components"], 1);
    assert_eq!(info["closed"], true);
    assert_eq!(info["manifold"], true);
    assert_eq!(info["self_intersecting_faces"], 0);
}

#[test]
fn info_fails_cleanly_on_bad_files() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.obj");
    let output = squish().arg("info").arg(&missing).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("missing.obj"));

    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    let output = squish().arg("info").arg(&bad).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("bad.obj:4"), "{stderr}");
}

/// Issue 28: an OBJ `f` line of 100 000 corners (a disk fanned from one corner into long thin
/// faces) did not finish in 30 s; the analysis is now near-linear (criterion bench
/// `pathological`), and the answer is right: one manifold open component, no self-intersection.
#[test]
fn info_on_a_polygon_of_100_000_corners() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ngon.obj");
    let n = 100_000;
    let mut text = String::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        text.push_str(&format!("v {} {} 0\n", a.cos(), a.sin()));
    }
    text.push('f');
    for i in 1..=n {
        text.push_str(&format!(" {i}"));
    }
    text.push('\n');
    std::fs::write(&path, text).unwrap();
    let info = info_json(&path);
    assert_eq!(info["faces"], n - 2);
    assert_eq!(info["components"], 1);
    assert_eq!(info["manifold"], true);
    assert_eq!(info["boundary_loops"], 1);
    assert_eq!(info["self_intersecting_faces"], 0);
}
