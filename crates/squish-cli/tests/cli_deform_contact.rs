//! `squish deform` and `squish contact` end to end on procedural meshes written to files.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

use glam::DVec3;
use squish::mesh::shapes;

fn squish() -> Command {
    Command::new(env!("CARGO_BIN_EXE_squish"))
}

/// Two unit icospheres overlapping by 0.4 along z, as OBJ and PLY files.
fn write_inputs(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let lower = shapes::icosphere(1.0, 3);
    let mut upper = shapes::icosphere(1.0, 3);
    upper.map_positions(|p| p + DVec3::new(0.0, 0.0, 1.6));
    let (a, b) = (dir.join("upper.obj"), dir.join("lower.ply"));
    squish_io::write_mesh(&a, &upper).unwrap();
    squish_io::write_mesh(&b, &lower).unwrap();
    (a, b)
}

#[test]
fn deform_writes_both_meshes_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_inputs(dir.path());
    let out = dir.path().join("out");
    let output = squish()
        .args(["deform"])
        .arg(&a)
        .arg(&b)
        .arg("-o")
        .arg(&out)
        .args(["--set", "a.bulge=1", "--set", "pair.contact_tau=0"])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let upper_in = squish_io::read_mesh(&a).unwrap();
    let upper_out = squish_io::read_mesh(&out.join("upper.obj")).unwrap();
    let lower_out = squish_io::read_mesh(&out.join("lower.ply")).unwrap();
    assert_eq!(upper_out.triangles, upper_in.triangles);
    assert_eq!(lower_out.num_vertices(), 642);
    // The top of the upper sphere is far from the contact: untouched, bit for bit.
    let top = upper_in.positions.iter().position(|p| p.z > 2.59).unwrap();
    assert_eq!(upper_out.positions[top], upper_in.positions[top]);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for object in report["frame"]["objects"].as_array().unwrap() {
        assert!(object["deformed"].as_bool().unwrap());
        assert!(object["relative_volume_change"].as_f64().unwrap().abs() < 1e-9);
    }
    let (before, after) =
        (report["penetration_before"].as_f64().unwrap(), report["penetration_after"].as_f64().unwrap());
    assert!(before > 0.3 && after < 0.02 * before, "{before} → {after}");
}

#[test]
fn deform_rejects_unknown_parameters_and_missing_files() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_inputs(dir.path());
    let output = squish().arg("deform").arg(&a).arg(&b).args(["--set", "a.stifness=2"]).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("a.stiffness"));
    let output = squish().arg("deform").arg(&a).arg(dir.path().join("nope.obj")).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("nope.obj"));
}

#[test]
fn contact_exports_labels_points_and_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_inputs(dir.path());
    let out = dir.path().join("contact");
    let output = squish().arg("contact").arg(&a).arg(&b).arg("-o").arg(&out).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("contact.json")).unwrap()).unwrap();
    let d = summary["mapping_direction"].as_array().unwrap();
    assert!((d[2].as_f64().unwrap() - 1.0).abs() < 1e-9, "d̂ is +z for mirror-symmetric spheres");
    assert!(summary["contact_area_on_surface"].as_f64().unwrap() > 0.1);
    assert!(!summary["intersection_points"].as_array().unwrap().is_empty());
    let upper = squish_io::read_ply_data(&out.join("upper.ply")).unwrap();
    let labels = upper.property("label").unwrap();
    let contact = labels.values.iter().filter(|&&l| l == 3.0).count();
    assert_eq!(contact as u64, summary["sides"][0]["contact_vertices"].as_u64().unwrap());
    assert!(upper.colors().is_some());
    let points = squish_io::read_ply_data(&out.join("boundary_points.ply")).unwrap();
    assert!(points.triangles.is_empty() && !points.positions.is_empty());
    // Intersection boundary points lie on both spheres: |p| ≈ 1 and |p − (0,0,1.6)| ≈ 1.
    let kinds = points.property("kind").unwrap();
    for (p, &k) in points.positions.iter().zip(&kinds.values) {
        if k == 1.0 {
            assert!((p.length() - 1.0).abs() < 0.02 && ((*p - DVec3::new(0.0, 0.0, 1.6)).length() - 1.0).abs() < 0.02);
        }
    }
}

/// Issue 28: with `--strict`, a frame that leaves a treatment undone exits 1 after writing its
/// outputs and says why on the console and in report.json; without it, the same run exits 0.
/// Here τ = 2 (ε_c clamped to the typical penetration) and a ball wholly inside another
/// (containment, penetration left).
#[test]
fn strict_fails_on_warnings_and_reports_them() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_inputs(dir.path());
    let out = dir.path().join("tau");
    let run = |extra: &[&str], a: &Path, b: &Path, out: &Path| {
        squish().arg("deform").arg(a).arg(b).arg("-o").arg(out).args(extra).output().unwrap()
    };
    let output = run(&["--set", "pair.contact_tau=3", "--strict"], &a, &b, &out);
    assert_eq!(output.status.code(), Some(1), "{}", String::from_utf8_lossy(&output.stderr));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("warning: pair (\"upper\", \"lower\"): pair.contact_tau = 3"), "{stdout}");
    assert!(String::from_utf8_lossy(&output.stderr).contains("--strict: 1 warning"));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["frame"]["warnings"][0]["kind"], "contact_spread_clamped");
    assert!(out.join("upper.obj").is_file() && out.join("lower.ply").is_file());
    assert!(run(&["--set", "pair.contact_tau=3"], &a, &b, &out).status.success());

    let inner = dir.path().join("inner.obj");
    let mut small = shapes::icosphere(0.3, 2);
    small.map_positions(|p| p + DVec3::new(0.0, 0.0, 0.1));
    squish_io::write_mesh(&inner, &small).unwrap();
    let output = run(&["--strict"], &inner, &b, &dir.path().join("inside"));
    assert_eq!(output.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("\"inner\" lies wholly inside \"lower\"") && stdout.contains("still penetrates"),
        "{stdout}"
    );
    let output = squish()
        .arg("contact")
        .arg(&inner)
        .arg(&b)
        .arg("-o")
        .arg(dir.path().join("c"))
        .arg("--strict")
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(1));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("c/contact.json")).unwrap()).unwrap();
    assert_eq!(summary["warnings"][0]["kind"], "containment");
}

/// Issue 28: an input name that is not UTF-8 became U+FFFD in the output's name; its bytes are
/// now kept.
#[cfg(unix)]
#[test]
fn output_names_keep_the_input_name_bytes() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_inputs(dir.path());
    let odd = dir.path().join(OsStr::from_bytes(b"caf\xe9.obj"));
    std::fs::copy(&a, &odd).unwrap();
    let out = dir.path().join("out");
    let output = squish().arg("deform").arg(&odd).arg(&b).arg("-o").arg(&out).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(out.join(OsStr::from_bytes(b"caf\xe9.obj")).is_file());
    assert!(!out.join("caf\u{FFFD}.obj").exists());
}
